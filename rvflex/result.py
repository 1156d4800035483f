"""``Result``: the one shape every scenario run returns (:func:`rvflex.run`).

A result holds the ``scenario`` it ran, its ``metrics`` (a frozen dataclass whose field names
carry their unit, e.g. ``te_pp_arcsec``) and the labelled data: :meth:`Result.to_xarray` (an
``xarray.Dataset`` with named dimensions, SI coordinates, ``units`` and ``long_name`` on every
variable, the scenario and spec in ``attrs``), :meth:`Result.to_dataframe` (tidy pandas),
:meth:`Result.plot` (on a given ``Axes`` or a new :class:`matplotlib.figure.Figure`; pyplot's
global state and the backend are never touched) and :meth:`Result.write` (the CSV/PNG files of
the CLI plus ``<name>.nc``, the Dataset as netCDF-4 through h5netcdf).

Each scenario module subclasses :class:`Result` with its data and drawing; this module holds
what they share.
"""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rvflex.spec import SpecError, dumps_errors, dumps_spec

__all__ = ["Result", "new_axes", "new_figure", "scenario_attrs", "spatial_variables", "variable"]

UNIT_SUFFIX = {"rad": "rad", "arcsec": "arcsec", "arcmin": "arcmin", "N m": "Nm", "N": "N", "m": "m", "1": "",
               "N m/arcmin": "Nm_per_arcmin", "deg": "deg"}
"""Column-name suffix of each ``units`` attribute in :meth:`Result.to_dataframe`."""


def variable(dims, values, units: str, long_name: str) -> tuple:
    """An ``xarray`` variable tuple ``(dims, values, attrs)`` with ``units`` and ``long_name``."""
    return (dims, np.asarray(values), {"units": units, "long_name": long_name})


def spatial_variables(raw, dim: str, suffix: str = "") -> tuple[dict, dict]:
    """The spatial model's out-of-plane records of a solver result ``raw`` as xarray variables over ``dim``.

    Parameters
    ----------
    raw : rvflex.solve.QuasiStaticResult or rvflex.solve.TorqueStepResult
        With ``carrier_tilt_rad``, ``carrier_shift_m``, ``disc_tilt_rad``, ``crank_tilt_rad`` (None for the planar
        model).
    dim : str
        The steps' dimension.
    suffix : str, optional
        Appended to the variables' names (``"_forward"``).

    Returns
    -------
    data, coords : dict
        ``carrier_tilt`` (dim × tilt_axis, rad), ``carrier_shift`` (dim × axis, m), ``disc_tilt``
        (dim × disc × tilt_axis, rad) and ``crank_tilt`` (dim × crank, rad), and their axis coordinates; both empty
        for the planar model.
    """
    if getattr(raw, "carrier_tilt_rad", None) is None:
        return {}, {}
    nd, nk = raw.disc_tilt_rad.shape[1], raw.crank_tilt_rad.shape[1]
    coords = {"tilt_axis": variable(("tilt_axis",), np.array(["x", "y"]), "1", "tilt about the housing's axis"),
              "axis": variable(("axis",), np.array(["x", "y", "z"]), "1", "housing axis (z: the reducer's)"),
              "disc": variable(("disc",), np.arange(1, nd + 1), "1", "cycloid disc number"),
              "crank": variable(("crank",), np.arange(1, nk + 1), "1", "crank number")}
    data = {f"carrier_tilt{suffix}": variable((dim, "tilt_axis"), raw.carrier_tilt_rad, "rad",
                                              "carrier tilt (ψx, ψy) on the main bearing pair, solved"),
            f"carrier_shift{suffix}": variable((dim, "axis"), raw.carrier_shift_m, "m",
                                               "carrier displacement at the main bearing pair's centre, solved"),
            f"disc_tilt{suffix}": variable((dim, "disc", "tilt_axis"), raw.disc_tilt_rad, "rad",
                                           "cycloid disc tilt (ψx, ψy), solved"),
            f"crank_tilt{suffix}": variable((dim, "crank"), raw.crank_tilt_rad, "rad",
                                            "crank tilt: slope of the chord between its support bearings, solved")}
    return data, coords


def scenario_attrs(scenario, **extra) -> dict:
    """Dataset attributes recording ``scenario``: its settings as JSON, the spec's name and TOML,
    the errors' TOML and the model options; netCDF-safe (strings and numbers only)."""
    settings = {}
    for f in dataclasses.fields(scenario):
        value = getattr(scenario, f.name)
        if f.name in ("spec", "errors"):
            continue
        if f.name == "options":
            value = value.as_dict()
        elif dataclasses.is_dataclass(value):
            value = dataclasses.asdict(value)
        settings[f.name] = value
    attrs = {"scenario": type(scenario).__name__,
             "scenario_settings": json.dumps(settings, default=_json_default),
             "reducer": scenario.spec.name,
             "spec_toml": dumps_spec(scenario.spec),
             "errors_toml": dumps_errors(scenario.errors),
             "Conventions": "CF-1.8",
             "source": "rvflex"}
    attrs.update(extra)
    return attrs


def _json_default(value):
    if isinstance(value, (np.integer, np.floating)):
        return value.item()
    if isinstance(value, tuple):
        return list(value)
    return str(value)


def new_figure(**kw):
    """A :class:`matplotlib.figure.Figure` not registered with pyplot (no backend switch, no
    global current figure)."""
    from matplotlib.figure import Figure

    return Figure(**kw)


def new_axes(ax=None, **figure_kw):
    """``ax``, or the axes of a new :func:`new_figure`."""
    if ax is not None:
        return ax
    return new_figure(**({"figsize": (8, 4.5), "layout": "constrained"} | figure_kw)).subplots()


@dataclass(frozen=True, eq=False)
class Result:
    """What a scenario run returns (built by the scenario's ``run``, not by hand).

    Parameters
    ----------
    scenario : object
        The scenario that ran.
    metrics : object
        Its scalar results.
    wall_s : float
        Wall time of the run (s).

    Attributes
    ----------
    scenario
        The scenario that ran (a frozen dataclass: spec, errors, options and settings).
    metrics
        A frozen dataclass of scalar results, unit in each field name.
    wall_s : float
        Wall time of the run (s): model build (unless a model was passed), FE reduction on a cold
        cache, solve.
    """

    scenario: Any
    metrics: Any
    wall_s: float

    name = "result"  # file stem of the netCDF file
    main_dim = "position"  # the dimension of :meth:`to_dataframe`'s rows

    def metrics_dict(self) -> dict:
        """The metrics as a plain dict (JSON-ready).

        Returns
        -------
        dict
            Field name (unit in the name, e.g. ``te_pp_arcsec``) to value.
        """
        return dataclasses.asdict(self.metrics)

    def to_xarray(self):
        """The labelled data as an ``xarray.Dataset`` (subclasses)."""
        raise NotImplementedError

    def to_dataframe(self):
        """The labelled data as a tidy table.

        Returns
        -------
        pandas.DataFrame
            One row per element of :attr:`main_dim`, one column per variable (and coordinate)
            along it, the unit in the column name (``te_arcsec``).
        """
        ds = self.to_xarray()
        names = [n for n, v in {**ds.coords, **ds.data_vars}.items() if v.dims == (self.main_dim,)]
        df = ds[[n for n in names if n in ds.data_vars]].to_dataframe().reset_index()
        df = df[[n for n in names if n in df.columns]]
        return df.rename(columns={n: _column(n, ds[n].attrs.get("units", "")) for n in names})

    def plot(self, ax=None):
        """Draw the main curve (subclasses).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on; None draws on a new :class:`matplotlib.figure.Figure` (pyplot and the
            backend are not touched).

        Returns
        -------
        matplotlib.axes.Axes
            The axes drawn on.
        """
        raise NotImplementedError

    def files(self, out: Path) -> list[Path]:
        """Write the CLI's CSV/PNG files (subclasses).

        Parameters
        ----------
        out : pathlib.Path
            An existing directory.

        Returns
        -------
        list of pathlib.Path
            The files written.
        """
        raise NotImplementedError

    def write(self, out: str | os.PathLike) -> list[Path]:
        """Write the CLI's files and ``<name>.nc`` (the Dataset, netCDF-4 via h5netcdf).

        Everything is written into a temporary directory first and moved in at the end, so a
        failure leaves nothing half-written.

        Parameters
        ----------
        out : str or os.PathLike
            The directory (created if missing).

        Returns
        -------
        list of pathlib.Path
            The files written, in ``out``.

        Raises
        ------
        SpecError
            ``out`` exists and is not a directory.
        """
        out = Path(out)
        if out.exists() and not out.is_dir():
            raise SpecError("out", str(out), "is a file, not a directory: results are written as several files")
        out.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(dir=out, prefix=".rvflex-write-"))
        try:
            paths = self.files(tmp)
            nc = tmp / f"{self.name}.nc"
            self.to_xarray().to_netcdf(nc, engine="h5netcdf")
            paths.append(nc)
            final = []
            for p in paths:
                os.chmod(p, 0o644)
                os.replace(p, out / p.name)
                final.append(out / p.name)
            return final
        finally:
            shutil.rmtree(tmp, ignore_errors=True)


def _column(name: str, units: str) -> str:
    suffix = UNIT_SUFFIX.get(units, units.replace(" ", "").replace("/", "_per_"))
    return f"{name}_{suffix}" if suffix and not name.endswith(suffix) else name


"""Reversal backlash (seed 002): the output angle lost when the input reverses.

Quasi-static: the input turns forward over a window and back over the same window with an
output load that resists the motion (so it changes sign at the reversal, as a friction or
process load does); the reversal backlash is the mean distance between the forward and the
reverse output branches at equal input angle. With a small load (default 3 % of rated, the
catalogue's lost-motion level) it is the free play plus the small elastic turn at that load.

    python -m rvflex.scenarios.reversal_backlash out/
"""

from __future__ import annotations

import dataclasses as dc
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rvflex.geometry.formulas import ARCMIN_PER_RAD
from rvflex.model import ReducerModel
from rvflex.options import ModelOptions
from rvflex.result import Result, new_axes, scenario_attrs, spatial_variables, variable
from rvflex.scenarios.common import OutputLoaded, check_model, check_scenario_inputs
from rvflex.solve import QuasiStaticResult, quasi_static
from rvflex.spec import ErrorSpec, ReducerSpec, SpecError
from rvflex.tilt import OutputLoad

__all__ = ["BacklashMetrics", "ReversalBacklash", "ReversalBacklashResult", "run_reversal_backlash",
           "write_backlash_outputs", "DEFAULT_LOAD_FRACTION"]

DEFAULT_LOAD_FRACTION = 0.03


@dataclass(frozen=True)
class ReversalBacklash(OutputLoaded):
    """Reversal backlash (``rvflex backlash``): the output angle lost when the input reverses
    under a load that resists the motion.

    Parameters
    ----------
    spec : ReducerSpec
        The reducer (:func:`rvflex.load_reducer`).
    errors : ErrorSpec, optional
        Manufacturing and assembly errors (:func:`rvflex.load_errors`); None: none.
    load_Nm : float, optional
        Load resisting the motion, N·m; None: :data:`DEFAULT_LOAD_FRACTION` of the rated torque.
    window_out_deg : float, optional
        Input travel of each branch, in degrees of output rotation.
    positions : int, optional
        Positions per branch (at least 8).
    options : ModelOptions or str, optional
        Model fidelity per part: a :class:`~rvflex.options.ModelOptions` or a preset name
        (``"rigid"``, ``"flexible"``, ``"flexible-carrier"``).
    output_load : rvflex.tilt.OutputLoad, optional
        Tilting moment, axial and radial force on the output (None: none): the carrier tilts and moves on its main
        bearing pair and the discs with it against the pins (:mod:`rvflex.tilt`).

    Raises
    ------
    SpecError
        A value out of range, naming the parameter.
    """

    spec: ReducerSpec
    errors: ErrorSpec | None = None
    load_Nm: float | None = None
    window_out_deg: float = 3.0
    positions: int = 60
    options: ModelOptions | str = ModelOptions()
    output_load: OutputLoad | None = None

    def __post_init__(self) -> None:
        check_scenario_inputs(self)
        self._check_output_load()
        if self.load_Nm is None:
            object.__setattr__(self, "load_Nm", DEFAULT_LOAD_FRACTION * self.spec.rated_torque_Nm)
        self.spec.check_torque("load_Nm", self.load_Nm)
        if not self.positions >= 8:
            raise SpecError("positions", self.positions, "must be at least 8")

    def run(self, *, model: ReducerModel | None = None, progress=None) -> ReversalBacklashResult:
        """Run the scenario (:func:`rvflex.run` calls this).

        Parameters
        ----------
        model : ReducerModel, optional
            A model from :func:`rvflex.build_reducer` with this scenario's spec, errors and
            options, reused instead of building one; None builds it.
        progress : callable, optional
            ``progress(done, total)``, called as the run advances (after each branch).

        Returns
        -------
        ReversalBacklashResult
            The labelled result.
        """
        t0 = time.perf_counter()
        lost, fwd, rev = run_reversal_backlash(self, model=model, progress=progress)
        return ReversalBacklashResult(self, BacklashMetrics(lost), time.perf_counter() - t0, fwd, rev)


@dataclass(frozen=True)
class BacklashMetrics:
    """Reversal backlash: mean distance between the forward and reverse output branches (arcmin)."""

    reversal_backlash_arcmin: float


def run_reversal_backlash(sc: ReversalBacklash, *, model: ReducerModel | None = None,
                          progress=None) -> tuple[float, QuasiStaticResult, QuasiStaticResult]:
    """Reversal backlash (arcmin) and the forward and reverse runs, on ``model`` (None: built here)."""
    model = check_model(sc, model)
    span = math.radians(sc.window_out_deg) * model.ratio
    grid = np.linspace(0.0, span, sc.positions)
    fwd = quasi_static(model, grid, sc.load_Nm, output_load=sc.solver_load)
    if progress is not None:
        progress(1, 2)
    rev = quasi_static(model, grid[::-1], sc.load_Nm, output_load=sc.solver_load)
    if progress is not None:
        progress(2, 2)
    lost = float(np.mean(fwd.theta_out - rev.theta_out[::-1])) * ARCMIN_PER_RAD
    return abs(lost), fwd, rev


def _reversed(run: QuasiStaticResult) -> QuasiStaticResult:
    """The spatial records of a reverse run in the forward run's order of input angles (the rest unchanged)."""
    if run.carrier_tilt_rad is None:
        return run
    return dc.replace(run, carrier_tilt_rad=run.carrier_tilt_rad[::-1], carrier_shift_m=run.carrier_shift_m[::-1],
                      disc_tilt_rad=run.disc_tilt_rad[::-1], crank_tilt_rad=run.crank_tilt_rad[::-1])


@dataclass(frozen=True, eq=False)
class ReversalBacklashResult(Result):
    """Forward and reverse output branches over the input window (``forward``, ``reverse``: the
    solver's records, the reverse one in its own, descending, order).

    Parameters
    ----------
    scenario : ReversalBacklash
        The scenario that ran.
    metrics : BacklashMetrics
        The reversal backlash, arcmin.
    wall_s : float
        Wall time of the run, s.
    forward, reverse : QuasiStaticResult
        The two branches (angles in rad).
    """

    forward: QuasiStaticResult
    reverse: QuasiStaticResult

    name = "backlash"
    main_dim = "position"

    def to_xarray(self):
        """Dataset over ``position`` (nominal output angle θ_in/i, rad): ``te_forward`` and
        ``te_reverse`` (arcmin) at equal input angle; the spatial model's ``carrier_tilt_forward``,
        ``carrier_shift_forward``, ``disc_tilt_forward`` and their ``_reverse`` twins
        (:func:`rvflex.result.spatial_variables`), at equal input angle too; the metric in ``attrs``.

        Returns
        -------
        xarray.Dataset
            Named dimensions, SI coordinates, ``units`` and ``long_name`` on every variable.
        """
        import xarray as xr

        f, r, dims = self.forward, self.reverse, ("position",)
        coords = {"position": variable(dims, f.theta_in / f.ratio, "rad", "nominal output angle θ_in/i"),
                  "theta_in": variable(dims, f.theta_in, "rad", "input angle θ_in")}
        data = {"te_forward": variable(dims, f.te_rad * ARCMIN_PER_RAD, "arcmin", "TE θ_out − θ_in/i, input forward"),
                "te_reverse": variable(dims, r.te_rad[::-1] * ARCMIN_PER_RAD, "arcmin",
                                       "TE θ_out − θ_in/i, input reversed")}
        for suffix, run in (("_forward", f), ("_reverse", _reversed(r))):
            more, axes = spatial_variables(run, "position", suffix)
            data.update(more)
            coords.update(axes)
        return xr.Dataset(data, coords=coords, attrs=scenario_attrs(self.scenario, **self.metrics_dict()))

    def plot(self, ax=None):
        """Both branches (arcmin) against the output angle (°); returns the axes.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on; None draws on a new Figure's axes (pyplot and the backend untouched).

        Returns
        -------
        matplotlib.axes.Axes
            The axes drawn on.
        """
        ax = new_axes(ax)
        f, r, sc = self.forward, self.reverse, self.scenario
        x = np.degrees(f.theta_in / f.ratio)
        ax.plot(x, f.te_rad * ARCMIN_PER_RAD, label="forward")
        ax.plot(x, r.te_rad[::-1] * ARCMIN_PER_RAD, label="reverse")
        ax.set_xlabel("output angle (°)")
        ax.set_ylabel("TE (arcmin)")
        ax.set_title(f"{sc.spec.name}: reversal backlash {self.metrics.reversal_backlash_arcmin:.4f}′ "
                     f"at ±{sc.load_Nm:g} N·m")
        ax.grid(alpha=0.3)
        ax.legend()
        return ax

    def files(self, out: Path) -> list[Path]:
        """backlash.csv and backlash.png.

        Parameters
        ----------
        out : pathlib.Path
            An existing directory.

        Returns
        -------
        list of pathlib.Path
            The files written.
        """
        return write_backlash_outputs(out, self.metrics.reversal_backlash_arcmin, self.forward, self.reverse,
                                      self.scenario)


def write_backlash_outputs(out: Path, lost: float, fwd: QuasiStaticResult, rev: QuasiStaticResult,
                           sc: ReversalBacklash) -> list[Path]:
    """Write backlash.csv and backlash.png (both output branches against the input angle)."""
    out.mkdir(parents=True, exist_ok=True)
    csv = out / "backlash.csv"
    np.savetxt(csv, np.column_stack([fwd.theta_in, fwd.te_rad, rev.te_rad[::-1]]), delimiter=",",
               header="theta_in_rad,te_forward_rad,te_reverse_rad", comments="", fmt="%.12g")
    ax = ReversalBacklashResult(sc, BacklashMetrics(lost), fwd.wall_s + rev.wall_s, fwd, rev).plot()
    png = out / "backlash.png"
    ax.figure.savefig(png, dpi=120)
    return [csv, png]


if __name__ == "__main__":
    import sys

    from rvflex import catalog

    result = ReversalBacklash(catalog.load("rv40e")).run()
    print(f"reversal backlash {result.metrics.reversal_backlash_arcmin:.4f}′")
    print(result.write(sys.argv[1] if len(sys.argv) > 1 else "out"))

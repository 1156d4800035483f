"""Flexibility effect: loaded TE, lost motion and torsional stiffness of the RV reducer with
rigid parts, with FE-reduced (Craig–Bampton) cycloid discs, and (``carrier`` not None)
with FE-reduced discs and carrier, at 0, 50, 100 and 150 % of rated torque, and the elastic
share of each figure.

The variants run the same model code; only their :class:`~rvflex.options.ModelOptions` differ.
Global disc and carrier deformation come from the reduced modes, the local contact approach
from the line-contact law in all rows. Variants: ``rigid``, ``flexible`` (discs),
``flexible+carrier`` (discs and carrier).

Run as a script for the catalogue RV-40E (its tooth modification, no manufacturing
errors: with seed 001's 12 µm bearing clearances the flexible torque cycle does not yet
converge near zero torque, where the discs float in their clearances)::

    python -m rvflex.scenarios.flexibility_effect out/
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rvflex.fe.reduce import PartSettings
from rvflex.model import build_reducer
from rvflex.options import DISC_FE, ModelOptions
from rvflex.result import Result, new_axes, new_figure, scenario_attrs, variable
from rvflex.scenarios.loaded_te import LoadedTE, run_loaded_te
from rvflex.scenarios.lost_motion import LostMotion, run_lost_motion
from rvflex.spec import ErrorSpec, ReducerSpec, SpecError

__all__ = ["FlexibilityEffect", "FlexibilityMetrics", "FlexibilityResult", "run_flexibility_effect",
           "write_flexibility_outputs"]


@dataclass(frozen=True)
class FlexibilityEffect:
    """Rigid against flexible discs (and carrier): loaded TE, wind-up and the torsional test
    of each model at several loads.

    Parameters
    ----------
    spec : ReducerSpec
        The reducer (:func:`rvflex.load_reducer`).
    errors : ErrorSpec, optional
        Manufacturing and assembly errors (:func:`rvflex.load_errors`); None: none.
    load_fractions : tuple of float, optional
        Loads of the TE runs as fractions of the rated torque (dimensionless, ≥ 0).
    positions_per_rev : int, optional
        TE positions per output revolution.
    steps : int, optional
        Torque steps of each hysteresis cycle.
    discs : PartSettings, optional
        The disc reduction (default :data:`rvflex.options.DISC_FE`: global deformation, 6 bore
        + 12 fixed-interface modes on 6 mm quadratic tets).
    carrier : PartSettings, optional
        The carrier reduction of the ``flexible+carrier`` row; None leaves that row out (the
        script runs it with :data:`rvflex.options.CARRIER_FE`).
    revolutions : float, optional
        The TE window in output revolutions (1/z_b is one crank turn).
    """

    spec: ReducerSpec
    errors: ErrorSpec | None = None
    load_fractions: tuple[float, ...] = (0.0, 0.5, 1.0, 1.5)
    positions_per_rev: int = 256
    steps: int = 80
    discs: PartSettings = DISC_FE
    carrier: PartSettings | None = None
    revolutions: float = 1.0

    def __post_init__(self) -> None:
        if not self.revolutions > 0:
            raise SpecError("revolutions", self.revolutions, "must be positive (output revolutions of the TE window)")
        if not isinstance(self.spec, ReducerSpec):
            raise TypeError(f"FlexibilityEffect.spec: expected a ReducerSpec (rvflex.load_reducer(...)), "
                            f"got {type(self.spec).__name__}")
        if self.errors is None:
            object.__setattr__(self, "errors", ErrorSpec())
        self.errors.check_against(self.spec)
        object.__setattr__(self, "load_fractions", tuple(float(f) for f in self.load_fractions))
        for f in self.load_fractions:
            if not f >= 0:
                raise SpecError("load_fractions", f, "must be non-negative fractions of rated torque")
            self.spec.check_torque("load_fractions", f * self.spec.rated_torque_Nm, allow_zero=True)
        for name in ("discs", "carrier"):
            value = getattr(self, name)
            if not (isinstance(value, PartSettings) or (name == "carrier" and value is None)):
                raise SpecError(name, value, "must be an rvflex.fe.reduce.PartSettings"
                                + (" or None" if name == "carrier" else ""))

    @property
    def variants(self) -> dict[str, ModelOptions]:
        """The compared models: ``rigid``, ``flexible`` (discs) and, with a carrier reduction,
        ``flexible+carrier``."""
        out = {"rigid": ModelOptions.rigid(), "flexible": ModelOptions(discs=self.discs)}
        if self.carrier is not None:
            out["flexible+carrier"] = ModelOptions(discs=self.discs, carrier=self.carrier)
        return out

    def run(self, *, model=None, progress=None) -> FlexibilityResult:
        """Build each variant's model once and run the loaded TE at every load and the torque
        cycle on it.

        Parameters
        ----------
        model : None
            Must be None: the scenario builds one model per variant.
        progress : callable, optional
            ``progress(done, total)``, called per run.

        Returns
        -------
        FlexibilityResult
            One row per (variant, load).
        """
        if model is not None:
            raise TypeError("FlexibilityEffect.run: model must be None — the scenario builds one model per variant "
                            f"({', '.join(self.variants)}); got {type(model).__name__}")
        t0 = time.perf_counter()
        rows = run_flexibility_effect(self, progress=progress)
        return FlexibilityResult(self, flexibility_metrics(rows), time.perf_counter() - t0, tuple(rows))


def run_flexibility_effect(sc: FlexibilityEffect, progress=None) -> list[dict]:
    """Rows of the comparison: one per (variant, load) with TE peak-to-peak and mean wind-up
    (arcsec), and per variant the hysteresis metrics at rated torque (lost motion, arcmin;
    torsional stiffness, N·m/arcmin). Elastic shares are added to the flexible rows. Each
    variant's model is built once; ``progress(done, total)`` after each run."""
    rows = []
    total, done = len(sc.variants) * (1 + len(sc.load_fractions)), 0
    for name, options in sc.variants.items():
        model = build_reducer(sc.spec, sc.errors, options)
        lm = run_lost_motion(LostMotion(sc.spec, sc.errors, sc.spec.rated_torque_Nm, sc.steps, options),
                             model=model)[1]
        done += 1
        if progress is not None:
            progress(done, total)
        for f in sc.load_fractions:
            load = f * sc.spec.rated_torque_Nm
            met = run_loaded_te(LoadedTE(sc.spec, sc.errors, load, sc.revolutions, sc.positions_per_rev,
                                         options=options),
                                model=model)[1]
            rows.append({"fidelity": name, "load_fraction": f, "load_Nm": load, "te_pp_arcsec": met.te_pp_arcsec,
                         "mean_windup_arcsec": met.mean_windup_arcsec,
                         "lost_motion_arcmin": lm.lost_motion_arcmin,
                         "torsional_stiffness_Nm_per_arcmin": lm.torsional_stiffness_Nm_per_arcmin})
            done += 1
            if progress is not None:
                progress(done, total)
    rigid = {r["load_fraction"]: r for r in rows if r["fidelity"] == "rigid"}
    discs = {r["load_fraction"]: r for r in rows if r["fidelity"] == "flexible"}
    for r in rows:
        if r["fidelity"] == "rigid":
            continue
        g = rigid[r["load_fraction"]]
        if r["fidelity"] == "flexible+carrier":  # the carrier's own share, against the flexible-disc row
            d = discs[r["load_fraction"]]
            r["carrier_share_te_pp"] = _share(r["te_pp_arcsec"], d["te_pp_arcsec"])
            r["carrier_share_windup"] = _share(r["mean_windup_arcsec"], d["mean_windup_arcsec"])
            r["carrier_share_compliance"] = _share(1 / r["torsional_stiffness_Nm_per_arcmin"],
                                                   1 / d["torsional_stiffness_Nm_per_arcmin"])
        r["elastic_share_te_pp"] = _share(r["te_pp_arcsec"], g["te_pp_arcsec"])
        r["elastic_share_windup"] = _share(r["mean_windup_arcsec"], g["mean_windup_arcsec"])
        r["elastic_share_lost_motion"] = _share(r["lost_motion_arcmin"], g["lost_motion_arcmin"])
        # the compliance 1/k adds up in series: the discs' share of the unit's compliance
        r["elastic_share_compliance"] = _share(1 / r["torsional_stiffness_Nm_per_arcmin"],
                                               1 / g["torsional_stiffness_Nm_per_arcmin"])
    return rows


@dataclass(frozen=True)
class FlexibilityMetrics:
    """The comparison at the load nearest rated torque: TE peak-to-peak and mean wind-up (arcsec),
    torsional stiffness (N·m/arcmin) of each variant, and the elastic shares (fractions, NaN
    where a variant is absent): discs against rigid, carrier against flexible discs."""

    load_Nm: float
    te_pp_rigid_arcsec: float
    te_pp_flexible_arcsec: float
    te_pp_flexible_carrier_arcsec: float
    windup_rigid_arcsec: float
    windup_flexible_arcsec: float
    windup_flexible_carrier_arcsec: float
    stiffness_rigid_Nm_per_arcmin: float
    stiffness_flexible_Nm_per_arcmin: float
    stiffness_flexible_carrier_Nm_per_arcmin: float
    elastic_share_te_pp: float
    elastic_share_windup: float
    elastic_share_compliance: float
    carrier_share_windup: float
    carrier_share_compliance: float


def flexibility_metrics(rows: list[dict]) -> FlexibilityMetrics:
    """:class:`FlexibilityMetrics` from the rows of :func:`run_flexibility_effect`."""
    f = min({r["load_fraction"] for r in rows}, key=lambda x: abs(x - 1.0))
    at = {r["fidelity"]: r for r in rows if r["load_fraction"] == f}
    nan = math.nan

    def get(variant: str, key: str) -> float:
        return float(at.get(variant, {}).get(key, nan))

    return FlexibilityMetrics(
        at["rigid"]["load_Nm"], get("rigid", "te_pp_arcsec"), get("flexible", "te_pp_arcsec"),
        get("flexible+carrier", "te_pp_arcsec"), get("rigid", "mean_windup_arcsec"),
        get("flexible", "mean_windup_arcsec"), get("flexible+carrier", "mean_windup_arcsec"),
        get("rigid", "torsional_stiffness_Nm_per_arcmin"), get("flexible", "torsional_stiffness_Nm_per_arcmin"),
        get("flexible+carrier", "torsional_stiffness_Nm_per_arcmin"), get("flexible", "elastic_share_te_pp"),
        get("flexible", "elastic_share_windup"), get("flexible", "elastic_share_compliance"),
        get("flexible+carrier", "carrier_share_windup"), get("flexible+carrier", "carrier_share_compliance"))


@dataclass(frozen=True, eq=False)
class FlexibilityResult(Result):
    """The comparison table: one row (dict) per (variant, load).

    Parameters
    ----------
    scenario : FlexibilityEffect
        The scenario that ran.
    metrics : FlexibilityMetrics
        The elastic shares of the comparison.
    wall_s : float
        Wall time of the run, s.
    rows : tuple of dict
        One row per (variant, load), units in the keys.
    """

    rows: tuple[dict, ...]

    name = "flexibility"
    main_dim = "load"

    def to_xarray(self):
        """Dataset over ``variant`` × ``load`` (N m; ``load_fraction`` of rated alongside): ``te_pp``,
        ``mean_windup`` (arcsec), elastic and carrier shares (1); over ``variant``: ``lost_motion``
        (arcmin), ``torsional_stiffness`` (N m/arcmin) and their shares.

        Returns
        -------
        xarray.Dataset
            Named dimensions, SI coordinates, ``units`` and ``long_name`` on every variable.
        """
        import xarray as xr

        variants = list(dict.fromkeys(r["fidelity"] for r in self.rows))
        fractions = list(self.scenario.load_fractions)
        rated = self.scenario.spec.rated_torque_Nm

        def grid(key):
            a = np.full((len(variants), len(fractions)), np.nan)
            for r in self.rows:
                if key in r:
                    a[variants.index(r["fidelity"]), fractions.index(r["load_fraction"])] = r[key]
            return a

        def per_variant(key):
            return grid(key)[:, 0]

        vl, v = ("variant", "load"), ("variant",)
        data = {"te_pp": variable(vl, grid("te_pp_arcsec"), "arcsec", "TE peak-to-peak over one output revolution"),
                "mean_windup": variable(vl, grid("mean_windup_arcsec"), "arcsec", "mean TE (wind-up)"),
                "lost_motion": variable(v, per_variant("lost_motion_arcmin"), "arcmin", "lost motion at ±3 % T_r"),
                "torsional_stiffness": variable(v, per_variant("torsional_stiffness_Nm_per_arcmin"), "N m/arcmin",
                                                "torsional stiffness 50–100 % T_r")}
        for key, long in (("elastic_share_te_pp", "elastic share of TE peak-to-peak (against rigid)"),
                          ("elastic_share_windup", "elastic share of the wind-up (against rigid)"),
                          ("carrier_share_te_pp", "carrier's share of TE peak-to-peak (against flexible discs)"),
                          ("carrier_share_windup", "carrier's share of the wind-up (against flexible discs)")):
            data[key] = variable(vl, grid(key), "1", long)
        for key, long in (("elastic_share_lost_motion", "elastic share of the lost motion (against rigid)"),
                          ("elastic_share_compliance", "elastic share of the torsional compliance (against rigid)"),
                          ("carrier_share_compliance", "carrier's share of the compliance (against flexible discs)")):
            data[key] = variable(v, per_variant(key), "1", long)
        coords = {"variant": variable(v, np.array(variants, dtype=object), "1", "model variant"),
                  "load": variable(("load",), np.array(fractions) * rated, "N m", "output torque"),
                  "load_fraction": variable(("load",), fractions, "1", "fraction of rated torque")}
        attrs = scenario_attrs(self.scenario, variants_options="; ".join(
            f"{k}: {o.describe()}" for k, o in self.scenario.variants.items() if k in variants))
        return xr.Dataset(data, coords=coords, attrs=attrs)

    def to_dataframe(self):
        """The comparison table, one row per (variant, load), as ``flexibility.csv``.

        Returns
        -------
        pandas.DataFrame
            The table, the unit in each column name.
        """
        import pandas as pd

        return pd.DataFrame(list(self.rows))

    def plot(self, ax=None):
        """TE peak-to-peak (arcsec) against load for each variant; returns the axes.

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
        self._curves(ax, "te_pp_arcsec", 1.0)
        window = ("one output revolution" if self.scenario.revolutions == 1.0
                  else f"{360 * self.scenario.revolutions:g}° of output")
        ax.set(xlabel="output torque (N·m)", ylabel="TE peak-to-peak (″)", title=f"Loaded TE over {window}")
        return ax

    def plot_windup(self, ax=None):
        """Mean wind-up (arcsec, positive) against load for each variant; returns the axes.

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
        self._curves(ax, "mean_windup_arcsec", -1.0)
        ax.set(xlabel="output torque (N·m)", ylabel="mean wind-up (″)", title="Mean wind-up")
        return ax

    def _curves(self, ax, key: str, sign: float) -> None:
        for fid, style in (("rigid", "o-"), ("flexible", "s-"), ("flexible+carrier", "^-")):
            sel = [x for x in self.rows if x["fidelity"] == fid]
            if sel:
                ax.plot([x["load_Nm"] for x in sel], [sign * x[key] for x in sel], style, label=fid)
        ax.grid(alpha=0.3)
        ax.legend()

    def files(self, out: Path) -> list[Path]:
        """flexibility.csv, flexibility.md (the table) and flexibility.png.

        Parameters
        ----------
        out : pathlib.Path
            An existing directory.

        Returns
        -------
        list of pathlib.Path
            The files written.
        """
        return write_flexibility_outputs(out, list(self.rows), self.scenario)


def _share(flexible: float, rigid: float) -> float:
    """(flexible − rigid)/flexible of a magnitude; NaN where it vanishes (below 1e-3 of the unit)."""
    return (abs(flexible) - abs(rigid)) / abs(flexible) if abs(flexible) > 1e-3 else math.nan


def _pct(share: float) -> str:
    return "–" if math.isnan(share) else f"{100 * share:.0f} %"


def write_flexibility_outputs(out: Path, rows: list[dict], sc: FlexibilityEffect) -> list[Path]:
    """``flexibility.csv``, ``flexibility.md`` (the table) and ``flexibility.png``."""
    import csv

    out.mkdir(parents=True, exist_ok=True)
    keys = list(dict.fromkeys(k for r in rows for k in r))  # first-seen order; rigid rows leave shares empty
    csv_path = out / "flexibility.csv"
    with open(csv_path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    md = out / "flexibility.md"
    carrier = (f"carrier reduction (flexible+carrier row): {dataclasses.asdict(sc.carrier)}"
               if sc.carrier is not None else "carrier rigid in every row")
    lines = [f"Disc reduction: {dataclasses.asdict(sc.discs)}; {carrier}. Elastic share = (flexible − rigid)/flexible "
             "of each magnitude.", "",
             "| variant | load | TE pp | elastic share | wind-up | elastic share |", "|---|---|---|---|---|---|"]
    for r in rows:
        es_te = _pct(r.get("elastic_share_te_pp", math.nan))
        es_w = _pct(r.get("elastic_share_windup", math.nan))
        lines.append(f"| {r['fidelity']} | {r['load_Nm']:.0f} N·m | {r['te_pp_arcsec']:.2f}″ | {es_te} | "
                     f"{r['mean_windup_arcsec']:.1f}″ | {es_w} |")
    lines += ["", "| variant | lost motion | elastic share | stiffness 50–100 % T_r | share of the compliance |",
              "|---|---|---|---|---|"]
    for name in dict.fromkeys(r["fidelity"] for r in rows):
        r = next(x for x in rows if x["fidelity"] == name)
        lines.append(f"| {name} | {r['lost_motion_arcmin']:.3f}′ | {_pct(r.get('elastic_share_lost_motion', math.nan))} "
                     f"| {r['torsional_stiffness_Nm_per_arcmin']:.1f} N·m/arcmin | "
                     f"{_pct(r.get('elastic_share_compliance', math.nan))} |")
    car = [r for r in rows if r["fidelity"] == "flexible+carrier"]
    if car:
        lines += ["", "Carrier's own share (flexible+carrier against flexible discs): " + ", ".join(
            f"{r['load_Nm']:.0f} N·m: TE pp {_pct(r['carrier_share_te_pp'])}, wind-up {_pct(r['carrier_share_windup'])}"
            for r in car) + f"; compliance {_pct(car[0]['carrier_share_compliance'])}."]
    md.write_text("\n".join(lines) + "\n")
    result = FlexibilityResult(sc, flexibility_metrics(rows), 0.0, tuple(rows))
    fig = new_figure(figsize=(11, 4.2))
    ax = fig.subplots(1, 2)
    result.plot(ax[0])
    result.plot_windup(ax[1])
    fig.suptitle(f"{sc.spec.name}: rigid vs FE-reduced cycloid discs (and carrier)")
    fig.tight_layout()
    png = out / "flexibility.png"
    fig.savefig(png, dpi=130)
    return [csv_path, md, png]


if __name__ == "__main__":
    import sys

    from rvflex import catalog
    from rvflex.options import CARRIER_FE

    result = FlexibilityEffect(catalog.load("rv40e"), carrier=CARRIER_FE).run(
        progress=lambda done, total: print(f"{done}/{total} runs", file=sys.stderr))
    print(result.to_dataframe().to_string())
    for p in result.write(sys.argv[1] if len(sys.argv) > 1 else "out"):
        print("wrote", p)

"""Flexibility effect: loaded TE, lost motion and torsional stiffness of the RV reducer with
rigid parts, with FE-reduced (Craig–Bampton) cycloid discs, and (``carrier_fe`` not None)
with FE-reduced discs and carrier, at 0, 50, 100 and 150 % of rated torque, and the elastic
share of each figure.

The variants run the same model code; only ``fidelity`` and ``flexible_carrier`` differ.
Global disc and carrier deformation come from the reduced modes, the local contact approach
from the line-contact law in all rows. Variants: ``rigid``, ``flexible`` (discs),
``flexible+carrier`` (discs and carrier).

Run as a script for the catalogue RV-40E (its tooth modification, no manufacturing
errors: with seed 001's 12 µm bearing clearances the flexible torque cycle does not yet
converge near zero torque, where the discs float in their clearances)::

    python -m rvflex.scenarios.flexibility_effect out/
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from rvflex.scenarios.loaded_te import LoadedTE, run_loaded_te
from rvflex.scenarios.lost_motion import LostMotion, run_lost_motion
from rvflex.spec import ErrorSpec, ReducerSpec, SpecError

__all__ = ["FlexibilityEffect", "run_flexibility_effect", "write_flexibility_outputs", "GLOBAL_MODES"]

GLOBAL_MODES = ()
"""Disc reduction settings of the scenario on top of :data:`rvflex.model.FLEXIBLE_DISC_FE` (none:
global deformation, 6 bore + 12 fixed-interface modes on 6 mm quadratic tets)."""


@dataclass(frozen=True)
class FlexibilityEffect:
    """Reducer, errors, load fractions of rated torque, TE positions per output revolution,
    hysteresis torque steps and the disc reduction settings (see :data:`GLOBAL_MODES`)."""

    spec: ReducerSpec
    errors: ErrorSpec
    load_fractions: tuple[float, ...] = (0.0, 0.5, 1.0, 1.5)
    positions_per_rev: int = 256
    steps: int = 80
    fe: tuple[tuple[str, float], ...] = GLOBAL_MODES
    carrier_fe: tuple[tuple[str, float], ...] | None = None
    """Carrier reduction settings on top of :data:`rvflex.model.FLEXIBLE_CARRIER_FE` for the
    ``flexible+carrier`` row; None leaves that row out (the script runs it with ``()``)."""

    def __post_init__(self) -> None:
        for f in self.load_fractions:
            if not f >= 0:
                raise SpecError("load_fractions", f, "must be non-negative fractions of rated torque")
            self.spec.check_torque("load", f * self.spec.rated_torque_Nm, allow_zero=True)


def run_flexibility_effect(sc: FlexibilityEffect, progress=print) -> list[dict]:
    """Rows of the comparison: one per (fidelity, load) with TE peak-to-peak and mean wind-up
    (arcsec), and per fidelity the hysteresis metrics at rated torque (lost motion, arcmin;
    torsional stiffness, N·m/arcmin). Elastic shares are added to the flexible rows."""
    rows = []
    variants = {"rigid": ("rigid", ()), "flexible": ("flexible", sc.fe)}
    if sc.carrier_fe is not None:  # build_reducer takes the carrier switch and settings from fe
        variants["flexible+carrier"] = ("flexible", sc.fe + (("flexible_carrier", True),)
                                        + tuple((f"carrier_{k}", v) for k, v in sc.carrier_fe))
    for name, (fidelity, fe) in variants.items():
        lm = run_lost_motion(LostMotion(sc.spec, sc.errors, sc.spec.rated_torque_Nm, sc.steps, fidelity, fe))[1]
        for f in sc.load_fractions:
            load = f * sc.spec.rated_torque_Nm
            met = run_loaded_te(LoadedTE(sc.spec, sc.errors, load, 1.0, sc.positions_per_rev, fidelity=fidelity,
                                         fe=fe))[1]
            rows.append({"fidelity": name, "load_fraction": f, "load_Nm": load, "te_pp_arcsec": met.te_pp_arcsec,
                         "mean_windup_arcsec": met.mean_windup_arcsec,
                         "lost_motion_arcmin": lm.lost_motion_arcmin,
                         "torsional_stiffness_Nm_per_arcmin": lm.torsional_stiffness_Nm_per_arcmin})
            progress(f"{name:16s} {load:7.1f} N·m: TE pp {met.te_pp_arcsec:7.3f}″, wind-up "
                     f"{met.mean_windup_arcsec:8.2f}″")
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


def _share(flexible: float, rigid: float) -> float:
    """(flexible − rigid)/flexible of a magnitude; NaN where it vanishes (below 1e-3 of the unit)."""
    return (abs(flexible) - abs(rigid)) / abs(flexible) if abs(flexible) > 1e-3 else math.nan


def _pct(share: float) -> str:
    return "–" if math.isnan(share) else f"{100 * share:.0f} %"


def write_flexibility_outputs(out: Path, rows: list[dict], sc: FlexibilityEffect) -> list[Path]:
    """``flexibility.csv``, ``flexibility.md`` (the table) and ``flexibility.png``."""
    import csv

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    keys = list(dict.fromkeys(k for r in rows for k in r))  # first-seen order; rigid rows leave shares empty
    csv_path = out / "flexibility.csv"
    with open(csv_path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    md = out / "flexibility.md"
    from rvflex.model import FLEXIBLE_CARRIER_FE, FLEXIBLE_DISC_FE

    carrier = (f"carrier reduction (flexible+carrier row): {FLEXIBLE_CARRIER_FE | dict(sc.carrier_fe)}"
               if sc.carrier_fe is not None else "carrier rigid in every row")
    lines = [f"Disc reduction: {FLEXIBLE_DISC_FE | dict(sc.fe)}; {carrier}. Elastic share = (flexible − rigid)/flexible "
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
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    for fid, style in (("rigid", "o-"), ("flexible", "s-"), ("flexible+carrier", "^-")):
        sel = [x for x in rows if x["fidelity"] == fid]
        if not sel:
            continue
        ax[0].plot([x["load_Nm"] for x in sel], [x["te_pp_arcsec"] for x in sel], style, label=fid)
        ax[1].plot([x["load_Nm"] for x in sel], [-x["mean_windup_arcsec"] for x in sel], style, label=fid)
    ax[0].set(xlabel="output torque (N·m)", ylabel="TE peak-to-peak (″)", title="Loaded TE over one output revolution")
    ax[1].set(xlabel="output torque (N·m)", ylabel="mean wind-up (″)", title="Mean wind-up")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend()
    fig.suptitle(f"{sc.spec.name}: rigid vs FE-reduced cycloid discs (and carrier)")
    fig.tight_layout()
    png = out / "flexibility.png"
    fig.savefig(png, dpi=130)
    plt.close(fig)
    return [csv_path, md, png]


if __name__ == "__main__":
    import sys

    from rvflex import catalog

    spec = catalog.load("rv40e")
    scenario = FlexibilityEffect(spec, ErrorSpec(), carrier_fe=())
    result = run_flexibility_effect(scenario)
    for p in write_flexibility_outputs(Path(sys.argv[1] if len(sys.argv) > 1 else "out"), result, scenario):
        print("wrote", p)

"""Seed 003's three cycloid modification schemes on the RV-80E, quasi-static and dynamic.

Seed 003 compares, on its RV-80E coupled model (time-varying involute mesh stiffness
9.0e8 ± 1.1e7 N/m, bearing stiffnesses of its Table 3, masses of Table 5), the whole-machine
TE of three schemes: no cycloidal modification 30.2″, involute + moved/equidistant 31.5″,
involute + pressure-angle 30.9″. Here the same three cycloid profiles on the catalogue RV-80E
(``rvflex/catalog/rv80e.toml``, the time-varying mesh stiffness of seed 003 included):

- ``none``: the theoretical profile (moved, equidistant, tip and root amounts 0);
- ``moved+equidistant``: the catalogue's Δr_p = −27 µm, Δr_rp = −22 µm (eq. 24 read literally);
- ``pressure-angle``: the theoretical profile in the working zone, 45 µm tip relief beyond the
  65° pressure angle and 15 µm root relief beyond 75° (seed 003 Table 2);
- ``pressure-angle (tip only)``: the same without the root relief (not a scheme of the paper).

The 15 µm root relief, blended in over the short stretch beyond 75°, makes the root concave
with a radius of curvature of 2.2 mm, smaller than the 3 mm pin: a pin sitting in the root
touches the two rims of the dimple at once. The contact element gives each rim its own
contact point (every separate local minimum of the pin–profile distance, see
:mod:`rvflex.contact.cycloid_pin`), so the force follows the pin continuously through the
root and both solvers converge. A run that does not converge all the same records the
solver's message for that scheme (``{"error": ...}``) and the others go on. The tip-only
variant isolates what the tip relief does.

Seed 003 gives no error amounts (its "composite meshing error" comes from Romax), and its
involute lead/profile crowning is not modelled (our mesh is a line-of-action spring): the runs
have no manufacturing errors, so they show what the profiles alone do. Operating condition 1
of Table 6: 15 rpm output, 800 N·m.

    python -m rvflex.scenarios.rv80e_modifications out/rv80e_modifications
"""

from __future__ import annotations

import dataclasses as dc
import json
import time
from pathlib import Path

import numpy as np

from rvflex.geometry.formulas import ARCSEC_PER_RAD
from rvflex.spec import ErrorSpec, ReducerSpec

__all__ = ["PAPER_TE_ARCSEC", "SCHEMES", "CATALOGUE_CLASS", "scheme_spec", "run_schemes", "run_hysteresis",
           "plot_schemes"]

PAPER_TE_ARCSEC = {"none": 30.2, "moved+equidistant": 31.5, "pressure-angle": 30.9}  # seed 003 Fig. 14
SCHEMES = (*PAPER_TE_ARCSEC, "pressure-angle (tip only)")
# Maker's catalogue class of the RV-80E (recalled, not in the seeds): lost motion ≤ 1′,
# torsional stiffness 196 N·m/arcmin.
CATALOGUE_CLASS = {"lost_motion_arcmin": 1.0, "torsional_stiffness_Nm_per_arcmin": 196.0}
OUTPUT_RPM, LOAD_NM = 15.0, 800.0  # seed 003 Table 6, condition 1


def scheme_spec(spec: ReducerSpec, scheme: str) -> ReducerSpec:
    """``spec`` (the catalogue RV-80E) with the cycloid profile of ``scheme``."""
    m = spec.cycloid.modification
    if scheme == "none":
        mod = dc.replace(m, moved_m=0.0, equidistant_m=0.0, tip_amount_m=0.0, root_amount_m=0.0)
    elif scheme == "moved+equidistant":
        mod = dc.replace(m, tip_amount_m=0.0, root_amount_m=0.0)
    elif scheme == "pressure-angle":
        mod = dc.replace(m, moved_m=0.0, equidistant_m=0.0, tip_amount_m=45e-6, root_amount_m=15e-6)  # seed 003 Table 2
    elif scheme == "pressure-angle (tip only)":
        mod = dc.replace(m, moved_m=0.0, equidistant_m=0.0, tip_amount_m=45e-6, root_amount_m=0.0)
    else:
        raise ValueError(f"scheme {scheme!r}: expected one of {', '.join(SCHEMES)}")
    return dc.replace(spec, cycloid=dc.replace(spec.cycloid, modification=mod))


def run_schemes(spec: ReducerSpec | None = None, *, positions: int = 2048, dynamic_revs: float = 1.0,
                step_s: float = 1e-4, modes: tuple[str, ...] = ("quasi-static", "dynamic")) -> dict[str, dict]:
    """TE of each scheme: ``{scheme: {mode: {te_pp_arcsec, te_min_arcsec, te_max_arcsec,
    mean_windup_arcsec, orders, wall_s, te_rad}}}`` at 15 rpm / 800 N·m; a run that does not
    converge gives ``{"error": message, "wall_s": ...}``."""
    from rvflex import catalog
    from rvflex.scenarios.loaded_te import LoadedTE, run_loaded_te

    spec = spec or catalog.load("rv80e")
    out: dict[str, dict] = {}
    for scheme in SCHEMES:
        s = scheme_spec(spec, scheme)
        out[scheme] = {}
        for mode in modes:
            revs = 1.0 if mode == "quasi-static" else dynamic_revs
            sc = LoadedTE(s, ErrorSpec(), LOAD_NM, revs, positions, 1, mode, OUTPUT_RPM, step_s=step_s)
            t0 = time.perf_counter()
            try:
                res, met = run_loaded_te(sc)
            except Exception as exc:  # noqa: BLE001 - SolveError (quasi-static) or Exudyn's SolverError (dynamic)
                out[scheme][mode] = {"error": f"{type(exc).__name__}: {exc}".splitlines()[0][:240],
                                     "wall_s": time.perf_counter() - t0}
                continue
            out[scheme][mode] = {"te_pp_arcsec": met.te_pp_arcsec, "te_min_arcsec": met.te_min_arcsec,
                                 "te_max_arcsec": met.te_max_arcsec, "mean_windup_arcsec": met.mean_windup_arcsec,
                                 "orders": [[o, a] for o, a in met.orders[:5]], "revolutions": revs,
                                 "wall_s": time.perf_counter() - t0, "te_rad": res.te_rad}
    return out


def run_hysteresis(spec: ReducerSpec | None = None, steps: int = 200) -> dict:
    """Lost motion and torsional stiffness of the catalogue RV-80E (rigid, no errors)."""
    from rvflex import catalog
    from rvflex.scenarios.lost_motion import LostMotion, run_lost_motion

    spec = spec or catalog.load("rv80e")
    t0 = time.perf_counter()
    _, m = run_lost_motion(LostMotion(spec, ErrorSpec(), spec.rated_torque_Nm, steps))
    return {"lost_motion_arcmin": m.lost_motion_arcmin, "torsional_stiffness_Nm_per_arcmin":
            m.torsional_stiffness_Nm_per_arcmin, "backlash_arcmin": m.backlash_arcmin,
            "hysteresis_loss_arcmin": m.hysteresis_loss_arcmin, "wall_s": time.perf_counter() - t0}


def plot_schemes(results: dict[str, dict], path: Path) -> Path:
    """TE over one output revolution per scheme (quasi-static solid, dynamic thin) and a bar
    chart of peak-to-peak beside seed 003's values."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(13, 4.6), layout="constrained")
    a0, a1 = fig.subplots(1, 2, width_ratios=(2, 1))
    for k, (scheme, r) in enumerate(results.items()):
        for mode, ls in (("quasi-static", "-"), ("dynamic", ":")):
            if "te_rad" not in r.get(mode, {}):
                continue
            te = r[mode]["te_rad"] * ARCSEC_PER_RAD
            deg = np.arange(len(te)) / len(te) * 360.0 * r[mode]["revolutions"]
            a0.plot(deg, te - te.mean(), ls, color=f"C{k}", lw=0.9, label=f"{scheme}, {mode}")
    a0.set_xlim(0.0, 10.0)  # the mesh orders (488, 976 per output revolution) need a close-up
    a0.set_xlabel("output angle (°), first 10°")
    a0.set_ylabel("TE − mean (arcsec)")
    a0.set_title(f"RV-80E, {OUTPUT_RPM:g} rpm output, {LOAD_NM:g} N·m, no errors")
    a0.grid(alpha=0.3)
    a0.legend(fontsize=7)
    x = np.arange(len(results))
    a1.bar(x - 0.27, [PAPER_TE_ARCSEC.get(s, np.nan) for s in results], 0.27, label="seed 003")
    for j, mode in enumerate(("quasi-static", "dynamic")):
        vals = [r.get(mode, {}).get("te_pp_arcsec", np.nan) for r in results.values()]
        a1.bar(x + 0.27 * j, vals, 0.27, label=f"rvflex {mode}")
    a1.set_xticks(x, [s.replace(" (", "\n(") for s in results], fontsize=7)
    a1.set_yscale("log")
    a1.set_ylabel("TE peak-to-peak (arcsec)")
    a1.legend(fontsize=7)
    a1.grid(alpha=0.3, which="both")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    return path


if __name__ == "__main__":
    import sys

    out = Path(sys.argv[1] if len(sys.argv) > 1 else "out/rv80e_modifications")
    res = run_schemes()
    hyst = run_hysteresis()
    for scheme, r in res.items():
        paper = f"{PAPER_TE_ARCSEC[scheme]:5.1f}″" if scheme in PAPER_TE_ARCSEC else "    –"
        print(f"{scheme:26s} paper {paper}  "
              + "  ".join(f"{mode} pp {v['te_pp_arcsec']:.3f}″ (mean {v['mean_windup_arcsec']:.1f}″, {v['wall_s']:.0f} s)"
                          if "error" not in v else f"{mode} FAILED: {v['error']}" for mode, v in r.items()))
    print(f"RV-80E catalogue entry: lost motion {hyst['lost_motion_arcmin']:.3f}′ (class ≤ "
          f"{CATALOGUE_CLASS['lost_motion_arcmin']:g}′), torsional stiffness {hyst['torsional_stiffness_Nm_per_arcmin']:.1f} "
          f"N·m/arcmin (class {CATALOGUE_CLASS['torsional_stiffness_Nm_per_arcmin']:g}), backlash {hyst['backlash_arcmin']:.3f}′")
    p = plot_schemes(res, out / "rv80e_modifications.png")
    doc = {s: {m: {k: v for k, v in d.items() if k != "te_rad"} for m, d in r.items()} for s, r in res.items()}
    doc["hysteresis"] = hyst
    doc["paper_te_arcsec"] = PAPER_TE_ARCSEC
    (out / "rv80e_modifications.json").write_text(json.dumps(doc, indent=2))
    print(f"wrote {p} and {out / 'rv80e_modifications.json'}")

"""The spatial model's convergence in face slices and in beam elements per crank segment, per built-in unit.

For each built-in unit at rated torque over one output revolution (256 positions): the spatial model with rigid
cranks in 2, 4 and 8 slices, then with 4 slices its cranks rigid and as beams of 1, 2, 4 and 8 elements per segment;
each row the mean wind-up, the TE peak-to-peak, the largest crank tilt (the chord between a crank's two support
journals, over the run) and the solver's wall time (warm: the unit's model built and run once before). Beside them
each unit's beam segments (:func:`rvflex.parts.crankshaft.beam_layout`)::

    python -m rvflex.scenarios.spatial_convergence --table docs/results/spatial_convergence.md
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from rvflex import catalog
from rvflex.geometry.formulas import ARCSEC_PER_RAD
from rvflex.model import build_reducer
from rvflex.options import ModelOptions, SpatialSettings
from rvflex.parts.crankshaft import beam_layout, segment_stiffness
from rvflex.solve import quasi_static

__all__ = ["ELEMENTS", "SLICES", "convergence_study", "crank_tilts", "table"]

SLICES = (2, 4, 8)
ELEMENTS = (1, 2, 4, 8)
POSITIONS = 256  # per output revolution
BEAM_SLICES = 4


def crank_tilts(model, q: np.ndarray) -> np.ndarray:
    """Each crank's tilt (rad): the chord between its two support journals over the support span, from the absolute
    coordinates ``q`` (rigid cranks: the body's tilt, to second order in it; beam cranks: the journals' stations)."""
    from exudyn.rigidBodyUtilities import RotXYZ2RotationMatrix

    half = 0.5 * model.spec.cranks.support_span_m
    out = []
    for k, node in enumerate(model.cranks.nodes):
        if model.cranks.beam is None:
            i = model.mbs.GetNodeODE2Index(node)
            chord = RotXYZ2RotationMatrix(q[i + 3:i + 6]) @ np.array([0.0, 0.0, 2.0 * half])
        else:
            shaft, b = model.cranks.stations[k], model.cranks.beam
            i, j = (model.mbs.GetNodeODE2Index(shaft[s]) for s in (b.output_support, b.input_support))
            chord = q[i:i + 3] - q[j:j + 3] + np.array([0.0, 0.0, 2.0 * half])
        out.append(math.hypot(chord[0], chord[1]) / (2.0 * half))
    return np.array(out)


def _run(spec, options: ModelOptions, positions: int) -> dict:
    """One run at rated torque over an output revolution: TE, the largest crank tilt over it, the solver's time."""
    model = build_reducer(spec, options=options)
    th = np.linspace(0.0, 2 * math.pi * model.ratio, positions + 1)[:-1]
    tilt = [0.0]

    def record(done: int, n: int) -> None:  # the system holds the step just converged (Exudyn's solvers)
        q = np.asarray(model.mbs.systemData.GetODE2Coordinates()) + model.reference
        tilt[0] = max(tilt[0], float(crank_tilts(model, q).max()))

    try:
        r = quasi_static(model, th, spec.rated_torque_Nm, progress=record, contact_states=False)
    except Exception as err:  # noqa: BLE001 - a row that does not converge is reported, not fatal
        return {"error": type(err).__name__}
    te = r.te_rad * ARCSEC_PER_RAD
    return {"mean_windup_arcsec": float(-te.mean()), "te_pp_arcsec": float(np.ptp(te)),
            "crank_tilt_arcsec": tilt[0] * ARCSEC_PER_RAD, "wall_s": r.wall_s}


def convergence_study(unit: str, positions: int = POSITIONS, slices: tuple[int, ...] = SLICES,
                      elements: tuple[int, ...] = ELEMENTS) -> dict:
    """The slice rows (rigid cranks, ``slices``) and the crank rows (4 slices: rigid, and beams of ``elements``)
    of ``unit`` over ``positions`` per output revolution."""
    spec = catalog.load(unit)
    _run(spec, ModelOptions.spatial_rigid(BEAM_SLICES, SpatialSettings(crank="beam")), 8)  # warm
    rows = [{"slices": ns, **_run(spec, ModelOptions.spatial_rigid(ns), positions)} for ns in slices]
    rigid = next((r for r in rows if r["slices"] == BEAM_SLICES), None)
    cranks = [{"crank": "rigid", **(rigid or _run(spec, ModelOptions.spatial_rigid(BEAM_SLICES), positions))}]
    cranks += [{"crank": f"beam, {n}", **_run(spec, ModelOptions.spatial_rigid(
        BEAM_SLICES, SpatialSettings(crank="beam", crank_elements=n)), positions)} for n in elements]
    return {"unit": unit, "positions": positions, "slices": rows, "cranks": cranks, "segments": segments(spec)}


def segments(spec) -> list[dict]:
    """Each beam segment of ``spec``'s cranks (one element per segment): its planes, radius and stiffness."""
    b = beam_layout(spec)
    z = b.station_z_m
    names = {b.gear: "gear", b.input_support: "input support", b.output_support: "output support",
             **{j: f"eccentric {d + 1}" for d, j in enumerate(b.eccentrics)}}
    out = []
    for j, r in enumerate(b.segment_radius_m):
        k = segment_stiffness(spec.materials.gears_cranks_discs, r, z[j + 1] - z[j])
        out.append({"from": names.get(j, "stack face"), "to": names.get(j + 1, "stack face"), "z0_m": z[j],
                    "z1_m": z[j + 1], "radius_m": r, "lateral_N_m": k[0], "bending_Nm_rad": k[3],
                    "torsion_Nm_rad": k[5]})
    return out


def _row(r: dict) -> str:
    if "error" in r:
        return f"does not converge ({r['error']}) | – | – | – |"
    return (f"{r['mean_windup_arcsec']:.3f} | {r['te_pp_arcsec']:.4f} | {r['crank_tilt_arcsec']:.1f} | "
            f"{r['wall_s']:.1f} |")


def table(studies: list[dict]) -> str:
    """The Markdown tables of :func:`convergence_study` results."""
    lines = ["<!-- generated by `python -m rvflex.scenarios.spatial_convergence --table "
             "docs/results/spatial_convergence.md`; do not edit -->", ""]
    for s in studies:
        lines += [f"**{s['unit']}**, rated torque, {s['positions']} positions over an output revolution.", "",
                  "| model | mean wind-up (″) | TE p-p (″) | largest crank tilt (″) | solve (s) |",
                  "|---|---:|---:|---:|---:|"]
        lines += [f"| rigid cranks, {r['slices']} slices | " + _row(r) for r in s["slices"]]
        lines += [f"| {r['crank']} cranks, {BEAM_SLICES} slices | " + _row(r) if r["crank"] == "rigid" else
                  f"| beam cranks, {r['crank'].split(', ')[1]} element(s)/segment, {BEAM_SLICES} slices | " + _row(r)
                  for r in s["cranks"]]
        lines += ["", "| segment | z (mm) | radius (mm) | lateral (N/µm) | bending (kN·m/rad) | torsion (kN·m/rad) |",
                  "|---|---|---:|---:|---:|---:|"]
        lines += [f"| {g['from']} – {g['to']} | {1e3 * g['z0_m']:.1f} … {1e3 * g['z1_m']:.1f} | "
                  f"{1e3 * g['radius_m']:.1f} | {g['lateral_N_m'] / 1e6:.0f} | {g['bending_Nm_rad'] / 1e3:.0f} | "
                  f"{g['torsion_Nm_rad'] / 1e3:.0f} |" for g in s["segments"]]
        lines.append("")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m rvflex.scenarios.spatial_convergence",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("--units", nargs="+", default=list(catalog.names()), help="built-in units (default: all)")
    p.add_argument("--positions", type=int, default=POSITIONS, help=f"per output revolution (default {POSITIONS})")
    p.add_argument("--table", help="write the Markdown tables to this path")
    args = p.parse_args(argv)
    import exudyn

    quiet, exudyn.config.printToConsole = exudyn.config.printToConsole, False  # a failing row's solver banners
    try:
        text = table([convergence_study(unit, args.positions) for unit in args.units])
    finally:
        exudyn.config.printToConsole = quiet
    print(text)
    if args.table:
        from pathlib import Path

        from rvflex.io import write_text

        write_text(Path(args.table), text + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

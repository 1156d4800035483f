"""Seed 004's tolerance design on the rigid RV-40E: single-factor design of its ten
characteristics and the L16(4^5) design of the five sensitive ones; our sensitive/insensitive
classification against the paper's.

    python -m rvflex.scenarios.tolerance_doe out/tolerance_doe
"""

from __future__ import annotations

from pathlib import Path

from rvflex.choices import Executor
from rvflex.sweeps import classify, load_design, plot_main_effects, range_table, sweep

__all__ = ["PAPER_CLASS", "run_tolerance_doe"]

DESIGNS = Path(__file__).resolve().parent / "designs"
PAPER_CLASS = {  # seed 004 §4: sensitive e, Δr_p, Δr_rp, r_b, r_r; insensitive r1, r2, a_c, a_k
    "eccentricity": "sensitive", "moved_modification": "sensitive", "equidistant_modification": "sensitive",
    "pin_circle_radius": "sensitive", "pin_radius": "sensitive", "sun_pitch_radius": "insensitive",
    "planet_pitch_radius": "insensitive", "disc_bore_distance": "insensitive",
    "input_carrier_hole_distance": "insensitive", "output_carrier_hole_distance": "insensitive",
}


def run_tolerance_doe(out: Path, executor: Executor = "process") -> dict[str, list[dict]]:
    """Run both designs (resumable stores under ``out``); returns each design's range table
    with our class and the paper's."""
    tables = {}
    for name in ("tolerance_single", "tolerance_l16"):
        design = load_design(DESIGNS / f"{name}.toml")
        res = sweep(design, out / f"{name}.sqlite", executor=executor)
        ranking = range_table(design, res.rows, "te_pp_arcsec")
        ours = classify(ranking)
        for r in ranking:
            r["class"] = ours[r["factor"]]
            r["paper"] = PAPER_CLASS[r["factor"]]
        plot_main_effects(design, ranking, "TE peak-to-peak (arcsec)", out / f"{name}_main_effects.png")
        tables[name] = ranking
    return tables


if __name__ == "__main__":
    import sys

    out = Path(sys.argv[1] if len(sys.argv) > 1 else "out/tolerance_doe")
    out.mkdir(parents=True, exist_ok=True)
    for name, ranking in run_tolerance_doe(out).items():
        print(f"\n{name}: range R of the level means of TE peak-to-peak")
        for r in ranking:
            agree = "" if r["class"] == r["paper"] else "   ≠ paper"
            print(f"  {r['factor']:30s} R = {r['range']:.4f}″  ours {r['class']:11s} paper {r['paper']}{agree}")
    print(f"\nplots and stores in {out}")

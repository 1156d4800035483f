"""Convergence of the flexible discs' TE in the FE settings: the loaded TE at rated torque
over one crank turn (1/z_b of an output revolution, where the elastic TE pattern repeats)
for a base reduction, the same with twice the fixed-interface modes, and with half the
element size — the study behind the defaults of the flexible fidelity. ``housing`` does the
same for the FE pin housing (rigid discs, so the housing's share stands alone).

    python -m rvflex.scenarios.fe_convergence out/ [discs|housing]
"""

from __future__ import annotations

import math
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from rvflex.choices import ConvergencePart, check_choice
from rvflex.fe.reduce import PartSettings
from rvflex.geometry.formulas import ARCSEC_PER_RAD
from rvflex.model import build_reducer
from rvflex.options import DISC_FE, HOUSING_FE, ModelOptions
from rvflex.solve import quasi_static
from rvflex.spec import ReducerSpec

__all__ = ["CASES", "HOUSING_CASES", "fe_convergence"]

CASES: tuple[tuple[str, PartSettings], ...] = (
    ("base: 8 mm linear tets, 12 modes", replace(DISC_FE, maxh_m=8e-3, mesh_order=1, n_modes=12, attach_per_tooth=0)),
    ("twice the modes (24)", replace(DISC_FE, maxh_m=8e-3, mesh_order=1, n_modes=24, attach_per_tooth=0)),
    ("half the element size (4 mm)", replace(DISC_FE, maxh_m=4e-3, mesh_order=1, n_modes=12, attach_per_tooth=0)),
    ("quadratic tets, 6 mm", replace(DISC_FE, maxh_m=6e-3, mesh_order=2, n_modes=12, attach_per_tooth=0)),
    ("+ 3 flank attachment modes per tooth", replace(DISC_FE, maxh_m=6e-3, mesh_order=2, n_modes=10,
                                                      attach_per_tooth=3)),
)
"""(name, disc reduction) of each case: variants of the preset's disc reduction (DISC_FE)."""

HOUSING_CASES: tuple[tuple[str, PartSettings], ...] = (
    ("8 mm linear tets, 8 modes (tests)", replace(HOUSING_FE, mesh_order=1)),
    ("8 mm linear, 24 modes", replace(HOUSING_FE, mesh_order=1, n_modes=24)),
    ("4 mm linear, 8 modes", replace(HOUSING_FE, maxh_m=4e-3, mesh_order=1)),
    ("8 mm quadratic, 8 modes (default)", HOUSING_FE),
    ("8 mm quadratic, attachment modes only", replace(HOUSING_FE, n_modes=0)),
    ("5 mm quadratic, 8 modes", replace(HOUSING_FE, maxh_m=5e-3)),
)
"""(name, housing reduction) of each case: variants of the preset's housing reduction (HOUSING_FE);
every one has the 2 in-plane attachment modes per pin seat."""


def fe_convergence(spec: ReducerSpec, positions: int = 32, cases: tuple[tuple[str, PartSettings], ...] | None = None,
                   progress=print, part: ConvergencePart = "discs") -> list[dict]:
    """Rows ``{case, n_modes, n_nodes, te_pp_arcsec, mean_windup_arcsec, s_per_step, f1_hz,
    reduce_s}`` for the rigid unit and each reduction of ``cases`` (default :data:`CASES` for
    ``part="discs"``, :data:`HOUSING_CASES` for ``"housing"``; catalogue geometry, no
    manufacturing errors, rated torque); each model is ``ModelOptions(**{part: settings})``,
    the other parts rigid. ``f1_hz`` is the first fixed-interface eigenfrequency, ``reduce_s``
    the cold reduction's wall time."""
    check_choice("part", part, ConvergencePart)
    cases = cases if cases is not None else (CASES if part == "discs" else HOUSING_CASES)
    theta = np.linspace(0.0, 2 * math.pi * spec.nominal_ratio / spec.cycloid.pin_count, positions, endpoint=False)
    rows = []
    for name, settings in ((f"rigid {part}", None), *cases):
        model = build_reducer(spec, None, ModelOptions() if settings is None else ModelOptions(**{part: settings}))
        red = model.reduced_disc if part == "discs" else model.reduced_housing
        t0 = time.perf_counter()
        te = quasi_static(model, theta, spec.rated_torque_Nm).te_rad * ARCSEC_PER_RAD
        row = {"case": name, "n_modes": red.n_modes if red else 0, "n_nodes": red.n_nodes if red else 0,
               "te_pp_arcsec": float(np.ptp(te)), "mean_windup_arcsec": float(te.mean()),
               "s_per_step": (time.perf_counter() - t0) / positions,
               "f1_hz": float(red.freqs_hz[0]) if red is not None and red.freqs_hz.size else float("nan"),
               "reduce_s": float(red.wall_s) if red is not None else float("nan")}
        rows.append(row)
        progress(f"{name:40s} modes {row['n_modes']:4d} nodes {row['n_nodes']:6d}: TE pp {row['te_pp_arcsec']:7.3f}″, "
                 f"wind-up {row['mean_windup_arcsec']:8.3f}″, {row['s_per_step']:.3f} s/step")
    return rows


if __name__ == "__main__":
    import csv
    import sys

    from rvflex import catalog

    out = Path(sys.argv[1] if len(sys.argv) > 1 else "out")
    out.mkdir(parents=True, exist_ok=True)
    which = sys.argv[2] if len(sys.argv) > 2 else "discs"
    result = fe_convergence(catalog.load("rv40e"), part=which)
    name = "fe_convergence.csv" if which == "discs" else f"fe_convergence_{which}.csv"
    with open(out / name, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(result[0]))
        w.writeheader()
        w.writerows(result)
    print("wrote", out / name)

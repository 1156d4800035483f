"""Convergence of the flexible discs' TE in the FE settings: the loaded TE at rated torque
over one crank turn (1/z_b of an output revolution, where the elastic TE pattern repeats)
for a base reduction, the same with twice the fixed-interface modes, and with half the
element size — the study behind the defaults of the flexible fidelity.

    python -m rvflex.scenarios.fe_convergence out/
"""

from __future__ import annotations

import math
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from rvflex.fe.reduce import PartSettings
from rvflex.geometry.formulas import ARCSEC_PER_RAD
from rvflex.model import build_reducer
from rvflex.options import DISC_FE, ModelOptions
from rvflex.solve import quasi_static
from rvflex.spec import ReducerSpec

__all__ = ["CASES", "fe_convergence"]

CASES: tuple[tuple[str, PartSettings], ...] = (
    ("base: 8 mm linear tets, 12 modes", replace(DISC_FE, maxh_m=8e-3, mesh_order=1, n_modes=12, attach_per_tooth=0)),
    ("twice the modes (24)", replace(DISC_FE, maxh_m=8e-3, mesh_order=1, n_modes=24, attach_per_tooth=0)),
    ("half the element size (4 mm)", replace(DISC_FE, maxh_m=4e-3, mesh_order=1, n_modes=12, attach_per_tooth=0)),
    ("quadratic tets, 6 mm", replace(DISC_FE, maxh_m=6e-3, mesh_order=2, n_modes=12, attach_per_tooth=0)),
    ("+ 3 flank attachment modes per tooth", replace(DISC_FE, maxh_m=6e-3, mesh_order=2, n_modes=10,
                                                      attach_per_tooth=3)),
)
"""(name, disc reduction) of each case: variants of the preset's disc reduction (DISC_FE)."""


def fe_convergence(spec: ReducerSpec, positions: int = 32, cases: tuple[tuple[str, PartSettings], ...] = CASES,
                   progress=print) -> list[dict]:
    """Rows ``{case, n_modes, n_nodes, te_pp_arcsec, mean_windup_arcsec, s_per_step}`` for the
    rigid unit and each disc reduction of ``cases`` (catalogue geometry, no manufacturing
    errors, rated torque); each model is ``ModelOptions(discs=settings)``."""
    theta = np.linspace(0.0, 2 * math.pi * spec.nominal_ratio / spec.cycloid.pin_count, positions, endpoint=False)
    rows = []
    for name, settings in (("rigid discs", None), *cases):
        model = build_reducer(spec, None, ModelOptions() if settings is None else ModelOptions(discs=settings))
        red = model.reduced_disc
        t0 = time.perf_counter()
        te = quasi_static(model, theta, spec.rated_torque_Nm).te_rad * ARCSEC_PER_RAD
        row = {"case": name, "n_modes": red.n_modes if red else 0, "n_nodes": red.n_nodes if red else 0,
               "te_pp_arcsec": float(np.ptp(te)), "mean_windup_arcsec": float(te.mean()),
               "s_per_step": (time.perf_counter() - t0) / positions}
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
    result = fe_convergence(catalog.load("rv40e"))
    with open(out / "fe_convergence.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(result[0]))
        w.writeheader()
        w.writerows(result)
    print("wrote", out / "fe_convergence.csv")

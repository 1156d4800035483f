"""Reversal backlash (seed 002): the output angle lost when the input reverses.

Quasi-static: the input turns forward over a window and back over the same window with an
output load that resists the motion (so it changes sign at the reversal, as a friction or
process load does); the reversal backlash is the mean distance between the forward and the
reverse output branches at equal input angle. With a small load (default 3 % of rated, the
catalogue's lost-motion level) it is the free play plus the small elastic turn at that load.

    python -m rvflex.scenarios.reversal_backlash out/
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rvflex.geometry.formulas import ARCMIN_PER_RAD
from rvflex.model import build_reducer, check_fidelity
from rvflex.solve import QuasiStaticResult, quasi_static
from rvflex.spec import ErrorSpec, ReducerSpec, SpecError

__all__ = ["ReversalBacklash", "run_reversal_backlash", "write_backlash_outputs", "DEFAULT_LOAD_FRACTION"]

DEFAULT_LOAD_FRACTION = 0.03


@dataclass(frozen=True)
class ReversalBacklash:
    """Reducer, errors, resisting load (N·m), input window (output degrees), positions and
    fidelity ("rigid" or "flexible")."""

    spec: ReducerSpec
    errors: ErrorSpec
    load_Nm: float
    window_out_deg: float = 3.0
    positions: int = 60
    fidelity: str = "rigid"
    fe: tuple[tuple[str, float], ...] = ()  # reduction settings of the flexible discs (rvflex.fe.reduce.PartSettings)

    def __post_init__(self) -> None:
        self.spec.check_torque("--load", self.load_Nm)
        check_fidelity(self.fidelity)
        if not self.positions >= 8:
            raise SpecError("--positions", self.positions, "must be at least 8")


def run_reversal_backlash(sc: ReversalBacklash) -> tuple[float, QuasiStaticResult, QuasiStaticResult]:
    """Reversal backlash (arcmin) and the forward and reverse runs."""
    model = build_reducer(sc.spec, sc.errors, sc.fidelity, fe=dict(sc.fe))
    span = math.radians(sc.window_out_deg) * model.ratio
    grid = np.linspace(0.0, span, sc.positions)
    fwd = quasi_static(model, grid, sc.load_Nm)
    rev = quasi_static(model, grid[::-1], sc.load_Nm)
    lost = float(np.mean(fwd.theta_out - rev.theta_out[::-1])) * ARCMIN_PER_RAD
    return abs(lost), fwd, rev


def write_backlash_outputs(out: Path, lost: float, fwd: QuasiStaticResult, rev: QuasiStaticResult,
                           sc: ReversalBacklash) -> list[Path]:
    """Write backlash.csv and backlash.png (both output branches against the input angle)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    csv = out / "backlash.csv"
    np.savetxt(csv, np.column_stack([fwd.theta_in, fwd.te_rad, rev.te_rad[::-1]]), delimiter=",",
               header="theta_in_rad,te_forward_rad,te_reverse_rad", comments="", fmt="%.12g")
    fig, ax = plt.subplots(figsize=(8, 4.5), layout="constrained")
    x = np.degrees(fwd.theta_in / fwd.ratio)
    ax.plot(x, fwd.te_rad * ARCMIN_PER_RAD, label="forward")
    ax.plot(x, rev.te_rad[::-1] * ARCMIN_PER_RAD, label="reverse")
    ax.set_xlabel("output angle (°)")
    ax.set_ylabel("TE (arcmin)")
    ax.set_title(f"{sc.spec.name}: reversal backlash {lost:.4f}′ at ±{sc.load_Nm:g} N·m")
    ax.grid(alpha=0.3)
    ax.legend()
    png = out / "backlash.png"
    fig.savefig(png, dpi=120)
    plt.close(fig)
    return [csv, png]


if __name__ == "__main__":
    import sys

    from rvflex import catalog

    spec = catalog.load("rv40e")
    sc = ReversalBacklash(spec, ErrorSpec(), DEFAULT_LOAD_FRACTION * spec.rated_torque_Nm)
    lost, f, r = run_reversal_backlash(sc)
    print(f"reversal backlash {lost:.4f}′")
    print(write_backlash_outputs(Path(sys.argv[1] if len(sys.argv) > 1 else "out"), lost, f, r, sc))

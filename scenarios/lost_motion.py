"""Torsional hysteresis test (input locked, output torque 0 → +T_r → −T_r → 0): lost motion,
hysteresis loss, torsional stiffness and backlash (the computation behind ``rvflex lost-motion``).

Run as a script for the catalogue RV-40E::

    python -m rvflex.scenarios.lost_motion out/
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rvflex.geometry.formulas import ARCSEC_PER_RAD
from rvflex.metrics import HysteresisMetrics, hysteresis_metrics
from rvflex.model import build_reducer, check_fidelity
from rvflex.solve import TorqueStepResult, hysteresis_cycle, torque_stepping
from rvflex.spec import ErrorSpec, ReducerSpec, SpecError

__all__ = ["LostMotion", "run_lost_motion", "write_lost_motion_outputs"]


@dataclass(frozen=True)
class LostMotion:
    """Scenario settings: reducer, errors, torque amplitude (default rated, N·m), torque steps,
    fidelity ("rigid" or "flexible": FE-reduced discs)."""

    spec: ReducerSpec
    errors: ErrorSpec
    torque_Nm: float
    steps: int = 200
    fidelity: str = "rigid"
    fe: tuple[tuple[str, float], ...] = ()  # reduction settings of the flexible discs (rvflex.fe.reduce.PartSettings)

    def __post_init__(self) -> None:
        self.spec.check_torque("--torque", self.torque_Nm)
        check_fidelity(self.fidelity)
        if not self.steps >= 40:
            raise SpecError("--steps", self.steps, "must be at least 40 torque steps")


def run_lost_motion(scenario: LostMotion, progress=None) -> tuple[TorqueStepResult, HysteresisMetrics]:
    """Run the torque cycle and evaluate the catalogue metrics."""
    model = build_reducer(scenario.spec, scenario.errors, scenario.fidelity, fe=dict(scenario.fe))
    res = torque_stepping(model, hysteresis_cycle(scenario.torque_Nm, scenario.steps), progress=progress)
    return res, hysteresis_metrics(res.torque_Nm, res.theta_out, scenario.torque_Nm)


def write_lost_motion_outputs(out: Path, res: TorqueStepResult, met: HysteresisMetrics,
                              scenario: LostMotion) -> list[Path]:
    """Write hysteresis.csv and hysteresis.png (the loop with its metrics marked)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    arcmin = res.theta_out * ARCSEC_PER_RAD / 60.0
    csv = out / "hysteresis.csv"
    np.savetxt(csv, np.column_stack([res.torque_Nm, res.theta_out, arcmin]), delimiter=",",
               header="torque_Nm,theta_out_rad,theta_out_arcmin", comments="", fmt="%.12g")
    fig, ax = plt.subplots(figsize=(8, 5.2), layout="constrained")
    ax.plot(arcmin, res.torque_Nm, "-", lw=1.2, marker=".", ms=3)
    t3 = 0.03 * scenario.torque_Nm
    ax.axhspan(-t3, t3, color="C1", alpha=0.15, label=f"±3 % T: lost motion {met.lost_motion_arcmin:.3f}′")
    ax.axhline(0.0, color="0.4", lw=0.6)
    ax.set_xlabel("output angle (arcmin)")
    ax.set_ylabel("output torque (N·m)")
    ax.set_title(f"{scenario.spec.name}: torsional hysteresis, input locked — stiffness "
                 f"{met.torsional_stiffness_Nm_per_arcmin:.1f} N·m/arcmin, backlash {met.backlash_arcmin:.3f}′, "
                 f"hysteresis loss {met.hysteresis_loss_arcmin:.3f}′", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left")
    png = out / "hysteresis.png"
    fig.savefig(png, dpi=120)
    plt.close(fig)
    return [csv, png]


if __name__ == "__main__":
    import sys

    from rvflex import catalog

    spec = catalog.load("rv40e")
    sc = LostMotion(spec, ErrorSpec(), spec.rated_torque_Nm)
    r, m = run_lost_motion(sc)
    print(m)
    print(write_lost_motion_outputs(Path(sys.argv[1] if len(sys.argv) > 1 else "out"), r, m, sc))

"""Loaded transmission error (the computation behind ``rvflex te``).

Run as a script for the RV-40E with seed 001's Table 2 errors at rated load::

    python -m rvflex.scenarios.loaded_te out/
"""

from __future__ import annotations

import dataclasses as dc
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rvflex.geometry.formulas import ARCSEC_PER_RAD
from rvflex.metrics import TEMetrics, order_spectrum, te_metrics
from rvflex.model import build_reducer, check_fidelity
from rvflex.solve import QuasiStaticResult, dynamic, quasi_static
from rvflex.spec import ErrorSpec, ReducerSpec, SpecError

__all__ = ["LoadedTE", "perfect_spec", "run_loaded_te", "seed001_errors", "write_te_outputs"]


@dataclass(frozen=True)
class LoadedTE:
    """Scenario settings: reducer, errors, output load (N·m), output revolutions, positions per
    output revolution, direction (+1 forward, −1 reverse), mode, output speed (rpm), time
    step (s) and fidelity ("rigid" or "flexible": FE-reduced cycloid discs)."""

    spec: ReducerSpec
    errors: ErrorSpec
    load_Nm: float
    revolutions: float = 1.0
    positions_per_rev: int = 2048
    direction: int = 1
    mode: str = "quasi-static"
    speed_out_rpm: float = 15.0
    step_s: float = 1e-4
    fidelity: str = "rigid"
    fe: tuple[tuple[str, float], ...] = ()  # reduction settings of the flexible discs (rvflex.fe.reduce.PartSettings)

    def __post_init__(self) -> None:
        check_fidelity(self.fidelity)
        self.spec.check_torque("--load", self.load_Nm, allow_zero=True)
        if not self.revolutions > 0:
            raise SpecError("--revs", self.revolutions, "must be positive (output revolutions)")
        if not self.positions_per_rev >= 16:
            raise SpecError("--positions", self.positions_per_rev, "must be at least 16 per output revolution")
        if self.direction not in (1, -1):
            raise SpecError("direction", self.direction, "must be +1 (forward) or -1 (reverse)")
        if self.mode not in ("quasi-static", "dynamic"):
            raise SpecError("--mode", self.mode, "must be 'quasi-static' or 'dynamic'")
        if self.mode == "dynamic" and not self.speed_out_rpm > 0:
            raise SpecError("--speed-out", self.speed_out_rpm, "must be positive in dynamic mode (rpm at the output)")
        if self.mode == "dynamic" and self.direction < 0:
            raise SpecError("--direction", "reverse", "dynamic runs go forward (reverse: quasi-static)")


def perfect_spec(spec: ReducerSpec) -> ReducerSpec:
    """The theoretical reducer: no tooth modification, no gear backlash, no bearing clearance."""
    c, b = spec.cycloid, spec.bearings
    return dc.replace(
        spec,
        cycloid=dc.replace(c, modification=dc.replace(c.modification, moved_m=0.0, equidistant_m=0.0, tip_amount_m=0.0,
                                                      root_amount_m=0.0, compensation_m=0.0)),
        input_stage=dc.replace(spec.input_stage, backlash_m=0.0),
        bearings=dc.replace(b, crank_support=dc.replace(b.crank_support, clearance_m=0.0),
                            eccentric=dc.replace(b.eccentric, clearance_m=0.0), main=dc.replace(b.main, clearance_m=0.0)))


def run_loaded_te(scenario: LoadedTE, progress=None) -> tuple[QuasiStaticResult, TEMetrics]:
    """Loaded TE over whole output revolutions, quasi-static or dynamic (the constant-speed part
    after the ramp, resampled at ``positions_per_rev``)."""
    model = build_reducer(scenario.spec, scenario.errors, scenario.fidelity, fe=dict(scenario.fe))
    if scenario.mode == "dynamic":
        ramp = 0.2
        dyn = dynamic(model, scenario.speed_out_rpm, scenario.revolutions, scenario.load_Nm, step_s=scenario.step_s,
                      ramp_s=ramp)
        n = int(round(scenario.positions_per_rev * scenario.revolutions))
        th_start = float(np.interp(ramp, dyn.time_s, dyn.theta_in))  # constant speed from here on
        theta = th_start + np.linspace(0.0, 2 * math.pi * scenario.revolutions * model.ratio, n, endpoint=False)
        te = np.interp(theta, dyn.theta_in, dyn.te_rad)
        res = QuasiStaticResult(theta, te + theta / model.ratio, te, np.zeros((n, 0, 0)), np.zeros((n, 0, 0)),
                                scenario.load_Nm, model.ratio, dyn.wall_s)
        if progress is not None:
            progress(n, n)
        return res, te_metrics(res.te_rad, scenario.revolutions)
    n = int(round(scenario.positions_per_rev * scenario.revolutions))
    theta = np.linspace(0.0, 2 * math.pi * scenario.revolutions * model.ratio, n, endpoint=False)
    if scenario.direction < 0:
        theta = -theta
    res = quasi_static(model, theta, scenario.load_Nm, progress=progress)
    return res, te_metrics(res.te_rad, scenario.revolutions)


def write_te_outputs(out: Path, res: QuasiStaticResult, metrics: TEMetrics, scenario: LoadedTE) -> list[Path]:
    """Write te.csv (per step), te.png (TE vs output angle with the order spectrum) and
    load_sharing.png (pin forces at the first position) to ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    te_as = res.te_rad * ARCSEC_PER_RAD
    out_deg = np.degrees(res.theta_in / res.ratio)
    csv = out / "te.csv"
    np.savetxt(csv, np.column_stack([res.theta_in, res.theta_out, out_deg, te_as]), delimiter=",",
               header="theta_in_rad,theta_out_rad,output_angle_deg,te_arcsec", comments="", fmt="%.12g")
    fig, (a0, a1) = plt.subplots(1, 2, figsize=(13, 4.6), layout="constrained", width_ratios=(2.2, 1))
    a0.plot(out_deg, te_as, lw=1.0)
    a0.axhline(metrics.mean_windup_arcsec, color="0.5", ls="--", lw=0.8, label=f"mean wind-up {metrics.mean_windup_arcsec:.1f}″")
    a0.set_xlabel("output angle (°)")
    a0.set_ylabel("TE = θ_out − θ_in/i (arcsec)")
    direction = "forward" if scenario.direction > 0 else "reverse"
    a0.set_title(f"{scenario.spec.name}: loaded TE at {scenario.load_Nm:g} N·m, {direction}, {scenario.mode}, "
                 f"peak-to-peak {metrics.te_pp_arcsec:.2f}″")
    a0.grid(alpha=0.3)
    a0.legend(fontsize=8)
    orders, amp = order_spectrum(res.te_rad, scenario.revolutions)
    keep = (orders > 0) & (orders <= max(3 * scenario.spec.cycloid.pin_count, 10))
    a1.bar(orders[keep], amp[keep], width=0.8 / scenario.revolutions)
    a1.set_xlabel("order (per output revolution)")
    a1.set_ylabel("amplitude (arcsec)")
    a1.set_title("order spectrum")
    a1.grid(alpha=0.3)
    te_png = out / "te.png"
    fig.savefig(te_png, dpi=120)
    plt.close(fig)
    if res.pin_force_N.size == 0:  # dynamic runs record the angles only
        return [csv, te_png]
    fig, ax = plt.subplots(figsize=(7, 4.2), layout="constrained")
    zb = res.pin_force_N.shape[2]
    for d in range(res.pin_force_N.shape[1]):
        ax.bar(np.arange(zb) + 0.4 * d - 0.2, res.pin_force_N[0, d], width=0.4, label=f"disc {d + 1}")
    ax.set_xlabel("pin number")
    ax.set_ylabel("normal force (N)")
    ax.set_title(f"pin load sharing at the first position ({scenario.load_Nm:g} N·m)")
    ax.legend()
    ax.grid(alpha=0.3)
    share_png = out / "load_sharing.png"
    fig.savefig(share_png, dpi=120)
    plt.close(fig)
    return [csv, te_png, share_png]


def seed001_errors(spec: ReducerSpec, seed: int = 1) -> ErrorSpec:
    """Seed 001 Table 2 errors on ``spec`` (µm values of the paper in SI). What the paper leaves
    open is chosen as stated: the ±8 µm pin-hole radial position error is a tolerance band,
    drawn uniformly per pin (``seed``); eccentricity-like errors at phase 0; pin diameter −8 µm
    (radius −4 µm); the 12 µm radial clearance on every eccentric (disc) bearing, where seed 001
    puts its clearance bushing."""
    nc, nd, zb = spec.cranks.count, spec.cycloid.disc_count, spec.cycloid.pin_count
    um = 1e-6
    pins = np.random.default_rng(seed).uniform(-8 * um, 8 * um, zb)
    return ErrorSpec(
        sun_base_eccentricity_m=10 * um, sun_runout_m=5 * um,
        planet_base_eccentricity_m=(10 * um,) * nc, planet_base_eccentricity_phase_rad=(0.0,) * nc,
        pin_radial_m=tuple(float(x) for x in pins), pin_radius_error_m=-4 * um,
        carrier_bore_eccentricity_m=(5 * um,) * nc, carrier_bore_eccentricity_phase_rad=(0.0,) * nc,
        carrier_runout_m=5 * um, pin_circle_radius_error_m=10 * um,
        crank_eccentricity_error_m=tuple((-2 * um, 2 * um)[k % 2] for k in range(nc)),
        eccentric_bearing_clearance_m=(12 * um,) * (nc * nd),
    )


if __name__ == "__main__":
    import sys

    from rvflex import catalog

    spec = catalog.load("rv40e")
    scenario = LoadedTE(spec, seed001_errors(spec), spec.rated_torque_Nm)
    res, met = run_loaded_te(scenario)
    paths = write_te_outputs(Path(sys.argv[1] if len(sys.argv) > 1 else "out"), res, met, scenario)
    print(f"TE peak-to-peak {met.te_pp_arcsec:.2f}″, mean wind-up {met.mean_windup_arcsec:.1f}″; wrote",
          ", ".join(map(str, paths)))

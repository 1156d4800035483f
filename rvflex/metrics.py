"""Catalogue metrics from results (DESIGN.md definitions).

TE = θ_out − θ_in/i; peak-to-peak over whole output revolutions; orders per output
revolution (order 1 = once per output turn).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rvflex.units import ARCSEC_PER_RAD

__all__ = ["HysteresisMetrics", "TEMetrics", "hysteresis_metrics", "te_metrics", "order_spectrum"]


@dataclass(frozen=True)
class TEMetrics:
    """TE figures in arcsec; ``orders``: (order, amplitude) pairs, largest amplitude first."""

    te_pp_arcsec: float
    te_min_arcsec: float
    te_max_arcsec: float
    mean_windup_arcsec: float
    orders: list[tuple[int, float]]


def order_spectrum(te_rad: np.ndarray, revolutions: float) -> tuple[np.ndarray, np.ndarray]:
    """Single-sided amplitude spectrum of TE sampled uniformly over ``revolutions`` whole output
    revolutions: orders (per output revolution) and amplitudes (arcsec)."""
    te = np.asarray(te_rad, float) * ARCSEC_PER_RAD
    n = len(te)
    spec = np.fft.rfft(te - te.mean()) / n
    amp = 2.0 * np.abs(spec)
    if n % 2 == 0:
        amp[-1] /= 2.0
    orders = np.arange(len(spec)) / revolutions
    return orders, amp


def te_metrics(te_rad: np.ndarray, revolutions: float, n_orders: int = 10) -> TEMetrics:
    """TE peak-to-peak, extremes, mean wind-up and the ``n_orders`` strongest integer orders."""
    te = np.asarray(te_rad, float) * ARCSEC_PER_RAD
    orders, amp = order_spectrum(te_rad, revolutions)
    integer = np.isclose(orders, np.round(orders)) & (orders > 0)
    idx = np.argsort(amp[integer])[::-1][:n_orders]
    top = [(int(round(orders[integer][i])), float(amp[integer][i])) for i in idx]
    return TEMetrics(float(np.ptp(te)), float(te.min()), float(te.max()), float(te.mean()), top)


@dataclass(frozen=True)
class HysteresisMetrics:
    """Catalogue figures of a torque cycle 0 → +T_r → −T_r → 0 with the input locked.

    lost_motion_arcmin: width between the branch midpoints at ±3 % T_r; hysteresis_loss_arcmin:
    width between the branches at zero torque; torsional_stiffness_Nm_per_arcmin: slope between
    50 % and 100 % T_r (mean of both signs); backlash_arcmin: distance at zero torque between
    the two elastic lines (50–100 % T_r, each sign) extrapolated;
    secant_stiffness_Nm_per_arcmin: 2·T_r over the loop's whole angular span from −T_r to
    +T_r, free play included (the overall stiffness a bench reads off the loop end points;
    seed 002 reports this kind of figure, which rises when the clearance shrinks, while the
    50–100 % slope is set by the loaded contacts alone).
    """

    lost_motion_arcmin: float
    hysteresis_loss_arcmin: float
    torsional_stiffness_Nm_per_arcmin: float
    backlash_arcmin: float
    secant_stiffness_Nm_per_arcmin: float


def _branch_angle(torque: np.ndarray, angle: np.ndarray, at: float) -> float:
    order = np.argsort(torque)
    return float(np.interp(at, torque[order], angle[order]))


def hysteresis_metrics(torque_Nm: np.ndarray, theta_out_rad: np.ndarray, rated_Nm: float) -> HysteresisMetrics:
    """Evaluate a cycle from :func:`rvflex.solve.hysteresis_cycle` (angles in rad)."""
    t = np.asarray(torque_Nm, float)
    a = np.asarray(theta_out_rad, float) * ARCSEC_PER_RAD / 60.0
    k_max, k_min = int(np.argmax(t)), int(np.argmin(t))
    # descending branch: +T → −T; ascending branch: −T → 0 joined with the first 0 → +T
    desc_t, desc_a = t[k_max:k_min + 1], a[k_max:k_min + 1]
    asc_t = np.concatenate([t[k_min:], t[:k_max + 1]])
    asc_a = np.concatenate([a[k_min:], a[:k_max + 1]])
    keep = np.r_[True, np.diff(asc_t) > 0]
    asc_t, asc_a = asc_t[keep], asc_a[keep]

    def mid(at: float) -> float:
        return 0.5 * (_branch_angle(desc_t, desc_a, at) + _branch_angle(asc_t, asc_a, at))

    lost = mid(0.03 * rated_Nm) - mid(-0.03 * rated_Nm)
    loss = abs(_branch_angle(desc_t, desc_a, 0.0) - _branch_angle(asc_t, asc_a, 0.0))
    lines = []
    for sign in (1.0, -1.0):
        sel = (sign * t >= 0.5 * rated_Nm - 1e-9) & (sign * t <= rated_Nm + 1e-9)
        slope, intercept = np.polyfit(a[sel], t[sel], 1)  # N·m per arcmin, and T at angle 0
        lines.append((slope, -intercept / slope))  # angle at zero torque
    stiffness = 0.5 * (lines[0][0] + lines[1][0])
    backlash = lines[0][1] - lines[1][1]
    secant = (t[k_max] - t[k_min]) / (a[k_max] - a[k_min])
    return HysteresisMetrics(float(lost), float(loss), float(stiffness), float(backlash), float(secant))

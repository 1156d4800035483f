"""Catalogue metrics from results (DESIGN.md definitions).

TE = θ_out − θ_in/i; peak-to-peak over whole output revolutions; orders per output
revolution (order 1 = once per output turn).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rvflex.geometry.formulas import ARCSEC_PER_RAD

__all__ = ["TEMetrics", "te_metrics", "order_spectrum"]


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

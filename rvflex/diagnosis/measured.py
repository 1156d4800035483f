"""Measured TE runs: the analysed window, its coverage, and a checked Fourier fit.

A bench logs TE in many ways: N samples per output revolution over [0, 2π) (the last sample one
step short of the full turn), inclusively over [0, 2π] (the first position repeated), over several
revolutions, over a partial last revolution, non-uniformly in angle (speed ripple, time-based
sampling), in either direction. None of these may change what the diagnosis sees, so the window is
chosen from the samples' own spacing, never from the nominal span:

- each sample stands for the interval up to the next one, so N samples with spacing Δ over
  (N − 1)·Δ cover N·Δ = one revolution;
- the window holds the largest whole number M ≥ 1 of revolutions those intervals cover, from the
  first sample in the direction of travel (an inclusive endpoint and a partial last revolution fall
  outside it);
- its coverage is the share of the revolution not lost in the largest gap between neighbouring
  positions (a gap of one typical spacing loses nothing); below :data:`MIN_COVERAGE` the run is
  refused.

The Fourier fit TE(p) = a₀ + Σ a_k cos kp + b_k sin kp (k = 1 … K) is refused, with a
:class:`~rvflex.diagnosis.errors.BenchError` naming the file and the reason, when it is not
overdetermined by :data:`MIN_SAMPLES_PER_ORDER` samples per fitted order, when its design is ill
conditioned (gaps that leave high orders undetermined), or when its reconstruction between the
samples does not reproduce the measured peak-to-peak (a fit that oscillates between the samples).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rvflex.diagnosis.errors import BenchError

__all__ = ["MAX_CONDITION", "MIN_COVERAGE", "MIN_SAMPLES_PER_ORDER", "TEFit", "TEWindow", "fit_te", "te_window"]

MIN_COVERAGE = 0.98  # share of an output revolution the analysed samples must cover
MIN_SAMPLES_PER_ORDER = 4  # samples in the window per fitted order (2 coefficients each): twice Nyquist
MAX_CONDITION = 1e3  # condition number of the column-normalised Fourier design (uniform sampling: ≈ 1.4)


@dataclass(frozen=True)
class TEWindow:
    """The analysed part of a TE run.

    Attributes
    ----------
    index : ndarray of int
        Indices of the samples in the window (file order).
    revolutions : int
        Whole output revolutions analysed.
    start_rad : float
        Position of the first sample (rad, forward coordinate).
    coverage : float
        Share of the revolution covered (1 − (largest gap − typical spacing)/2π).
    spacing_rad : float
        Typical (median) spacing of neighbouring positions (rad).
    samples_in_run : int
        Samples in the whole run.
    """

    index: np.ndarray
    revolutions: int
    start_rad: float
    coverage: float
    spacing_rad: float
    samples_in_run: int

    @property
    def samples(self) -> int:
        return len(self.index)

    def describe(self) -> dict:
        """JSON-ready summary (angles in degrees)."""
        return {"samples": int(self.samples), "samples_in_run": int(self.samples_in_run),
                "revolutions": int(self.revolutions), "start_deg": math.degrees(self.start_rad),
                "coverage": float(self.coverage), "spacing_deg": math.degrees(self.spacing_rad)}


def te_window(position_rad: np.ndarray, where: str) -> TEWindow:
    """The analysed window of a TE run with positions ``position_rad`` (output angle, rad, in
    file order; increasing or decreasing). ``where`` names the file in errors.

    Raises
    ------
    BenchError
        Fewer than 4 samples, positions that do not move one way, or a coverage below
        :data:`MIN_COVERAGE` of a revolution.
    """
    p = np.asarray(position_rad, float)
    if len(p) < 4:
        raise BenchError(where, f"{len(p)} samples: a TE run needs at least one output revolution of samples")
    travel = p - p[0]
    sign = 1.0 if travel[-1] >= 0 else -1.0
    s = sign * travel  # distance travelled from the first sample
    steps = np.diff(s)
    spacing = float(np.median(np.abs(steps))) if len(steps) else 0.0
    if not spacing > 0:
        raise BenchError(where, "the output angle does not advance (median spacing 0)")
    covered = float(s.max()) + spacing  # each sample stands for the interval up to the next one
    revs = max(1, int(math.floor(covered / (2 * math.pi) + 1e-6)))
    # the window [0, M·2π) less half a spacing: an inclusive endpoint (position 2π·M) stays out
    idx = np.nonzero(s < revs * 2 * math.pi - 0.5 * spacing)[0]
    ang = np.sort(np.mod(s[idx], 2 * math.pi))
    gaps = np.diff(np.r_[ang, ang[0] + 2 * math.pi]) if len(ang) else np.array([2 * math.pi])
    coverage = float(min(1.0, 1.0 - (gaps.max() - spacing) / (2 * math.pi)))
    if coverage < MIN_COVERAGE:
        raise BenchError(where, f"the samples cover {coverage:.3f} of an output revolution (largest gap "
                                f"{math.degrees(gaps.max()):.2f}° at a typical spacing of {math.degrees(spacing):.3g}°); "
                                f"the order analysis needs at least {MIN_COVERAGE:g} of a whole revolution")
    return TEWindow(idx, revs, float(p[0]), coverage, spacing, len(p))


@dataclass(frozen=True)
class TEFit:
    """A checked least-squares Fourier fit of one TE run (arcsec).

    ``mean``, ``cos``/``sin`` the coefficients a₀, a_k, b_k (k = 1 … K); ``rms_residual`` the rms
    misfit at the samples; ``pp_measured`` the peak-to-peak of the samples in the window and
    ``pp_fit`` that of the reconstruction on a fine uniform grid; ``condition`` the design's
    condition number.
    """

    mean: float
    cos: np.ndarray
    sin: np.ndarray
    rms_residual: float
    pp_measured: float
    pp_fit: float
    condition: float

    def describe(self) -> dict:
        return {"te_pp_measured_arcsec": float(self.pp_measured), "te_pp_fit_arcsec": float(self.pp_fit),
                "fit_rms_residual_arcsec": float(self.rms_residual), "fit_condition": float(self.condition)}


def fit_te(position_rad: np.ndarray, te_arcsec: np.ndarray, max_order: int, where: str) -> TEFit:
    """Least-squares Fourier fit of orders 0 … ``max_order`` to TE samples (positions in rad,
    TE in arcsec, the window's samples), with the checks of the module docstring.

    Raises
    ------
    BenchError
        Too few samples per order, an ill-conditioned design, or a fit whose reconstruction
        disagrees with the measured peak-to-peak.
    """
    p = np.asarray(position_rad, float)
    te = np.asarray(te_arcsec, float)
    n, K = len(p), int(max_order)
    if n < MIN_SAMPLES_PER_ORDER * K:
        raise BenchError(where, f"{n} samples in the analysed window for {K} orders: the Fourier fit needs at least "
                                f"{MIN_SAMPLES_PER_ORDER} samples per fitted order ({MIN_SAMPLES_PER_ORDER * K}); "
                                f"log more samples per revolution")
    k = np.arange(1, K + 1)
    kp = np.outer(p, k)
    A = np.empty((n, 2 * K + 1))
    A[:, 0] = 1.0
    A[:, 1:K + 1] = np.cos(kp)
    A[:, K + 1:] = np.sin(kp)
    scale = np.linalg.norm(A, axis=0)
    coef, _, rank, sv = np.linalg.lstsq(A / scale, te, rcond=None)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf
    if rank < A.shape[1] or cond > MAX_CONDITION:
        raise BenchError(where, f"the Fourier fit of orders 1…{K} is ill conditioned (condition number {cond:.3g} > "
                                f"{MAX_CONDITION:g}): the samples leave high orders undetermined (gaps or clustered "
                                f"positions); sample the revolution more evenly")
    coef = coef / scale
    res = te - A @ coef
    rms = float(np.sqrt(np.mean(res**2)))
    grid = np.linspace(0.0, 2 * math.pi, max(8 * K, 1024), endpoint=False)
    kg = np.outer(grid, k)
    recon = coef[0] + np.cos(kg) @ coef[1:K + 1] + np.sin(kg) @ coef[K + 1:]
    pp_meas = float(te.max() - te.min())
    pp_fit = float(recon.max() - recon.min())
    # noise widens the samples' peak-to-peak by up to a few rms; a fit that oscillates between the
    # samples (too few of them, a wrong window) makes the reconstruction's far larger
    tol = 0.25 * pp_meas + 8.0 * rms + 0.1
    if abs(pp_fit - pp_meas) > tol:
        raise BenchError(where, f"the Fourier fit does not reproduce the measurement: reconstructed TE peak-to-peak "
                                f"{pp_fit:.4g}″ against {pp_meas:.4g}″ measured (rms misfit {rms:.3g}″); the samples "
                                f"do not determine orders up to {K}")
    return TEFit(float(coef[0]), coef[1:K + 1].copy(), coef[K + 1:].copy(), rms, pp_meas, pp_fit, cond)

"""The feature vector the diagnosis compares, of model runs and bench runs alike.

- a TE run: its mean (the wind-up) and its Fourier coefficients a_k, b_k of orders 1 … K per
  output revolution (arcsec), TE(p) = mean + Σ a_k cos kp + b_k sin kp, p = θ_in/i the
  position in output revolutions (rad). Measured coefficients come from a least-squares fit
  to the samples (non-uniform sampling and speed ripple are harmless), model coefficients
  from the FFT of the uniform grid.
- a hysteresis run: the output angle (arcsec) on the descending and ascending branch at
  fixed fractions of the torque amplitude.

The unknown encoder origin enters as a position shift δ common to all TE runs
(:func:`shift_measured`), the unknown constant offset as a nuisance (one for all TE runs,
one per hysteresis run): both are estimated by the fit, never assumed.
"""

from __future__ import annotations

import numpy as np

from rvflex.diagnosis.plan import BRANCH_FRACTIONS, Layout, PlanRun, feature_layout
from rvflex.diagnosis.replay import Response
from rvflex.diagnosis.settings import DiagnosisSettings
from rvflex.geometry.formulas import ARCSEC_PER_RAD

__all__ = ["branch_angles", "features", "measured_features", "measured_runs", "shift_measured"]


def branch_angles(torque: np.ndarray, theta: np.ndarray, torque_max: float) -> np.ndarray:
    """Output angle (same unit as ``theta``) on the descending (+T → −T) and then the ascending
    branch, each at the torques ±HYST_FRACTIONS·torque_max in increasing order (4·12 values).
    """
    t = np.asarray(torque, float)
    a = np.asarray(theta, float)
    k_max, k_min = int(np.argmax(t)), int(np.argmin(t))
    if k_max > k_min:  # a cycle that goes negative first: read it mirrored
        t, a = -t, -a
        k_max, k_min = int(np.argmax(t)), int(np.argmin(t))
        flip = -1.0
    else:
        flip = 1.0
    desc = (t[k_max:k_min + 1], a[k_max:k_min + 1])
    asc = (np.concatenate([t[k_min:], t[:k_max + 1]]), np.concatenate([a[k_min:], a[:k_max + 1]]))
    at = BRANCH_FRACTIONS * torque_max
    out = []
    for bt, ba in (desc, asc):
        o = np.argsort(bt, kind="stable")
        bt, ba = bt[o], ba[o]
        keep = np.r_[True, np.diff(bt) > 0]
        out.append(np.interp(at, bt[keep], ba[keep]))
    if flip < 0:  # back to the true sign: the branches swap roles
        out = [-out[1][::-1], -out[0][::-1]]
    return np.concatenate(out)


def features(resp: Response, plan: tuple[PlanRun, ...], settings: DiagnosisSettings) -> tuple[np.ndarray, Layout]:
    """Feature vector (arcsec) of a model response and its layout."""
    lay = feature_layout(plan, settings.max_order)
    f = np.empty(lay.n)
    K = settings.max_order
    for r, p in enumerate(plan):
        if p.kind == "te":
            te = resp.te[r] * ARCSEC_PER_RAD
            c = np.fft.rfft(te) / len(te)
            f[lay.dc[r]] = c[0].real
            f[lay.cos[r]] = 2 * c[1:K + 1].real
            f[lay.sin[r]] = -2 * c[1:K + 1].imag
        else:
            f[lay.hyst[r]] = branch_angles(resp.torque[r], resp.theta[r] * ARCSEC_PER_RAD, p.torque_max_Nm)
    return f, lay


def measured_features(dataset, plan: tuple[PlanRun, ...], settings: DiagnosisSettings) -> tuple[np.ndarray, Layout]:
    """Feature vector (arcsec) of the bench runs, before the origin shift (see :func:`measured_runs`)."""
    f, lay, _ = measured_runs(dataset, plan, settings)
    return f, lay


def measured_runs(dataset, plan: tuple[PlanRun, ...], settings: DiagnosisSettings) -> tuple[np.ndarray, Layout, dict]:
    """Feature vector (arcsec) of the bench runs, before the origin shift, its layout, and per TE
    run what was analysed (``{run: {window and fit figures}}``).

    TE runs: a checked least-squares Fourier fit (orders 0 … K, :func:`rvflex.diagnosis.measured.fit_te`)
    of TE = θ_out − θ_in/i (or the TE column) against the position p over the run's analysed
    whole revolutions (:func:`rvflex.diagnosis.measured.te_window`).

    Raises
    ------
    BenchError
        A run whose samples cannot determine the orders (coverage, samples per order, conditioning,
        a reconstruction that disagrees with the measured peak-to-peak).
    """
    from rvflex.diagnosis.measured import fit_te, te_window

    lay = feature_layout(plan, settings.max_order)
    f = np.empty(lay.n)
    K = settings.max_order
    ratio = dataset.reducer.nominal_ratio
    info = {}
    for r, (run, p) in enumerate(zip(dataset.runs, plan)):
        if p.kind == "te":
            pos, te = run.te_samples(ratio)
            win = run.window or te_window(pos, run.file)
            fit = fit_te(pos[win.index], te[win.index] * ARCSEC_PER_RAD, K, run.file)
            f[lay.dc[r]] = fit.mean
            f[lay.cos[r]] = fit.cos
            f[lay.sin[r]] = fit.sin
            info[r] = {"file": run.file, "form": run.form, **win.describe(), **fit.describe()}
        else:
            f[lay.hyst[r]] = branch_angles(run.torque_Nm, run.theta_out_rad * ARCSEC_PER_RAD, p.torque_max_Nm)
    return f, lay, info


def shift_measured(f: np.ndarray, lay: Layout, delta: np.ndarray) -> np.ndarray:
    """Measured features with the position origin moved by ``delta`` (rad; scalar or array of G
    shifts → (n, G)): TE_shifted(p) = TE(p + δ), so a_k' = a_k cos kδ + b_k sin kδ,
    b_k' = −a_k sin kδ + b_k cos kδ. Means and hysteresis features do not change."""
    delta = np.atleast_1d(np.asarray(delta, float))
    out = np.repeat(f[:, None], len(delta), axis=1)
    k = np.arange(1, lay.max_order + 1)[:, None]
    c, s = np.cos(k * delta[None, :]), np.sin(k * delta[None, :])
    for r in lay.te_runs:
        a, b = f[lay.cos[r]][:, None], f[lay.sin[r]][:, None]
        out[lay.cos[r]] = a * c + b * s
        out[lay.sin[r]] = -a * s + b * c
    return out

"""What calibration says: the sentence on the calibrated nominal parameters, and whether the nominal
parameters within their priors reproduce an accepted effect (a tie, or no effect needed)."""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import lsq_linear

from rvflex.diagnose.linear import Candidate, Sensitivities
from rvflex.diagnose.nominal import describe_calibration
from rvflex.diagnose.verdict import SIGNATURE_TIE

__all__ = ["CALIBRATION_PREFERRED", "calibration_sentence", "calibration_ties"]


def _fmt_cal(row: dict) -> str:
    if "stiffness_scale" in row:
        return f"{row['name'].replace('_', ' ')} ×{row['stiffness_scale']:.2f}"
    if row["unit"] == "m":
        return f"{row['name'].replace('_', ' ')} {row['value'] * 1e6:.1f} µm"
    return f"{row['name'].replace('_', ' ')} {row['value']:.2f}"


def calibration_sentence(none: Candidate, nominal_model: Candidate, chosen, settings) -> str:
    rows = describe_calibration(none)
    if not rows:
        return "No nominal parameter calibrated."
    moved = [r for r in rows if abs(r["shift"]) > 0.5 * r["prior_sigma"]]
    bound = [r["name"] for r in rows if r["at_prior_bound"]]
    shrink = none.gap_shrink_pct
    s = (f"Calibration ({', '.join(_fmt_cal(r) for r in rows)}) closes {max(shrink, 0):.0f} % of the nominal "
         f"model's weighted gap.")
    if bound:
        s += f" {', '.join(bound)} ran into the bound of its prior range: the nominal parameter is off by more than assumed."
    if chosen is None and moved and shrink >= settings.min_shrink_pct:
        s += " Nominal parameters off; no unmodelled effect."
    return s


CALIBRATION_PREFERRED = 0.10  # nominal parameters reproducing an effect's change to within this: no effect needed


def calibration_ties(chosen: Candidate, cal, sens: Sensitivities, w) -> tuple[tuple[str, ...], tuple[str, ...], float]:
    """Nominal parameters whose columns, within their prior ranges (from their calibrated values),
    reproduce the accepted effect's fitted change to within SIGNATURE_TIE (weighted), the runs that
    would separate them, and the relative weighted residual of that reproduction."""
    if not cal or chosen.jacobian is None:
        return (), (), math.inf
    sig, i = np.zeros(len(w)), 0
    for e, xe in chosen.split():
        if not e.nominal:
            sig += chosen.jacobian[:, i:i + e.n] @ xe
        i += e.n
    sig = sig * w
    norm = float(np.linalg.norm(sig))
    if norm <= 0:
        return (), (), math.inf
    J = np.column_stack([sens.plus[c.name] for c in cal]) * w[:, None]
    now = {e.name: xe for e, xe in chosen.split() if e.nominal}  # room left from the calibrated values
    lo = np.concatenate([c.lower - now.get(c.name, c.center) for c in cal])
    hi = np.concatenate([c.upper - now.get(c.name, c.center) for c in cal])
    coef = lsq_linear(J, sig, bounds=(lo, hi), method="bvls").x
    ratio = float(np.linalg.norm(sig - J @ coef)) / norm
    if ratio > SIGNATURE_TIE:
        return (), (), ratio
    share = np.abs(coef) * np.linalg.norm(J, axis=0)
    names = tuple(c.name for c, s in zip(cal, share) if s > 0.1 * share.max())
    runs = tuple(dict.fromkeys(c.separating_runs for c in cal if c.name in names and c.separating_runs))
    return names, runs, ratio

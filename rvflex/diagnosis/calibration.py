"""What calibration says: the sentence on the calibrated nominal parameters, and whether the nominal
parameters within their priors reproduce an accepted effect (a tie, or no effect needed)."""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import lsq_linear

from rvflex.diagnosis.linear import Candidate, Sensitivities
from rvflex.diagnosis.nominal import SAME_QUANTITY, describe_calibration
from rvflex.diagnosis.verdict import SIGNATURE_TIE

__all__ = ["CALIBRATION_PREFERRED", "UNDETERMINED_INFO", "calibration_lookalikes", "calibration_sentence", "lookalike_sentence", "calibration_ties", "separable",
           "undetermined"]

UNDETERMINED_INFO = 1.0  # a prior σ of the parameter moves the weighted features by less: the runs do not determine it


def undetermined(cal, sens, w: np.ndarray, nuis: np.ndarray) -> dict[str, str]:
    """Nominal parameters these runs do not determine, with the reason: one prior σ of every
    parameter changes the weighted features by less than UNDETERMINED_INFO floor units once the
    offsets have taken their share (the data hold less about it than the prior). Calibrating such a
    parameter fits model-form mismatch and noise (measured: the first-stage mesh stiffness of the
    RV-40E moves the output's wind-up by 0.05″ over its prior range, 0.02 floor units, and the
    refinement drove it to either bound of its range); it is held at its nominal value."""
    cols = nuis[:, np.abs(nuis).sum(0) > 0] * w[:, None]
    q = np.linalg.qr(cols)[0] if cols.shape[1] else np.zeros((len(w), 0))
    out = {}
    for c in cal:
        info = 0.0
        for J in (sens.plus.get(c.name), sens.minus.get(c.name)):
            if J is None:
                continue
            Jw = J.reshape(len(w), -1) * w[:, None]
            Jw = Jw - q @ (q.T @ Jw)
            info = max(info, float(np.max(np.linalg.norm(Jw, axis=0) * np.asarray(c.prior_sigma))))
        if info < UNDETERMINED_INFO:
            out[c.name] = (f"not determined by these runs: over one prior σ it moves the weighted features by "
                           f"{info:.2g} floor units (< {UNDETERMINED_INFO:g}); held at its nominal value")
    return out


def _fmt_cal(row: dict) -> str:
    if "stiffness_scale" in row:
        return f"{row['name'].replace('_', ' ')} ×{row['stiffness_scale']:.2f}"
    if row["unit"] == "m":
        return f"{row['name'].replace('_', ' ')} {row['value'] * 1e6:.1f} µm"
    if row["param"] == "exponent_change":  # the law's exponent itself reads better than its change
        return f"{row['name'].replace('_', ' ')} F ∝ δ^{1.0 + row['value']:.2f}"
    return f"{row['name'].replace('_', ' ')} {row['value']:.2f}"


def calibration_sentence(none: Candidate, nominal_model: Candidate, chosen, settings, held: dict | None = None,
                         open_effect: bool = False, anchor_scale: float = 1.0) -> str:
    """The verdict's first sentence: the calibrated nominal parameters and how much of the gap they
    close. "Nominal parameters off; no unmodelled effect" only when no effect is accepted and none is
    left open (``open_effect``: a significant candidate that was not confirmed, or whose model
    evaluation failed — the verdict then says the gap it explains stays unexplained). Stiffness scales are
    stated against the model as specified (``anchor_scale`` times the calibrated component scale)."""
    rows = describe_calibration(none, anchor_scale=anchor_scale)
    kept = (f" Not determined by these runs, held at nominal: {', '.join(n.replace('_', ' ') for n in held)}."
            if held else "")
    if not rows:
        return "No nominal parameter calibrated." + kept
    moved = [r for r in rows if abs(r["shift"]) > 0.5 * r["prior_sigma"]]
    bound = [r["name"] for r in rows if r["at_prior_bound"] and r["cut_by"] is None]
    cut = [r for r in rows if r["at_prior_bound"] and r["cut_by"] is not None]
    shrink = none.gap_shrink_pct
    s = (f"Calibration ({', '.join(_fmt_cal(r) for r in rows)}) closes {max(shrink, 0):.0f} % of the nominal "
         f"model's weighted gap.")
    if bound:
        s += f" {', '.join(bound)} ran into the bound of its prior range: the nominal parameter is off by more than assumed."
    for r in cut:
        s += f" {r['name']} ran into the bound {r['cut_by']}: the unit calls for a value this spec does not allow."
    if chosen is None and not open_effect and moved and shrink >= settings.min_shrink_pct:
        s += " Nominal parameters off; no unmodelled effect."
    return s + kept


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
    now = {e.name: xe for e, xe in chosen.split() if e.nominal}
    return _reproduced(sig, cal, now, sens, w)[:3]


def calibration_lookalikes(effects, calibrated: Candidate, sens: Sensitivities, w, pool: float = 1.0,
                           threshold: float = 0.0) -> dict:
    """Effects the calibration can stand in for: those whose signature at typical size (each parameter's
    secant at its step, every column on its own) the nominal parameters, within their prior ranges from
    the calibrated values, reproduce to within CALIBRATION_PREFERRED — or to within SIGNATURE_TIE when what
    they leave of it is below the discrepancy: its weighted energy over the pooled discrepancy variance
    ``pool`` (floor units²) under ``threshold`` (the most evidence the effect could earn over the
    calibration at typical size; 0, the default: CALIBRATION_PREFERRED alone). Such an effect can be
    neither found nor excluded by these runs whatever its evidence; the report names it as a tie with the
    runs that would separate them. An effect on the same quantity as a nominal parameter
    (:data:`~rvflex.diagnosis.nominal.SAME_QUANTITY`) is what lies beyond that parameter's range and is
    not listed. A non-polar effect one of whose parameters alone the nominal parameters reproduce to within
    CALIBRATION_PREFERRED is listed with that part. Returns {effect name: (nominal parameters, separating runs,
    worst relative residual, the parameters concerned — () for the whole effect)}."""
    cal = tuple(e for e in calibrated.effects if e.nominal)
    now = {e.name: xe for e, xe in calibrated.split() if e.nominal}
    out = {}
    for e in effects:
        if e.nominal or e.name not in sens or e.name in SAME_QUANTITY:
            continue
        cols = [_reproduced(sens.plus[e.name][:, j] * prm.step, cal, now, sens, w) for j, prm in enumerate(e.params)]
        own = (e.separating_runs,) if e.separating_runs else ()
        worst = max(c[2] for c in cols)
        below_discrepancy = all(c[3] / pool < threshold for c in cols)
        names = tuple(dict.fromkeys(n for c in cols for n in c[0]))
        runs = tuple(dict.fromkeys(r for c in cols for r in c[1]))
        if names and (worst <= CALIBRATION_PREFERRED or below_discrepancy):
            out[e.name] = (names, tuple(dict.fromkeys(own + runs)), worst, ())
            continue
        # a part of the effect the calibration reproduces on its own (measured: the linear part of a hidden
        # series compliance, 96 % reproduced by the needle-bearing stiffness, while its stiffening part is
        # not): that part can be neither found nor excluded. Not for polar effects, whose components are
        # one quantity at an unknown angle
        part = [(prm.name, c) for prm, c in zip(e.params, cols) if c[0] and c[2] <= CALIBRATION_PREFERRED]
        if part and not e.polar:
            names = tuple(dict.fromkeys(n for _, c in part for n in c[0]))
            runs = tuple(dict.fromkeys(r for _, c in part for r in c[1]))
            out[e.name] = (names, tuple(dict.fromkeys(own + runs)), max(c[2] for _, c in part),
                           tuple(p for p, _ in part))
    return out


def _reproduced(sig: np.ndarray, cal, now: dict, sens: Sensitivities, w) -> tuple[tuple[str, ...], tuple[str, ...], float, float]:
    """How well the nominal parameters ``cal`` (from their values ``now``, within their ranges) reproduce the
    model change ``sig``: (the parameters that carry it, their separating runs, relative weighted residual,
    the weighted residual's energy; no names beyond SIGNATURE_TIE)."""
    if not cal:
        return (), (), math.inf, math.inf
    norm = float(np.linalg.norm(sig * w))
    if norm <= 0:
        return (), (), math.inf, math.inf
    coef, J, left = _reproduction(sig, cal, now, sens, w)
    ratio = left / norm
    if ratio > SIGNATURE_TIE:
        return (), (), ratio, left**2
    share = np.abs(coef) * np.linalg.norm(J, axis=0)
    names = tuple(c.name for c, s in zip(cal, share) if s > 0.1 * share.max())
    runs = tuple(dict.fromkeys(c.separating_runs for c in cal if c.name in names and c.separating_runs))
    return names, runs, ratio, left**2


def _reproduction(sig: np.ndarray, cal, now: dict, sens: Sensitivities, w) -> tuple[np.ndarray, np.ndarray, float]:
    """The nominal parameters' best reproduction of the model change ``sig`` (bounded least squares on the
    weighted features, each parameter within its prior range from its value in ``now``): their steps, their
    weighted columns, and the weighted norm of what is left."""
    sig = sig * w
    J = np.column_stack([sens.plus[c.name] for c in cal]) * w[:, None]
    lo = np.concatenate([c.lower - now.get(c.name, c.center) for c in cal])
    hi = np.concatenate([c.upper - now.get(c.name, c.center) for c in cal])
    coef = lsq_linear(J, sig, bounds=(lo, hi), method="bvls").x
    return coef, J, float(np.linalg.norm(sig - J @ coef))


def separable(sig: np.ndarray, calibrated: Candidate, sens: Sensitivities, w) -> tuple[float, float]:
    """The size of the model change ``sig`` (features) in floor units (its weighted norm, ``w`` = 1/floor),
    and of its part the calibrated nominal parameters of ``calibrated`` cannot reproduce within their prior
    ranges: the part a diagnosis that calibrates first can tell from a calibration with these runs."""
    size = float(np.linalg.norm(sig * w))
    cal = tuple(e for e in calibrated.effects if e.nominal and e.name in sens.plus)
    if not cal or size <= 0:
        return size, size
    now = {e.name: xe for e, xe in calibrated.split() if e.nominal}
    return size, _reproduction(sig, cal, now, sens, w)[2]


def lookalike_sentence(lookalikes: dict) -> str:
    """The verdict's sentence on the effects the calibration can stand in for ("" when none)."""
    if not lookalikes:
        return ""
    parts = [f"{name}{' (its ' + ', '.join(prm) + ')' if prm else ''} from the calibrated {', '.join(names)} "
             f"(within their prior ranges they reproduce {100 * (1 - ratio):.0f} % of its signature at typical size; "
             f"{'; '.join(runs) or 'no run named'} would separate them)"
             for name, (names, runs, ratio, prm) in lookalikes.items()]
    return "These runs cannot tell " + "; nor ".join(parts) + ": a tie, not an exclusion."

"""The verdict of a diagnosis: the withheld-run check, ties between candidates, and the sentence."""

from __future__ import annotations

import math
import re

import numpy as np
from scipy.optimize import lsq_linear

from rvflex.diagnosis.effects import Effect
from rvflex.diagnosis.features import shift_measured
from rvflex.diagnosis.linear import Candidate, Problem, bounds, lin_fit, prior_of
from rvflex.diagnosis.nominal import NOMINAL, SAME_QUANTITY
from rvflex.diagnosis.null import OFF_PERIOD_MARGIN, total_size
from rvflex.diagnosis.plan import part_label

__all__ = ["SIGNATURE_TIE", "TIE_RSS_RATIO", "acceptable", "equivalent", "fmt_mag", "fmt_pct", "is_significant",
           "not_evaluated_sentence", "reason_line", "undetermined_effect", "verdict", "withheld_check",
           "withheld_confirms"]

def _linearisation(c: Candidate, f0: np.ndarray):
    """(base features, Jacobian, reference point, lower, upper, prior) a candidate is predicted with:
    about its model-in-the-loop point when refined, else about the nominal model."""
    J = c.jacobian if c.jacobian is not None else np.zeros((len(f0), 0))
    if c.refined and len(c.x):
        base, x_ref = c.model_features, c.x
    elif c.refined:
        base, x_ref = c.model_features, np.zeros(0)
    elif c.base_features is not None:
        base, x_ref = c.base_features, c.base_x
    else:
        base, x_ref = f0, np.zeros(len(c.x))
    lo, hi = (c.lower, c.upper) if c.lower is not None else bounds(c.effects)
    return base, J, x_ref, lo, hi, prior_of(c.effects)


def _nominal_held(lin, c: Candidate):
    """``lin`` (see :func:`_linearisation`) with the nominal parameters of ``c`` held at its values."""
    base, J, x_ref, lo, hi, (pw, pc) = lin
    held = np.concatenate([np.full(e.n, e.nominal) for e in c.effects]) if c.effects else np.zeros(0, bool)
    free = ~held
    base = base + J[:, held] @ (c.x[held] - x_ref[held])
    return base, J[:, free], x_ref[free], lo[free], hi[free], (pw[free], pc[free])


def withheld_check(prob: Problem, plan, c: Candidate, ref: Candidate, f0, folds, hold_nominal: bool = False) -> dict:
    """Refit ``c`` on each fold's fitted runs only and predict its other runs (linearised about
    the candidate's point with its Jacobian; origin δ as fitted on all runs), and the same for the
    reference ``ref`` (the calibrated model for an effect, the nominal model for the calibration).
    With ``hold_nominal`` the nominal parameters of both stay at their values fitted on all runs and
    only the effect's parameters (and the offsets) are refitted: the check then asks whether the
    effect, found in some runs, predicts the others. Refitting six nominal parameters on a fold's
    one or two runs instead let them drift where that fold does not determine them (the torque
    cycle's stiffnesses from the TE runs alone): measured on the realistic self-check (seed 3), a
    hidden thermal mismatch then predicted the withheld runs −71 % "better", held +59 %.
    Improvement = 1 − rms(prediction residual)/rms(reference's prediction residual), per fold and
    pooled over every predicted run (weighted residual energy)."""
    doc = {"fitted_runs": list(dict.fromkeys(part_label(plan, p) for f, _ in folds for p in f)),
           "predicted_runs": [part_label(plan, p) for _, pr in folds for p in pr], "improvement_pct": None, "folds": []}
    if not folds:
        doc["note"] = "no run usable for the withheld check"
        return doc
    lay = prob.lay
    d = c.delta

    def predict(lin, fitted_parts, predicted_parts):
        base_, J_, x_ref_, lo_, hi_, prior_ = lin
        rows_f = np.concatenate([lay.part_rows(p) for p in fitted_parts])
        rows_p = np.concatenate([lay.part_rows(p) for p in predicted_parts])
        x, nu, _, _, _ = lin_fit(prob, base_, J_, x_ref_, lo_, hi_, rows=rows_f, delta=d, prior=prior_)
        model = base_ + J_ @ (x - x_ref_)
        # nuisances: the common TE offset comes from the fitted runs; a predicted torque cycle's (or half
        # cycle's) own offset is no prediction, so it is refitted on the predicted part
        cols = prob.nuis[:, np.abs(prob.nuis[rows_f]).sum(0) > 0]
        model = model + cols @ nu
        r = (shift_measured(prob.y, lay, d)[:, 0] - model)
        for part in predicted_parts:
            if part[0] in lay.hyst:
                rows = lay.part_rows(part)
                r[rows] -= np.average(r[rows], weights=prob.w[rows] ** 2)
        rw = r[rows_p] * prob.w[rows_p]
        return float(rw @ rw), x

    lin_c, lin_ref = _linearisation(c, f0), _linearisation(ref, f0)
    if hold_nominal:
        lin_c, lin_ref = _nominal_held(lin_c, c), _nominal_held(lin_ref, ref)
    total_before = total_after = 0.0
    for fitted_parts, predicted_parts in folds:
        rss_before, _ = predict(lin_ref, fitted_parts, predicted_parts)
        rss_after, x_f = predict(lin_c, fitted_parts, predicted_parts)
        total_before += rss_before
        total_after += rss_after
        doc["folds"].append({"fitted_runs": [part_label(plan, p) for p in fitted_parts],
                             "predicted_runs": [part_label(plan, p) for p in predicted_parts],
                             "improvement_pct": (100.0 * (1.0 - math.sqrt(rss_after / rss_before))
                                                 if rss_before > 0 else 0.0),
                             "rss_before": rss_before, "rss_after": rss_after,
                             "fitted_params": [float(v) for v in x_f]})
    doc["improvement_pct"] = 100.0 * (1.0 - math.sqrt(total_after / total_before)) if total_before > 0 else 0.0
    doc["rss_before"], doc["rss_after"] = total_before, total_after
    return doc


TIE_RSS_RATIO = 1.15  # candidates whose residuals differ by less than this factor are not separated by the data


SIGNATURE_TIE = 0.25  # another candidate reproduces the lead's fitted signature to within this (relative, weighted)


def equivalent(cands, lead, sens, f0, w) -> list:
    """Candidates the data cannot tell from ``lead``: their residual is within TIE_RSS_RATIO of
    the lead's, or their own sensitivities, within their parameter bounds, reproduce the lead's
    fitted model change (weighted, origin shift ignored) to within SIGNATURE_TIE — both computed
    from model runs. When the two share an effect (two pairs), only the part of the lead's change
    that the shared effect does not make has to be reproduced."""
    names = {e.name for e in lead.effects}
    total = lead.model_features - f0
    parts, i = {}, 0
    for e, xe in lead.split():  # the lead's change per effect, from its Jacobian
        parts[e.name] = lead.jacobian[:, i:i + e.n] @ xe if lead.jacobian is not None else np.zeros_like(total)
        i += e.n
    out = []
    for o in cands:
        own = {e.name for e in o.effects}
        mine, theirs = {e.name for e in lead.attributed}, {e.name for e in o.attributed}
        if o is lead or theirs <= mine or mine <= theirs or not all(e.name in sens for e in o.effects):
            continue
        if o.refined and o.rss <= TIE_RSS_RATIO * lead.rss:
            out.append(o)
            continue
        shared = names & own
        sig = (total - sum((parts[nm] for nm in shared), np.zeros_like(total))) * w
        norm = float(np.linalg.norm(sig))
        if norm <= 0:
            continue
        for J, lo, hi in sens.orthants(tuple(e for e in o.effects if e.name not in shared)):
            A = J * w[:, None]
            coef = lsq_linear(A, sig, bounds=(lo, hi), method="bvls").x
            if np.linalg.norm(sig - A @ coef) <= SIGNATURE_TIE * norm:
                out.append(o)
                break
    return out


def verdict(cands, chosen, none, has_folds, settings, unavailable, failed, tied=(), blocked=None) -> str:
    if not cands:
        return "No candidate effect could be evaluated; the gap is unexplained."
    if chosen is not None:
        c = chosen
        tie = [o for o in cands if o.name in tied]
        mag = "; ".join(f"{e.name} {fmt_mag(e, m)} (95 % {fmt_mag(e, iv[0])} … {fmt_mag(e, iv[1])})"
                        for e, m, iv in zip(c.effects, c.magnitude, c.magnitude_interval) if not e.nominal)
        s = (f"{c.name} explains the gap: {mag}; the weighted gap shrinks by {c.gap_shrink_pct:.0f} %, "
             f"{100 - c.gap_shrink_pct:.0f} % of it stays unexplained by any candidate; the withheld runs' "
             f"prediction improves by {c.withheld['improvement_pct']:.0f} %.")
        s += beyond_the_class_sentence(c) + off_period_sentence(c)
        # a nominal parameter at its class top is where an effect on the same quantity begins, not a limit
        shared = {SAME_QUANTITY[e.name] for e in c.effects if e.name in SAME_QUANTITY}
        bound = [b for b in c.at_bound if b.split(".")[0] not in shared]
        if bound:
            s += f" The fit hits a parameter bound ({', '.join(bound)}): the magnitude is a limit, not an estimate."
        if tie:
            s += (f" Tied with {', '.join(o.name for o in tie[:3])}: their model signatures reproduce this one "
                  "(or fit as well), so these runs cannot separate them.")
        return s
    if blocked is not None:
        return (f"No effect is confirmed: {blocked.name} fits best in the linearised model (score "
                f"{blocked.score:.1f}, gap shrink {blocked.gap_shrink_pct:.0f} %) but its model evaluation at the "
                f"fitted values failed ({failed.get(blocked.name, '')[:160]}), so no weaker candidate is accepted "
                f"in its place; what calibration leaves stays unexplained.")
    best = cands[0]
    significant = is_significant(best, settings)
    if significant and not has_folds:
        return (f"{best.name} fits best (gap shrinks by {best.gap_shrink_pct:.0f} %) but cannot be confirmed: "
                f"no run is usable for the withheld check (add a reverse or another-load run).")
    if significant:
        why = []
        if not best.refined:
            why.append("its model-in-the-loop evaluation failed, so only its linearised fit is known"
                       if best.name in failed else
                       "it was not evaluated with the model in the loop (the refinement budget, refine_top, ran out), "
                       "so only its linearised fit is known")
        if undetermined_effect(best):
            why.append(undetermined_effect(best))
        wh = best.withheld.get("improvement_pct")
        if not withheld_confirms(best.withheld, settings):
            folds = (f", or {settings.confirming_folds} folds each predicted with evidence ≥ {settings.bic_threshold:g}"
                     if settings.confirming_folds else "")
            why.append(f"refitted without them it predicts the withheld runs only {fmt_pct(wh)} better "
                       f"(≥ {settings.min_withheld_pct:g} % needed{folds})")
        elif ("against_single" in best.withheld
              and not withheld_confirms(best.withheld["against_single"], settings, replicated=True)):
            alone = best.withheld["against_single"]
            why.append(f"its second effect is not confirmed by the withheld runs: against {alone['single']} alone "
                       + (f"fewer than {settings.confirming_folds} folds are each predicted better with evidence "
                          f"≥ {settings.bic_threshold:g} (pooled {fmt_pct(alone['improvement_pct'])})"
                          if settings.confirming_folds else
                          "it needs replicated folds, and confirming_folds is None"))
        return (f"No effect is confirmed: the best candidate, {best.name}, removes {best.gap_shrink_pct:.0f} % "
                f"of the gap (score {best.score:.1f}), but {' and '.join(why or ['it was not accepted'])}; "
                "what calibration leaves stays unexplained.")
    return (f"No significant unmodelled effect: the best candidate, {best.name}, removes only "
            f"{max(best.gap_shrink_pct, 0):.0f} % of the gap (score {best.score:.1f}, withheld "
            f"{fmt_pct(best.withheld.get('improvement_pct'))}); the remaining gap is model-form "
            f"mismatch and noise.")


REASON_CHARS = 240  # a reason in the verdict is one line of at most this many characters


def reason_line(msg: str, limit: int = REASON_CHARS) -> str:
    """``msg`` as one line of at most ``limit`` characters, without any traceback: a message that
    carries one (a child process's standard error, say) keeps what precedes it and its last line,
    the exception itself."""
    head, trace, tail = str(msg).partition("Traceback (most recent call last):")

    def lines(t: str) -> list[str]:  # a child's standard error comes as lines, or joined by " | "
        return [p.strip() for p in re.split(r"\n| \| ", t) if p.strip()]

    # a traceback's frames ('File "…", line …' and their source lines) are left out, its last line kept
    parts = [p for p in lines(head) + (lines(tail)[-1:] if trace else []) if not p.startswith('File "')]
    line = " ".join(parts) or "no reason given"
    return line if len(line) <= limit else line[:limit - 1].rstrip() + "…"


def not_evaluated_sentence(unavailable: dict, failed: dict) -> str:
    """The verdict's sentence on what could not be evaluated, each with a one-line reason: the nominal
    parameters not calibrated (``unavailable`` entries "not calibrated: …"; a stiffness or form is held
    at its nominal value, a fidelity share left out of the model) and the candidate effects not
    evaluated (the other ``unavailable`` entries, and ``failed``: name → why, the effects whose
    sensitivity runs failed); "" when everything was evaluated."""
    cal = {k: v.removeprefix("not calibrated: ") for k, v in unavailable.items() if v.startswith("not calibrated: ")}
    eff = {k: v for k, v in unavailable.items() if k not in cal} | {k: v for k, v in failed.items() if k not in cal}

    def kept(name: str) -> str:
        e = NOMINAL.get(name)
        return ("left out of the model" if e is not None and e.kind == "fidelity" and e.center[0] != 0.0
                else "held at its nominal value")

    out = []
    if cal:
        out.append("Not calibrated: " + "; ".join(f"{k.replace('_', ' ')}, {kept(k)} ({reason_line(v)})"
                                                  for k, v in cal.items()) + ".")
    if eff:
        out.append("Not evaluated: " + "; ".join(f"{k} ({reason_line(v)})" for k, v in eff.items()) + ".")
    return " ".join(out)


def is_significant(c: Candidate, settings) -> bool:
    """A candidate whose evidence passes ``bic_threshold`` (whether or not it is confirmed); with the
    single-variance evidence ("bic") it must also remove ``min_shrink_pct`` of the gap."""
    if settings.evidence_model == "bic":
        return c.score >= settings.bic_threshold and c.gap_shrink_pct >= settings.min_shrink_pct
    return c.score >= settings.bic_threshold


def withheld_confirms(wh: dict, settings, replicated: bool = False) -> bool:
    """Whether a withheld check (:func:`withheld_check`, its folds' ``evidence`` filled in) confirms an
    effect: the pooled prediction of the withheld runs improves by ``min_withheld_pct``, or (replicated)
    ``confirming_folds`` folds each improve with evidence ≥ ``bic_threshold``, none gets worse by as much
    and the pooled prediction improves (see :class:`~rvflex.diagnosis.settings.DiagnosisSettings`).

    With ``replicated`` only the second way counts: the second effect of a pair, checked against its better
    single. The pooled share is dominated by the fold with the most model-form residual (the TE runs' ripple
    and wind-ups), so a second effect that only soaks up a model-form difference between the runs passes it
    from one fold (measured on the self-checks: four single hidden effects gained a series compliance as second
    effect, fold evidence [10, 7, 7], [62, 0, 0], [528, 1, −3] and [59, 8, 8]; the real second effects found,
    [340, 28, 75], [507, 39, 39] and [476, 23, 23])."""
    pct = wh.get("improvement_pct")
    if pct is None:
        return False
    if pct >= settings.min_withheld_pct and not replicated:
        return True
    ev = [f.get("evidence") for f in wh.get("folds", ())]
    if not settings.confirming_folds or pct <= 0 or not ev or any(e is None for e in ev):
        return False
    t = settings.bic_threshold
    return sum(e >= t for e in ev) >= settings.confirming_folds and min(ev) > -t


def acceptable(c: Candidate, settings) -> bool:
    """Whether a candidate passes every acceptance test: significant, determined, confirmed by the withheld
    runs and, for a pair, its second effect confirmed against the better single by replication
    (``withheld["against_single"]``, :func:`withheld_confirms` with ``replicated``)."""
    return (is_significant(c, settings) and not undetermined_effect(c) and withheld_confirms(c.withheld, settings)
            and ("against_single" not in c.withheld
                 or withheld_confirms(c.withheld["against_single"], settings, replicated=True)))


def beyond_the_class_sentence(c: Candidate) -> str:
    """For an effect of ``c`` on the same quantity as a nominal parameter (:data:`SAME_QUANTITY`: the
    eccentric-bearing clearance beyond the crank-bearing clearance's class): the total the runs determine, and
    the class it lies beyond ("" when ``c`` has none; the split between the two is not determined)."""
    names = [e.name for e in c.effects]
    out = ""
    for e in c.attributed:
        partner = SAME_QUANTITY.get(e.name)
        if partner in names:
            p = c.effects[names.index(partner)]
            total = total_size(e.name, {n: c.magnitude_of(n) for n in (e.name, partner)})
            out += (f" The runs determine only the total: {fmt_mag(e, total)} in all ({e.name} "
                    f"{fmt_mag(e, c.magnitude_of(e.name))} with the calibrated {partner} "
                    f"{fmt_mag(p, c.magnitude_of(partner))}), against a class of at most {fmt_mag(p, p.params[0].high)} "
                    "above the spec's.")
    return out


def off_period_sentence(c: Candidate) -> str:
    """For an effect of ``c`` established by its evidence at the orders no healthy unit has rather than by its size
    (the grade's ``off_period_beyond``): that evidence against the controls', and the size they reach ("" for none)."""
    g = c.grade or {}
    out = ""
    for n in g.get("off_period_beyond", ()):
        e = next(x for x in c.effects if x.name == n)
        out += (f" Its {n} is no larger than healthy units of other model forms make of one "
                f"({fmt_mag(e, g['magnitude_thresholds'][n])}), but at the TE orders no healthy unit has (not multiples "
                f"of the pin count) it earns an evidence of {g['own_off_period_evidence'][n]:.0f}, beyond "
                f"{OFF_PERIOD_MARGIN:g} times the {g['off_period_thresholds'][n]:.0f} they give it.")
    return out


def undetermined_effect(c: Candidate) -> str:
    """Why an unmodelled effect of ``c`` is not a finding ("" when every one is determined): its 95 %
    magnitude interval reaches zero (the runs cannot tell it from no effect), or a parameter of it sits
    at the bound of its range (its size is a limit, not an estimate; measured on a foreign bench: a
    verdict accepted an effect at its bound with a 95 % interval from 0 to ten times its value)."""
    for e, _m, (lo, hi) in zip(c.effects, c.magnitude, c.magnitude_interval):
        if not e.nominal and lo <= 0.0:
            return (f"the 95 % interval of {e.name} ({fmt_mag(e, lo)} … {fmt_mag(e, hi)}) includes zero: these runs "
                    "cannot determine it" + (f"; {e.separating_runs} would" if e.separating_runs else ""))
    own = {e.name for e in c.attributed}
    bound = [b for b in c.at_bound if b.split(".")[0] in own]
    if bound:
        return f"{bound[0]} sits at the bound of its range: its size is a limit, not an estimate"
    return ""


def fmt_pct(v) -> str:
    return "n/a" if v is None else f"{v:+.0f} %"


def fmt_mag(e: Effect, m: float) -> str:
    u = e.params[0].unit
    if u == "m":
        return f"{m * 1e6:.2f} µm"
    if u == "rad":
        return f"{m * 206264.806:.2f}″"
    if u == "1/K":
        return f"{m * 1e6:.2f} ppm/K"
    return f"{m:.3g} {u}"

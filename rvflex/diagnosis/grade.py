"""Graded verdicts: established, consistent but not established, or an unexplained model-form gap.

A candidate that passes the acceptance tests of :mod:`rvflex.diagnosis.verdict` (evidence, a determined size,
the withheld runs) has only shown that it helps. On a healthy unit of another make a candidate helps too: it
absorbs part of the model-form gap (measured on an independent simulator's RV-80E: a 4 µm pin-ring runout
passed every test on all three healthy units while removing 10–29 % of the gap). A finding is *established*
only when, besides those tests,

1. it is beyond what healthy units of other model forms make of it (:mod:`rvflex.diagnosis.null`): each of its
   effects earns a larger relative evidence (the evidence it earns on its own, all of a single's and a pair's less
   that of its other effect alone, over what the candidate leaves unexplained) than all but one of the ensemble's
   controls give that effect (:data:`~rvflex.diagnosis.null.RELATIVE_RANK`), and each effect's size exceeds the
   largest determined size the controls reach (for the eccentric-bearing clearance, the total with the calibrated
   crank-bearing clearance: the runs determine only that, :func:`~rvflex.diagnosis.null.total_size`), or its own
   evidence at the orders no healthy unit has (:func:`off_period_rows`: not multiples of z_b; a unit without part
   errors repeats itself every pin pitch of the output whatever its model form) is significant and exceeds
   :data:`~rvflex.diagnosis.null.OFF_PERIOD_MARGIN` times the most any control's candidate gives it
   (``off_period_max``);
   an effect the controls were not diagnosed with (absent from the distribution), or one with look-alike model
   forms the ensemble cannot draw yet (``Effect.unjudged_by``), is never established while a distribution is in
   use;
2. it explains most (:data:`MOST`) of what calibration left where its own signature lies: in the discrepancy
   groups (:mod:`rvflex.diagnosis.discrepancy`) that hold :data:`SIGNATURE_SHARE` of its signature, the
   calibrated residual falls by at least half. An effect that is the cause leaves model-form residue only;
   one that stands in for a model-form gap takes a part of it and leaves the rest;
3. the runs can tell it from every candidate that fits better, passes the tests and lies, in each of its effects,
   within what healthy units reach (``healthy_reach``; applied by the verdict stage,
   :mod:`rvflex.diagnosis.stages.verdict`): tied with one, the gap is as well a model-form gap.

Otherwise it is *consistent but not established*, said with the test it fails and what would settle it, and
the verdict is the unexplained gap (its size and where it lies). Only an established finding is accepted and
written "explains the gap".
"""

from __future__ import annotations

import numpy as np

from rvflex.diagnosis.discrepancy import Discrepancy, residual
from rvflex.diagnosis.linear import Candidate, Problem, split_params
from rvflex.diagnosis.nominal import SAME_QUANTITY
from rvflex.diagnosis.null import off_period_frees, own_evidence, relative_evidence, side, side_text, total_size
from rvflex.diagnosis.verdict import fmt_mag, fmt_pct, is_significant, undetermined_effect, withheld_confirms

__all__ = ["CONSISTENT", "ESTABLISHED", "MOST", "NOT_SIGNIFICANT", "SIGNATURE_SHARE", "consistent_sentence",
           "explained_where_it_lies", "gap_sentence", "grade", "own_change", "part_ties", "part_ties_sentence"]

ESTABLISHED, CONSISTENT, NOT_SIGNIFICANT = "established", "consistent but not established", "not significant"
MOST = 0.5  # "explains most": at least half of what calibration left where the signature lies
SIGNATURE_SHARE = 0.8  # the groups that hold this share of a candidate's signature energy are where it lies


def own_change(c: Candidate) -> np.ndarray:
    """The candidate's unmodelled effects' own share of its model change (features, arcsec), from its
    Jacobian: the part its nominal parameters' recalibration does not make."""
    out = np.zeros(len(c.model_features))
    if c.jacobian is None:
        return out
    i = 0
    for e in c.effects:
        if not e.nominal:
            out += c.jacobian[:, i:i + e.n] @ c.x[i:i + e.n]
        i += e.n
    return out


def off_period_rows(prob: Problem, period: int) -> np.ndarray:
    """The TE features (cos and sin coefficients of every TE run) at the orders that are not multiples of
    ``period`` (the unit's pin count z_b): where no healthy unit has TE (a unit without part errors repeats itself
    every pin pitch of the output whatever its model form, :func:`rvflex.diagnosis.replay.one_period`)."""
    lay = prob.lay
    rows = []
    for r in lay.te_runs:
        for sl in (lay.cos[r], lay.sin[r]):
            k = np.arange(1, sl.stop - sl.start + 1)
            rows.append(np.arange(sl.start, sl.stop)[k % period != 0])
    return np.concatenate(rows) if rows else np.zeros(0, int)


def explained_where_it_lies(prob: Problem, c: Candidate, base_residual: np.ndarray, disc: Discrepancy,
                            off_rows: np.ndarray | None = None) -> dict:
    """Where ``c``'s signature lies and how much of the calibrated model's residual there it removes
    (``base_residual``: that model's weighted residual, :func:`~rvflex.diagnosis.discrepancy.residual`).

    Returns
    -------
    dict
        ``leftover``: what the candidate leaves unexplained, its weighted residual energy in units of the
        discrepancy the calibrated model leaves (the units its evidence is counted in); ``groups``: labels of the
        discrepancy groups holding :data:`SIGNATURE_SHARE` of the weighted signature energy (largest first);
        ``explained_pct``: the fall of the weighted residual sum of squares over those groups (%);
        ``left_rms_arcsec``: the residual's rms there after the candidate (arcsec); with ``off_rows``
        (:func:`off_period_rows`), ``off_period_evidence``: the fall of the weighted residual energy over those
        features, in the units of ``leftover``. Only ``leftover`` (and ``off_period_evidence``) when the candidate has no signature.
    """
    groups = disc.groups
    rb, rc = base_residual, residual(prob, c)
    leftover = float(rc @ rc) / disc.pooled
    extra = {}
    if off_rows is not None:
        extra["off_period_evidence"] = float(rb[off_rows] @ rb[off_rows] - rc[off_rows] @ rc[off_rows]) / disc.pooled
    s = own_change(c) * prob.w
    e = np.array([g.energy(s) for g in groups])
    if not e.sum() > 0:
        return {"leftover": leftover} | extra
    order = np.argsort(-e)
    cum = np.cumsum(e[order]) / e.sum()
    where = [groups[i] for i in order[:int(np.searchsorted(cum, SIGNATURE_SHARE)) + 1]]
    before, after = sum(g.energy(rb) for g in where), sum(g.energy(rc) for g in where)
    left = sum(g.energy(rc / prob.w) for g in where) / sum(g.size for g in where)
    return {"leftover": leftover, "groups": [g.label for g in where],
            "explained_pct": 100.0 * (before - after) / before if before > 0 else 0.0,
            "left_rms_arcsec": float(np.sqrt(left))} | extra


def grade(c: Candidate, settings, null, local: dict, singles: dict | None = None,
          singles_off: dict | None = None) -> dict:
    """The grade of candidate ``c`` (see the module docstring).

    Parameters
    ----------
    c : Candidate
        Scored (withheld check done).
    settings : DiagnosisSettings
    null : NullDistribution or None
        The ensemble's thresholds (None: no null distribution; rule 1 is not applied and ``note`` says so).
    local : dict
        :func:`explained_where_it_lies` of ``c`` (without ``leftover``, the candidate's ``rss`` stands for it).
    singles : dict, optional
        Effect → evidence of the single-effect candidates of the same diagnosis: what each effect of a pair earns
        on its own (:func:`~rvflex.diagnosis.null.own_evidence`).
    singles_off : dict, optional
        Effect → off-period evidence (``local["off_period_evidence"]``) of the single-effect candidates: what each
        effect of a pair earns on its own there.

    Returns
    -------
    dict
        ``grade`` (:data:`ESTABLISHED`, :data:`CONSISTENT` or :data:`NOT_SIGNIFICANT`), ``fails`` (one phrase per
        test it fails), ``own_evidence`` and ``relative_evidence`` (effect → the evidence it earns on its own here,
        and that over ``leftover``, what the candidate leaves unexplained), ``relative_thresholds`` (effect → the
        relative evidence the ensemble's controls reach, None where the null has none), ``magnitude_thresholds``
        (effect → size they reach), ``explained_where_pct``, ``signature_groups``, ``healthy_reach`` (its effects
        that do not exceed a threshold of the null distribution: healthy units of other model forms reach them),
        ``off_period_evidence`` (the candidate's), ``own_off_period_evidence`` (effect → its own share),
        ``off_period_thresholds`` (effect → the most the controls give it, None where the null has none) and
        ``off_period_beyond`` (its effects whose size is within the controls' but whose off-period evidence is
        beyond theirs).
    """
    names = [e.name for e in c.attributed]
    own = {n: own_evidence(c.score, names, n, singles or {}) for n in names}
    leftover = float(local.get("leftover", c.rss))
    rel = {n: relative_evidence(own[n], leftover) for n in names}
    rel_ts = {n: null.relative_threshold(n) for n in names} if null is not None else {}
    mag_t = {n: null.magnitude_threshold(n) for n in names} if null is not None else {}
    whose = f" ({null.unit} ensemble)" if null is not None and null.unit else ""
    out = {"own_evidence": own, "leftover": leftover, "relative_evidence": rel, "relative_thresholds": rel_ts,
           "magnitude_thresholds": mag_t, "null_unit": (null.unit or "all units") if null is not None else None,
           "explained_where_pct": local.get("explained_pct"), "signature_groups": local.get("groups", []),
           "off_period_evidence": local.get("off_period_evidence")}
    off = local.get("off_period_evidence")
    own_off = {n: own_evidence(off, names, n, singles_off or {}) for n in names} if off is not None else {}
    off_t = {n: null.off_period_threshold(n) for n in names} if null is not None else {}
    out |= {"own_off_period_evidence": own_off, "off_period_thresholds": off_t}
    beyond = []  # its effects beyond the controls at the orders no healthy unit has, whatever their size
    if not is_significant(c, settings):
        return out | {"grade": NOT_SIGNIFICANT, "fails": [f"its evidence {c.score:.0f} is below {settings.bic_threshold:g}"]}
    fails = _failed_tests(c, settings)
    reached = []  # its effects healthy units of other model forms reach (a threshold not exceeded)
    for n in names:
        t = rel_ts.get(n)
        if t is None or rel[n] > t:
            continue
        reached.append(n)
        earns = (f"its evidence {c.score:.0f} is" if len(names) == 1 else
                 f"its {n} earns an evidence of {own[n]:.0f} on its own (the pair's {c.score:.0f} less the other "
                 "effect's alone),")
        fails.append(f"{earns} {rel[n]:.2f} times the {leftover:.0f} the candidate leaves unexplained, not beyond the "
                     f"{t:.2f} that healthy units of other model forms reach for it{whose}")
    sizes = {e.name: m for e, m in zip(c.effects, c.magnitude)}
    for (e, x), m in zip(split_params(c.effects, c.x), c.magnitude):
        sg = side(e.name, x)
        t = null.magnitude_threshold(e.name, sg) if null is not None else None
        if t is not None:
            mag_t[e.name] = t
        size = total_size(e.name, sizes)
        if not e.nominal and t is not None and size <= t:
            if off_period_frees(own_off.get(e.name), off_t.get(e.name), settings.bic_threshold):
                beyond.append(e.name)
                continue
            reached.append(e.name)
            where = side_text(e.name, sg)
            what = (f"its {e.name} of {fmt_mag(e, abs(m))}" if size == abs(m) else
                    f"its {e.name}, {fmt_mag(e, size)} in total with the calibrated {SAME_QUANTITY[e.name]},")
            fails.append(f"{what} is within the {fmt_mag(e, t)} {'in total ' if size != abs(m) else ''}healthy units "
                         f"of other model forms reach{where}{whose}")
    if null is not None:  # look-alike model forms the ensemble cannot draw: its thresholds do not bound them
        fails += [f"healthy units with {e.unjudged_by}, model forms the ensemble cannot draw yet, act where {e.name} "
                  "acts: the null distribution does not bound what they make of it" for e in c.attributed
                  if e.unjudged_by]
    if null is not None:  # no controls were diagnosed with it: nothing says how far healthy units take it
        fails += [f"healthy units of other model forms have not been diagnosed with {e.name}{whose} (rebuild the null "
                  f"distribution: rvflex null-distribution)" for e in c.attributed if null.relative_threshold(e.name) is None]
    pct = local.get("explained_pct")
    if pct is None or pct < 100 * MOST:
        where = ", ".join(local.get("groups", [])[:3]) or "its signature's features"
        fails.append(f"it removes only {max(pct or 0.0, 0.0):.0f} % of what calibration left where its signature "
                     f"lies ({where})")
    note = "" if null is not None else "not judged against healthy units of other model forms (no null distribution)"
    return out | {"grade": CONSISTENT if fails else ESTABLISHED, "fails": fails, "note": note,
                  "healthy_reach": sorted(set(reached)), "off_period_beyond": beyond}


def _failed_tests(c: Candidate, settings) -> list[str]:
    """The acceptance tests of :func:`~rvflex.diagnosis.verdict.acceptable` that ``c`` fails, one phrase each."""
    out = []
    if not c.refined:
        out.append("it is known only by its linearised fit")
    why = undetermined_effect(c)
    if why:
        out.append(why)
    if not withheld_confirms(c.withheld, settings):
        out.append(f"the withheld runs do not confirm it (prediction {fmt_pct(c.withheld.get('improvement_pct'))})")
    alone = c.withheld.get("against_single")
    if alone is not None and not withheld_confirms(alone, settings, replicated=True):
        out.append(f"its second effect is not confirmed by the withheld runs against {alone['single']} alone")
    return out


def gap_sentence(disc: Discrepancy | None, top: int = 3) -> str:
    """What calibration leaves, its size and where it lies: the discrepancy groups with the most residual energy
    beyond their floors, each with its rms (arcsec)."""
    if disc is None or not len(disc.groups):
        return ""
    excess = disc.rss - disc.n
    idx = [i for i in np.argsort(-excess) if excess[i] > 0][:top]
    if not idx:
        return "What calibration leaves is at the noise and model-form floors."
    parts = [f"{disc.groups[i].label} ({disc.rms_arcsec[i]:.2f}″ rms, {disc.sigma[i]:.1f} floors)" for i in idx]
    return "The unexplained model-form gap lies mostly in " + "; ".join(parts) + "."


def consistent_sentence(c: Candidate) -> str:
    """The verdict on a candidate that passes the tests but is not established: what it would be, why it is not
    established, and what would settle it. Never "explains the gap"."""
    mag = "; ".join(f"{e.name} {fmt_mag(e, m)} (95 % {fmt_mag(e, iv[0])} … {fmt_mag(e, iv[1])})"
                    for e, m, iv in zip(c.effects, c.magnitude, c.magnitude_interval) if not e.nominal)
    settle = [e.separating_runs for e in c.attributed if e.separating_runs]
    return (f"Consistent but not established: {mag} fits (the weighted gap shrinks by {c.gap_shrink_pct:.0f} %, "
            f"the withheld runs' prediction improves by {c.withheld.get('improvement_pct') or 0:.0f} %), but "
            + "; ".join(c.grade.get("fails", [])) + ". "
            + (f"It would be settled by {'; '.join(settle)}." if settle else
               "It would be settled by runs where its signature stands above the model-form gap: a load, "
               "temperature or direction where it acts and the model form does not, or a measurement of the part.")
            + " No effect is named.")


def part_ties(spec, c: Candidate) -> list[dict]:
    """For each effect of an established finding ``c``: the part errors no candidate models that act at its
    lowest order (:func:`rvflex.diagnosis.orders.lacking_lookalikes`), which TE alone cannot tell from it."""
    from rvflex.diagnosis.orders import lacking_lookalikes

    out = []
    for e in c.attributed:
        tie = lacking_lookalikes(spec, e.name)
        if tie:
            out.append({"effect": e.name, "order": tie["order"], "lacking": tie["lacking"],
                        "separating": e.separating_runs or ""})
    return out


def part_ties_sentence(ties: list[dict]) -> str:
    """The verdict's sentence on :func:`part_ties` ("" when there are none)."""
    out = []
    for t in ties:
        s = (f"At order {t['order']} {t['effect']} is tied with part errors no candidate models: "
             + "; ".join(t["lacking"]) + " — the TE runs cannot tell them apart")
        out.append(s + (f"; {t['separating']} would." if t["separating"] else "."))
    return " ".join(out)

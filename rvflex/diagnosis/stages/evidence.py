"""The evidence stage of a diagnosis: every candidate scored against the discrepancy the calibrated model
leaves (:mod:`rvflex.diagnosis.discrepancy`; ``evidence_model="bic"``: the plain BIC), its shrink of what
calibration left, and its withheld check (:func:`~rvflex.diagnosis.verdict.withheld_check`: refitted on some runs,
does it predict the others; a pair's second effect against its better single too). A candidate known only by its
linearisation that then leads, or that passes every acceptance test below a refined one that fails, is refined
in its turn. Last the grades (:mod:`rvflex.diagnosis.grade`): a candidate that passes the tests is established only
beyond what healthy units of other model forms make of it (the null distribution) and when it explains most of
what calibration left where its signature lies."""

from __future__ import annotations

import dataclasses as dc
from dataclasses import dataclass

from rvflex.diagnosis.discrepancy import residual
from rvflex.diagnosis.grade import explained_where_it_lies, grade, off_period_rows
from rvflex.diagnosis.linear import Candidate
from rvflex.diagnosis.null import load_null
from rvflex.diagnosis.settings import DiagnosisSettings
from rvflex.diagnosis.stages.calibration import shrink_pct
from rvflex.diagnosis.stages.candidates import Candidates, adding, note_singles
from rvflex.diagnosis.verdict import acceptable, withheld_check
from rvflex.spec import ReducerSpec

__all__ = ["Evidence", "run"]


@dataclass(frozen=True, eq=False)
class Evidence:
    """The candidates scored, checked on withheld runs and graded."""

    candidates: Candidates
    ranking: tuple[Candidate, ...]  # best score first
    failed: dict  # candidates without sensitivities and refinements that failed: why


def run(cands: Candidates) -> Evidence:
    """The scores, withheld checks and grades of ``cands``; the leaders known only linearised refined in turn."""
    att = cands.attribution
    calib = att.calibrated
    feat = calib.features
    prob, settings, plan, folds = feat.problem, feat.bench.settings, feat.bench.plan, feat.bench.folds
    f0, none, disc, score_of = feat.baseline, calib.model, calib.discrepancy, calib.score
    failed = dict(cands.failed)
    best_single = dict(cands.best_single)

    def checked(c: Candidate, ref: Candidate) -> dict:  # the withheld check, each fold's evidence filled in
        wh = withheld_check(prob, plan, c, ref, f0, folds, hold_nominal=True)
        for f in (wh, *wh.get("folds", ())):
            f["evidence"] = disc.predictive_evidence(f)
        return wh

    def scored(c: Candidate) -> Candidate:
        wh = checked(c, none)
        if len(c.attributed) > 1:  # a pair: its second effect must predict the withheld runs too, against the better single
            sub = max((best_single[e.name] for e in c.attributed if e.name in best_single), key=score_of)
            wh["against_single"] = {**checked(c, sub), "single": sub.name}
        return dc.replace(c, score=score_of(c), bic_score=none.bic - c.bic, gap_shrink_pct=shrink_pct(c.rss, none.rss),
                          withheld=wh)

    out = sorted((scored(c) for c in cands.candidates), key=lambda c: -c.score)
    # a refined candidate can fall below a linearised one, or fail the withheld check while a linearised one
    # below it passes: walking down the ranking as the acceptance does, the leader or a linearised candidate that
    # passes every test is refined in its turn (at most refine_top more), so no verdict rests on a candidate known
    # only by its linearisation (measured: a hidden series compliance, second at score 91 and confirmed by all
    # three folds, stayed linearised under a crank eccentricity the withheld runs rejected)
    for _ in range(settings.refine_top):
        nxt = None
        for c in out:
            if c.score < settings.bic_threshold or c.name in failed or (c.refined and acceptable(c, settings)):
                break  # below the threshold, blocking (its evaluation failed), or the one accepted
            if not c.refined and (c is out[0] or acceptable(c, settings)):
                nxt = [c]
                break
        # nothing accepted under a refined pair judged against a linearised single: before "unexplained", its
        # singles are refined and the pair judged again (measured, far self-check seed 2, case 17: a hidden
        # −3.9 ppm/K thermal mismatch, the pair with a crank-bearing clearance refined to score 764 and refuted
        # against the clearance alone, linearised at 97; the thermal mismatch alone, linearised at 54 at its bound,
        # refined reaches 860 and is confirmed by the withheld runs)
        pair_singles = nxt is None and not any(c.refined and acceptable(c, settings) for c in out)
        if pair_singles:
            nxt = _singles_of_refuted_pair(out, settings, failed)
        if not nxt:
            break
        again = att.refined(nxt, failed)
        out = [c for c in out if all(c is not s for s in nxt)] + [scored(c) for c in again]
        if pair_singles:
            note_singles(best_single, again)
            out = [scored(c) if len(c.attributed) > 1 else c for c in adding(out, best_single, settings, score_of)]
        if not again:  # its evaluation failed: kept linearised, and named so in the verdict
            out += nxt
        out.sort(key=lambda c: -c.score)
    # --- grades: a candidate that passes the tests is established only beyond what healthy units of other model
    # forms make of it (the null distribution) and when it explains most of what calibration left where its
    # signature lies; the others that pass are consistent but not established
    null = _null_of(settings, feat.runner.spec)
    r_cal = residual(prob, none)  # what calibration left, once for every candidate
    singles = {c.attributed[0].name: c.score for c in out if len(c.attributed) == 1}
    # a healthy unit repeats itself every pin pitch of the output: the features at the other orders, once for all
    off_rows = off_period_rows(prob, feat.runner.spec.cycloid.pin_count)
    local = [explained_where_it_lies(prob, c, r_cal, disc, off_rows) for c in out]
    singles_off = {c.attributed[0].name: lo["off_period_evidence"] for c, lo in zip(out, local) if len(c.attributed) == 1}
    out = [dc.replace(c, grade=grade(c, settings, null, lo, singles, singles_off)) for c, lo in zip(out, local)]
    return Evidence(cands, tuple(out), failed)


def _null_of(settings: DiagnosisSettings, spec: ReducerSpec):
    """The null distribution ``settings.null_distribution`` names (None: none), for the unit ``spec`` is a
    variant of (:meth:`~rvflex.diagnosis.null.NullDistribution.for_spec`)."""
    if settings.null_distribution is None:
        return None
    null = load_null(None if settings.null_distribution == "builtin" else settings.null_distribution)
    return null.for_spec(spec) if null is not None else None


def _singles_of_refuted_pair(ranked: list[Candidate], settings: DiagnosisSettings, failed: dict) -> list[Candidate]:
    """The linearised singles of the leader of ``ranked`` (by score) when it is a refined pair whose second effect
    was judged against a linearised single (``withheld["against_single"]``): a refined fit against a linearised
    one, which can favour either. [] when the leader is no such pair."""
    lead = ranked[0] if ranked else None
    if (lead is None or not lead.refined or len(lead.attributed) < 2 or lead.score < settings.bic_threshold
            or lead.name in failed):
        return []
    names = {e.name for e in lead.attributed}
    singles = [c for c in ranked if len(c.attributed) == 1 and c.name in names and not c.refined and c.name not in failed]
    against = lead.withheld.get("against_single", {}).get("single")
    return singles if against in {c.name for c in singles} else []

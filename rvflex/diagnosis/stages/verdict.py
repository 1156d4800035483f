"""The verdict stage of a diagnosis: walking down the ranking, the first refined candidate that passes every
acceptance test and is established is accepted (unless one above it with evidence could not be evaluated with the
model in the loop: that one blocks). Calibrate first: an accepted effect the nominal parameters reproduce within
their prior ranges is demoted to a tie with the calibration. Then the candidates tied with the accepted one, the
part errors TE cannot tell from it, the effects the calibration can stand in for, and the sentence."""

from __future__ import annotations

import dataclasses as dc
import math
from dataclasses import dataclass

from rvflex.diagnosis.calibration import (
    CALIBRATION_PREFERRED,
    calibration_lookalikes,
    calibration_sentence,
    calibration_ties,
    lookalike_sentence,
)
from rvflex.diagnosis.grade import (
    CONSISTENT,
    ESTABLISHED,
    consistent_sentence,
    gap_sentence,
    part_ties,
    part_ties_sentence,
)
from rvflex.diagnosis.linear import Candidate
from rvflex.diagnosis.settings import DiagnosisSettings
from rvflex.diagnosis.stages.evidence import Evidence
from rvflex.diagnosis.verdict import acceptable, equivalent, is_significant, not_evaluated_sentence, verdict

__all__ = ["Verdict", "run"]


@dataclass(frozen=True, eq=False)
class Verdict:
    """What the diagnosis concludes."""

    evidence: Evidence
    candidates: tuple[Candidate, ...]  # the ranking, the accepted candidate's copy in its place
    chosen: Candidate | None  # the accepted candidate
    ties: tuple[str, ...]  # candidates the runs cannot tell from the lead
    text: str  # the verdict sentence
    calibration_ties: tuple[str, ...]  # nominal parameters that can mimic the accepted effect
    separating_runs: tuple[str, ...]  # runs that would separate such a tie
    lookalikes: dict  # effects the calibration can stand in for (calibration_lookalikes)
    part_ties: tuple  # part errors no candidate models that TE cannot tell from the accepted effect


def run(ev: Evidence) -> Verdict:
    """The accepted effect of ``ev`` (if any), its ties and the verdict sentence."""
    calib = ev.candidates.attribution.calibrated
    feat = calib.features
    settings, folds, cal, w, f0 = feat.bench.settings, feat.bench.folds, feat.to_calibrate, feat.weights, feat.baseline
    none, nominal_model, sens, disc = calib.model, calib.nominal_model, calib.sensitivities, calib.discrepancy
    unavailable, failed, usable = feat.unavailable, ev.failed, feat.usable
    anc, held, not_evaluated = feat.anchor, feat.held, feat.not_evaluated
    out = list(ev.ranking)
    chosen, final, blocked = _accepted(out, settings, failed)
    # a finding the runs cannot tell from a better fit that healthy units of other model forms reach is no finding:
    # the gap is as well explained by the model form (measured, foreign bench 2 V09: a stiffening flange compliance,
    # which no candidate models, fitted as a 773″ crank phase error beyond every control, while a pin-ring runout
    # that healthy RV-80E units reach fitted it better)
    while chosen is not None and (rival := _healthy_rival(final, chosen, settings, sens, f0, w)) is not None:
        out = [_held_by(c, rival) if c.name == chosen.name else c for c in out]
        chosen, final, blocked = _accepted(out, settings, failed)
    # calibrate first: an effect that the nominal parameters reproduce within their prior ranges is not
    # needed — the nominal explanation is expected, the effect is extra; it is reported as a tie
    cal_ties, runs_needed, tie_ratio = (calibration_ties(chosen, cal, sens, w) if chosen is not None
                                        else ((), (), math.inf))
    demoted = None
    if cal_ties and tie_ratio <= CALIBRATION_PREFERRED:
        demoted = chosen
        final = [dc.replace(c, accepted=False, note=(c.note + "; " if c.note else "")
                            + "tied with the calibration of " + ", ".join(cal_ties)) if c is chosen else c
                 for c in final]
        chosen = None
    lead_c = chosen or (final[0] if final else None)
    # ties of a lead that explains nothing would be every candidate: only a significant lead has ties
    tied = (tuple(o.name for o in equivalent(final, lead_c, sens, f0, w))
            if lead_c is not None and lead_c.score >= settings.bic_threshold else ())
    text = verdict(final, chosen, none, bool(folds), settings, unavailable, failed, tied, blocked)
    # a candidate that passes every test but is not established: the verdict says so instead of "unexplained"
    consistent = (next((c for c in final if c.grade.get("grade") == CONSISTENT and c.refined
                        and acceptable(c, settings)), None) if chosen is None and blocked is None else None)
    if consistent is not None:
        text = consistent_sentence(consistent)
    if chosen is None:
        text += " " + gap_sentence(disc)
    ties_to_parts = part_ties(feat.runner.spec, chosen) if chosen is not None else []
    if ties_to_parts:
        text += " " + part_ties_sentence(ties_to_parts)
    if demoted is not None:
        text = (f"Nominal parameters off; no unmodelled effect is needed: {demoted.name} would remove "
                f"{demoted.gap_shrink_pct:.0f} % of what calibration leaves, but within their prior ranges the nominal "
                f"parameters {', '.join(cal_ties)} reproduce its signature, so these runs cannot tell it from them "
                f"(a tie); {'; '.join(runs_needed)} would separate them.")
    open_effect = blocked is not None or bool(final and is_significant(final[0], settings))
    missing = not_evaluated_sentence(unavailable, not_evaluated)
    text = (anc.sentence() + " "
            + calibration_sentence(none, nominal_model, chosen if demoted is None else demoted, settings, held,
                                   open_effect=open_effect, anchor_scale=anc.scale)
            + (" " + missing if missing else "") + " " + text)
    # effects the calibration can stand in for (an output series compliance against the bearing stiffnesses):
    # named as ties, since these runs can neither find nor exclude them
    named = {e.name for c in (chosen, demoted) if c is not None for e in c.attributed}
    lookalikes = calibration_lookalikes([e for e in usable if e.name not in named], none, sens, w, disc.pooled,
                                        settings.bic_threshold)
    if cal_ties and demoted is None:
        text += (f" Partly tied with the calibration of {', '.join(cal_ties)} (within their prior ranges they reproduce "
                 f"{100 * (1 - tie_ratio):.0f} % of the effect's signature): {'; '.join(runs_needed)} would separate "
                 "them.")
    if lookalikes:
        text += " " + lookalike_sentence(lookalikes)
    return Verdict(ev, tuple(final), chosen, tied, text, cal_ties, runs_needed, lookalikes, tuple(ties_to_parts))


def _healthy_rival(final: list[Candidate], chosen: Candidate, settings: DiagnosisSettings, sens, f0, w):
    """The best-fitting candidate of ``final`` that fits better than ``chosen``, passes every acceptance test, is
    reached by healthy units of other model forms in each of its effects (``grade["healthy_reach"]``: as a whole
    it may be the model form; a pair with an effect beyond them claims that effect) and is tied with ``chosen``
    (:func:`~rvflex.diagnosis.verdict.equivalent`: a candidate that holds ``chosen``'s effects, or is held by them,
    is no rival); None when there is none."""
    rivals = [c for c in final if c.score > chosen.score and c.refined and acceptable(c, settings)
              and set(c.grade.get("healthy_reach") or ()) >= {e.name for e in c.attributed}]
    tied = equivalent(rivals, chosen, sens, f0, w) if rivals else []
    return max(tied, key=lambda c: c.score) if tied else None


def _held_by(c: Candidate, rival: Candidate) -> Candidate:
    """``c`` graded consistent but not established, for its tie with ``rival`` (:func:`_healthy_rival`)."""
    why = (f"these runs cannot tell it from {rival.name}, which fits better (evidence {rival.score:.0f} against "
           f"{c.score:.0f}) and is within what healthy units of other model forms reach: the gap is as well a model-form "
           "gap")
    return dc.replace(c, grade=c.grade | {"grade": CONSISTENT, "fails": list(c.grade.get("fails", [])) + [why]})


def _accepted(ranked: list[Candidate], settings: DiagnosisSettings, failed: dict):
    """Walk down ``ranked`` (by score) as the verdict does: the first refined candidate that passes every
    acceptance test is chosen (a copy marked accepted), unless a candidate above it with evidence could
    not be evaluated with the model in the loop (named in ``failed``): that one blocks the acceptance.
    Returns (chosen | None, the ranking with the chosen copy in its place, blocked | None)."""
    chosen = None
    final = []
    blocked = None  # a candidate that fits better (linearised) but whose model evaluation failed
    for c in ranked:
        if c.refined and acceptable(c, settings) and c.grade.get("grade", ESTABLISHED) == ESTABLISHED \
                and chosen is None and blocked is None:
            chosen = dc.replace(c, accepted=True)
            final.append(chosen)
            continue
        if chosen is None and blocked is None and c.name in failed and c.score >= settings.bic_threshold:
            blocked = c
        final.append(c)
    return chosen, final, blocked

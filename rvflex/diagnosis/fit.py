"""Which effect: calibrate the uncertain nominal parameters, then attribute what is left.

1. The bench runs' features are read and checked (:func:`~rvflex.diagnosis.features.measured_runs`:
   bad or undetermined data are refused before any model run). The nominal model (the reducer as
   specified, no errors) is run under every bench run's conditions; the measured and model
   features are weighted by their noise/model-form floors.
2. Sensitivities: one model run per parameter of every candidate effect and every nominal
   parameter (:mod:`rvflex.diagnosis.nominal`) at its typical step (a secant, so clearances and
   other one-sided effects are linearised where they act; two-sided effects get a secant on each
   side of zero); cached on disk by content (:mod:`rvflex.diagnosis.runs`), evaluated in a process
   pool, computed once and used by both stages.
3. Calibration: the nominal parameters alone are fitted (bounded linear least squares with the
   nuisances — common TE offset, hysteresis offsets — the unknown encoder origin δ and each
   parameter's regulariser toward its nominal value) and refined with the model in the loop. The
   calibrated model is the baseline of the attribution.
4. Attribution: every candidate (each effect, and pairs) is fitted *together with* the nominal
   parameters (same regularisers), so an effect gets only what calibration cannot explain. A pair
   is kept only when its second effect has evidence ≥ ``bic_threshold`` given the better single
   (``evidence_model="bic"``: removes ``min_shrink_pct`` of the weighted gap that single leaves),
   and is accepted only when the withheld folds confirm it against that single by replication.
5. The best ``refine_top`` candidates by their score (step 6, from the linearised fits) and the
   best single by the linearised BIC are refined with the model in the loop
   (:mod:`rvflex.diagnosis.refine`); their score uses the real model's residual. A linearised
   candidate that then leads, or that passes every acceptance test below a refined one that
   fails, is refined in its turn.
6. Model selection by the evidence against the discrepancy the calibrated model leaves
   (:mod:`rvflex.diagnosis.discrepancy`; ``evidence_model="bic"``: the plain BIC and
   ``min_shrink_pct``); intervals from the linearised covariance (95 %), regulariser included. An
   effect is accepted only when its evidence reaches ``bic_threshold``, its size is determined, and it predicts withheld
   runs ``min_withheld_pct`` better than the calibrated model refitted on the same runs, or predicts
   ``confirming_folds`` withheld folds each with evidence ≥ ``bic_threshold``
   (:func:`rvflex.diagnosis.verdict.withheld_confirms`).
"""

from __future__ import annotations

import dataclasses as dc
import itertools
import math
import time
from pathlib import Path

import numpy as np

from rvflex.diagnosis.calibrate import (
    anchored,
    baseline_response,
    calibrated,
    calibration_parameters,
    evaluated_each,
    linearised_step,
)
from rvflex.diagnosis.calibration import (
    CALIBRATION_PREFERRED,
    calibration_lookalikes,
    calibration_sentence,
    calibration_ties,
    lookalike_sentence,
    undetermined,
)
from rvflex.diagnosis.discrepancy import Discrepancy, evidence, feature_groups, residual
from rvflex.diagnosis.features import measured_runs
from rvflex.diagnosis.grade import (
    CONSISTENT,
    ESTABLISHED,
    consistent_sentence,
    explained_where_it_lies,
    gap_sentence,
    grade,
    part_ties,
    part_ties_sentence,
)
from rvflex.diagnosis.linear import (
    Candidate,
    Problem,
    Sensitivities,
    bounds,
    lin_fit,
    make_candidate,
    nuisance_columns,
    prior_of,
    split_params,
    weights,
)
from rvflex.diagnosis.nominal import REPLACES, within_spec_rules
from rvflex.diagnosis.null import load_null
from rvflex.diagnosis.plan import PlanRun, plan_from_dataset
from rvflex.diagnosis.refine import evaluated_candidate, refine
from rvflex.diagnosis.replay import one_period
from rvflex.diagnosis.result import Diagnosis
from rvflex.diagnosis.runs import ModelRunner
from rvflex.diagnosis.sensitivity import (
    available_candidates,
    fidelity_sets,
    rebased_from,
    second_effect_adds,
    sensitivities,
    sensitivity_runs,
    signature_size,
    signature_sizes,
)
from rvflex.diagnosis.settings import DiagnosisSettings
from rvflex.diagnosis.verdict import (
    acceptable,
    equivalent,
    is_significant,
    not_evaluated_sentence,
    reason_line,
    verdict,
    withheld_check,
)
from rvflex.options import ModelOptions
from rvflex.spec import ErrorSpec, ReducerSpec

__all__ = ["Candidate", "Diagnosis", "available_candidates", "diagnose", "restated", "second_effect_adds",
           "signature_sizes", "withheld_folds", "withheld_split"]


def withheld_split(plan: tuple[PlanRun, ...]) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """Runs fitted and runs predicted in the withheld check: fit on the forward TE runs at the
    highest load and on the torque cycles, predict every other run (other directions, other
    loads). With no TE run forward at the highest load the first TE run takes its place."""
    te = [r for r, p in enumerate(plan) if p.kind == "te"]
    hyst = [r for r, p in enumerate(plan) if p.kind != "te"]
    if not te:
        return tuple(hyst), ()
    fwd = [r for r in te if plan[r].direction > 0]
    pool = fwd or te
    top = max(plan[r].load_Nm for r in pool)
    fit_te = [r for r in pool if plan[r].load_Nm == top][:1]
    fitted = tuple(sorted(fit_te + hyst))
    return fitted, tuple(r for r in range(len(plan)) if r not in fitted)


def withheld_folds(plan: tuple[PlanRun, ...]) -> tuple[tuple[tuple[tuple[int, int], ...], tuple[tuple[int, int], ...]], ...]:
    """The folds of the withheld check, each (fitted parts, predicted parts) of runs (run, side: 0 the whole
    run, ±1 a torque cycle's positive / negative-torque half, :meth:`~rvflex.diagnosis.plan.Layout.part_rows`);
    nothing is predicted twice. Fold 1 is :func:`withheld_split` (the other TE runs predicted from the forward
    TE run at the highest load and the torque cycles); then each torque cycle's halves predict each other, with
    the TE runs fitted too: an effect whose evidence lies in the torque cycle (friction's loop, a clearance's
    free play, the curve's stiffening) is confirmed on the half it was not fitted on, and one read from the
    TE runs must predict both halves. Folds with nothing to fit or to predict are left out."""
    folds = []
    fitted, predicted = withheld_split(plan)
    if fitted and predicted:
        folds.append((tuple((r, 0) for r in fitted), tuple((r, 0) for r in predicted)))
    te = tuple((r, 0) for r, p in enumerate(plan) if p.kind == "te")
    for h in (r for r, p in enumerate(plan) if p.kind != "te"):
        for side in (1, -1):
            folds.append((te + ((h, side),), ((h, -side),)))
    return tuple(folds)


def diagnose(dataset, *, settings: DiagnosisSettings | None = None, effects: tuple[str, ...] | None = None,
             nominal: tuple[str, ...] | None = None, law=None, cache_dir: str | Path | None = None, progress=None,
             errors: ErrorSpec | None = None) -> Diagnosis:
    """Diagnose the gap between the model of ``dataset.reducer`` and the bench runs.

    Parameters
    ----------
    dataset : BenchDataset
        From :func:`rvflex.diagnosis.bench.read_bench`.
    settings : DiagnosisSettings
    effects : tuple of str, optional
        Names of the candidate effects (default: every registered, available effect).
    nominal : tuple of str, optional
        Nominal parameters to calibrate first (default: all of :data:`rvflex.diagnosis.nominal.NOMINAL`;
        ``()``: none, the nominal model is taken as exact).
    law : ContactLaw, optional
        Contact law of the model (default: the model's line contact).
    cache_dir : path, optional
        Disk cache of model runs (content-hashed; safe to share between datasets).
    progress : callable, optional
        ``progress(done, total)`` over model runs.
    errors : ErrorSpec, optional
        Known errors of the unit (default: none).

    Raises
    ------
    BenchError
        A TE run whose samples cannot determine the analysed orders (before any model run).
    EvaluationFailed
        The nominal model does not converge under the bench conditions.
    """
    from threadpoolctl import threadpool_limits

    # one BLAS thread for the fits (and the pool's workers forked meanwhile): their QR and products on a few
    # thousand features gain nothing from threads on two cores, and OpenBLAS's threads on a busy machine cost
    # (measured at load 7: the δ search's QR of 2100 × 12 and its product with the 2100 × 2048 shifted features,
    # 94 ms with the default threads, 21 ms with one)
    with threadpool_limits(1, user_api="blas"):
        return _diagnose(dataset, settings, effects, nominal, law, cache_dir, progress, errors)


def _diagnose(dataset, settings, effects, nominal, law, cache_dir, progress, errors) -> Diagnosis:
    t0 = time.perf_counter()
    settings = settings or DiagnosisSettings()
    spec: ReducerSpec = dataset.reducer
    settings = settings.for_dataset(dataset)  # the orders the bench resolves, the alias-free model grid
    errors = errors or ErrorSpec()
    plan = plan_from_dataset(dataset, settings)
    y, lay, windows = measured_runs(dataset, plan, settings)
    cands, unavailable = available_candidates(effects, plan)
    cal = calibration_parameters(nominal, spec, plan, unavailable)
    replaced = {REPLACES[c.name] for c in cal if c.name in REPLACES}
    cands = tuple(e for e in cands if e.name not in replaced)
    cache = Path(cache_dir) if cache_dir else None
    runner = ModelRunner(spec, errors, plan, settings, law, cache, progress)

    # --- the data anchor: the unit's torsional stiffness against the nominal model's; far off, every stiffness
    # is scaled and calibration starts there (f_spec, resp_spec: the model as specified, the gap before)
    anc, runner, f_spec, resp_spec = anchored(runner, cal, y, lay, plan)
    spec = runner.spec
    cal = within_spec_rules(cal, spec)
    runner.run([()] + sensitivity_runs(cands + cal))  # the baseline alongside the sensitivities' runs
    f0, resp0 = baseline_response(runner)
    w = weights(f0, y, lay, settings, spec.cycloid.pin_count)
    nuis = nuisance_columns(lay)
    prob = Problem.build(y, lay, w, nuis)
    n, n_nuis = lay.n, nuis.shape[1]

    sens, failed = sensitivities(runner, cands + cal, f0, resp0, plan, settings, lay)
    for c in cal:
        if c.name in failed:
            unavailable[c.name] = f"not calibrated: {reason_line(failed.pop(c.name))}"
    cal = tuple(c for c in cal if c.name in sens and c.name not in unavailable)
    not_evaluated = dict(failed)  # candidates without sensitivities (later entries: failed refinements)
    held = undetermined(cal, sens, w, nuis)  # what the runs cannot tell from noise stays nominal
    cal = tuple(c for c in cal if c.name not in held)
    size = {e.name: signature_size(e, sens, w) for e in cands + cal if e.name in sens}
    usable = [e for e in cands if e.name in sens and e.name not in failed]

    # --- the nominal model as specified (the gap before calibration and before the anchor)
    x, nu, d, rss, A = lin_fit(prob, f_spec, np.zeros((n, 0)), np.zeros(0), np.zeros(0), np.zeros(0))
    nominal_model = make_candidate((), x, nu, d, rss, A, n, n_nuis, f_spec, refined=True, response=resp_spec)

    # --- stage 1, calibration: the nominal parameters alone, refined with the model in the loop
    sens_nominal = sens  # the secants about the anchored nominal model (the rebase replaces the fidelity ones)
    calib, sens = calibrated(prob, runner, sens, cal, f0, resp0, lay, settings, failed, n_nuis)
    x_cal = calib.x
    f_cal = calib.model_features
    J_cal = calib.jacobian
    # stage 2 keeps the stated priors: an effect competes with the nominal parameters on equal terms (narrowing
    # them to the calibrated values let calibration keep what an effect explains: measured, a hidden thermal
    # mismatch was absorbed by the stiffnesses and the clearance)
    # (its RSS with the prior penalty, as every candidate's, which fits the same nominal parameters)
    none = evaluated_candidate(prob, cal, x_cal, f_cal, calib.response or resp0, J_cal, n_nuis,
                               refined=calib.refined, note="calibrated nominal model")

    # --- stage 2, attribution: each candidate effect (and pair) with the nominal parameters, linearised
    # about the calibrated model (its model run and Broyden Jacobian), on all features
    J_nominal = np.column_stack([sens_nominal.plus[c.name] for c in cal]) if cal else np.zeros((n, 0))
    lo_c, hi_c = bounds(cal)

    def lin(effs, about_nominal: bool = False, corners: bool = False):
        effs = tuple(effs)
        prior = prior_of(cal + effs)
        x_c, f_b, J_b = (np.zeros(len(x_cal)), f0, J_nominal) if about_nominal else (x_cal, f_cal, J_cal)
        x_ref = np.r_[x_c, np.zeros(sum(e.n for e in effs))]
        best = None
        for Je, lo, hi in sens.orthants(effs, corners):  # two-sided parameters: each sign with its own secant
            J = np.column_stack([J_b, Je])
            lo_, hi_ = np.r_[lo_c, lo], np.r_[hi_c, hi]
            fit_ = lin_fit(prob, f_b, J, x_ref, lo_, hi_, prior=prior)
            if best is None or fit_[3] < best[0][3]:
                best = (fit_, J, lo_, hi_)
        if best is None:
            return None
        (x, nu, d, rss, A), J, lo, hi = best
        return make_candidate(cal + effs, x, nu, d, rss, A, n, n_nuis, f_b + J @ (x - x_ref), refined=False,
                              note="linearised about the nominal model" if about_nominal else "linearised",
                              jacobian=J, box=(lo, hi), base=(x_ref, f_b))

    # a second start about the anchored nominal model: the calibration alone can stand in for an effect with a
    # far-fetched mix of its parameters, and linearised about that mix the effect finds nothing (measured, same-
    # family self-check seed 1, case 0: a hidden series compliance taken as contact stiffness ×3.33 with needle
    # bearings ×0.46, weighted RSS with the priors 120.0; the compliance fitted about it 118.2, while the drawn
    # compliance with the drawn stiffnesses gives 89.6). Only for an effect without evidence about the calibration:
    # where the effect has some, a start far from the calibration can fit the model-form gap better and the effect
    # worse (measured, far self-check seed 1, case 10: a hidden 8.9 ppm/K thermal mismatch fitted at 8.0 ppm/K about
    # the calibration, score 74, confirmed; from the nominal model at 13.0 ppm/K, score 153, refuted by the TE runs'
    # fold). Kept when its linearised fit is better by the evidence threshold than the fit about the calibration and
    # than the calibration alone linearised about the nominal model (each kept start costs model runs), with its twin
    # about the calibration refined beside it (the better real residual stays)
    twins = {}
    # the calibration alone linearised about the nominal model: what that linearisation gains without any effect
    # (linearised so far from the calibration it is optimistic: measured, far self-check seed 2, case 2, weighted RSS
    # 330 against the calibrated model's 474, which five effects with no signature there then "shared")
    rss_nominal = (lin_fit(prob, f0, J_nominal, np.zeros(len(x_cal)), lo_c, hi_c, prior=prior_of(cal))[3]
                   if settings.nominal_start else math.inf)
    # trusted only where it does not promise the calibration more than the model run at the calibration gave
    # (measured: 123.0 against 120.0 in the case above; 330 against 474 in the far case where its effect fits were
    # spurious, 188 against 264 in far seed 3's case 6)
    nominal_trusted = settings.nominal_start and rss_nominal >= none.rss - settings.bic_threshold

    # a third start for an effect whose two parameters nearly cancel along a diagonal (Effect.corners): its fit
    # through the corner secants, refined beside the others (measured, realistic self-check seed 5, case 6: a hidden
    # moved/equidistant deviation of −5.3/−4.2 µm, fitted from the axes' secants at 0.07/−0.47 µm, weighted RSS
    # 199.6; the calibration with the drawn deviation in the model reaches 159.4)
    corner_twins = {}

    def lin_best(effs, about_nominal: bool = True):
        c = _lin_best(effs, about_nominal)
        if (t := lin(effs, corners=True)) is not None:
            corner_twins[t.name] = t
        return c

    def _lin_best(effs, about_nominal: bool = True):
        here = lin(effs)
        if not (about_nominal and nominal_trusted) or score_of(here) >= settings.bic_threshold:
            return here  # (an effect with evidence about the calibration keeps that fit: the rescue is for the hidden)
        there = lin(effs, about_nominal=True)
        # better by the evidence an effect must bring, against the fit about the calibration and against the
        # calibration alone linearised the same way (the effect's own share of the gain)
        if there.rss > min(here.rss, rss_nominal) - settings.bic_threshold:
            return here
        twins[there.name] = here
        return there

    def with_twins(cands: list) -> list:  # (a scored candidate is a copy: its twin is found by name)
        return list(cands) + [t[c.name] for t in (twins, corner_twins) for c in cands
                              if c.name in t and not c.refined]

    def best_per_name(cands: list) -> list:
        best = {}
        for c in cands:
            if c.name not in best or c.rss < best[c.name].rss:
                best[c.name] = c
        return list(best.values())

    # the fidelity effects (the contact-law form, the elastic discs) enter every evaluation as the difference their
    # model makes, measured about the calibration; a candidate whose errors move every contact the same way (a
    # profile deviation of a few µm, the pin circle grown by thermal expansion) changes that difference, so each such
    # refined candidate has it measured again about its own point and is refined on from there, as the calibration
    # is (the better real residual stays; measured, realistic self-check seed 5, case 14: a hidden 9.98 ppm/K thermal
    # mismatch fitted at 5.85 ppm/K, weighted RSS 1074, and at 9.82 ppm/K, RSS 393, with the differences about itself)
    # an effect that is another one with parameters held at zero (Effect.same_as: the pin friction's Coulomb torque
    # is the output friction without its load-proportional part) is the same model run: each fit is restated as the
    # other where its values allow, so both carry the better fit and the evidence prefers the fewer parameters
    # (measured, realistic self-check seed 5, case 13: a hidden pin friction of 0.013 fitted as output friction
    # 0.0148 with no load-proportional part, score 847.7, and as pin friction 0.0068, score 838.9, the refinement
    # stalled; named output friction)
    effect_of = {e.name: e for e in usable}

    def settled(cands: list) -> list:  # re-measured about themselves, and restated
        cands = best_per_name(cands)
        cands += _about_themselves(prob, runner, sens, cands, f0, resp0, settings, n_nuis)
        named = {frozenset(e.name for e in c.attributed): [e.name for e in c.attributed] for c in ranked}
        return best_per_name(cands + [_ordered(r, named) for c in cands if c.refined
                                      for r in restated(prob, c, effect_of, sens, n_nuis)])

    # --- the discrepancy the calibrated model leaves, per order band and run: every score is measured against it
    folds = withheld_folds(plan)
    groups = feature_groups(lay, plan, spec.cycloid.pin_count)
    disc = Discrepancy.of(prob, none, groups)

    def score_of(c: Candidate) -> float:
        return (none.bic - c.bic if settings.evidence_model == "bic"
                else evidence(prob, c, none, disc, settings.discrepancy_pooling))

    singles = sorted((lin_best((e,)) for e in usable), key=lambda c: c.bic)
    from_nominal = {c.name for c in singles if c.name in twins}
    # pairs: every pair of effects (or those with one of the best pair_top singles) — a weak second
    # effect need not rank high alone while a strong one dominates the gap, and two effects can act
    # only together; kept only when the second effect has evidence given the better single
    lead = {c.attributed[0].name for c in singles[: settings.pair_top]} if settings.pair_top else None
    by_name = {c.name: c for c in singles}
    pairs = []
    for a, b in itertools.combinations([c.attributed[0] for c in singles], 2):
        if lead is not None and a.name not in lead and b.name not in lead:
            continue
        c = lin_best((a, b), about_nominal=bool({a.name, b.name} & from_nominal))
        if second_effect_adds(c, by_name, settings, score_of):
            pairs.append(c)
    ranked = sorted(singles + pairs, key=lambda c: c.bic)

    # --- model in the loop: the candidates the verdict will rank first, by the same score (their linearised
    # fits), and the best single by the linearised BIC. Chosen by the BIC alone, the leader by the evidence was
    # often left linearised and so could not be accepted (measured on 80 self-check and foreign
    # benches: 22 leaders unrefined, among them hidden thermal mismatches at score 639 and 72 and a series
    # compliance at 36, each reported as "its model-in-the-loop evaluation failed")
    by_score = sorted(ranked, key=lambda c: -score_of(c))
    to_refine = by_score[: settings.refine_top]
    if singles and singles[0] not in to_refine:
        to_refine.append(singles[0])
    refined = settled(refine(with_twins(to_refine), prob, runner, sens, f0, resp0, settings, failed, n_nuis))
    refined_names = {c.name for c in refined}
    allc = refined + [c for c in ranked if c.name not in refined_names]
    # the pair rule again with the model-in-the-loop residuals where there are some
    best_single = {}

    def note_singles(cands: list) -> None:  # each single's best fit so far (refined ones by their real residual)
        for c in cands:
            if len(c.attributed) == 1 and (c.name not in best_single or c.rss < best_single[c.name].rss):
                best_single[c.name] = c

    def adding(cands: list) -> list:  # the singles, and the pairs whose second effect adds to their better single
        return [c for c in cands if len(c.attributed) == 1 or second_effect_adds(c, best_single, settings, score_of)]

    note_singles(allc)
    allc = adding(allc)

    # --- scores against the calibrated model, shrink of what calibration left, withheld check
    none = dc.replace(none, gap_shrink_pct=_shrink(none.rss, nominal_model.rss),
                      withheld=withheld_check(prob, plan, none, nominal_model, f0, folds))

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
        return dc.replace(c, score=score_of(c), bic_score=none.bic - c.bic, gap_shrink_pct=_shrink(c.rss, none.rss),
                          withheld=wh)

    out = sorted((scored(c) for c in allc), key=lambda c: -c.score)
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
        again = settled(refine(with_twins(nxt), prob, runner, sens, f0, resp0, settings, failed, n_nuis))
        out = [c for c in out if all(c is not s for s in nxt)] + [scored(c) for c in again]
        if pair_singles:
            note_singles(again)
            out = [scored(c) if len(c.attributed) > 1 else c for c in adding(out)]
        if not again:  # its evaluation failed: kept linearised, and named so in the verdict
            out += nxt
        out.sort(key=lambda c: -c.score)
    # --- grades: a candidate that passes the tests is established only beyond what healthy units of other model
    # forms make of it (the null distribution) and when it explains most of what calibration left where its
    # signature lies; the others that pass are consistent but not established
    null = _null_of(settings, spec)
    r_cal = residual(prob, none)  # what calibration left, once for every candidate
    out = [dc.replace(c, grade=grade(c, settings, null, explained_where_it_lies(prob, c, r_cal, disc))) for c in out]
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
    ties_to_parts = part_ties(spec, chosen) if chosen is not None else []
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
    return Diagnosis(dataset, settings, plan, lay, w, y, none, none.response or resp0, tuple(final), chosen,
                     folds, unavailable, failed, size, text, runner.model_runs,
                     time.perf_counter() - t0, tied, nominal_model, windows, cal_ties, runs_needed, held, anc, disc,
                     lookalikes, sens, tuple(ties_to_parts))


def _null_of(settings: DiagnosisSettings, spec: ReducerSpec):
    """The null distribution ``settings.null_distribution`` names (None: none), for the unit ``spec`` is a
    variant of (:meth:`~rvflex.diagnosis.null.NullDistribution.for_spec`)."""
    if settings.null_distribution is None:
        return None
    null = load_null(None if settings.null_distribution == "builtin" else settings.null_distribution)
    return null.for_spec(spec) if null is not None else None


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


def _alike_at_every_pin(runner: ModelRunner, c: Candidate) -> bool:
    """Whether the model of ``c`` (the runner's with its model effects applied) is alike at every pin
    (:func:`~rvflex.diagnosis.replay.one_period`): its errors change every contact the same way."""
    spec, errors = runner.spec, runner.errors
    for e, x in split_params(c.effects, c.x):
        if e.kind == "model":
            spec, errors = e.apply_to(spec, errors, x, runner.plan[0])
    return one_period(1, spec, errors, ModelOptions.rigid()) is not None


def _about_themselves(prob: Problem, runner: ModelRunner, sens: Sensitivities, cands: list[Candidate], f0,
                      resp0, settings: DiagnosisSettings, n_nuis: int) -> list[Candidate]:
    """Each of ``cands`` that attributes a model effect alike at every pin, evaluated with the fidelity effects'
    differences measured about its own point, and the refinement continued from there (all in common batches;
    one whose model run fails is left out)."""
    todo = [c for c in cands if any(e.kind == "model" for e in c.attributed)
            and any(e.kind == "fidelity" for e in c.effects) and _alike_at_every_pin(runner, c)]
    bases = [tuple((e, x) for e, x in split_params(c.effects, c.x) if e.kind != "fidelity") for c in todo]
    sets = [fidelity_sets(sens, c.effects, b) for c, b in zip(todo, bases)]
    outs = runner.run(list(bases) + [s for ss in sets for s in ss])
    at_base, outs = outs[:len(todo)], outs[len(todo):]
    kept, each = [], []
    for c, b, ss, (fb, rb, _) in zip(todo, bases, sets, at_base):
        mine, outs = outs[:len(ss)], outs[len(ss):]
        if fb is not None:
            sens_c, _ = rebased_from(sens, c.effects, b, fb, rb, mine, resp0, prob.lay)
            kept.append(c)
            each.append(sens_c)
    done = [(at, sens_c) for at, sens_c in zip(evaluated_each(prob, runner, each, kept, f0, resp0, n_nuis), each)
            if at is not None]
    steps = [linearised_step(prob, at, n_nuis, "fidelity differences about itself") for at, _ in done]
    return [at for at, _ in done] + (refine(steps, prob, runner, [sn for _, sn in done], f0, resp0, settings, {},
                                            n_nuis) if steps else [])


def restated(prob: Problem, c: Candidate, by_name: dict, sens: Sensitivities, n_nuis: int) -> list[Candidate]:
    """``c`` with one effect exchanged for the effect it is the same model as (``Effect.same_as``, either way:
    to the larger effect always, to the smaller one when the parameters it lacks are zero): the same model
    run and residual, the Jacobian's columns mapped (a parameter added at zero takes its secant)."""
    out = []
    names = [e.name for e in c.effects]
    for i, e in enumerate(c.effects):
        pairs = [(e, by_name.get(e.same_as[0]), True)] if e.same_as else []
        pairs += [(o, e, False) for o in by_name.values() if o.same_as and o.same_as[0] == e.name]
        for small, big, up in pairs:
            if big is None or small is None or (big if up else small).name in names or big.name not in sens:
                continue
            start = sum(f.n for f in c.effects[:i])
            cols = c.jacobian[:, start:start + e.n]
            xe = c.x[start:start + e.n]
            mapping = small.same_as[1]
            if up:
                x_new = np.array([0.0 if j is None else xe[j] for j in mapping])
                J_new = np.column_stack([sens.plus[big.name][:, k] if j is None else cols[:, j]
                                         for k, j in enumerate(mapping)])
            else:
                if any(j is None and xe[k] != 0.0 for k, j in enumerate(mapping)):
                    continue
                order = sorted((j, k) for k, j in enumerate(mapping) if j is not None)
                x_new = np.array([xe[k] for _, k in order])
                J_new = np.column_stack([cols[:, k] for _, k in order])
            effects = c.effects[:i] + ((big if up else small),) + c.effects[i + 1:]
            x = np.r_[c.x[:start], x_new, c.x[start + e.n:]]
            J = np.column_stack([c.jacobian[:, :start], J_new, c.jacobian[:, start + e.n:]])
            out.append(evaluated_candidate(prob, effects, x, c.model_features, c.response, J, n_nuis,
                                           note=c.note + "; restated" if c.note else "restated"))
    return out


def _ordered(c: Candidate, named: dict) -> Candidate:
    """``c`` with its effects in the order the candidate ``named`` lists for the same set has (the same name)."""
    order = named.get(frozenset(e.name for e in c.attributed))
    if order is None or order == [e.name for e in c.attributed]:
        return c
    by = {e.name: e for e in c.attributed}
    effects = tuple(e for e in c.effects if e.nominal) + tuple(by[nm] for nm in order)
    pos = {e.name: k for k, e in enumerate(c.effects)}
    start = np.cumsum([0] + [e.n for e in c.effects])
    idx = np.concatenate([np.arange(start[pos[e.name]], start[pos[e.name]] + e.n) for e in effects])
    perm = [pos[e.name] for e in effects]

    def cut(a):
        return None if a is None else a[idx]

    return dc.replace(c, effects=effects, x=c.x[idx], interval=c.interval[idx], jacobian=c.jacobian[:, idx],
                      magnitude=tuple(c.magnitude[k] for k in perm),
                      magnitude_interval=tuple(c.magnitude_interval[k] for k in perm),
                      lower=cut(c.lower), upper=cut(c.upper), base_x=cut(c.base_x))


def _shrink(rss: float, ref: float) -> float:
    return 100.0 * (1.0 - math.sqrt(rss / ref)) if ref > 0 else 0.0

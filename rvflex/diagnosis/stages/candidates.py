"""The candidates stage of a diagnosis: every candidate effect, and every pair, fitted *together with* the
nominal parameters (same regularisers, linearised about the calibrated model), so an effect gets only what
calibration cannot explain. A pair is kept only when its second effect has evidence ≥ ``bic_threshold`` given the
better single. The best ``refine_top`` candidates by their score (from the linearised fits) and the best single by
the linearised BIC (and any named in ``also_refine``) are refined with the model in the loop
(:mod:`rvflex.diagnosis.refine`), measured again about themselves where their errors move every contact alike, and
restated as the effect they are the same model as."""

from __future__ import annotations

import dataclasses as dc
import itertools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from rvflex.diagnosis.calibrate import evaluated_each, linearised_step
from rvflex.diagnosis.linear import Candidate, bounds, lin_fit, make_candidate, prior_of, split_params
from rvflex.diagnosis.refine import evaluated_candidate, refine
from rvflex.diagnosis.replay import one_period
from rvflex.diagnosis.runs import ModelRunner
from rvflex.diagnosis.sensitivity import fidelity_sets, rebased_from, second_effect_adds
from rvflex.diagnosis.settings import DiagnosisSettings
from rvflex.diagnosis.stages.calibration import Calibrated
from rvflex.options import ModelOptions

if TYPE_CHECKING:
    from rvflex.diagnosis.linear import Problem, Sensitivities

__all__ = ["Attribution", "Candidates", "adding", "from_pairs", "note_singles", "restated", "run"]


@dataclass(frozen=True, eq=False)
class Attribution:
    """What a refinement of candidates draws on: the calibration, the linearised ranking (singles and kept
    pairs, by BIC) and the twins of the candidates fitted from other starts (name → the fit refined beside it)."""

    calibrated: Calibrated
    ranked: tuple[Candidate, ...]
    twins: dict  # of a candidate linearised about the nominal model: its fit about the calibration
    corner_twins: dict  # of an effect with corners (Effect.corners): its fit through the corner secants

    def with_twins(self, cands: list) -> list:
        """``cands`` and the twins of those not refined (a scored candidate is a copy: its twin is found by name)."""
        return list(cands) + [t[c.name] for t in (self.twins, self.corner_twins) for c in cands
                              if c.name in t and not c.refined]

    def settled(self, cands: list) -> list:
        """The best fit per name of ``cands`` and of their versions re-measured about themselves and restated.

        The fidelity effects (the contact-law form, the elastic discs) enter every evaluation as the difference their
        model makes, measured about the calibration; a candidate whose errors move every contact the same way (a
        profile deviation of a few µm, the pin circle grown by thermal expansion) changes that difference, so each
        such refined candidate has it measured again about its own point and is refined on from there, as the
        calibration is (the better real residual stays; measured, realistic self-check seed 5, case 14: a hidden 9.98
        ppm/K thermal mismatch fitted at 5.85 ppm/K, weighted RSS 1074, and at 9.82 ppm/K, RSS 393, with the
        differences about itself). An effect that is another one with parameters held at zero (Effect.same_as: the pin
        friction's Coulomb torque is the output friction without its load-proportional part) is the same model run:
        each fit is restated as the other where its values allow, so both carry the better fit and the evidence
        prefers the fewer parameters (measured, realistic self-check seed 5, case 13: a hidden pin friction of 0.013
        fitted as output friction 0.0148 with no load-proportional part, score 847.7, and as pin friction 0.0068,
        score 838.9, the refinement stalled; named output friction).
        """
        calib = self.calibrated
        feat = calib.features
        prob, runner, sens, n_nuis = feat.problem, feat.runner, calib.sensitivities, feat.n_nuis
        effect_of = {e.name: e for e in feat.usable}
        cands = best_per_name(cands)
        cands += _about_themselves(prob, runner, sens, cands, feat.baseline, feat.baseline_response,
                                   feat.bench.settings, n_nuis)
        named = {frozenset(e.name for e in c.attributed): [e.name for e in c.attributed] for c in self.ranked}
        return best_per_name(cands + [_ordered(r, named) for c in cands if c.refined
                                      for r in restated(prob, c, effect_of, sens, n_nuis)])

    def refined(self, cands: list, failed: dict) -> list:
        """``cands`` and their twins refined with the model in the loop, then settled (:meth:`settled`);
        refinements that fail are added to ``failed``."""
        calib = self.calibrated
        feat = calib.features
        return self.settled(refine(self.with_twins(cands), feat.problem, feat.runner, calib.sensitivities,
                                   feat.baseline, feat.baseline_response, feat.bench.settings, failed, feat.n_nuis))


@dataclass(frozen=True, eq=False)
class Candidates:
    """Every candidate the evidence weighs: the refined ones first, then the linearised rest."""

    attribution: Attribution
    candidates: tuple[Candidate, ...]
    best_single: dict  # each single's best fit (refined ones by their real residual), name → candidate
    failed: dict  # candidates without sensitivities and refinements that failed: why


def run(calib: Calibrated) -> Candidates:
    """Each candidate effect (and pair) fitted with the nominal parameters, linearised about the calibrated
    model (its model run and Broyden Jacobian), on all features; the leaders refined with the model in the loop."""
    feat = calib.features
    prob, sens, settings, cal, usable = feat.problem, calib.sensitivities, feat.bench.settings, feat.to_calibrate, feat.usable
    n, n_nuis, f0 = feat.bench.layout.n, feat.n_nuis, feat.baseline
    none, score_of = calib.model, calib.score
    x_cal, f_cal, J_cal = calib.calibration.x, calib.calibration.model_features, calib.calibration.jacobian
    # the stated priors are kept: an effect competes with the nominal parameters on equal terms (narrowing
    # them to the calibrated values let calibration keep what an effect explains: measured, a hidden thermal
    # mismatch was absorbed by the stiffnesses and the clearance)
    J_nominal = np.column_stack([feat.sensitivities.plus[c.name] for c in cal]) if cal else np.zeros((n, 0))
    lo_c, hi_c = bounds(cal)

    def lin(effs, about_nominal: bool = False, corners: bool = False):
        effs = tuple(effs)
        prior = prior_of(cal + effs)
        x_c, f_b, J_b = (np.zeros(len(x_cal)), f0, J_nominal) if about_nominal else (x_cal, f_cal, J_cal)
        x_ref = np.r_[x_c, np.zeros(sum(e.n for e in effs))]
        best = None
        about = feat.sensitivities if about_nominal else sens  # the effects' secants about the same point
        for Je, lo, hi in about.orthants(effs, corners):  # two-sided parameters: each sign with its own secant
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
    att = Attribution(calib, tuple(ranked), twins, corner_twins)

    # --- model in the loop: the candidates the verdict will rank first, by the same score (their linearised
    # fits), and the best single by the linearised BIC. Chosen by the BIC alone, the leader by the evidence was
    # often left linearised and so could not be accepted (measured on 80 self-check and foreign
    # benches: 22 leaders unrefined, among them hidden thermal mismatches at score 639 and 72 and a series
    # compliance at 36, each reported as "its model-in-the-loop evaluation failed")
    by_score = sorted(ranked, key=lambda c: -score_of(c))
    to_refine = by_score[: settings.refine_top]
    if singles and singles[0] not in to_refine:
        to_refine.append(singles[0])
    to_refine += [c for c in ranked if c.name in settings.also_refine and c not in to_refine]
    failed = dict(calib.failed)
    refined = att.refined(to_refine, failed)
    so_far = {}
    note_singles(so_far, refined + ranked)
    starts = from_pairs(refined, so_far, x_cal, f_cal, prob, n_nuis)
    if starts:  # a start that fails leaves the single's other fits standing: its failure is not the name's
        refined = best_per_name(refined + att.settled(refine(starts, prob, feat.runner, sens, f0,
                                                             feat.baseline_response, settings, {}, n_nuis)))
    refined_names = {c.name for c in refined}
    allc = refined + [c for c in ranked if c.name not in refined_names]
    # the pair rule again with the model-in-the-loop residuals where there are some
    best_single = {}
    note_singles(best_single, allc)
    allc = adding(allc, best_single, settings, score_of)
    return Candidates(att, tuple(allc), best_single, failed)


def from_pairs(refined: list, best_single: dict, x_cal: np.ndarray, f_cal: np.ndarray, prob: Problem,
               n_nuis: int) -> list[Candidate]:
    """Starts for single effects at the values their refined pairs found: each effect of a refined pair whose value
    there lies outside the 95 % interval of its best single fit, with the pair's nominal parameters and the pair's
    Jacobian columns, linearised about the calibration (the refinement's first evaluation is at the start).

    An effect whose response has a dead zone is left near zero by its own fits: the pin circle grown by a thermal
    mismatch opens play only once it exceeds the modification's interference, so linearised about the calibration
    it sees little, and the calibration's clearance and stiffnesses take up that little. A pair, its second effect
    taking up part of the model-form gap, can step past the dead zone; the single then deserves a fit from there
    (measured, foreign bench 2 V04: a hidden 5.7 ppm/K mismatch fitted alone at 0.57 ppm/K [0.31, 0.83], RSS
    within 1 % of the calibration's; paired with a pin-ring runout at 5.04 ppm/K)."""
    out = []
    for c in refined:
        if len(c.attributed) != 2 or c.jacobian is None:
            continue
        cal = tuple(e for e in c.effects if e.nominal)
        start = np.cumsum([0] + [e.n for e in c.effects])
        pos = {e.name: k for k, e in enumerate(c.effects)}
        ncal = int(start[len(cal)])
        if ncal != len(x_cal):
            continue
        for e in c.attributed:
            single = best_single.get(e.name)
            k = pos[e.name]
            m = e.magnitude(c.x[start[k]:start[k + 1]])
            if single is None or m == 0.0:
                continue
            lo, hi = single.magnitude_interval[-1]
            if lo <= m <= hi:
                continue
            keep = np.r_[np.arange(ncal), np.arange(start[k], start[k + 1])]
            effects, J = cal + (e,), c.jacobian[:, keep]
            x_ref = np.r_[x_cal, np.zeros(e.n)]
            out.append(make_candidate(effects, c.x[keep], c.nuisance, c.delta, c.rss, prob.weighted_design(J),
                                      prob.lay.n, n_nuis, c.model_features, refined=False,
                                      note="started from its pair", jacobian=J, base=(x_ref, f_cal)))
    return out


def best_per_name(cands: list) -> list:
    """The fit with the lowest residual of each name in ``cands``."""
    best = {}
    for c in cands:
        if c.name not in best or c.rss < best[c.name].rss:
            best[c.name] = c
    return list(best.values())


def note_singles(best_single: dict, cands: list) -> None:
    """Enter in ``best_single`` each single's best fit so far (refined ones by their real residual)."""
    for c in cands:
        if len(c.attributed) == 1 and (c.name not in best_single or c.rss < best_single[c.name].rss):
            best_single[c.name] = c


def adding(cands: list, best_single: dict, settings: DiagnosisSettings, score) -> list:
    """The singles of ``cands``, and the pairs whose second effect adds to their better single
    (:func:`~rvflex.diagnosis.sensitivity.second_effect_adds`)."""
    return [c for c in cands if len(c.attributed) == 1 or second_effect_adds(c, best_single, settings, score)]


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

"""Secant sensitivities of the candidate effects and nominal parameters (one model run per parameter
at its typical step, cleared of the model's numerical noise), the size of each signature, and which
candidates a dataset can evaluate."""

from __future__ import annotations

import dataclasses as dc
import itertools
import math
from pathlib import Path

import numpy as np

from rvflex.diagnosis.effects import Effect, available_effects
from rvflex.diagnosis.features import features
from rvflex.diagnosis.linear import Candidate, Sensitivities, denoise_orders, weights
from rvflex.diagnosis.replay import EvaluationFailed, Response, recorded
from rvflex.diagnosis.runs import ModelRunner
from rvflex.diagnosis.settings import DiagnosisSettings
from rvflex.spec import ErrorSpec, ReducerSpec

__all__ = ["available_candidates", "fidelity_sets", "rebase_effects", "rebase_fidelity", "rebased_from", "second_effect_adds",
           "sensitivities", "sensitivity_runs", "signature_size", "signature_sizes"]


def available_candidates(effects, plan) -> tuple[tuple[Effect, ...], dict]:
    """The candidate effects the model can evaluate for ``plan``, and the reasons of the others."""
    cands, unavailable = available_effects(effects)
    ok = []
    for e in cands:
        avail, why = e.available_for(plan)
        if avail:
            ok.append(e)
        else:
            unavailable[e.name] = why
    return tuple(ok), unavailable


def signature_size(e: Effect, sens: Sensitivities, w: np.ndarray) -> float:
    """||w·ΔF||/√(parameters) at the typical step (rms of the two sides for two-sided effects)."""
    size2 = float(np.sum(((sens.plus[e.name] * e.steps[None, :]) * w[:, None]) ** 2))
    if e.name in sens.minus:
        size2 = 0.5 * (size2 + float(np.sum(((sens.minus[e.name] * e.steps[None, :]) * w[:, None]) ** 2)))
    return math.sqrt(size2 / e.n)


def second_effect_adds(pair: Candidate, singles: dict, settings: DiagnosisSettings, score=None) -> bool:
    """Whether the pair's second effect earns its place against the better of its two single effects.

    With the discrepancy model and ``score`` (a candidate's evidence against the calibrated model's
    discrepancy): the pair's evidence exceeds the better single's by ≥ ``bic_threshold`` (the evidence of the
    second effect given the first, against the same discrepancy). Otherwise: against the better single by
    residual the pair removes ≥ ``min_shrink_pct`` of the remaining weighted gap and improves the BIC by
    ≥ ``bic_threshold``."""
    subs = [singles[e.name] for e in pair.attributed if e.name in singles]
    if not subs:
        return False
    if score is not None and settings.evidence_model != "bic":
        return score(pair) - max(score(c) for c in subs) >= settings.bic_threshold
    sub = min(subs, key=lambda c: c.rss)
    if sub.rss <= 0:
        return False
    shrink = 100.0 * (1.0 - math.sqrt(pair.rss / sub.rss))
    return shrink >= settings.min_shrink_pct and sub.bic - pair.bic >= settings.bic_threshold


def _side_step(e: Effect, prm, sign: float) -> float:
    """The secant step of a two-sided effect on one side: the typical step, or the parameter's
    bound on that side when nearer (a secant from beyond the range mis-states the response within
    it: measured, the −11.5 ppm/K secant of a thermal mismatch bounded at −5 ppm/K, deep in the
    preload the shrinking pin circle makes)."""
    if not e.two_sided:
        return prm.step
    room = prm.high if sign > 0 else -prm.low
    return min(prm.step, room) if room > 0 else prm.step


def _jobs(cands, base: tuple = ()) -> tuple[list[tuple], list[tuple]]:
    """The model evaluations of the sensitivities (active sets, each after the model point ``base``) and what
    each is for (name, parameter index, sign or "coupled")."""
    base = tuple(base)
    jobs, owners = [], []
    for e in cands:  # one run per parameter (measurement effects need no model run)
        if e.kind == "measurement":
            continue
        for j, prm in enumerate(e.params):
            for sign in ((1.0, -1.0) if e.central or e.two_sided else (1.0,)):
                x = np.zeros(e.n)
                x[j] = sign * _side_step(e, prm, sign)
                jobs.append(base + ((e, x),))
                owners.append((e.name, j, sign))
        if e.corners:  # the four corners (±step, ±step), each parameter's step on its side
            for signs in itertools.product((1.0, -1.0), repeat=2):
                x = np.array([sg * _side_step(e, prm, sg) for sg, prm in zip(signs, e.params)])
                jobs.append(base + ((e, x),))
                owners.append((e.name, None, (signs, x)))
    # coupled effects: the same step on the model of the fidelity effect they are coupled to (at its step)
    by_name = {c.name: c for c in cands}
    for name, fid in _coupled(cands).items():
        e = by_name[name]
        for j, prm in enumerate(e.params):
            x = np.zeros(e.n)
            x[j] = prm.step
            jobs.append(base + ((e, x), (fid, np.array([fid.params[0].step]))))
            owners.append((name, j, "coupled"))
    return jobs, owners


def _coupled(cands) -> dict:
    """The effects coupled to a fidelity effect among ``cands``: name → that fidelity effect."""
    by_name = {c.name: c for c in cands}
    return {e.name: by_name[e.coupled_to] for e in cands
            if e.coupled_to in by_name and by_name[e.coupled_to].kind == "fidelity"}


def sensitivity_runs(cands) -> list[tuple]:
    """The model evaluations (active sets) :func:`sensitivities` of ``cands`` asks for (to run them
    alongside others in one batch)."""
    return _jobs(cands)[0]


def sensitivities(runner, cands, f0, resp0, plan, settings, lay, base: tuple = ()) -> tuple[Sensitivities, dict]:
    """Secant sensitivities (features per unit parameter) of every candidate, and the failures; about the model
    point ``base`` ((Effect, x) pairs, its features ``f0``) when one is given, else about the nominal model."""
    n = lay.n
    jobs, owners = _jobs(cands, base)
    by_name = {c.name: c for c in cands}
    coupled = _coupled(cands)
    # (the runner runs the slow runs of a batch, the elastic discs' models, first)
    outs = runner.run(jobs)
    sens: dict[str, np.ndarray] = {}
    minus: dict[str, np.ndarray] = {}
    failed: dict[str, str] = {}
    for e in cands:
        if e.kind == "measurement":
            cols = []
            for j, prm in enumerate(e.params):
                x = np.zeros(e.n)
                x[j] = prm.step
                fj, _ = features(recorded(resp0, plan, settings, [(e, x)], runner.spec), plan, settings)
                cols.append((fj - f0) / prm.step)
            sens[e.name] = np.column_stack(cols)
    responses = {}
    flexed = {}
    corners: dict[str, dict] = {}
    for (name, j, sign), (fj, rj, msg) in zip(owners, outs):
        if sign == "coupled":
            flexed[(name, j)] = (fj, msg)
            continue
        if j is None:  # a corner: its feature change; a failed one is left out (the axes' secants stay)
            if fj is not None:
                corners.setdefault(name, {})[sign[0]] = (sign[1], fj - f0)
            continue
        e = by_name[name]
        if fj is not None and e.kind == "fidelity":
            responses[name] = rj
        if name in failed:
            continue
        if fj is None:
            failed[name] = f"model evaluation failed at the sensitivity step: {msg}"
            sens.pop(name, None)
            minus.pop(name, None)
            continue
        if e.two_sided and sign < 0:  # the −step secant (f0 − f−)/h, kept apart
            minus.setdefault(name, np.zeros((n, e.n)))[:, j] = (f0 - fj) / _side_step(e, e.params[j], -1.0)
            continue
        # one-sided: the secant (f+ − f0)/h; central: (f+ − f0)/(2h) + (f0 − f−)/(2h)
        scale = e.params[j].step * (2.0 if e.central else 1.0)
        sens.setdefault(name, np.zeros((n, e.n)))[:, j] += sign * (fj - f0) / scale
    # the coupling: the step's change on the fidelity model less its change on the rigid one, per unit
    # share·x; the secant used by the linear fits is the fidelity model's (the share is nominally 1)
    coupling = {}
    for name, fid in coupled.items():
        e = by_name[name]
        if name not in sens or fid.name not in sens:
            continue
        h_f = fid.params[0].step
        f_fid = f0 + sens[fid.name][:, 0] * h_f  # the fidelity model at its step
        cols = []
        for j, prm in enumerate(e.params):
            fj, msg = flexed[(name, j)]
            if fj is None:
                failed[name] = f"model evaluation failed at the sensitivity step on the {fid.name} model: {msg}"
                break
            cols.append(((fj - f_fid) / prm.step - sens[name][:, j]) / h_f)
        else:
            coupling[name] = (fid.name, np.column_stack(cols))
            sens[name] = sens[name] + coupling[name][1]
    for name in list(coupled):
        if name in failed:
            sens.pop(name, None)
    sens = {name: denoise_orders(v, lay) for name, v in sens.items()}
    minus = {name: denoise_orders(v, lay) for name, v in minus.items()}
    coupling = {name: (fid, denoise_orders(c, lay)) for name, (fid, c) in coupling.items()}
    corners = {name: {sg: (x, denoise_orders(df, lay)) for sg, (x, df) in c.items()} for name, c in corners.items()
               if name in sens}
    return Sensitivities(sens, minus, responses, coupling, corners=corners), failed


def rebase_effects(runner, sens: Sensitivities, effects, base: tuple, f_base: np.ndarray, resp0, settings,
                   lay) -> tuple[Sensitivities, dict]:
    """``sens`` with the secants of the model effects among ``effects`` (kind ``model`` and ``conditions``)
    measured again about the model point ``base`` ((Effect, x) pairs; ``f_base``: its rigid features) instead of
    the nominal model; returns it and the failures (name → why; a failed one keeps its nominal secant). A coupled
    effect keeps its coupling to its fidelity model.

    An effect's signature depends on the point it acts at, most where a calibrated clearance lets a part move:
    measured, RV-80E with a pin-ring runout of 8 µm at 240 N·m, order 78 of the TE 0.011″ with the eccentric
    bearings at no clearance and 0.535″ at 2 µm. A secant taken about the nominal model then needs a size many
    times the real one to give the same signature (a healthy unit's control of another model form fitted a 20 µm
    runout, at its bound, where about its calibration a few µm do).

    An effect with corners (``Effect.corners``: the modification deviation) keeps its secants about the nominal
    model: its two parameters nearly cancel along a diagonal on which the residual is flat, so where on it a fit
    lands is set by small differences between secants, and measured again about the calibration they moved it to
    the bound (measured, first foreign bench H03, a hidden 6 µm pin radius error: moved/equidistant fitted at
    2.1/7.7 µm about the nominal secants, at 5.8/10.0 µm, the bound, about the calibration's, the evidence the
    same); it has its fidelity differences measured about its own point instead (``stages.candidates``)."""
    mine = tuple(e for e in effects if e.kind in ("model", "conditions") and e.name in sens.plus and not e.corners)
    if not base or not mine:
        return sens, {}
    new, failed = sensitivities(runner, mine, f_base, resp0, runner.plan, settings, lay, base)
    plus, minus, corners = dict(sens.plus), dict(sens.minus), dict(sens.corners)
    for e in mine:
        if e.name not in new.plus:
            continue
        plus[e.name] = new.plus[e.name] + (sens.coupling[e.name][1] if e.name in sens.coupling else 0.0)
        minus.pop(e.name, None)
        corners.pop(e.name, None)
        if e.name in new.minus:
            minus[e.name] = new.minus[e.name]
        if e.name in new.corners:
            corners[e.name] = new.corners[e.name]
    return dc.replace(sens, plus=plus, minus=minus, corners=corners), failed


def rebase_fidelity(runner, sens: Sensitivities, effects, base: tuple, f_base: np.ndarray, resp_base,
                    resp0, lay) -> tuple[Sensitivities, dict]:
    """``sens`` with the fidelity effects among ``effects`` measured again about the model point ``base``
    ((Effect, x) pairs of model effects; ``f_base``, ``resp_base``: its rigid features and response) instead
    of the nominal model; returns it and the failures (name → why; a failed one keeps its nominal secant).

    A fidelity effect acts as the difference its model makes, added linearly by its share (see
    :mod:`rvflex.diagnosis.refine`); that difference depends on the other parameters (the point contact's on
    the clearance and the contact stiffness most), and measured at the nominal model it is wrong at a
    calibration far from it (measured, far self-check seed 3, control case 7: at the calibrated point the
    model with the nominal differences left a weighted RSS of 2397, the model run with its own 604, and the
    point contact preferred at share 1.5 where the model run prefers 1.0)."""
    sets = fidelity_sets(sens, effects, base)
    if not sets:
        return sens, {}
    return rebased_from(sens, effects, base, f_base, resp_base, runner.run(sets), resp0, lay)


def fidelity_sets(sens: Sensitivities, effects, base: tuple) -> list[tuple]:
    """The model runs :func:`rebase_fidelity` makes (active sets): each fidelity effect among ``effects`` at
    its step about ``base`` (none without a base)."""
    if not base:
        return []
    return [tuple(base) + ((e, np.array([e.params[0].step])),) for e in effects
            if e.kind == "fidelity" and e.name in sens.plus]


def rebased_from(sens: Sensitivities, effects, base: tuple, f_base: np.ndarray, resp_base, outs: list, resp0,
                 lay) -> tuple[Sensitivities, dict]:
    """:func:`rebase_fidelity` from the outputs ``outs`` of its model runs (:func:`fidelity_sets`, in order)."""
    fids = [e for e in effects if e.kind == "fidelity" and e.name in sens.plus]
    plus, responses, failed = dict(sens.plus), dict(sens.responses), {}
    for e, (fj, rj, msg) in zip(fids, outs):
        if fj is None:
            failed[e.name] = f"model evaluation failed about the calibrated parameters: {msg}"
            continue
        plus[e.name] = denoise_orders((fj - f_base) / e.params[0].step, lay)[:, None]
        if rj is not None and resp_base is not None and resp0 is not None:  # resp0 plus the difference at base
            responses[e.name] = Response(_moved(rj.te, resp_base.te, resp0.te), resp0.torque,
                                         _moved(rj.theta, resp_base.theta, resp0.theta))
    # a coupled effect's point moves with its fidelity effect's difference: where that was measured again
    done = {e.name for e in fids if e.name not in failed}
    at = {name: v for name, v in sens.base.items() if sens.coupling[name][0] not in done}
    at.update({e.name: np.asarray(x, float) for e, x in base if e.name in sens.coupling and sens.coupling[e.name][0] in done})
    return dc.replace(sens, plus=plus, responses=responses, base=at), failed


def _moved(a: tuple, b: tuple, a0: tuple) -> tuple:
    """Per run, ``a0`` plus the difference ``a`` − ``b`` (None where any of them is None)."""
    return tuple(None if x is None or y is None or z is None else z + (x - y) for x, y, z in zip(a, b, a0))


def signature_sizes(spec: ReducerSpec, plan, settings: DiagnosisSettings, effects: tuple[str, ...] | None = None,
                    *, law=None, cache_dir: str | Path | None = None, errors: ErrorSpec | None = None) -> dict:
    """Size of each effect's model signature at its typical magnitude, in units of the
    residual floors (measurement noise not included): ||w·ΔF||/√(parameters). Below ~3 an
    effect is not observable with these runs; NaN when its model evaluation failed."""
    settings = settings.for_spec(spec)
    cands, _ = available_candidates(effects, plan)
    cands = tuple(e.for_unit(spec) for e in cands)
    runner = ModelRunner(spec, errors or ErrorSpec(), plan, settings, law, Path(cache_dir) if cache_dir else None)
    f0, resp0, msg = runner.run([()])[0]
    if f0 is None:
        raise EvaluationFailed(f"the baseline model does not converge: {msg}")
    _, lay = features(resp0, plan, settings)
    y0 = f0.copy()
    for r in lay.te_runs:  # no measurement: the floors alone
        y0[lay.cos[r]] = y0[lay.sin[r]] = 0.0
    w = weights(f0, y0, lay, settings, spec.cycloid.pin_count)
    sens, _ = sensitivities(runner, cands, f0, resp0, plan, settings, lay)
    return {e.name: (signature_size(e, sens, w) if e.name in sens else math.nan) for e in cands}

"""The features stage of a diagnosis: the model's side. The data anchor (the unit's torsional stiffness
against the nominal model's; far off, every stiffness is scaled and calibration starts there), the baseline
model run under every bench run's conditions, one model run per parameter of every candidate effect and
nominal parameter (secants, :mod:`rvflex.diagnosis.sensitivity`; cached on disk by content, evaluated in a
process pool, used by every later stage), and the weights of the features by their noise and model-form
floors."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rvflex.diagnosis.anchor import Anchor
from rvflex.diagnosis.calibrate import anchored, baseline_response
from rvflex.diagnosis.calibration import undetermined
from rvflex.diagnosis.effects import Effect
from rvflex.diagnosis.linear import Problem, Sensitivities, nuisance_columns, weights
from rvflex.diagnosis.nominal import within_spec_rules
from rvflex.diagnosis.replay import Response
from rvflex.diagnosis.runs import ModelRunner
from rvflex.diagnosis.sensitivity import sensitivities, sensitivity_runs, signature_size
from rvflex.diagnosis.stages.bench import Bench
from rvflex.diagnosis.verdict import reason_line

__all__ = ["Features", "run"]


@dataclass(frozen=True, eq=False)
class Features:
    """The model's features beside the measured ones, and what the runs can determine."""

    bench: Bench
    runner: ModelRunner  # the anchored model's (its model runs counted from the start)
    anchor: Anchor
    spec_features: np.ndarray  # the model as specified (before the anchor): its features
    spec_response: Response  # and its response
    baseline: np.ndarray  # the anchored nominal model's features
    baseline_response: Response
    weights: np.ndarray
    problem: Problem
    n_nuis: int  # nuisance columns: common TE offset, hysteresis offsets
    sensitivities: Sensitivities  # the secants about the anchored nominal model
    to_calibrate: tuple[Effect, ...]  # the nominal parameters calibrated (those the runs determine)
    usable: tuple[Effect, ...]  # the candidate effects with sensitivities
    signature_size: dict  # name → its signature at the typical step, in floor units
    held: dict  # nominal parameters the runs cannot tell from noise, held nominal: why
    failed: dict  # candidates whose sensitivities failed: why
    not_evaluated: dict  # the same, as the verdict names them
    unavailable: dict  # effects and nominal parameters left out: why


def run(bench: Bench) -> Features:
    """The anchored model, its baseline and sensitivities, and the weighted problem of ``bench``.

    Raises
    ------
    EvaluationFailed
        The nominal model does not converge under the bench conditions.
    """
    req, plan, settings, y, lay = bench.request, bench.plan, bench.settings, bench.measured, bench.layout
    cands = bench.candidates
    runner = ModelRunner(req.dataset.reducer, req.errors, plan, settings, req.law, req.cache_dir, req.progress)
    # --- the data anchor: the unit's torsional stiffness against the nominal model's; far off, every stiffness
    # is scaled and calibration starts there (f_spec, resp_spec: the model as specified, the gap before)
    anc, runner, f_spec, resp_spec = anchored(runner, bench.to_calibrate, y, lay, plan)
    spec = runner.spec
    cal = within_spec_rules(bench.to_calibrate, spec)
    runner.run([()] + sensitivity_runs(cands + cal))  # the baseline alongside the sensitivities' runs
    f0, resp0 = baseline_response(runner)
    w = weights(f0, y, lay, settings, spec.cycloid.pin_count)
    nuis = nuisance_columns(lay)
    prob = Problem.build(y, lay, w, nuis)

    sens, failed = sensitivities(runner, cands + cal, f0, resp0, plan, settings, lay)
    unavailable = dict(bench.unavailable)
    for c in cal:
        if c.name in failed:
            unavailable[c.name] = f"not calibrated: {reason_line(failed.pop(c.name))}"
    cal = tuple(c for c in cal if c.name in sens and c.name not in unavailable)
    not_evaluated = dict(failed)  # candidates without sensitivities (later entries: failed refinements)
    held = undetermined(cal, sens, w, nuis)  # what the runs cannot tell from noise stays nominal
    cal = tuple(c for c in cal if c.name not in held)
    size = {e.name: signature_size(e, sens, w) for e in cands + cal if e.name in sens}
    usable = tuple(e for e in cands if e.name in sens and e.name not in failed)
    return Features(bench, runner, anc, f_spec, resp_spec, f0, resp0, w, prob, nuis.shape[1], sens, cal, usable,
                    size, held, failed, not_evaluated, unavailable)

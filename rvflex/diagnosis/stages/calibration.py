"""The calibration stage of a diagnosis: the nominal parameters alone (bounded linear least squares with the
nuisances, the unknown encoder origin δ and each parameter's regulariser toward its nominal value), refined with
the model in the loop (:func:`~rvflex.diagnosis.calibrate.calibrated`). The calibrated model is the baseline of
the attribution; the discrepancy it leaves, per order band and run, is what every candidate's score is measured
against."""

from __future__ import annotations

import dataclasses as dc
import math
from dataclasses import dataclass

import numpy as np

from rvflex.diagnosis.calibrate import calibrated
from rvflex.diagnosis.discrepancy import Discrepancy, evidence, feature_groups
from rvflex.diagnosis.linear import Candidate, Sensitivities, lin_fit, make_candidate, split_params
from rvflex.diagnosis.refine import evaluated_candidate
from rvflex.diagnosis.sensitivity import rebase_effects
from rvflex.diagnosis.stages.features import Features
from rvflex.diagnosis.verdict import withheld_check

__all__ = ["Calibrated", "run", "shrink_pct"]


@dataclass(frozen=True, eq=False)
class Calibrated:
    """The calibrated nominal model and what it leaves."""

    features: Features
    nominal_model: Candidate  # the model as specified (the gap before calibration and before the anchor)
    calibration: Candidate  # the calibration's fit: its point, model run and Broyden Jacobian
    model: Candidate  # the calibrated nominal model, with its gap shrink and withheld check against nominal_model
    sensitivities: Sensitivities  # with the fidelity and candidate effects' secants measured about the calibration
    discrepancy: Discrepancy  # what the calibrated model leaves, per order band and run
    failed: dict  # candidates without sensitivities and refinements that failed: why

    def score(self, c: Candidate) -> float:
        """The evidence of candidate ``c`` against the calibrated model (``evidence_model="bic"``: the BIC
        improvement; else against its discrepancy, :func:`~rvflex.diagnosis.discrepancy.evidence`)."""
        settings = self.features.bench.settings
        return (self.model.bic - c.bic if settings.evidence_model == "bic"
                else evidence(self.features.problem, c, self.model, self.discrepancy, settings.discrepancy_pooling))


def run(feat: Features) -> Calibrated:
    """The nominal model as specified and the calibrated one, with what the calibrated model leaves."""
    bench = feat.bench
    prob, n, n_nuis, settings = feat.problem, bench.layout.n, feat.n_nuis, bench.settings
    f0, resp0 = feat.baseline, feat.baseline_response
    cal = feat.to_calibrate
    # --- the nominal model as specified (the gap before calibration and before the anchor)
    x, nu, d, rss, A = lin_fit(prob, feat.spec_features, np.zeros((n, 0)), np.zeros(0), np.zeros(0), np.zeros(0))
    nominal_model = make_candidate((), x, nu, d, rss, A, n, n_nuis, feat.spec_features, refined=True,
                                   response=feat.spec_response)

    # --- the nominal parameters alone, refined with the model in the loop
    failed = dict(feat.failed)
    calib, sens = calibrated(prob, feat.runner, feat.sensitivities, cal, f0, resp0, bench.layout, settings, failed,
                             n_nuis)
    # --- the candidate effects' secants measured again about the calibration: every candidate is fitted about it
    sens = about_calibration(feat, calib, sens)
    # (its RSS with the prior penalty, as every candidate's, which fits the same nominal parameters)
    none = evaluated_candidate(prob, cal, calib.x, calib.model_features, calib.response or resp0, calib.jacobian,
                               n_nuis, refined=calib.refined, note="calibrated nominal model")
    # --- the discrepancy the calibrated model leaves, per order band and run: every score is measured against it
    groups = feature_groups(bench.layout, bench.plan, feat.runner.spec.cycloid.pin_count)
    disc = Discrepancy.of(prob, none, groups)
    # --- its shrink of the gap the nominal model leaves, and its withheld check against that model
    none = dc.replace(none, gap_shrink_pct=shrink_pct(none.rss, nominal_model.rss),
                      withheld=withheld_check(prob, bench.plan, none, nominal_model, f0, bench.folds))
    return Calibrated(feat, nominal_model, calib, none, sens, disc, failed)


def about_calibration(feat: Features, calib: Candidate, sens: Sensitivities) -> Sensitivities:
    """``sens`` with the candidate model effects' secants measured about the calibrated model point (its model
    parameters; :func:`~rvflex.diagnosis.sensitivity.rebase_effects`), where the calibration moved it; a
    failed run keeps the nominal secant."""
    base = tuple((e, x) for e, x in split_params(calib.effects, calib.x) if e.kind != "fidelity" and np.any(x != 0.0))
    if not base:
        return sens
    fb, _, _ = feat.runner.run([base])[0]
    if fb is None:
        return sens
    settings = feat.bench.settings
    out, _ = rebase_effects(feat.runner, sens, feat.usable, base, fb, feat.baseline_response, settings,
                            feat.bench.layout)
    return out


def shrink_pct(rss: float, ref: float) -> float:
    """How much a weighted residual sum of squares ``rss`` shrinks the gap ``ref`` leaves (%, by rms)."""
    return 100.0 * (1.0 - math.sqrt(rss / ref)) if ref > 0 else 0.0

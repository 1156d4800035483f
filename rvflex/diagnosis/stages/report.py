"""The report stage of a diagnosis: the :class:`~rvflex.diagnosis.result.Diagnosis`, everything the verdict
rests on in one result (:mod:`rvflex.diagnosis.report` writes its report and JSON document)."""

from __future__ import annotations

import time

from rvflex.diagnosis.result import Diagnosis
from rvflex.diagnosis.stages.verdict import Verdict

__all__ = ["run"]


def run(v: Verdict) -> Diagnosis:
    """The result of the diagnosis that reached verdict ``v``."""
    ev = v.evidence
    calib = ev.candidates.attribution.calibrated
    feat = calib.features
    bench = feat.bench
    none = calib.model
    return Diagnosis(bench.request.dataset, bench.settings, bench.plan, bench.layout, feat.weights, bench.measured,
                     none, none.response or feat.baseline_response, v.candidates, v.chosen, bench.folds,
                     feat.unavailable, ev.failed, feat.signature_size, v.text, feat.runner.model_runs,
                     time.perf_counter() - bench.request.started_s, v.ties, calib.nominal_model, bench.windows,
                     v.calibration_ties, v.separating_runs, feat.held, feat.anchor, calib.discrepancy, v.lookalikes,
                     calib.sensitivities, v.part_ties)

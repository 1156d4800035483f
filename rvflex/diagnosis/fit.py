"""Which effect: calibrate the uncertain nominal parameters, then attribute what is left.

:func:`diagnose` runs the stages of :mod:`rvflex.diagnosis.stages` in data-flow order, each a module whose
``run`` takes the previous stage's value and returns its own:

1. ``bench`` (→ ``Bench``): the bench runs' features are read and checked
   (:func:`~rvflex.diagnosis.features.measured_runs`: bad or undetermined data are refused before any model
   run); the plan, the withheld folds, the candidate effects and nominal parameters the runs can test.
2. ``features`` (→ ``Features``): the data anchor; the nominal model (the reducer as specified, no errors) run
   under every bench run's conditions; sensitivities: one model run per parameter of every candidate effect and
   every nominal parameter (:mod:`rvflex.diagnosis.nominal`) at its typical step (a secant, so clearances and
   other one-sided effects are linearised where they act; two-sided effects get a secant on each side of zero),
   cached on disk by content (:mod:`rvflex.diagnosis.runs`), evaluated in a process pool, computed once and used
   by every later stage; the measured and model features weighted by their noise/model-form floors.
3. ``calibration`` (→ ``Calibrated``): the nominal parameters alone are fitted (bounded linear least squares
   with the nuisances — common TE offset, hysteresis offsets — the unknown encoder origin δ and each parameter's
   regulariser toward its nominal value) and refined with the model in the loop. The calibrated model is the
   baseline of the attribution, and the discrepancy it leaves (:mod:`rvflex.diagnosis.discrepancy`) the
   reference of every score. The candidate effects' secants are run again about the calibrated point
   (:func:`~rvflex.diagnosis.sensitivity.rebase_effects`; the modification deviation's excepted).
4. ``candidates`` (→ ``Candidates``): every candidate (each effect, and pairs) is fitted *together with* the
   nominal parameters (same regularisers), so an effect gets only what calibration cannot explain. A pair is kept
   only when its second effect has evidence ≥ ``bic_threshold`` given the better single
   (``evidence_model="bic"``: removes ``min_shrink_pct`` of the weighted gap that single leaves). The best
   ``refine_top`` candidates by their score (from the linearised fits) and the best single by the linearised BIC
   are refined with the model in the loop (:mod:`rvflex.diagnosis.refine`); their score uses the real model's
   residual.
5. ``evidence`` (→ ``Evidence``): model selection by the evidence against the discrepancy the calibrated model
   leaves (``evidence_model="bic"``: the plain BIC and ``min_shrink_pct``); intervals from the linearised
   covariance (95 %), regulariser included; the withheld check of every candidate (a pair's also against its
   better single). A linearised candidate that then leads, or that passes every acceptance test below a refined
   one that fails, is refined in its turn. Then the grades (:mod:`rvflex.diagnosis.grade`).
6. ``verdict`` (→ ``Verdict``): an effect is accepted only when its evidence reaches ``bic_threshold``, its size
   is determined, and it predicts withheld runs ``min_withheld_pct`` better than the calibrated model refitted on
   the same runs, or predicts ``confirming_folds`` withheld folds each with evidence ≥ ``bic_threshold``
   (:func:`rvflex.diagnosis.verdict.withheld_confirms`); a pair only when the withheld folds confirm it against
   its better single by replication; and only when established beyond the null distribution and not reproduced
   by the nominal parameters within their prior ranges.
7. ``report`` (→ :class:`~rvflex.diagnosis.result.Diagnosis`).
"""

from __future__ import annotations

import time
from pathlib import Path

from rvflex.diagnosis.linear import Candidate
from rvflex.diagnosis.plan import withheld_folds, withheld_split
from rvflex.diagnosis.result import Diagnosis
from rvflex.diagnosis.sensitivity import available_candidates, second_effect_adds, signature_sizes
from rvflex.diagnosis.settings import DiagnosisSettings
from rvflex.diagnosis.stages import bench, calibration, candidates, evidence, features, report, verdict
from rvflex.diagnosis.stages.bench import Request
from rvflex.diagnosis.stages.candidates import restated
from rvflex.spec import ErrorSpec

__all__ = ["Candidate", "Diagnosis", "available_candidates", "diagnose", "restated", "second_effect_adds",
           "signature_sizes", "withheld_folds", "withheld_split"]


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
        request = Request(dataset, settings or DiagnosisSettings(), effects, nominal, law,
                          Path(cache_dir) if cache_dir else None, progress, errors or ErrorSpec(), time.perf_counter())
        runs = bench.run(request)  # the plan, the measured features (checked), the candidates the runs can test
        model = features.run(runs)  # the data anchor, the baseline model and every parameter's secants, the weights
        calib = calibration.run(model)  # the nominal parameters alone, refined; the discrepancy they leave
        cands = candidates.run(calib)  # each effect and pair fitted with them, linearised; the leaders refined
        ev = evidence.run(cands)  # scores against that discrepancy, withheld checks, further refinements, grades
        v = verdict.run(ev)  # the accepted effect, its ties, the sentence
        return report.run(v)  # the Diagnosis

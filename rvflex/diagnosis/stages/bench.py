"""The bench stage of a diagnosis: what the bench runs are and what they can test. The plan the model is run
under, the measured features (read and checked before any model run: bad or undetermined data are refused),
the withheld folds, and the candidate effects and nominal parameters the runs can evaluate."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rvflex.diagnosis.calibrate import calibration_parameters
from rvflex.diagnosis.effects import Effect
from rvflex.diagnosis.features import measured_runs
from rvflex.diagnosis.nominal import REPLACES
from rvflex.diagnosis.plan import Layout, PlanRun, plan_from_dataset, withheld_folds
from rvflex.diagnosis.sensitivity import available_candidates
from rvflex.diagnosis.settings import DiagnosisSettings
from rvflex.spec import ErrorSpec

__all__ = ["Bench", "Request", "run"]


@dataclass(frozen=True)
class Request:
    """What a diagnosis is asked (the arguments of :func:`~rvflex.diagnosis.fit.diagnose`, defaults filled in)."""

    dataset: object  # BenchDataset
    settings: DiagnosisSettings
    effects: tuple[str, ...] | None  # candidate effects by name (None: every registered one)
    nominal: tuple[str, ...] | None  # nominal parameters to calibrate (None: all)
    law: object  # ContactLaw of the model, None: its line contact
    cache_dir: Path | None
    progress: object  # progress(done, total) over model runs, or None
    errors: ErrorSpec
    started_s: float  # time.perf_counter() when the diagnosis started


@dataclass(frozen=True, eq=False)
class Bench:
    """The bench runs as the diagnosis reads them."""

    request: Request
    settings: DiagnosisSettings  # for this dataset: the orders the bench resolves, the alias-free model grid
    plan: tuple[PlanRun, ...]
    measured: np.ndarray  # the measured features
    layout: Layout
    windows: dict  # per TE run: the analysed window and its fit figures
    folds: tuple  # the withheld check's folds (plan.withheld_folds)
    candidates: tuple[Effect, ...]  # the candidate effects these runs can evaluate
    to_calibrate: tuple[Effect, ...]  # the nominal parameters to calibrate
    unavailable: dict  # effects and nominal parameters left out: why


def run(request: Request) -> Bench:
    """The plan, the measured features and the candidates of ``request.dataset``; a
    :class:`~rvflex.diagnosis.errors.BenchError` for a TE run whose samples cannot determine the analysed orders."""
    dataset = request.dataset
    settings = request.settings.for_dataset(dataset)  # the orders the bench resolves, the alias-free model grid
    plan = plan_from_dataset(dataset, settings)
    y, lay, windows = measured_runs(dataset, plan, settings)
    cands, unavailable = available_candidates(request.effects, plan)
    cands = tuple(e.for_unit(dataset.reducer) for e in cands)
    cal = calibration_parameters(request.nominal, dataset.reducer, plan, unavailable)
    replaced = {REPLACES[c.name] for c in cal if c.name in REPLACES}
    cands = tuple(e for e in cands if e.name not in replaced)
    return Bench(request, settings, plan, y, lay, windows, withheld_folds(plan), cands, cal, unavailable)

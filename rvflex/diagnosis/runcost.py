"""What one model run of a diagnosis costs on each unit (``rvflex bench diagnosis``).

A diagnosis evaluates the model under its bench plan some 15–50 times; each evaluation (one *model
run*) runs every bench run. Three kinds occur: the rigid model (the baseline, the stiffness,
clearance and most effect secants, the refinements), the rigid and the flexible model (the
disc-flexibility share) and the rigid and two flexible models (the contact-law form). This times one
run of each kind on each unit side by side in one process, under the self-check campaign's plan (TE
at rated torque forward and reverse and at a quarter of it, the torque cycle) and the diagnosis's
default resolution, the FE reductions taken from the cache (warmed first, not timed). Process CPU
time is the measure: wall time on a shared machine says more about the other jobs.
"""

from __future__ import annotations

import time

import numpy as np

from rvflex import catalog
from rvflex.choices import RunCostKind, check_choice, choices
from rvflex.diagnosis.nominal import NOMINAL
from rvflex.diagnosis.replay import evaluate
from rvflex.diagnosis.selfcheck import campaign_plan
from rvflex.diagnosis.settings import DiagnosisSettings
from rvflex.spec import ErrorSpec

__all__ = ["RUN_KINDS", "TARGET_RATIO", "bench_model_runs"]

RUN_KINDS: dict[RunCostKind, str | None] = {"rigid": None, "flexible": "disc_flexibility",
                                            "contact-law": "contact_law_form"}
"""The kinds of model run of a diagnosis: the nominal parameter whose run it is (None: the rigid model)."""

TARGET_RATIO = 1.5  # issue 24: a model run on any unit at most 1.5× the RV-40E's


def bench_model_runs(units: tuple[str, ...] = ("rv40e", "rv80e"), kinds: tuple[RunCostKind, ...] = choices(RunCostKind), *,
                     max_order: int = 255, repeats: int = 1, progress=None) -> dict:
    """Time one diagnosis model run of each kind on each unit.

    Parameters
    ----------
    units : tuple of str
        Built-in reducer names or spec TOML paths; the first is the reference of the ratios.
    kinds : tuple of {"rigid", "flexible", "contact-law"}
        Kinds of model run (:data:`RUN_KINDS`).
    max_order : int
        Analysed orders (255: what a bench sampled 1024 times per revolution gives); the model grid
        is the alias-free one for them (:meth:`DiagnosisSettings.for_spec`).
    repeats : int
        Runs of each kind per unit, interleaved over the units; the least CPU time is kept.
    progress : callable, optional
        ``progress(message)`` after each timed run.

    Returns
    -------
    dict
        ``rows``: per unit and kind ``cpu_s`` (least process CPU time of a run, s), ``wall_s`` (its
        wall time, s), ``positions_per_rev``, ``torque_steps`` (of the replayed cycle), ``te_runs``;
        ``ratio``: unit → kind → cpu_s over the reference unit's; ``target_ratio``; ``reference``.
    """
    from threadpoolctl import threadpool_limits

    for k in kinds:
        check_choice("kinds", k, RunCostKind)
    if repeats < 1:
        raise ValueError(f"repeats = {repeats}: must be ≥ 1")
    setups = {}
    for unit in units:
        spec = catalog.resolve(unit, field="--units")
        settings = DiagnosisSettings(max_order=max_order, workers=1).for_spec(spec)
        plan = campaign_plan(spec, settings.hysteresis_steps)
        setups[unit] = (spec, settings, plan)
    best: dict = {}
    with threadpool_limits(1, user_api="blas"):  # as the diagnosis runs its models
        for spec, _, plan in setups.values():  # warm-up: imports, kernels, FE reductions
            for kind in kinds:
                evaluate(spec, ErrorSpec(), plan[:1], DiagnosisSettings(max_order=3, workers=1), _active(kind))
        for _ in range(repeats):
            for unit, (spec, settings, plan) in setups.items():
                for kind in kinds:
                    c0, t0 = time.process_time(), time.perf_counter()
                    evaluate(spec, ErrorSpec(), plan, settings, _active(kind))
                    cpu, wall = time.process_time() - c0, time.perf_counter() - t0
                    if (unit, kind) not in best or cpu < best[unit, kind][0]:
                        best[unit, kind] = (cpu, wall)
                    if progress:
                        progress(f"{unit} {kind}: {cpu:.2f} s CPU, {wall:.2f} s wall")
    rows = []
    for (unit, kind), (cpu, wall) in best.items():
        spec, settings, plan = setups[unit]
        rows.append({"unit": unit, "kind": kind, "cpu_s": cpu, "wall_s": wall,
                     "positions_per_rev": settings.positions_per_rev,
                     "torque_steps": sum(len(p.torque_path_Nm) for p in plan),
                     "te_runs": sum(p.kind == "te" for p in plan)})
    ref = units[0]
    ratio = {u: {k: best[u, k][0] / best[ref, k][0] for k in kinds} for u in units}
    return {"rows": rows, "ratio": ratio, "reference": ref, "target_ratio": TARGET_RATIO, "max_order": max_order,
            "repeats": repeats}


def _active(kind: RunCostKind) -> tuple:
    name = RUN_KINDS[kind]
    return () if name is None else ((NOMINAL[name], np.array([1.0])),)

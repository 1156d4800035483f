"""The Python API of the studies over many model runs: tolerance sweeps, the sim-to-real
diagnosis of bench data and its self-check, behind ``import rvflex``.

::

    import rvflex
    res = rvflex.sweep("scenarios/designs/smoke.toml", executor="serial")
    res.to_dataframe(), res.to_xarray()
    d = rvflex.diagnose("path/to/bench_dir")
    d.verdict, d.to_dataframe("ranking"), d.plot(), d.write("out/diagnosis")

Each function checks its arguments (errors name the Python parameter) and calls the engine
(:mod:`rvflex.sweeps`, :mod:`rvflex.diagnosis`); the ``rvflex sweep``, ``rvflex diagnose`` and
``rvflex selfcheck`` commands call these same functions.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from rvflex.choices import Executor, Mismatch, check_choice, did_you_mean
from rvflex.diagnosis.bench import BenchDataset, read_bench
from rvflex.diagnosis.effects import EFFECTS
from rvflex.diagnosis.fit import Diagnosis
from rvflex.diagnosis.nominal import NOMINAL
from rvflex.diagnosis.settings import DiagnosisSettings
from rvflex.spec import ErrorSpec, SpecError
from rvflex.sweeps import designs
from rvflex.sweeps.designs import Design, design_points
from rvflex.sweeps.executors import SweepResult

__all__ = ["diagnose", "load_design", "selfcheck", "sweep"]


def _names(field: str, value, known) -> tuple[str, ...] | None:
    """``value`` as a tuple of known names (None stays None); an unknown name is refused naming
    ``field`` with the closest known one."""
    if value is None:
        return None
    if isinstance(value, str) or not all(isinstance(v, str) for v in value):
        raise SpecError(field, value, "must be a tuple of names (or None for all)")
    for v in value:
        if v not in known:
            raise SpecError(field, v, f"unknown name; known: {', '.join(known)}{did_you_mean(v, known)}")
    return tuple(value)


def _diagnosis_arguments(who: str, effects, nominal, settings):
    """The effects and nominal parameters of a diagnosis as tuples of known names (None: all) and its
    settings checked, for :func:`diagnose` and :func:`selfcheck` (``who``: the function, for messages)."""
    if not isinstance(settings, (DiagnosisSettings, type(None))):
        raise TypeError(f"rvflex.{who}: settings must be an rvflex.DiagnosisSettings, got {type(settings).__name__}")
    return _names("effects", effects, tuple(EFFECTS)), _names("nominal", nominal, tuple(NOMINAL)), settings


def diagnose(bench: str | os.PathLike | BenchDataset, *, effects: tuple[str, ...] | None = None,
             nominal: tuple[str, ...] | None = None, settings: DiagnosisSettings | None = None,
             errors: ErrorSpec | None = None, cache_dir: str | os.PathLike | None = None,
             progress=None) -> Diagnosis:
    """Diagnose the gap between the model of a bench's reducer and its measured runs.

    The nominal parameters are calibrated first, then every candidate effect (and pair) is fitted
    with them and ranked by BIC; an effect is accepted only when it also predicts withheld runs
    (docs/diagnosis.md).

    Parameters
    ----------
    bench : str, os.PathLike or BenchDataset
        A bench dataset folder (``bench.toml`` and one CSV per run; read by :func:`read_bench`)
        or a dataset already read.
    effects : tuple of str, optional
        The candidate effects (default: every registered effect the runs can show; names in
        :data:`rvflex.diagnosis.effects.EFFECTS`, e.g. ``"crank_eccentricity_error"``).
    nominal : tuple of str, optional
        The uncertain nominal parameters calibrated first (default: all of
        :data:`rvflex.diagnosis.nominal.NOMINAL`; ``()``: none, the model as specified is exact).
    settings : DiagnosisSettings, optional
        Model resolution, analysed orders, acceptance thresholds and process-pool size (default:
        ``DiagnosisSettings()``: the orders the bench resolves, 2 worker processes).
    errors : ErrorSpec, optional
        Known manufacturing and assembly errors of the unit (m, rad; default: none).
    cache_dir : str or os.PathLike, optional
        Disk cache of model runs (content-hashed: safe to share between benches; default none).
    progress : callable, optional
        ``progress(done, total)`` over the model runs.

    Returns
    -------
    Diagnosis
        ``.verdict`` (one paragraph), ``.candidates`` (ranked), ``.chosen`` (the accepted effect
        or None), ``.to_dataframe(table)``, ``.plot(ax=None)`` and ``.write(dir)`` (the report
        files of ``rvflex diagnose --out``).

    Raises
    ------
    BenchError
        A bad bench file, row or key, or TE runs that cannot determine the analysed orders
        (before any model run).
    SpecError
        An unknown effect or nominal-parameter name (with the closest known one).
    EvaluationFailed
        The model does not converge under the bench's conditions.
    """
    from rvflex.diagnosis.fit import diagnose as fit_diagnose

    if isinstance(bench, BenchDataset):
        dataset = bench
    elif isinstance(bench, (str, os.PathLike)):
        dataset = read_bench(bench)
    else:
        raise TypeError(f"rvflex.diagnose: bench must be a folder or a BenchDataset (rvflex.read_bench(...)), "
                        f"got {type(bench).__name__}")
    effects, nominal, settings = _diagnosis_arguments("diagnose", effects, nominal, settings)
    if not isinstance(errors, (ErrorSpec, type(None))):
        raise TypeError(f"rvflex.diagnose: errors must be an rvflex.ErrorSpec, got {type(errors).__name__}")
    return fit_diagnose(dataset, settings=settings, effects=effects, nominal=nominal, errors=errors,
                        cache_dir=cache_dir, progress=progress)


def selfcheck(out_dir: str | os.PathLike | None = None, *, cases: int = 20, seed: int = 1, mismatch: Mismatch = "none",
              reducer: str | os.PathLike = "rv40e", effects: tuple[str, ...] | None = None,
              nominal: tuple[str, ...] | None = None, settings: DiagnosisSettings | None = None, progress=None,
              log=None, reuse_benches: bool = False, told: bool = False) -> dict:
    """Check the diagnosis blind: write synthetic benches with hidden effects, diagnose each, score.

    Every case draws one or two effects (or none: a control case) at random magnitudes, writes a
    bench from a model of another resolution or family (``mismatch``), diagnoses it without the
    truth and scores the answer (docs/diagnosis.md, "Self-check"). A case takes about a minute.

    Parameters
    ----------
    out_dir : str or os.PathLike, optional
        Folder for the benches, their truths, the model-run cache and the partial scores (default:
        a temporary folder, removed afterwards).
    cases : int, optional
        Number of benches (≥ 1).
    seed : int, optional
        Random seed of the draws.
    mismatch : {"none", "realistic", "far", "ensemble"}, optional
        The generator: the diagnosing model at a finer resolution with a 2 % stiffer contact and
        a control every 5th case (``"none"``); another model family per case with a control
        every 4th case (``"realistic"``); that family with the overall stiffness also drawn
        ×0.5 … ×2 (``"far"``); a unit of another model form per case, drawn from the ensemble the
        null distribution is made of (:class:`~rvflex.diagnosis.ensemble.EnsembleMismatch`), with a
        control every 4th case (``"ensemble"``).
    reducer : str or os.PathLike, optional
        The unit: a built-in reducer name or a spec TOML file.
    effects : tuple of str, optional
        The effects hidden and diagnosed (default: every registered effect the bench plan can
        show), as in :func:`diagnose`.
    nominal : tuple of str, optional
        The nominal parameters each diagnosis calibrates (default: all), as in :func:`diagnose`.
    settings : DiagnosisSettings, optional
        The settings of every diagnosis, its process-pool size included (default:
        ``DiagnosisSettings()``).
    progress : callable, optional
        ``progress(done, total)`` over the cases.
    log : callable, optional
        ``log(line)`` for each case's outcome (default: silent).
    reuse_benches : bool, optional
        Diagnose again a bench that ``out_dir`` already holds from the same draw and generator (its
        key matches; any other is written afresh) instead of generating it: the diagnosis settings or
        code can change, the benches stay. ``wall_s`` then leaves out their generation.
    told : bool, optional
        Also diagnose each effect case told its hidden effects (the candidates only those, their sizes
        not told): per case ``told_top1`` (a candidate with the dominant effect accepted) and
        ``told_chosen``, and ``top1_rate_told``. What the runs confirm of the hidden effects when the
        ranking has nothing else to choose; about one more cached diagnosis per effect case.

    Returns
    -------
    dict
        The score document of ``rvflex selfcheck --json``: ``top1_rate``, ``top2_rate``,
        ``magnitude_within_25pct_rate``, ``median_gap_shrink_pct`` (%), ``control_correct_rate``,
        ``calibration_rate``, ``false_names`` (accepted names that are not hidden, over all cases) and
        ``false_names_per_20_cases``, ``wall_s`` (s), ``per_case`` and ``settings``.

    Raises
    ------
    SpecError
        ``cases`` below 1, an unknown ``mismatch``, reducer, effect or nominal parameter (naming the
        parameter).
    """
    import dataclasses as dc

    from rvflex.api import load_reducer
    from rvflex.diagnosis.selfcheck import SelfCheckSettings
    from rvflex.diagnosis.selfcheck import selfcheck as run_selfcheck

    if isinstance(cases, bool) or not isinstance(cases, int) or cases < 1:
        raise SpecError("cases", cases, "must be an integer ≥ 1")
    check_choice("mismatch", mismatch, Mismatch)
    effects, nominal, settings = _diagnosis_arguments("selfcheck", effects, nominal, settings)
    reducer = os.fspath(reducer)
    # a spec file by its absolute path: the benches written elsewhere refer to it
    reducer = str(Path(reducer).resolve()) if reducer.endswith(".toml") else reducer
    load_reducer(reducer, field="reducer")  # one clear message for an unknown name or a bad spec, before any run
    settings = SelfCheckSettings(cases=cases, seed=seed, diagnosis=settings or DiagnosisSettings(), mismatch=mismatch,
                                 control_every=5 if mismatch == "none" else 4, reducer=reducer, effects=effects,
                                 nominal=nominal, reuse_benches=bool(reuse_benches), told=bool(told))
    with tempfile.TemporaryDirectory(prefix="rvflex-selfcheck-") as tmp:
        out = Path(out_dir) if out_dir is not None else Path(tmp)
        doc = run_selfcheck(out, settings, progress=progress, log=log or (lambda line: None))
    doc["settings"] = {"cases": settings.cases, "seed": settings.seed, "reducer": settings.reducer,
                       "effects": settings.effects, "nominal": settings.nominal,
                       "diagnosis": dc.asdict(settings.diagnosis), "generator": dc.asdict(settings.generator),
                       "realism": dc.asdict(settings.realism), "mismatch": settings.mismatch,
                       "realistic": dc.asdict(settings.realistic), "far": dc.asdict(settings.far),
                       "reuse_benches": settings.reuse_benches, "told": settings.told}
    return doc


def load_design(path: str | os.PathLike) -> Design:
    """Read and validate a sweep design TOML file.

    Parameters
    ----------
    path : str or os.PathLike
        The design file: a ``[sweep]`` table (name, reducer, scenario, kind, ``load_Nm``, ...), one
        ``[[factor]]`` table per factor (deviations in m) and an optional ``[model]`` table;
        described in the command reference (``rvflex sweep``), e.g. ``scenarios/designs/smoke.toml``.

    Returns
    -------
    Design
        The validated design.

    Raises
    ------
    SpecError
        An unreadable file or a bad value, naming the file, the TOML key (``[sweep].kind``,
        ``factor[2].levels``, ``[model].fidelity``), the value and the rule.
    """
    import rvflex.scenarios  # noqa: F401 -- registers the scenarios a design may name (rvflex.scenarios.sweepable)

    return designs.load_design(path)


def sweep(design: Design | str | os.PathLike, store: str | os.PathLike | None = None, *, executor: Executor = "process",
          workers: int | None = None, scheduler: str | None = None, progress=None) -> SweepResult:
    """Evaluate every point of a sweep design, each in its own model.

    Parameters
    ----------
    design : Design, str or os.PathLike
        The design (:class:`rvflex.Design`) or its TOML file (:func:`rvflex.load_design`).
    store : str or os.PathLike, optional
        SQLite file that keeps every finished point: a rerun with the same design resumes from it
        (default: a temporary store, removed afterwards).
    executor : {"serial", "process", "dask"}, optional
        This process, a local process pool (default) or a Dask cluster.
    workers : int, optional
        Worker processes (default: the CPU count; 1 for ``"serial"``).
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://HOST:PORT``; default: a local cluster).
    progress : callable, optional
        ``progress(done, total)``: ``done`` points evaluated by this call of the design's ``total``.

    Returns
    -------
    SweepResult
        The points with their factor deviations (m) and metrics: ``.to_dataframe()`` (one row per
        point), ``.to_xarray()`` (over ``point``, ``units`` on every variable), ``.rows``, and the
        run facts (``finished``, ``failed``, ``wall_s``).

    Raises
    ------
    SpecError
        A bad design file or value (naming the file and TOML key), an unknown executor, or a store
        written by another design.
    """
    import rvflex.scenarios  # noqa: F401 -- registers the scenarios a point runs (rvflex.scenarios.sweepable)
    from rvflex.sweeps.executors import sweep as run_sweep

    if isinstance(design, (str, os.PathLike)):
        design = load_design(design)
    elif not isinstance(design, Design):
        raise TypeError(f"rvflex.sweep: design must be an rvflex.Design or a design TOML path, got "
                        f"{type(design).__name__}")
    total = len(design_points(design))
    done = 0

    def tick() -> None:
        nonlocal done
        done += 1
        if progress is not None:
            progress(done, total)

    with tempfile.TemporaryDirectory(prefix="rvflex-sweep-") as tmp:
        path = Path(store) if store is not None else Path(tmp) / f"{design.name}.sqlite"
        return run_sweep(design, path, executor=executor, workers=workers, scheduler=scheduler, progress=tick)

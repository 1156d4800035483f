"""Running a sweep: every point built and evaluated in its own worker, each result stored at once.

``sweep(design, executor=...)`` evaluates every design point — a full spec/errors variant
made with :func:`dataclasses.replace` — by building its own model in its worker, and writes
each finished point at once to the sweep's SQLite store (:class:`~rvflex.sweeps.store.Store`).
Rerunning the same design resumes: finished points are skipped; a failed point records its
error and the sweep goes on; the points left when a worker dies get a fresh pool once, and if
a second pool dies too each of them runs alone in its own pool, so only the point that kills
its worker is recorded as "worker died" (:func:`rvflex.parallel.map_warm`). Results do not
depend on the executor: serial, a local process pool, or Dask (a LocalCluster, or an existing
cluster by address).

The sweep process warms itself once (imports, compiled kernels, the nominal spec) before the
pool forks its workers, so workers start warm; that start-up is reported apart from the
evaluation wall time (``SweepResult.startup_s`` and ``wall_s``). Every point builds its model
with the design's :class:`~rvflex.options.ModelOptions` (``Design.options``); with FE parts the
warm-up reduces them once (disk cache) before the workers start. What a point runs comes from
the scenario registry (:mod:`rvflex.sweeps.registry`), never from a scenario import here.
"""

from __future__ import annotations

import contextlib
import json
import os
import time
from dataclasses import dataclass
from pathlib import Path

from rvflex.catalog import resolve
from rvflex.choices import Executor, check_choice, choices
from rvflex.options import ModelOptions
from rvflex.parallel import map_warm
from rvflex.spec import ErrorSpec, ReducerSpec, SpecError
from rvflex.sweeps import registry
from rvflex.sweeps.designs import Design, design_points
from rvflex.sweeps.factors import FACTORS
from rvflex.sweeps.registry import SweepScenario
from rvflex.sweeps.store import Store

__all__ = ["DASK_CONNECT_TIMEOUT_S", "EXECUTORS", "SweepResult", "evaluate_point", "evaluate_timed", "sweep",
           "warm_process"]

EXECUTORS: tuple[str, ...] = choices(Executor)


def evaluate_point(args: tuple[str | ReducerSpec, str | SweepScenario, float, int, float, dict[str, float],
                               ModelOptions]) -> dict[str, float]:
    """Evaluate one point in the current process (a worker): build the variant, its model, run.

    ``args`` = (nominal reducer, scenario, load N·m, positions per revolution, revolutions,
    point, model options). The nominal reducer is a :class:`ReducerSpec` (the sweep resolves it
    once and ships it; it is immutable) or a name/path for :func:`rvflex.catalog.resolve`; the
    scenario a registered :class:`~rvflex.sweeps.registry.SweepScenario` or its name; the options
    a :class:`~rvflex.options.ModelOptions` (``Design.options``)."""
    reducer, scenario, load, positions, revs, point, options = args
    spec = reducer if isinstance(reducer, ReducerSpec) else resolve(reducer)
    entry = scenario if isinstance(scenario, SweepScenario) else registry.get(scenario)
    errors = ErrorSpec()
    for name, value in point.items():
        spec, errors = FACTORS[name][2](spec, errors, value)
    return entry.evaluate(spec, errors, load, positions, revs, options)


def evaluate_timed(args) -> tuple[dict[str, float], float, int]:
    """:func:`evaluate_point`, the CPU time it took (s) and the id of the process that ran it."""
    c0 = time.process_time()
    result = evaluate_point(args)
    return result, time.process_time() - c0, os.getpid()


@dataclass(frozen=True)
class SweepResult:
    """Rows (point index, factor values, metrics or error) and run facts."""

    rows: list[dict]
    finished: int
    failed: int
    wall_s: float
    executor: Executor
    workers: int
    startup_s: float = 0.0  # the process warm-up before the first point (:func:`warm_process`), not in wall_s
    cpu_s: float = 0.0  # worker CPU time summed over the points evaluated in this run
    cpu_busiest_worker_s: float = 0.0  # the largest per-worker sum of it (the pool's CPU makespan)

    def to_dataframe(self):
        """The points as a pandas DataFrame.

        Returns
        -------
        pandas.DataFrame
            One row per point (index ``point``): the factor deviations (SI, as in the design) and
            the metrics (unit in the name, e.g. ``te_pp_arcsec``), ``error`` where a point failed.
        """
        import pandas as pd

        return pd.DataFrame(self.rows).set_index("point") if self.rows else pd.DataFrame(index=pd.Index([], name="point"))

    def to_xarray(self):
        """The points as an xarray Dataset.

        Returns
        -------
        xarray.Dataset
            The table over the dimension ``point``, each variable with ``units`` and ``long_name``
            (factor deviations from :data:`~rvflex.sweeps.factors.FACTORS`, metrics from their
            names); the executor, workers and point counts in ``attrs``.
        """
        import xarray as xr

        from rvflex.sweeps.factors import FACTORS

        ds = xr.Dataset.from_dataframe(self.to_dataframe())
        metric_units = (("_Nm_per_arcmin", "N m/arcmin"), ("_arcsec", "arcsec"), ("_arcmin", "arcmin"))
        for name in ds.data_vars:
            if name in FACTORS:
                ds[name].attrs = {"units": FACTORS[name][1], "long_name": f"deviation of the {FACTORS[name][0]}"}
            else:
                unit = next((u for suffix, u in metric_units if name.endswith(suffix)), "1")
                ds[name].attrs = {"units": unit, "long_name": name.replace("_", " ")}
        ds["point"].attrs = {"units": "1", "long_name": "design point"}
        ds.attrs = {"executor": self.executor, "workers": self.workers, "finished": self.finished, "failed": self.failed}
        return ds


def sweep(design: Design, store_path: str | Path, *, executor: Executor = "process", workers: int | None = None,
          scheduler: str | None = None, progress=None) -> SweepResult:
    """Evaluate every point of ``design`` (skipping those already in the store), each with a
    model built with ``design.options``.

    ``executor``: "serial", "process" (a local process pool) or "dask" (a LocalCluster of
    ``workers`` single-threaded worker processes, or the cluster at ``scheduler``,
    ``tcp://HOST:PORT``)."""
    check_choice("executor", executor, Executor)
    points = design_points(design)
    workers = 1 if executor == "serial" else (workers or os.cpu_count() or 1)
    with contextlib.ExitStack() as stack:
        # connect before the store exists: a dead scheduler leaves nothing behind
        client = stack.enter_context(_dask_client(workers, scheduler)) if executor == "dask" else None
        return _sweep(design, points, Path(store_path), executor, workers, client, progress)


def warm_process(reducer: str | ReducerSpec, scenario: str | SweepScenario,
                 options: ModelOptions | None = None) -> ReducerSpec:
    """Once-per-process warm-up of a sweep: import the evaluation path (Exudyn, the model, the
    scenario, SciPy through the geometry checks) and load its cached compiled kernels by
    resolving the nominal reducer and building its model once with ``options`` (None: rigid;
    FE parts are reduced here, or loaded from the disk cache, so the workers find them
    cached); returns that spec.

    The sweep runs it in its own process before the pool forks, so every worker starts warm
    (about 2–3 s of imports and kernel loading paid once per sweep instead of once per
    worker), and on each Dask worker; it is timed as ``SweepResult.startup_s``. Idempotent."""
    import exudyn  # noqa: F401 -- the warm-up is these imports

    import rvflex.model
    import rvflex.solve  # noqa: F401

    (scenario if isinstance(scenario, SweepScenario) else registry.get(scenario)).warm()
    options = options or ModelOptions.rigid()
    if isinstance(reducer, ReducerSpec) and options == ModelOptions.rigid():
        return reducer
    spec = reducer if isinstance(reducer, ReducerSpec) else resolve(reducer)
    rvflex.model.build_reducer(spec, None, options)  # loads the kernels (and FE reductions); the model is dropped
    return spec


def _sweep(design, points, store_path, executor, workers, client, progress) -> SweepResult:
    store = Store(store_path, design, len(points))
    done = store.done()
    todo = [i for i in range(len(points)) if i not in done or done[i][0] is None and done[i][1] == "worker died"]
    t_start = time.perf_counter()
    nominal = design.reducer
    scenario = registry.get(design.scenario)
    if todo:
        nominal = warm_process(design.reducer, scenario, design.options)
        if client is not None:  # the resolved spec: a remote worker need not read the reducer's file
            client.run(warm_process, nominal, scenario, design.options)
    args = [(nominal, scenario, design.load_Nm, design.positions_per_rev, design.revolutions, points[i],
             design.options) for i in todo]
    t0 = time.perf_counter()

    cpu: dict[int, float] = {}  # worker process id → CPU time of its points evaluated in this run (s)

    def record(i: int, value=None, error: BaseException | None = None, died: bool = False) -> None:
        if died:
            store.write(i, points[i], None, "worker died")
        elif error is not None:
            store.write(i, points[i], None, f"{type(error).__name__}: {error}")
        else:
            result, cpu_s, pid = value
            store.write(i, points[i], result, None)
            cpu[pid] = cpu.get(pid, 0.0) + cpu_s
        if progress is not None:
            progress()

    if executor == "dask":
        _run_dask(client, todo, args, record)
    else:  # serial: in this process; process: a warm forked pool that survives a dying worker
        map_warm(evaluate_timed, args, 0 if executor == "serial" else workers, retries=1,
                 on_outcome=lambda out: record(todo[out.index], out.value, out.error, out.died))
    rows = []
    for i, (res, err) in sorted(store.done().items()):
        row = {"point": i, **points[i]}
        row.update(json.loads(res) if res else {"error": err})
        rows.append(row)
    failed = sum(1 for r in rows if "error" in r)
    return SweepResult(rows, len(rows) - failed, failed, time.perf_counter() - t0, executor, workers, t0 - t_start,
                       float(sum(cpu.values())), max(cpu.values(), default=0.0))


DASK_CONNECT_TIMEOUT_S = 5.0


@contextlib.contextmanager
def _dask_client(workers: int, scheduler: str | None):
    """A Dask client on a LocalCluster of single-threaded worker processes, or on the cluster at
    ``scheduler``; an address that does not answer is refused within DASK_CONNECT_TIMEOUT_S."""
    from dask.distributed import Client, LocalCluster

    if scheduler:
        try:
            client = Client(scheduler, timeout=f"{DASK_CONNECT_TIMEOUT_S}s")
        except (OSError, TimeoutError) as err:
            raise SpecError("scheduler", scheduler, f"does not answer within {DASK_CONNECT_TIMEOUT_S:g} s "
                                                      f"({type(err).__name__})") from None
        with client:
            yield client
        return
    with (LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster,
          Client(cluster) as client):
        yield client


def _run_dask(client, todo, args, record) -> None:
    """Evaluate on the Dask cluster; each finished point is recorded as it arrives."""
    from dask.distributed import as_completed

    futures = {client.submit(evaluate_timed, a, pure=False, retries=1): i for i, a in zip(todo, args)}
    for fut in as_completed(futures):
        try:
            value = fut.result()
        except Exception as err:  # noqa: BLE001 -- a failing point is recorded, the sweep goes on
            record(futures[fut], error=err)
        else:
            record(futures[fut], value)

"""Parameter sweeps and tolerance designs over full model runs.

``sweep(design, executor=...)`` evaluates every design point — a full spec/errors variant
made with :func:`dataclasses.replace` — by building its own model in its worker, and writes
each finished point at once to the sweep's SQLite store. Rerunning the same design resumes:
finished points are skipped; a failed point records its error and the sweep goes on; the
points left when a worker dies get a fresh pool once, and if a second pool dies too each of
them runs alone in its own pool, so only the point that kills its worker is recorded as
"worker died". Results do not depend on the executor.
The sweep process warms itself once (imports, compiled kernels, the nominal spec) before the
pool forks its workers, so workers start warm; that start-up is reported apart from the
evaluation wall time (``SweepResult.startup_s`` and ``wall_s``).

Designs: single factor, orthogonal arrays (L9, L16(4^5), L27), Latin hypercube and Sobol
(scipy.stats.qmc), Monte Carlo tolerance stacks (seeded normal or uniform), and two global
sensitivity designs sampled and analysed with SALib: ``morris`` (elementary-effects screening,
μ* and σ) and ``sobol-indices`` (Saltelli sampling, first-order S1 and total ST indices with
bootstrap confidence intervals). Executors: serial, a local process pool, or Dask (a
LocalCluster, or an existing cluster by address).
"""

from __future__ import annotations

import contextlib
import dataclasses as dc
import hashlib
import itertools
import json
import math
import os
import sqlite3
import time
import tomllib
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rvflex.spec import ErrorSpec, ReducerSpec, SpecError

__all__ = [
    "FACTORS",
    "Design",
    "Factor",
    "SweepResult",
    "bench_sweep",
    "classify",
    "design_points",
    "evaluate_point",
    "load_design",
    "monte_carlo_design",
    "orthogonal_array",
    "plot_indices",
    "plot_main_effects",
    "range_table",
    "sensitivity_indices",
    "sweep",
    "write_indices_csv",
]


# ----------------------------------------------------------------------------- factors

def _cycloid(spec, errors, **kw):
    return dc.replace(spec, cycloid=dc.replace(spec.cycloid, **kw)), errors


def _modification(spec, errors, **kw):
    c = spec.cycloid
    return dc.replace(spec, cycloid=dc.replace(c, modification=dc.replace(c.modification, **kw))), errors


def _per(spec, errors, field: str, value: float, count: int):
    return spec, dc.replace(errors, **{field: (value,) * count})


FACTORS = {
    # name: (description, unit, apply(spec, errors, deviation) -> (spec, errors))
    "eccentricity": ("crank eccentricity e (both cranks)", "m",
                     lambda s, e, v: _cycloid(s, e, eccentricity_m=s.cycloid.eccentricity_m + v)),
    "moved_modification": ("moved modification Δr_p", "m",
                           lambda s, e, v: _modification(s, e, moved_m=s.cycloid.modification.moved_m + v)),
    "equidistant_modification": ("equidistant modification Δr_rp", "m",
                                 lambda s, e, v: _modification(s, e, equidistant_m=s.cycloid.modification.equidistant_m + v)),
    "pin_circle_radius": ("pin-circle radius r_b", "m", lambda s, e, v: (s, dc.replace(e, pin_circle_radius_error_m=v))),
    "pin_radius": ("pin radius r_r", "m", lambda s, e, v: (s, dc.replace(e, pin_radius_error_m=v))),
    "sun_pitch_radius": ("sun pitch radius r1", "m", lambda s, e, v: (s, dc.replace(e, sun_pitch_radius_error_m=v))),
    "planet_pitch_radius": ("planet pitch radius r2", "m",
                            lambda s, e, v: _per(s, e, "planet_pitch_radius_error_m", v, s.cranks.count)),
    "disc_bore_distance": ("disc crank-bore distance a_c", "m",
                           lambda s, e, v: _per(s, e, "disc_bore_distance_error_m", v, s.cycloid.disc_count)),
    "input_carrier_hole_distance": ("input-end carrier hole distance a_k", "m",
                                    lambda s, e, v: (s, dc.replace(e, input_carrier_hole_distance_error_m=v))),
    "output_carrier_hole_distance": ("output-end carrier hole distance a_k", "m",
                                     lambda s, e, v: (s, dc.replace(e, output_carrier_hole_distance_error_m=v))),
    "eccentric_bearing_clearance": ("radial clearance of every eccentric bearing", "m",
                                    lambda s, e, v: _per(s, e, "eccentric_bearing_clearance_m", v,
                                                         s.cranks.count * s.cycloid.disc_count)),
}
"""Design factors: each a deviation (SI) applied to the nominal spec or errors."""

DESIGN_KINDS = ("single-factor", "L9", "L16", "L27", "lhs", "sobol", "monte-carlo", "morris", "sobol-indices")
SALIB_KINDS = ("morris", "sobol-indices")
SCENARIOS = ("te", "lost-motion")


# ----------------------------------------------------------------------------- designs

def orthogonal_array(name: str) -> np.ndarray:
    """Standard orthogonal array as 0-based levels: L9(3^4), L16(4^5), L27(3^13)."""
    if name == "L9":
        a = np.array([[i, j, (i + j) % 3, (i + 2 * j) % 3] for i in range(3) for j in range(3)])
        return a
    if name == "L16":  # GF(4) construction: columns x, y, x+y, x+2y, x+3y
        add = np.array([[0, 1, 2, 3], [1, 0, 3, 2], [2, 3, 0, 1], [3, 2, 1, 0]])
        mul = np.array([[0, 0, 0, 0], [0, 1, 2, 3], [0, 2, 3, 1], [0, 3, 1, 2]])
        return np.array([[x, y, add[x, y], add[x, mul[2, y]], add[x, mul[3, y]]] for x in range(4) for y in range(4)])
    if name == "L27":  # GF(3): columns a, b, c and their combinations (13 columns)
        rows = []
        for a_ in range(3):
            for b_ in range(3):
                for c_ in range(3):
                    v = (a_, b_, c_)
                    cols = []
                    for coeff in ((1, 0, 0), (0, 1, 0), (1, 1, 0), (1, 2, 0), (0, 0, 1), (1, 0, 1), (1, 0, 2),
                                  (0, 1, 1), (1, 1, 1), (1, 2, 2), (0, 1, 2), (1, 2, 1), (1, 1, 2)):
                        cols.append(sum(k * x for k, x in zip(coeff, v)) % 3)
                    rows.append(cols)
        return np.array(rows)
    raise ValueError(f"orthogonal array {name!r}: available L9, L16, L27")


@dataclass(frozen=True)
class Factor:
    """A design factor: registry name and its levels (deviations, SI) or range/tolerance."""

    name: str
    levels: tuple[float, ...] = ()
    low: float = math.nan
    high: float = math.nan
    sigma: float = math.nan


@dataclass(frozen=True)
class Design:
    """A sweep definition (see ``scenarios/designs/smoke.toml``)."""

    name: str
    reducer: str
    scenario: str
    kind: str
    factors: tuple[Factor, ...]
    load_Nm: float
    positions_per_rev: int = 256
    revolutions: float = 1.0
    samples: int = 8
    seed: int = 1
    distribution: str = "uniform"
    morris_levels: int = 4
    source: str = "<design>"

    @property
    def digest(self) -> str:
        """Content hash of everything that defines the points and their evaluation."""
        d = dc.asdict(self)
        d.pop("source")
        if self.kind != "morris":  # only Morris uses it: older stores keep their digest
            d.pop("morris_levels")
        return hashlib.sha256(json.dumps(d, sort_keys=True, default=str).encode()).hexdigest()[:16]


def load_design(path: str | Path) -> Design:
    """Read and validate a design TOML file (one message naming the field and the rule)."""
    path = Path(path)
    src = str(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, tomllib.TOMLDecodeError) as err:
        raise SpecError("design", src, f"cannot be read as TOML: {err}") from None
    sw = data.get("sweep", {})
    for key in ("name", "reducer", "scenario", "kind", "load_Nm"):
        if key not in sw:
            raise SpecError(f"[sweep].{key}", None, "missing key", src)
    if sw["scenario"] not in SCENARIOS:
        raise SpecError("[sweep].scenario", sw["scenario"], f"must be one of {', '.join(SCENARIOS)}", src)
    if sw["kind"] not in DESIGN_KINDS:
        raise SpecError("[sweep].kind", sw["kind"], f"must be one of {', '.join(DESIGN_KINDS)}", src)
    factors = []
    for k, f in enumerate(data.get("factor", [])):
        name = f.get("name")
        if name not in FACTORS:
            raise SpecError(f"factor[{k}].name", name, f"unknown factor; valid: {', '.join(FACTORS)}", src)
        fac = Factor(name, tuple(float(x) for x in f.get("levels", ())), float(f.get("low", math.nan)),
                     float(f.get("high", math.nan)), float(f.get("sigma", math.nan)))
        for v in fac.levels + tuple(x for x in (fac.low, fac.high) if not math.isnan(x)):
            if abs(v) > 1e-3:
                raise SpecError(f"factor[{k}]", v, "expected a deviation in metres, at most ±1 mm", src)
            if name == "eccentric_bearing_clearance" and v < 0:
                raise SpecError(f"factor[{k}]", v, "a clearance cannot be negative", src)
        factors.append(fac)
    if not factors:
        raise SpecError("factor", None, "a design needs at least one [[factor]]", src)
    known = {f.name for f in dc.fields(Design)} - {"factors", "source"}
    extra = set(sw) - known
    if extra:
        raise SpecError(f"[sweep].{min(extra)}", sw[min(extra)], "unknown key", src)
    design = Design(factors=tuple(factors), source=src, **sw)
    if design.kind in SALIB_KINDS:
        _salib_problem(design)  # bounds and sample counts checked before anything runs
    return design


def _salib_problem(design: Design) -> dict:
    """SALib problem dict of a ``morris`` / ``sobol-indices`` design (bounds are the factors'
    ``low``/``high`` deviations, m); refuses missing or empty ranges and too few samples."""
    src = design.source
    for k, f in enumerate(design.factors):
        if not (math.isfinite(f.low) and math.isfinite(f.high) and f.low < f.high):
            raise SpecError(f"factor[{k}] {f.name}", (f.low, f.high), f"{design.kind} needs low < high", src)
    if design.samples < 2:
        raise SpecError("[sweep].samples", design.samples,
                        "at least 2 (Morris trajectories / Saltelli base samples)", src)
    if design.kind == "morris" and not (design.morris_levels >= 2 and design.morris_levels % 2 == 0):
        raise SpecError("[sweep].morris_levels", design.morris_levels, "an even number of grid levels, at least 2",
                        src)
    if design.kind == "sobol-indices" and design.samples & (design.samples - 1):
        raise SpecError("[sweep].samples", design.samples,
                        "a power of two (Saltelli's scheme keeps the Sobol sequence's balance)", src)
    return {"num_vars": len(design.factors), "names": [f.name for f in design.factors],
            "bounds": [[f.low, f.high] for f in design.factors]}


def _salib_samples(design: Design) -> np.ndarray:
    """The SALib sample matrix (rows = points, SI deviations), seeded by ``design.seed``.

    ``morris``: ``samples`` trajectories of D + 1 points on a ``morris_levels`` grid;
    ``sobol-indices``: Saltelli's scheme, ``samples`` × (D + 2) points (first and total order).
    """
    problem = _salib_problem(design)
    if design.kind == "morris":
        from SALib.sample import morris

        return morris.sample(problem, design.samples, num_levels=design.morris_levels, seed=design.seed)
    from SALib.sample import sobol

    return sobol.sample(problem, design.samples, calc_second_order=False, scramble=True, seed=design.seed)


def design_points(design: Design) -> list[dict[str, float]]:
    """The design's points: one dict factor → deviation per point."""
    names = [f.name for f in design.factors]
    kind = design.kind
    if kind == "single-factor":
        pts = []
        for f in design.factors:
            for v in f.levels:
                p = dict.fromkeys(names, 0.0)
                p[f.name] = v
                pts.append(p)
        return pts
    if kind in ("L9", "L16", "L27"):
        oa = orthogonal_array(kind)
        if len(names) > oa.shape[1]:
            raise SpecError("factor", len(names), f"{kind} has {oa.shape[1]} columns")
        for f in design.factors:
            if len(f.levels) != oa.max() + 1:
                raise SpecError(f"factor {f.name}.levels", f.levels, f"{kind} needs {oa.max() + 1} levels")
        return [{f.name: f.levels[row[j]] for j, f in enumerate(design.factors)} for row in oa]
    if kind in SALIB_KINDS:
        return [dict(zip(names, map(float, row))) for row in _salib_samples(design)]
    rng = np.random.default_rng(design.seed)
    if kind in ("lhs", "sobol"):
        from scipy.stats import qmc

        sampler = (qmc.LatinHypercube(d=len(names), seed=rng) if kind == "lhs"
                   else qmc.Sobol(d=len(names), scramble=True, seed=rng))
        u = sampler.random(design.samples)
        lo = np.array([f.low for f in design.factors])
        hi = np.array([f.high for f in design.factors])
        return [dict(zip(names, map(float, lo + row * (hi - lo)))) for row in u]
    # Monte Carlo tolerance stack
    pts = []
    for _ in range(design.samples):
        p = {}
        for f in design.factors:
            if design.distribution == "normal":
                p[f.name] = float(rng.normal(0.0, f.sigma))
            else:
                p[f.name] = float(rng.uniform(f.low, f.high))
        pts.append(p)
    return pts


# ----------------------------------------------------------------------------- evaluation

def evaluate_point(args: tuple[str | ReducerSpec, str, float, int, float, dict[str, float]]) -> dict[str, float]:
    """Evaluate one point in the current process (a worker): build the variant, its model, run.

    ``args[0]`` is the nominal reducer: a :class:`ReducerSpec` (the sweep resolves it once and
    ships it; it is immutable) or a name/path for :func:`rvflex.catalog.resolve`."""
    reducer, scenario, load, positions, revs, point = args
    if isinstance(reducer, ReducerSpec):
        spec = reducer
    else:
        from rvflex.catalog import resolve

        spec = resolve(reducer)
    errors = ErrorSpec()
    for name, value in point.items():
        spec, errors = FACTORS[name][2](spec, errors, value)
    if scenario == "te":
        from rvflex.scenarios.loaded_te import LoadedTE, run_loaded_te

        met = run_loaded_te(LoadedTE(spec, errors, load, revs, positions))[1]
        return {"te_pp_arcsec": met.te_pp_arcsec, "mean_windup_arcsec": met.mean_windup_arcsec}
    from rvflex.scenarios.lost_motion import LostMotion, run_lost_motion

    met = run_lost_motion(LostMotion(spec, errors, load, max(positions, 40)))[1]
    return dc.asdict(met)


@dataclass(frozen=True)
class SweepResult:
    """Rows (point index, factor values, metrics or error) and run facts."""

    rows: list[dict]
    finished: int
    failed: int
    wall_s: float
    executor: str
    workers: int
    startup_s: float = 0.0  # the process warm-up before the first point (:func:`warm_process`), not in wall_s
    cpu_s: float = 0.0  # worker CPU time summed over the points evaluated in this run
    cpu_busiest_worker_s: float = 0.0  # the largest per-worker sum of it (the pool's CPU makespan)


class _Store:
    """One SQLite file per sweep: the design digest and one row per finished point."""

    def __init__(self, path: Path, design: Design, n_points: int):
        path.parent.mkdir(parents=True, exist_ok=True)
        self.db = sqlite3.connect(path, timeout=30.0)
        self.db.execute("CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT)")
        self.db.execute("CREATE TABLE IF NOT EXISTS points (id INTEGER PRIMARY KEY, point TEXT, result TEXT, "
                        "error TEXT)")
        row = self.db.execute("SELECT value FROM meta WHERE key = 'digest'").fetchone()
        if row is None:
            self.db.execute("INSERT INTO meta VALUES ('digest', ?), ('design', ?), ('points', ?)",
                            (design.digest, design.name, str(n_points)))
            self.db.commit()
        elif row[0] != design.digest:
            raise SpecError("store", str(path), f"was written by a different design (digest {row[0]}, this one "
                                                f"{design.digest}): use another --out or delete it")

    def done(self) -> dict[int, tuple[str | None, str | None]]:
        return {i: (r, e) for i, r, e in self.db.execute("SELECT id, result, error FROM points")}

    def write(self, index: int, point: dict, result: dict | None, error: str | None) -> None:
        self.db.execute("INSERT OR REPLACE INTO points VALUES (?, ?, ?, ?)",
                        (index, json.dumps(point), None if result is None else json.dumps(result), error))
        self.db.commit()


def sweep(design: Design, store_path: str | Path, *, executor: str = "process", workers: int | None = None,
          scheduler: str | None = None, progress=None) -> SweepResult:
    """Evaluate every point of ``design`` (skipping those already in the store).

    ``executor``: "serial", "process" (a local process pool) or "dask" (a LocalCluster of
    ``workers`` single-threaded worker processes, or the cluster at ``scheduler``,
    ``tcp://HOST:PORT``)."""
    if executor not in ("serial", "process", "dask"):
        raise SpecError("--executor", executor, "must be 'serial', 'process' or 'dask'")
    points = design_points(design)
    workers = 1 if executor == "serial" else (workers or os.cpu_count() or 1)
    with contextlib.ExitStack() as stack:
        # connect before the store exists: a dead scheduler leaves nothing behind
        client = stack.enter_context(_dask_client(workers, scheduler)) if executor == "dask" else None
        return _sweep(design, points, Path(store_path), executor, workers, client, progress)


def warm_process(reducer: str | ReducerSpec, scenario: str) -> ReducerSpec:
    """Once-per-process warm-up of a sweep: import the evaluation path (Exudyn, the model, the
    scenario, SciPy through the geometry checks) and load its cached compiled kernels by
    resolving and validating the nominal reducer; returns that spec.

    The sweep runs it in its own process before the pool forks, so every worker starts warm
    (about 2–3 s of imports and kernel loading paid once per sweep instead of once per
    worker), and on each Dask worker; it is timed as ``SweepResult.startup_s``. Idempotent."""
    import exudyn  # noqa: F401

    import rvflex.model
    import rvflex.solve

    if scenario == "te":
        import rvflex.scenarios.loaded_te
    else:
        import rvflex.scenarios.lost_motion
    if isinstance(reducer, ReducerSpec):
        return reducer
    from rvflex.catalog import resolve

    spec = resolve(reducer)
    rvflex.model.build_reducer(spec)  # loads the contact and mesh kernels; the model is dropped
    return spec


def _sweep(design, points, store_path, executor, workers, client, progress) -> SweepResult:
    store = _Store(store_path, design, len(points))
    done = store.done()
    todo = [i for i in range(len(points)) if i not in done or done[i][0] is None and done[i][1] == "worker died"]
    t_start = time.perf_counter()
    nominal = design.reducer
    if todo:
        nominal = warm_process(design.reducer, design.scenario)
        if client is not None:  # the resolved spec: a remote worker need not read the reducer's file
            client.run(warm_process, nominal, design.scenario)
    args = {i: (nominal, design.scenario, design.load_Nm, design.positions_per_rev, design.revolutions,
                points[i]) for i in todo}
    t0 = time.perf_counter()

    cpu: dict[int, float] = {}  # worker process id → CPU time of its points evaluated in this run (s)

    def record(i, fn):
        try:
            result, cpu_s, pid = fn()
            store.write(i, points[i], result, None)
            cpu[pid] = cpu.get(pid, 0.0) + cpu_s
        except BrokenProcessPool:
            raise
        except Exception as err:  # noqa: BLE001 -- a failing point is recorded, the sweep goes on
            store.write(i, points[i], None, f"{type(err).__name__}: {err}")
        if progress is not None:
            progress()

    if executor == "serial":
        for i in todo:
            record(i, lambda i=i: evaluate_timed(args[i]))
    elif executor == "dask":
        _run_dask(client, todo, args, record)
    else:
        remaining = list(todo)
        for _attempt in range(2):  # a killed worker's points get a fresh pool once
            if remaining:
                remaining = _run_pool(remaining, args, workers, record)
        for i in remaining:  # the same points killed two pools: find the culprit, one point per pool
            if _run_pool([i], args, 1, record):
                store.write(i, points[i], None, "worker died")
                if progress is not None:
                    progress()
    rows = []
    for i, (res, err) in sorted(store.done().items()):
        row = {"point": i, **points[i]}
        row.update(json.loads(res) if res else {"error": err})
        rows.append(row)
    failed = sum(1 for r in rows if "error" in r)
    return SweepResult(rows, len(rows) - failed, failed, time.perf_counter() - t0, executor, workers, t0 - t_start,
                       float(sum(cpu.values())), max(cpu.values(), default=0.0))


def evaluate_timed(args) -> tuple[dict[str, float], float, int]:
    """:func:`evaluate_point`, the CPU time it took (s) and the id of the process that ran it."""
    c0 = time.process_time()
    result = evaluate_point(args)
    return result, time.process_time() - c0, os.getpid()


def _run_pool(indices: list[int], args: dict, workers: int, record) -> list[int]:
    """Evaluate ``indices`` in a fresh process pool, recording each point as it completes;
    returns the points left unfinished when a worker died (empty when none did)."""
    remaining = list(indices)
    try:
        with ProcessPoolExecutor(max_workers=workers, mp_context=_fork_context()) as pool:
            futures = {pool.submit(evaluate_timed, args[i]): i for i in remaining}
            for fut in as_completed(futures):  # store each point as soon as it is done
                record(futures[fut], fut.result)
                remaining.remove(futures[fut])
    except BrokenProcessPool:
        return remaining
    return []


def _fork_context():
    """Workers forked from the warm sweep process (:func:`warm_process`) where the platform
    forks (Linux); elsewhere the platform default, each worker then warming on its first point."""
    import multiprocessing as mp

    return mp.get_context("fork") if "fork" in mp.get_all_start_methods() else None


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
            raise SpecError("--scheduler", scheduler, f"does not answer within {DASK_CONNECT_TIMEOUT_S:g} s "
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

    futures = {client.submit(evaluate_timed, args[i], pure=False, retries=1): i for i in todo}
    for fut in as_completed(futures):
        record(futures[fut], fut.result)


def range_table(design: Design, rows: list[dict], metric: str) -> list[dict]:
    """Level means K1…Kn and range R per factor (seed 004 Table 8 style) for an orthogonal or
    single-factor design."""
    out = []
    for f in design.factors:
        means = []
        for level in f.levels:
            vals = [r[metric] for r in rows if metric in r and r[f.name] == level]
            means.append(float(np.mean(vals)) if vals else math.nan)
        finite = [m for m in means if not math.isnan(m)]
        out.append({"factor": f.name, "K": means, "range": (max(finite) - min(finite)) if finite else math.nan})
    return sorted(out, key=lambda r: -r["range"])


def classify(ranking: list[dict], key: str = "range") -> dict[str, str]:
    """Sensitive / insensitive per factor: the ranges (or another non-negative measure ``key``,
    e.g. ``index`` of :func:`sensitivity_indices`), sorted, split where two consecutive ones
    differ by the largest ratio (the natural break on a log scale); the upper group is
    sensitive. A single factor is sensitive; a factor without a finite measure is left out."""
    ranked = sorted((r for r in ranking if math.isfinite(r[key])), key=lambda r: -r[key])
    if len(ranked) < 2:
        return {r["factor"]: "sensitive" for r in ranked}
    ratios = [max(a[key], 1e-300) / max(b[key], 1e-300) for a, b in itertools.pairwise(ranked)]
    cut = int(np.argmax(ratios)) + 1
    return {r["factor"]: ("sensitive" if k < cut else "insensitive") for k, r in enumerate(ranked)}


def sensitivity_indices(design: Design, rows: list[dict], metric: str, *, num_resamples: int = 1000,
                        conf_level: float = 0.95) -> list[dict]:
    """Global sensitivity of ``metric`` from a finished ``morris`` or ``sobol-indices`` sweep,
    analysed with SALib (bootstrap seeded by ``design.seed``), most influential factor first.

    Each entry has ``factor``, ``index`` (the ranking measure) and ``index_name``, plus:

    - ``morris``: ``index`` = μ* (mean |elementary effect|, in the metric's unit per full
      ``low``…``high`` range, so comparable with a single-factor range R of a linear
      response), ``mu``, ``sigma`` (spread of the effects: interaction or non-linearity)
      and ``mu_star_conf``;
    - ``sobol-indices``: ``index`` = ST (total-order index, share of the variance including
      interactions), ``S1``, ``S1_conf`` and ``ST_conf`` (half-widths at ``conf_level``).

    Every entry also has ``groups_used``: a trajectory (Morris) or a Saltelli block with a failed
    point is dropped whole, since both estimators need complete groups; raises ``ValueError``
    when fewer than two groups are complete.
    """
    if design.kind not in SALIB_KINDS:
        raise ValueError(f"sensitivity indices need a {' or '.join(SALIB_KINDS)} design, not {design.kind!r}")
    problem = _salib_problem(design)
    x = _salib_samples(design)
    y = np.full(len(x), np.nan)
    for r in rows:
        if metric in r and r[metric] is not None:
            y[r["point"]] = float(r[metric])
    d = len(design.factors)
    size = d + 1 if design.kind == "morris" else d + 2
    ok = np.isfinite(y.reshape(-1, size)).all(axis=1)
    if ok.sum() < 2:
        raise ValueError(f"only {int(ok.sum())} complete {'trajectories' if size == d + 1 else 'blocks'} of "
                         f"{len(ok)}: too few for {design.kind}")
    keep = np.repeat(ok, size)
    out = []
    if design.kind == "morris":
        from SALib.analyze import morris

        res = morris.analyze(problem, x[keep], y[keep], num_resamples=num_resamples, conf_level=conf_level,
                             num_levels=design.morris_levels, seed=design.seed)
        for j, name in enumerate(problem["names"]):
            out.append({"factor": name, "index_name": "mu_star", "index": float(res["mu_star"][j]),
                        "mu": float(res["mu"][j]), "sigma": float(res["sigma"][j]),
                        "mu_star_conf": float(res["mu_star_conf"][j]), "groups_used": int(ok.sum())})
    else:
        from SALib.analyze import sobol

        res = sobol.analyze(problem, y[keep], calc_second_order=False, num_resamples=num_resamples,
                            conf_level=conf_level, seed=design.seed)
        for j, name in enumerate(problem["names"]):
            out.append({"factor": name, "index_name": "ST", "index": float(res["ST"][j]),
                        "S1": float(res["S1"][j]), "S1_conf": float(res["S1_conf"][j]),
                        "ST_conf": float(res["ST_conf"][j]), "groups_used": int(ok.sum())})
    return sorted(out, key=lambda r: -r["index"])


def write_indices_csv(ranking: list[dict], classes: dict[str, str], path: Path) -> Path:
    """Write the :func:`sensitivity_indices` table (one row per factor, with its class) as CSV."""
    import csv

    keys = ["factor", "index_name", "index"] + [k for k in ranking[0] if k not in ("factor", "index_name", "index")]
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(keys + ["class"])
        for r in ranking:
            w.writerow([r[k] for k in keys] + [classes.get(r["factor"], "")])
    return path


def plot_indices(design: Design, ranking: list[dict], metric: str, path: Path) -> Path:
    """Bar plot of the sensitivity indices with their confidence intervals; for Morris also the
    μ*–σ plane (σ ≫ μ* flags interaction or non-linearity)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [r["factor"] for r in ranking][::-1]
    y = np.arange(len(names))
    morris = ranking[0]["index_name"] == "mu_star"
    fig, axes = plt.subplots(1, 2 if morris else 1, figsize=(11 if morris else 7, 0.5 * len(names) + 2),
                             layout="constrained", squeeze=False)
    ax = axes[0, 0]
    rev = ranking[::-1]
    if morris:
        ax.barh(y, [r["index"] for r in rev], xerr=[r["mu_star_conf"] for r in rev], capsize=3)
        ax.set_xlabel(f"μ* of {metric} (per full range)")
        ax2 = axes[0, 1]
        ax2.scatter([r["index"] for r in ranking], [r["sigma"] for r in ranking])
        for r in ranking:
            ax2.annotate(r["factor"], (r["index"], r["sigma"]), fontsize=7)
        ax2.set_xlabel("μ*")
        ax2.set_ylabel("σ")
        ax2.grid(alpha=0.3)
    else:
        ax.barh(y - 0.2, [r["S1"] for r in rev], 0.4, xerr=[r["S1_conf"] for r in rev], capsize=3, label="S1")
        ax.barh(y + 0.2, [r["index"] for r in rev], 0.4, xerr=[r["ST_conf"] for r in rev], capsize=3, label="ST")
        ax.set_xlabel(f"Sobol index of {metric}")
        ax.legend()
    ax.set_yticks(y, names, fontsize=8)
    ax.grid(alpha=0.3, axis="x")
    fig.suptitle(f"{design.name}: {design.kind} ({design.samples} {'trajectories' if morris else 'base samples'}, "
                 f"{ranking[0]['groups_used']} complete)")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_main_effects(design: Design, ranking: list[dict], metric: str, path: Path) -> Path:
    """Main-effect plot: level means of ``metric`` against each factor's deviation (µm)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(ranking)
    cols = min(n, 5)
    rows_ = math.ceil(n / cols)
    fig, axes = plt.subplots(rows_, cols, figsize=(3.0 * cols, 2.6 * rows_), layout="constrained", squeeze=False,
                             sharey=True)
    levels = {f.name: f.levels for f in design.factors}
    cls = classify(ranking)
    for ax, r in zip(axes.flat, ranking):
        ax.plot(np.asarray(levels[r["factor"]]) * 1e6, r["K"], "o-")
        ax.set_title(f"{r['factor']}\nR = {r['range']:.4g} ({cls[r['factor']]})", fontsize=8)
        ax.set_xlabel("deviation (µm)", fontsize=8)
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    axes[0, 0].set_ylabel(metric)
    fig.suptitle(f"{design.name}: main effects ({design.kind}, {design.reducer})")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def monte_carlo_design(points: int, seed: int = 1, positions_per_rev: int = 2048) -> Design:
    """Monte Carlo tolerance stack of seed 004's five sensitive characteristics on the rigid
    RV-40E (uniform within their tolerance bands), quasi-static loaded TE at rated torque over
    one output revolution: the benchmark design of ``rvflex bench sweep``."""
    um = 1e-6
    return Design(
        name=f"mc{points}", reducer="rv40e", scenario="te", kind="monte-carlo", load_Nm=412.0,
        positions_per_rev=positions_per_rev, samples=points, seed=seed, distribution="uniform",
        factors=(Factor("eccentricity", low=-3 * um, high=3 * um), Factor("moved_modification", low=-1 * um, high=1 * um),
                 Factor("equidistant_modification", low=-2 * um, high=2 * um),
                 Factor("pin_circle_radius", low=-3 * um, high=3 * um), Factor("pin_radius", low=-1 * um, high=1 * um)))


def bench_sweep(store_dir: Path, points: int = 100, speedup_points: int = 32, progress=print) -> dict:
    """Wall time of a ``points``-point Monte Carlo with the process executor (2 workers), and the
    speed-up from 1 to 2 workers on the same ``speedup_points`` points, measured in one run.

    The process is warmed once (:func:`warm_process`: imports and compiled kernels, which every
    sweep pays once before its pool forks) before either setting runs, so both settings start
    alike; the wall times are the sweeps' evaluation phases (``SweepResult.wall_s``), and each
    sweep's own start-up is reported beside them (``startup_*_s``). ``cpu_*_s`` is the worker
    CPU time summed over the points: ``busy_*`` = cpu / (workers × wall) is 1 for a pool that
    never waits, less when the tail idles a worker or other processes take the cores.
    ``speedup_cpu`` = cpu_1 / (CPU of the busiest of the 2 workers) is the speed-up the same
    points would show on cores of their own: it keeps the load imbalance and the slower
    per-point CPU of two busy cores, and drops what other processes take (a check on a shared
    machine, not a substitute for ``speedup``)."""
    import shutil

    store_dir.mkdir(parents=True, exist_ok=True)
    out = {}
    small = monte_carlo_design(speedup_points, seed=2)
    t0 = time.perf_counter()
    warm_process(small.reducer, small.scenario)
    out["process_warmup_s"] = time.perf_counter() - t0
    for w in (1, 2):
        path = store_dir / f"speedup_{w}.sqlite"
        path.unlink(missing_ok=True)
        progress(f"{speedup_points} points with {w} worker(s) ...")
        res = sweep(small, path, executor="process", workers=w)
        out[w] = res
    big = monte_carlo_design(points)
    path = store_dir / "mc.sqlite"
    path.unlink(missing_ok=True)
    progress(f"{points}-point Monte Carlo with 2 workers ...")
    res = sweep(big, path, executor="process", workers=2)
    shutil.rmtree(store_dir, ignore_errors=True)
    one, two = out[1], out[2]
    return {"mc_points": points, "mc_finished": res.finished, "mc_wall_s": res.wall_s + res.startup_s,
            "speedup_points": speedup_points, "process_warmup_s": out["process_warmup_s"],
            "wall_1_worker_s": one.wall_s, "wall_2_workers_s": two.wall_s,
            "startup_1_worker_s": one.startup_s, "startup_2_workers_s": two.startup_s,
            "cpu_1_worker_s": one.cpu_s, "cpu_2_workers_s": two.cpu_s,
            "busy_1_worker": one.cpu_s / one.wall_s, "busy_2_workers": two.cpu_s / (2 * two.wall_s),
            "speedup_cpu": one.cpu_s / two.cpu_busiest_worker_s,
            "speedup": one.wall_s / two.wall_s}

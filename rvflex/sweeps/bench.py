"""``rvflex bench sweep``: wall time of a Monte Carlo sweep and the 1 → 2 worker speed-up."""

from __future__ import annotations

import shutil
import time
from pathlib import Path

from rvflex.sweeps.designs import monte_carlo_design
from rvflex.sweeps.executors import sweep, warm_process

__all__ = ["bench_sweep"]


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

"""Parameter sweeps and tolerance designs over full model runs.

``sweep(design, store, executor=...)`` evaluates every point of a design — a spec/errors
variant made with :func:`dataclasses.replace` — in its own model, stores each finished point
at once in SQLite and resumes from there; see :mod:`rvflex.sweeps.executors`.

Modules, one concern each:

- :mod:`~rvflex.sweeps.factors`: the named deviations a design can vary (``FACTORS``);
- :mod:`~rvflex.sweeps.designs`: :class:`Design` and its TOML file, the points of each kind
  (single factor, L9/L16/L27, LHS, Sobol, Monte Carlo, Morris, Saltelli);
- :mod:`~rvflex.sweeps.registry`: the scenarios a point can run (``te``, ``lost-motion``),
  registered by the scenarios themselves (:mod:`rvflex.scenarios.sweepable`);
- :mod:`~rvflex.sweeps.store`: the SQLite store;
- :mod:`~rvflex.sweeps.executors`: serial, process pool (:mod:`rvflex.parallel`) and Dask;
- :mod:`~rvflex.sweeps.analysis`: ranges, sensitive/insensitive split, SALib indices;
- :mod:`~rvflex.sweeps.plots`: main-effect and index plots;
- :mod:`~rvflex.sweeps.bench`: ``rvflex bench sweep``.
"""

from rvflex.sweeps.analysis import classify, range_table, sensitivity_indices, write_indices_csv
from rvflex.sweeps.bench import bench_sweep
from rvflex.sweeps.designs import (
    DESIGN_KINDS,
    SALIB_KINDS,
    Design,
    Factor,
    design_points,
    load_design,
    monte_carlo_design,
    orthogonal_array,
)
from rvflex.sweeps.executors import EXECUTORS, SweepResult, evaluate_point, sweep, warm_process
from rvflex.sweeps.factors import FACTORS
from rvflex.sweeps.plots import plot_indices, plot_main_effects
from rvflex.sweeps.registry import SweepScenario, register

__all__ = [
    "DESIGN_KINDS",
    "EXECUTORS",
    "FACTORS",
    "SALIB_KINDS",
    "Design",
    "Factor",
    "SweepResult",
    "SweepScenario",
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
    "register",
    "sensitivity_indices",
    "sweep",
    "warm_process",
    "write_indices_csv",
]

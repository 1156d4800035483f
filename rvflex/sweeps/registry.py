"""What a sweep can run: scenarios register here, the sweep engine looks them up by name.

The engine (designs, executors) never imports a scenario module: a scenario module registers
a :class:`SweepScenario` when it is imported. The built-in ones (``te``, ``lost-motion``)
register in :mod:`rvflex.scenarios.sweepable`, which ``import rvflex.scenarios`` (and the
``rvflex`` command) loads. An entry is a frozen dataclass of module-level functions, so it
pickles by reference into any worker, a Dask worker included, which imports its module there.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from rvflex.options import ModelOptions
from rvflex.spec import ErrorSpec, ReducerSpec, SpecError

__all__ = ["SweepScenario", "get", "names", "register"]


@dataclass(frozen=True)
class SweepScenario:
    """A scenario a sweep point can run.

    ``evaluate(spec, errors, load_Nm, positions_per_rev, revolutions, options) -> {metric: value}``
    runs one point (builds its own model with ``options``, a
    :class:`~rvflex.options.ModelOptions`); ``metric`` is the ranking metric among its keys,
    in ``unit``; ``warm()`` imports what ``evaluate`` needs (run once per process before a
    pool forks)."""

    name: str
    evaluate: Callable[[ReducerSpec, ErrorSpec, float, int, float, ModelOptions], dict[str, float]]
    metric: str
    unit: str
    warm: Callable[[], None]


_REGISTRY: dict[str, SweepScenario] = {}


def register(scenario: SweepScenario) -> SweepScenario:
    """Make ``scenario`` runnable by sweeps under its name (re-registering replaces it)."""
    _REGISTRY[scenario.name] = scenario
    return scenario


def names() -> tuple[str, ...]:
    """Names of the registered scenarios, in registration order."""
    return tuple(_REGISTRY)


def get(name: str) -> SweepScenario:
    """The registered scenario ``name``; refuses an unknown name, listing the known ones."""
    try:
        return _REGISTRY[name]
    except KeyError:
        raise SpecError("scenario", name, f"not a registered sweep scenario ({', '.join(_REGISTRY) or 'none'}"
                                                  f"; the built-in ones register on `import rvflex.scenarios`)") from None

"""One process-pool helper for every parallel run of independent model evaluations.

:func:`map_warm` evaluates ``fn(item)`` for every item in a local process pool whose workers
are forked from the calling process where the platform forks (Linux), so they start warm:
whatever the caller imported and compiled before the call (Exudyn, the model, numba kernels)
is already in every worker. It reports each item as soon as it finishes, keeps going when an
item raises (the exception is that item's outcome), and survives a worker that dies (killed
by the OS, a crash in compiled code): the items not finished when a pool breaks get a fresh
pool ``retries`` times; the items still left then run one per pool, so only the item that
kills its worker every time is reported as dead. ``workers=0`` evaluates in the calling
process (serial; same outcomes, no pool).

Used by the sweep's process executor, the sensitivity scenario and the diagnosis's model runs;
results never depend on the number of workers, since every evaluation builds its own model.
"""

from __future__ import annotations

import multiprocessing as mp
from collections.abc import Callable, Iterable
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any

__all__ = ["Outcome", "fork_context", "map_warm"]


@dataclass(frozen=True)
class Outcome:
    """What became of one item: its ``value``, or the ``error`` it raised, or ``died`` (its
    worker process died on every attempt)."""

    index: int  # position of the item in the input
    value: Any = None
    error: BaseException | None = None
    died: bool = False

    @property
    def ok(self) -> bool:
        """True when ``fn`` returned a value."""
        return self.error is None and not self.died


def fork_context():
    """The ``fork`` start method where the platform has it (workers inherit the warm parent),
    else None (the platform default: each worker then imports on its first item)."""
    return mp.get_context("fork") if "fork" in mp.get_all_start_methods() else None


def map_warm(fn: Callable[[Any], Any], items: Iterable[Any], workers: int, *,
             progress: Callable[[int, int], None] | None = None, retries: int = 1,
             on_outcome: Callable[[Outcome], None] | None = None) -> list[Outcome]:
    """Evaluate ``fn(item)`` for every item; returns one :class:`Outcome` per item, in item order.

    Parameters
    ----------
    fn
        A picklable (module-level) function of one item.
    workers
        Pool size; 0 evaluates in this process, in item order.
    progress
        Called as ``progress(done, total)`` after every finished item.
    retries
        Fresh pools for the unfinished items after a pool breaks (a worker died), before the
        items left run one per pool to find the one that kills its worker.
    on_outcome
        Called with each :class:`Outcome` as soon as it is known (e.g. to store it), in
        completion order; an exception it raises stops the run.
    """
    items = list(items)
    outcomes: dict[int, Outcome] = {}

    def finish(out: Outcome) -> None:
        outcomes[out.index] = out
        if on_outcome is not None:
            on_outcome(out)
        if progress is not None:
            progress(len(outcomes), len(items))

    if workers <= 0:
        for i, item in enumerate(items):
            try:
                out = Outcome(i, value=fn(item))
            except Exception as err:  # noqa: BLE001 -- a failing item is its outcome, the run goes on
                out = Outcome(i, error=err)
            finish(out)
        return [outcomes[i] for i in range(len(items))]

    remaining = list(range(len(items)))
    for _attempt in range(1 + max(retries, 0)):
        if remaining:
            remaining = _run_pool(fn, items, remaining, workers, finish)
    for i in remaining:  # the same items broke every pool: one per pool finds the culprit
        if _run_pool(fn, items, [i], 1, finish):
            finish(Outcome(i, died=True))
    return [outcomes[i] for i in range(len(items))]


def _run_pool(fn, items: list, indices: list[int], workers: int, finish) -> list[int]:
    """Evaluate ``indices`` in a fresh pool, finishing each as it completes; returns the indices
    left unfinished when a worker died (empty when none did)."""
    remaining = list(indices)
    try:
        with ProcessPoolExecutor(max_workers=workers, mp_context=fork_context()) as pool:
            futures = {pool.submit(fn, items[i]): i for i in remaining}
            for fut in as_completed(futures):
                i = futures[fut]
                try:
                    out = Outcome(i, value=fut.result())
                except BrokenProcessPool:
                    raise
                except Exception as err:  # noqa: BLE001 -- the item's own error, raised in its worker
                    out = Outcome(i, error=err)
                remaining.remove(i)
                finish(out)
    except BrokenProcessPool:
        return remaining
    return []

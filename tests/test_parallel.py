"""rvflex.parallel.map_warm: outcomes per item in item order, errors kept per item, a worker that
dies every time isolated to its own item, the same outcomes serial and pooled."""

from __future__ import annotations

import os

import pytest

from rvflex.parallel import map_warm


def _work(x: int) -> int:
    if x == 3:
        raise ValueError("three")
    if x == 5:
        os._exit(7)  # the worker process dies
    return x * x


@pytest.mark.skipif("fork" not in __import__("multiprocessing").get_all_start_methods(),
                    reason="the test function reaches the workers through fork")
def test_pool_outcomes_errors_and_a_dying_worker():
    seen, progress = [], []
    out = map_warm(_work, range(8), 2, on_outcome=lambda o: seen.append(o.index),
                   progress=lambda done, total: progress.append((done, total)))
    assert [o.index for o in out] == list(range(8))
    assert [o.value for o in out if o.ok] == [0, 1, 4, 16, 36, 49]
    assert isinstance(out[3].error, ValueError) and str(out[3].error) == "three"
    assert out[5].died and not out[5].ok and [o.index for o in out if o.died] == [5]
    assert sorted(seen) == list(range(8)) and progress[-1] == (8, 8)


def test_serial_gives_the_same_values():
    items = [0, 1, 2, 3, 4]
    serial = map_warm(_work, items, 0)
    assert [o.value for o in serial] == [0, 1, 4, None, 16]
    assert isinstance(serial[3].error, ValueError)

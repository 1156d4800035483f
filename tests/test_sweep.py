"""Sweeps: designs, executors that agree, the resumable store, failures, bad design input."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from rvflex.cli import main
from rvflex.spec import SpecError
from rvflex.sweep import design_points, load_design, orthogonal_array, sweep

SMOKE = Path(__file__).resolve().parents[1] / "scenarios" / "designs" / "smoke.toml"


@pytest.mark.parametrize("name", ["L9", "L16", "L27"])
def test_orthogonal_arrays_are_balanced(name):
    """Every pair of columns shows every level pair equally often (strength 2)."""
    a = orthogonal_array(name)
    q = a.max() + 1
    for i, j in itertools.combinations(range(a.shape[1]), 2):
        counts = np.zeros((q, q), int)
        for r in a:
            counts[r[i], r[j]] += 1
        assert np.all(counts == len(a) // (q * q)), (name, i, j)


def test_executors_agree_and_the_store_resumes(tmp_path):
    """Serial and process pools give the same table; a rerun skips finished points."""
    design = load_design(SMOKE)
    assert len(design_points(design)) <= 8
    serial = sweep(design, tmp_path / "s.sqlite", executor="serial")
    pool = sweep(design, tmp_path / "p.sqlite", executor="process", workers=2)
    assert serial.failed == pool.failed == 0
    assert serial.rows == pool.rows
    again = sweep(design, tmp_path / "s.sqlite", executor="serial")
    assert again.rows == serial.rows and again.wall_s < 0.5 * serial.wall_s


@pytest.mark.parametrize("executor", ["serial", "process"])
def test_failing_point_is_recorded_and_the_sweep_goes_on(tmp_path, executor):
    """An invalid variant fails its point only, whatever the executor (the error crosses the
    process boundary intact instead of breaking the pool)."""
    text = SMOKE.read_text().replace("levels = [-2e-6, 2e-6]\n", "levels = [-2e-6, 9e-4]\n", 1)
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    res = sweep(load_design(bad), tmp_path / "b.sqlite", executor=executor, workers=2)
    errors = [r for r in res.rows if "error" in r]
    assert res.failed == 1 and len(errors) == 1
    assert "K1 = e·z_b/r_p" in errors[0]["error"]
    assert res.finished == len(res.rows) - 1


def test_bad_design_input(tmp_path):
    text = SMOKE.read_text()
    for old, new, message in [
        ('name = "pin_radius"', 'name = "pin_radious"', r"unknown factor; valid: eccentricity, "),
        ('name = "pin_radius"\nlevels = [-1e-6, 1e-6]', 'name = "eccentric_bearing_clearance"\nlevels = [-1e-6, 1e-6]',
         r"a clearance cannot be negative"),
    ]:
        p = tmp_path / "d.toml"
        p.write_text(text.replace(old, new))
        with pytest.raises(SpecError, match=message):
            load_design(p)
    design = load_design(SMOKE)
    sweep(design, tmp_path / "x.sqlite", executor="serial")
    p = tmp_path / "other.toml"
    p.write_text(text.replace("positions_per_rev = 64", "positions_per_rev = 32"))
    with pytest.raises(SpecError, match=r"was written by a different design"):
        sweep(load_design(p), tmp_path / "x.sqlite", executor="serial")


def test_sweep_command_json(tmp_path):
    import json

    assert main(["sweep", str(SMOKE), "--executor", "serial", "--out", str(tmp_path / "o"),
                 "--json", str(tmp_path / "s.json")]) == 0
    doc = json.loads((tmp_path / "s.json").read_text())
    assert {"points", "finished", "failed", "wall_s", "executor", "workers", "ranking"} <= doc.keys()
    assert doc["finished"] == doc["points"] == 6 and doc["failed"] == 0
    assert (tmp_path / "o" / "table.csv").exists()


def test_dask_local_cluster_gives_the_serial_table(tmp_path):
    """The Dask path (a LocalCluster of 2 worker processes) reproduces the serial table."""
    design = load_design(SMOKE)
    serial = sweep(design, tmp_path / "s.sqlite", executor="serial")
    dask = sweep(design, tmp_path / "d.sqlite", executor="dask", workers=2)
    assert dask.rows == serial.rows and dask.executor == "dask"


def test_dead_scheduler_is_refused_quickly_and_leaves_no_store(tmp_path):
    import time

    t0 = time.perf_counter()
    with pytest.raises(SpecError, match=r"--scheduler = 'tcp://127.0.0.1:1': does not answer within 5 s"):
        sweep(load_design(SMOKE), tmp_path / "x.sqlite", executor="dask", scheduler="tcp://127.0.0.1:1")
    assert time.perf_counter() - t0 < 15.0
    assert not (tmp_path / "x.sqlite").exists()


def test_classification_splits_at_the_largest_ratio():
    from rvflex.sweep import classify

    ranking = [{"factor": f, "range": r} for f, r in
               [("a", 0.38), ("b", 0.30), ("c", 0.21), ("d", 0.19), ("e", 0.063), ("f", 0.037), ("g", 0.013)]]
    cls = classify(ranking)
    assert [f for f, c in cls.items() if c == "sensitive"] == ["a", "b", "c", "d"]

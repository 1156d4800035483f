"""Sweeps: designs, executors that agree, the resumable store, failures, bad design input."""

from __future__ import annotations

import dataclasses
import itertools
from pathlib import Path

import numpy as np
import pytest

from rvflex.cli import main
from rvflex.spec import SpecError
from rvflex.sweeps import design_points, load_design, orthogonal_array, sweep

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
    with pytest.raises(SpecError, match=r"^scheduler = 'tcp://127.0.0.1:1': does not answer within 5 s"):
        sweep(load_design(SMOKE), tmp_path / "x.sqlite", executor="dask", scheduler="tcp://127.0.0.1:1")
    assert time.perf_counter() - t0 < 15.0
    assert not (tmp_path / "x.sqlite").exists()


def test_classification_splits_at_the_largest_ratio():
    from rvflex.sweeps import classify

    ranking = [{"factor": f, "range": r} for f, r in
               [("a", 0.38), ("b", 0.30), ("c", 0.21), ("d", 0.19), ("e", 0.063), ("f", 0.037), ("g", 0.013)]]
    cls = classify(ranking)
    assert [f for f, c in cls.items() if c == "sensitive"] == ["a", "b", "c", "d"]


# ----------------------------------------------------------------------------- SALib designs

MORRIS = SMOKE.parent / "smoke_morris.toml"


def _analytic_design(kind: str, samples: int):
    from rvflex.sweeps import Design, Factor

    um = 1e-6
    return Design(name="analytic", reducer="rv40e", scenario="te", kind=kind, load_Nm=412.0, samples=samples, seed=3,
                  factors=(Factor("eccentricity", low=-3 * um, high=3 * um), Factor("pin_radius", low=-1 * um, high=1 * um),
                           Factor("sun_pitch_radius", low=-10 * um, high=0.0)))


# y = Σ b_i·x_i (arcsec per m of deviation): a linear response with known indices
_COEF = {"eccentricity": 2e6, "pin_radius": -3e6, "sun_pitch_radius": 1e4}


def _analytic_rows(design):
    return [{"point": i, **p, "y": sum(_COEF[k] * v for k, v in p.items())} for i, p in enumerate(design_points(design))]


def test_morris_of_a_linear_response_recovers_its_effects():
    """Every elementary effect of a linear response is b_i·(high − low): μ* equals it, σ is 0."""
    from rvflex.sweeps import sensitivity_indices

    design = _analytic_design("morris", 10)
    assert len(design_points(design)) == 10 * 4  # trajectories × (D + 1)
    ranking = sensitivity_indices(design, _analytic_rows(design), "y")
    span = {f.name: f.high - f.low for f in design.factors}
    assert [r["factor"] for r in ranking] == ["eccentricity", "pin_radius", "sun_pitch_radius"]
    for r in ranking:
        assert r["index"] == pytest.approx(abs(_COEF[r["factor"]]) * span[r["factor"]], rel=1e-9)
        assert r["mu"] == pytest.approx(_COEF[r["factor"]] * span[r["factor"]], rel=1e-9)
        assert r["sigma"] < 1e-9 * r["index"]


def test_sobol_indices_of_a_linear_response_match_the_variance_shares():
    """Uniform independent inputs: S1_i = ST_i = b_i²·w_i²/Σ b_j²·w_j² (w the range); the
    estimate must fall within its own bootstrap interval of the exact share (plus 0.05 for the
    estimator's bias at 64 base samples)."""
    from rvflex.sweeps import sensitivity_indices

    design = _analytic_design("sobol-indices", 64)
    assert len(design_points(design)) == 64 * 5  # base samples × (D + 2)
    ranking = sensitivity_indices(design, _analytic_rows(design), "y")
    var = {f.name: (_COEF[f.name] * (f.high - f.low)) ** 2 for f in design.factors}
    total = sum(var.values())
    assert [r["factor"] for r in ranking] == ["eccentricity", "pin_radius", "sun_pitch_radius"]
    for r in ranking:
        exact = var[r["factor"]] / total
        assert abs(r["S1"] - exact) <= r["S1_conf"] + 0.05, r
        assert abs(r["index"] - exact) <= r["ST_conf"] + 0.05, r


def test_a_failed_point_drops_its_whole_trajectory():
    from rvflex.sweeps import sensitivity_indices

    design = _analytic_design("morris", 6)
    rows = _analytic_rows(design)
    rows[5] = {"point": 5, "error": "SolveError: stalled"}  # second trajectory
    ranking = sensitivity_indices(design, rows, "y")
    assert all(r["groups_used"] == 5 for r in ranking)
    assert ranking[0]["index"] == pytest.approx(2e6 * 6e-6, rel=1e-9)


def test_salib_design_input_is_checked(tmp_path):
    text = MORRIS.read_text()
    for old, new, message in [
        ("low = -1e-6\nhigh = 1e-6", "levels = [-1e-6, 1e-6]", r"morris needs low < high"),
        ("morris_levels = 4", "morris_levels = 3", r"an even number of grid levels"),
        ('kind = "morris"', 'kind = "sobol-indices"', r"a power of two"),  # samples = 4 is one: use 6
    ]:
        p = tmp_path / "d.toml"
        body = text.replace(old, new)
        if "power of two" in message:
            body = body.replace("samples = 4", "samples = 6").replace("morris_levels = 4\n", "")
        p.write_text(body)
        with pytest.raises(SpecError, match=message):
            load_design(p)


def test_morris_on_the_model_agrees_with_single_factor_ranges_under_both_executors(tmp_path):
    """Smoke model, coarse resolution: the Morris design of the smoke factors over the smoke
    levels gives identical rows under the serial and the process executor; its μ* ranking of
    TE peak-to-peak is the single-factor range ranking; and for the mean wind-up, which is
    linear in µm deviations (σ/μ* < 2 % here), μ* equals the single-factor range R (the
    same end-to-end change) within 5 %."""
    import json

    from rvflex.sweeps import range_table, sensitivity_indices

    single_design = load_design(SMOKE)
    single = sweep(single_design, tmp_path / "s.sqlite", executor="serial")
    design = load_design(MORRIS)
    serial = sweep(design, tmp_path / "m.sqlite", executor="serial")
    assert main(["sweep", str(MORRIS), "--executor", "process", "--workers", "2", "--out", str(tmp_path / "o"),
                 "--json", str(tmp_path / "m.json")]) == 0
    pool = sweep(design, tmp_path / "o" / "smoke_morris.sqlite", executor="serial")  # resumes: nothing to run
    assert serial.failed == 0 and serial.rows == pool.rows
    doc = json.loads((tmp_path / "m.json").read_text())
    assert doc["points"] == 16 and doc["finished"] == 16
    for metric in ("te_pp_arcsec", "mean_windup_arcsec"):
        ranges = range_table(single_design, single.rows, metric)
        indices = sensitivity_indices(design, serial.rows, metric)
        assert [r["factor"] for r in indices] == [r["factor"] for r in ranges], metric
    assert [{"factor": r["factor"], "index": r["index"]} for r in doc["ranking"]] == [
        {"factor": r["factor"], "index": r["index"]} for r in sensitivity_indices(design, serial.rows, "te_pp_arcsec")]
    ranges = {r["factor"]: r["range"] for r in range_table(single_design, single.rows, "mean_windup_arcsec")}
    for r in sensitivity_indices(design, serial.rows, "mean_windup_arcsec")[:2]:
        assert r["sigma"] < 0.02 * r["index"]
        assert r["index"] == pytest.approx(ranges[r["factor"]], rel=0.05)
    assert (tmp_path / "o" / "indices.csv").exists() and (tmp_path / "o" / "indices.png").exists()


@pytest.mark.skipif("fork" not in __import__("multiprocessing").get_all_start_methods(),
                    reason="the stand-in evaluation reaches the workers through fork")
def test_only_the_point_that_kills_its_worker_is_recorded_as_dead(tmp_path, monkeypatch):
    """A point whose worker dies every time breaks two pools; the remaining points then run one
    per pool, so the others finish and only the culprit is recorded as 'worker died'."""
    import os

    import rvflex.sweeps.executors as sw  # where the sweep looks both up

    def stand_in(args):  # a cheap evaluation; the +2 µm eccentricity point kills its process
        point = args[5]
        if point["eccentricity"] == 2e-6:
            os._exit(3)
        return {"te_pp_arcsec": 1e6 * sum(point.values())}

    monkeypatch.setattr(sw, "evaluate_point", stand_in)
    monkeypatch.setattr(sw, "warm_process", lambda reducer, scenario, options=None: reducer)
    res = sweep(load_design(SMOKE), tmp_path / "k.sqlite", executor="process", workers=2)
    assert [r["point"] for r in res.rows if r.get("error") == "worker died"] == [1]
    assert res.finished == 5 and res.failed == 1


# --------------------------------------------------------------------------- model options of a design

SMOKE_FLEXIBLE = SMOKE.with_name("smoke_flexible.toml")


def test_design_model_table_maps_to_model_options(tmp_path):
    """``[model]`` becomes the design's ModelOptions: the preset of ``fidelity`` with the
    ``[model.discs]`` fields overridden; no table is rigid, and a rigid design keeps the digest it
    had before designs carried options (its stores resume)."""
    from rvflex.options import ModelOptions

    assert load_design(SMOKE).options == ModelOptions.rigid()
    assert load_design(SMOKE).digest == "50a0ec0d575e8eed"  # the digest of smoke.toml before [model] existed
    assert load_design(SMOKE_FLEXIBLE).options == ModelOptions.flexible_discs()
    p = tmp_path / "d.toml"
    p.write_text(SMOKE.read_text() + '\n[model]\nfidelity = "rigid"\n')
    assert load_design(p).digest == load_design(SMOKE).digest
    p.write_text(SMOKE.read_text() + '\n[model]\nfidelity = "flexible-carrier"\ncarrier_seat_marker = "all_nodes"\n'
                                     '[model.discs]\nn_modes = 24\nmaxh_m = 8e-3\n[model.carrier]\nseat_coupling = "rbe2"\n')
    d = load_design(p)
    want = ModelOptions.flexible_discs_and_carrier().with_fe("discs", n_modes=24, maxh_m=8e-3).with_fe(
        "carrier", seat_coupling="rbe2")
    assert d.options == dataclasses.replace(want, carrier_seat_marker="all_nodes")
    assert d.digest != load_design(SMOKE).digest  # another model: another store


@pytest.mark.parametrize("model, message", [
    ('fidelity = "flex"', r"\[model\]\.fidelity = 'flex': must be one of 'rigid', 'flexible', 'flexible-carrier'"),
    ("fidelity = 1", r"\[model\]\.fidelity = 1: must be one of"),
    ('fidelty = "flexible"', r"\[model\]\.fidelty = 'flexible': unknown key; valid: fidelity, discs, carrier"),
    ('fidelity = "rigid"\n[model.discs]\nn_modes = 24', r"\[model\]\.discs = .*rigid with fidelity = 'rigid'"),
    ('fidelity = "flexible"\n[model.discs]\nmodes = 24', r"\[model\]\.discs\.modes = 24: unknown key; valid: maxh_m"),
    ('fidelity = "flexible"\n[model.discs]\nn_modes = 2.5', r"\[model\]\.discs\.n_modes = 2\.5: must be an integer"),
    ('fidelity = "flexible"\n[model.discs]\nmaxh_m = 6', r"\[model\]\.discs\.maxh_m = 6: expected metres"),
    ('fidelity = "flexible"\n[model.carrier]\nn_modes = 4', r"\[model\]\.carrier = .*the carrier is rigid"),
    ('fidelity = "flexible-carrier"\n[model.carrier]\nseat_coupling = "rbe4"',
     r"\[model\]\.carrier\.seat_coupling = 'rbe4': must be one of 'rbe3', 'rbe2'"),
    ('carrier_seat_marker = "some"', r"\[model\]\.carrier_seat_marker = 'some': must be one of 'virtual', 'all_nodes'"),
])
def test_design_with_invalid_model_options_is_refused_naming_the_key(tmp_path, model, message):
    p = tmp_path / "d.toml"
    p.write_text(SMOKE.read_text() + f"\n[model]\n{model}\n")
    with pytest.raises(SpecError, match=message) as err:
        load_design(p)
    assert str(p) in str(err.value)  # the file is named too


@pytest.mark.parametrize("old, new, message", [
    ('scenario = "te"', 'scenario = "te"\nfidelity = "flexible"',
     r"\[sweep\]\.fidelity = 'flexible': unknown key \(model options go in the \[model\] table\)"),
    ('kind = "single-factor"', 'kind = "single_factor"', r"\[sweep\]\.kind = 'single_factor': must be one of"),
    ('kind = "single-factor"', 'kind = "monte-carlo"\ndistribution = "gaussian"\nsamples = 2',
     r"\[sweep\]\.distribution = 'gaussian': must be one of 'uniform', 'normal'"),
    ("[sweep]", "[modle]\nfidelity = 'flexible'\n\n[sweep]", r"\[modle\] = .*unknown table; valid: \[sweep\]"),
])
def test_design_sweep_table_choices_are_checked(tmp_path, old, new, message):
    p = tmp_path / "d.toml"
    p.write_text(SMOKE.read_text().replace(old, new, 1))
    with pytest.raises(SpecError, match=message):
        load_design(p)


def test_every_point_runs_with_the_design_options(tmp_path, monkeypatch):
    """The design's ModelOptions reach the scenario of every point, under either executor
    (a stand-in scenario records what it gets)."""
    from rvflex.sweeps import SweepScenario, registry

    p = tmp_path / "d.toml"
    p.write_text(SMOKE.read_text().replace('scenario = "te"', 'scenario = "record-options"')
                 + '\n[model]\nfidelity = "flexible"\n[model.discs]\nn_modes = 7\n')
    monkeypatch.setitem(registry._REGISTRY, "record-options",
                        SweepScenario("record-options", _record_options, "n_modes", "1", _no_warm))
    design = load_design(p)
    for executor in ("serial", "process"):
        res = sweep(design, tmp_path / f"{executor}.sqlite", executor=executor, workers=2)
        assert res.failed == 0 and len(res.rows) == 6
        assert {r["n_modes"] for r in res.rows} == {7.0}
        assert {r["flexible_carrier"] for r in res.rows} == {0.0}


def _record_options(spec, errors, load_Nm, positions_per_rev, revolutions, options):
    return {"n_modes": float(options.discs.n_modes), "flexible_carrier": float(options.flexible_carrier_on)}


def _no_warm():
    pass


@pytest.mark.flexible
def test_flexible_design_point_equals_the_flexible_scenario_run(tmp_path, coarse_disc):
    """A sweep point of a flexible design (coarse disc: 8 mm linear tets, 12 modes) gives the TE
    of the same LoadedTE run directly with the same options, and not the rigid model's."""
    import rvflex
    from rvflex.options import ModelOptions
    from rvflex.sweeps import FACTORS

    spec, _ = coarse_disc  # the coarse disc is in the session's FE cache
    p = tmp_path / "d.toml"
    p.write_text(SMOKE_FLEXIBLE.read_text().replace("levels = [-1e-6, 1e-6]", "levels = [1e-6]")
                 .replace("positions_per_rev = 64", "positions_per_rev = 32").replace("revolutions = 0.25", "revolutions = 0.125")
                 + "\n[model.discs]\nmaxh_m = 8e-3\nmesh_order = 1\n")
    design = load_design(p)
    options = ModelOptions.flexible_discs().with_fe("discs", maxh_m=8e-3, mesh_order=1)
    assert design.options == options
    res = sweep(design, tmp_path / "f.sqlite", executor="serial")
    assert res.failed == 0
    variant, errors = FACTORS["pin_radius"][2](spec, rvflex.ErrorSpec(), 1e-6)
    runs = {name: rvflex.run(rvflex.LoadedTE(variant, errors, 412.0, 0.125, 32, options=o)).metrics
            for name, o in (("flexible", options), ("rigid", ModelOptions.rigid()))}
    assert res.rows[0]["te_pp_arcsec"] == pytest.approx(runs["flexible"].te_pp_arcsec, rel=1e-9, abs=1e-9)
    assert res.rows[0]["mean_windup_arcsec"] == pytest.approx(runs["flexible"].mean_windup_arcsec, rel=1e-9)
    assert abs(runs["flexible"].mean_windup_arcsec - runs["rigid"].mean_windup_arcsec) > 0.1  # the discs' compliance


@pytest.mark.parametrize("python, message", [
    (dict(factors=(("eccentricity", (1e-6,)),)), r"^factors\[0\] = \('eccentricity', \(1e-06,\)\): must be an rvflex.Factor"),
    (dict(factors=()), r"^factors = \(\): a design needs a non-empty tuple of Factor"),
    (dict(kind="L9"), r"^factors\[0\]\.levels = \(-2e-06, 2e-06\): L9 needs 3 levels"),
    (dict(load_Nm="412"), r"^load_Nm = '412': must be a non-negative number"),
    (dict(positions_per_rev=64.0), r"^positions_per_rev = 64.0: must be an integer ≥ 4"),
    (dict(revolutions=0), r"^revolutions = 0: must be a positive number"),
    (dict(kind="morris", samples=4), r"^factors\[0\] = \(nan, nan\): eccentricity: morris needs low < high"),
])
def test_design_errors_from_python_name_the_parameter(python, message):
    """A Design made in Python is refused naming its parameter (no TOML key, no file)."""
    from rvflex.sweeps import Design, Factor

    kwargs = dict(name="d", reducer="rv40e", scenario="te", kind="single-factor", load_Nm=412.0,
                  factors=(Factor("eccentricity", (-2e-6, 2e-6)),)) | python
    with pytest.raises(SpecError, match=message):
        Design(**kwargs)


def test_factor_errors_from_python_name_the_parameter():
    from rvflex.sweeps import Factor

    with pytest.raises(SpecError, match=r"^name = 'eccentricty': unknown factor; .*did you mean 'eccentricity'\?$"):
        Factor("eccentricty", (1e-6,))
    with pytest.raises(SpecError, match=r"^levels\[1\] = 2.0: expected a deviation in metres, at most ±1 mm"):
        Factor("eccentricity", (1e-6, 2.0))
    with pytest.raises(SpecError, match=r"^levels\[0\] = '1e-6': must be a number"):
        Factor("eccentricity", ("1e-6",))
    with pytest.raises(SpecError, match=r"^low = -1e-06: a clearance cannot be negative"):
        Factor("eccentric_bearing_clearance", low=-1e-6, high=1e-6)
    with pytest.raises(SpecError, match=r"^sigma = -1e-06: must be positive"):
        Factor("eccentricity", sigma=-1e-6)


@pytest.mark.parametrize("old, new, message", [
    ("levels = [-2e-6, 2e-6]", 'levels = [-2e-6, "2e-6"]', r"factor\[0\]\.levels\[1\] = '2e-6': must be a number"),
    ("levels = [-2e-6, 2e-6]", "levels = [-2e-6, 2]", r"factor\[0\]\.levels\[1\] = 2.0: expected a deviation in metres"),
    ("levels = [-2e-6, 2e-6]", "levels = -2e-6", r"factor\[0\]\.levels = -2e-06: must be an array"),
    ("levels = [-2e-6, 2e-6]", "level = [-2e-6, 2e-6]", r"factor\[0\]\.level = .*unknown key; .*did you mean 'levels'"),
    ('kind = "single-factor"', 'kind = "L9"', r"factor\[0\]\.levels = \(-2e-06, 2e-06\): L9 needs 3 levels"),
    ("load_Nm = 412.0", 'load_Nm = "412"', r"\[sweep\]\.load_Nm = '412': must be a non-negative number"),
    ("positions_per_rev = 64", "positions_per_rev = 64.5", r"\[sweep\]\.positions_per_rev = 64.5: must be an integer"),
    ("revolutions = 0.25", "revolutions = -1.0", r"\[sweep\]\.revolutions = -1.0: must be a positive number"),
    ('name = "smoke"', "name = 3", r"\[sweep\]\.name = 3: must be a non-empty string"),
])
def test_design_errors_from_a_file_name_the_file_and_the_toml_key(tmp_path, old, new, message):
    """The same rules read from a design file name the file and the TOML key instead."""
    p = tmp_path / "d.toml"
    text = SMOKE.read_text()
    assert old in text
    p.write_text(text.replace(old, new, 1))
    with pytest.raises(SpecError, match=message) as err:
        load_design(p)
    assert str(err.value).startswith(f"{p}: ")


def test_a_design_file_with_integer_levels_has_the_digest_of_float_levels(tmp_path):
    """TOML integers are read as floats: ``levels = [0, 1e-6]`` is the design ``[0.0, 1e-6]`` (the
    same store)."""
    a, b = tmp_path / "a.toml", tmp_path / "b.toml"
    text = SMOKE.read_text()
    a.write_text(text.replace("levels = [-1e-6, 1e-6]", "levels = [0, 1e-6]"))
    b.write_text(text.replace("levels = [-1e-6, 1e-6]", "levels = [0.0, 1e-6]"))
    assert load_design(a).digest == load_design(b).digest

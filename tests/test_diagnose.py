"""Sim-to-real gap diagnosis: every bad-input rule of the bench format, the withheld split,
the effect registry, and a 2-case blind self-check at coarse settings."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from rvflex import catalog
from rvflex.diagnosis.bench import (
    MIN_SAMPLES_PER_REV,
    BenchDataset,
    BenchError,
    BenchRun,
    read_bench,
    write_bench,
)
from rvflex.diagnosis.effects import EFFECTS, Effect, Param, available_effects
from rvflex.diagnosis.features import branch_angles, shift_measured
from rvflex.diagnosis.fit import withheld_folds, withheld_split
from rvflex.diagnosis.plan import BRANCH_FRACTIONS, PlanRun, feature_layout
from rvflex.diagnosis.settings import DiagnosisSettings
from rvflex.fe.reduce import PartSettings
from rvflex.options import ModelOptions
from rvflex.spec import ErrorSpec

SPEC = catalog.load("rv40e")
RATIO = SPEC.nominal_ratio


def _te_run(n: int = 600, direction: str = "forward", load: float = 412.0, file: str = "te.csv") -> BenchRun:
    t = np.linspace(0.0, 4.1, n)
    sign = 1.0 if direction == "forward" else -1.0
    p = sign * 2 * np.pi * 1.02 * t / 4.1
    return BenchRun(file, "te", t, RATIO * p, p + 1e-5 * np.sin(3 * p), np.full(n, load), direction=direction,
                    load_Nm=load, speed_out_rpm=15.0)


def _hyst_run(n: int = 120) -> BenchRun:
    s = np.linspace(0, 1, n)
    torque = 412.0 * np.interp(s, [0, 0.25, 0.75, 1.0], [0, 1, -1, 0])
    return BenchRun("hyst.csv", "hysteresis", s * 10, np.empty(0), torque * 1e-6, torque, torque_max_Nm=412.0)


@pytest.fixture()
def good(tmp_path) -> Path:
    folder = tmp_path / "bench"
    write_bench(folder, BenchDataset(SPEC, "rv40e", (_te_run(), _te_run(direction="reverse", file="rev.csv"),
                                                     _hyst_run())))
    return folder


def test_writer_reader_round_trip(good):
    ds = read_bench(good)
    assert [r.kind for r in ds.runs] == ["te", "te", "hysteresis"]
    assert ds.runs[1].direction == "reverse" and ds.runs[0].load_Nm == 412.0
    # 17 significant digits: the angles survive exactly
    np.testing.assert_array_equal(ds.runs[0].theta_in_rad, _te_run().theta_in_rad)
    assert not list(good.glob(".*.tmp"))  # no temporary file left behind


def _edit(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))


def _rows(path: Path) -> list[str]:
    return path.read_text().splitlines()


@pytest.mark.parametrize("case, where, problem", [
    ("no_toml", "bench.toml", "file not found"),
    ("no_csv", "te.csv", "file not found"),
    ("missing_column", "te.csv, header", "missing column 'theta_out_rad'"),
    ("misspelled_column", "te.csv, header", "found 'theta_outt_rad': misspelled?"),
    ("non_numeric", "te.csv, row 5, column 'theta_in_rad'", "not a number: 'abc'"),
    ("nan", "te.csv, row 7, column 'theta_out_rad'", "must be finite"),
    ("inf", "hyst.csv, row 3, column 'torque_Nm'", "must be finite"),
    ("time_backwards", "te.csv, row 10, column 'time_s'", "time must increase strictly"),
    ("too_few_samples", "te.csv", "at least one whole output revolution"),
    ("unknown_reducer", "bench.toml, key 'reducer.catalog'", "not in the catalogue"),
    ("missing_key", "bench.toml, run 1 (te.csv)", "missing required key 'load_Nm'"),
    ("misspelled_key", "bench.toml, run 1 (te.csv)", "found 'load_nm': misspelled?"),
    ("bad_direction", "bench.toml, run 1 (te.csv), key 'direction'", "must be 'forward' or 'reverse'"),
    ("load_beyond_max", "bench.toml, run 1 (te.csv), key 'load_Nm'", "momentary maximum"),
    ("cycle_beyond_max", "bench.toml, run 3 (hyst.csv), key 'torque_max_Nm'", "momentary maximum"),
    ("short_cycle", "hyst.csv", "reaching ±torque_max_Nm"),
    ("wrong_way", "rev.csv, column 'theta_in_rad'", "does not turn reverse"),
    ("spike", "te.csv, row 40, column 'theta_out_rad'", "an outlier"),
])
def test_bad_input_names_file_row_or_key(good, case, where, problem):
    toml, te, hy = good / "bench.toml", good / "te.csv", good / "hyst.csv"
    if case == "no_toml":
        toml.unlink()
    elif case == "no_csv":
        te.unlink()
    elif case in ("missing_column", "misspelled_column"):
        rows = _rows(te)
        rows[0] = rows[0].replace("theta_out_rad", "theta_outt_rad" if case == "misspelled_column" else "angle")
        te.write_text("\n".join(rows) + "\n")
    elif case in ("non_numeric", "nan", "time_backwards", "spike"):
        rows = _rows(te)
        line = {"non_numeric": 5, "nan": 7, "time_backwards": 10, "spike": 40}[case]
        cells = rows[line - 1].split(",")
        if case == "spike":  # one sample 0.5° off its neighbours
            cells[2] = repr(float(cells[2]) + math.radians(0.5))
        elif case == "non_numeric":
            cells[1] = "abc"
        elif case == "nan":
            cells[2] = "nan"
        else:
            cells[0] = "0.0"
        rows[line - 1] = ",".join(cells)
        te.write_text("\n".join(rows) + "\n")
    elif case == "inf":
        rows = _rows(hy)
        cells = rows[2].split(",")
        cells[1] = "inf"
        rows[2] = ",".join(cells)
        hy.write_text("\n".join(rows) + "\n")
    elif case == "too_few_samples":
        write_bench(good, BenchDataset(SPEC, "rv40e", (_te_run(n=MIN_SAMPLES_PER_REV - 10),)))
    elif case == "unknown_reducer":
        _edit(toml, 'catalog = "rv40e"', 'catalog = "rv999x"')
    elif case == "missing_key":
        _edit(toml, "load_Nm = 412.0\n", "")
    elif case == "misspelled_key":
        _edit(toml, "load_Nm = 412.0\n", "load_nm = 412.0\n")
    elif case == "bad_direction":
        _edit(toml, 'direction = "forward"', 'direction = "forwards"')
    elif case == "load_beyond_max":
        _edit(toml, "load_Nm = 412.0\n", "load_Nm = 5000.0\n")
    elif case == "cycle_beyond_max":
        _edit(toml, "torque_max_Nm = 412.0", "torque_max_Nm = 9000.0")
    elif case == "short_cycle":
        _edit(toml, "torque_max_Nm = 412.0", "torque_max_Nm = 800.0")
    elif case == "wrong_way":
        write_bench(good, BenchDataset(SPEC, "rv40e", (_te_run(), _te_run(file="rev.csv"), _hyst_run())))
        _edit(toml, 'file = "rev.csv"\nkind = "te"\ndirection = "forward"', 'file = "rev.csv"\nkind = "te"\ndirection = "reverse"')
    with pytest.raises(BenchError) as info:
        read_bench(good)
    assert info.value.where.endswith(where) or where in info.value.where
    assert problem in info.value.problem


def test_cli_refuses_bad_input_and_writes_nothing(good, tmp_path, capsys):
    from rvflex.cli import main

    (good / "te.csv").unlink()
    out = tmp_path / "report"
    code = main(["diagnose", str(good), "--out", str(out), "--json", str(tmp_path / "d.json")])
    assert code == 2
    assert "te.csv" in capsys.readouterr().err
    assert not out.exists() and not (tmp_path / "d.json").exists()


def test_withheld_split_and_no_withheld_run():
    plan = (PlanRun("te", "a", 1, 412.0), PlanRun("te", "b", -1, 412.0), PlanRun("te", "c", 1, 103.0),
            PlanRun("hysteresis", "h", torque_max_Nm=412.0))
    assert withheld_split(plan) == ((0, 3), (1, 2))
    assert withheld_split(plan[:1] + plan[3:]) == ((0, 1), ())  # nothing left to predict
    # nothing predicted twice: the other TE runs from the forward TE run at the highest load and the torque
    # cycle, then each half of the torque cycle from the TE runs and the other half (run, side)
    te = ((0, 0), (1, 0), (2, 0))
    assert withheld_folds(plan) == ((((0, 0), (3, 0)), ((1, 0), (2, 0))),
                                    (te + ((3, 1),), ((3, -1),)), (te + ((3, -1),), ((3, 1),)))
    assert withheld_folds(plan[:1] + plan[3:]) == ((((0, 0), (1, 1)), ((1, -1),)), (((0, 0), (1, -1)), ((1, 1),)))
    assert withheld_folds(plan[3:]) == ((((0, 1),), ((0, -1),)), (((0, -1),), ((0, 1),)))  # a cycle checks itself
    assert withheld_folds(plan[:1]) == ()
    # the halves: both branches at the torques of one sign, together the whole cycle
    lay = feature_layout(plan, 5)
    pos, neg = lay.part_rows((3, 1)), lay.part_rows((3, -1))
    assert sorted(np.r_[pos, neg]) == sorted(lay.run_rows(3)) and len(pos) == len(neg) == len(BRANCH_FRACTIONS)
    torque = np.tile(BRANCH_FRACTIONS, 2)  # the branch_angles order: descending, then ascending branch
    assert np.all(torque[pos - lay.hyst[3].start] > 0) and np.all(torque[neg - lay.hyst[3].start] < 0)


def test_friction_acts_on_the_torque_cycle_through_a_coulomb_play():
    """T_f = 2 % of 412 N·m: stuck until the applied torque first exceeds T_f, then T − T_f while
    it rises, held for 2·T_f after the reversal, then T + T_f."""
    fr = EFFECTS["pin_contact_friction"]
    path = (0.0, 4.0, 8.24, 20.0, 412.0, 406.0, 400.0, 0.0, -412.0)
    run = fr.conditions(PlanRun("hysteresis", "h", torque_max_Nm=412.0, torque_path_Nm=path), np.array([0.02]), SPEC)
    tf = 8.24
    np.testing.assert_allclose(run.torque_eff_Nm, (0.0, 0.0, 0.0, 20.0 - tf, 412.0 - tf, 412.0 - tf, 412.0 - tf,
                                                   0.0 + tf, -412.0 + tf), rtol=0, atol=1e-12)
    te = fr.conditions(PlanRun("te", "a", 1, 412.0), np.array([0.02]), SPEC)
    assert te.load_Nm == pytest.approx(412.0 + tf)


def test_origin_shift_is_exact_for_a_pure_harmonic():
    """Shifting the measured features by δ must equal sampling the pattern at p + δ."""
    from rvflex.diagnosis.plan import feature_layout

    plan = (PlanRun("te", "a", 1, 412.0),)
    lay = feature_layout(plan, 10)
    f = np.zeros(lay.n)
    f[lay.cos[0].start + 2] = 1.0  # cos 3p
    d = 0.3
    g = shift_measured(f, lay, d)[:, 0]
    # cos 3(p + δ) = cos 3δ cos 3p − sin 3δ sin 3p
    assert g[lay.cos[0].start + 2] == pytest.approx(math.cos(3 * d))
    assert g[lay.sin[0].start + 2] == pytest.approx(-math.sin(3 * d))


def test_branch_angles_of_a_linear_loop():
    """A linear spring with a Coulomb band: both branches sampled at the same torques; the
    descending branch lies above the ascending one by the band width everywhere."""
    s = np.linspace(0, 1, 401)
    torque = 100.0 * np.interp(s, [0, 0.25, 0.75, 1.0], [0, 1, -1, 0])
    direction = np.sign(np.gradient(torque))
    theta = torque / 1e4 - 1e-4 * direction
    a = branch_angles(torque, theta, 100.0)
    half = len(a) // 2
    np.testing.assert_allclose(a[:half] - a[half:], 2e-4, rtol=0, atol=1e-9)


def test_effect_library_covers_the_issue_and_registers_new_effects():
    need = {"eccentric_bearing_clearance", "main_bearing_clearance", "pin_ring_runout", "pin_position_h2",
            "crank_eccentricity_error", "crank_phase_error", "disc_modification_deviation",
            "cycloid_pitch_error", "carrier_hole_position", "disc_carrier_flexibility", "pin_contact_friction",
            "thermal_expansion", "output_encoder_eccentricity", "input_stage_runout"}
    assert need <= set(EFFECTS)
    for e in EFFECTS.values():
        assert all(p.low <= 0.0 <= p.high and p.step > 0 for p in e.params)
    flex = EFFECTS["disc_carrier_flexibility"]
    from rvflex.model import FIDELITIES

    assert flex.available()[0] == ("flexible" in FIDELITIES)
    extra = Effect("test_only", "a registered test effect", (Param("x_m", "m", -1e-6, 1e-6, 5e-7),),
                   apply=lambda s, e, x: (s, e))
    from rvflex.diagnosis.effects import register

    register(extra)
    try:
        assert "test_only" in [e.name for e in available_effects()[0]]
        with pytest.raises(ValueError):
            register(extra)
    finally:
        EFFECTS.pop("test_only")


def test_a_pin_radius_error_is_the_equidistant_deviation_reversed():
    """The pin–profile gap depends only on generating pin radius − pin radius: a +4 µm pin radius
    error and a −4 µm equidistant deviation give the same TE at two loads and the same torque
    cycle (to 1e-3″, the solver's settling) while each moves them by ~18″ — so the library has one
    effect for both, and the deviation's description says so."""
    from rvflex.diagnosis.replay import evaluate
    from rvflex.units import ARCSEC_PER_RAD as arcsec

    path = tuple(412.0 * np.interp(np.linspace(0, 1, 25), [0, 0.25, 0.75, 1], [0, 1, -1, 0]))
    plan = (PlanRun("te", "a", 1, 412.0), PlanRun("te", "b", 1, 103.0),
            PlanRun("hysteresis", "h", torque_max_Nm=412.0, torque_path_Nm=path))
    s = DiagnosisSettings(hysteresis_steps=24)
    base = evaluate(SPEC, ErrorSpec(), plan, s)
    pin = evaluate(SPEC, ErrorSpec(pin_radius_error_m=4e-6), plan, s)
    dev = evaluate(SPEC, ErrorSpec(), plan, s, ((EFFECTS["disc_modification_deviation"], np.array([0.0, -4e-6])),))
    for k in range(2):
        assert np.ptp(np.asarray(pin.te[k]) - base.te[k]) * arcsec > 0.05  # the pin error changes the TE ripple
        assert np.abs(np.mean(pin.te[k]) - np.mean(base.te[k])) * arcsec > 10.0  # and its wind-up
        np.testing.assert_allclose(np.asarray(pin.te[k]) * arcsec, np.asarray(dev.te[k]) * arcsec, atol=1e-3)
    np.testing.assert_allclose(np.asarray(pin.theta[2]) * arcsec, np.asarray(dev.theta[2]) * arcsec, atol=1e-3)
    assert "pin_radius_error" not in EFFECTS and "pin radius error" in EFFECTS["disc_modification_deviation"].description


def test_temperature_round_trip_and_run_labels(tmp_path):
    run = dataclasses.replace(_te_run(), temperature_C=40.0)
    write_bench(tmp_path / "b", BenchDataset(SPEC, "rv40e", (run, _hyst_run())))
    ds = read_bench(tmp_path / "b")
    assert ds.runs[0].temperature_C == 40.0 and math.isnan(ds.runs[1].temperature_C)
    assert ds.runs[0].label == "te forward 412 N·m at 40 °C" and ds.runs[1].label == "hysteresis ±412 N·m"


def test_thermal_expansion_follows_each_runs_temperature():
    """Δα·r_b·(T − 20 °C) per run: zero at the reference temperature, 15.18 µm for an aluminium
    housing (11.5e-6/K) at 40 °C on the 66 mm pin circle, shrinking below 20 °C."""
    from rvflex.diagnosis.effects import REFERENCE_TEMPERATURE_C
    from rvflex.spec import ErrorSpec

    th = EFFECTS["thermal_expansion"]
    assert th.per_run and REFERENCE_TEMPERATURE_C == 20.0
    for temp, growth in ((20.0, 0.0), (40.0, 15.18e-6), (0.0, -15.18e-6)):
        run = PlanRun("te", "a", 1, 412.0, temperature_C=temp)
        spec, err = th.apply_to(SPEC, ErrorSpec(), np.array([11.5e-6]), run)
        assert spec is SPEC
        assert err.pin_circle_radius_error_m == pytest.approx(growth, abs=1e-12)


def test_thermal_expansion_needs_every_runs_temperature():
    """Without a recorded temperature the thermal effect cannot act: it is listed as unavailable
    (naming the key and the run), and a model evaluation with it is refused before any run."""
    from rvflex.diagnosis.fit import available_candidates
    from rvflex.diagnosis.replay import EvaluationFailed, evaluate
    from rvflex.spec import ErrorSpec

    plan = (PlanRun("te", "te forward 412 N·m at 40 °C", 1, 412.0, temperature_C=40.0),
            PlanRun("hysteresis", "hysteresis ±412 N·m", torque_max_Nm=412.0))
    cands, why = available_candidates(("thermal_expansion", "pin_ring_runout"), plan)
    assert [e.name for e in cands] == ["pin_ring_runout"]
    assert "temperature_C" in why["thermal_expansion"] and "hysteresis ±412 N·m" in why["thermal_expansion"]
    with pytest.raises(EvaluationFailed, match="temperature_C"):
        evaluate(SPEC, ErrorSpec(), plan, DiagnosisSettings(), ((EFFECTS["thermal_expansion"], np.array([1e-5])),))
    cands, why = available_candidates(("thermal_expansion",), plan[:1])
    assert [e.name for e in cands] == ["thermal_expansion"] and not why


def test_two_sided_sensitivities_fit_each_sign_with_its_own_secant():
    from rvflex.diagnosis.linear import Sensitivities

    th, pr = EFFECTS["thermal_expansion"], EFFECTS["carrier_hole_position"]
    plus, minus = np.array([[1.0], [2.0]]), np.array([[3.0], [4.0]])
    sens = Sensitivities({th.name: plus, pr.name: np.array([[5.0], [6.0]])}, {th.name: minus})
    (j1, lo1, hi1), (j2, lo2, hi2) = sens.orthants((th,))
    np.testing.assert_array_equal(j1, plus)
    np.testing.assert_array_equal(j2, minus)
    assert (lo1[0], hi1[0]) == (0.0, th.params[0].high) and (lo2[0], hi2[0]) == (th.params[0].low, 0.0)
    pair = sens.orthants((pr, th))
    assert len(pair) == 2 and all(j.shape == (2, 2) for j, _, _ in pair)
    assert all(lo[0] == pr.params[0].low and hi[0] == pr.params[0].high for _, lo, hi in pair)
    assert len(sens.orthants((pr,))) == 1


def test_on_the_cancelling_diagonal_the_modification_deviation_is_fitted_through_its_corner():
    """Moved and equidistant deviations of the same sign nearly cancel: at (−4, −4) µm the TE ripple changes
    by about 1″ where the sum of the two axes' changes says about 4.5″ (measured), so a fit from the axes'
    secants mis-states every deviation along that diagonal. The model is also run at the four corners
    (±step, ±step), and the fits may use secants through a corner (each column in turn replaced so that
    J·h is the corner's change); the axes' sign patterns stay as they were."""
    from rvflex.diagnosis.linear import Sensitivities
    from rvflex.diagnosis.replay import evaluate
    from rvflex.diagnosis.sensitivity import sensitivity_runs
    from rvflex.units import ARCSEC_PER_RAD as arcsec

    e = EFFECTS["disc_modification_deviation"]
    assert e.corners and len(sensitivity_runs((e,))) == 2 * 2 + 4  # each parameter at ±step, and the corners
    plan = (PlanRun("te", "a", 1, 412.0), PlanRun("te", "b", 1, 103.0))
    s = DiagnosisSettings()

    def ripple(x):  # the TE of both runs less their means (the wind-up is the clearance's, shared with others)
        r = evaluate(SPEC, ErrorSpec(), plan, s, ((e, np.asarray(x)),) if x is not None else ())
        return np.concatenate([(np.asarray(t) - np.mean(t)) * arcsec for t in r.te])

    h = -4e-6
    f0, fm, fe, fc = ripple(None), ripple([h, 0.0]), ripple([0.0, h]), ripple([h, h])
    corner, axes = np.linalg.norm(fc - f0), np.linalg.norm(fm + fe - 2 * f0)
    assert corner < 0.4 * axes and np.linalg.norm(fc - fm - fe + f0) > 2.0  # arcsec
    minus = np.column_stack([(f0 - fm) / -h, (f0 - fe) / -h])  # the −step secants
    sens = Sensitivities({e.name: minus}, {e.name: minus}, corners={e.name: {(-1.0, -1.0): (np.array([h, h]), fc - f0)}})
    axes_only = sens.orthants((e,))
    assert len(axes_only) == 4
    through = sens.orthants((e,), corners=True)
    assert len(through) == 2  # the one measured corner, each column in turn
    for J, lo, hi in through:
        np.testing.assert_allclose(J @ np.array([h, h]), fc - f0, atol=1e-9)
        assert np.all(hi == 0.0) and np.all(lo < 0.0)  # the corner's sign pattern
    J_axes = next(J for J, lo, hi in axes_only if np.all(hi == 0.0))
    assert np.linalg.norm(J_axes @ np.array([h, h]) - (fc - f0)) > 2.0


def test_the_fidelity_differences_are_measured_again_about_candidates_alike_at_every_pin():
    """A candidate whose model errors change every contact the same way (a profile deviation, the pin circle's
    thermal growth, a clearance) has the contact-law and elastic-disc differences measured again about its own
    point; one whose errors differ from pin to pin (a pin pattern, a runout) keeps the calibration's (its elastic
    runs take the whole revolution). Decided by the replay's own test of a model that repeats every pin pitch."""
    from types import SimpleNamespace

    from rvflex.diagnosis.runs import ModelRunner
    from rvflex.diagnosis.stages.candidates import _alike_at_every_pin

    plan = (PlanRun("te", "a", 1, 412.0, temperature_C=40.0),)
    runner = ModelRunner(SPEC, ErrorSpec(), plan, DiagnosisSettings(), None, None)

    def alike(name, x):
        e = EFFECTS[name]
        return _alike_at_every_pin(runner, SimpleNamespace(effects=(e,), x=np.asarray(x, float)))

    assert alike("thermal_expansion", [11.5e-6]) and alike("disc_modification_deviation", [-4e-6, -4e-6])
    assert alike("eccentric_bearing_clearance", [5e-6]) and alike("pin_contact_friction", [0.01])
    assert not alike("pin_position_h3", [2e-6, 1e-6]) and not alike("pin_ring_runout", [3e-6, 0.0])


def test_side_by_side_diagnoses_store_the_same_model_run_at_once(tmp_path):
    """The self-check diagnoses its cases side by side in forked workers that share one run cache, and two of
    them may store the same model run at the same moment (the same value object, inherited through the fork):
    each store writes its own temporary file, so neither's rename finds its file gone (it did once in a
    self-check: "No such file or directory: ….tmp"), and the entry is whole."""
    import multiprocessing as mp
    import pickle

    from rvflex.diagnosis.runs import ModelRunner

    plan = (PlanRun("te", "a", 1, 412.0, temperature_C=40.0),)
    runner = ModelRunner(SPEC, ErrorSpec(), plan, DiagnosisSettings(), None, tmp_path / "cache")
    value = (np.arange(20000.0), None, "")

    def store_many(_):
        for _ in range(300):
            runner._store("k" * 24, value)

    ctx = mp.get_context("fork")
    procs = [ctx.Process(target=store_many, args=(i,)) for i in range(3)]
    for p in procs:
        p.start()
    for p in procs:
        p.join()
    assert [p.exitcode for p in procs] == [0, 0, 0]
    entry = pickle.loads((tmp_path / "cache" / f"{'k' * 24}.pkl").read_bytes())
    assert np.array_equal(entry[0], value[0])
    assert not list((tmp_path / "cache").glob("*.tmp"))


def test_a_pin_friction_fit_and_an_output_friction_fit_without_load_part_are_one_model():
    """The pin friction's Coulomb torque is the output friction with its load-proportional part at zero: the
    same model run. A fit of the output friction whose load part sits at zero is restated as the pin friction
    (the same residual, one parameter fewer, so the evidence prefers it by log n), and a pin friction fit as the
    output friction at zero load part (with that part's secant); one with a load part is not restated down.
    Features written here: a torque-cycle signature per parameter, and a measured loop no wider at high load."""
    from rvflex.diagnosis.discrepancy import Discrepancy, evidence, feature_groups
    from rvflex.diagnosis.fit import restated
    from rvflex.diagnosis.linear import Problem, Sensitivities, bounds, lin_fit, make_candidate, nuisance_columns
    from rvflex.diagnosis.plan import feature_layout

    pin, out = EFFECTS["pin_contact_friction"], EFFECTS["output_friction"]
    assert pin.same_as == (out.name, (0, None))
    plan = (PlanRun("hysteresis", "cycle", torque_max_Nm=412.0, torque_path_Nm=(0.0, 412.0, 0.0, -412.0, 0.0)),)
    lay = feature_layout(plan, 127)
    rng = np.random.default_rng(3)
    u = np.sign(np.arange(lay.n) - lay.n / 2) * 50.0  # arcsec per unit Coulomb fraction: the loop's width
    v = np.linspace(-1.0, 1.0, lay.n) * 40.0  # per unit load share: a width growing with the torque
    sens = Sensitivities({out.name: np.column_stack([u, v]), pin.name: u[:, None]}, {})
    effects = {pin.name: pin, out.name: out}
    w = np.full(lay.n, 1.0 / 0.05)

    def fit(y, e):
        prob = Problem.build(y, lay, w, nuisance_columns(lay))
        n_nuis = prob.nuis.shape[1]
        J = sens.plus[e.name]
        x, nu, d, rss, A = lin_fit(prob, np.zeros(lay.n), J, np.zeros(e.n), *bounds((e,)))
        c = make_candidate((e,), x, nu, d, rss, A, lay.n, n_nuis, J @ x, refined=True, jacobian=J)
        x0, nu0, d0, rss0, A0 = lin_fit(prob, np.zeros(lay.n), np.zeros((lay.n, 0)), np.zeros(0), np.zeros(0), np.zeros(0))
        none = make_candidate((), x0, nu0, d0, rss0, A0, lay.n, n_nuis, np.zeros(lay.n), refined=True)
        disc = Discrepancy.of(prob, none, feature_groups(lay, plan, SPEC.cycloid.pin_count))
        return prob, n_nuis, c, lambda k: evidence(prob, k, none, disc)

    noise = rng.normal(0.0, 0.05, lay.n)
    prob, n_nuis, c, score = fit(0.013 * u - 0.002 * v + noise, out)
    assert c.x[1] == 0.0  # the load part at its bound
    (down,) = restated(prob, c, effects, sens, n_nuis)
    assert down.name == pin.name and down.k == c.k - 1 and down.refined
    np.testing.assert_allclose(down.x, c.x[:1])
    assert down.rss == pytest.approx(c.rss, rel=1e-12)
    assert score(down) - score(c) == pytest.approx(math.log(lay.n), rel=1e-9)

    prob, n_nuis, c, _ = fit(0.013 * u + 0.02 * v + noise, out)
    assert c.x[1] > 0.01 and restated(prob, c, effects, sens, n_nuis) == []  # a load part: not the pin friction

    prob, n_nuis, c, _ = fit(0.013 * u + noise, pin)
    (up,) = restated(prob, c, effects, sens, n_nuis)
    assert up.name == out.name and up.k == c.k + 1
    np.testing.assert_allclose(up.x, [c.x[0], 0.0])
    np.testing.assert_array_equal(up.jacobian[:, 1], v)
    assert up.rss == pytest.approx(c.rss, rel=1e-12)


def test_a_pair_restated_in_the_rankings_name_order_is_the_same_fit():
    """``stages.candidates._ordered``: a pair refined as (b, a) and ranked as "a + b" is given the ranking's order. Its
    parameters, intervals, Jacobian columns, magnitudes and bounds move together (the nominal parameters stay
    first), so it is the same fit: the same model features from its Jacobian, the same residual."""
    from rvflex.diagnosis.linear import Problem, bounds, lin_fit, make_candidate, nuisance_columns
    from rvflex.diagnosis.nominal import NOMINAL
    from rvflex.diagnosis.stages.candidates import _ordered

    cal, a, b = NOMINAL["contact_stiffness"], EFFECTS["thermal_expansion"], EFFECTS["pin_ring_runout"]
    assert (cal.n, a.n, b.n) == (1, 1, 2)
    plan = (PlanRun("te", "te", load_Nm=412.0),)
    lay = feature_layout(plan, 63)
    rng = np.random.default_rng(7)
    J = rng.normal(size=(lay.n, 4)) * np.r_[1.0, 1e6, 1e6, 1e5]  # columns: contact stiffness, runout cos/sin, thermal
    y = J @ np.array([0.1, 2e-6, -1e-6, 8e-6]) + rng.normal(0.0, 0.05, lay.n)
    prob = Problem.build(y, lay, np.full(lay.n, 20.0), nuisance_columns(lay))
    n_nuis = prob.nuis.shape[1]
    effects = (cal, b, a)
    lo, hi = bounds(effects)
    x, nu, d, rss, A = lin_fit(prob, np.zeros(lay.n), J, np.zeros(4), lo, hi)
    c = make_candidate(effects, x, nu, d, rss, A, lay.n, n_nuis, J @ x, refined=False, jacobian=J, box=(lo, hi),
                       base=(np.zeros(4), np.zeros(lay.n)))
    assert c.name == f"{b.name} + {a.name}"
    o = _ordered(c, {frozenset((a.name, b.name)): [a.name, b.name]})
    assert o.name == f"{a.name} + {b.name}" and [e.name for e in o.effects] == [cal.name, a.name, b.name]
    idx = [0, 3, 1, 2]
    np.testing.assert_array_equal(o.x, c.x[idx])
    np.testing.assert_array_equal(o.interval, c.interval[idx])
    np.testing.assert_array_equal(o.jacobian, c.jacobian[:, idx])
    np.testing.assert_array_equal(o.lower, c.lower[idx])
    np.testing.assert_array_equal(o.upper, c.upper[idx])
    np.testing.assert_allclose(o.jacobian @ o.x, c.jacobian @ c.x, rtol=1e-12, atol=1e-12)
    assert o.magnitude == (c.magnitude[0], c.magnitude[2], c.magnitude[1]) and o.rss == c.rss
    assert _ordered(o, {frozenset((a.name, b.name)): [a.name, b.name]}) is o  # already in order


def test_a_single_is_started_again_from_the_value_its_refined_pair_found():
    """``stages.candidates.from_pairs``: an effect of a refined pair whose value there lies outside the 95 % interval
    of its own best fit gets a start at the pair's values (the pair's nominal parameters and that effect's, the pair's
    Jacobian columns for them), linearised about the calibration so the refinement's first run is at the start; an
    effect the pair leaves within its own interval gets none."""
    from rvflex.diagnosis.linear import Problem, bounds, lin_fit, make_candidate, nuisance_columns
    from rvflex.diagnosis.nominal import NOMINAL
    from rvflex.diagnosis.stages.candidates import from_pairs

    cal, a, b = NOMINAL["contact_stiffness"], EFFECTS["thermal_expansion"], EFFECTS["pin_ring_runout"]
    plan = (PlanRun("te", "te", load_Nm=412.0, temperature_C=40.0),)
    lay = feature_layout(plan, 63)
    rng = np.random.default_rng(3)
    J = rng.normal(size=(lay.n, 4)) * np.r_[1.0, 1e5, 1e6, 1e6]  # columns: contact stiffness, thermal, runout cos/sin
    y = J @ np.array([0.1, 5e-6, 2e-6, -1e-6]) + rng.normal(0.0, 0.05, lay.n)
    prob = Problem.build(y, lay, np.full(lay.n, 20.0), nuisance_columns(lay))
    n_nuis = prob.nuis.shape[1]

    def fit(effects, cols):
        lo, hi = bounds(effects)
        x, nu, d, rss, A = lin_fit(prob, np.zeros(lay.n), J[:, cols], np.zeros(len(cols)), lo, hi)
        return make_candidate(effects, x, nu, d, rss, A, lay.n, n_nuis, J[:, cols] @ x, refined=True,
                              jacobian=J[:, cols])

    pair = fit((cal, a, b), [0, 1, 2, 3])
    np.testing.assert_allclose(pair.x[1], 5e-6, rtol=0.05)
    stuck = dataclasses.replace(fit((cal, a), [0, 1]), x=np.array([0.1, 5e-7]), magnitude=(0.1, 5e-7),
                                magnitude_interval=((0.0, 0.2), (3e-7, 8e-7)))  # a single left in a dead zone
    near = fit((cal, b), [0, 2, 3])
    near = dataclasses.replace(near, magnitude_interval=(near.magnitude_interval[0], (0.0, 1e-3)))
    x_cal, f_cal = np.array([0.05]), rng.normal(size=lay.n)
    starts = from_pairs([pair], {a.name: stuck, b.name: near}, x_cal, f_cal, prob, n_nuis)
    assert [s.name for s in starts] == [a.name]  # the runout lies within its single's interval: no start
    s = starts[0]
    assert [e.name for e in s.effects] == [cal.name, a.name] and not s.refined
    np.testing.assert_array_equal(s.x, pair.x[[0, 1]])
    np.testing.assert_array_equal(s.jacobian, pair.jacobian[:, [0, 1]])
    np.testing.assert_array_equal(s.base_x, [0.05, 0.0])
    np.testing.assert_array_equal(s.base_features, f_cal)
    assert not from_pairs([stuck, near], {a.name: stuck, b.name: near}, x_cal, f_cal, prob, n_nuis)  # singles: none


def test_a_pair_needs_its_second_effect_to_remove_a_quarter_of_the_rest():
    """With the single-variance evidence ("bic", the former rule kept to compare), the rule that admits an
    effect against "no effect" applied to the second effect of a pair: ≥ 25 % of the weighted gap the better
    single leaves, and ≥ 10 in BIC."""
    from types import SimpleNamespace

    from rvflex.diagnosis.fit import second_effect_adds
    from rvflex.diagnosis.linear import bic

    n = 800
    a, b = EFFECTS["carrier_hole_position"], EFFECTS["thermal_expansion"]

    def cand(effects, rss, k):
        return SimpleNamespace(effects=effects, attributed=effects, name=" + ".join(e.name for e in effects), rss=rss, bic=bic(rss, n, k))

    singles = {a.name: cand((a,), 100.0, 4), b.name: cand((b,), 400.0, 4)}
    s = DiagnosisSettings(evidence_model="bic")
    assert second_effect_adds(cand((a, b), 0.70**2 * 100.0, 5), singles, s)  # 30 % of the rest
    assert not second_effect_adds(cand((a, b), 0.85**2 * 100.0, 5), singles, s)  # 15 %: model-form absorption
    assert not second_effect_adds(cand((a, b), 0.70**2 * 400.0, 5), singles, s)  # measured against the better single


def test_with_the_discrepancy_a_pair_needs_evidence_for_its_second_effect_given_the_first():
    """With the discrepancy model the pair's second effect earns its place by evidence, not by a share of the
    gap: the pair's evidence over the better of its singles (both against the calibrated model's discrepancy,
    so the difference is the second effect's evidence given the first) must reach ``bic_threshold``. Measured on
    realistic seed 5, case 0: a 2.1 µm 3rd-harmonic pin pattern removes 20 % of what calibration leaves, the
    pair with the pin friction beside it 26 % (8 % of what the pattern leaves: the former rule asked 25 %), with
    evidence 89 over the pattern alone."""
    from types import SimpleNamespace

    from rvflex.diagnosis.fit import second_effect_adds

    a, b = EFFECTS["pin_position_h3"], EFFECTS["pin_contact_friction"]

    def cand(effects, score):
        return SimpleNamespace(effects=effects, attributed=effects, name=" + ".join(e.name for e in effects),
                               score=score, rss=1.0)

    singles = {a.name: cand((a,), 389.0), b.name: cand((b,), 77.0)}
    s = DiagnosisSettings()
    assert s.evidence_model == "discrepancy"
    score = lambda c: c.score  # noqa: E731 - the candidates carry their evidence
    assert second_effect_adds(cand((a, b), 478.0), singles, s, score)
    assert not second_effect_adds(cand((a, b), 389.0 + 0.9 * s.bic_threshold), singles, s, score)  # given the better
    assert not second_effect_adds(cand((a, b), 80.0), singles, s, score)  # worse than the pattern alone


def test_a_pair_whose_second_effect_does_not_predict_the_withheld_runs_is_not_confirmed():
    """A pair must also predict the withheld runs better than its better single alone (the rule that a
    confident answer predicts runs it was not fitted on, applied to the second effect), and by replication:
    two folds each predicted better with evidence ≥ 10, not the pooled share that one fold dominates. A pair
    that the withheld runs confirm against the calibrated model — its first effect does that — but not its
    second effect against the single is not accepted, and the verdict says why (fold evidences as measured on
    the self-checks: a spurious series compliance beside a clearance [62, 0, 0] at pooled +21 %, the
    real pin friction beside a pin pattern [340, 28, 75])."""
    from types import SimpleNamespace

    from rvflex.diagnosis.verdict import acceptable, verdict, withheld_confirms

    a, b = EFFECTS["pin_position_h3"], EFFECTS["pin_contact_friction"]
    s = DiagnosisSettings()

    def against(pct, folds):
        return {"improvement_pct": pct, "single": a.name, "folds": [{"evidence": v} for v in folds]}

    def pair(alone):
        wh = {"improvement_pct": 30.0, "folds": [{"evidence": 400.0}] * 3, "against_single": alone}
        return SimpleNamespace(name=f"{a.name} + {b.name}", effects=(a, b), attributed=(a, b), score=478.0,
                               gap_shrink_pct=26.0, refined=True, withheld=wh, magnitude=(2.3e-6, 0.013),
                               magnitude_interval=((2.2e-6, 2.4e-6), (0.01, 0.016)), at_bound=())

    one_fold = against(21.4, (62.0, 0.0, 0.0))
    assert withheld_confirms(one_fold, s) and not withheld_confirms(one_fold, s, replicated=True)
    assert not acceptable(pair(one_fold), s)
    assert not acceptable(pair(against(1.0, (3.0, -1.0, 0.5))), s)
    assert acceptable(pair(against(31.7, (340.0, 28.0, 75.0))), s)
    text = verdict([pair(one_fold)], None, None, True, s, {}, {})
    assert text.startswith("No effect is confirmed") and f"against {a.name} alone fewer than 2 folds" in text


def test_a_refined_pair_refuted_against_a_linearised_single_has_its_singles_refined():
    """Before a diagnosis says "unexplained" under a refined pair whose second effect was judged against a
    linearised single (a model-in-the-loop fit against a linearised one), the pair's linearised singles are
    refined (far self-check seed 2, case 17: a hidden thermal mismatch, linearised at score 54 at its bound,
    refined at 860 and confirmed; the pair with a clearance at 764, refuted against the clearance linearised
    at 97). Not when the single it was judged against is refined, nor under a single or an unrefined leader."""
    from types import SimpleNamespace

    from rvflex.diagnosis.stages.evidence import _singles_of_refuted_pair

    a, b, c = EFFECTS["eccentric_bearing_clearance"], EFFECTS["thermal_expansion"], EFFECTS["pin_ring_runout"]
    s = DiagnosisSettings()

    def cand(effects, score, refined, against=None):
        wh = {"against_single": {"single": against}} if against else {}
        return SimpleNamespace(effects=effects, attributed=effects, name=" + ".join(e.name for e in effects),
                               score=score, refined=refined, withheld=wh)

    pair = cand((a, b), 764.0, True, against=a.name)
    sa, sb, sc = cand((a,), 97.0, False), cand((b,), 54.0, False), cand((c,), 27.0, False)
    assert _singles_of_refuted_pair([pair, sa, sb, sc], s, {}) == [sa, sb]
    sa_ref = cand((a,), 97.0, True)
    assert _singles_of_refuted_pair([pair, sa_ref, sb, sc], s, {}) == []  # judged against a refined single
    assert _singles_of_refuted_pair([sa, pair, sb], s, {}) == []  # the leader is a single
    assert _singles_of_refuted_pair([cand((a, b), 764.0, False, a.name), sa, sb], s, {}) == []  # linearised pair
    assert _singles_of_refuted_pair([pair, sa, sb], s, {b.name: "failed"}) == [sa]  # a failed single stays out
    assert _singles_of_refuted_pair([cand((a, b), 5.0, True, a.name), sa, sb], s, {}) == []  # no evidence


def test_settings_refuse_too_few_positions_for_the_orders():
    with pytest.raises(ValueError, match="positions_per_rev"):
        DiagnosisSettings(positions_per_rev=128, max_order=120)


def test_the_model_grid_folds_no_pin_mesh_harmonic_into_the_analysed_orders():
    """The default grid is chosen per reducer, a grid that folds a pin-mesh harmonic into the analysed
    orders is refused with the harmonic and the order named, and the chosen grid reproduces the flexible
    model's orders 1…127 as a 1024-position run gives them (the mesh orders to 0.02″). At 256
    positions the flexible discs' 4·z_b (0.93″ at 412 N·m) folds to order 96, at 320 their 6·z_b
    (0.22″) onto 2·z_b: model-only signatures no bench shows."""
    from rvflex.diagnosis.replay import evaluate
    from rvflex.units import ARCSEC_PER_RAD

    s = DiagnosisSettings().for_spec(SPEC)
    assert s.positions_per_rev == 448  # z_b = 40: every m·z_b, m ≤ 8, resolved or folded beyond order 127
    with pytest.raises(ValueError, match=r"4·z_b = 160 folds to order 96.*use 448"):
        DiagnosisSettings(positions_per_rev=256).for_spec(SPEC)
    with pytest.raises(ValueError, match=r"5·z_b = 200 folds to order 120"):
        DiagnosisSettings(positions_per_rev=320).for_spec(SPEC)
    plan = (PlanRun("te", "fwd", 1, 412.0),)

    def orders(n):
        te = evaluate(SPEC, ErrorSpec(), plan, DiagnosisSettings(positions_per_rev=n, max_order=127),
                      options=ModelOptions.flexible_discs()).te[0] * ARCSEC_PER_RAD
        return np.fft.rfft(te)[1:128] * 2 / n

    fine, chosen, old = orders(1024), orders(448), orders(320)
    assert abs(fine[79]) > 4.0  # 2·z_b, the flexible discs' mesh order (5.7″)
    # the 1024-position run folds nothing below order 400 (its 10·z_b, 0.06″) onto orders ≤ 127; the chosen
    # grid leaves the mesh orders within 0.02″ (at 320, 6·z_b put 0.2″ on 2·z_b); what it still folds are the
    # 10…13·z_b harmonics (0.03–0.06″) onto orders 48, 32, 72, 56 — measured 0.08″ at most
    mesh = np.arange(1, 128) % 40 == 0
    assert np.max(np.abs(chosen - fine)[mesh]) < 0.02 < 0.15 < abs(old[79] - fine[79])
    assert np.max(np.abs(chosen - fine)) < 0.1


@pytest.mark.slow
def test_selfcheck_two_cases(tmp_path):
    """A blind 2-case self-check at coarse settings: one hidden effect, one control.

    Four candidates (two low-order effects that share order 1, a clearance and friction) keep
    it within CI time. Expectations: the JSON has the issue's keys; the hidden effect is
    among the two best-ranked candidates (it is drawn at 0.6–1.4× its typical size, tens of
    times above the noise floor); the control is reported as no significant effect."""
    from rvflex.diagnosis.selfcheck import GeneratorModel, SelfCheckSettings, selfcheck

    effects = ("pin_ring_runout", "output_encoder_eccentricity", "eccentric_bearing_clearance",
               "pin_contact_friction")
    settings = SelfCheckSettings(cases=2, seed=3, control_every=2, two_effect_share=0.0, effects=effects,
                                 generator=GeneratorModel(positions_per_rev=256, hysteresis_steps=60),
                                 diagnosis=DiagnosisSettings(max_order=63,
                                                             hysteresis_steps=24, refine_top=2,
                                                             refine_iterations=1, workers=2), told=True)
    doc = selfcheck(tmp_path, settings, log=lambda s: None)
    json.dumps(doc)
    assert {"cases", "top1_rate", "top2_rate", "magnitude_within_25pct_rate", "median_gap_shrink_pct",
            "control_correct_rate", "wall_s"} <= doc.keys()
    assert doc["cases"] == 2 and doc["effect_cases"] == 1 and doc["control_cases"] == 1
    assert doc["top2_rate"] == 1.0
    assert doc["control_correct_rate"] == 1.0
    # told its hidden effect (the only candidate), the diagnosis accepts it: tens of times above the noise floor
    effect_case = next(r for r in doc["per_case"] if not r["control"])
    assert effect_case["told_top1"] and doc["top1_rate_told"] == 1.0, effect_case
    assert "told_top1" not in next(r for r in doc["per_case"] if r["control"])
    # the truth stays outside the dataset folders the diagnosis reads
    assert not list((tmp_path / "datasets").rglob("*.json"))


@pytest.mark.slow
def test_thermal_expansion_is_told_from_a_modification_deviation(tmp_path):
    """Both move the pin circle against the discs; at one temperature their signatures nearly
    coincide. The self-check's campaign records each run's temperature (cold torque cycle, warm
    rated-load TE runs): the thermal effect then scales from run to run and the modification
    deviation does not. A hidden 10 ppm/K mismatch must be found blind, within ±25 %, and not be
    reported as tied with the deviation."""
    from rvflex.diagnosis.fit import diagnose
    from rvflex.diagnosis.selfcheck import BENCH_TEMPERATURES_C, GeneratorModel, generate_case

    hidden = [(EFFECTS["thermal_expansion"], np.array([10e-6]))]
    generate_case(tmp_path / "bench", tmp_path / "truth.json", SPEC, hidden, np.random.default_rng(5),
                  gen=GeneratorModel(positions_per_rev=192, hysteresis_steps=40))
    ds = read_bench(tmp_path / "bench")
    assert {r.temperature_C for r in ds.runs} == set(BENCH_TEMPERATURES_C.values())
    # orders 1…95 (z_b and 2·z_b in): the disc-flexibility share is read where it acts, on order 2·z_b. With
    # orders 1…31 only the wind-ups and the torque cycle are left to tell a thermal mismatch from the share,
    # and the share took most of it (measured: share at its bound 2, thermal 20 % of the rest); at the former
    # 128 positions the mesh harmonics' aliases on orders 8, 16 and 24 had pinned the share instead
    settings = DiagnosisSettings(max_order=95, hysteresis_steps=16, refine_top=2,
                                 refine_iterations=3, workers=2)
    diag = diagnose(ds, settings=settings, effects=("thermal_expansion", "disc_modification_deviation"),
                    cache_dir=tmp_path / "cache")
    assert diag.chosen is not None and diag.chosen.name == "thermal_expansion", diag.verdict
    assert diag.chosen.magnitude_of("thermal_expansion") == pytest.approx(10e-6, rel=0.25)
    assert "disc_modification_deviation" not in diag.ties


def test_demo_scenario_is_importable_without_running(tmp_path):
    """The walk-through computes only when called (plotting and writing only under __main__)."""
    from rvflex.scenarios.diagnosis_demo import DiagnosisDemo, run_diagnosis_demo

    sc = DiagnosisDemo(tmp_path)
    assert sc.effect in EFFECTS and len(sc.params) == EFFECTS[sc.effect].n
    assert callable(run_diagnosis_demo) and not list(tmp_path.iterdir())


def test_replay_and_lost_motion_share_one_torque_stepping_engine():
    """The diagnosis replays a torque cycle with rvflex.solve.torque_stepping itself: the same
    equilibria as the lost-motion test (bit for bit on the same path and model)."""
    from rvflex.diagnosis.replay import evaluate
    from rvflex.model import build_reducer
    from rvflex.solve import hysteresis_cycle, torque_stepping
    from rvflex.spec import ErrorSpec

    s = DiagnosisSettings(hysteresis_steps=40, workers=1)
    path = hysteresis_cycle(SPEC.rated_torque_Nm, s.hysteresis_steps)
    plan = (PlanRun("hysteresis", "cycle", torque_max_Nm=SPEC.rated_torque_Nm, torque_path_Nm=tuple(map(float, path))),)
    replayed = evaluate(SPEC, ErrorSpec(), plan, s).theta[0]
    direct = torque_stepping(build_reducer(SPEC, ErrorSpec()), path).theta_out
    np.testing.assert_array_equal(replayed, direct)
    # a physical loop: the output turns with the torque, by ~T/k ≈ 2.6′ at rated torque (k ≈ 159 N·m/arcmin)
    k = int(np.argmax(path))
    assert 1.5 < replayed[k] * 180 * 60 / np.pi < 4.5


def _variant(case, run):
    """(spec, errors) of a measured failing case: (nominal parameters and effects by name, base errors)."""
    from rvflex.diagnosis.nominal import NOMINAL

    active, err = case
    spec = SPEC
    for name, x in active:
        spec, err = (NOMINAL.get(name) or EFFECTS[name]).apply_to(spec, err, np.asarray(x, float), run)
    return spec, err


# measured in the realistic self-check (seed 3): fitted values at which the model failed to converge; the
# pin-ring runouts as measured (x/y components (6.3268, 6.4955) and (−1.0147, 2.8465) µm), as errors: the
# contact-onset kink is a knife edge that the runout's φ + π twin does not reproduce bit for bit
STIFF_FLOATING = ((("contact_stiffness", [-0.5]), ("needle_bearing_stiffness", [0.5388]), ("mesh_stiffness", [-0.1149]),
                   ("crank_bearing_clearance", [4.3405e-6])),
                  ErrorSpec(pin_ring_runout_m=math.hypot(6.3268e-6, 6.4955e-6),
                            pin_ring_runout_phase_rad=math.atan2(6.4955e-6, 6.3268e-6)))
KINKED_FREE_PLAY = ((("contact_stiffness", [-0.2279]), ("needle_bearing_stiffness", [-0.02195]),
                     ("crank_bearing_clearance", [2.8540e-6])),
                    ErrorSpec(pin_ring_runout_m=math.hypot(-1.0147e-6, 2.8465e-6),
                              pin_ring_runout_phase_rad=math.atan2(2.8465e-6, -1.0147e-6)))


def test_a_unit_the_one_shot_loading_cannot_load_is_loaded_step_by_step():
    """quasi_static reaches its first loaded state by a stiff-to-working regulariser continuation
    under the full load; with 4.3 µm crank-bearing clearance and a 6 µm pin-ring runout that failed
    (seed 3, case 0) and the torque-stepping engine now loads the unit instead. Without friction the
    equilibrium does not depend on the path: on the nominal unit both reach the same state."""
    from rvflex.model import build_reducer
    from rvflex.solve import _loaded_by_torque_stepping, quasi_static
    from rvflex.units import ARCSEC

    run = PlanRun("te", "fwd", 1, 412.0)
    model = build_reducer(*_variant(STIFF_FLOATING, run))
    res = quasi_static(model, np.linspace(0.0, 2 * np.pi * model.ratio / 40, 9, endpoint=False), 412.0, fail_fast=True)
    assert np.all(np.isfinite(res.te_rad)) and 1.0 < np.ptp(res.te_rad) / ARCSEC < 20.0  # the unit's TE: a few ″
    nominal = build_reducer(SPEC, ErrorSpec())
    direct = quasi_static(nominal, np.zeros(1), 412.0, fail_fast=True).theta_out[0]
    stepped = _loaded_by_torque_stepping(nominal, -412.0)[nominal.output_index]
    assert abs(stepped - direct) / ARCSEC < 1e-3


def test_a_cycle_step_on_a_contact_onset_is_left_out_and_interpolated(monkeypatch):
    """Inside the free play an equilibrium can sit where a contact begins, and Exudyn's Newton cycles there
    (seed 3, case 16: 12.4 N·m). The engine leaves such a step out (NaN) when the next one converges;
    the replay interpolates over it in torque. Up to the first such step the strict engine gives the same
    angles. The compiled step, with its exact Jacobian, takes every step of that cycle, at the angles of
    Exudyn's solver wherever that converged (1e-4″, both solvers' tolerance)."""
    from rvflex.diagnosis.replay import evaluate
    from rvflex.model import build_reducer
    from rvflex.solve import SOLVER_ENV, SolveError, hysteresis_cycle, torque_stepping
    from rvflex.units import ARCSEC

    path = hysteresis_cycle(SPEC.rated_torque_Nm, 40)
    run = PlanRun("hysteresis", "cycle", torque_max_Nm=SPEC.rated_torque_Nm, torque_path_Nm=tuple(path))
    compiled = torque_stepping(build_reducer(*_variant(KINKED_FREE_PLAY, run)), path).theta_out
    monkeypatch.setenv(SOLVER_ENV, "exudyn")
    run = PlanRun("hysteresis", "cycle", torque_max_Nm=SPEC.rated_torque_Nm, torque_path_Nm=tuple(path))
    model = build_reducer(*_variant(KINKED_FREE_PLAY, run))
    with pytest.raises(SolveError) as err:
        torque_stepping(model, path)
    strict = err.value.result.theta_out  # the steps before the first failure
    loose = torque_stepping(build_reducer(*_variant(KINKED_FREE_PLAY, run)), path, skip_unsolved=True)
    bad = np.isnan(loose.theta_out)
    # measured: the ±3 % point (12.4 N·m) on each of its four passages; never two in a row, the first or the last
    assert 1 <= bad.sum() <= 4 and not bad[0] and not bad[-1] and not np.any(bad[1:] & bad[:-1])
    np.testing.assert_array_equal(loose.theta_out[:len(strict)], strict)
    replayed = evaluate(*_variant(KINKED_FREE_PLAY, run), (run,), DiagnosisSettings(hysteresis_steps=40)).theta[0]
    np.testing.assert_array_equal(replayed[~bad], loose.theta_out[~bad])
    angles = branch_angles(path, replayed, SPEC.rated_torque_Nm)
    assert np.all(np.isfinite(angles)) and np.all(np.diff(angles[:12]) > 0)  # the output turns with the torque
    assert np.all(np.isfinite(compiled)) and np.abs(compiled[~bad] - loose.theta_out[~bad]).max() / ARCSEC < 1e-4


# measured in the far self-check (seed 1, case 18: a hidden 5.1 µm pin-ring runout, the clearance calibrated at
# 7.2 µm): the refinement's fitted values, at which the model failed; a failed model run blocks the candidate that
# fits best (score 950, withheld +48 %), so the verdict could accept nothing
WIDE_FREE_PLAY_LOADING = ((("contact_stiffness", [-0.09204593091786119]), ("needle_bearing_stiffness", [0.2582913302784014]),
                           ("crank_bearing_clearance", [7.4201290169999196e-06]),
                           ("pin_ring_runout", [-5.262253964774403e-07, 3.4350020714972386e-06])), ErrorSpec())
WIDE_FREE_PLAY_CYCLE = ((("contact_stiffness", [-0.07293186366060032]), ("needle_bearing_stiffness", [0.24285609976698735]),
                         ("crank_bearing_clearance", [7.519964805946424e-06]),
                         ("pin_ring_runout", [-7.517505663963433e-07, 4.907145816424627e-06])), ErrorSpec())


def test_a_loading_step_that_fails_is_left_out_without_changing_the_loaded_state():
    """The fallback loading of a TE run (see the test above) steps the torque up along LOADING_FRACTIONS;
    with a 7.4 µm clearance and a 3.5 µm runout its 1 % step (4.1 N·m) fails however it is started (seed-1
    case 18's reverse rated run failed so). Without friction the loaded state does not depend on the path:
    the step is left out, and the state is the one reached along the path without it."""
    from rvflex.model import build_reducer
    from rvflex.solve import LOADING_FRACTIONS, _loaded_by_torque_stepping, torque_stepping
    from rvflex.units import ARCSEC

    run = PlanRun("te", "rev", -1, 412.0)
    model = build_reducer(*_variant(WIDE_FREE_PLAY_LOADING, run))
    stepped = _loaded_by_torque_stepping(model, 412.0)[model.output_index]
    fractions = [f for f in LOADING_FRACTIONS if f != 0.01]
    other = torque_stepping(build_reducer(*_variant(WIDE_FREE_PLAY_LOADING, run)), 412.0 * np.asarray(fractions))
    assert abs(stepped - other.theta_out[-1]) / ARCSEC < 1e-3
    assert 100.0 < stepped / ARCSEC < 1000.0  # a wind-up of a few arcminutes at rated torque, not a jump


def test_a_cycle_step_that_fails_is_solved_from_the_state_its_first_leg_converged_at_that_torque():
    """On the unloading leg of a cycle with 7.5 µm clearance and a 4.9 µm runout the 4 % and 3 % steps
    (16.5, 12.4 N·m) both fail from the last state and from the unloaded one, and two failed steps in a row
    failed the run (seed-1 case 18). The loading leg converged at both torques; without friction the
    equilibrium there is the same, and from that state it converges. The frictionless model's two legs then
    agree at every torque both reached (1e-4″: the solver's tolerance)."""
    from rvflex.model import build_reducer
    from rvflex.solve import hysteresis_cycle, torque_stepping
    from rvflex.units import ARCSEC

    path = hysteresis_cycle(SPEC.rated_torque_Nm, 40)
    run = PlanRun("hysteresis", "cycle", torque_max_Nm=SPEC.rated_torque_Nm, torque_path_Nm=tuple(path))
    theta = torque_stepping(build_reducer(*_variant(WIDE_FREE_PLAY_CYCLE, run)), path, skip_unsolved=True).theta_out
    bad = np.isnan(theta)
    assert not bad[0] and not bad[-1] and not np.any(bad[1:] & bad[:-1])
    top = int(np.argmax(path))
    for j in range(1, top):  # the loading leg, against the unloading leg at the same torque
        k = top + int(np.flatnonzero(np.isclose(path[top:], path[j]))[0])
        if not (bad[j] or bad[k]):
            assert abs(theta[j] - theta[k]) / ARCSEC < 1e-4, (path[j], theta[j] / ARCSEC, theta[k] / ARCSEC)
    assert not bad[top + int(np.flatnonzero(np.isclose(path[top:], 16.48))[0])]  # the failed step is solved


# measured in the realistic self-check (seed 3, case 14): a calibration point of the refinement, whose torque cycle
# leaves zero torque twice (the start and the reversal) through 3.3 µm of crank-bearing clearance
FLOATING_AT_ZERO = ((("contact_stiffness", [-0.7]), ("needle_bearing_stiffness", [0.820632583]),
                     ("crank_bearing_clearance", [3.333e-06])), ErrorSpec())


def test_a_cycle_that_needed_the_continuation_out_of_zero_torque_takes_the_reversal_by_it(monkeypatch):
    """Out of zero torque the unit floats in its free play: Exudyn's Newton (its chord Newton and its static
    solver, ``RVFLEX_SOLVER=exudyn``; the compiled step's retries take this step) fails at the cycle's first
    step (2.06 N·m; before, at each of its bisections too), and the stiff-to-working regulariser continuation
    takes it. The reversal (0 → −2.06 N·m) then starts with the continuation, so Exudyn's solver fails there no
    more (with the bisections, 0.6 s of a 1.5 s cycle before). Without friction the equilibrium does not depend on
    the path: the reversal's angle is the one a cycle started downwards reaches through the fallbacks in turn,
    within 1e-4″ (the solver's tolerance), and the one the compiled step reaches."""
    import rvflex.solve as solve
    from rvflex.model import build_reducer
    from rvflex.solve import hysteresis_cycle, torque_stepping
    from rvflex.units import ARCSEC

    path = hysteresis_cycle(SPEC.rated_torque_Nm, 40)
    run = PlanRun("hysteresis", "cycle", torque_max_Nm=SPEC.rated_torque_Nm, torque_path_Nm=tuple(path))
    compiled = torque_stepping(build_reducer(*_variant(FLOATING_AT_ZERO, run)), path, skip_unsolved=True)
    monkeypatch.setenv(solve.SOLVER_ENV, "exudyn")
    failed = []  # the torques at which Exudyn's static solver failed
    solve_at = solve.solve_at

    def counted(model, ss, theta_in, q_abs):
        try:
            return solve_at(model, ss, theta_in, q_abs)
        except Exception:
            failed.append(model.mbs.GetLoadParameter(model.carrier.load, "load"))
            raise

    monkeypatch.setattr(solve, "solve_at", counted)
    theta = torque_stepping(build_reducer(*_variant(FLOATING_AT_ZERO, run)), path, skip_unsolved=True).theta_out
    assert np.all(np.isfinite(theta))
    assert failed and all(0.0 < t <= path[1] + 1e-9 for t in failed), failed  # only on the way out of zero first
    reversal = int(np.flatnonzero((path[:-1] == 0.0) & (path[1:] < 0.0))[0]) + 1
    failed.clear()
    down = torque_stepping(build_reducer(*_variant(FLOATING_AT_ZERO, run)), [0.0, path[reversal]]).theta_out
    assert failed  # the downward start needed the fallbacks: it went through them in turn
    assert abs(theta[reversal] - down[1]) / ARCSEC < 1e-4, (theta[reversal] / ARCSEC, down[1] / ARCSEC)
    assert compiled.compiled is not None and np.all(np.isfinite(compiled.theta_out))
    assert np.abs(compiled.theta_out - theta).max() / ARCSEC < 1e-3


# ----------------------------------------------------------------------------- calibrate, then attribute

CAL = ("contact_stiffness", "contact_law_form", "needle_bearing_stiffness", "mesh_stiffness", "crank_bearing_clearance")
# coarse for CI time: orders 1…95 (z_b and 2·z_b in; the model grid, 416 positions, folds no pin-mesh
# harmonic onto another order), 24-step cycle
CI_SETTINGS = DiagnosisSettings(max_order=95, hysteresis_steps=24, refine_top=3,
                                refine_iterations=3, workers=2)


def _mismatched_bench(tmp_path, hidden, samples_per_rev=512, **drawn):
    """A bench from another model family (power-law contact, scaled needle-bearing and mesh
    stiffness, a nominal crank-bearing clearance; TE sampled over [0, 2π)), rigid for CI time."""
    from rvflex.diagnosis.selfcheck import GeneratorModel, RealisticMismatch, generate_case

    gen = RealisticMismatch(options=ModelOptions.rigid(), samples_per_rev=samples_per_rev, fixed=tuple(drawn.items()))
    truth = generate_case(tmp_path / "bench", tmp_path / "truth.json", SPEC, hidden, np.random.default_rng(7),
                          gen=GeneratorModel(positions_per_rev=256, hysteresis_steps=48), realistic=gen)
    assert truth["nominal"] == drawn
    return read_bench(tmp_path / "bench")


@pytest.mark.slow
def test_a_control_with_30pct_stiffness_mismatch_is_nominal_parameters_off(tmp_path):
    """No hidden effect; the generator's contact law is a power law 30 % stiffer than the line
    contact's equivalent, its needle bearings 30 % softer, its mesh 30 % stiffer, with a 2 µm nominal
    clearance. Calibration must take that and no effect be accepted."""
    from rvflex.diagnosis.fit import diagnose

    ds = _mismatched_bench(tmp_path, [], contact_scale=1.3, needle_bearing_scale=0.7, mesh_scale=1.3,
                           clearance_m=2e-6)
    diag = diagnose(ds, settings=CI_SETTINGS, nominal=CAL, cache_dir=tmp_path / "cache",
                    effects=("eccentric_bearing_clearance", "pin_ring_runout", "disc_modification_deviation"))
    assert diag.chosen is None, diag.verdict
    assert "Nominal parameters off; no unmodelled effect" in diag.verdict
    assert diag.baseline.gap_shrink_pct >= 50.0  # calibration closes most of the nominal model's gap
    # labelled tables for a notebook: the ranking, the gap per run and metric, the calibration
    rank, gap, cal = (diag.to_dataframe(t) for t in ("ranking", "gap", "calibration"))
    assert list(rank["effect"]) == [c.name for c in diag.candidates] and not rank["accepted"].any()
    assert {"measured", "nominal_model", "calibrated", "after"} <= set(gap.columns)
    assert set(cal["name"]) == set(CAL)
    # the first-stage mesh compliance, reflected through the 118:1 ratio, moves the output by ~0.05″ over its
    # whole prior range: the runs do not determine it, and it is reported held at nominal, not calibrated
    det = cal.set_index("name")["determined"]
    assert not det["mesh_stiffness"] and det.drop("mesh_stiffness").all()
    assert "Not determined by these runs, held at nominal: mesh stiffness" in diag.verdict


@pytest.mark.slow
def test_a_hidden_clearance_is_found_through_a_30pct_contact_stiffness_mismatch(tmp_path):
    """A hidden 15 µm eccentric-bearing clearance (9.76 µm beyond the RV-40E's nominal class of 0 … 5.24 µm, within
    which the runs cannot tell a hidden clearance from the nominal one: the generator takes the drawn
    size as the excess over the class top, ``beyond_the_class``), the generator's contact 30 % softer
    than the diagnosing model's: the clearance is accepted and its size (nominal + excess, the observable
    total) is within ±25 %. At the diagnosis's default resolution: with orders only up to 95 and a
    24-step torque cycle a −10 µm pin-radius error (its torque-cycle signature is the clearance's)
    won instead, tied with the clearance — measured; the equidistant deviation now stands for the
    pin radius error in the candidate list."""
    from rvflex.diagnosis.fit import diagnose
    from rvflex.diagnosis.nominal import clearance_class_top

    hidden = [(EFFECTS["eccentric_bearing_clearance"], np.array([15e-6 - clearance_class_top(SPEC)]))]  # + the class
    ds = _mismatched_bench(tmp_path, hidden, samples_per_rev=1024, contact_scale=0.7, needle_bearing_scale=1.0,
                           mesh_scale=1.0, clearance_m=0.0)
    diag = diagnose(ds, settings=DiagnosisSettings(workers=2), nominal=CAL, cache_dir=tmp_path / "cache",
                    effects=("eccentric_bearing_clearance", "pin_ring_runout", "disc_modification_deviation"))
    assert diag.chosen is not None and diag.chosen.name == "eccentric_bearing_clearance", diag.verdict
    total = diag.chosen.magnitude_of("eccentric_bearing_clearance") + diag.chosen.magnitude_of("crank_bearing_clearance")
    assert total == pytest.approx(15e-6, rel=0.25)


def test_the_verdict_says_no_unmodelled_effect_only_when_none_is_left_open():
    """Calibration that closes most of the gap reads "Nominal parameters off; no unmodelled effect"
    only when no candidate is left open: a significant candidate the withheld runs did not confirm
    (or whose model evaluation failed) leaves its part of the gap unexplained, and the verdict must
    not also say there is no effect (seen on the realistic self-check: a pin-ring runout removing
    71 % of what calibration left, not confirmed, under a first sentence saying no effect)."""
    from rvflex.diagnosis.calibration import calibration_sentence
    from rvflex.diagnosis.linear import make_candidate
    from rvflex.diagnosis.nominal import NOMINAL

    n = 40
    needle = NOMINAL["needle_bearing_stiffness"]
    cal = make_candidate((needle,), np.array([0.8]), np.zeros(0), 0.0, 10.0, np.eye(n)[:, :1], n, 0, np.zeros(n),
                         refined=True)
    cal = dataclasses.replace(cal, gap_shrink_pct=90.0)
    nominal = make_candidate((), np.zeros(0), np.zeros(0), 0.0, 1000.0, np.zeros((n, 0)), n, 0, np.zeros(n),
                             refined=True)
    s = DiagnosisSettings()
    assert "Nominal parameters off; no unmodelled effect." in calibration_sentence(cal, nominal, None, s)
    assert "no unmodelled effect" not in calibration_sentence(cal, nominal, None, s, open_effect=True)


def test_the_pin_ring_runout_is_parameterised_by_the_doubled_angle():
    """A pin-ring runout r at angle φ and at φ + π load the pins alike (the two discs' load zones are
    180° apart): the model's quarter-load TE and torque cycle agree to 1e-3″, while a quarter turn
    of φ moves the order-2·z_c TE by about 1.6″ (measured: ±0.79″ at 5 µm). So the effect's
    parameters are (r cos 2φ, r sin 2φ): the effect maps them to φ = atan2/2, and a linear fit in
    them can turn the runout (in x/y components the two secants were antiparallel on the TE)."""
    from rvflex.diagnosis.plan import PlanRun
    from rvflex.diagnosis.replay import evaluate
    from rvflex.solve import hysteresis_cycle
    from rvflex.units import ARCSEC

    e = EFFECTS["pin_ring_runout"]
    assert e.polar and e.magnitude(np.array([3e-6, 4e-6])) == pytest.approx(5e-6)
    r, phi = 5e-6, 0.3
    _, err = e.apply_to(SPEC, ErrorSpec(), np.array([r * math.cos(2 * phi), r * math.sin(2 * phi)]), None)
    assert err.pin_ring_runout_m == pytest.approx(r) and err.pin_ring_runout_phase_rad == pytest.approx(phi)
    tr = SPEC.rated_torque_Nm
    plan = (PlanRun("te", "q", 1, 0.25 * tr, temperature_C=25.0),
            PlanRun("hysteresis", "h", torque_max_Nm=tr, torque_path_Nm=tuple(map(float, hysteresis_cycle(tr, 40))),
                    temperature_C=23.0))
    s = DiagnosisSettings().for_spec(SPEC)
    out = [evaluate(SPEC, ErrorSpec(pin_ring_runout_m=r, pin_ring_runout_phase_rad=p), plan, s)
           for p in (phi, phi + math.pi, phi + math.pi / 2)]
    same = [np.max(np.abs(np.asarray(out[0].te[0]) - np.asarray(out[1].te[0]))) / ARCSEC,
            np.max(np.abs(np.asarray(out[0].theta[1]) - np.asarray(out[1].theta[1]))) / ARCSEC]
    assert max(same) < 1e-3
    zc = SPEC.cycloid.disc_teeth
    c = [np.fft.rfft(np.asarray(o.te[0]))[2 * zc] * 2 / len(o.te[0]) / ARCSEC for o in out]
    assert abs(c[2] - c[0]) > 1.0  # a quarter turn of φ is half a turn of 2φ: the order-2·z_c TE flips


def test_a_run_that_repeats_every_pin_pitch_is_solved_over_one_pitch():
    """One crank revolution turns the output one pin pitch with the carrier, the cranks and the discs back where
    they were: with errors that ride on those parts or are alike at every pin, the TE repeats every pitch, and
    solved over one pitch it is the whole revolution's; a pin-ring runout turns with the housing, breaks it and
    gets the whole revolution."""
    from rvflex.diagnosis.replay import ModelRun, one_period, run_model
    from rvflex.units import ARCSEC_PER_RAD as as_

    z_b, z_c = SPEC.cycloid.pin_count, SPEC.cycloid.disc_teeth
    n = 576
    phase = one_period(n, SPEC, ErrorSpec(), ModelOptions.rigid())
    m = phase.max() + 1
    assert m == 72  # gcd(576, 40) = 8: 72 distinct positions within a pitch
    turns = (np.arange(n) / n - phase / (m * z_b)) * z_b  # whole pitches between the two positions
    np.testing.assert_allclose(turns, np.round(turns), rtol=0, atol=1e-9)

    plan = (PlanRun("te", "a", 1, 412.0), PlanRun("te", "b", -1, 206.0))
    st = DiagnosisSettings(max_order=20, positions_per_rev=360, workers=1).for_spec(SPEC)  # 9 positions a pitch
    pitch_steps = 360 // z_b
    rng = np.random.default_rng(3)
    riding = ErrorSpec(crank_support_clearance_m=(2e-6, 2e-6), eccentric_bearing_clearance_m=(3e-6,) * 4,
                       crank_eccentricity_error_m=(2e-6, -1e-6), crank_phase_error_rad=(3e-4, 0.0),
                       disc_pitch_error_m=tuple(tuple(rng.normal(0, 2e-6, z_c)) for _ in range(2)),
                       input_carrier_hole_distance_error_m=4e-6, pin_radius_error_m=-3e-6,
                       pin_circle_radius_error_m=2e-6, planet_runout_m=(3e-6, 0.0), disc_moved_error_m=(3e-6, 0.0))
    runout = ErrorSpec(pin_ring_runout_m=5e-6, pin_ring_runout_phase_rad=0.4)
    assert one_period(360, SPEC, riding, ModelOptions.rigid()) is not None
    assert one_period(360, SPEC, runout, ModelOptions.rigid()) is None
    assert one_period(360, SPEC, ErrorSpec(carrier_runout_m=5e-6), ModelOptions.rigid()) is None  # measured: 0.06″
    assert one_period(360, SPEC, riding, ModelOptions(housing=PartSettings(4e-3, 8))) is None
    rigid = ModelRun((), ModelOptions.rigid())
    full = run_model(SPEC, riding, plan, dataclasses.replace(st, one_period=False), rigid)
    short = run_model(SPEC, riding, plan, st, rigid)
    for te_full, te_short in zip(full.te, short.te):
        assert np.ptp(te_full) * as_ > 1.0  # the errors and clearances make arcseconds of TE within each pitch
        # the whole revolution repeats every pitch, and the pitch solved alone is it, within the solver's tolerance
        assert np.max(np.abs(te_full - np.roll(te_full, pitch_steps))) * as_ < 1e-6
        assert np.max(np.abs(te_full - te_short)) * as_ < 1e-6
    # the runout's TE does not repeat in a pitch: solved over one, it would be wrong by hundredths of an arcsecond
    te = run_model(SPEC, runout, plan[:1], st, rigid).te[0]
    assert np.max(np.abs(te - np.roll(te, pitch_steps))) * as_ > 0.02  # (0.058″ measured)

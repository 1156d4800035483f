"""Output loads on the spatial model (``output_load=`` of rvflex.solve, ``--spatial``): the carrier's tilt and shift
solved with the gear train (two-way), against the pair alone (rvflex.tilt.carrier_tilt) and the planar model's
one-way tilt (rvflex.tilt.tilted_errors). Solved by the compiled step (its equilibria are Exudyn's:
tests/test_engine_spatial.py); RV-40E, four slices, 64 positions over a third of an output revolution (13 periods of the disc-tooth order z_c = 39)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import rvflex
from rvflex import catalog
from rvflex.cli import main
from rvflex.contact.angular_contact import PairLoad, pair_model, solve
from rvflex.geometry.formulas import ARCMIN_PER_RAD, ARCSEC_PER_RAD
from rvflex.model import build_reducer
from rvflex.options import ModelOptions
from rvflex.solve import quasi_static, torque_stepping
from rvflex.tilt import MOMENT_SLICES, OutputLoad, carrier_tilt, tilted_errors

WINDOW_PERIODS = 13  # periods of order z_c in the window: a third of an output revolution of the RV-40E
POSITIONS = 64
AXIAL_N = 500.0


@pytest.fixture(scope="module")
def rv40e():
    return catalog.load("rv40e")


@pytest.fixture(scope="module")
def theta(rv40e):
    span = 2 * math.pi * rv40e.ratio * WINDOW_PERIODS / rv40e.cycloid.disc_teeth
    return np.linspace(0.0, span, POSITIONS + 1)[:-1]


def _order_zc(te_rad: np.ndarray) -> float:
    """Amplitude (arcsec) of the TE's order-z_c component over the window (its DFT bin)."""
    a = np.fft.rfft(te_rad * ARCSEC_PER_RAD)
    return 2.0 * abs(a[WINDOW_PERIODS]) / len(te_rad)


@pytest.fixture(scope="module")
def runs(rv40e, theta):
    """Spatial RV-40E at rated torque: no output load, 250 and 500 N·m about +x, 500 N·m at 2 rad, an axial force."""
    loads = {"none": None, "m250": OutputLoad(moment_Nm=250.0), "m500": OutputLoad(moment_Nm=500.0),
             "m500_2rad": OutputLoad(moment_Nm=500.0, moment_angle_rad=2.0),
             "axial": OutputLoad(axial_force_N=AXIAL_N)}
    out = {}
    for name, load in loads.items():
        model = build_reducer(rv40e, options=ModelOptions.spatial_rigid(MOMENT_SLICES))
        out[name] = quasi_static(model, theta, rv40e.rated_torque_Nm, output_load=load)
    return out


@pytest.fixture(scope="module")
def one_way(rv40e, theta):
    """The planar model with the same slices, untilted and with the pins moved against the pair's tilt at 500 N·m."""
    out = {}
    for m in (0.0, 500.0):
        errors = tilted_errors(None, carrier_tilt(rv40e, m)) if m else None
        out[m] = quasi_static(build_reducer(rv40e, errors, options=ModelOptions(face_slices=MOMENT_SLICES)), theta,
                              rv40e.rated_torque_Nm)
    return out


def test_the_records_have_their_shapes_and_the_planar_model_has_none(runs, one_way, rv40e):
    r, n, nd = runs["m500"], POSITIONS, rv40e.cycloid.disc_count
    assert r.carrier_tilt_rad.shape == (n, 2) and r.carrier_shift_m.shape == (n, 3)
    assert r.disc_tilt_rad.shape == (n, nd, 2)
    assert r.crank_tilt_rad.shape == (n, rv40e.cranks.count) and np.isfinite(r.crank_tilt_rad).all()
    assert r.pin_slice_force_N.shape == (n, nd, MOMENT_SLICES, rv40e.cycloid.pin_count)
    assert np.isfinite(r.carrier_tilt_rad).all() and np.isfinite(r.disc_tilt_rad).all()
    assert one_way[500.0].carrier_tilt_rad is None and one_way[500.0].crank_tilt_rad is None


def test_the_solved_tilt_is_the_pairs_a_little_stiffened_by_the_gear_train(runs, rv40e):
    """The moment's tilt (less the untilted run's, the gear train's own couple between the discs' planes) points
    along the moment whatever its direction, and is the pair-alone tilt made a little smaller: the gear train
    resists the tilt in parallel with the pair (mean ratio ≤ 1), and by the one-way measurement it carries at most
    2 % of the moment (tests/test_tilt.py holds it below 5 %), so the mean ratio stays above 0.95 (measured 0.988
    at 250 N·m, 0.991 at 500 N·m about +x and at 2 rad). Position by position the untilted run's tilt (±1.6e-5 rad,
    the couple turning with the cranks) meets a pair the moment has stiffened, so subtracting it leaves a few per
    cent either way (measured 0.966–1.008 along the pair's tilt, up to 0.02 across it): held within 0.9–1.05 and
    0.05."""
    base = runs["none"].carrier_tilt_rad
    for name, m, angle in (("m250", 250.0, 0.0), ("m500", 500.0, 0.0), ("m500_2rad", 500.0, 2.0)):
        pair = np.asarray(carrier_tilt(rv40e, m, angle).tilt_rad)
        d = runs[name].carrier_tilt_rad - base
        along = d @ pair / np.linalg.norm(pair) ** 2  # per position, the share of the pair's tilt
        across = d @ np.array([-pair[1], pair[0]]) / np.linalg.norm(pair) ** 2
        assert 0.95 <= along.mean() <= 1.0
        assert (along <= 1.05).all() and (along >= 0.9).all()
        assert abs(across.mean()) < 0.01 and np.abs(across).max() < 0.05  # the pair is axisymmetric
    # the untilted couple's tilt (measured 1.6e-5 rad, 3.4″) is small against 250 N·m's (0.15×)
    assert np.linalg.norm(base, axis=1).max() < 0.2 * carrier_tilt(rv40e, 250.0).tilt_magnitude_rad


def test_the_moment_adds_the_disc_tooth_order_ripple(runs, one_way, rv40e):
    """The discs sit on either side of the pair's centre, so the tilt shifts them oppositely against the pins:
    their order-z_c errors no longer cancel (the one-way model's signature, tests/test_tilt.py). Absent untilted,
    it grows in proportion to the solved tilt (±10 %), and stays below the one-way model's, which carries the discs
    rigidly with the pair's tilt while here the pins push back through the discs' needle bearings and the cranks'
    supports (measured 4.21″ against 4.62″ at 500 N·m, 0.91×). The mean wind-up, a torsional figure, moves by
    less than 0.5″ (measured 0.06″)."""
    a = {name: _order_zc(runs[name].te_rad) for name in ("none", "m250", "m500")}
    assert a["none"] < 0.01
    assert a["m500"] > 1.0
    tilt = {name: np.linalg.norm(runs[name].carrier_tilt_rad.mean(axis=0)) for name in ("m250", "m500")}
    assert a["m500"] / a["m250"] == pytest.approx(tilt["m500"] / tilt["m250"], rel=0.1)
    one = _order_zc(one_way[500.0].te_rad)
    assert 0.8 * one < a["m500"] < one
    mean = {name: runs[name].te_rad.mean() * ARCSEC_PER_RAD for name in ("none", "m500")}
    assert abs(mean["m500"] - mean["none"]) < 0.5


def test_the_face_pushed_into_the_pins_carries_more(runs, one_way, rv40e):
    """A disc at axial position z moves by θ × z with the tilted carrier, so its face farther along the axis is
    pushed further into the pins: at every position the pins' resultant on that face opposes the push more than on
    the other face (the sign test of tests/test_tilt.py, same direction as the one-way model), and so does what
    the moment adds to the untilted run's face difference (the spatial unit's discs already tilt a little under
    torque alone). The two-way push is smaller than the one-way one: each disc tilts back against its pins, less
    than the carrier (measured 0.61×), and its faces share the moment's push more evenly (measured 0.48× the
    one-way face difference on average)."""
    push = np.asarray(carrier_tilt(rv40e, 500.0).disc_shift_m(1.0))  # the discs' move per metre along the axis

    def face_difference(r):  # (positions, discs): +z face minus −z face resultant, along the push
        s = r.slice_resultant_N
        return np.einsum("ndk,k->nd", s[:, :, -1] - s[:, :, 0], push)

    loaded, base = face_difference(runs["m500"]), face_difference(runs["none"])
    assert (loaded < 0.0).all()
    added = loaded - base
    assert (added < 0.0).all()
    one = face_difference(one_way[500.0]) - face_difference(one_way[0.0])
    assert (one < 0.0).all()
    assert 0.3 < added.mean() / one.mean() < 0.9
    disc = np.linalg.norm(runs["m500"].disc_tilt_rad.mean(axis=0), axis=-1)
    car = np.linalg.norm(runs["m500"].carrier_tilt_rad.mean(axis=0))
    assert (disc < car).all() and (disc > 0.3 * car).all()


def test_an_axial_force_moves_the_carrier_along_the_axis_only(runs, rv40e):
    """Spur meshes and axial pins give the gear train no axial path to the housing: the pair alone carries an axial
    force, so the carrier moves along +z by the pair's own axial deflection, with no mean radial move or tilt
    (below 1 % of it, the tilt per radius of the pair's pitch circle). Not exactly the pair's: the gear train's own
    couple tilts the carrier (1.6e-5 rad, as 30–40 N·m on the pair alone), and a tilted pair yields more axially
    (the pair alone under 500 N with 40 N·m: 1.020× its axial deflection without; at 2000 N 1.087×, measured
    1.065× on the unit): the unit's move lies between the pair's and 1.03× it (measured 1.018×)."""
    d = runs["axial"].carrier_shift_m - runs["none"].carrier_shift_m
    pair = solve(pair_model(rv40e.bearings.main_pair), PairLoad(force_N=(0.0, 0.0, AXIAL_N))).q[2]
    r = 0.5 * rv40e.bearings.main_pair.pitch_diameter_m
    tilt = runs["axial"].carrier_tilt_rad - runs["none"].carrier_tilt_rad
    assert pair > 0.0
    assert pair <= d[:, 2].mean() <= 1.03 * pair
    assert np.abs(d[:, :2].mean(axis=0)).max() < 0.01 * pair
    assert np.abs(tilt.mean(axis=0)).max() * r < 0.01 * pair


def test_a_moment_at_zero_torque_is_the_pairs_alone_and_takes_up_free_play(rv40e):
    """Torque stepping holds the moment over the cycle. At zero torque the unit floats in its free play, so the pair
    alone carries the moment (its tilt to 1e-3); tilted, each disc is pressed into its pins on one side and the
    lost motion shrinks, as in the one-way model (measured 1.991′ → 1.933′ at 500 N·m; one-way 1.987′ → 1.915′),
    the torsional stiffness beyond the play unchanged within 1 % (measured 155.3 both)."""
    res = {}
    for m in (0.0, 500.0):
        load = OutputLoad(moment_Nm=m) if m else None
        res[m] = rvflex.run(rvflex.LostMotion(rv40e, steps=40, options=ModelOptions.spatial_rigid(MOMENT_SLICES),
                                              output_load=load))
    raw = res[500.0].raw
    zero = np.flatnonzero(raw.torque_Nm == 0.0)[0]
    assert raw.carrier_tilt_rad[zero, 0] == pytest.approx(carrier_tilt(rv40e, 500.0).tilt_rad[0], rel=1e-3)
    lm = {m: r.metrics.lost_motion_arcmin for m, r in res.items()}
    assert lm[500.0] < lm[0.0] - 0.02
    assert res[500.0].metrics.torsional_stiffness_Nm_per_arcmin == pytest.approx(
        res[0.0].metrics.torsional_stiffness_Nm_per_arcmin, rel=0.01)
    assert res[500.0].to_xarray()["carrier_tilt"].dims == ("torque_step", "tilt_axis")


def test_the_planar_model_takes_the_load_through_its_errors_not_the_solver(rv40e):
    load = OutputLoad(moment_Nm=500.0)
    planar = rvflex.LoadedTE(rv40e, output_load=load, options=ModelOptions(face_slices=MOMENT_SLICES))
    spatial = rvflex.LoadedTE(rv40e, output_load=load, options=ModelOptions.spatial_rigid())
    assert planar.solver_load is None and planar.model_errors != planar.errors
    assert spatial.solver_load is load and spatial.model_errors == spatial.errors
    model = build_reducer(rv40e, options=ModelOptions(face_slices=2))
    with pytest.raises(ValueError, match=r"output_load: only the spatial model \(options\.spatial\) carries it"):
        quasi_static(model, np.zeros(1), 100.0, output_load=load)
    with pytest.raises(ValueError, match="output_load: only the spatial model"):
        torque_stepping(model, np.array([0.0, 10.0]), output_load=load)


def test_te_of_the_spatial_model_under_a_moment_from_the_command_line(tmp_path, capsys, rv40e):
    out = tmp_path / "te"
    code = main(["te", "--reducer", "rv40e", "--spatial", "--moment", "500", "--positions", "64", "--json",
                 str(tmp_path / "te.json"), "--out", str(out)])
    assert code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "solved with the gear train (spatial model" in text and "on its main bearing pair alone 0.705′" in text
    doc = json.loads((tmp_path / "te.json").read_text())
    ld = doc["output_load"]
    assert doc["face_slices"] == MOMENT_SLICES and ld["moment_Nm"] == 500.0
    pair = carrier_tilt(rv40e, 500.0)
    assert ld["pair_carrier_tilt_arcmin"] == pytest.approx(pair.tilt_arcmin)
    assert 0.95 * pair.tilt_arcmin < ld["carrier_tilt_arcmin"] <= pair.tilt_arcmin
    assert f"the carrier tilts {ld['carrier_tilt_arcmin']:.3f}′" in text
    assert len(ld["carrier_shift_m"]) == 3 and np.asarray(ld["disc_tilt_rad"]).shape == (2, 2)
    assert (out / "pin_loads.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    import xarray as xr

    with xr.open_dataset(out / "te.nc") as ds:
        assert ds["carrier_tilt"].dims == ("position", "tilt_axis") and ds["carrier_tilt"].attrs["units"] == "rad"
        assert ds["carrier_shift"].dims == ("position", "axis")
        assert ds["disc_tilt"].dims == ("position", "disc", "tilt_axis")
        assert ds["crank_tilt"].dims == ("position", "crank")
        # the cranks tilt tens of arcseconds in their support rows under rated torque (tests/test_spatial_model.py)
        most = doc["crank_tilt_max_arcsec"]
        assert float(ds["crank_tilt"].max()) * ARCSEC_PER_RAD == pytest.approx(max(most), rel=1e-9)
        assert len(most) == 2 and all(10.0 < t < 100.0 for t in most)
        assert f"crank 1 {most[0]:.1f}″" in text
        assert ds["pin_slice_force"].dims == ("position", "disc", "slice", "pin")
        assert float(ds["carrier_tilt"].sel(tilt_axis="x").mean()) * ARCMIN_PER_RAD == pytest.approx(
            ld["carrier_tilt_arcmin"], rel=1e-3)
        assert ds.attrs["pair_carrier_tilt_rad"][0] == pytest.approx(pair.tilt_rad[0])


@pytest.mark.parametrize("command", [["lost-motion", "--steps", "40"], ["backlash"]])
def test_lost_motion_and_backlash_take_spatial(tmp_path, capsys, command):
    code = main([*command, "--reducer", "rv40e", "--spatial", "--moment", "500", "--json", str(tmp_path / "r.json")])
    assert code == 0
    assert "solved with the gear train" in capsys.readouterr().out
    ld = json.loads((tmp_path / "r.json").read_text())["output_load"]
    assert ld["carrier_tilt_rad"][0] > 0.9 * ld["pair_carrier_tilt_rad"][0] > 0.0


@pytest.mark.parametrize("argv, message", [
    (["--fidelity", "flexible"], "--spatial = True: takes rigid parts only (--fidelity rigid), got --fidelity "
                                 "flexible"),
    (["--slices", "1"], "--slices = 1: must be at least 2 with spatial"),
    (["--moment", "5000"], "--moment = 5000.0: must lie in (0, 2300] N·m (the allowable moment of rv40e)"),
])
def test_what_spatial_cannot_take_is_a_one_line_error(tmp_path, capsys, argv, message):
    code = main(["te", "--reducer", "rv40e", "--spatial", "--positions", "32", "--out", str(tmp_path / "o"), *argv])
    assert code == 2
    err = capsys.readouterr().err
    assert message in " ".join(err.split())
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()

"""A tilting moment on the output and the pin contact along the face width (rvflex.tilt, face_slices)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import rvflex
from rvflex import catalog
from rvflex.cli import main
from rvflex.geometry.formulas import ARCSEC_PER_RAD
from rvflex.model import build_reducer
from rvflex.options import ModelOptions
from rvflex.solve import quasi_static
from rvflex.spec import SpecError
from rvflex.tilt import OutputLoad, carrier_tilt, gear_train_moment_Nm, tilted_errors


def _order(te_rad, order):
    a = np.fft.rfft(te_rad * ARCSEC_PER_RAD)
    return 2.0 * abs(a[order]) / len(te_rad)


@pytest.mark.parametrize("unit", ["rv40e", "rv80e", "rv160n"])
def test_the_contact_in_slices_gives_the_planar_unit(unit):
    """Without a moment every slice of a disc sits at the same gap and carries its share of the width, so the
    sliced model is the planar one: same TE and wind-up (the line law's approach depends on the force per unit
    width alone), each pin's slices summing to its planar force."""
    spec = catalog.load(unit)
    th = np.linspace(0.0, 2 * math.pi * spec.ratio / 4, 97)
    runs = {}
    for ns in (1, 3):
        model = build_reducer(spec, options=ModelOptions(face_slices=ns))
        runs[ns] = quasi_static(model, th, spec.rated_torque_Nm)
    plain, sliced = runs[1], runs[3]
    assert np.abs(sliced.te_rad - plain.te_rad).max() * ARCSEC_PER_RAD < 1e-6
    np.testing.assert_allclose(sliced.pin_force_N, plain.pin_force_N, rtol=1e-7, atol=1e-6)
    assert sliced.pin_slice_force_N.shape == (len(th), spec.cycloid.disc_count, 3, spec.cycloid.pin_count)
    np.testing.assert_allclose(sliced.pin_slice_force_N, np.repeat(plain.pin_force_N[:, :, None, :] / 3, 3, axis=2),
                               rtol=1e-7, atol=1e-6)


def test_the_sliced_contact_on_fe_discs_gives_the_planar_unit(coarse_disc):
    """Each slice of an FE disc's contact carries the flank's in-plane modal motion: untilted, three slices give the
    planar FE model's TE and pin forces."""
    spec, red = coarse_disc
    th = np.linspace(0.0, 2 * math.pi * spec.ratio / 8, 33)
    runs = []
    for ns in (1, 3):
        options = dataclasses.replace(ModelOptions.flexible_discs(), discs=red.settings, face_slices=ns)
        runs.append(quasi_static(build_reducer(spec, options=options, reduced_disc=red), th, spec.rated_torque_Nm))
    assert np.abs(runs[1].te_rad - runs[0].te_rad).max() * ARCSEC_PER_RAD < 1e-6
    np.testing.assert_allclose(runs[1].pin_force_N, runs[0].pin_force_N, rtol=1e-7, atol=1e-5)


def test_lost_motion_of_the_sliced_contact_is_the_planar_one(rv40e):
    plain = rvflex.run(rvflex.LostMotion(rv40e, steps=40)).metrics
    sliced = rvflex.run(rvflex.LostMotion(rv40e, steps=40, options=ModelOptions(face_slices=3))).metrics
    assert sliced.lost_motion_arcmin == pytest.approx(plain.lost_motion_arcmin, abs=1e-6)
    assert sliced.torsional_stiffness_Nm_per_arcmin == pytest.approx(plain.torsional_stiffness_Nm_per_arcmin,
                                                                     rel=1e-6)


@pytest.fixture(scope="module")
def rv40e():
    return catalog.load("rv40e")


@pytest.fixture(scope="module")
def tilted_runs(rv40e):
    """RV-40E at rated torque, 4 slices, 256 positions per output revolution: no moment, 250 and 500 N·m."""
    th = np.linspace(0.0, 2 * math.pi * rv40e.ratio, 257)[:-1]
    out = {}
    for moment in (0.0, 250.0, 500.0):
        errors = tilted_errors(None, carrier_tilt(rv40e, moment)) if moment else None
        model = build_reducer(rv40e, errors, options=ModelOptions(face_slices=4))
        out[moment] = quasi_static(model, th, rv40e.rated_torque_Nm)
    return out


def test_the_tilted_sliced_model_steps_as_exudyn_solves_it(rv40e, monkeypatch):
    """The sliced contacts are ordinary contact elements of the Exudyn system: its own static solver (the model of
    record) gives the compiled step's TE and slice forces under a moment."""
    from rvflex import solve

    errors = tilted_errors(None, carrier_tilt(rv40e, 1000.0))
    th = np.linspace(0.0, 2 * math.pi * rv40e.ratio / 39, 9)  # one sweep of the load zone: the tilt's ripple
    runs = {}
    for choice in ("compiled", "exudyn"):
        monkeypatch.setenv(solve.SOLVER_ENV, choice)
        runs[choice] = quasi_static(build_reducer(rv40e, errors, options=ModelOptions(face_slices=3)), th,
                                    rv40e.rated_torque_Nm)
    assert runs["compiled"].compiled is not None and runs["exudyn"].compiled is None
    assert np.abs(runs["compiled"].te_rad - runs["exudyn"].te_rad).max() * ARCSEC_PER_RAD < 1e-3
    np.testing.assert_allclose(runs["compiled"].pin_slice_force_N, runs["exudyn"].pin_slice_force_N, rtol=1e-5,
                               atol=1e-2)
    np.testing.assert_allclose(runs["compiled"].slice_resultant_N, runs["exudyn"].slice_resultant_N, rtol=1e-5,
                               atol=1e-2)
    assert np.ptp(runs["exudyn"].te_rad) * ARCSEC_PER_RAD > 5.0


def test_the_carrier_tilts_with_the_moment_on_its_pair(rv40e):
    """The pair's tilt stiffness is positive (the tilt points along the moment) and the tilt turns with the
    moment's direction; the catalogue figure it gives (rvflex moment-rigidity) is of the order of 10³ N·m/′."""
    for angle in (0.0, 1.0, 2.5):
        t = carrier_tilt(rv40e, 500.0, angle)
        m = 500.0 * np.array([math.cos(angle), math.sin(angle)])
        theta = np.asarray(t.tilt_rad)
        assert theta @ m > 0.0
        cos = theta @ m / (np.linalg.norm(theta) * 500.0)
        assert cos > 0.999  # the pair is axisymmetric to 4e-5 (docs/spatial.md)
        assert 300.0 < 500.0 / t.tilt_arcmin < 3000.0


def test_a_tilt_adds_the_discs_kinematic_error_at_the_disc_tooth_order(rv40e, tilted_runs):
    """The two discs sit on either side of the pair's centre, so a tilt moves them oppositely against the pins:
    each disc's once-per-load-zone-sweep error at order z_c no longer cancels between them (the pin-ring tilt's
    signature). It is absent untilted and, a kinematic error of a µm shift, grows in proportion to the tilt."""
    zc = rv40e.cycloid.disc_teeth
    a = {m: _order(r.te_rad, zc) for m, r in tilted_runs.items()}
    assert a[0.0] < 0.05
    assert a[500.0] > 1.0
    t250, t500 = carrier_tilt(rv40e, 250.0).tilt_magnitude_rad, carrier_tilt(rv40e, 500.0).tilt_magnitude_rad
    assert a[500.0] / a[250.0] == pytest.approx(t500 / t250, rel=0.1)
    # the mean wind-up is a torsional figure: a tilt leaves it within a few tenths of an arcsecond
    mean = {m: r.te_rad.mean() * ARCSEC_PER_RAD for m, r in tilted_runs.items()}
    assert abs(mean[500.0] - mean[0.0]) < 0.5


def test_a_tilt_loads_the_face_pushed_into_the_pins(rv40e, tilted_runs):
    """A disc at axial position z moves by θ × z against the pins, so its face farther along the axis is pushed
    further into them: at every position the pins' resultant on that face opposes the push more than on the
    other face (a contact's stiffness is positive), and one face of each disc carries a larger line load than
    the other. Untilted, both faces carry the same."""
    flat = tilted_runs[0.0].pin_slice_force_N
    np.testing.assert_allclose(flat[:, :, 0], flat[:, :, -1], rtol=1e-9, atol=1e-6)
    push = np.asarray(carrier_tilt(rv40e, 500.0).disc_shift_m(1.0))  # the discs' move per metre along the axis
    r = tilted_runs[500.0].slice_resultant_N
    for d in range(rv40e.cycloid.disc_count):
        opposes = (r[:, d, -1] - r[:, d, 0]) @ push  # +z face minus −z face
        assert (opposes < 0.0).all()
    f = tilted_runs[500.0].pin_slice_force_N
    assert not np.allclose(f[:, :, 0].max(axis=(0, 2)), f[:, :, -1].max(axis=(0, 2)), rtol=0.05)


def test_the_gear_train_takes_a_small_share_of_the_moment(rv40e, tilted_runs):
    """The one-way coupling of rvflex.tilt: what the tilt adds to the pin forces' moment about the discs'
    mid-plane resists it (on average against the moment) and stays a few per cent of the moment the pair
    carries (measured: at most 9.9 N·m, 7.7 N·m on average, at 500 N·m)."""
    base = gear_train_moment_Nm(rv40e, tilted_runs[0.0].slice_resultant_N)
    added = gear_train_moment_Nm(rv40e, tilted_runs[500.0].slice_resultant_N) - base
    assert added.mean(axis=0) @ np.array([500.0, 0.0]) < 0.0
    assert np.hypot(*added.T).max() < 0.05 * 500.0


def test_a_moment_takes_up_part_of_the_free_play(rv40e):
    """Tilted, each disc is pressed into its pins on one side (the two discs on opposite sides), so part of the
    modification's free play is taken up: lost motion and backlash shrink with the moment, the torsional
    stiffness beyond the play stays within a few per cent (measured: 1.987′ → 1.915′ → 1.687′ at 0, 500 and
    2300 N·m, stiffness 159.3 → 155.6 N·m/′)."""
    runs = {m: rvflex.run(rvflex.LostMotion(rv40e, steps=60, options=ModelOptions(face_slices=2),
                                            output_load=OutputLoad(moment_Nm=m) if m else None)).metrics
            for m in (0.0, 500.0, 2300.0)}
    lm = [runs[m].lost_motion_arcmin for m in (0.0, 500.0, 2300.0)]
    assert lm[0] > lm[1] > lm[2] and lm[0] - lm[2] > 0.1
    assert runs[2300.0].torsional_stiffness_Nm_per_arcmin == pytest.approx(runs[0.0].torsional_stiffness_Nm_per_arcmin,
                                                                          rel=0.05)


def test_a_radial_force_moves_the_carrier_along_it(rv40e):
    """A radial force at the pair's centre moves the carrier along the force (the pair's radial stiffness is
    positive), and the discs with it against the pins; a force that takes a ball beyond ISO 76's static limit is
    refused, naming it."""
    for angle in (0.0, 2.0):
        t = carrier_tilt(rv40e, OutputLoad(radial_force_N=5000.0, radial_angle_rad=angle))
        d = np.asarray(t.shift_m)
        assert d @ np.array([math.cos(angle), math.sin(angle)]) > 0.99 * np.linalg.norm(d) > 1e-6
        assert t.tilt_magnitude_rad < 1e-6  # at the centre of a symmetric pair: no tilt
    with pytest.raises(SpecError, match=r"radial_force_N = 1000000\.0: .* beyond the 4\.2 GPa static limit"):
        carrier_tilt(rv40e, OutputLoad(radial_force_N=1e6))
    with pytest.raises(SpecError, match="radial_force_N = -5.0: must not be negative"):
        OutputLoad(radial_force_N=-5.0)


def test_te_under_a_moment_from_the_command_line(tmp_path, capsys):
    out = tmp_path / "te"
    code = main(["te", "--reducer", "rv40e", "--moment", "500", "--positions", "64", "--json",
                 str(tmp_path / "te.json"), "--out", str(out)])
    assert code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "the carrier tilts 0.705′" in text and "4 slices" in text
    assert (out / "pin_loads.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    import json

    doc = json.loads((tmp_path / "te.json").read_text())
    assert doc["face_slices"] == 4 and doc["output_load"]["moment_Nm"] == 500.0
    ends = np.asarray(doc["pin_loads"]["end_line_load_N_m"])
    assert ends.shape == (2, 2) and (ends > 0).all()
    import xarray as xr

    with xr.open_dataset(out / "te.nc") as ds:
        assert ds["pin_slice_force"].dims == ("position", "disc", "slice", "pin")
        assert ds.attrs["moment_Nm"] == 500.0


@pytest.mark.parametrize("argv, message", [
    (["--moment", "5000"], "--moment = 5000.0: must lie in (0, 2300] N·m (the allowable moment of rv40e)"),
    (["--moment", "-10"], "--moment = -10.0: must lie in (0, 2300] N·m"),
    (["--slices", "0"], "--slices = 0: must be an integer from 1 to 64"),
    (["--radial-force", "-5"], "--radial-force = -5.0: must not be negative"),
])
def test_bad_moment_and_slices_are_one_line_errors(tmp_path, capsys, argv, message):
    code = main(["te", "--reducer", "rv40e", "--positions", "32", "--out", str(tmp_path / "o"), *argv])
    assert code == 2
    err = capsys.readouterr().err
    assert message in " ".join(err.split())
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_a_spec_without_the_pair_is_refused_under_a_moment(rv40e):
    bare = dataclasses.replace(rv40e, bearings=dataclasses.replace(rv40e.bearings, main_pair=None))
    with pytest.raises(SpecError, match=r"bearings\.main_pair"):
        rvflex.LoadedTE(bare, output_load=OutputLoad(moment_Nm=500.0))
    rvflex.LoadedTE(bare)  # without a moment it runs as ever


def test_a_sweep_design_takes_the_slices_in_its_model_table():
    assert ModelOptions.from_table({"fidelity": "rigid", "face_slices": 3}).face_slices == 3
    with pytest.raises(SpecError, match=r"\[model\]\.face_slices = 0: must be an integer from 1 to 64"):
        ModelOptions.from_table({"face_slices": 0}, source="design.toml")
    assert rvflex.OutputLoad is OutputLoad  # the load is a top-level name beside the scenarios

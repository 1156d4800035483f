"""The main bearing pair and the moment rigidity of the output: Hertz point contact against closed
forms, the preloaded pair against the Jones single-row equation and the analytic tilt stiffness of
a ring of linear elements, the physics the figure must show (preload stiffens, contact loss
softens, sign symmetry, back-to-back stiffer than face-to-face), the Exudyn carrier against the
numpy solution, and the specs' new optional section."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from rvflex import catalog
from rvflex.contact.angular_contact import (
    PairLoad,
    ball_raceway_contacts,
    hertz_point_contact,
    pair_model,
    solve,
)
from rvflex.scenarios.moment_rigidity import MomentRigidity
from rvflex.spec import AngularContactPair, SpecError, dumps_spec, loads_spec

E, NU = 2.19e11, 0.3


@pytest.fixture(scope="module")
def rv40e():
    return catalog.load("rv40e")


@pytest.fixture(scope="module")
def pair(rv40e):
    return rv40e.bearings.main_pair


# --------------------------------------------------------------------------- Hertz point contact


def test_ball_on_flat_is_the_hertz_sphere_closed_form():
    d = 0.008
    c = hertz_point_contact((2 / d, 2 / d, 0.0, 0.0), E, NU)
    e_star = E / (2 * (1 - NU**2))  # two bodies of one material
    assert c.ellipticity == 1.0
    assert c.stiffness_N_m1p5 == pytest.approx(4 / 3 * e_star * math.sqrt(d / 2), rel=1e-12)
    # contact radius a = (3QR/(4E*))^(1/3), peak pressure 3Q/(2πa²)
    q = 100.0
    a = (3 * q * (d / 2) / (4 * e_star)) ** (1 / 3)
    assert c.semi_axes_m(q)[0] == pytest.approx(a, rel=1e-12)
    assert c.peak_pressure_Pa(q) == pytest.approx(1.5 * q / (math.pi * a * a), rel=1e-12)


def test_groove_contact_ellipticity_matches_brewe_hamrock(pair):
    # Brewe & Hamrock's fit k = 1.0339 (Ry/Rx)^0.636 is quoted within 3 % of the exact ellipticity
    d, dm, alpha = pair.ball_diameter_m, pair.pitch_diameter_m, pair.contact_angle_rad
    gamma = d * math.cos(alpha) / dm
    inner, outer = ball_raceway_contacts(pair)
    for c, rx_inv, ry_inv in ((inner, 2 / d + 2 / d * gamma / (1 - gamma), 2 / d - 1 / (pair.inner_conformity * d)),
                              (outer, 2 / d - 2 / d * gamma / (1 + gamma), 2 / d - 1 / (pair.outer_conformity * d))):
        assert c.ellipticity == pytest.approx(1.0339 * (rx_inv / ry_inv) ** 0.636, rel=0.03)
    # a ball in a groove is stiffer than on a flat, and the closer the groove's conformity, the stiffer
    flat = hertz_point_contact((2 / d, 2 / d, 0.0, 0.0), E, NU).stiffness_N_m1p5
    assert inner.stiffness_N_m1p5 > flat and outer.stiffness_N_m1p5 > flat
    looser, _ = ball_raceway_contacts(dataclasses.replace(pair, inner_conformity=0.53))
    assert looser.stiffness_N_m1p5 < inner.stiffness_N_m1p5


# --------------------------------------------------------------------------- the preloaded pair


def test_preload_state_carries_the_preload_and_stays_centred(pair):
    model = pair_model(pair)
    state = solve(model, PairLoad())
    assert np.abs(state.q[:3]).max() < 1e-12 and np.abs(state.q[3:]).max() < 1e-11
    for row in (0, 1):
        sel = model.row == row
        axial = (state.ball_load_N[sel] * np.sin(state.contact_angle_rad[sel])).sum()
        assert axial == pytest.approx(pair.preload_N, rel=1e-9)
    # the preloaded contact angle is above the nominal one (the rows are pressed together)
    assert np.all(state.contact_angle_rad > pair.contact_angle_rad)


def test_single_row_axial_load_follows_jones_equation(pair):
    """No preload, axial force: one row carries it, the other lifts off; the loaded row obeys
    F = Z·K·A^1.5·(cos α₀/cos α − 1)^1.5·sin α with tan α = (A sin α₀ + δ_a)/(A cos α₀)."""
    free = dataclasses.replace(pair, preload_N=0.0)
    model = pair_model(free)
    a, a0, z = model.centre_distance_m, free.contact_angle_rad, free.balls_per_row
    for force in (500.0, 5000.0, 20000.0):
        state = solve(model, PairLoad(force_N=(0.0, 0.0, force)))
        loaded = state.ball_load_N > 0
        assert loaded.sum() == z and len(set(model.row[loaded])) == 1
        d_axial = abs(state.q[2])
        alpha = math.atan((a * math.sin(a0) + d_axial) / (a * math.cos(a0)))
        jones = z * model.stiffness * a**1.5 * (math.cos(a0) / math.cos(alpha) - 1) ** 1.5 * math.sin(alpha)
        assert jones == pytest.approx(force, rel=1e-8)
        assert state.contact_angle_rad[loaded] == pytest.approx(alpha, rel=1e-9)


def _tilt_stiffness_of_linear_ring(model, q0, length0) -> float:
    """Analytic tilt stiffness (N·m/rad) of the two rows of linear elements at the preloaded state:
    Σ_rows [k·(n/2)·ℓ² + (Q₀/L₀)·(n·z² + (n/2)·r² − (n/2)·ℓ²)], ℓ = |z|·cos α' + r·sin α', from
    Σ sin²ψ = n/2 over n equally spaced elements; the second term is the preloaded elements'
    lateral (geometric) stiffness."""
    n = model.pair.balls_per_row
    total = 0.0
    for row in (0, 1):
        p = model.inner_centres_m[model.row == row][0]
        v = model.outer_centres_m[model.row == row][0] - p
        r, z = math.hypot(p[0], p[1]), p[2]
        alpha = math.asin(abs(v[2]) / np.linalg.norm(v))
        lever = abs(z) * math.cos(alpha) + r * math.sin(alpha)
        total += model.stiffness * n / 2 * lever**2 + q0 / length0 * (n * z**2 + n / 2 * r**2 - n / 2 * lever**2)
    return total


def test_linear_elements_give_the_analytic_ring_tilt_stiffness(pair):
    k = 2.0e8
    model = pair_model(pair, law="linear", linear_stiffness_N_m=k)
    zero = solve(model, PairLoad())
    q0 = float(zero.ball_load_N[0])
    length0 = float(np.linalg.norm(model.outer_centres_m[0] - model.inner_centres_m[0]))
    analytic = _tilt_stiffness_of_linear_ring(model, q0, length0)
    assert zero.tilt_stiffness_Nm_rad() == pytest.approx(analytic, rel=1e-12)
    # and the solved tilt under a small moment (no ball unloads, geometric nonlinearity ~1e-7)
    m = 1.0
    state = solve(model, PairLoad(moment_Nm=(m, 0.0)))
    assert state.balls_in_contact == model.n_balls
    assert state.q[3] == pytest.approx(m / analytic, rel=1e-6)


def test_preload_raises_the_moment_rigidity(rv40e, pair):
    figures = []
    for factor in (0.0, 0.5, 1.0, 2.0):
        spec = dataclasses.replace(rv40e, bearings=dataclasses.replace(
            rv40e.bearings, main_pair=dataclasses.replace(pair, preload_N=factor * pair.preload_N)))
        model = pair_model(spec.bearings.main_pair)
        figures.append(solve(model, PairLoad(moment_Nm=(100.0, 0.0))).q[3])
    tilt = np.array(figures)
    assert np.all(np.diff(tilt) < 0), tilt  # more preload, less tilt at the same moment
    assert tilt[0] > 1.5 * tilt[2]  # a pair without preload is far softer at small moments


def test_contact_loss_softens_the_pair(pair):
    # linear elements: once the balls on one side lift off, half the ring carries the moment:
    # the tangent tilt stiffness halves (to within the preload's geometric term)
    lin = pair_model(pair, law="linear", linear_stiffness_N_m=2e8)
    k0 = solve(lin, PairLoad()).tilt_stiffness_Nm_rad()
    late = solve(lin, PairLoad(moment_Nm=(2000.0, 0.0)))
    assert late.balls_in_contact < lin.n_balls
    assert late.tilt_stiffness_Nm_rad() == pytest.approx(k0 / 2, rel=0.05)
    # Hertz: the tangent falls when balls start to lift off, before the Hertz hardening wins
    hz = pair_model(pair)
    state0 = solve(hz, PairLoad())
    after = MomentRigidity(catalog.load("rv40e"), model="pair").run().metrics.contact_loss_moment_Nm
    state = solve(hz, PairLoad(moment_Nm=(1.5 * after, 0.0)))
    assert state.balls_in_contact < hz.n_balls
    assert state.tilt_stiffness_Nm_rad() < 0.9 * state0.tilt_stiffness_Nm_rad()


def test_moment_sign_symmetry_and_direction_independence(rv40e):
    r = MomentRigidity(rv40e, steps=8, model="pair").run()
    # equal to the solver's tolerance: 1e-12 m at the balls against ~1e-5 m of tilt motion there
    assert r.tilt_rad[::-1] == pytest.approx(-r.tilt_rad, rel=1e-7, abs=1e-15)
    assert np.all(np.diff(r.tilt_rad) > 0)  # more moment, more tilt
    # a moment axis half a ball pitch away (a ball on the loaded line instead of on the tilt
    # axis): the figure moves by far less than the model's other uncertainties (measured 4e-5)
    z = rv40e.bearings.main_pair.balls_per_row
    turned = MomentRigidity(rv40e, steps=8, phase_rad=math.pi / z, model="pair").run()
    assert turned.metrics.moment_rigidity_Nm_per_arcmin == pytest.approx(
        r.metrics.moment_rigidity_Nm_per_arcmin, rel=1e-3)


def test_figure_units_are_newton_metres_per_arcminute(rv40e):
    r = MomentRigidity(rv40e, steps=4, model="pair").run()
    m = r.moment_Nm[-1]
    per_rad = 2 * m / (r.tilt_rad[-1] - r.tilt_rad[0])  # N·m/rad
    assert r.metrics.moment_rigidity_Nm_per_arcmin == pytest.approx(per_rad * math.pi / 10800, rel=1e-12)
    assert r.metrics.tilt_at_moment_arcmin == pytest.approx(r.tilt_rad[-1] * 10800 / math.pi, rel=1e-9)
    # a rigid-ring ball pair of this size: hundreds to a few thousand N·m/arcmin (~1e6–1e7 N·m/rad)
    assert 1e6 < per_rad < 1e7


def test_back_to_back_is_stiffer_in_tilt_than_face_to_face(pair):
    o = solve(pair_model(pair), PairLoad()).tilt_stiffness_Nm_rad()
    x = solve(pair_model(dataclasses.replace(pair, arrangement="face_to_face")), PairLoad()).tilt_stiffness_Nm_rad()
    assert o > 2 * x  # the O pair's pressure centres lie outside the rows, the X pair's between them


@pytest.mark.parametrize("name", catalog.names())
def test_allowable_moment_matches_its_stated_criterion(name):
    """The catalogue's allowable moments are 'the moment at which the most loaded ball reaches
    3.33 GPa, rounded down': at the allowable moment the peak pressure is at most that and, after
    rounding down by less than 3 % of the moment (pressure ~ load^(1/3)), above 3.2 GPa."""
    spec = catalog.load(name)
    state = solve(pair_model(spec.bearings.main_pair), PairLoad(moment_Nm=(spec.allowable_moment_Nm, 0.0)))
    assert 3.2e9 < state.peak_pressure_Pa.max() <= 4.2e9 / 2 ** (1 / 3)


# --------------------------------------------------------------------------- Exudyn cross-check


def test_exudyn_carrier_matches_the_numpy_pair_with_linear_elements(pair):
    from rvflex.parts.main_bearing import static_displacement

    model = pair_model(pair, law="linear", linear_stiffness_N_m=2e8)
    for load in (PairLoad(moment_Nm=(50.0, 0.0)), PairLoad(force_N=(200.0, -100.0, 300.0), moment_Nm=(30.0, -40.0))):
        numpy_q = solve(model, load).q
        exudyn_q = static_displacement(model, load)
        # same mechanics; Exudyn turns the carrier by finite (Tait–Bryan) rotations, the numpy
        # model by small ones: they part at O(θ) ≈ 1e-5 relative here
        assert exudyn_q == pytest.approx(numpy_q, rel=1e-4, abs=1e-4 * np.abs(numpy_q).max())


def test_exudyn_carrier_with_linearised_hertz_balls_has_the_pairs_tangent(pair):
    from rvflex.parts.main_bearing import static_displacement

    model = pair_model(pair)
    k0 = solve(model, PairLoad()).tilt_stiffness_Nm_rad()
    m = 2.0  # small: the Hertz pair's own nonlinearity over it is ~1e-4
    theta = static_displacement(model, PairLoad(moment_Nm=(m, 0.0)))[3]
    assert theta == pytest.approx(m / k0, rel=1e-3)


# --------------------------------------------------------------------------- specs


@pytest.mark.parametrize(("field", "value", "rule"), [
    ("preload_N", -10.0, r"preload_N = -10\.0: expected an axial force in N, from 0"),
    ("contact_angle_rad", 0.0, r"contact_angle_rad = 0\.0: must lie in \(0, π/2\)"),
    ("contact_angle_rad", math.pi / 2, r"contact_angle_rad = 1\.57\d*: must lie in \(0, π/2\)"),
    ("balls_per_row", 60, r"balls_per_row = 60: 60 balls of 8 mm do not fit on a 128 mm pitch circle"),
    ("inner_conformity", 0.5, r"inner_conformity = 0\.5: groove radius over ball diameter must lie in \(0\.5, 0\.6\]"),
    ("arrangement", "tandem", r"arrangement = 'tandem': must be one of back_to_back, face_to_face"),
])
def test_bad_pair_values_are_refused_naming_the_field(pair, field, value, rule):
    with pytest.raises(SpecError, match=rule):
        dataclasses.replace(pair, **{field: value})


def test_bad_pair_value_in_toml_names_its_table(rv40e):
    text = dumps_spec(rv40e).replace("preload_N = 1000.0", "preload_N = -5.0")
    with pytest.raises(SpecError, match=r"bearings\.main_pair\.preload_N = -5\.0"):
        loads_spec(text, "user.toml")


def test_a_spec_without_the_new_fields_loads_and_is_refused_only_where_needed(rv40e, tmp_path):
    bare = dataclasses.replace(rv40e, allowable_moment_Nm=None,
                               bearings=dataclasses.replace(rv40e.bearings, main_pair=None))
    text = dumps_spec(bare)
    assert "main_pair" not in text and "allowable_moment_Nm" not in text
    again = loads_spec(text, "user.toml")
    assert again == bare and again.bearings.main_pair is None
    with pytest.raises(SpecError, match=r"bearings\.main_pair = None: rv40e gives no main bearing pair geometry"):
        MomentRigidity(again)
    with pytest.raises(SpecError, match=r"allowable_moment_Nm = None: rv40e states no allowable moment"):
        MomentRigidity(dataclasses.replace(rv40e, allowable_moment_Nm=None))


def test_misspelled_pair_key_gets_a_suggestion(rv40e):
    text = dumps_spec(rv40e).replace("balls_per_row =", "ball_per_row =")
    with pytest.raises(SpecError, match=r"bearings\.main_pair\.ball_per_row = 40: unknown key .*'balls_per_row'"):
        loads_spec(text)


def test_pair_type_is_exported_and_validated():
    with pytest.raises(SpecError, match=r"kind = 'needle'"):
        AngularContactPair("needle", "back_to_back", 0.1, 0.03, 0.7, 30, 0.006, 0.52, 0.53, 100.0,
                           catalog.load("rv40e").materials.pins)

"""The spatial rigid model (``build_reducer`` with ``options.spatial``) and the section map it rests on
(rvflex.contact.tilt_map): the map exact against the rotation and finite differences, the tilted slice and gear
elements against finite differences, the model reduced to the planar one when its out-of-plane coordinates are
held, the free model against the planar one at rated torque, and its determinism. Solved by the compiled step
(its residual and equilibria are Exudyn's: tests/test_engine_spatial.py)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from exudyn.rigidBodyUtilities import RotXYZ2RotationMatrix

from rvflex import catalog
from rvflex.contact.tilt_map import section_force, section_pose
from rvflex.engine import compiled_step
from rvflex.geometry.formulas import ARCSEC_PER_RAD
from rvflex.model import build_reducer
from rvflex.options import ModelOptions
from rvflex.solve import quasi_static
from rvflex.spec import ErrorSpec, SpecError
from rvflex.tilt import MOMENT_SLICES


def _crank_turn(spec, n: int) -> np.ndarray:
    """``n`` input angles over one crank revolution relative to the carrier (one pin pitch of the output): the
    pin mesh's ripple period (rad)."""
    return np.linspace(0.0, 2 * math.pi * spec.ratio / spec.cycloid.pin_count, n + 1)[:-1]


@pytest.fixture(scope="module")
def rv40e():
    return catalog.load("rv40e")


@pytest.fixture(scope="module")
def loaded_spatial(rv40e):
    """The RV-40E spatial model (2 slices) solved at rated torque at input angle 0: a loaded, tilted state."""
    model = build_reducer(rv40e, options=ModelOptions.spatial_rigid(2))
    quasi_static(model, np.zeros(1), rv40e.rated_torque_Nm)
    return model


def _user_functions(model, item: int):
    o = model.mbs.GetObject(item)
    return o["forceUserFunction"]["function"], o["jacobianUserFunction"]["function"]


def _central_jacobian(force, q: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """−∂f/∂q (Exudyn's left-hand-side convention) by central differences."""
    out = np.empty((len(q), len(q)))
    for j, h in enumerate(steps):
        e = np.zeros(len(q))
        e[j] = h
        out[:, j] = -(np.array(force(q + e)) - np.array(force(q - e))) / (2 * h)
    return out


def test_the_section_pose_is_the_rotated_body_point():
    """s(q) is the in-plane position of the body point (0, 0, ℓ) under Exudyn's Rxyz rotation, exactly, and the
    node's own (x, y, ψz) when untilted: the mapping adds nothing to a planar state."""
    rng = np.random.default_rng(3)
    s, jac = np.empty(3), np.empty((3, 6))
    for _ in range(20):
        q = np.concatenate([rng.normal(0, 1e-3, 3), rng.normal(0, 0.05, 2), rng.uniform(-30, 30, 1)])
        lever = rng.uniform(-0.03, 0.03)
        section_pose(q, lever, s, jac)
        p = q[:3] + RotXYZ2RotationMatrix(q[3:]) @ np.array([0.0, 0.0, lever])
        np.testing.assert_allclose(s, [p[0], p[1], q[5]], rtol=0, atol=1e-15)
        q[3:5] = 0.0
        section_pose(q, lever, s, jac)
        assert np.array_equal(s, q[[0, 1, 5]])


def test_the_tilt_map_gives_the_exact_jacobian_of_the_mapped_force():
    """A section force from a quadratic potential on s (f₃ = −A(s − s₀), K₃ = A) mapped at large tilts (0.2 rad)
    and a 30 mm lever, where the curvature term −Σ f₃ᵢ ∂²sᵢ/∂q² is large: the mapped K equals central differences
    of the mapped force to 1e-8 of its largest entry and is symmetric (the Hessian of the potential in q), and
    leaving the curvature term out would fail the comparison by orders of magnitude."""
    rng = np.random.default_rng(7)
    a = rng.normal(size=(3, 3))
    a = a @ a.T + np.diag([1e8, 1e8, 1e4])  # N/m, N/m, N·m/rad: a contact-like stiffness
    s0 = np.array([2e-3, -1e-3, 0.01])
    lever = 0.03

    def mapped(q):
        s, jac = np.empty(3), np.empty((3, 6))
        section_pose(q, lever, s, jac)
        f3 = -a @ (s - s0)
        return section_force(q, lever, f3, a)

    for _ in range(5):
        q = np.concatenate([rng.normal(0, 1e-3, 3), rng.uniform(-0.2, 0.2, 2), rng.uniform(-3, 3, 1)])
        f, k, d = mapped(q)
        assert not d.any()
        fd = _central_jacobian(lambda x: mapped(x)[0], q, np.full(6, 1e-6))
        scale = np.abs(k).max()
        assert np.abs(k - fd).max() <= 1e-8 * scale
        assert np.abs(k - k.T).max() <= 1e-12 * scale
        s, jac = np.empty(3), np.empty((3, 6))
        section_pose(q, lever, s, jac)
        without = jac.T @ a @ jac  # the map without its curvature term
        assert np.abs(without - fd).max() > 1e-5 * scale


def test_a_tilted_slice_elements_jacobian_matches_finite_differences(loaded_spatial):
    """Both slices' elements on disc 0, their force and Jacobian user functions as Exudyn calls them, at the
    loaded state (the disc tilted ~12″): the Jacobian equals central differences of the force to 2e-5 (entries
    scaled by the diagonal, so translations in N/m and tilts and turn in N·m/rad compare alike; the line law's force
    is solved to 1e-13 and its closest point to 1e-11 rad, which leaves ~5e-6 of noise in 1e-9 m / 1e-8 rad
    differences, as tests/test_contact.py allows the planar kernel 1e-5); the axial coordinate enters neither the
    force nor the Jacobian; the public map (the kernel on :meth:`section`, then :func:`section_force`) is the
    element's force. (The line law's Jacobian is not exactly symmetric, through its flank-curvature dependence:
    the map's symmetry is tested above.)"""
    model = loaded_spatial
    idx = model.spatial_index()["disc0"]
    q = np.asarray(model.mbs.systemData.GetODE2Coordinates())[idx].copy()
    assert np.hypot(*q[3:5]) * ARCSEC_PER_RAD > 5.0  # tilted
    zero = np.zeros(6)
    for c in model.discs.contacts[:model.discs.slices]:  # disc 0, slices at levers ∓2.5 mm
        force, jacobian = _user_functions(model, c.object_index)
        k = np.array(jacobian(model.mbs, 0.0, c.object_index, q, zero, 1.0, 0.0))
        f = np.array(force(model.mbs, 0.0, c.object_index, q, zero))
        assert np.hypot(*f[:2]) > 100.0  # a loaded slice
        assert f[2] == 0.0 and not k[2].any() and not k[:, 2].any()
        fd = _central_jacobian(lambda x: force(model.mbs, 0.0, c.object_index, x, zero), q,
                               np.array([1e-9, 1e-9, 1e-9, 1e-8, 1e-8, 1e-8]))
        diag = np.abs(np.diag(k))
        diag[2] = 1.0
        keep = [0, 1, 3, 4, 5]
        err = np.abs(k - fd) / np.sqrt(np.outer(diag, diag))
        assert err[np.ix_(keep, keep)].max() < 2e-5
        assert np.abs(fd[:, 2]).max() < 1e-6 * diag.max()
        s, _ = c.section(model.reference[idx] + q)
        f3, k3, _, _, _ = c.evaluate(s)
        f6, k6, _ = section_force(model.reference[idx] + q, c.lever_m, f3, k3)
        # to the closest-point solve's tolerance: the differences above moved its warm start
        np.testing.assert_allclose(f6, f, rtol=1e-8, atol=1e-6)
        np.testing.assert_allclose(k6, k, rtol=1e-8, atol=1e-3)


def test_the_gear_mesh_on_a_tilting_crank_has_the_exact_jacobian(loaded_spatial):
    """The involute mesh whose planet is a spatial crank's gear section (29.5 mm from the crank's node), at the
    loaded state (the crank tilted ~30″): its Jacobian user function equals central differences of its force over
    the sun's (x, y, θ) and the crank's six coordinates to 1e-6 (scaled as above; measured 4e-8) and is
    symmetric (a potential law; no damping in statics)."""
    model = loaded_spatial
    h = model.cranks.meshes[0]
    assert h.planet_lever_m == model.spec.cranks.gear_axial_position_m
    qs = np.asarray(model.mbs.systemData.GetODE2Coordinates())
    q = np.concatenate([qs[model.planar_index()["sun"]], qs[model.spatial_index()["crank0"]]])
    assert np.hypot(*q[6:8]) * ARCSEC_PER_RAD > 10.0
    force, jacobian = _user_functions(model, h.mesh_object)
    zero = np.zeros(9)
    k = np.array(jacobian(model.mbs, 0.0, h.mesh_object, q, zero, 1.0, 0.0))
    f = np.array(force(model.mbs, 0.0, h.mesh_object, q, zero))
    assert np.hypot(*f[3:5]) > 100.0 and f[5] == 0.0  # the loaded mesh pushes the planet, not along the axis
    fd = _central_jacobian(lambda x: force(model.mbs, 0.0, h.mesh_object, x, zero), q,
                           np.array([1e-9, 1e-9, 1e-8, 1e-9, 1e-9, 1e-9, 1e-8, 1e-8, 1e-8]))
    diag = np.abs(np.diag(k))
    diag[5] = 1.0
    scale = np.sqrt(np.outer(diag, diag))
    assert np.abs((k - fd) / scale).max() < 1e-6
    assert np.abs((k - k.T) / scale).max() < 1e-12


@pytest.fixture(scope="module")
def planar_and_held(rv40e):
    """RV-40E at rated torque over one crank revolution (32 positions), 4 slices: the planar model and the
    spatial one with every body's z, ψx, ψy held."""
    th = _crank_turn(rv40e, 32)
    planar = quasi_static(build_reducer(rv40e, options=ModelOptions(face_slices=MOMENT_SLICES)), th,
                          rv40e.rated_torque_Nm)
    held = build_reducer(rv40e, options=ModelOptions.spatial_rigid(MOMENT_SLICES), hold_out_of_plane=True)
    return planar, quasi_static(held, th, rv40e.rated_torque_Nm), held


def test_the_held_spatial_model_is_the_planar_one(planar_and_held):
    """Untilted, every section is its node's (x, y, ψz), the two half support bearings at the same shift are the
    lumped one, and the nominal unit's two-fold symmetry leaves the carrier centred (no load on the main pair's
    radial law, which differs from the planar bushing): the TE equals the planar model's to ≤ 1e-6″ (the
    solvers' tolerances; measured ~1e-9″) and each slice's pin forces agree to 1e-5 of the peak."""
    planar, held, model = planar_and_held
    # the compiled step took both (tests/test_engine_spatial.py: its spatial residual and equilibria are Exudyn's),
    # the spatial model on as many free coordinates as the planar one
    assert held.compiled is not None and planar.compiled is not None
    assert held.compiled["free"] == planar.compiled["free"]
    assert np.abs(held.te_rad - planar.te_rad).max() * ARCSEC_PER_RAD <= 1e-6
    assert np.abs(held.pin_slice_force_N - planar.pin_slice_force_N).max() <= 1e-5 * planar.pin_force_N.max()
    q = np.asarray(model.mbs.systemData.GetODE2Coordinates())
    for name, idx in model.spatial_index().items():
        assert np.abs(q[idx[2:5]]).max() < 1e-20, name  # held: z, ψx, ψy (to the constraints' round-off)
    assert np.abs(q[model.spatial_index()["carrier"][:2]]).max() < 1e-12


@pytest.mark.parametrize("unit", ["rv40e", "rv80e", "rv160n"])
def test_the_free_spatial_model_winds_up_a_little_more_than_the_planar_one(unit):
    """Free out of the plane, at rated torque, no moment and no axial force: the TE ripple agrees with the planar
    model's within 0.1″ (measured 0.004″, 0.082″, 0.008″ for the RV-40E, RV-80E, RV-160N over one crank revolution,
    4 slices) and the mean wind-up is larger by 1–3 % (measured 1.87 %, 2.57 %, 1.74 %).

    Why larger: the two discs' pin resultants are opposite, so each crank carries a couple between its eccentric
    planes that tilts it in its support pair (36–61″ measured), moving each eccentric along its own disc's load, and
    the discs tilt against their needles (7–16″), loading their pins' faces unequally. The planar model has neither
    compliance. With the cranks' tilt held (each support bearing 5e9 N·m/rad in tilt) the difference falls below
    0.5 % (measured 0.18 %, 0.21 %, 0.18 %: the discs' own tilt is what remains), so the support pairs' tilt stiffness is what sets it: the
    tapered rows' radial stiffness over the span between their pressure centres (tests/test_tapered_roller.py)."""
    spec = catalog.load(unit)
    th = _crank_turn(spec, 32)
    planar = quasi_static(build_reducer(spec, options=ModelOptions(face_slices=MOMENT_SLICES)), th,
                          spec.rated_torque_Nm)
    model = build_reducer(spec, options=ModelOptions.spatial_rigid(MOMENT_SLICES))
    spatial = quasi_static(model, th, spec.rated_torque_Nm)
    gap = spatial.te_rad.mean() / planar.te_rad.mean() - 1.0
    assert 0.01 < gap < 0.03, gap
    assert abs(np.ptp(spatial.te_rad) - np.ptp(planar.te_rad)) * ARCSEC_PER_RAD < 0.1
    b = spec.bearings
    held = dataclasses.replace(spec, bearings=dataclasses.replace(
        b, crank_support_pair=None, crank_support=dataclasses.replace(b.crank_support, tilt_stiffness_Nm_rad=1e10)))
    held_gap = quasi_static(build_reducer(held, options=ModelOptions.spatial_rigid(MOMENT_SLICES)), th,
                            spec.rated_torque_Nm).te_rad.mean() / planar.te_rad.mean() - 1.0
    assert 0.0 < held_gap < 0.005, held_gap
    q = np.asarray(model.mbs.systemData.GetODE2Coordinates())
    index = model.spatial_index()
    crank_tilt = max(np.hypot(*q[index[f"crank{k}"][3:5]]) for k in range(spec.cranks.count)) * ARCSEC_PER_RAD
    assert 10.0 < crank_tilt < 100.0, crank_tilt
    # the run's record of each crank's tilt (its axis' slope) is the last state's at the last step
    assert spatial.crank_tilt_rad.shape == (len(th), spec.cranks.count)
    assert np.nanmax(spatial.crank_tilt_rad[-1]) * ARCSEC_PER_RAD == pytest.approx(crank_tilt, rel=1e-6)
    # a disc's slices carry unequal loads once it tilts (equal in the planar model: test_tilt.py)
    faces = spatial.pin_slice_force_N[:, 0].sum(axis=-1)
    assert np.all(np.abs(faces[:, -1] - faces[:, 0]) > 1e-3 * faces.mean())


@pytest.mark.parametrize("unit", ["rv40e", "rv80e", "rv160n"])
def test_the_crank_tilt_moves_the_planet_gear_in_its_mesh(unit):
    """On the perfect-geometry unit (no modification, no clearances) the spatial TE carries a component n_c times
    per crank revolution against the carrier (order n_c·z_b: 80, 80, 120), measured 0.36″, 0.49″, 0.11″, which the
    planar model has not. Its cause: each crank tilts in its support pair under the couple of its two eccentrics,
    and its planet gear, ``gear_axial_position_m`` outboard of the discs' mid-plane, moves along the first stage's
    line of action, turning the crank. With the gear in the mid-plane the component vanishes (≤ 0.003″ measured)
    and the spatial TE ripple is the planar one's (within 0.004″ measured; 0.02″ asserted)."""
    from rvflex.scenarios.loaded_te import perfect_spec

    spec = perfect_spec(catalog.load(unit))
    centred = dataclasses.replace(spec, cranks=dataclasses.replace(spec.cranks, gear_axial_position_m=0.0))
    th = _crank_turn(spec, 32)  # one crank revolution against the carrier: the component is its harmonic n_c

    def harmonic(model) -> tuple[float, float]:
        te = quasi_static(model, th, spec.rated_torque_Nm).te_rad * ARCSEC_PER_RAD
        return 2.0 * abs(np.fft.rfft(te)[spec.cranks.count]) / te.size, float(np.ptp(te))

    planar = harmonic(build_reducer(spec, options=ModelOptions(face_slices=MOMENT_SLICES)))
    as_built = harmonic(build_reducer(spec, options=ModelOptions.spatial_rigid()))
    in_plane = harmonic(build_reducer(centred, options=ModelOptions.spatial_rigid()))
    assert as_built[0] > 0.08 and as_built[0] > 20.0 * planar[0], (as_built, planar)
    assert in_plane[0] < 0.01 and abs(in_plane[1] - planar[1]) < 0.02, (in_plane, planar)


def test_building_and_solving_twice_gives_identical_results(rv40e):
    """Two builds of the same spatial model solve to bit-identical TE, tilts and pin forces; a run adds no
    Exudyn item."""
    th = _crank_turn(rv40e, 8)
    runs, states = [], []
    for _ in range(2):
        model = build_reducer(rv40e, options=ModelOptions.spatial_rigid(MOMENT_SLICES))
        items = model.item_count
        runs.append(quasi_static(model, th, rv40e.rated_torque_Nm))
        assert model.item_count == items
        states.append(np.asarray(model.mbs.systemData.GetODE2Coordinates()).copy())
    assert np.array_equal(runs[0].te_rad, runs[1].te_rad)
    assert np.array_equal(runs[0].pin_slice_force_N, runs[1].pin_slice_force_N)
    assert np.array_equal(states[0], states[1])


def test_the_spatial_index_and_the_compiled_step(loaded_spatial):
    """Six coordinates per spatial body (x y z ψx ψy ψz), the planar index their (x, y, ψz); the compiled step
    takes the spatial model, every spatial coordinate free."""
    model = loaded_spatial
    planar, spatial = model.planar_index(), model.spatial_index()
    assert set(spatial) == {"carrier", "crank0", "crank1", "disc0", "disc1"} and "sun" in planar
    for name, idx in spatial.items():
        assert len(idx) == 6 and np.array_equal(planar[name], idx[[0, 1, 5]])
    assert model.output_index == spatial["carrier"][5]
    step = compiled_step(model)
    assert model.spatial and step is not None
    assert set(np.concatenate(list(spatial.values()))) <= set(step.d["free"])


def test_what_the_spatial_model_cannot_take_is_refused_in_one_line(rv40e):
    """(Beam cranks: tests/test_spatial_spec.py.)"""
    with pytest.raises(SpecError) as info:
        build_reducer(rv40e, ErrorSpec(main_bearing_clearance_m=2e-6), options="spatial")
    assert info.value.field == "errors.main_bearing_clearance_m" and "\n" not in str(info.value)
    no_span = dataclasses.replace(rv40e, cranks=dataclasses.replace(rv40e.cranks, support_span_m=None))
    with pytest.raises(SpecError) as info:
        build_reducer(no_span, options="spatial")
    assert info.value.field == "cranks.support_span_m" and "options.spatial needs" in str(info.value)
    with pytest.raises(ValueError, match="hold_out_of_plane: applies to the spatial model only"):
        build_reducer(rv40e, hold_out_of_plane=True)

"""The compiled quasi-static step (rvflex.engine with rvflex.engine3d) on the spatial rigid model against Exudyn, the
model of record: the same residual and Jacobian at a loaded, displaced and tilted state, the same equilibria along
a run (with a tilting moment and an axial force on the output), runs of steps equal to the step-by-step loop, and
no compiled step for a 3D connector it has no law for."""

import numpy as np
import pytest

from rvflex.api import load_reducer
from rvflex.bench_te import clearance_errors
from rvflex.model import build_reducer
from rvflex.options import ModelOptions
from rvflex.tilt import OutputLoad
from tests.test_engine import _exudyn_residual

ARCSEC_PER_RAD = 206264.806
UNITS = ["rv40e", "rv80e", "rv160n"]


def _load(spec) -> OutputLoad:
    """Half the allowable tilting moment, about an axis 0.3 rad from +x, and a 2 kN axial force."""
    return OutputLoad(moment_Nm=0.5 * spec.allowable_moment_Nm, moment_angle_rad=0.3, axial_force_N=2000.0)


def _theta(spec, n: int) -> np.ndarray:
    """n input angles over two crank turns relative to the carrier."""
    return np.linspace(0.0, 4 * np.pi * spec.nominal_ratio / spec.cycloid.pin_count, n, endpoint=False)


@pytest.mark.parametrize("unit", UNITS)
def test_the_compiled_spatial_residual_and_jacobian_are_exudyns(unit):
    """Seed 001's clearances, 70 % of rated torque with half the allowable moment and 2 kN axial on the output,
    at the loaded equilibrium moved by 1 µm / 1e-6 rad in every coordinate and tilted by 2e-5 rad (carrier, cranks
    and discs each by its own amount): bearings inside and beyond their clearances, pins of every slice in and out
    of contact. The compiled force equals Exudyn's residual (its ConnectorRigidBodySpringDamper bushings, the
    pair element, the slices' and meshes' user functions) to 1e-9 of its largest entry. The compiled Jacobian
    equals Exudyn's to 3e-5 of its largest entry (~1e9):
    Exudyn differentiates the bushings by forward differences of h ≈ 1 nm, whose error ½·h·∂²F/∂d² reaches
    ½·1e-9 m·k/ε ≈ 2e4 N/m at a needle bearing just beyond its 12 µm clearance (k = 5.1e8 N/m; measured 8.5e3 on
    the RV-40E), and it leaves out the turning of the markers' Jacobians (F·lever ≈ 1e3 N·m/rad). The 3D bushings'
    own Jacobian (supports, needle bearings and their regularisers) equals the central differences of their force
    (step 1e-8) column by column to 1e-6 of the column's largest entry (and the quotient's rounding, 1e-9 of the
    largest entry): their tilt and lever terms (~1e4–1e7) are columns of their own, not hidden by the contact
    stiffness (~1e9) of another."""
    from rvflex import solve
    from rvflex.engine import compiled_step

    spec = load_reducer(unit)
    model = build_reducer(spec, clearance_errors(spec), ModelOptions.spatial_rigid())
    step = compiled_step(model)
    assert step is not None
    solve.quasi_static(model, np.array([0.0, 0.05]), 0.7 * spec.rated_torque_Nm, output_load=_load(spec))
    q = np.asarray(model.mbs.systemData.GetODE2Coordinates()) + model.reference
    rng = np.random.default_rng(5)
    for idx in model.spatial_index().values():
        q[idx] += rng.normal(0.0, 1e-6, 6)
        q[idx[3:5]] += rng.normal(0.0, 2e-5, 2)
    r_exu, j_exu = _exudyn_residual(model, q)
    f, kt = step.residual(q)
    free = step.d["free"]
    assert np.abs(r_exu[free]).max() > 1e2
    assert np.abs(f[free] - r_exu[free]).max() < 1e-9 * np.abs(r_exu[free]).max()
    jc = -kt[np.ix_(free, free)]
    jx = j_exu[np.ix_(free, free)]
    assert np.abs(jc - jx).max() < 3e-5 * np.abs(jx).max()
    # the 3D bushings alone (no contact kernel, whose closest-point solves leave ~1e-7 N of noise in a difference
    # quotient), column by column
    from rvflex.engine3d import bushings3d, workspace3d

    b3 = tuple(step.d[k] for k in ("b3_idx", "b3_slot", "b3_first", "b3_lp", "b3_kind", "b3_par"))
    # two supports and a needle bearing per disc on each crank, each with its Cartesian regulariser on its points
    assert len(b3[0]) == (2 + spec.cycloid.disc_count) * spec.cranks.count and np.all(b3[4] == 3)

    def bushings(qa):
        f3, k3 = np.zeros(len(qa)), np.zeros((len(qa), len(qa)))
        bushings3d(qa, b3, f3, k3, workspace3d(len(b3[2])))
        return f3, k3

    _, kb = bushings(q)
    h = 1e-8  # the difference quotient's error: O(h²), 2e-7 of a column here (2e-5 at h = 1e-7)
    jd = np.zeros_like(kb)
    for j in free:
        for sign in (1.0, -1.0):
            qq = q.copy()
            qq[j] += sign * h
            jd[:, j] -= sign * bushings(qq)[0] / (2 * h)
    kb, jd = kb[np.ix_(free, free)], jd[np.ix_(free, free)]
    scale = np.abs(jd).max(axis=0)
    moved = scale > 0.0
    assert moved.sum() >= 5 * (1 + 2 * spec.cranks.count)  # every body's coordinates but a free spin
    # the quotient's rounding: the markers' absolute positions (~0.1 m) carry ~1e-17 m, times the stiffest
    # bushing (~1e9 N/m) over the step: ~1 N/m, 1e-9 of the largest entry
    assert np.all(np.abs(kb - jd).max(axis=0)[moved] <= 1e-6 * scale[moved] + 1e-9 * scale.max())
    assert np.all(kb[:, ~moved] == 0.0)


@pytest.mark.parametrize("unit", UNITS)
@pytest.mark.parametrize("loaded", ["torque", "moment", "axial", "moment-and-axial"])
def test_compiled_spatial_steps_reach_exudyns_equilibria(unit, loaded):
    """Seed 001's errors at rated torque over two crank turns relative to the carrier (32 positions), the output
    carrying the torque alone, half the allowable moment, a 2 kN axial force, or both: the default run (compiled
    steps) gives Exudyn's static solver's TE at every step within 1e-4″, the carrier's and every disc's tilt within
    1e-3 of the largest, the carrier's shift within 1e-9 m and the pin forces of every slice within 1 N."""
    from rvflex import solve

    spec = load_reducer(unit)
    theta = _theta(spec, 32)
    full = _load(spec)
    load = {"torque": None, "moment": OutputLoad(moment_Nm=full.moment_Nm, moment_angle_rad=full.moment_angle_rad),
            "axial": OutputLoad(axial_force_N=full.axial_force_N), "moment-and-axial": full}[loaded]
    opts = ModelOptions.spatial_rigid()
    fast = solve.quasi_static(build_reducer(spec, clearance_errors(spec), opts), theta, spec.rated_torque_Nm,
                              output_load=load)
    exudyn = solve.quasi_static(build_reducer(spec, clearance_errors(spec), opts), theta, spec.rated_torque_Nm,
                                chord_newton=False, output_load=load)
    continuation = len(solve.REGULARISER_CONTINUATION_NM_RAD) + len(solve.LOAD_CONTINUATION)
    assert fast.compiled is not None and fast.compiled["fallbacks"] <= continuation
    assert fast.compiled["free"] == 6 * (1 + spec.cranks.count + spec.cycloid.disc_count)
    assert np.ptp(fast.te_rad) * ARCSEC_PER_RAD > 1.0
    assert np.abs(fast.te_rad - exudyn.te_rad).max() * ARCSEC_PER_RAD < 1e-4
    for name in ("carrier_tilt_rad", "disc_tilt_rad"):
        a, b = getattr(fast, name), getattr(exudyn, name)
        assert np.all(np.isfinite(a)) and np.abs(b).max() > 1e-6
        assert np.abs(a - b).max() < 1e-3 * np.abs(b).max()
    assert np.abs(fast.carrier_shift_m - exudyn.carrier_shift_m).max() < 1e-9
    if load is not None and load.moment_Nm:  # the moment tilts the carrier by a hundred µrad
        assert np.abs(fast.carrier_tilt_rad).max() > 1e-4
    if loaded == "axial":  # the pair alone carries an axial force: the carrier moves along +z
        assert fast.carrier_shift_m[:, 2].min() > 0.0
    assert np.abs(fast.pin_slice_force_N - exudyn.pin_slice_force_N).max() < 1.0


@pytest.mark.parametrize("unit", UNITS)
def test_compiled_steps_of_beam_cranks_are_exudyns(unit):
    """Beam cranks, two elements per segment, seed 001's errors, rated torque, half the allowable moment and a 2 kN
    axial force on the output, two crank turns (32 positions). The compiled step takes the segments as 3D bushings
    with the segment's torsion (the xyz angles of the stations' relative turn, as Exudyn's connector): its force is
    Exudyn's residual to 1e-9 of the largest entry at a displaced, tilted state, its equilibria Exudyn's within
    1e-4″ of TE (measured 4e-9″), and a step costs what it costs with rigid cranks, fewer than 8 contact
    evaluations beyond the first pose's continuation (the stations follow their crank's node in the guess)."""
    from rvflex import solve
    from rvflex.engine import compiled_step
    from rvflex.options import SpatialSettings

    spec = load_reducer(unit)
    theta = _theta(spec, 32)
    opts = ModelOptions.spatial_rigid(4, SpatialSettings(crank="beam", crank_elements=2))
    model = build_reducer(spec, clearance_errors(spec), opts)
    step = compiled_step(model)
    assert step is not None
    fast = solve.quasi_static(model, theta, spec.rated_torque_Nm, output_load=_load(spec))
    exudyn = solve.quasi_static(build_reducer(spec, clearance_errors(spec), opts), theta, spec.rated_torque_Nm,
                                chord_newton=False, output_load=_load(spec))
    continuation = len(solve.REGULARISER_CONTINUATION_NM_RAD) + len(solve.LOAD_CONTINUATION)
    assert fast.compiled is not None and fast.compiled["fallbacks"] <= continuation
    stations = sum(len(shaft) for shaft in model.cranks.stations)
    assert fast.compiled["free"] == 6 * (1 + stations + spec.cycloid.disc_count)
    assert np.abs(fast.te_rad - exudyn.te_rad).max() * ARCSEC_PER_RAD < 1e-4
    assert np.abs(fast.carrier_tilt_rad - exudyn.carrier_tilt_rad).max() < 1e-3 * np.abs(exudyn.carrier_tilt_rad).max()
    q = np.asarray(model.mbs.systemData.GetODE2Coordinates()) + model.reference
    rng = np.random.default_rng(7)
    q += rng.normal(0.0, 1e-7, q.size)
    r_exu, _ = _exudyn_residual(model, q)
    f, _ = step.residual(q)
    free = step.d["free"]
    assert np.abs(f[free] - r_exu[free]).max() < 1e-9 * np.abs(r_exu[free]).max()
    rigid = solve.quasi_static(build_reducer(spec, clearance_errors(spec), ModelOptions.spatial_rigid()), theta,
                               spec.rated_torque_Nm, output_load=_load(spec))
    assert fast.compiled["evaluations"] <= rigid.compiled["evaluations"] + 8 * len(theta)


def test_runs_of_compiled_spatial_steps_are_the_step_by_step_loop(monkeypatch):
    """The spatial model's recorded steps taken in compiled runs give the TE, tilts and shifts of the loop taking
    them one by one (runs that take no step), to 1e-9″ and 1e-12 rad / m, under a tilting moment."""
    from rvflex import engine, solve

    spec = load_reducer("rv40e")
    theta = _theta(spec, 96)

    def run():
        return solve.quasi_static(build_reducer(spec, clearance_errors(spec), ModelOptions.spatial_rigid()), theta,
                                  spec.rated_torque_Nm, output_load=_load(spec))

    batched = run()
    monkeypatch.setattr(engine.CompiledStep, "steps",
                        lambda self, theta, history, last_te, *args: (0, history, last_te, None))
    loop = run()
    assert np.abs(batched.te_rad - loop.te_rad).max() * ARCSEC_PER_RAD < 1e-9
    for name in ("carrier_tilt_rad", "disc_tilt_rad", "carrier_shift_m"):
        a, b = getattr(batched, name), getattr(loop, name)
        assert np.all(np.isfinite(a)) and np.abs(a - b).max() < 1e-12
    assert np.abs(batched.pin_slice_force_N - loop.pin_slice_force_N).max() < 1e-6


def test_a_spatial_connector_without_a_known_law_is_left_to_exudyn():
    """A plain rigid-body spring-damper between two spatial bodies (not rvflex's clearance law) makes the compiled
    step decline the spatial model: Exudyn's solver solves it."""
    from exudyn.itemInterface import MarkerBodyRigid, ObjectConnectorRigidBodySpringDamper

    from rvflex.engine import compiled_step

    model = build_reducer(load_reducer("rv40e"), None, ModelOptions.spatial_rigid())
    assert compiled_step(model) is not None
    mbs = model.mbs
    a = mbs.AddMarker(MarkerBodyRigid(bodyNumber=model.cranks.bodies[0], localPosition=[0.0, 0.0, 0.0]))
    b = mbs.AddMarker(MarkerBodyRigid(bodyNumber=model.discs.bodies[0], localPosition=[0.0, 0.0, 0.0]))
    mbs.AddObject(ObjectConnectorRigidBodySpringDamper(markerNumbers=[a, b], stiffness=np.eye(6)))
    mbs.Assemble()
    assert compiled_step(model) is None


def test_a_spatial_torque_cycle_is_exudyns(monkeypatch):
    """The catalogue torque cycle (input locked, 0 → ±T_r → 0 in 40 steps) on the spatial RV-40E with half the
    allowable moment held on the output: the compiled step takes every step (the torque stepping of lost motion
    and hysteresis) and its output angles and carrier tilts equal those of Exudyn's own solver within 1e-3″ (the
    torque cycles' tolerance against the model of record, tests/test_engine.py; measured 1e-6″) and 1e-3 of the
    largest tilt. (With seed 001's clearances Exudyn's solver fails in the free play near zero torque, −2 N·m,
    where the compiled step converges.)"""
    from rvflex import solve

    spec = load_reducer("rv40e")
    path = solve.hysteresis_cycle(spec.rated_torque_Nm, 40)
    runs = {}
    for choice in ("compiled", "exudyn"):
        monkeypatch.setenv(solve.SOLVER_ENV, choice)
        runs[choice] = solve.torque_stepping(build_reducer(spec, None, ModelOptions.spatial_rigid()), path,
                                             output_load=_load(spec))
    counts = runs["compiled"].compiled
    assert counts is not None and counts["fallbacks"] == 0 and runs["exudyn"].compiled is None
    a, b = (runs[k].theta_out * ARCSEC_PER_RAD for k in ("compiled", "exudyn"))
    assert np.all(np.isfinite(a)) and np.ptp(a) > 100.0
    assert np.abs(a - b).max() < 1e-3
    ta, tb = runs["compiled"].carrier_tilt_rad, runs["exudyn"].carrier_tilt_rad
    assert np.abs(ta - tb).max() < 1e-3 * np.abs(tb).max()

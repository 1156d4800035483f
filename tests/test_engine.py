"""The compiled quasi-static step (rvflex.engine) against Exudyn, the model of record: the same residual
and Jacobian at any state, the same equilibria along a run, and no compiled step for a system it does not
replicate."""

import numpy as np
import pytest

from rvflex.api import load_reducer
from rvflex.bench_te import clearance_errors
from rvflex.model import build_reducer

ARCSEC_PER_RAD = 206264.806


def _exudyn_residual(model, q_abs):
    """Exudyn's static residual (RHS − LHS of the ODE2 equations) and its Jacobian at ``q_abs``."""
    import exudyn as exu

    from rvflex.solve import _static_solver, static_settings

    ss = static_settings()
    ss.staticSolver.useLoadFactor = False
    solver = _static_solver(model, ss, q_abs)
    sd = model.mbs.systemData
    n2 = sd.ODE2Size()
    sd.SetODE2Coordinates(q_abs - model.reference, configuration=exu.ConfigurationType.Current)
    solver.ComputeNewtonResidual(model.mbs, ss)
    r = np.asarray(solver.GetSystemResidual())[:n2]
    solver.ComputeNewtonJacobian(model.mbs, ss)
    return r, np.asarray(solver.GetSystemJacobian())[:n2, :n2]


def loaded_state(model, spec, theta: float = 0.3) -> np.ndarray:
    """Absolute coordinates of ``model`` driven to input angle ``theta`` at 70 % of rated torque on a soft output
    regulariser, 3 µm / 3e-6 rad off the kinematics (seeded): bearings and pins in and out of contact."""
    mbs = model.mbs
    mbs.SetObjectParameter(model.sun.drive, "offset", theta)
    mbs.SetObjectParameter(model.carrier.regulariser, "offset", theta / model.ratio)
    mbs.SetObjectParameter(model.carrier.regulariser, "stiffness", 1e4)
    mbs.SetLoadParameter(model.carrier.load, "load", -0.7 * spec.rated_torque_Nm)
    rng = np.random.default_rng(1)
    q = model.kinematic_coordinates(theta)
    return q + rng.normal(0.0, 3e-6, q.shape)


def compiled_residual_is_exudyns(model, spec):
    """At :func:`loaded_state` the compiled force equals Exudyn's residual to rounding (1e-12 of its largest entry,
    asserted, and the state loaded); returns (the compiled step, the state, its free coordinates' indices, the
    compiled Jacobian ∂f/∂q and Exudyn's ∂r/∂q over them)."""
    from rvflex.engine import compiled_step

    step = compiled_step(model)
    assert step is not None
    q = loaded_state(model, spec)
    r_exu, j_exu = _exudyn_residual(model, q)
    f, kt = step.residual(q)
    free = step.d["free"]
    assert np.abs(r_exu[free]).max() > 1e2  # a loaded state, not an empty one
    assert np.abs(f[free] - r_exu[free]).max() < 1e-12 * np.abs(r_exu[free]).max()
    return step, q, free, -kt[np.ix_(free, free)], j_exu[np.ix_(free, free)]  # the engine's kt is −∂f/∂q


@pytest.mark.parametrize("unit", ["rv40e", "rv80e", "rv160n"])
def test_the_compiled_residual_and_jacobian_are_exudyns(unit):
    """At a loaded, perturbed state (3 µm / 3e-6 rad off the kinematics, so bearings sit inside and beyond
    their 12 µm clearances and pins in and out of contact) the compiled force equals Exudyn's residual to
    rounding (1e-12 of its largest entry) and its Jacobian Exudyn's to 1e-6 (Exudyn differentiates the
    bearing connectors numerically, relative step 1e-7)."""
    spec = load_reducer(unit)
    _, _, _, jc, jx = compiled_residual_is_exudyns(build_reducer(spec, clearance_errors(spec), "rigid"), spec)
    assert np.abs(jc - jx).max() < 1e-6 * np.abs(jx).max()


@pytest.mark.parametrize("unit", ["rv40e", "rv80e", "rv160n"])
def test_the_compiled_steps_reach_exudyns_equilibria(unit):
    """Seed 001's errors sized for the unit (12 µm crank-bearing clearances, runouts, pin errors) at rated
    load over two crank turns relative to the carrier (64 positions, contact sets changing): the default
    run (compiled steps; a first-pose continuation step they cannot take goes to Exudyn) gives the TE of Exudyn's static solver at every step within 1e-4″ (both converge
    to ~1e-10 rad) and the same pin forces within 1 N (1e-10 m against ~1e9 N/m)."""
    from rvflex import solve

    spec = load_reducer(unit)
    model = build_reducer(spec, clearance_errors(spec), "rigid")
    theta = np.linspace(0.0, 4 * np.pi * model.ratio / spec.cycloid.pin_count, 64, endpoint=False)
    fast = solve.quasi_static(model, theta, spec.rated_torque_Nm)
    exudyn = solve.quasi_static(build_reducer(spec, clearance_errors(spec), "rigid"), theta,
                                spec.rated_torque_Nm, chord_newton=False)
    # the compiled step took the run: at most the loading continuation's first-pose steps fell back to Exudyn
    continuation = len(solve.REGULARISER_CONTINUATION_NM_RAD) + len(solve.LOAD_CONTINUATION)
    assert fast.compiled is not None and fast.compiled["fallbacks"] <= continuation
    assert fast.compiled["evaluations"] >= 2 * len(theta)
    assert np.ptp(fast.te_rad) * ARCSEC_PER_RAD > 1.0
    assert np.abs(fast.te_rad - exudyn.te_rad).max() * ARCSEC_PER_RAD < 1e-4
    assert np.abs(fast.pin_force_N - exudyn.pin_force_N).max() < 1.0


def test_runs_of_compiled_steps_are_the_step_by_step_loop(monkeypatch):
    """The recorded steps taken in compiled runs (``CompiledStep.steps``: guess, Newton and checks without
    Python between steps) give the TE and pin forces of the loop taking them one by one (runs that take no
    step), to 1e-9″ and 1e-6 N (the same arithmetic in another order), on seed 001's clearances at rated load
    over four crank turns. A run that stops before a step (as at one its Newton cannot take) leaves that
    step to the loop, and the next run goes on from it: the same TE again."""
    from rvflex import engine, solve

    spec = load_reducer("rv40e")
    theta = np.linspace(0.0, 8 * np.pi * 121 / spec.cycloid.pin_count, 160, endpoint=False)

    def run():
        return solve.quasi_static(build_reducer(spec, clearance_errors(spec), "rigid"), theta, spec.rated_torque_Nm)

    batched = run()
    calls = []
    real_steps = engine.CompiledStep.steps

    def one_by_one(self, theta, history, last_te, *args):
        calls.append(len(theta))
        return 0, history, last_te, None

    monkeypatch.setattr(engine.CompiledStep, "steps", one_by_one)
    loop = run()
    assert len(calls) >= len(theta) - 2  # every recorded step after the first was offered to a run
    assert np.abs(batched.te_rad - loop.te_rad).max() * ARCSEC_PER_RAD < 1e-9
    assert np.abs(batched.pin_force_N - loop.pin_force_N).max() < 1e-6
    assert np.abs(batched.disc_torque_Nm - loop.disc_torque_Nm).max() < 1e-6
    # the discs' ring torques carry the output torque less the input's share (1/i)
    assert np.allclose(batched.disc_torque_Nm.sum(axis=1), spec.rated_torque_Nm * (1 - 1 / spec.nominal_ratio),
                       rtol=1e-4)
    assert np.ptp(batched.te_rad) * ARCSEC_PER_RAD > 1.0

    # a run that stops at step 50 (as a Newton that does not converge there would): the loop takes step 50
    def stopping(self, theta, history, last_te, max_jump, out, forces, gaps, torques, resultants, states):
        start = len(batched.te_rad) - len(theta)
        stop = max(0, 50 - start) if start <= 50 else len(theta)
        return real_steps(self, theta[:stop], history, last_te, max_jump, out, forces, gaps, torques, resultants,
                          states) if stop else (0, history, last_te, None)

    monkeypatch.setattr(engine.CompiledStep, "steps", stopping)
    stopped = run()
    assert np.abs(stopped.te_rad - loop.te_rad).max() * ARCSEC_PER_RAD < 1e-9

def test_pins_skipped_as_surely_open_change_nothing():
    """The kernel's skip of a pin whose last gap exceeds how far its centre has moved since
    (``evaluate_tracked`` with ``skip_open``) leaves the force and Jacobian of a disc exactly those of every
    pin evaluated, at loaded states a Newton iteration (1 µm, 1e-5 rad) and a whole step (0.4 mm, 0.1 rad)
    away from the recorded one; within the iteration it skips most pins (the loaded ones it never skips)."""
    from rvflex.contact import _cycloid_kernel as K
    from rvflex.solve import quasi_static

    spec = load_reducer("rv40e")
    model = build_reducer(spec, clearance_errors(spec), "rigid")
    quasi_static(model, np.linspace(0.0, 0.3, 8), spec.rated_torque_Nm, contact_states=False)
    import exudyn as exu

    c = model.discs.contacts[0]
    ri = list(c.rigid_index)
    q0 = (c.reference + np.asarray(model.mbs.GetNodeOutput(c.node, exu.OutputVariableType.Coordinates)))[ri]
    n, npin = 3, len(c.radii_m)

    def call(q, last, skip, t_cache):
        f, k, d, out = np.zeros(n), np.zeros((n, n)), np.zeros((n, n)), np.zeros((npin, K.N_OUT))
        pout, count = K.empty_points(npin)
        K.evaluate_tracked(q, np.zeros(3), c.offset_rad, c.pins_m, c.radii_m, c.profile.par, c.profile.herr,
                           c.profile.hpsi, c._law_vec, t_cache, c.phi, np.zeros(0), np.zeros(0), f, k, d, out, c.zones,
                           c.zone_window_rad, pout, count, last, skip)
        return f, k, out

    for move in (np.array([1e-6, -1e-6, 1e-5]), np.array([4e-4, 1e-4, 0.1])):
        last = np.tile([0.0, 0.0, -np.inf], (npin, 1))
        t_cache = np.full(npin, np.nan)
        _, _, out0 = call(q0, last, False, t_cache)  # records every pin
        assert np.isfinite(last[:, 2]).all() and (out0[:, K.O_FORCE] > 0).sum() >= 1
        recorded = last.copy()
        f_all, k_all, out_all = call(q0 + move, last.copy(), False, t_cache.copy())
        f_skip, k_skip, out_skip = call(q0 + move, last, True, t_cache.copy())
        np.testing.assert_array_equal(f_skip, f_all)
        np.testing.assert_array_equal(k_skip, k_all)
        np.testing.assert_array_equal(out_skip[:, K.O_FORCE], out_all[:, K.O_FORCE])
        skipped = (last == recorded).all(axis=1)  # a skipped pin's record stays as it was
        assert not (skipped & (out_all[:, K.O_FORCE] > 0)).any()
        if move[2] < 1e-4:
            assert skipped.sum() > npin // 2
        else:
            assert not skipped.any()


def test_a_run_without_pin_states_gives_the_te_of_one_with_them():
    """Without pin states the compiled runs skip the surely open pins; the TE is the same to 1e-9″ (the skipped
    pins' closest-point warm starts are older, the same minimum to rounding) on every built-in unit with seed
    001-like clearances at rated load."""
    from rvflex.solve import quasi_static

    for unit in ("rv40e", "rv80e", "rv160n"):
        spec = load_reducer(unit)
        theta = np.linspace(0.0, 2 * np.pi * spec.nominal_ratio / 4, 512, endpoint=False)
        model = build_reducer(spec, clearance_errors(spec), "rigid")
        full = quasi_static(model, theta, spec.rated_torque_Nm, contact_states=True)
        lean = quasi_static(model, theta, spec.rated_torque_Nm, contact_states=False)
        assert np.abs(full.te_rad - lean.te_rad).max() * ARCSEC_PER_RAD < 1e-9
        assert np.ptp(full.te_rad) * ARCSEC_PER_RAD > 1.0


def test_a_system_with_an_item_the_compiled_step_does_not_replicate_is_left_to_exudyn():
    """An extra connector the compiled step has no law for (a coordinate spring between two bodies) makes
    it decline the system: that model is solved by Exudyn's solver."""
    from exudyn.itemInterface import MarkerNodeCoordinate, ObjectConnectorCoordinateSpringDamper

    from rvflex.engine import compiled_step

    model = build_reducer(load_reducer("rv40e"), None, "rigid")
    assert compiled_step(model) is not None
    mbs = model.mbs
    a = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=model.cranks.nodes[0], coordinate=2))
    b = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=model.cranks.nodes[1], coordinate=2))
    mbs.AddObject(ObjectConnectorCoordinateSpringDamper(markerNumbers=[a, b], stiffness=1.0))
    mbs.Assemble()
    assert compiled_step(model) is None


def test_a_torque_cycle_the_full_newton_cannot_take_is_taken_by_the_compiled_retries(monkeypatch):
    """Stiff supports, 3 µm needle-bearing clearance and a 5 µm pitch error: out of zero torque, floating in the
    free play, the compiled full Newton cycles where a contact sets in (and Exudyn's solver from the kinematic
    guess diverges). The compiled step's retries (damped, then a kept Jacobian, then a growing load) take
    those steps without leaving compiled code, and the cycle equals the one Exudyn's own solver makes within
    1e-3″ (the engine's tolerance against the model of record)."""
    import dataclasses as dc

    from rvflex import solve
    from rvflex.diagnosis.effects import EFFECTS
    from rvflex.spec import ErrorSpec

    spec = load_reducer("rv40e")
    b = spec.bearings
    spec = dc.replace(spec, bearings=dc.replace(
        b, crank_support=dc.replace(b.crank_support, radial_stiffness_N_m=1e11),
        main=dc.replace(b.main, radial_stiffness_N_m=1e11),
        eccentric=dc.replace(b.eccentric, radial_stiffness_N_m=3e8, clearance_m=3e-6)))
    spec, errors = EFFECTS["cycloid_pitch_error"].apply(spec, ErrorSpec(), np.array([5e-6, 0.0]))
    path = solve.hysteresis_cycle(spec.rated_torque_Nm, 400)
    runs = {}
    for choice in ("compiled", "exudyn"):
        monkeypatch.setenv(solve.SOLVER_ENV, choice)
        runs[choice] = solve.torque_stepping(build_reducer(spec, errors), path)
    counts = runs["compiled"].compiled
    assert counts is not None and counts["retried"] >= 1 and counts["fallbacks"] == 0
    assert runs["exudyn"].compiled is None
    angles = {k: r.theta_out * ARCSEC_PER_RAD for k, r in runs.items()}
    assert np.all(np.isfinite(angles["compiled"]))
    assert np.max(np.abs(angles["compiled"] - angles["exudyn"])) < 1e-3


def test_a_cycle_whose_first_step_floats_at_zero_torque_starts_on_the_positive_side():
    """A calibrated RV-80E whose housing grew away from the pins (1.6 µm on the pin circle), 2 µm needle
    clearance and a 1.3 µm disc pitch error (a diagnosis's fitted values, kept to the last digit: the
    floating state is that fragile): at zero torque, out of the kinematic state, every solver fails
    (the compiled step, its chord Newton, Exudyn's solver, the continuation), as a step to zero torque
    inside the free play does. The cycle's first step is then taken at +0.2 % of the amplitude, like a
    later zero torque on the side the path comes from, and equals that torque's equilibrium."""
    import dataclasses as dc

    from rvflex import solve
    from rvflex.spec import ErrorSpec

    base = load_reducer("rv80e")
    b, m = base.bearings, base.materials
    spec = dc.replace(
        base, bearings=dc.replace(b, eccentric=dc.replace(b.eccentric, radial_stiffness_N_m=415477166.78272074)),
        materials=dc.replace(m, gears_cranks_discs=dc.replace(m.gears_cranks_discs, youngs_modulus_Pa=93829393278.03145),
                             pins=dc.replace(m.pins, youngs_modulus_Pa=99268778395.5985)))
    n = base.cycloid.pin_count - 1
    k = 2 * np.pi * np.arange(n) / n
    pitch = tuple(float(x) for x in 1.2771251654086349e-06 * np.cos(k) + 1.502479098706317e-07 * np.sin(k))
    errors = ErrorSpec(pin_circle_radius_error_m=1.566814853089541e-06,
                       eccentric_bearing_clearance_m=(2.0611840719398425e-06,) * 2 * base.cranks.count,
                       disc_pitch_error_m=(pitch, pitch))
    path = solve.hysteresis_cycle(800.0, 40)
    cycle = solve.torque_stepping(build_reducer(spec, errors), path)
    assert np.all(np.isfinite(cycle.theta_out))
    shifted = solve.torque_stepping(build_reducer(spec, errors), [solve.ZERO_TORQUE_SHIFT * 800.0, path[1]])
    assert abs(cycle.theta_out[0] - shifted.theta_out[0]) * ARCSEC_PER_RAD < 1e-3
    assert shifted.theta_out[0] > 0.0  # the positive side


@pytest.fixture(scope="module")
def fe_model_options(fe_cache):
    """Coarse FE discs (as tests/test_flexible.py's) and a coarse FE carrier: the system the compiled step
    replicates with its FFRF bodies."""
    from conftest import COARSE_DISC

    from rvflex.options import ModelOptions

    return {"discs": ModelOptions.flexible_discs().with_fe("discs", **COARSE_DISC),
            "discs and carrier": ModelOptions.flexible_discs_and_carrier().with_fe("discs", **COARSE_DISC)
            .with_fe("carrier", maxh_m=8e-3, n_modes=6, mesh_order=1),
            "discs, carrier and housing": ModelOptions.flexible_all().with_fe("discs", **COARSE_DISC)
            .with_fe("carrier", maxh_m=8e-3, n_modes=6, mesh_order=1)
            .with_fe("housing", maxh_m=8e-3, n_modes=8, mesh_order=1)}


@pytest.mark.flexible
@pytest.mark.parametrize("parts", ["discs", "discs and carrier", "discs, carrier and housing"])
def test_the_compiled_residual_of_fe_bodies_is_exudyns(fe_model_options, parts):
    """FE discs (and carrier, and housing: its pins on their seats) held in the plane, at a loaded equilibrium
    moved by 1 µm / 1e-6 rad and every
    modal coordinate by a tenth of its loaded size: the compiled force equals Exudyn's residual (FFRF
    bodies, bore and seat markers on their mesh nodes, the bearings' axial and tilt springs on the modes) to
    1e-9 of its largest entry, and its Jacobian Exudyn's to 1e-4. The carrier's crank seats tilt with its
    end plates' bending, and Exudyn turns a seat bearing's joint frame (marker 0, the seat) with them, which
    gives its radial force an axial part of tilt × force the compiled step leaves out: with the carrier the
    residuals agree to 3 × the largest seat tilt (about 1e-5 rad). Exudyn
    differentiates the bearings by forward differences of ~1 nm, which inside a bearing's 0.2 µm smoothing
    band (stiffness ramping from 0 to k = 5e8 N/m) err by up to ½·1 nm·k/(2w) ≈ 1e6 N/m, 5e-5 of the largest
    entry (2e10)."""
    from rvflex import solve
    from rvflex.engine import compiled_step

    spec = load_reducer("rv40e")
    model = build_reducer(spec, clearance_errors(spec), fe_model_options[parts])
    step = compiled_step(model)
    assert step is not None and model.modal_nodes
    theta = np.array([0.0, 0.05])
    solve.quasi_static(model, theta, 0.7 * spec.rated_torque_Nm)
    mbs = model.mbs
    q = np.asarray(mbs.systemData.GetODE2Coordinates()) + model.reference
    rng = np.random.default_rng(3)
    free = step.d["free"]
    for idx in model.planar_index().values():
        q[idx] += rng.normal(0.0, 1e-6, 3)
    for n in model.modal_nodes:
        i = mbs.GetNodeODE2Index(n)
        m = mbs.GetNode(n)["numberOfODE2Coordinates"]
        q[i:i + m] *= 1.0 + rng.normal(0.0, 0.1, m)
    r_exu, j_exu = _exudyn_residual(model, q)
    f, kt = step.residual(q)
    tilt = 0.0
    if model.flexible_carrier:  # the seats' tilt against the carrier's frame, as Exudyn's markers give it
        import exudyn as exu

        current = exu.ConfigurationType.Current
        frame = np.asarray(mbs.GetNodeOutput(model.carrier.node, exu.OutputVariableType.RotationMatrix,
                                             configuration=current)).reshape(3, 3)
        for mk in (*model.carrier.bore_markers, *model.carrier.input_seat_markers):
            rel = frame.T @ np.asarray(mbs.GetMarkerOutput(mk, exu.OutputVariableType.RotationMatrix,
                                                           configuration=current)).reshape(3, 3)
            tilt = max(tilt, float(np.hypot(rel[0, 2], rel[1, 2])))
        assert 0.0 < tilt < 1e-3
    assert np.abs(r_exu[free]).max() > 1e2
    assert np.abs(f[free] - r_exu[free]).max() < max(1e-9, 3 * tilt) * np.abs(r_exu[free]).max()
    jx, jc = j_exu[np.ix_(free, free)], -kt[np.ix_(free, free)]
    assert np.abs(jc - jx).max() < 1e-4 * np.abs(jx).max()


@pytest.mark.flexible
@pytest.mark.parametrize("parts", ["discs and carrier", "discs, carrier and housing"])
def test_compiled_fe_steps_reach_exudyns_equilibria(fe_model_options, parts):
    """Coarse FE discs and carrier (and housing), seed 001's errors (12 µm crank-bearing clearances, runouts, pin errors) at
    rated load over one crank turn relative to the carrier (24 positions): the compiled step takes every step,
    the first pose's loading included, and gives the TE of Exudyn's static solver within 1e-4″ and its pin
    forces within 1 N."""
    from rvflex import solve

    spec = load_reducer("rv40e")
    theta = np.linspace(0.0, 2 * np.pi * spec.nominal_ratio / spec.cycloid.pin_count, 24, endpoint=False)
    opts = fe_model_options[parts]
    fast = solve.quasi_static(build_reducer(spec, clearance_errors(spec), opts), theta, spec.rated_torque_Nm)
    exudyn = solve.quasi_static(build_reducer(spec, clearance_errors(spec), opts), theta, spec.rated_torque_Nm,
                                chord_newton=False)
    assert fast.compiled is not None and fast.compiled["fallbacks"] == 0
    assert np.ptp(fast.te_rad) * ARCSEC_PER_RAD > 1.0
    assert np.abs(fast.te_rad - exudyn.te_rad).max() * ARCSEC_PER_RAD < 1e-4
    assert np.abs(fast.pin_force_N - exudyn.pin_force_N).max() < 1.0

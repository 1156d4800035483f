"""Involute sun–planet mesh element (rvflex.contact.gear_mesh) on the RV-40E first stage.

Expected values are derived here from the gear geometry (base radii, line of action), not
taken from the module. Tolerances: static solves run Newton to 1e-8 of the step's initial
residual (a few N), so solver-level forces agree to ~1e-9 relative; where the model deliberately departs
from the textbook law the bound is that departure, stated at the test (contact smoothing
w = 10 nm, stiffness-variation term, second-order error geometry).
"""

from __future__ import annotations

import dataclasses as dc
import math

import exudyn as exu
import numpy as np
import pytest
from exudyn.itemInterface import (
    LoadCoordinate,
    MarkerNodeCoordinate,
    NodePoint2D,
    NodePointGround,
    NodeRigidBody2D,
    ObjectConnectorCoordinate,
    ObjectRigidBody2D,
)

from rvflex import catalog
from rvflex.contact.gear_mesh import SMOOTHING_M, add_gear_mesh, evaluate, mesh_state, normal_backlash_m
from rvflex.spec import ErrorSpec, SpecError

UM = 1e-6
ZS, ZP = 12, 36  # RV-40E sun / planet teeth


@pytest.fixture(scope="module")
def stage():
    return catalog.load("rv40e").input_stage


def _radii(stage):
    """Base radii r_b = m·z·cos α/2 (m)."""
    c = stage.module_m * math.cos(stage.pressure_angle_rad) / 2
    return c * stage.sun_teeth, c * stage.planet_teeth


def _perfect(stage, *, amplitude=True):
    """No backlash (and optionally constant stiffness): the mesh law is then exactly linear."""
    return dc.replace(stage, backlash_m=0.0,
                      mesh_stiffness_amplitude_N_m=stage.mesh_stiffness_amplitude_N_m if amplitude else 0.0)


# --------------------------------------------------------------------------- a two-gear rig


@dc.dataclass
class Rig:
    mbs: object
    sc: object
    mesh: object
    sun_torque: int  # LoadCoordinate on θ_s
    planet_torque: int  # LoadCoordinate on θ_p
    sun_angle: int | None  # coordinate constraint driving θ_s (None: sun free to turn)
    planet_angle: int | None  # coordinate constraint locking θ_p (None: planet free to turn)


def _rig(stage, *, errors=None, gamma0=0.0, sun_driven=False, planet_locked=True):
    """Sun on the axis, planet at centre distance a0 and angle gamma0; both centres held
    (bearings), sun torque- or angle-driven, planet locked or free to turn.
    Masses and inertias of seed 003 Table 5 (they matter only in the dynamic test)."""
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    a0 = stage.centre_distance_m
    ns = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0.0, 0.0, 0.0]))
    npl = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[a0 * math.cos(gamma0), a0 * math.sin(gamma0), 0.0]))
    mbs.AddObject(ObjectRigidBody2D(nodeNumber=ns, mass=0.12, inertia=7.24e-6))
    mbs.AddObject(ObjectRigidBody2D(nodeNumber=npl, mass=0.13, inertia=13.81e-6))
    ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()), coordinate=0))

    def coord(node, k):
        return mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=k))

    def fix(node, k):
        return mbs.AddObject(ObjectConnectorCoordinate(markerNumbers=[ground, coord(node, k)]))

    for node in (ns, npl):
        fix(node, 0)
        fix(node, 1)
    sun_angle = fix(ns, 2) if sun_driven else None
    planet_angle = fix(npl, 2) if planet_locked else None
    sun_torque = mbs.AddLoad(LoadCoordinate(markerNumber=coord(ns, 2), load=0.0))
    planet_torque = mbs.AddLoad(LoadCoordinate(markerNumber=coord(npl, 2), load=0.0))
    mesh = add_gear_mesh(mbs, ns, npl, stage, errors=errors)
    mbs.Assemble()
    return Rig(mbs, sc, mesh, sun_torque, planet_torque, sun_angle, planet_angle)


def _settings():
    ss = exu.SimulationSettings()
    ss.solution.file.write = False
    ss.solution.sensors.active = False
    ss.staticSolver.verboseMode = 0
    ss.staticSolver.newton.relativeTolerance = 1e-8  # rounding floor: k·eps·a ≈ 1e-8 N on a few-N residual
    ss.staticSolver.newton.adaptInitialResidual = False  # tolerance relative to the true initial residual
    ss.timeIntegration.verboseMode = 0
    return ss


def _solve(rig, *, sun=None, planet=None, sun_torque=None, planet_torque=None, guess=None):
    """One static solve (load/angle continuation): set the driven values, start from the last
    solution (optionally with a predicted [θ_s, θ_p]) and keep the result as the next start."""
    mbs, sd = rig.mbs, rig.mbs.systemData
    if sun is not None:
        mbs.SetObjectParameter(rig.sun_angle, "offset", sun)
    if planet is not None:
        mbs.SetObjectParameter(rig.planet_angle, "offset", planet)
    if sun_torque is not None:
        mbs.SetLoadParameter(rig.sun_torque, "load", sun_torque)
    if planet_torque is not None:
        mbs.SetLoadParameter(rig.planet_torque, "load", planet_torque)
    if guess is not None:
        q = sd.GetODE2Coordinates(exu.ConfigurationType.Initial)
        q[2], q[5] = guess
        sd.SetODE2Coordinates(q, exu.ConfigurationType.Initial)
    assert mbs.SolveStatic(_settings()), "static solver did not converge"
    sd.SetODE2Coordinates(sd.GetODE2Coordinates(), exu.ConfigurationType.Initial)
    sd.SetAECoordinates(sd.GetAECoordinates(), exu.ConfigurationType.Initial)
    q = sd.GetODE2Coordinates()
    return q[2], q[5], mesh_state(mbs, rig.mesh)


def _e(angle):
    return np.array([math.cos(angle), math.sin(angle)])


# --------------------------------------------------------------------------- static load path


@pytest.mark.parametrize("gamma0", [0.0, 2.3])
def test_static_torque_gives_force_over_base_radius_and_deflection_over_stiffness(stage, gamma0):
    """Perfect gears, no backlash, constant stiffness, planet locked: T on the sun gives the
    line-of-action force T/r_bs, the deflection F/k and a sun rotation δ/r_bs; the nodal
    forces are ∓F along the line of action n₊ at the base tangents (moments ∓r_b·F)."""
    s = _perfect(stage, amplitude=False)
    rbs, rbp = _radii(s)
    k = s.mesh_stiffness_mean_N_m
    rig = _rig(s, gamma0=gamma0)
    torque = 2.0  # N·m, about the sun torque per crank at 60 % of rated output torque
    th_s, th_p, st = _solve(rig, sun_torque=torque)
    force = torque / rbs
    assert st.force_N == pytest.approx(force, rel=1e-9)
    assert st.deflection_m == pytest.approx(force / k, rel=1e-9)
    assert th_s == pytest.approx(force / k / rbs, rel=1e-9)
    assert st.drive_force_N > 100 * st.coast_force_N  # positive sun torque loads the drive flank
    assert st.operating_pressure_angle_rad == pytest.approx(s.pressure_angle_rad, abs=1e-12)
    assert st.centre_line_angle_rad == pytest.approx(gamma0, abs=1e-12)
    # nodal forces: equal and opposite along the flank normals, moments r_b × force
    q = rig.mbs.systemData.GetODE2Coordinates()
    f, _, _ = evaluate(rig.mesh, q)
    n_drive = _e(gamma0 + math.pi / 2 - s.pressure_angle_rad)
    n_coast = _e(gamma0 - math.pi / 2 + s.pressure_angle_rad)
    on_planet = st.drive_force_N * n_drive + st.coast_force_N * n_coast
    np.testing.assert_allclose(f[3:5], on_planet, rtol=0, atol=1e-9 * force)
    np.testing.assert_allclose(f[0:2], -on_planet, rtol=0, atol=1e-9 * force)
    assert f[2] == pytest.approx(-rbs * force, rel=1e-9)
    assert f[5] == pytest.approx(-rbp * force, rel=1e-9)


def test_backlash_free_play_is_b_over_base_radius(stage):
    """Planet locked, sun torque cycled 0 → +2 → −2 → +2 N·m through the dead zone: every
    static solve converges, and the flank lines θ(T) extrapolated to T = 0 are b/r_bs apart.
    Bound 1e-4 relative (5 nm along the line): the smoothing shifts a loaded flank by
    w²/(4g) ≤ 0.4 nm at T ≥ 0.5 N·m; the stiffness phase changes k by < 1e-5 across the play."""
    rbs, _ = _radii(stage)
    rig = _rig(stage)
    up = [0.0, 0.01, 0.05, 0.2, 0.5, 1.0, 1.5, 2.0]
    path = up + up[::-1][1:] + [-t for t in up[1:]] + [-t for t in up[::-1][1:]] + up[1:]
    angles = {}
    for torque in path:
        th_s, _, st = _solve(rig, sun_torque=torque)
        angles.setdefault(torque, []).append(th_s)
        if torque == 0.0:  # in the dead zone: no flank carries load
            assert abs(st.deflection_m) < normal_backlash_m(stage) / 2
            assert abs(st.force_N) < 1e-6
    flank = [0.5, 1.0, 1.5, 2.0]
    pos = np.polyfit(flank, [angles[t][0] for t in flank], 1)
    neg = np.polyfit(flank, [angles[-t][0] for t in flank], 1)  # abscissa |T|
    play = np.polyval(pos, 0.0) - np.polyval(neg, 0.0)
    assert play == pytest.approx(normal_backlash_m(stage) / rbs, rel=1e-4)
    # both flanks are the same elastic line, slope 1/(k·r_bs²) with k(φ ≈ 0) = k_mean + k_amp
    # (to 3e-3: the smoothing offset w²/4g falls by 0.3 nm over the fitted 0.2 µm of deflection)
    k0 = stage.mesh_stiffness_mean_N_m + stage.mesh_stiffness_amplitude_N_m
    assert pos[0] == pytest.approx(1 / (k0 * rbs**2), rel=3e-3)
    assert neg[0] == pytest.approx(-pos[0], rel=1e-3)
    # the cycle is closed: returning to +2 N·m gives the same angle
    assert angles[2.0][-1] == pytest.approx(angles[2.0][0], abs=1e-12)


@pytest.mark.parametrize("sun_pitch, planet_pitch", [(-12 * UM, -15 * UM), (3 * UM, 0.0)])
def test_pitch_radius_errors_shrink_the_play_by_2_dr_sin_alpha(stage, sun_pitch, planet_pitch):
    """A pitch-radius (tooth-thickness) error Δr moves each flank by Δr·sin α: the play
    becomes (b − 2(Δr_s + Δr_p)·sin α)/r_bs. Seed 004's −0.012/−0.015 mm tolerances open it."""
    rbs, _ = _radii(stage)
    errors = ErrorSpec(sun_pitch_radius_error_m=sun_pitch, planet_pitch_radius_error_m=(planet_pitch, 0.0))
    rig = _rig(stage, errors=errors)
    th = {torque: _solve(rig, sun_torque=torque)[0] for torque in (0.01, 0.5, 1.0, 0.5, 0.01, -0.01, -0.5, -1.0)}
    zero_pos = 2 * th[0.5] - th[1.0]  # line through 0.5 and 1 N·m, at T = 0
    zero_neg = 2 * th[-0.5] - th[-1.0]
    play = zero_pos - zero_neg
    expected = (normal_backlash_m(stage) - 2 * (sun_pitch + planet_pitch) * math.sin(stage.pressure_angle_rad)) / rbs
    assert play == pytest.approx(expected, rel=1e-4)


def test_time_varying_stiffness_modulates_static_deflection(stage):
    """Constant sun torque, planet locked at 16 positions over one tooth pitch, no backlash:
    δ follows the potential's balance T = k(φ)·r_bs·δ + ½k'(φ)·z_s·δ², i.e. δ = T/(r_bs·k(φ))
    to 2.3e-6 relative, with k(φ) = k_mean + k_amp·cos φ; its peak-to-peak is
    T/r_bs·(1/(k_m − k_a) − 1/(k_m + k_a)) (2.4 % of the mean for seed 003's values)."""
    s = _perfect(stage)
    rbs, _ = _radii(s)
    km, ka = s.mesh_stiffness_mean_N_m, s.mesh_stiffness_amplitude_N_m
    rig = _rig(s)
    torque = 2.0
    deflection = []
    for j in range(16):
        psi = j * 2 * math.pi / ZS / 16
        th_s, _, st = _solve(rig, planet=-psi * ZS / ZP, sun_torque=torque, guess=(psi, -psi * ZS / ZP))
        phi = ZS * th_s  # γ = 0
        assert st.mesh_phase_rad == pytest.approx(phi, abs=1e-12)
        k, dk = km + ka * math.cos(phi), -ka * math.sin(phi)
        root = math.sqrt((k * rbs) ** 2 + 2 * dk * ZS * torque)
        exact = (root - k * rbs) / (dk * ZS) if dk else torque / (k * rbs)
        assert st.deflection_m == pytest.approx(exact, rel=1e-8)
        assert st.deflection_m == pytest.approx(torque / (rbs * k), rel=1e-5)
        deflection.append(st.deflection_m)
    deflection = np.array(deflection)
    ptp = torque / rbs * (1 / (km - ka) - 1 / (km + ka))
    assert np.ptp(deflection) == pytest.approx(ptp, rel=1e-3)
    assert np.argmin(deflection) == 0 and np.argmax(deflection) == 8  # stiffest at φ = 0


# --------------------------------------------------------------------------- kinematics


def test_kinematic_ratio_planet_free(stage):
    """Sun turned quasi-statically through one revolution (24 steps), planet free to turn
    against a 0.5 N·m drag: θ_p = −(z_s/z_p)·θ_s + (b/2 + g)/r_bp, g the loaded flank's
    overlap: s(g) = y, y = (F + F_coast)/k(φ), F = T_drag/r_bp (smoothed law: g = y − w²/4y).
    The stated lag (b/2 + F/k_mean)/r_bp = 9.86e-4 rad holds to (F·k_amp/k_mean² + w²/4y)/r_bp
    = 5.6e-8 rad (stiffness ripple and smoothing offset at this light 20 N load)."""
    rbs, rbp = _radii(stage)
    w = SMOOTHING_M
    rig = _rig(stage, sun_driven=True, planet_locked=False)
    drag = 0.5  # N·m against the planet's (clockwise) rotation
    force = drag / rbp
    lag_mean = (normal_backlash_m(stage) / 2 + force / stage.mesh_stiffness_mean_N_m) / rbp
    worst = 0.0
    th_p = 0.0
    for j in range(1, 25):
        th_s_set = j * 2 * math.pi / 24
        guess = (th_s_set, -th_s_set * ZS / ZP + lag_mean)
        th_s, th_p, st = _solve(rig, sun=th_s_set, planet_torque=drag, guess=guess)
        y = (force + st.coast_force_N) / st.stiffness_N_m  # the open flank's leakage, 2e-5 of F
        expected = -th_s * ZS / ZP + (normal_backlash_m(stage) / 2 + y - w * w / (4 * y)) / rbp
        assert th_p == pytest.approx(expected, abs=1e-12)
        assert st.force_N == pytest.approx(force, rel=1e-6)
        worst = max(worst, abs(th_p + th_s * ZS / ZP - lag_mean))
    assert th_p == pytest.approx(-2 * math.pi * ZS / ZP + lag_mean, abs=1e-6)  # after one sun revolution
    km, ka = stage.mesh_stiffness_mean_N_m, stage.mesh_stiffness_amplitude_N_m
    bound = (force * ka / km**2 + w**2 / (4 * y)) / rbp
    assert worst <= 1.1 * bound


def test_dynamic_run_at_speed_keeps_the_ratio(stage):
    """The element in generalized-α: sun driven at 1800 rpm for half a revolution (mesh
    frequency 360 Hz ≪ the 33 kHz mesh resonance), planet against a 0.5 N·m drag, started
    on the loaded flank. θ_p + (z_s/z_p)·θ_s stays at the static lag (b/2 + y − w²/4y)/r_bp,
    y = F/k_mean; the bound 1.5e-8 rad (0.4 nm along the line) is the k(φ) ripple
    F·k_amp/(k_mean²·r_bp) = 1.05e-8 rad plus what is left of the start transient."""
    rbs, rbp = _radii(stage)
    omega = 1800 * 2 * math.pi / 60
    rig = _rig(stage, sun_driven=True, planet_locked=False)
    mbs = rig.mbs
    drag = 0.5
    force = drag / rbp
    y = force / stage.mesh_stiffness_mean_N_m
    lag = (normal_backlash_m(stage) / 2 + y - SMOOTHING_M**2 / (4 * y)) / rbp
    mbs.SetObjectParameter(rig.sun_angle, "offsetUserFunction", lambda mbs_, t, item, offset: omega * t)
    mbs.SetObjectParameter(rig.sun_angle, "offsetUserFunction_t", lambda mbs_, t, item, offset: omega)
    mbs.SetLoadParameter(rig.planet_torque, "load", drag)
    q0 = np.zeros(6)
    q0[5] = lag
    v0 = np.zeros(6)
    v0[2], v0[5] = omega, -omega * ZS / ZP
    mbs.Assemble()
    sd = mbs.systemData
    sd.SetODE2Coordinates(q0, exu.ConfigurationType.Initial)
    sd.SetODE2Coordinates_t(v0, exu.ConfigurationType.Initial)
    ss = _settings()
    ss.timeIntegration.endTime = 0.5 / 30  # half a revolution
    ss.timeIntegration.numberOfSteps = 400
    ss.timeIntegration.generalizedAlpha.spectralRadius = 0.6  # damp the start transient numerically
    assert mbs.SolveDynamic(ss)
    q = sd.GetODE2Coordinates()
    assert q[2] == pytest.approx(math.pi, abs=1e-9)
    assert q[5] + q[2] * ZS / ZP == pytest.approx(lag, abs=1.5e-8)
    assert mesh_state(mbs, rig.mesh).force_N == pytest.approx(force, rel=1e-4)


def test_carrier_rotation_with_the_gears_gives_no_force(stage):
    """The planet carried round the sun by β (any number of turns) with both gears turning
    by β: δ stays 0 and the nodal forces are only the dead-zone leakage of the smoothing,
    2·k·w²/(4·b/2) ≈ 2e-3 N, turned with the carrier. Carried without turning the gears,
    the same β winds the mesh up by r_B·β."""
    rbs, rbp = _radii(stage)
    rig = _rig(stage)
    leak = 2 * stage.mesh_stiffness_mean_N_m * SMOOTHING_M**2 / (4 * normal_backlash_m(stage) / 2)
    a0 = stage.centre_distance_m
    f0, _, _ = evaluate(rig.mesh, np.zeros(6))
    assert np.abs(f0).max() < leak
    for beta in (0.3, 2.9, 3.3, -3.3, 7.0, -12.0, 40.0, 2 * math.pi * 25):
        q = np.array([0.0, 0.0, beta, a0 * (math.cos(beta) - 1), a0 * math.sin(beta), beta])
        st = mesh_state(None, rig.mesh, q=q)
        assert abs(st.deflection_m) < 1e-13
        assert st.centre_line_angle_rad == pytest.approx(beta, abs=1e-12)  # continuous over turns
        f, _, _ = evaluate(rig.mesh, q)
        rot = np.array([[math.cos(beta), -math.sin(beta)], [math.sin(beta), math.cos(beta)]])
        np.testing.assert_allclose(f[[0, 1]], rot @ f0[[0, 1]], rtol=0, atol=1e-9 * leak)
        np.testing.assert_allclose(f[[3, 4]], rot @ f0[[3, 4]], rtol=0, atol=1e-9 * leak)
        assert abs(f[2]) < 1e-9 * leak * rbs and abs(f[5]) < 1e-9 * leak * rbp
        if abs(beta) < math.pi:  # δ is tracked modulo 2π·r_B about the rolling estimate
            q_wound = q.copy()
            q_wound[[2, 5]] = 0.0
            wound = mesh_state(None, rig.mesh, q=q_wound)
            assert wound.deflection_m == pytest.approx(-(rbs + rbp) * beta, rel=1e-12)


# --------------------------------------------------------------------------- errors


def _te_curve(stage, errors, planet_angles):
    """Sun angle under 2 N·m with the planet locked at each angle (one rig, continuation;
    the sun's start value is predicted from the rolling kinematics)."""
    rig = _rig(stage, errors=errors)
    th_s, _, _ = _solve(rig, sun_torque=0.05)
    th_p_prev, out = 0.0, []
    for th_p in planet_angles:
        guess = th_s - (th_p - th_p_prev) * ZP / ZS
        th_s, _, _ = _solve(rig, planet=th_p, sun_torque=2.0, guess=(guess, th_p))
        th_p_prev = th_p
        out.append(th_s)
    return np.array(out)


@pytest.mark.parametrize("case", ["sun eccentricity", "sun runout", "planet eccentricity"])
def test_eccentricity_gives_once_per_revolution_te(stage, case):
    """A base-circle offset ε (turning with its gear) moves the loaded (drive) flank by its
    projection on the line of action n₊, e₊ = ε·sin(θ + φ − γ + α) for the sun and
    −ε·sin(θ_p + φ − γ + α) for the planet: full amplitude ε, and ε·sin α when the offset
    points along the centre line. With the planet locked under a constant sun torque the
    sun angle therefore carries TE = −e₊/r_bs, once per revolution of the erroneous gear.
    Bound 1e-3 of the amplitude: second-order geometry ε/a = 3e-4, stiffness-phase shift 5e-6."""
    rbs, _ = _radii(stage)
    alpha = stage.pressure_angle_rad
    errors, eps, phase, gear = {  # magnitudes of seed 001 Table 2
        "sun eccentricity": (ErrorSpec(sun_base_eccentricity_m=10 * UM, sun_base_eccentricity_phase_rad=0.5),
                             10 * UM, 0.5, "sun"),
        "sun runout": (ErrorSpec(sun_runout_m=5 * UM, sun_runout_phase_rad=2.0), 5 * UM, 2.0, "sun"),
        "planet eccentricity": (ErrorSpec(planet_base_eccentricity_m=(10 * UM, 0.0),
                                          planet_base_eccentricity_phase_rad=(1.2, 0.0)), 10 * UM, 1.2, "planet"),
    }[case]
    n = 24  # samples over one revolution of the erroneous gear
    turn = [-2 * math.pi * j / n for j in range(n)]
    planet_angles = [t * ZS / ZP for t in turn] if gear == "sun" else turn
    perfect = _te_curve(stage, None, planet_angles)
    erroneous = _te_curve(stage, errors, planet_angles)
    te = erroneous - perfect
    th = perfect if gear == "sun" else np.array(planet_angles)
    sign = 1.0 if gear == "sun" else -1.0
    expected = -sign * eps * np.sin(th + phase + alpha) / rbs  # γ = 0
    np.testing.assert_allclose(te, expected, rtol=0, atol=1e-3 * eps / rbs)
    # one harmonic per revolution of the erroneous gear, amplitude ε/r_bs
    spectrum = np.abs(np.fft.rfft(te)) * 2 / n
    assert spectrum[1] == pytest.approx(eps / rbs, rel=1e-3)
    assert spectrum[2:].max() < 1e-3 * spectrum[1]


def test_error_terms_match_their_first_order_projections(stage):
    """Each error term, at random configurations (carrier anywhere, gears rolled), moves the
    flank overlaps by its documented first-order value: the centre offsets projected on
    n₊ = e^{i(γ+π/2−α)} (drive) and n₋ = e^{i(γ−π/2+α)} (coast), pitch-radius errors by
    (Δr_s + Δr_p)·sin α on both; planet_index picks the tuple entry; the planet runout has
    phase 0. Bound: second order, 3·ε_total²/a."""
    a0 = stage.centre_distance_m
    alpha = stage.pressure_angle_rad
    errors = ErrorSpec(sun_base_eccentricity_m=10 * UM, sun_base_eccentricity_phase_rad=0.4,
                       sun_runout_m=5 * UM, sun_runout_phase_rad=-1.1, sun_pitch_radius_error_m=-12 * UM,
                       planet_base_eccentricity_m=(3 * UM, 10 * UM), planet_base_eccentricity_phase_rad=(0.0, 2.5),
                       planet_runout_m=(1 * UM, 4 * UM), planet_pitch_radius_error_m=(0.0, -15 * UM))
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    ns = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0, 0, 0]))
    npl = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[a0, 0, 0]))
    good = add_gear_mesh(mbs, ns, npl, stage)
    bad = add_gear_mesh(mbs, ns, npl, stage, planet_index=1, errors=errors)
    rng = np.random.default_rng(7)
    bound = 3 * (15 * UM + 14 * UM) ** 2 / a0
    for _ in range(20):
        beta = rng.uniform(-20, 20)  # carrier angle
        th_s = rng.uniform(-50, 50)  # sun rolled relative to the carrier
        th_p = beta - (th_s - beta) * ZS / ZP + rng.uniform(-1e-3, 1e-3)
        q = np.array([1 * UM, -2 * UM, th_s, a0 * (math.cos(beta) - 1), a0 * math.sin(beta), th_p])
        g0, g1 = mesh_state(None, good, q=q), mesh_state(None, bad, q=q)
        gam = g0.centre_line_angle_rad
        d_s = 10 * UM * _e(th_s + 0.4) + 5 * UM * _e(th_s - 1.1)
        d_p = 10 * UM * _e(th_p + 2.5) + 4 * UM * _e(th_p)
        pitch = (-12 * UM - 15 * UM) * math.sin(alpha)
        n_drive, n_coast = _e(gam + math.pi / 2 - alpha), _e(gam - math.pi / 2 + alpha)
        assert g1.drive_overlap_m - g0.drive_overlap_m == pytest.approx((d_s - d_p) @ n_drive + pitch, abs=bound)
        assert g1.coast_overlap_m - g0.coast_overlap_m == pytest.approx((d_s - d_p) @ n_coast + pitch, abs=bound)


# --------------------------------------------------------------------------- Jacobian, invariance


def _states(stage):
    """Configurations on either flank, in the smoothing zone, in the dead zone, with velocities."""
    rbs, rbp = _radii(stage)
    b2 = normal_backlash_m(stage) / 2
    rng = np.random.default_rng(3)
    for target in (b2 + 2 * UM, b2 + 0.3 * UM, -b2 - 1 * UM, b2 + 0.5 * SMOOTHING_M, b2 - 3 * SMOOTHING_M, 0.0):
        th_s = rng.uniform(-30, 30)
        q = np.array([*rng.uniform(-2, 2, 2) * UM, th_s, *rng.uniform(-2, 2, 2) * UM, 0.0])
        q[5] = (target - rbs * th_s) / rbp
        qt = rng.normal(size=6) * np.array([1e-3, 1e-3, 100, 1e-3, 1e-3, 30])
        yield q, qt


def test_analytic_jacobian_matches_finite_differences(stage):
    """∂f/∂q and ∂f/∂q̇ against 4th-order central differences of f, relative 1e-6 of the
    largest entry, at states on both flanks, in the smoothing zone and the dead zone, with
    errors (the input-shaft angle error's chain rule included), stiffness variation and velocities (damping). Steps 1 nm / 0.1 µrad: small
    against the 10 nm smoothing, large against rounding."""
    errors = ErrorSpec(sun_base_eccentricity_m=10 * UM, sun_base_eccentricity_phase_rad=0.4, sun_runout_m=5 * UM,
                       planet_base_eccentricity_m=(10 * UM,), planet_base_eccentricity_phase_rad=(2.0,),
                       planet_runout_m=(3 * UM,), sun_pitch_radius_error_m=-5 * UM,
                       planet_base_pitch_error_m=(4 * UM,), input_shaft_angle_error_rad=2e-3,
                       input_shaft_angle_error_phase_rad=0.7)
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    a0 = stage.centre_distance_m
    ns = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0, 0, 0.1]))
    npl = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[a0 * math.cos(0.7), a0 * math.sin(0.7), -0.2]))
    mesh = add_gear_mesh(mbs, ns, npl, stage, errors=errors)
    steps = np.array([1e-9, 1e-9, 1e-7, 1e-9, 1e-9, 1e-7])
    for q, qt in _states(stage):
        f, dfdq, dfdqt = evaluate(mesh, q, qt)
        num_q, num_qt = np.empty((6, 6)), np.empty((6, 6))
        for j in range(6):
            e = np.zeros(6)
            e[j] = steps[j]
            fq = [evaluate(mesh, q + m * e, qt)[0] for m in (-2, -1, 1, 2)]
            num_q[:, j] = (fq[0] - 8 * fq[1] + 8 * fq[2] - fq[3]) / (12 * steps[j])
            e[j] = 1.0  # f is linear in q̇
            num_qt[:, j] = (evaluate(mesh, q, qt + e)[0] - evaluate(mesh, q, qt - e)[0]) / 2
        assert np.abs(dfdq - num_q).max() <= 1e-6 * np.abs(dfdq).max()
        assert np.abs(dfdqt - num_qt).max() <= 1e-6 * np.abs(dfdqt).max() + 1e-12
        # without velocities the stiffness is the Hessian of a potential: symmetric
        k0 = evaluate(mesh, q)[1]
        assert np.abs(k0 - k0.T).max() <= 1e-12 * np.abs(k0).max()


def test_exudyn_assembles_the_jacobian_with_the_right_sign_and_scale(stage):
    """The jacobianUserFunction convention (LHS derivative times fODE2, fODE2_t): Exudyn's
    assembled Jacobian with our analytic function equals the one it builds by its own
    numerical differentiation of the force user function (1e-6 position part; the
    velocity part 1e-4, Exudyn differentiates with a one-sided step)."""
    rbs, rbp = _radii(stage)
    a0 = stage.centre_distance_m
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    ns = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0, 0, 0], initialCoordinates=[1e-6, 2e-6, 0.3],
                                     initialVelocities=[1e-3, 0, 2.0]))
    npl = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[a0 * math.cos(0.7), a0 * math.sin(0.7), 0.2],
                                      initialCoordinates=[0, 0, (30e-6 - rbs * 0.3) / rbp],
                                      initialVelocities=[0, 1e-3, -0.5]))
    for node in (ns, npl):
        mbs.AddObject(ObjectRigidBody2D(nodeNumber=node, mass=0.1, inertia=1e-5))
    add_gear_mesh(mbs, ns, npl, stage, errors=ErrorSpec(sun_base_eccentricity_m=10 * UM))
    mbs.Assemble()

    def assembled(numerical, f_ode2, f_ode2_t):
        ss = _settings()
        ss.timeIntegration.newton.numericalDifferentiation.forODE2 = numerical
        solver = exu.MainSolverImplicitSecondOrder()
        solver.InitializeSolver(mbs, ss)
        solver.ComputeJacobianODE2RHS(mbs, f_ode2, f_ode2_t)
        jac = np.array(solver.GetSystemJacobian())
        solver.FinalizeSolver(mbs, ss)
        return jac

    for factors, rel in (((1.0, 0.0), 1e-6), ((0.0, 1.0), 1e-4)):
        ours, theirs = assembled(False, *factors), assembled(True, *factors)
        assert np.abs(ours).max() > 0
        assert np.abs(ours - theirs).max() <= rel * np.abs(ours).max()


def test_forces_conserve_momentum_and_angular_momentum(stage):
    """Generalized forces do no work in rigid motions of the pair: Σ F = 0 and Σ (M + r × F) = 0
    about the origin, at random states with errors and velocities (relative 1e-12)."""
    errors = ErrorSpec(sun_base_eccentricity_m=10 * UM, planet_base_eccentricity_m=(10 * UM,),
                       planet_runout_m=(5 * UM,), sun_runout_m=5 * UM, sun_runout_phase_rad=1.0)
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    a0 = stage.centre_distance_m
    ref_s = np.array([1e-3, -2e-3, 0.0])  # sun off the origin: the moment check is not trivial
    ref_p = np.array([ref_s[0] + a0 * math.cos(2.0), ref_s[1] + a0 * math.sin(2.0), 0.5])
    ns = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=list(ref_s)))
    npl = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=list(ref_p)))
    mesh = add_gear_mesh(mbs, ns, npl, stage, errors=errors)
    for q, qt in _states(stage):
        f, _, _ = evaluate(mesh, q, qt)
        xs, xp = ref_s[:2] + q[:2], ref_p[:2] + q[3:5]
        scale = np.abs(f).max()
        assert abs(f[0] + f[3]) <= 1e-12 * scale and abs(f[1] + f[4]) <= 1e-12 * scale
        moment = f[2] + f[5] + (xs[0] * f[1] - xs[1] * f[0]) + (xp[0] * f[4] - xp[1] * f[3])
        assert abs(moment) <= 1e-12 * scale * a0


# --------------------------------------------------------------------------- bad input


def _two_nodes(stage, second=NodeRigidBody2D):
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    a0 = stage.centre_distance_m
    ns = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0, 0, 0]))
    npl = mbs.AddNode(second(referenceCoordinates=[a0, 0, 0] if second is NodeRigidBody2D else [a0, 0]))
    return sc, mbs, ns, npl


def test_bad_input_is_refused_naming_the_parameter(stage):
    sc, mbs, ns, npl = _two_nodes(stage, NodePoint2D)
    with pytest.raises(ValueError, match="planet_node.*NodeRigidBody2D"):
        add_gear_mesh(mbs, ns, npl, stage)
    sc, mbs, ns, npl = _two_nodes(stage)
    with pytest.raises(ValueError, match="sun_node"):
        add_gear_mesh(mbs, 7, npl, stage)
    with pytest.raises(ValueError, match="planet_node.*differ"):
        add_gear_mesh(mbs, ns, ns, stage)
    two = ErrorSpec(planet_base_eccentricity_m=(10 * UM, 10 * UM), planet_base_eccentricity_phase_rad=(0.0, 1.0))
    with pytest.raises(ValueError, match="planet_index.*planet_base_eccentricity_m"):
        add_gear_mesh(mbs, ns, npl, stage, planet_index=2, errors=two)
    with pytest.raises(ValueError, match="planet_index"):
        add_gear_mesh(mbs, ns, npl, stage, planet_index=-1)
    with pytest.raises(ValueError, match="errors"):
        add_gear_mesh(mbs, ns, npl, stage, errors={"sun_runout_m": 1e-6})
    with pytest.raises(ValueError, match="smoothing_m"):
        add_gear_mesh(mbs, ns, npl, stage, smoothing_m=0.0)
    # negative stiffness/backlash: InputStage refuses them, and so does the element if bypassed
    with pytest.raises(ValueError, match="mesh_stiffness_mean_N_m"):
        dc.replace(stage, mesh_stiffness_mean_N_m=-9e8)
    for name, value in (("mesh_stiffness_mean_N_m", -9e8), ("backlash_m", -1e-6), ("mesh_damping_Ns_m", -1.0)):
        bad = dc.replace(stage)
        object.__setattr__(bad, name, value)
        with pytest.raises(SpecError, match=f"stage.{name}"):
            add_gear_mesh(mbs, ns, npl, bad)
    # a planet that is not at the stage's centre distance
    far = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[stage.centre_distance_m + 2 * stage.module_m, 0, 0]))
    with pytest.raises(ValueError, match="planet_node.*centre distance"):
        add_gear_mesh(mbs, ns, far, stage)


def test_base_pitch_error_gives_a_once_per_tooth_transmission_error(stage):
    """Planet base-pitch error f_pb = 4 µm (seed 002's E_bp), constant stiffness, no backlash,
    constant sun torque, planet locked at 16 positions over one tooth pitch: the sun angle
    carries e_pb/r_bs = ½f_pb·cos φ/r_bs on top of the constant elastic lag."""
    s = _perfect(stage)
    s = dc.replace(s, mesh_stiffness_amplitude_N_m=0.0)
    rbs, _ = _radii(s)
    errors = ErrorSpec(planet_base_pitch_error_m=(4 * UM, 0.0))
    rig = _rig(s, errors=errors)
    torque = 2.0
    lag = torque / (rbs * s.mesh_stiffness_mean_N_m) / rbs
    for j in range(16):
        psi = j * 2 * math.pi / ZS / 16
        th_s, _, st = _solve(rig, planet=-psi * ZS / ZP, sun_torque=torque, guess=(psi, -psi * ZS / ZP))
        phi = ZS * th_s
        # sun ahead of the rigid position by the elastic lag plus the pitch excitation
        expected = psi + lag + 0.5 * 4 * UM * math.cos(phi) / rbs
        assert th_s == pytest.approx(expected, abs=1e-9 / rbs)  # 1 nm along the line of action

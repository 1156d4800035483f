"""Clearance bearing (seed 001): the smoothed IF law, its symbolic evaluation in Exudyn, static
equilibria through the clearance both ways, linear axial/tilt stiffness, free spin, a dynamic
bounce against an independent reference, and bad input.

Most cases use the RV-40E eccentric (needle) bearing of the catalogue, k_n = 5.1e8 N/m,
c = 500 N·s/m, with seed 001's 12 µm radial clearance added as an ErrorSpec-style extra
clearance, and the default smoothing half-width w = 0.1 µm.

Statics need a weak regularising spring while the bearing is open (the body floats in the
clearance, the Jacobian is singular). It acts between the same two markers, radially with
k_r = 1e-6·k_n (510 N/m) and about the bearing axis with 1 N·m/rad. In contact it carries a
share k_r/(k_n + k_r) = 1e-6 of the radial load, i.e. it shifts a contact equilibrium by
1e-6·d ≈ 1.4e-11 m at d ≈ 14 µm; inside the clearance it carries the whole (tiny) load.
"""

from __future__ import annotations

import math
import sys

import exudyn as exu
import numpy as np
import pytest
from exudyn.itemInterface import (
    LoadForceVector,
    LoadTorqueVector,
    MarkerBodyPosition,
    MarkerBodyRigid,
    MarkerNodeCoordinate,
    NodeRigidBody2D,
    ObjectConnectorRigidBodySpringDamper,
    ObjectGround,
    ObjectRigidBody2D,
    SensorNode,
    SensorObject,
)
from exudyn.rigidBodyUtilities import InertiaCylinder, RotationMatrixY
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from rvflex import catalog
from rvflex.contact.bearing import (
    DEFAULT_SMOOTHING_M,
    BearingHandles,
    add_clearance_bearing,
    contact_indicator,
    radial_force_N,
)
from rvflex.spec import SpecError

UM = 1e-6
EPS = 12 * UM  # seed 001 Table 2: bearing radial internal clearance
W = DEFAULT_SMOOTHING_M
REG = 1e-6  # regularising radial spring as a share of k_n (module docstring)
K_SPIN = 1.0  # N·m/rad, regularises the free rotation about the bearing axis
CRANK_XY = (0.036, 0.012)  # a bearing away from the origin, as in the reducer (m)
FORCE = exu.OutputVariableType.ForceLocal
TORQUE = exu.OutputVariableType.TorqueLocal


@pytest.fixture(scope="module")
def ecc():
    """RV-40E eccentric bearing: needle, k_n = 5.1e8 N/m, c = 500 N·s/m, nominal clearance 0."""
    return catalog.load("rv40e").bearings.eccentric


# --------------------------------------------------------------------------- helpers


def _settings(load_steps: int = 1) -> exu.SimulationSettings:
    ss = exu.SimulationSettings()
    ss.solution.file.write = False
    ss.solution.sensors.writePeriod = 1e-9  # store every step
    ss.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    ss.staticSolver.verboseMode = 0
    ss.staticSolver.numberOfLoadSteps = load_steps
    ss.timeIntegration.verboseMode = 0
    return ss


def _planar(ecc, *, v0=(0.0, 0.0, 0.0), regularise=True, **kw):
    """Ground bore at CRANK_XY and a 1 kg planar journal body there, joined by the bearing."""
    mbs = exu.SystemContainer().AddSystem()
    ground = mbs.AddObject(ObjectGround())
    node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[*CRANK_XY, 0.0], initialVelocities=list(v0)))
    body = mbs.AddObject(ObjectRigidBody2D(nodeNumber=node, mass=1.0, inertia=1e-4))
    m0 = mbs.AddMarker(MarkerBodyRigid(bodyNumber=ground, localPosition=[*CRANK_XY, 0.0]))
    m1 = mbs.AddMarker(MarkerBodyRigid(bodyNumber=body))
    handles = add_clearance_bearing(mbs, m0, m1, ecc, extra_clearance_m=EPS, **kw)
    if regularise:
        k_r = REG * ecc.radial_stiffness_N_m
        mbs.AddObject(ObjectConnectorRigidBodySpringDamper(
            markerNumbers=[m0, m1], stiffness=np.diag([k_r, k_r, 0.0, 0.0, 0.0, K_SPIN])))
    return mbs, node, m1, handles


def _spatial(ecc):
    """3D rigid body (Euler parameters) in a bearing whose axis is turned to global x."""
    mbs = exu.SystemContainer().AddSystem()
    ground = mbs.AddObject(ObjectGround())
    p = [*CRANK_XY, 0.01]
    body = mbs.CreateRigidBody(inertia=InertiaCylinder(7850.0, 0.01, 0.02, axis=0), referencePosition=p,
                               nodeType=exu.NodeType.RotationEulerParameters)
    # joint frame: local z = global x, local x = global −z, local y = global y
    m0 = mbs.AddMarker(MarkerBodyRigid(bodyNumber=ground, localHT=exu.HT(rotation=RotationMatrixY(math.pi / 2),
                                                                          translation=p)))
    m1 = mbs.AddMarker(MarkerBodyRigid(bodyNumber=body))
    handles = add_clearance_bearing(mbs, m0, m1, ecc, extra_clearance_m=EPS)
    k_r = REG * ecc.radial_stiffness_N_m
    mbs.AddObject(ObjectConnectorRigidBodySpringDamper(
        markerNumbers=[m0, m1], stiffness=np.diag([k_r, k_r, 0.0, 0.0, 0.0, K_SPIN])))
    return mbs, m1, handles


def _solve_static(mbs, ss) -> int:
    """Static solve from the current initial state; return the Newton iterations used."""
    assert mbs.SolveStatic(ss), "static solver failed"
    return mbs.sys["staticSolver"].it.newtonStepsCount


def _continue_from_current(mbs) -> None:
    mbs.systemData.SetODE2Coordinates(mbs.systemData.GetODE2Coordinates(), exu.ConfigurationType.Initial)


def _equilibrium_d(load_N: float, k_n: float) -> float:
    """Radial equilibrium |d| of bearing + regularising spring under |load| (reference law)."""
    f = abs(load_N)
    if f == 0.0:
        return 0.0
    k_r = REG * k_n
    return brentq(lambda d: k_r * d + radial_force_N(d, stiffness_N_m=k_n, clearance_m=EPS) - f,
                  0.0, f / k_r, xtol=1e-16, rtol=1e-14)


# --------------------------------------------------------------------------- the law itself


def test_law_is_sharp_outside_the_band_and_c1_inside(ecc):
    """Exactly 0 for d ≤ ε − w, exactly k_n(d − ε) for d ≥ ε + w, ≤ k_n·w/4 above the sharp law
    in between, monotone and C¹ (slopes either side of each band edge agree to O(h))."""
    k = ecc.radial_stiffness_N_m
    d = np.linspace(0.0, 2 * EPS, 200_001)
    f = radial_force_N(d, stiffness_N_m=k, clearance_m=EPS)
    sharp = k * np.maximum(d - EPS, 0.0)
    inside, beyond, band = d <= EPS - W, d >= EPS + W, np.abs(d - EPS) < W
    assert np.all(f[inside] == 0.0)
    np.testing.assert_allclose(f[beyond], sharp[beyond], rtol=1e-12)
    excess = f[band] - sharp[band]
    assert excess.min() >= 0.0 and excess.max() <= k * W / 4 * (1 + 1e-9)
    assert radial_force_N(EPS, stiffness_N_m=k, clearance_m=EPS) == pytest.approx(k * W / 4, rel=1e-9)
    assert np.all(np.diff(f) >= 0.0)
    h = 1e-12
    for edge, slope in ((EPS - W, 0.0), (EPS + W, k)):
        left = (radial_force_N(edge, stiffness_N_m=k, clearance_m=EPS)
                - radial_force_N(edge - h, stiffness_N_m=k, clearance_m=EPS)) / h
        right = (radial_force_N(edge + h, stiffness_N_m=k, clearance_m=EPS)
                 - radial_force_N(edge, stiffness_N_m=k, clearance_m=EPS)) / h
        assert left == pytest.approx(slope, abs=2e-4 * k) and right == pytest.approx(slope, abs=2e-4 * k)
    s = contact_indicator(d, clearance_m=EPS)
    assert s[inside].max() == 0.0 and s[beyond].min() == 1.0


def test_law_without_clearance_is_the_linear_spring(ecc):
    """ε = 0: w_eff = 0, the law is k_n·d and the damping indicator is 1 everywhere."""
    k = ecc.radial_stiffness_N_m
    d = np.array([0.0, 1e-12, 1e-9, 1e-6, 1e-4])
    np.testing.assert_array_equal(radial_force_N(d, stiffness_N_m=k, clearance_m=0.0), k * d)
    np.testing.assert_array_equal(contact_indicator(d, clearance_m=0.0), np.ones_like(d))


# --------------------------------------------------------------------------- connector = law


@pytest.mark.parametrize("clearance, smoothing", [(EPS, W), (EPS, 0.0), (0.0, W), (0.05 * UM, W)],
                         ids=["12um-smoothed", "12um-sharp", "no-clearance", "clearance<w"])
def test_connector_evaluates_the_law_in_the_joint_frame(ecc, clearance, smoothing):
    """Planar disc (bore marker 0, rotated and moved) and planar crank (marker 1): the
    connector's ForceLocal equals the reference law k_n·r_w(d − ε)·u/d + c·s_w·v in the bore
    frame, to rounding (rtol 1e-12), at d = 0, inside, in the band and beyond; no torque."""
    k, c = ecc.radial_stiffness_N_m, ecc.radial_damping_Ns_m
    mbs = exu.SystemContainer().AddSystem()
    nodes = [mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0.0, 0.0, 0.0])) for _ in range(2)]
    disc, crank = (mbs.AddObject(ObjectRigidBody2D(nodeNumber=n, mass=1.0, inertia=1e-4)) for n in nodes)
    bore = np.array(CRANK_XY)
    m0 = mbs.AddMarker(MarkerBodyRigid(bodyNumber=disc, localPosition=[*bore, 0.0]))
    m1 = mbs.AddMarker(MarkerBodyRigid(bodyNumber=crank))
    h = add_clearance_bearing(mbs, m0, m1, ecc, extra_clearance_m=clearance, smoothing_m=smoothing)
    assert isinstance(h, BearingHandles) and h.clearance_m == clearance
    assert h.smoothing_m == min(smoothing, clearance)
    assert mbs.GetObject(h.connector)["springForceTorqueUserFunction"]["type"] == "Symbolic"
    mbs.Assemble()

    phi, p_disc = 0.7, np.array([1e-3, -2e-3])
    rot = np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])
    v_crank = np.array([3e-3, -1e-3])
    v_local = rot.T @ v_crank  # disc at rest: relative velocity in the bore frame
    if clearance == 0.0:
        radii = [0.0, 1e-12, 1e-9, 1 * UM, 5 * UM]
    else:  # the sharp law's damping indicator jumps at d = ε: evaluate it off the switch only
        radii = [0.0, 1e-12, 0.5 * clearance, clearance - 0.5 * W, *([clearance] if smoothing else []),
                 clearance + 0.5 * W, clearance + 2 * W, clearance + 3 * UM]
    for d in radii:
        u = d * np.array([math.cos(2.1), math.sin(2.1)])
        p_crank = p_disc + rot @ (bore + u)
        mbs.systemData.SetODE2Coordinates([*p_disc, phi, *p_crank, -1.3])
        mbs.systemData.SetODE2Coordinates_t([0.0, 0.0, 0.0, *v_crank, 5.0])
        f_r = radial_force_N(d, stiffness_N_m=k, clearance_m=clearance, smoothing_m=smoothing)
        s = contact_indicator(d, clearance_m=clearance, smoothing_m=smoothing)
        expect = (f_r * u / d if d > 0 else 0 * u) + c * s * v_local
        got = mbs.GetObjectOutput(h.connector, FORCE)
        np.testing.assert_allclose(got[:2], expect, rtol=1e-9, atol=1e-9 * (k * UM), err_msg=f"d = {d}")
        assert got[2] == 0.0
        np.testing.assert_array_equal(mbs.GetObjectOutput(h.connector, TORQUE), 0.0)


# --------------------------------------------------------------------------- statics


def test_zero_force_inside_the_clearance(ecc):
    """A body pushed by 3.06 mN against the 510 N/m regularising spring rests at 6 µm, inside
    ε − w = 11.9 µm: the bearing force is exactly zero and the spring carries all of the load."""
    mbs, node, m1, h = _planar(ecc)
    k_r = REG * ecc.radial_stiffness_N_m
    load = k_r * 6 * UM
    e = np.array([math.cos(-0.8), math.sin(-0.8), 0.0])
    mbs.AddLoad(LoadForceVector(markerNumber=m1, loadVector=list(load * e)))
    mbs.Assemble()
    _solve_static(mbs, _settings())
    u = mbs.GetObjectOutput(h.connector, exu.OutputVariableType.DisplacementLocal)
    np.testing.assert_allclose(u, 6 * UM * e, rtol=0, atol=1e-6 * 6 * UM)  # Newton tolerance 1e-8
    np.testing.assert_array_equal(mbs.GetObjectOutput(h.connector, FORCE), 0.0)


@pytest.mark.parametrize("load_N", [100.0, 1000.0, 5000.0])
@pytest.mark.parametrize("angle", [0.0, 2.5])
def test_static_displacement_beyond_the_clearance(ecc, load_N, angle):
    """Radial load F ≥ 2·k_n·w (102 N) puts the equilibrium beyond the band, where the law is
    exact: d = ε + F/k_n. Tolerance 0.1 nm covers the spring share (1e-6·d ≤ 2.2e-11 m) and the
    Newton tolerance; the displacement is along the load."""
    k = ecc.radial_stiffness_N_m
    mbs, node, m1, h = _planar(ecc)
    e = np.array([math.cos(angle), math.sin(angle), 0.0])
    mbs.AddLoad(LoadForceVector(markerNumber=m1, loadVector=list(load_N * e)))
    mbs.Assemble()
    _solve_static(mbs, _settings(load_steps=5))
    u = mbs.GetObjectOutput(h.connector, exu.OutputVariableType.DisplacementLocal)
    np.testing.assert_allclose(u, (EPS + load_N / k) * e, rtol=0, atol=1e-10)
    bearing_share = load_N * e - REG * k * u  # the rest is in the regularising spring
    np.testing.assert_allclose(mbs.GetObjectOutput(h.connector, FORCE), bearing_share, rtol=1e-8, atol=1e-9)


def test_static_displacement_in_the_band_is_within_w_of_the_sharp_law(ecc):
    """F = 20 N < k_n·w: the smoothed equilibrium lies in the band, within w of the sharp one
    (ε + F/k_n), and equals the reference law's equilibrium to 1e-11 m."""
    k = ecc.radial_stiffness_N_m
    mbs, node, m1, h = _planar(ecc)
    mbs.AddLoad(LoadForceVector(markerNumber=m1, loadVector=[0.0, -20.0, 0.0]))
    mbs.Assemble()
    _solve_static(mbs, _settings(load_steps=5))
    d = -mbs.GetObjectOutput(h.connector, exu.OutputVariableType.DisplacementLocal)[1]
    assert abs(d - EPS) < W
    assert abs(d - (EPS + 20.0 / k)) < W
    assert d == pytest.approx(_equilibrium_d(20.0, k), abs=1e-11)


def test_static_solver_crosses_the_clearance_both_ways(ecc):
    """Load rises 0 → +200 N by the static solver's load factor (10 steps, crossing from the
    centre into contact), then reverses +200 N → −200 N in 10 N steps, each step a static solve
    from the previous one, through the band, the open clearance (F = 0 sits at the centre) and
    into contact on the opposite side. Every step converges in ≤ 12 Newton iterations and
    matches the reference equilibrium to 0.1 nm."""
    k = ecc.radial_stiffness_N_m
    mbs, node, m1, h = _planar(ecc)
    e = np.array([math.cos(0.5), math.sin(0.5), 0.0])
    top = 200.0
    load = mbs.AddLoad(LoadForceVector(markerNumber=m1, loadVector=list(top * e)))
    mbs.Assemble()
    ss = _settings(load_steps=10)
    ss.staticSolver.adaptiveStep = False  # every load step must converge as given
    rising = _solve_static(mbs, ss)
    path = [(top, mbs.GetObjectOutput(h.connector, exu.OutputVariableType.DisplacementLocal))]

    ss.staticSolver.useLoadFactor = False
    ss.staticSolver.numberOfLoadSteps = 1
    iterations = []
    for f in np.linspace(top, -top, 41)[1:]:
        _continue_from_current(mbs)
        mbs.SetLoadParameter(load, "loadVector", list(f * e))
        iterations.append(_solve_static(mbs, ss))
        path.append((f, mbs.GetObjectOutput(h.connector, exu.OutputVariableType.DisplacementLocal)))

    in_band = 0
    for f, u in path:
        d_ref = _equilibrium_d(f, k)
        np.testing.assert_allclose(u, math.copysign(d_ref, f) * e, rtol=0, atol=1e-10, err_msg=f"F = {f} N")
        in_band += abs(d_ref - EPS) < W
    assert in_band >= 2  # the path really went through the switch (±10 N, ±20 N)
    assert rising <= 10 * 12 and max(iterations) <= 12
    assert path[-1][1] @ e == pytest.approx(-(EPS + top / k), abs=1e-10)


def test_axial_and_tilt_stiffness_act_linearly(ecc):
    """3D body, bearing axis turned to global x by marker 0's localHT: axial force and tilt
    torques give u_z = F/k_ax and θ = M/k_tilt, and doubling the loads doubles the response
    (rtol 1e-6: Newton tolerance; the regularising spring does not act on these directions).
    A radial load along global z lands on the radial law (local −x)."""
    k_ax, k_t, k = ecc.axial_stiffness_N_m, ecc.tilt_stiffness_Nm_rad, ecc.radial_stiffness_N_m
    results = []
    for scale in (1.0, 2.0):
        mbs, m1, h = _spatial(ecc)
        mbs.AddLoad(LoadForceVector(markerNumber=m1, loadVector=[scale * 40.0, 0.0, 0.0]))
        mbs.AddLoad(LoadTorqueVector(markerNumber=m1, loadVector=[0.0, scale * 0.5, -scale * 0.3]))
        mbs.Assemble()
        _solve_static(mbs, _settings(load_steps=2))
        u = mbs.GetObjectOutput(h.connector, exu.OutputVariableType.DisplacementLocal)
        th = mbs.GetObjectOutput(h.connector, exu.OutputVariableType.Rotation)
        assert u[2] == pytest.approx(scale * 40.0 / k_ax, rel=1e-6)
        assert th[1] == pytest.approx(scale * 0.5 / k_t, rel=1e-6)  # global y = local y
        assert th[0] == pytest.approx(scale * 0.3 / k_t, rel=1e-6)  # global −z = local x
        np.testing.assert_allclose(u[:2], 0.0, atol=1e-15)  # radial stays centred
        results.append(np.array([u[2], th[0], th[1]]))
    np.testing.assert_allclose(results[1], 2 * results[0], rtol=1e-6)

    mbs, m1, h = _spatial(ecc)
    mbs.AddLoad(LoadForceVector(markerNumber=m1, loadVector=[0.0, 0.0, 1000.0]))
    mbs.Assemble()
    _solve_static(mbs, _settings(load_steps=5))
    u = mbs.GetObjectOutput(h.connector, exu.OutputVariableType.DisplacementLocal)
    np.testing.assert_allclose(u, [-(EPS + 1000.0 / k), 0.0, 0.0], atol=1e-10)


def test_rotation_about_the_axis_is_free(ecc):
    """Loaded in contact (1 kN radial) and twisted about the bearing axis by 0.6 N·m against
    the 1 N·m/rad regularising spring, the 3D body turns by 0.6 rad: the bearing adds no
    torque about its axis (TorqueLocal z exactly 0) and the radial deflection is unchanged."""
    k = ecc.radial_stiffness_N_m
    mbs, m1, h = _spatial(ecc)
    mbs.AddLoad(LoadForceVector(markerNumber=m1, loadVector=[0.0, 1000.0, 0.0]))
    mbs.AddLoad(LoadTorqueVector(markerNumber=m1, loadVector=[0.6, 0.0, 0.0]))
    mbs.Assemble()
    _solve_static(mbs, _settings(load_steps=5))
    th = mbs.GetObjectOutput(h.connector, exu.OutputVariableType.Rotation)
    assert th[2] == pytest.approx(0.6 / K_SPIN, rel=1e-6)
    assert mbs.GetObjectOutput(h.connector, TORQUE)[2] == 0.0
    u = mbs.GetObjectOutput(h.connector, exu.OutputVariableType.DisplacementLocal)
    np.testing.assert_allclose(u, [0.0, EPS + 1000.0 / k, 0.0], atol=1e-10)


# --------------------------------------------------------------------------- dynamics


def _bounce(ecc, *, steps: int, step_s: float = 5e-6, v0: float = 0.01, angle: float = 0.4, spin: float = 3.0):
    """Free (unregularised) planar journal launched at v0 along ``angle``, spinning; sensors
    record displacement, velocities and the bearing force at every step."""
    mbs, node, m1, h = _planar(ecc, v0=(v0 * math.cos(angle), v0 * math.sin(angle), spin), regularise=False)
    pos = mbs.AddSensor(SensorNode(nodeNumber=node, outputVariableType=exu.OutputVariableType.Displacement,
                                   storeInternal=True, writeToFile=False))
    vel = mbs.AddSensor(SensorNode(nodeNumber=node, outputVariableType=exu.OutputVariableType.Coordinates_t,
                                   storeInternal=True, writeToFile=False))
    force = mbs.AddSensor(SensorObject(objectNumber=h.connector, outputVariableType=FORCE,
                                       storeInternal=True, writeToFile=False))
    mbs.Assemble()
    ss = _settings()
    ss.timeIntegration.endTime = steps * step_s
    ss.timeIntegration.numberOfSteps = steps
    ss.timeIntegration.generalizedAlpha.spectralRadius = 0.9
    return mbs, ss, (pos, vel, force), h


def _flights(free: np.ndarray) -> list[slice]:
    """Flight phases: runs of ≥ 20 consecutive samples with the journal inside ε − w."""
    out, start = [], None
    for i, f in enumerate([*free, False]):
        if f and start is None:
            start = i
        elif not f and start is not None:
            if i - start >= 20:
                out.append(slice(start, i))
            start = None
    return out


def test_dynamic_bounce_in_the_clearance(ecc):
    """1 kg journal launched radially at 10 mm/s inside the 12 µm clearance, spinning at 3 rad/s;
    10 ms of generalized-α (ρ∞ = 0.9, h = 5 µs: 28 steps per contact half-period
    π·√(m/k_n) = 139 µs). It bounces ≥ 4 times; in flight the bearing force is exactly zero and
    the velocity settles to a constant (the integrator's acceleration transient after a
    contact decays by ≈ 0.73 per step); each flight speed matches a 1D LSODA reference of the
    same law (rtol 1e-10) within 1e-3·v0 (measured 2.7e-4·v0 at h = 5 µs, 1e-4·v0 at
    2.5 µs); the spin stays exactly 3 rad/s (free rotation)."""
    k, c, m, v0, angle = ecc.radial_stiffness_N_m, ecc.radial_damping_Ns_m, 1.0, 0.01, 0.4
    mbs, ss, sensors, _ = _bounce(ecc, steps=2000, v0=v0, angle=angle)
    assert mbs.SolveDynamic(ss, solverType=exu.DynamicSolverType.GeneralizedAlpha)
    p, v, f = (mbs.GetSensorStoredData(s) for s in sensors)
    e = np.array([math.cos(angle), math.sin(angle)])
    r, vr = p[:, 1:3] @ e, v[:, 1:3] @ e
    np.testing.assert_allclose(p[:, 1:3] @ np.array([-e[1], e[0]]), 0.0, atol=1e-15)  # stays on its line
    flights = _flights(np.abs(r) < EPS - W)
    assert len(flights) >= 5  # launch + ≥ 4 rebounds
    for seg in flights:
        np.testing.assert_array_equal(f[seg, 1:], 0.0)
        tail = vr[seg][len(vr[seg]) // 2:]
        assert np.ptp(tail) <= 1e-15
    np.testing.assert_array_equal(v[:, 3], 3.0)

    def rhs(t, y):
        x, xd = y
        d = abs(x)
        f = (math.copysign(radial_force_N(d, stiffness_N_m=k, clearance_m=EPS), x)
             + c * contact_indicator(d, clearance_m=EPS) * xd)
        return [xd, -f / m]

    ref = solve_ivp(rhs, (0.0, ss.timeIntegration.endTime), [0.0, v0], method="LSODA", rtol=1e-10,
                    atol=[1e-14, 1e-10], max_step=2e-6)
    ref_flights = _flights(np.abs(ref.y[0]) < EPS - W)
    n = min(len(flights), len(ref_flights))
    assert n >= 5
    got = np.array([vr[seg][-1] for seg in flights[:n]])
    want = np.array([ref.y[1][seg][-1] for seg in ref_flights[:n]])
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-3 * v0)
    assert abs(got[-1]) < 0.9 * abs(got[0])  # contact damping dissipated energy
    assert np.abs(r).max() <= EPS + v0 * math.sqrt(m / k) + W  # undamped penetration bound


def _python_calls_during(solve) -> int:
    """Python-level function calls while ``solve()`` runs (a profile hook sees every call Exudyn
    makes into Python, e.g. a Python user function)."""
    count = 0

    def hook(frame, event, arg):
        nonlocal count
        count += event == "call"

    sys.setprofile(hook)
    try:
        solve()
    finally:
        sys.setprofile(None)
    return count


def test_no_python_callback_per_step(ecc):
    """The symbolic law runs in C++: the Python calls during a dynamic solve do not grow with
    the number of steps (200 vs 400). Control: the same connector with an equivalent Python
    user function makes at least one Python call per step, so the hook would catch it."""
    counts = []
    for steps in (200, 400):
        mbs, ss, *_ = _bounce(ecc, steps=steps)
        counts.append(_python_calls_during(lambda: mbs.SolveDynamic(ss)))
    assert counts[0] == counts[1] < 20

    mbs, ss, _, h = _bounce(ecc, steps=200)
    k = ecc.radial_stiffness_N_m

    def python_law(mbs, t, itemNumber, u, rot, v, w, stiffness, damping, rotJ0, rotJ1, offset):
        return [k * u[0], k * u[1], 0.0, 0.0, 0.0, 0.0]

    mbs.SetObjectParameter(h.connector, "springForceTorqueUserFunction", python_law)
    assert _python_calls_during(lambda: mbs.SolveDynamic(ss)) >= 200


# --------------------------------------------------------------------------- bad input


def _two_markers():
    mbs = exu.SystemContainer().AddSystem()
    ground = mbs.AddObject(ObjectGround())
    node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0.0, 0.0, 0.0]))
    body = mbs.AddObject(ObjectRigidBody2D(nodeNumber=node, mass=1.0, inertia=1e-4))
    markers = {
        "rigid0": mbs.AddMarker(MarkerBodyRigid(bodyNumber=ground)),
        "rigid1": mbs.AddMarker(MarkerBodyRigid(bodyNumber=body)),
        "position": mbs.AddMarker(MarkerBodyPosition(bodyNumber=body)),
        "coordinate": mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=0)),
    }
    return mbs, markers


@pytest.mark.parametrize("kwargs, match", [
    (dict(extra_clearance_m=-1e-6), r"^extra_clearance_m = -1e-06: .*cannot be negative"),
    (dict(extra_clearance_m=12.0), r"^extra_clearance_m = 12.0: expected metres"),
    (dict(smoothing_m=-1e-7), r"^smoothing_m = -1e-07: expected metres"),
    (dict(smoothing_m=float("nan")), r"^smoothing_m = nan: expected metres"),
    (dict(smoothing_m=0.1), r"^smoothing_m = 0.1: expected metres, 0 to 10 µm"),
    (dict(marker0="position"), r"^marker0 = 2: is a MarkerBodyPosition; the bearing needs a rigid"),
    (dict(marker1="coordinate"), r"^marker1 = 3: is a MarkerNodeCoordinate; the bearing needs a rigid"),
    (dict(marker0=99), r"^marker0 = 99: is not a marker of this system"),
    (dict(marker1="rigid0"), r"^marker1 = 0: must differ from marker0"),
    (dict(bearing="needle"), r"^bearing = 'needle': must be an rvflex.spec.Bearing"),
])
def test_bad_input_is_refused_naming_the_parameter(ecc, kwargs, match):
    mbs, markers = _two_markers()
    args = dict(marker0="rigid0", marker1="rigid1", bearing=ecc) | kwargs
    for key in ("marker0", "marker1"):
        args[key] = markers.get(args[key], args[key])
    with pytest.raises(SpecError, match=match) as info:
        add_clearance_bearing(mbs, **args)
    assert isinstance(info.value, ValueError)
    assert mbs.systemData.NumberOfObjects() == 2  # nothing was added

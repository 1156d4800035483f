"""The single-disc test bench of the contact element: one rigid disc whose centre is
driven along the eccentric circle, the pin ring fixed, a torque on the disc.

Used by the validation tests and ``rvflex bench contact``. The disc is a planar rigid body
(NodeRigidBody2D); its centre follows coordinate constraints whose offsets the stepping
loop sets to the eccentric position, and its rotation is free: the disc angle is the
output. Output angle and TE are counted positive in the direction the disc turns for a
positive eccentric rotation (the disc turns backwards, −θ/z_c), so a resisting torque
makes TE negative (the disc lags).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rvflex.contact.bearing import add_clearance_bearing
from rvflex.contact.cycloid_pin import ContactLaw, CycloidPinContact, add_cycloid_pin_contact
from rvflex.geometry.clearance import initial_clearance_numeric
from rvflex.geometry.pins import nominal_disc_pose, pin_centres, pin_radii
from rvflex.geometry.profile import build_profile
from rvflex.numerics import generalized_alpha_settings
from rvflex.spec import Bearing, CycloidStage, ErrorSpec

__all__ = ["SingleDisc", "build_single_disc", "quasi_static_te", "DynamicDisc", "build_dynamic_disc", "run_dynamic",
           "arc_length_segments"]

REGULARISER_NM_RAD = 0.1
FIRST_CONTACT_BIAS_RAD = 1e-8  # predictor just past first contact, so the contact has stiffness


@dataclass(frozen=True, eq=False)
class SingleDisc:
    """Handles of the single-disc bench (Exudyn items and the contact element)."""

    system_container: object
    mbs: object
    stage: CycloidStage
    node: int
    constraint_x: int
    constraint_y: int
    load: int
    regulariser: int
    contact: CycloidPinContact
    reference: np.ndarray
    disc: int
    errors: ErrorSpec | None


def build_single_disc(stage: CycloidStage, law: ContactLaw, *, errors: ErrorSpec | None = None, disc: int = 0,
                      resisting_torque_Nm: float = 0.0, mass_kg: float = 0.5,
                      inertia_kg_m2: float = 1e-3) -> SingleDisc:
    """Assemble the bench at eccentric angle 0 with the disc at its kinematic pose.

    ``resisting_torque_Nm`` acts on the disc against its motion (N·m).
    """
    import exudyn as exu
    from exudyn.itemInterface import (
        LoadCoordinate,
        MarkerNodeCoordinate,
        NodePointGround,
        NodeRigidBody2D,
        ObjectConnectorCoordinate,
        ObjectConnectorCoordinateSpringDamper,
        ObjectRigidBody2D,
    )

    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    centre, _ = nominal_disc_pose(stage, 0.0, disc)
    ref = np.array([centre[0], centre[1], 0.0])
    node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=list(ref), initialCoordinates=[0.0, 0.0, 0.0]))
    mbs.AddObject(ObjectRigidBody2D(nodeNumber=node, mass=mass_kg, inertia=inertia_kg_m2))
    ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()), coordinate=0))
    mx, my, mt = (mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=k)) for k in range(3))
    cx = mbs.AddObject(ObjectConnectorCoordinate(markerNumbers=[ground, mx], offset=0.0))
    cy = mbs.AddObject(ObjectConnectorCoordinate(markerNumbers=[ground, my], offset=0.0))
    # the disc turns negative for positive eccentric rotation: a resisting torque is positive
    load = mbs.AddLoad(LoadCoordinate(markerNumber=mt, load=resisting_torque_Nm))
    # weak torsional spring to the kinematic angle (offset set per step): keeps Newton
    # regular while every pin is in clearance; carries REGULARISER_NM_RAD × TE, e.g.
    # 1e-5 N·m at 1e-4 rad of TE, a negligible share of any working load
    reg = mbs.AddObject(ObjectConnectorCoordinateSpringDamper(markerNumbers=[ground, mt], stiffness=REGULARISER_NM_RAD,
                                                              offset=0.0))
    contact = add_cycloid_pin_contact(mbs, node, stage, law, disc=disc, errors=errors)
    mbs.Assemble()
    return SingleDisc(sc, mbs, stage, node, cx, cy, load, reg, contact, ref, disc, errors)


def static_settings():
    """Static-solver settings of the bench: tight Newton tolerances, dense solver (3 unknowns)."""
    import exudyn as exu

    ss = exu.SimulationSettings()
    ss.staticSolver.newton.relativeTolerance = 1e-12
    ss.staticSolver.newton.absoluteTolerance = 1e-7
    ss.staticSolver.verboseMode = 0
    ss.solution.file.write = False
    ss.linearSolver.solverType = exu.LinearSolverType.EXUdense
    return ss


def quasi_static_te(bench: SingleDisc, eccentric_angles_rad: np.ndarray, *,
                    predictor_offset_rad: float = 0.0) -> np.ndarray:
    """Static equilibrium at each eccentric angle, each step starting from the previous one.

    The predictor keeps the previous step's TE and adds ``predictor_offset_rad`` (so a
    test can make Newton work). Returns TE (rad) per angle: disc angle minus the kinematic
    −θ/z_c, counted positive in the disc's direction of motion.
    """
    import exudyn as exu

    mbs, stage = bench.mbs, bench.stage
    ss = static_settings()
    te = np.empty(len(eccentric_angles_rad))
    prev = None
    for k, theta in enumerate(eccentric_angles_rad):
        centre, angle = nominal_disc_pose(stage, float(theta), bench.disc)
        node_angle = angle + stage.disc_phase_rad[bench.disc] / stage.disc_teeth  # body angle, not profile angle
        mbs.SetObjectParameter(bench.constraint_x, "offset", centre[0] - bench.reference[0])
        mbs.SetObjectParameter(bench.constraint_y, "offset", centre[1] - bench.reference[1])
        mbs.SetObjectParameter(bench.regulariser, "offset", node_angle - bench.reference[2])
        if prev is None:  # first step: turn the disc to first contact on the loaded flank
            prev = _first_contact_te(bench, float(theta))
        q0 = np.array([centre[0] - bench.reference[0], centre[1] - bench.reference[1],
                       node_angle - prev + predictor_offset_rad - bench.reference[2]])
        mbs.systemData.SetODE2Coordinates(q0, configuration=exu.ConfigurationType.Initial)
        if not mbs.SolveStatic(ss):
            raise RuntimeError(f"static solve failed at eccentric angle {theta:.6f} rad")
        q = np.asarray(mbs.systemData.GetODE2Coordinates()) + bench.reference
        bench.contact.check_penetration()
        prev = -(q[2] - node_angle)
        te[k] = prev
    return te


def _first_contact_te(bench: SingleDisc, theta: float) -> float:
    """TE (rad) at which the first pin touches on the flank the load presses (0 without load)."""
    torque = bench.mbs.GetLoad(bench.load)["load"]
    if torque == 0.0:
        return 0.0
    cl = initial_clearance_numeric(bench.stage, bench.errors, bench.disc, theta, profile=bench.contact.profile)
    # a positive (resisting) torque turns the disc positive: TE = −turn
    turn = cl.turn_pos_rad + FIRST_CONTACT_BIAS_RAD if torque > 0 else cl.turn_neg_rad - FIRST_CONTACT_BIAS_RAD
    return -turn


# ---------------------------------------------------------------------------- dynamic bench


@dataclass(frozen=True, eq=False)
class DynamicDisc:
    """Handles of the dynamic single-disc bench: a crank turning at constant speed carries
    the disc on an eccentric (revolute joint); the pins are fixed; a torque resists the
    disc. ``contact`` is the rvflex element or Exudyn's ObjectContactCurveCircles index."""

    system_container: object
    mbs: object
    stage: CycloidStage
    crank_node: int
    disc_node: int
    contact: object
    crank_speed_rad_s: float
    sensor_crank: int
    sensor_disc: int


def arc_length_segments(stage: CycloidStage, n_segments: int, disc: int = 0,
                        errors: ErrorSpec | None = None) -> np.ndarray:
    """The disc profile as ``n_segments`` chords of equal arc length, rows (x0, y0, x1, y1),
    counter-clockwise (exterior on the right), for ObjectContactCurveCircles (m)."""
    prof = build_profile(stage, errors, disc)
    t = np.linspace(0.0, 2 * np.pi, 64 * n_segments + 1)
    _, q1, _ = prof.evaluate(t)
    speed = np.abs(q1)
    s = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(t))])
    pts, _, _ = prof.evaluate(np.interp(np.linspace(0.0, s[-1], n_segments + 1), s, t))
    return np.column_stack([pts.real[:-1], pts.imag[:-1], pts.real[1:], pts.imag[1:]])


def build_dynamic_disc(stage: CycloidStage, *, law: ContactLaw | None = None, curve_circles_segments: int = 0,
                       curve_circles_stiffness_N_m2: float = 0.0, curve_circles_damping_Ns_m2: float = 0.0,
                       crank_speed_rad_s: float = 2 * np.pi, resisting_torque_Nm: float = 0.0,
                       start_te_rad: float = 0.0, disc_mass_kg: float = 0.5,
                       disc_inertia_kg_m2: float = 1e-3, eccentric_bearing: Bearing | None = None,
                       eccentric_clearance_m: float = 0.0) -> DynamicDisc:
    """Assemble the dynamic bench with the rvflex contact (``law``) or, when
    ``curve_circles_segments`` > 0, Exudyn's polygon contact on that many arc-length segments.

    The eccentric carries the disc through a revolute joint, or, with ``eccentric_bearing``,
    through the clearance bearing (its clearance plus ``eccentric_clearance_m``). The disc
    starts on its kinematic path at TE = ``start_te_rad`` with consistent velocities.
    """
    import exudyn as exu
    from exudyn.itemInterface import (
        LoadCoordinate,
        MarkerBodyPosition,
        MarkerBodyRigid,
        MarkerNodeCoordinate,
        NodeGenericData,
        NodePointGround,
        NodeRigidBody2D,
        ObjectConnectorCoordinate,
        ObjectContactCurveCircles,
        ObjectJointRevolute2D,
        ObjectRigidBody2D,
        SensorNode,
    )

    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    e, zc, w = stage.eccentricity_m, stage.disc_teeth, crank_speed_rad_s
    ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()), coordinate=0))
    crank = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0.0, 0.0, 0.0], initialVelocities=[0.0, 0.0, w]))
    crank_body = mbs.AddObject(ObjectRigidBody2D(nodeNumber=crank, mass=1.0, inertia=1e-3))
    for k in range(2):
        mbs.AddObject(ObjectConnectorCoordinate(markerNumbers=[ground, mbs.AddMarker(
            MarkerNodeCoordinate(nodeNumber=crank, coordinate=k))]))
    mbs.AddObject(ObjectConnectorCoordinate(markerNumbers=[ground, mbs.AddMarker(
        MarkerNodeCoordinate(nodeNumber=crank, coordinate=2))], offset=w, velocityLevel=True))
    disc = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[e, 0.0, 0.0], initialCoordinates=[0.0, 0.0, -start_te_rad],
                                       initialVelocities=[0.0, e * w, -w / zc]))
    disc_body = mbs.AddObject(ObjectRigidBody2D(nodeNumber=disc, mass=disc_mass_kg, inertia=disc_inertia_kg_m2))
    if eccentric_bearing is None:
        mbs.AddObject(ObjectJointRevolute2D(markerNumbers=[
            mbs.AddMarker(MarkerBodyPosition(bodyNumber=crank_body, localPosition=[e, 0.0, 0.0])),
            mbs.AddMarker(MarkerBodyPosition(bodyNumber=disc_body, localPosition=[0.0, 0.0, 0.0]))]))
    else:
        add_clearance_bearing(mbs, mbs.AddMarker(MarkerBodyRigid(bodyNumber=crank_body, localPosition=[e, 0.0, 0.0])),
                              mbs.AddMarker(MarkerBodyRigid(bodyNumber=disc_body, localPosition=[0.0, 0.0, 0.0])),
                              eccentric_bearing, extra_clearance_m=eccentric_clearance_m)
    mbs.AddLoad(LoadCoordinate(markerNumber=mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=disc, coordinate=2)),
                               load=resisting_torque_Nm))
    if curve_circles_segments:
        ring = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0.0, 0.0, 0.0]))
        ring_body = mbs.AddObject(ObjectRigidBody2D(nodeNumber=ring, mass=5.0, inertia=0.1))
        for k in range(3):  # Exudyn wants the circle markers on a body, not on ground
            mbs.AddObject(ObjectConnectorCoordinate(markerNumbers=[ground, mbs.AddMarker(
                MarkerNodeCoordinate(nodeNumber=ring, coordinate=k))]))
        pins = [mbs.AddMarker(MarkerBodyRigid(bodyNumber=ring_body, localPosition=[p[0], p[1], 0.0]))
                for p in pin_centres(stage)]
        seg = arc_length_segments(stage, curve_circles_segments)
        data = mbs.AddNode(NodeGenericData(initialCoordinates=[0.0] * (3 * len(seg)),
                                           numberOfDataCoordinates=3 * len(seg)))
        contact = mbs.AddObject(ObjectContactCurveCircles(
            markerNumbers=[mbs.AddMarker(MarkerBodyRigid(bodyNumber=disc_body))] + pins, nodeNumber=data,
            circlesRadii=list(pin_radii(stage)), segmentsData=exu.MatrixContainer(seg),
            contactStiffness=curve_circles_stiffness_N_m2, contactDamping=curve_circles_damping_Ns_m2))
    else:
        contact = add_cycloid_pin_contact(mbs, disc, stage, law)
    s_crank = mbs.AddSensor(SensorNode(nodeNumber=crank, outputVariableType=exu.OutputVariableType.Coordinates,
                                       storeInternal=True, writeToFile=False))
    s_disc = mbs.AddSensor(SensorNode(nodeNumber=disc, outputVariableType=exu.OutputVariableType.Coordinates,
                                      storeInternal=True, writeToFile=False))
    mbs.Assemble()
    return DynamicDisc(sc, mbs, stage, crank, disc, contact, w, s_crank, s_disc)


def run_dynamic(bench: DynamicDisc, crank_revolutions: float, step_s: float,
                spectral_radius: float = 0.8) -> tuple[np.ndarray, np.ndarray, float]:
    """Integrate with generalized-α; returns crank angle (rad), TE (rad) and wall time (s).

    TE = disc angle − (−θ_crank/z_c), counted positive in the disc's direction of motion.
    """
    import time

    mbs = bench.mbs
    end = crank_revolutions * 2 * np.pi / bench.crank_speed_rad_s
    ss = generalized_alpha_settings(end, step_s, spectral_radius, relative_tolerance=1e-10)
    t0 = time.perf_counter()
    mbs.SolveDynamic(ss)
    wall = time.perf_counter() - t0
    crank = np.asarray(mbs.GetSensorStoredData(bench.sensor_crank))
    disc = np.asarray(mbs.GetSensorStoredData(bench.sensor_disc))
    theta = crank[:, 3]
    return theta, -(disc[:, 3] + theta / bench.stage.disc_teeth), wall

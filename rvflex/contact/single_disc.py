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

from rvflex.contact.cycloid_pin import ContactLaw, CycloidPinContact, add_cycloid_pin_contact
from rvflex.geometry.pins import nominal_disc_pose
from rvflex.spec import CycloidStage, ErrorSpec

__all__ = ["SingleDisc", "build_single_disc", "quasi_static_te"]

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
    from exudyn.itemInterface import (LoadCoordinate, MarkerNodeCoordinate, NodePointGround, NodeRigidBody2D,
                                      ObjectConnectorCoordinate, ObjectConnectorCoordinateSpringDamper,
                                      ObjectRigidBody2D)

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
    from rvflex.geometry.clearance import initial_clearance_numeric

    cl = initial_clearance_numeric(bench.stage, bench.errors, bench.disc, theta, profile=bench.contact.profile)
    # a positive (resisting) torque turns the disc positive: TE = −turn
    turn = cl.turn_pos_rad + FIRST_CONTACT_BIAS_RAD if torque > 0 else cl.turn_neg_rad - FIRST_CONTACT_BIAS_RAD
    return -turn

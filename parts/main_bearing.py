"""The output carrier as a spatial rigid body on its main bearing pair, in Exudyn.

A ``NodeRigidBodyRxyz`` carrier held by one Exudyn ``ObjectConnectorSpringDamper`` per ball,
between the ball's inner groove centre on the carrier and its outer groove centre on the
ground, so each ball acts along its contact line and its contact angle follows the load (built-in
connectors: no Python runs per ball or step). The carrier's turn about the axis is locked (the
gear train holds it). Each spring is the ball's law linearised at the preloaded, unloaded state:
stiffness dQ/dδ and a reference length that makes it carry the preload ball load Q₀. With the
``"linear"`` law of :mod:`rvflex.contact.angular_contact` this is that law exactly while every
ball stays loaded; with ``"hertz"`` it is the pair's tangent at zero load. The quasi-static
moment rigidity itself comes from :func:`rvflex.contact.angular_contact.solve` (nonlinear Hertz,
contact loss); this model is its independent cross-check and the carrier body a spatial reducer
model builds on.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rvflex.contact.angular_contact import PairLoad, PairModel

__all__ = ["MainBearingHandles", "build", "linearised_springs", "static_displacement"]


@dataclass(frozen=True)
class MainBearingHandles:
    """Items of the carrier on its bearing pair.

    Parameters
    ----------
    node : int
        The carrier's rigid-body node (Tait–Bryan xyz angles), at the pair's centre.
    body : int
        The carrier body.
    marker : int
        Rigid node marker at the pair's centre, where loads act.
    springs : tuple of int
        One spring-damper per ball, rows as in the :class:`PairModel`.
    torsion_lock : int
        Constraint holding the carrier's turn about the axis.
    force_load, torque_load : int
        The force and tilting-moment loads on ``marker``.
    """

    node: int
    body: int
    marker: int
    springs: tuple[int, ...]
    torsion_lock: int
    force_load: int
    torque_load: int


def linearised_springs(model: PairModel) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness (N/m) and reference length (m) of each ball's spring, linearised at no load.

    Parameters
    ----------
    model : PairModel
        The bearing pair's model.

    Returns
    -------
    tuple of numpy.ndarray
        (stiffness, reference length), one entry per ball.

    Raises
    ------
    ValueError
        A ball without stiffness at no load (no preload): the springs would leave the carrier free.
    """
    length = np.linalg.norm(model.outer_centres_m - model.inner_centres_m, axis=1)
    squeeze = length - model.centre_distance_m
    k = model.ball_stiffness_N_m(squeeze)
    if not np.all(k > 0.0):
        raise ValueError("main bearing pair without preload: the balls have no stiffness at no load")
    return k, length - model.ball_load_N(squeeze) / k


def build(mbs, model: PairModel, *, mass_kg: float = 1.0, inertia_kg_m2: tuple[float, float, float] = (1e-3, 1e-3, 2e-3),
          load: PairLoad | None = None) -> MainBearingHandles:
    """Add the carrier on its main bearing pair to ``mbs`` (not assembled).

    Parameters
    ----------
    mbs : exudyn.MainSystem
        The system to add to.
    model : PairModel
        The bearing pair's model (:func:`rvflex.contact.angular_contact.pair_model`); needs a preload.
    mass_kg : float, optional
        Carrier mass, kg (static solutions do not depend on it).
    inertia_kg_m2 : tuple of float, optional
        Principal moments of inertia (I_xx, I_yy, I_zz) at the pair's centre, kg·m².
    load : PairLoad, optional
        Force and tilting moment on the carrier at the pair's centre (N, N·m); default none.

    Returns
    -------
    MainBearingHandles
        The items added.
    """
    from exudyn.itemInterface import (
        LoadForceVector,
        LoadTorqueVector,
        MarkerBodyPosition,
        MarkerNodeCoordinate,
        MarkerNodeRigid,
        NodePointGround,
        NodeRigidBodyRxyz,
        ObjectConnectorCoordinate,
        ObjectConnectorSpringDamper,
        ObjectGround,
        ObjectRigidBody,
    )

    load = PairLoad() if load is None else load
    stiffness, reference = linearised_springs(model)
    ground = mbs.AddObject(ObjectGround())
    node = mbs.AddNode(NodeRigidBodyRxyz(referenceCoordinates=[0.0] * 6))
    ixx, iyy, izz = inertia_kg_m2
    body = mbs.AddObject(ObjectRigidBody(mass=mass_kg, inertia=[ixx, iyy, izz, 0.0, 0.0, 0.0], nodeNumber=node))
    springs = []
    for k, l0, p_in, p_out in zip(stiffness, reference, model.inner_centres_m, model.outer_centres_m, strict=True):
        m_in = mbs.AddMarker(MarkerBodyPosition(bodyNumber=body, localPosition=p_in.tolist()))
        m_out = mbs.AddMarker(MarkerBodyPosition(bodyNumber=ground, localPosition=p_out.tolist()))
        springs.append(int(mbs.AddObject(ObjectConnectorSpringDamper(
            markerNumbers=[m_out, m_in], referenceLength=float(l0), stiffness=float(k), damping=0.0))))
    ground_node = mbs.AddNode(NodePointGround())
    m_ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ground_node, coordinate=0))
    m_turn = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=5))
    lock = mbs.AddObject(ObjectConnectorCoordinate(markerNumbers=[m_ground, m_turn]))
    marker = mbs.AddMarker(MarkerNodeRigid(nodeNumber=node))
    force = mbs.AddLoad(LoadForceVector(markerNumber=marker, loadVector=list(load.force_N)))
    torque = mbs.AddLoad(LoadTorqueVector(markerNumber=marker, loadVector=[*load.moment_Nm, 0.0]))
    return MainBearingHandles(int(node), int(body), int(marker), tuple(springs), int(lock), int(force), int(torque))


def static_displacement(model: PairModel, load: PairLoad) -> np.ndarray:
    """Static (δx, δy, δz, θx, θy) of the Exudyn carrier under ``load`` (m, rad).

    Parameters
    ----------
    model : PairModel
        The bearing pair's model; needs a preload.
    load : PairLoad
        Force and tilting moment at the pair's centre (N, N·m).

    Returns
    -------
    numpy.ndarray
        Displacement of the pair's centre (m) and the Tait–Bryan tilt angles about x and y (rad).

    Raises
    ------
    RuntimeError
        Exudyn's static solver did not converge.
    """
    import exudyn as exu

    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    handles = build(mbs, model, load=load)
    mbs.Assemble()
    ss = exu.SimulationSettings()
    ss.staticSolver.verboseMode = 0
    # the preloaded balls' forces (tens of N each) cancel: their round-off floors the residual
    # near 1e-9 N, so 1e-9 of the load is as tight as it converges
    ss.staticSolver.newton.relativeTolerance = 1e-9
    ss.staticSolver.newton.absoluteTolerance = 1e-7
    ss.solution.file.write = False
    ss.linearSolver.solverType = exu.LinearSolverType.EXUdense
    if not mbs.SolveStatic(ss):
        raise RuntimeError("main bearing pair: Exudyn's static solver did not converge")
    q = np.asarray(mbs.GetNodeOutput(handles.node, exu.OutputVariableType.Coordinates))
    return q[:5].copy()

"""The output carrier as a spatial rigid body on its main bearing pair, in Exudyn.

The pair element (:func:`add_pair_element`) is the pair's own law in the multibody model: an
``ObjectGenericODE2`` on the carrier's ``NodeRigidBodyRxyz`` whose force and analytic Jacobian come from the
numba kernel :func:`rvflex.contact.angular_contact.pair_kernel` that :func:`~rvflex.contact.angular_contact.solve`
uses (nonlinear Hertz, contact loss, one call for all balls).

The spring model (:func:`build`) is an independent cross-check of both: a ``NodeRigidBodyRxyz`` carrier held
by one Exudyn ``ObjectConnectorSpringDamper`` per ball, between the ball's inner groove centre on the carrier
and its outer groove centre on the ground, so each ball acts along its contact line and its contact angle
follows the load (built-in connectors: no Python runs per ball or step), the carrier turned by finite
rotations. The carrier's turn about the axis is locked (the gear train holds it). Each spring is the ball's
law linearised at the preloaded, unloaded state: stiffness dQ/dδ and a reference length that makes it carry
the preload ball load Q₀. With the ``"linear"`` law of :mod:`rvflex.contact.angular_contact` this is that law
exactly while every ball stays loaded; with ``"hertz"`` it is the pair's tangent at zero load.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rvflex.choices import PairContacts, check_choice
from rvflex.contact.angular_contact import PairLoad, PairModel, pair_kernel

__all__ = ["MainBearingHandles", "PairElement", "add_pair_element", "build", "linearised_springs",
           "static_displacement"]

_NODE = 6  # coordinates of a NodeRigidBodyRxyz: x, y, z, ψx, ψy, ψz


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


@dataclass(frozen=True, eq=False)
class PairElement:
    """The main bearing pair as one Exudyn element on the carrier's node (:func:`add_pair_element`).

    The carrier's displacement from its reference pose is q = (x, y, z, ψx, ψy) of the node's coordinates: the
    node's reference point is the pair's centre, its reference tilt zero, and the tilts act on the balls as the
    small rotations of :func:`rvflex.contact.angular_contact.solve` (exact to first order; the turn ψz, which the
    gear train sets, does not load the balls: the raceways are rings about the axis). The element's generalized
    force on q is the kernel's; a load conjugate to q (Exudyn ``LoadCoordinate`` on the node) is the pair's
    :class:`~rvflex.contact.angular_contact.PairLoad` exactly, and equals a moment vector to O(θ). No damping.

    Parameters
    ----------
    object : int
        The ``ObjectGenericODE2``.
    node : int
        The carrier's ``NodeRigidBodyRxyz``.
    model : PairModel
        The pair it evaluates.
    """

    object: int
    node: int
    model: PairModel
    _work: _PairWork = field(repr=False)

    @property
    def seat_m(self) -> np.ndarray:
        """(x, y, 0, 0, 0): the outer rings' seat off the node's reference point (m, rad); the balls see the node's
        (x, y, z, ψx, ψy) less it."""
        return self._work.seat.copy()

    def evaluate(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Force (6,) on the node's coordinates (N, N·m; zero on ψz), its stiffness −∂f/∂q (6, 6), and each
        ball's load (N), at the node's displacement coordinates ``q`` (6,) (m, rad; the balls see them less the
        seat offset)."""
        w = self._fill(np.asarray(q, dtype=float))
        return w.f.copy(), w.k.copy(), w.load.copy()

    def _fill(self, q: np.ndarray) -> _PairWork:
        w, m = self._work, self.model
        np.subtract(q[:5], w.seat, out=w.q5)  # the carrier relative to the outer rings' seat
        pair_kernel(w.q5, m.inner_centres_m, m.outer_centres_m, m.centre_distance_m, m.stiffness, m.law_code,
                    w.f5, w.k5, w.load, w.unit, w.squeeze)
        w.f[:5], w.k[:5, :5] = w.f5, w.k5
        w.key = q.tobytes()  # the Jacobian call checks it is asked at this state
        return w

    def _force_uf(self, mbs, t, item, q, q_t):
        return self._fill(np.asarray(q, dtype=float)).f

    def _jacobian_uf(self, mbs, t, item, q, q_t, f_ode2, f_ode2_t):
        q = np.asarray(q, dtype=float)
        w = self._work if self._work.key == q.tobytes() else self._fill(q)  # Newton asks where the force was
        return w.k if f_ode2 == 1.0 else f_ode2 * w.k


@dataclass(eq=False)
class _PairWork:
    """Buffers of the element's user functions: the last evaluated state and its force and stiffness."""

    f5: np.ndarray
    k5: np.ndarray
    f: np.ndarray
    k: np.ndarray
    load: np.ndarray
    unit: np.ndarray
    squeeze: np.ndarray
    seat: np.ndarray  # (x, y, 0, 0, 0): the outer rings' seat off the node's reference point (m)
    q5: np.ndarray
    key: bytes = b""

    @classmethod
    def for_balls(cls, n: int, seat_m: tuple[float, float] = (0.0, 0.0)) -> _PairWork:
        return cls(np.zeros(5), np.zeros((5, 5)), np.zeros(_NODE), np.zeros((_NODE, _NODE)), np.zeros(n),
                   np.zeros((n, 3)), np.zeros(n), np.array([seat_m[0], seat_m[1], 0.0, 0.0, 0.0]), np.zeros(5))


def add_pair_element(mbs, carrier_node: int, model: PairModel, *,
                     seat_offset_m: tuple[float, float] = (0.0, 0.0)) -> PairElement:
    """Add the main bearing pair acting on the carrier's node to ``mbs`` (not assembled).

    Parameters
    ----------
    mbs : exudyn.MainSystem
        The system to add to.
    carrier_node : int
        The carrier's ``NodeRigidBodyRxyz``; its reference point is the pair's centre (on the axis, midway
        between the rows) and its reference tilt (ψx, ψy) zero.
    model : PairModel
        The pair (:func:`rvflex.contact.angular_contact.pair_model`); with or without preload.
    seat_offset_m : tuple of float, optional
        (x, y) of the outer rings' axis in the housing off the node's reference point (m): a runout of the
        carrier's seat (``ErrorSpec.carrier_runout_m``); the balls are unloaded by the preload alone where the
        carrier sits on that axis.

    Returns
    -------
    PairElement
        The element and its node.

    Raises
    ------
    ValueError
        The node is not a ``NodeRigidBodyRxyz`` or its reference pose is tilted.
    """
    from exudyn.itemInterface import ObjectGenericODE2

    node = mbs.GetNode(carrier_node)
    if node["nodeType"] != "RigidBodyRxyz":
        raise ValueError(f"main bearing pair: node {carrier_node} is a {node['nodeType']} node, not RigidBodyRxyz")
    ref = np.asarray(node["referenceCoordinates"], dtype=float)
    if np.any(ref[3:5] != 0.0):
        raise ValueError(f"main bearing pair: node {carrier_node}'s reference tilt (ψx, ψy) = {ref[3:5].tolist()} "
                         "rad must be zero (the balls' kinematics start from the untilted carrier)")
    seat = tuple(float(v) for v in seat_offset_m)
    if len(seat) != 2 or not all(np.isfinite(seat)):
        raise ValueError(f"main bearing pair: seat_offset_m = {seat_offset_m!r} must be two finite lengths (m)")
    element = PairElement(-1, int(carrier_node), model, _PairWork.for_balls(model.n_balls, seat))
    zero = np.zeros((_NODE, _NODE))
    idx = mbs.AddObject(ObjectGenericODE2(nodeNumbers=[carrier_node], massMatrix=zero, stiffnessMatrix=zero,
                                          dampingMatrix=zero, forceUserFunction=element._force_uf,
                                          jacobianUserFunction=element._jacobian_uf))
    object.__setattr__(element, "object", int(idx))
    return element


def _carrier(mbs, mass_kg: float, inertia_kg_m2: tuple[float, float, float]) -> tuple[int, int, int]:
    """A carrier body on a NodeRigidBodyRxyz at the origin, its turn about the axis locked: (node, body, lock)."""
    from exudyn.itemInterface import (
        MarkerNodeCoordinate,
        NodePointGround,
        NodeRigidBodyRxyz,
        ObjectConnectorCoordinate,
        ObjectRigidBody,
    )

    node = mbs.AddNode(NodeRigidBodyRxyz(referenceCoordinates=[0.0] * _NODE))
    ixx, iyy, izz = inertia_kg_m2
    body = mbs.AddObject(ObjectRigidBody(mass=mass_kg, inertia=[ixx, iyy, izz, 0.0, 0.0, 0.0], nodeNumber=node))
    m_ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()), coordinate=0))
    m_turn = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=5))
    lock = mbs.AddObject(ObjectConnectorCoordinate(markerNumbers=[m_ground, m_turn]))
    return int(node), int(body), int(lock)


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
        MarkerNodeRigid,
        ObjectConnectorSpringDamper,
        ObjectGround,
    )

    load = PairLoad() if load is None else load
    stiffness, reference = linearised_springs(model)
    ground = mbs.AddObject(ObjectGround())
    node, body, lock = _carrier(mbs, mass_kg, inertia_kg_m2)
    springs = []
    for k, l0, p_in, p_out in zip(stiffness, reference, model.inner_centres_m, model.outer_centres_m, strict=True):
        m_in = mbs.AddMarker(MarkerBodyPosition(bodyNumber=body, localPosition=p_in.tolist()))
        m_out = mbs.AddMarker(MarkerBodyPosition(bodyNumber=ground, localPosition=p_out.tolist()))
        springs.append(int(mbs.AddObject(ObjectConnectorSpringDamper(
            markerNumbers=[m_out, m_in], referenceLength=float(l0), stiffness=float(k), damping=0.0))))
    marker = mbs.AddMarker(MarkerNodeRigid(nodeNumber=node))
    force = mbs.AddLoad(LoadForceVector(markerNumber=marker, loadVector=list(load.force_N)))
    torque = mbs.AddLoad(LoadTorqueVector(markerNumber=marker, loadVector=[*load.moment_Nm, 0.0]))
    return MainBearingHandles(node, body, int(marker), tuple(springs), lock, int(force), int(torque))


def static_displacement(model: PairModel, load: PairLoad, *,
                        contacts: PairContacts = "springs") -> np.ndarray:
    """Static (δx, δy, δz, θx, θy) of the Exudyn carrier under ``load`` (m, rad).

    Parameters
    ----------
    model : PairModel
        The bearing pair's model; the springs need a preload.
    load : PairLoad
        Force and tilting moment at the pair's centre (N, N·m).
    contacts : {"springs", "element"}, optional
        The carrier on one linearised spring per ball (:func:`build`; the load a force and a torque vector),
        or on the pair element (:func:`add_pair_element`; the load the generalized force conjugate to the
        element's coordinates, as :func:`rvflex.contact.angular_contact.solve` takes it).

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

    check_choice("contacts", contacts, PairContacts)
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    if contacts == "springs":
        node = build(mbs, model, load=load).node
    else:
        from exudyn.itemInterface import LoadCoordinate, MarkerNodeCoordinate

        node = _carrier(mbs, 1.0, (1e-3, 1e-3, 2e-3))[0]
        add_pair_element(mbs, node, model)
        for k, value in enumerate(load.vector()):
            mbs.AddLoad(LoadCoordinate(markerNumber=mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=k)),
                                       load=float(value)))
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
    q = np.asarray(mbs.GetNodeOutput(node, exu.OutputVariableType.Coordinates))
    return q[:5].copy()

"""Carrier (output flange): a planar body on the main bearing, loaded by the output torque,
with the crank bores at the (error-shifted) crank positions.

``fidelity="flexible"`` (:func:`build` with ``reduced``, a carrier
:class:`rvflex.fe.reduce.ReducedPart`): the carrier is an ``ObjectFFRFreducedOrder`` on a
``NodeRigidBodyRxyz`` held in the plane (z, ψx, ψy), whose floating frame is the output face
(clamped in every mode): the output angle, the output load, its regulariser and the main
bearing act on that frame — the output face, where the driven machine is bolted and the
output encoder measures. Each crank has two support bearings, one per plate seat, each half
of the spec's lumped pair (``split_support_bearing``), on distributing (RBE3)
``MarkerSuperElementRigid`` seat markers. By default (``seat_marker="virtual"``) a seat marker
holds four massless virtual nodes appended to the reduced carrier whose mode rows are the
seat's RBE3 motion (:func:`rvflex.fe.couplings.rbe3_virtual_nodes`): the same kinematics, hence
the same loads, as the marker on all 108–136 seat nodes with the reduction's weights
(``seat_marker="all_nodes"``), at a fraction of the cost.

:func:`build_spatial`: the carrier as a rigid body free in space (``NodeRigidBodyRxyz`` at the main pair's
centre, on the axis in the discs' mid-plane) on the main bearing pair element
(:func:`rvflex.parts.main_bearing.add_pair_element`), with a crank bore in each end plate at ±``support_span_m``/2.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from rvflex.choices import BodyFidelity, SeatMarker, check_choice, choices
from rvflex.contact.tapered_roller import half_bearing, support_rows
from rvflex.fe import ffrf as ffrf_module
from rvflex.fe.couplings import rbe3_virtual_nodes
from rvflex.numerics import OUTPUT_REGULARISER_NM_RAD  # re-exported: the regulariser this builder installs
from rvflex.parts import bearings
from rvflex.parts.main_bearing import PairElement, add_pair_element
from rvflex.spec import ErrorSpec, ReducerSpec, SpecError

__all__ = ["CarrierHandles", "build", "build_spatial", "crank_axis_positions", "OUTPUT_REGULARISER_NM_RAD",
           "add_input_seat_bearings", "split_support_bearing", "SEAT_MARKERS"]

SEAT_MARKERS = choices(SeatMarker)  # flexible carrier: seat markers on 4 virtual RBE3 nodes | on all seat nodes


@dataclass(frozen=True)
class CarrierHandles:
    """node/body of the carrier; bore_markers: one rigid marker per crank bore;
    load: LoadCoordinate of the output torque; regulariser: weak torsional spring to the
    kinematic output angle (offset set by the solver); main: the main bearing (a bushing; None on the spatial
    carrier, whose main bearing is ``pair``)."""

    node: int
    body: int
    bore_markers: tuple[int, ...]
    load: int
    regulariser: int
    main: bearings.BearingPair | None
    modal_node: int = -1  # flexible carrier: the NodeGenericODE2 of its modal coordinates
    # flexible or spatial carrier: the input-plate seat markers (bore_markers: output plate)
    input_seat_markers: tuple[int, ...] = ()
    pair: PairElement | None = None  # spatial carrier: the main bearing pair element on its node
    # spatial carrier: LoadCoordinate on its node's x, y, z, ψx, ψy (the output load; set by the solver)
    output_loads: tuple[int, ...] = ()

    @property
    def angle_coordinate(self) -> int:
        """Index of the output angle θ_out among the node's coordinates: 2 (NodeRigidBody2D x, y, θ)
        or 5 (the flexible or spatial carrier's NodeRigidBodyRxyz x, y, z, ψx, ψy, ψz)."""
        return 2 if self.modal_node < 0 and self.pair is None else 5


def crank_axis_positions(spec: ReducerSpec, errors: ErrorSpec) -> np.ndarray:
    """Crank axes in the carrier frame, (count, 2) (m): nominal circle, plus the hole-distance
    errors of the two carrier plates (mean, split symmetrically along the line between
    holes) and each bore's eccentricity."""
    c = spec.cranks
    ang = np.asarray(c.angles_rad)
    pos = c.crank_circle_radius_m * np.column_stack([np.cos(ang), np.sin(ang)])
    dhole = 0.5 * (errors.input_carrier_hole_distance_error_m + errors.output_carrier_hole_distance_error_m)
    if dhole:
        pos = pos + 0.5 * dhole * pos / np.linalg.norm(pos, axis=1, keepdims=True)
    if errors.carrier_bore_eccentricity_m:
        ph = np.asarray(errors.carrier_bore_eccentricity_phase_rad or (0.0,) * c.count)
        pos = pos + np.asarray(errors.carrier_bore_eccentricity_m)[:, None] * np.column_stack([np.cos(ph), np.sin(ph)])
    return pos


def split_support_bearing(spec: ReducerSpec) -> ReducerSpec:
    """``spec`` with the crank support bearing halved (stiffness and damping): one of the two
    tapered roller bearings of a crank that the rigid planar model lumps into one (rv40e.toml:
    seed 003's 1.6e8 N/m × 2). The flexible carrier seats each of them in its own plate."""
    import dataclasses

    half = half_bearing(spec.bearings.crank_support)
    return dataclasses.replace(spec, bearings=dataclasses.replace(spec.bearings, crank_support=half))


def add_input_seat_bearings(mbs, spec: ReducerSpec, errors: ErrorSpec, carrier: CarrierHandles,
                            cranks) -> tuple[bearings.BearingPair, ...]:
    """Flexible carrier: the second support bearing of each crank, in the input-plate seat
    (half of the lumped pair, the same clearance error as the first), on the crank marker of
    the first (``cranks.supports[k].marker1``)."""
    half = split_support_bearing(spec).bearings.crank_support
    out = []
    for k, seat in enumerate(carrier.input_seat_markers):
        extra = errors.crank_support_clearance_m[k] if errors.crank_support_clearance_m else 0.0
        out.append(bearings.build(mbs, seat, cranks.supports[k].marker1, half, extra_clearance_m=extra))
    return tuple(out)


def build(mbs, spec: ReducerSpec, errors: ErrorSpec, ground_body: int, ground_coordinate: int, *,
          fidelity: BodyFidelity = "rigid", reduced=None, seat_marker: SeatMarker = "virtual") -> CarrierHandles:
    """Add the carrier, its main bearing to the housing (with the carrier runout as an
    offset of the bearing seat) and the output load.

    ``fidelity="flexible"`` needs ``reduced`` (the Craig–Bampton carrier, output face the
    reference interface, ``seat_out<k>``/``seat_in<k>`` seat interfaces); ``bore_markers`` are
    then the output-plate seats and ``input_seat_markers`` the input-plate seats (the crank
    builder puts one support bearing on the first, :func:`add_input_seat_bearings` the other).
    ``seat_marker`` (flexible only): ``"virtual"`` (default) puts each seat marker on four massless
    virtual nodes carrying the seat's RBE3 motion, ``"all_nodes"`` on all seat nodes with the
    RBE3 weights — the same coupling (to round-off), ~N times slower (tests compare the two).
    """
    from exudyn.itemInterface import (
        LoadCoordinate,
        MarkerBodyRigid,
        MarkerNodeCoordinate,
        NodeRigidBody2D,
        ObjectConnectorCoordinateSpringDamper,
        ObjectRigidBody2D,
    )

    check_choice("fidelity", fidelity, BodyFidelity)
    if fidelity == "flexible":
        return _build_flexible(mbs, spec, errors, ground_body, ground_coordinate, reduced, seat_marker)
    ca = spec.carrier
    rho = spec.materials.carriers.density_kg_m3
    mass = rho * math.pi * ca.outer_radius_m**2 * 2 * ca.plate_thickness_m
    node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0.0, 0.0, 0.0]))
    body = mbs.AddObject(ObjectRigidBody2D(nodeNumber=node, mass=mass, inertia=0.5 * mass * ca.outer_radius_m**2))
    seat = errors.carrier_runout_m * np.array([math.cos(errors.carrier_runout_phase_rad),
                                               math.sin(errors.carrier_runout_phase_rad)])
    main = bearings.build(mbs, mbs.AddMarker(MarkerBodyRigid(bodyNumber=ground_body, localPosition=[seat[0], seat[1], 0])),
                          mbs.AddMarker(MarkerBodyRigid(bodyNumber=body, localPosition=[0.0, 0.0, 0.0])),
                          spec.bearings.main, extra_clearance_m=errors.main_bearing_clearance_m)
    bores = tuple(int(mbs.AddMarker(MarkerBodyRigid(bodyNumber=body, localPosition=[p[0], p[1], 0.0])))
                  for p in crank_axis_positions(spec, errors))
    theta = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=2))
    load = mbs.AddLoad(LoadCoordinate(markerNumber=theta, load=0.0))
    reg = mbs.AddObject(ObjectConnectorCoordinateSpringDamper(markerNumbers=[ground_coordinate, theta],
                                                              stiffness=OUTPUT_REGULARISER_NM_RAD, offset=0.0))
    return CarrierHandles(int(node), int(body), bores, int(load), int(reg), main)


def build_spatial(mbs, spec: ReducerSpec, errors: ErrorSpec, ground_coordinate: int) -> CarrierHandles:
    """Add the carrier as a rigid body free in space on its main bearing pair, and the output load.

    The node (``NodeRigidBodyRxyz``) sits at the pair's centre, on the axis in the discs' mid-plane; the pair
    element (:func:`rvflex.parts.main_bearing.add_pair_element`, Hertz balls with their preload) holds its
    x, y, z, ψx, ψy, with the carrier runout as the offset of the outer rings' seat; the output torque and the
    regulariser act on ψz. ``bore_markers`` are the output-plate crank bores' bearing points at +h,
    ``input_seat_markers`` the input-plate ones at −h (the planet gears sit at −z), h the support bearings'
    :func:`rvflex.contact.tapered_roller.support_rows` half span (``support_span_m``/2, or the tapered rows'
    pressure centres).

    Parameters
    ----------
    mbs : exudyn.MainSystem
        The system to add to.
    spec : ReducerSpec
        The reducer; needs ``bearings.main_pair`` and ``cranks.support_span_m`` (``spec.check_spatial``).
    errors : ErrorSpec
        Its errors: the carrier runout and the crank bore positions apply.
    ground_coordinate : int
        A ground coordinate marker (the regulariser's other end).

    Returns
    -------
    CarrierHandles
        With ``main`` None and ``pair`` the pair element.

    Raises
    ------
    SpecError
        A main-bearing clearance error: the pair is preloaded and has no clearance in this model.
    """
    from exudyn.itemInterface import (
        LoadCoordinate,
        MarkerBodyRigid,
        MarkerNodeCoordinate,
        NodeRigidBodyRxyz,
        ObjectConnectorCoordinateSpringDamper,
        ObjectRigidBody,
    )

    from rvflex.contact.angular_contact import pair_model

    spec.check_spatial("options.spatial")
    if errors.main_bearing_clearance_m:
        raise SpecError("errors.main_bearing_clearance_m", errors.main_bearing_clearance_m,
                        "must be 0 in the spatial model: its main bearing is the preloaded ball pair, without clearance")
    ca, half = spec.carrier, 0.5 * spec.cranks.support_span_m
    h = support_rows(spec).half_span_m  # where the crank bores' bearings carry (the rows' pressure centres)
    rho = spec.materials.carriers.density_kg_m3
    plate = rho * math.pi * ca.outer_radius_m**2 * ca.plate_thickness_m
    mass = 2 * plate
    izz = 0.5 * mass * ca.outer_radius_m**2
    ixx = mass * (ca.outer_radius_m**2 / 4 + ca.plate_thickness_m**2 / 12 + half**2)  # two plates at ±span/2
    node = int(mbs.AddNode(NodeRigidBodyRxyz(referenceCoordinates=[0.0] * 6)))
    body = int(mbs.AddObject(ObjectRigidBody(nodeNumber=node, mass=mass, inertia=[ixx, ixx, izz, 0.0, 0.0, 0.0])))
    seat = errors.carrier_runout_m * np.array([math.cos(errors.carrier_runout_phase_rad),
                                               math.sin(errors.carrier_runout_phase_rad)])
    pair = add_pair_element(mbs, node, pair_model(spec.bearings.main_pair), seat_offset_m=(seat[0], seat[1]))
    axes = crank_axis_positions(spec, errors)
    bores = tuple(int(mbs.AddMarker(MarkerBodyRigid(bodyNumber=body, localPosition=[p[0], p[1], h]))) for p in axes)
    inputs = tuple(int(mbs.AddMarker(MarkerBodyRigid(bodyNumber=body, localPosition=[p[0], p[1], -h])))
                   for p in axes)
    theta = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=5))
    load = mbs.AddLoad(LoadCoordinate(markerNumber=theta, load=0.0))
    reg = mbs.AddObject(ObjectConnectorCoordinateSpringDamper(markerNumbers=[ground_coordinate, theta],
                                                              stiffness=OUTPUT_REGULARISER_NM_RAD, offset=0.0))
    # the output load as generalized forces on x, y, z, ψx, ψy: the forces are exact (the node is the pair's
    # centre, where the load acts); a moment M on (ψx, ψy) is Gᵀ·M with G the Rxyz angular-velocity matrix, = M to
    # O(ψ) (2e-4 rad at the RV-40E's 500 N·m: a 0.02 % error of the moment)
    outs = tuple(int(mbs.AddLoad(LoadCoordinate(markerNumber=mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node,
                                                                                                  coordinate=k)),
                                                load=0.0))) for k in range(5))
    return CarrierHandles(node, body, bores, int(load), int(reg), None, input_seat_markers=inputs, pair=pair,
                          output_loads=outs)


def _build_flexible(mbs, spec, errors, ground_body, ground_coordinate, reduced,
                    seat_marker: SeatMarker = "virtual") -> CarrierHandles:
    """The FFRF carrier: reference frame = output face (clamped in all modes), planar-held."""
    from exudyn.itemInterface import (
        CoordinateConstraint,
        LoadCoordinate,
        MarkerBodyRigid,
        MarkerNodeCoordinate,
        MarkerNodeRigid,
        MarkerSuperElementRigid,
        ObjectConnectorCoordinateSpringDamper,
    )

    check_choice("seat_marker", seat_marker, SeatMarker)
    if reduced is None or reduced.part != "carrier" or int(ground_coordinate) < 0:
        raise ValueError("flexible carrier: needs the reduced carrier (reduce_part(spec, 'carrier')) and a ground "
                         "coordinate marker")
    if reduced.interfaces[0].name != "output":
        raise ValueError("flexible carrier: the reduction's reference interface must be the output face")
    ffrf = ffrf_module.ffrf_interface(reduced)
    seat_names = [f"seat_{side}{k}" for side in ("out", "in") for k in range(spec.cranks.count)]
    pos = reduced.node_positions_m
    if seat_marker == "virtual":  # massless nodes carrying each seat's RBE3 motion, appended to the mesh
        virtual = rbe3_virtual_nodes(reduced.mode_basis, pos, [reduced.interface(n) for n in seat_names])
        ffrf, first = ffrf_module.with_virtual_nodes(ffrf, virtual)
        vpos = virtual.positions_m

        def marker_nodes(name):
            g = np.asarray(virtual.group(name), int)
            return first + g, np.full(len(g), 1.0 / len(g)), vpos[g]
    else:
        def marker_nodes(name):
            itf = reduced.interface(name)
            return np.asarray(itf.nodes, int), np.asarray(itf.weights, float), pos[itf.nodes]
    h = ffrf.AddObjectFFRFreducedOrder(mbs, positionRef=[0.0, 0.0, 0.0], rotationMatrixRef=np.eye(3))
    node, modal, body = int(h["nRigidBody"]), int(h["nGenericODE2"]), int(h["oFFRFreducedOrder"])
    for coord in (2, 3, 4):  # planar: z, ψx, ψy held
        m = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=coord))
        mbs.AddObject(CoordinateConstraint(markerNumbers=[ground_coordinate, m]))
    seat = errors.carrier_runout_m * np.array([math.cos(errors.carrier_runout_phase_rad),
                                               math.sin(errors.carrier_runout_phase_rad)])
    # main bearing on the reference frame: the output face's rigid motion (frame origin on the axis)
    main = bearings.build(mbs, mbs.AddMarker(MarkerBodyRigid(bodyNumber=ground_body, localPosition=[seat[0], seat[1], 0])),
                          mbs.AddMarker(MarkerNodeRigid(nodeNumber=node)),
                          spec.bearings.main, extra_clearance_m=errors.main_bearing_clearance_m)
    axes = crank_axis_positions(spec, errors)

    def add_seat_marker(name: str, target: np.ndarray) -> int:
        nodes, w, x = marker_nodes(name)
        ref = w @ x  # the marker's reference point: the weighted centroid (the same for both kinds)
        off = math.hypot(target[0] - ref[0], target[1] - ref[1])
        if off > 1e-3:  # reduce_part keeps plain area weights when positive weights cannot centre the seat
            warnings.warn(f"flexible carrier: seat {name}'s weighted centroid lies {off * 1e3:.1f} mm off the crank "
                          f"axis (the mesh is too coarse to centre its weights): the bearing still acts on the axis "
                          f"through the marker offset, but the seat's load distribution is lopsided; use a finer "
                          f"carrier mesh", stacklevel=2)
        return int(mbs.AddMarker(MarkerSuperElementRigid(
            bodyNumber=body, offset=[target[0] - ref[0], target[1] - ref[1], -ref[2]],
            meshNodeNumbers=nodes.tolist(), weightingFactors=w.tolist())))

    bores = tuple(add_seat_marker(f"seat_out{k}", p) for k, p in enumerate(axes))
    inputs = tuple(add_seat_marker(f"seat_in{k}", p) for k, p in enumerate(axes))
    theta = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=5))
    load = mbs.AddLoad(LoadCoordinate(markerNumber=theta, load=0.0))
    reg = mbs.AddObject(ObjectConnectorCoordinateSpringDamper(markerNumbers=[ground_coordinate, theta],
                                                              stiffness=OUTPUT_REGULARISER_NM_RAD, offset=0.0))
    return CarrierHandles(node, body, bores, int(load), int(reg), main, modal, inputs)

"""Carrier (output flange): a planar body on the main bearing, loaded by the output torque,
with the crank bores at the (error-shifted) crank positions."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rvflex.spec import ErrorSpec, ReducerSpec
from rvflex.parts import bearings

__all__ = ["CarrierHandles", "build", "crank_axis_positions", "OUTPUT_REGULARISER_NM_RAD"]

OUTPUT_REGULARISER_NM_RAD = 1.0  # to the kinematic output angle: 1e-4 N·m per 1e-4 rad of TE


@dataclass(frozen=True)
class CarrierHandles:
    """node/body of the carrier; bore_markers: one rigid marker per crank bore;
    load: LoadCoordinate of the output torque; regulariser: weak torsional spring to the
    kinematic output angle (offset set by the solver); main: the main bearing."""

    node: int
    body: int
    bore_markers: tuple[int, ...]
    load: int
    regulariser: int
    main: bearings.BearingPair


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


def build(mbs, spec: ReducerSpec, errors: ErrorSpec, ground_body: int, ground_coordinate: int, *,
          fidelity: str = "rigid") -> CarrierHandles:
    """Add the carrier, its main bearing to the housing (with the carrier runout as an
    offset of the bearing seat) and the output load."""
    from exudyn.itemInterface import (LoadCoordinate, MarkerBodyRigid, MarkerNodeCoordinate, NodeRigidBody2D,
                                      ObjectConnectorCoordinateSpringDamper, ObjectRigidBody2D)

    if fidelity != "rigid":
        raise NotImplementedError(f"fidelity = {fidelity!r}: the flexible carrier comes with the FE issue")
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

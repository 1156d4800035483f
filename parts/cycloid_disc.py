"""Cycloid discs: one planar body per disc on the crank eccentrics (clearance bearings in
its crank bores), meshing with the pin ring through the exact contact element."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rvflex.contact.cycloid_pin import ContactLaw, CycloidPinContact, add_cycloid_pin_contact
from rvflex.parts import bearings
from rvflex.spec import ErrorSpec, ReducerSpec

__all__ = ["DiscHandles", "build", "bore_positions"]


@dataclass(frozen=True)
class DiscHandles:
    """Per disc: node, body, pin contact and its eccentric bearings (one per crank)."""

    nodes: tuple[int, ...]
    bodies: tuple[int, ...]
    contacts: tuple[CycloidPinContact, ...]
    eccentric_bearings: tuple[tuple[bearings.BearingPair, ...], ...]


def bore_positions(spec: ReducerSpec, errors: ErrorSpec, disc: int) -> np.ndarray:
    """Crank-bore centres in the disc frame, (cranks, 2) (m); a bore-distance error a_c moves
    each bore radially by half of it."""
    c = spec.cranks
    ang = np.asarray(c.angles_rad)
    r = c.crank_circle_radius_m + 0.5 * (errors.disc_bore_distance_error_m[disc] if errors.disc_bore_distance_error_m
                                         else 0.0)
    return r * np.column_stack([np.cos(ang), np.sin(ang)])


def build(mbs, spec: ReducerSpec, errors: ErrorSpec, cranks, law: ContactLaw, eccentric_offsets: np.ndarray,
          axes: np.ndarray, *, fidelity: str = "rigid") -> DiscHandles:
    """Add the discs at their reference poses (output angle 0): disc d's centre is where its
    eccentrics put it, crank axis + eccentric − bore (averaged over the cranks)."""
    from exudyn.itemInterface import MarkerBodyRigid, NodeRigidBody2D, ObjectRigidBody2D

    if fidelity != "rigid":
        raise NotImplementedError(f"fidelity = {fidelity!r}: the flexible disc comes with the FE issue")
    cy = spec.cycloid
    rho = spec.materials.gears_cranks_discs.density_kg_m3
    r_out = cy.pin_circle_radius_m - cy.pin_radius_m
    mass = rho * math.pi * (r_out**2 - cy.disc_center_hole_radius_m**2) * cy.disc_thickness_m
    inertia = 0.5 * mass * (r_out**2 + cy.disc_center_hole_radius_m**2)
    nodes, bodies, contacts, ecc_bearings = [], [], [], []
    for d in range(cy.disc_count):
        bores = bore_positions(spec, errors, d)
        centre = np.mean(axes + eccentric_offsets[:, d] - bores, axis=0)
        node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[centre[0], centre[1], 0.0]))
        body = mbs.AddObject(ObjectRigidBody2D(nodeNumber=node, mass=mass, inertia=inertia))
        pairs = []
        for k in range(spec.cranks.count):
            idx = k * cy.disc_count + d
            extra = errors.eccentric_bearing_clearance_m[idx] if errors.eccentric_bearing_clearance_m else 0.0
            bore = mbs.AddMarker(MarkerBodyRigid(bodyNumber=body, localPosition=[bores[k, 0], bores[k, 1], 0.0]))
            pairs.append(bearings.build(mbs, cranks.eccentric_markers[k][d], bore, spec.bearings.eccentric,
                                        extra_clearance_m=extra))
        # pin and disc errors may make pins interfere by a few µm at the nominal pose (the first
        # static step resolves it); deeper than 50 µm would be a broken spec
        contacts.append(add_cycloid_pin_contact(mbs, node, cy, law, disc=d, errors=errors,
                                                initial_interference_m=50e-6))
        nodes.append(int(node))
        bodies.append(int(body))
        ecc_bearings.append(tuple(pairs))
    return DiscHandles(tuple(nodes), tuple(bodies), tuple(contacts), tuple(ecc_bearings))

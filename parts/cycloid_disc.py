"""Cycloid discs: one planar body per disc on the crank eccentrics (clearance bearings in
its crank bores), meshing with the pin ring through the exact contact element."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rvflex.choices import BodyFidelity, check_choice
from rvflex.contact.cycloid_pin import ContactLaw, CycloidPinContact, add_cycloid_pin_contact
from rvflex.fe import ffrf as ffrf_module  # called through the module: tests stand in for ffrf_interface
from rvflex.fe.geometry import pillar_angles
from rvflex.parts import bearings
from rvflex.spec import ErrorSpec, ReducerSpec

__all__ = ["DiscHandles", "build", "bore_positions", "contact_mode_table"]


@dataclass(frozen=True)
class DiscHandles:
    """Per disc: node, body, pin contact and its eccentric bearings (one per crank)."""

    nodes: tuple[int, ...]
    bodies: tuple[int, ...]
    contacts: tuple[CycloidPinContact, ...]
    eccentric_bearings: tuple[tuple[bearings.BearingPair, ...], ...]
    modal_nodes: tuple[int, ...] = ()  # flexible discs: the NodeGenericODE2 of each disc's modes


def contact_mode_table(flank, offset_rad: float, grid_per_tooth: int, teeth: int) -> np.ndarray:
    """The FE disc's flank mode rows (body frame, :class:`rvflex.fe.reduce.FlankRows`) on the
    contact element's uniform grid in a disc's profile frame, turned by ``offset_rad`` (a
    whole number of teeth) against the FE frame.

    A tooth turn shifts the profile parameter by the same angle (p(t + 2π/z_c) =
    e^{2πi/z_c}·p(t) for z_b = z_c + 1), so profile parameter t sits at t + offset on the FE
    disc; the rows are turned back by −offset into the profile frame. Returns (n_grid, 2, m).
    """
    n_grid = teeth * grid_per_tooth
    t = 2 * math.pi * np.arange(n_grid) / n_grid
    rows = flank.rows_at(t + offset_rad)
    c, s_ = math.cos(offset_rad), math.sin(offset_rad)
    out = np.empty_like(rows)
    out[:, 0] = c * rows[:, 0] + s_ * rows[:, 1]
    out[:, 1] = -s_ * rows[:, 0] + c * rows[:, 1]
    return np.ascontiguousarray(out)


def bore_positions(spec: ReducerSpec, errors: ErrorSpec, disc: int) -> np.ndarray:
    """Crank-bore centres in the disc frame, (cranks, 2) (m); a bore-distance error a_c moves
    each bore radially by half of it."""
    c = spec.cranks
    ang = np.asarray(c.angles_rad)
    r = c.crank_circle_radius_m + 0.5 * (errors.disc_bore_distance_error_m[disc] if errors.disc_bore_distance_error_m
                                         else 0.0)
    return r * np.column_stack([np.cos(ang), np.sin(ang)])


def build(mbs, spec: ReducerSpec, errors: ErrorSpec, cranks, law: ContactLaw, eccentric_offsets: np.ndarray,
          axes: np.ndarray, *, fidelity: BodyFidelity = "rigid", reduced=None, ground_coordinate: int = -1) -> DiscHandles:
    """Add the discs at their reference poses (output angle 0): disc d's centre is where its
    eccentrics put it, crank axis + eccentric − bore (averaged over the cranks).

    ``fidelity="flexible"`` needs ``reduced``, the Craig–Bampton disc
    (:class:`rvflex.fe.reduce.ReducedPart`: FEMinterface with its modes, the bore
    interfaces, bore 0 the floating-frame reference, and the flank mode rows) and
    ``ground_coordinate``, a ground coordinate marker that holds each disc's out-of-plane
    coordinates (z, ψx, ψy).
    """
    check_choice("fidelity", fidelity, BodyFidelity)
    if fidelity == "flexible":
        return _build_flexible(mbs, spec, errors, cranks, law, eccentric_offsets, axes, reduced, ground_coordinate)
    from exudyn.itemInterface import MarkerBodyRigid, NodeRigidBody2D, ObjectRigidBody2D

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


def _marker_nodes(positions: np.ndarray, ring: np.ndarray) -> np.ndarray:
    """Four nodes of an RBE2 bore ring that carry its rigid motion exactly: the ring moves
    rigidly in every Craig–Bampton mode, so four well-spread nodes (two per face, a quarter
    turn apart) give the same marker as all of them at a fraction of the cost — the cost of
    MarkerSuperElementRigid grows with its node count and dominates the Jacobian."""
    p = positions[ring]
    c = p.mean(axis=0)
    ang = np.arctan2(p[:, 1] - c[1], p[:, 0] - c[0])
    picks = []
    for z_side, target in ((p[:, 2].min(), 0.0), (p[:, 2].min(), 0.5 * math.pi), (p[:, 2].max(), math.pi),
                           (p[:, 2].max(), 1.5 * math.pi)):
        cost = np.abs(np.angle(np.exp(1j * (ang - target)))) + 1e3 * np.abs(p[:, 2] - z_side)
        picks.append(int(ring[np.argmin(cost)]))
    picks = list(dict.fromkeys(picks))
    return np.asarray(picks if len(picks) >= 3 else ring, dtype=int)


def _half_turn_symmetric(spec: ReducerSpec) -> bool:
    """z_c odd, and cranks and pillars map onto themselves under a half turn."""
    def symmetric(angles) -> bool:
        a = np.mod(np.asarray(angles, float), 2 * math.pi)
        b = np.mod(a + math.pi, 2 * math.pi)
        return all(np.min(np.abs(np.angle(np.exp(1j * (a - x))))) < 1e-9 for x in b)

    return spec.cycloid.disc_teeth % 2 == 1 and symmetric(spec.cranks.angles_rad) and symmetric(pillar_angles(spec))


def _build_flexible(mbs, spec, errors, cranks, law, eccentric_offsets, axes, reduced, ground_coordinate) -> DiscHandles:
    """FFRF reduced-order discs (ObjectFFRFreducedOrder on a NodeRigidBodyRxyz held in the
    plane): bearings on MarkerSuperElementRigid at the bores, the contact with the modal flank
    displacement. Global deformation is in the modes; the local Hertz approach stays in the
    contact law (the flank rows average the mesh over a patch of a few mm of flank, so the
    mesh's own local contact deformation is not sampled)."""
    from exudyn.itemInterface import CoordinateConstraint, MarkerNodeCoordinate, MarkerSuperElementRigid

    if reduced is None or int(ground_coordinate) < 0:
        raise ValueError("fidelity = 'flexible': needs the reduced disc and a ground coordinate marker")
    cy = spec.cycloid
    positions = reduced.node_positions_m
    if reduced.flank is None or reduced.flank.rows.shape[0] % cy.disc_teeth:
        raise ValueError("fidelity = 'flexible': the reduced disc has no flank mode rows on a whole-tooth grid")
    grid_per_tooth = reduced.flank.rows.shape[0] // cy.disc_teeth
    ffrf = ffrf_module.ffrf_interface(reduced)  # one interface (cached on disk) serves every disc
    nodes, bodies, contacts, ecc_bearings, modal_nodes = [], [], [], [], []
    for d in range(cy.disc_count):
        if errors.disc_bore_distance_error_m and errors.disc_bore_distance_error_m[d]:
            raise ValueError("fidelity = 'flexible': disc bore-distance errors need their own FE geometry (not yet)")
        bores = bore_positions(spec, errors, d)
        centre = np.mean(axes + eccentric_offsets[:, d] - bores, axis=0)
        # the FE disc is disc 0 (profile frame = body frame); disc d's profile is turned by
        # −φ_d/z_c against its bores. With z_c odd and a layout symmetric under a half turn
        # (RV: two cranks and pillars opposite), that disc is the FE disc turned by β = π.
        beta = 0.0 if cy.disc_phase_rad[d] == 0.0 else math.pi
        if beta and not _half_turn_symmetric(spec):
            raise ValueError(f"fidelity = 'flexible': disc {d} (phase {cy.disc_phase_rad[d]:.4f} rad) needs its own "
                             "FE geometry; only a layout symmetric under a half turn with odd z_c reuses disc 0")
        rot = np.array([[math.cos(beta), -math.sin(beta), 0.0], [math.sin(beta), math.cos(beta), 0.0], [0, 0, 1.0]])
        h = ffrf.AddObjectFFRFreducedOrder(mbs, positionRef=[centre[0], centre[1], 0.0], rotationMatrixRef=rot)
        node, modal, body = int(h["nRigidBody"]), int(h["nGenericODE2"]), int(h["oFFRFreducedOrder"])
        for coord in (2, 3, 4):  # planar: z, ψx, ψy held
            m = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=coord))
            mbs.AddObject(CoordinateConstraint(markerNumbers=[ground_coordinate, m]))
        pairs = []
        for k in range(spec.cranks.count):
            idx = k * cy.disc_count + d
            extra = errors.eccentric_bearing_clearance_m[idx] if errors.eccentric_bearing_clearance_m else 0.0
            # the FE bore that sits at bore k once the FE disc is turned by β
            fe_bore = int(np.argmin([np.hypot(*(rot[:2, :2] @ itf.centre_m[:2] - bores[k]))
                                     for itf in reduced.interfaces]))
            bnodes = _marker_nodes(positions, np.asarray(reduced.interfaces[fe_bore].nodes, dtype=int))
            w = np.full(len(bnodes), 1.0 / len(bnodes))
            ref = w @ positions[bnodes]
            target = rot[:2, :2].T @ bores[k]  # bore centre in the FE frame
            marker = mbs.AddMarker(MarkerSuperElementRigid(
                bodyNumber=body, offset=[target[0] - ref[0], target[1] - ref[1], -ref[2]],
                meshNodeNumbers=bnodes.tolist(), weightingFactors=w.tolist()))
            pairs.append(bearings.build(mbs, cranks.eccentric_markers[k][d], marker, spec.bearings.eccentric,
                                        extra_clearance_m=extra))
        # profile frame against the FE (node) frame: −φ_d/z_c − β, a whole number of teeth for the half turn
        offset = -cy.disc_phase_rad[d] / cy.disc_teeth - beta
        phi = contact_mode_table(reduced.flank, offset, grid_per_tooth, cy.disc_teeth)
        contacts.append(add_cycloid_pin_contact(mbs, node, cy, law, disc=d, errors=errors,
                                                initial_interference_m=50e-6, modal_node=modal, phi=phi,
                                                offset_rad=offset))
        nodes.append(node)
        bodies.append(body)
        modal_nodes.append(modal)
        ecc_bearings.append(tuple(pairs))
    return DiscHandles(tuple(nodes), tuple(bodies), tuple(contacts), tuple(ecc_bearings), tuple(modal_nodes))

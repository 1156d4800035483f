"""Cycloid discs: one planar body per disc on the crank eccentrics (clearance bearings in
its crank bores), meshing with the pin ring through the exact contact element."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rvflex.contact.cycloid_pin import ContactLaw, CycloidPinContact, add_cycloid_pin_contact
from rvflex.parts import bearings
from rvflex.spec import ErrorSpec, ReducerSpec

__all__ = ["DiscHandles", "FLANK_GRID_PER_TOOTH", "build", "bore_positions", "flank_mode_table"]

FLANK_GRID_PER_TOOTH = 64  # profile-parameter samples of the modal flank table per tooth


@dataclass(frozen=True)
class DiscHandles:
    """Per disc: node, body, pin contact and its eccentric bearings (one per crank)."""

    nodes: tuple[int, ...]
    bodies: tuple[int, ...]
    contacts: tuple[CycloidPinContact, ...]
    eccentric_bearings: tuple[tuple[bearings.BearingPair, ...], ...]
    modal_nodes: tuple[int, ...] = ()  # flexible discs: the NodeGenericODE2 of each disc's modes


def flank_mode_table(positions_m: np.ndarray, modes: np.ndarray, profile, offset_rad: float,
                     grid_per_tooth: int = FLANK_GRID_PER_TOOTH) -> np.ndarray:
    """In-plane modal displacement of the flank, averaged through the thickness, on the
    uniform profile-parameter grid the contact element reads (profile frame).

    Parameters
    ----------
    positions_m : ndarray (n_nodes, 3)
        FE node reference positions in the disc body frame (m).
    modes : ndarray (3·n_nodes, m)
        Mode basis, node-major (x, y, z per node).
    profile : CycloidProfile
        The disc's exact profile (profile frame = body frame turned by ``offset_rad``).
    offset_rad : float
        Profile-frame angle relative to the body frame (rad).

    Returns
    -------
    ndarray (n_grid, 2, m)
        Hat-function (half-width 1.5× the largest node gap along t) average of the flank
        nodes' mode displacements, turned into the profile frame.
    """
    c, s_ = math.cos(offset_rad), math.sin(offset_rad)
    xy = positions_m[:, :2] @ np.array([[c, -s_], [s_, c]])  # body → profile frame: R(−offset)·x
    pr = profile.gap(np.ascontiguousarray(xy), np.zeros(len(xy)))
    spacing = 2 * math.pi / (profile.stage.disc_teeth * grid_per_tooth)
    on = np.nonzero(np.abs(pr.gap_m) < 2e-6)[0]  # FE nodes on the flank (the spline is within 1 µm)
    if len(on) < 4 * profile.stage.disc_teeth:
        raise ValueError(f"flank mode table: only {len(on)} FE nodes lie on the flank; mesh too coarse or frames differ")
    t_on = np.mod(pr.t[on], 2 * math.pi)
    order = np.argsort(t_on)
    t_on, on = t_on[order], on[order]
    gaps = np.diff(np.concatenate([t_on, t_on[:1] + 2 * math.pi]))
    width = max(1.5 * gaps.max(), spacing)  # every grid point sees at least two flank nodes
    n_grid = profile.stage.disc_teeth * grid_per_tooth
    tg = 2 * math.pi * np.arange(n_grid) / n_grid
    ux = modes[3 * on] * c + modes[3 * on + 1] * s_  # rotate displacements into the profile frame
    uy = -modes[3 * on] * s_ + modes[3 * on + 1] * c
    out = np.empty((n_grid, 2, modes.shape[1]))
    for j, t in enumerate(tg):
        dt = np.abs((t_on - t + math.pi) % (2 * math.pi) - math.pi)
        w = np.clip(1.0 - dt / width, 0.0, None)
        sw = w.sum()
        if sw <= 0:
            raise ValueError(f"flank mode table: no flank node within {width:.2e} rad of t = {t:.4f}")
        out[j, 0] = w @ ux / sw
        out[j, 1] = w @ uy / sw
    return out


def bore_positions(spec: ReducerSpec, errors: ErrorSpec, disc: int) -> np.ndarray:
    """Crank-bore centres in the disc frame, (cranks, 2) (m); a bore-distance error a_c moves
    each bore radially by half of it."""
    c = spec.cranks
    ang = np.asarray(c.angles_rad)
    r = c.crank_circle_radius_m + 0.5 * (errors.disc_bore_distance_error_m[disc] if errors.disc_bore_distance_error_m
                                         else 0.0)
    return r * np.column_stack([np.cos(ang), np.sin(ang)])


def build(mbs, spec: ReducerSpec, errors: ErrorSpec, cranks, law: ContactLaw, eccentric_offsets: np.ndarray,
          axes: np.ndarray, *, fidelity: str = "rigid", reduced=None, ground_coordinate: int = -1) -> DiscHandles:
    """Add the discs at their reference poses (output angle 0): disc d's centre is where its
    eccentrics put it, crank axis + eccentric − bore (averaged over the cranks).

    ``fidelity="flexible"`` needs ``reduced``, the Craig–Bampton disc (``reduced.fem``, an
    Exudyn FEMinterface with its modes; ``reduced.interface_nodes``, the FE nodes of each
    crank bore, bore 0 the floating-frame reference) and ``ground_coordinate``, a ground
    coordinate marker that holds each disc's out-of-plane coordinates (z, ψx, ψy).
    """
    if fidelity == "flexible":
        return _build_flexible(mbs, spec, errors, cranks, law, eccentric_offsets, axes, reduced, ground_coordinate)
    from exudyn.itemInterface import MarkerBodyRigid, NodeRigidBody2D, ObjectRigidBody2D

    if fidelity != "rigid":
        raise ValueError(f"fidelity = {fidelity!r}: 'rigid' or 'flexible'")
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


def _half_turn_symmetric(spec: ReducerSpec) -> bool:
    """z_c odd, and cranks and pillars map onto themselves under a half turn."""
    def symmetric(angles) -> bool:
        a = np.mod(np.asarray(angles, float), 2 * math.pi)
        b = np.mod(a + math.pi, 2 * math.pi)
        return all(np.min(np.abs(np.angle(np.exp(1j * (a - x))))) < 1e-9 for x in b)

    from rvflex.fe.geometry import pillar_angles

    return spec.cycloid.disc_teeth % 2 == 1 and symmetric(spec.cranks.angles_rad) and symmetric(pillar_angles(spec))


def _build_flexible(mbs, spec, errors, cranks, law, eccentric_offsets, axes, reduced, ground_coordinate) -> DiscHandles:
    """FFRF reduced-order discs (ObjectFFRFreducedOrder on a NodeRigidBodyRxyz held in the
    plane): bearings on MarkerSuperElementRigid at the bores, the contact with the modal flank
    displacement. Global deformation is in the modes; the local Hertz approach stays in the
    contact law (the flank table averages nodes over a tooth-fraction window, so the
    mesh's own local contact deformation is not sampled)."""
    import exudyn as exu
    from exudyn.FEM import ObjectFFRFreducedOrderInterface
    from exudyn.itemInterface import CoordinateConstraint, MarkerNodeCoordinate, MarkerSuperElementRigid

    if reduced is None or int(ground_coordinate) < 0:
        raise ValueError("fidelity = 'flexible': needs the reduced disc and a ground coordinate marker")
    cy = spec.cycloid
    fem = reduced.fem
    positions = fem.GetNodePositionsAsArray()
    modes = np.asarray(fem.modeBasis["matrix"] if isinstance(fem.modeBasis, dict) else fem.modeBasis)
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
        ffrf = ObjectFFRFreducedOrderInterface(fem, rigidBodyNodeType=exu.NodeType.RotationRxyz)
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
            fe_bore = int(np.argmin([np.hypot(*(rot[:2, :2] @ (np.asarray(positions[np.asarray(b, int)], float)
                                                                 .mean(axis=0)[:2]) - bores[k]))
                                     for b in reduced.interface_nodes]))
            bnodes = np.asarray(reduced.interface_nodes[fe_bore], dtype=int)
            w = np.full(len(bnodes), 1.0 / len(bnodes))
            ref = w @ positions[bnodes]
            target = rot[:2, :2].T @ bores[k]  # bore centre in the FE frame
            marker = mbs.AddMarker(MarkerSuperElementRigid(
                bodyNumber=body, offset=[target[0] - ref[0], target[1] - ref[1], -ref[2]],
                meshNodeNumbers=bnodes.tolist(), weightingFactors=w.tolist()))
            pairs.append(bearings.build(mbs, cranks.eccentric_markers[k][d], marker, spec.bearings.eccentric,
                                        extra_clearance_m=extra))
        from rvflex.geometry.profile import build_profile

        profile = build_profile(cy, errors, d)
        # profile frame against the FE (node) frame: −φ_d/z_c − β, a whole number of teeth for the half turn
        offset = -cy.disc_phase_rad[d] / cy.disc_teeth - beta
        phi = flank_mode_table(positions, modes, profile, offset)
        contacts.append(add_cycloid_pin_contact(mbs, node, cy, law, disc=d, errors=errors, profile=profile,
                                                initial_interference_m=50e-6, modal_node=modal, phi=phi,
                                                offset_rad=offset))
        nodes.append(node)
        bodies.append(body)
        modal_nodes.append(modal)
        ecc_bearings.append(tuple(pairs))
    return DiscHandles(tuple(nodes), tuple(bodies), tuple(contacts), tuple(ecc_bearings), tuple(modal_nodes))

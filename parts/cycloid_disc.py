"""Cycloid discs: one planar body per disc on the crank eccentrics (clearance bearings in
its crank bores), meshing with the pin ring through the exact contact element.

:func:`build_spatial`: each disc a rigid body free in space (``NodeRigidBodyRxyz`` in its plane) whose pin
contact is sliced along the face width, each slice seeing the section of the tilted disc at its axial lever."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rvflex.choices import BodyFidelity, check_choice
from rvflex.contact.cycloid_pin import ContactLaw, CycloidPinContact, add_cycloid_pin_contact
from rvflex.fe import ffrf as ffrf_module  # called through the module: tests stand in for ffrf_interface
from rvflex.fe.geometry import pillar_angles
from rvflex.geometry.pins import disc_planes
from rvflex.parts import bearings
from rvflex.spec import ErrorSpec, ReducerSpec

__all__ = ["DiscHandles", "FEDiscPlacement", "build", "build_spatial", "bore_positions", "contact_mode_table", "fe_disc_placements",
           "face_line_loads", "fe_disc_spec", "slice_line_loads", "slice_planes"]


@dataclass(frozen=True)
class DiscHandles:
    """Per disc: node, body, pin contact and its eccentric bearings (one per crank)."""

    nodes: tuple[int, ...]
    bodies: tuple[int, ...]
    contacts: tuple[CycloidPinContact, ...]
    eccentric_bearings: tuple[tuple[bearings.BearingPair, ...], ...]
    modal_nodes: tuple[int, ...] = ()  # flexible discs: the NodeGenericODE2 of each disc's modes
    slices: int = 1  # contacts per disc along the face width: ``contacts[d * slices + s]`` is disc d's slice s


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
          axes: np.ndarray, *, fidelity: BodyFidelity = "rigid", reduced=None, ground_coordinate: int = -1,
          housing=None, face_slices: int = 1) -> DiscHandles:
    """Add the discs at their reference poses (output angle 0): disc d's centre is where its
    eccentrics put it, crank axis + eccentric − bore (averaged over the cranks).

    ``fidelity="flexible"`` needs ``reduced``, the Craig–Bampton discs
    (:class:`rvflex.fe.reduce.ReducedPart`: FEMinterface with its modes, the bore
    interfaces, bore 0 the floating-frame reference, and the flank mode rows): one per disc,
    each the reduction of ``fe_disc_spec(spec, p.holes_turn_rad)`` for that disc's
    :func:`fe_disc_placements` entry ``p``, or a single one when every placement uses disc 0's
    geometry; and ``ground_coordinate``, a ground coordinate marker that holds each disc's
    out-of-plane coordinates (z, ψx, ψy).

    ``housing``: the pin ring's :class:`~rvflex.parts.pin_ring.PinRingHandles`; a flexible one
    (``modal_node`` ≥ 0) carries the pins on its seats in every disc's contact.

    ``face_slices``: each disc's pin contact as that many contact elements side by side along the face width
    (:func:`slice_planes`), each with the law of its share (:meth:`ContactLaw.sliced`).
    """
    check_choice("fidelity", fidelity, BodyFidelity)
    carried = {}
    if housing is not None and housing.modal_node >= 0:
        carried = {"housing_node": housing.modal_node, "seat": housing.seat_rows}
    sliced = (law.sliced(face_slices), slice_planes(spec, face_slices))
    if fidelity == "flexible":
        return _build_flexible(mbs, spec, errors, cranks, law, eccentric_offsets, axes, reduced, ground_coordinate,
                               carried, sliced)
    from exudyn.itemInterface import NodeRigidBody2D, ObjectRigidBody2D

    cy = spec.cycloid
    mass, inertia, _ = _disc_inertia(spec)
    nodes, bodies, contacts, ecc_bearings = [], [], [], []
    for d in range(cy.disc_count):
        bores = bore_positions(spec, errors, d)
        centre = np.mean(axes + eccentric_offsets[:, d] - bores, axis=0)
        node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[centre[0], centre[1], 0.0]))
        body = mbs.AddObject(ObjectRigidBody2D(nodeNumber=node, mass=mass, inertia=inertia))
        pairs = _eccentric_bearings(mbs, spec, errors, cranks, body, d, bores)
        # pin and disc errors may make pins interfere by a few µm at the nominal pose (the first
        # static step resolves it); deeper than 50 µm would be a broken spec
        slice_law, planes = sliced
        for z in planes[d]:
            contacts.append(add_cycloid_pin_contact(mbs, node, cy, slice_law, disc=d, errors=errors,
                                                    initial_interference_m=50e-6, axial_m=z, **carried))
        nodes.append(int(node))
        bodies.append(int(body))
        ecc_bearings.append(tuple(pairs))
    return DiscHandles(tuple(nodes), tuple(bodies), tuple(contacts), tuple(ecc_bearings), slices=face_slices)


def build_spatial(mbs, spec: ReducerSpec, errors: ErrorSpec, cranks, law: ContactLaw, eccentric_offsets: np.ndarray,
                  axes: np.ndarray, *, face_slices: int) -> DiscHandles:
    """Add the discs as rigid bodies free in space at their reference poses (output angle 0; in-plane as
    :func:`build`), each node (``NodeRigidBodyRxyz``) in its disc's plane (:func:`rvflex.geometry.pins.disc_planes`).

    Each crank bore sits on its eccentric (``cranks.eccentric_markers``, in the same plane) through the
    eccentric (needle) bearing: the radial clearance law with its axial and tilt springs, the bore's clearance
    error added. The pin contact is ``face_slices`` elements at :func:`slice_planes` (pins cut there, so a
    tilted pin ring applies), each with its share of the law (:meth:`ContactLaw.sliced`) acting on the disc's
    section at its lever from the node: the disc's tilt loads its pins' ends unequally and the slices' forces
    tilt it back (:mod:`rvflex.contact.tilt_map`).

    Parameters
    ----------
    mbs : exudyn.MainSystem
        The system to add to.
    spec : ReducerSpec
        The reducer.
    errors : ErrorSpec
        Its errors (bores, profile, pins).
    cranks : CrankHandles
        The spatial cranks (:func:`rvflex.parts.crankshaft.build_spatial`).
    law : ContactLaw
        The whole face's pin contact law.
    eccentric_offsets : numpy.ndarray
        Eccentric centres in each crank's frame, (cranks, discs, 2) (m).
    axes : numpy.ndarray
        Crank axes in the carrier frame, (cranks, 2) (m).
    face_slices : int
        Contact slices per disc (≥ 1).

    Returns
    -------
    DiscHandles
        ``contacts[d * face_slices + s]`` disc d's slice s.
    """
    from exudyn.itemInterface import NodeRigidBodyRxyz, ObjectRigidBody

    cy = spec.cycloid
    mass, izz, ixx = _disc_inertia(spec)
    slice_law, planes = law.sliced(face_slices), slice_planes(spec, face_slices)
    mid = disc_planes(spec)
    nodes, bodies, contacts, ecc_bearings = [], [], [], []
    for d in range(cy.disc_count):
        bores = bore_positions(spec, errors, d)
        centre = np.mean(axes + eccentric_offsets[:, d] - bores, axis=0)
        node = int(mbs.AddNode(NodeRigidBodyRxyz(referenceCoordinates=[centre[0], centre[1], mid[d], 0.0, 0.0, 0.0])))
        body = int(mbs.AddObject(ObjectRigidBody(nodeNumber=node, mass=mass, inertia=[ixx, ixx, izz, 0.0, 0.0, 0.0])))
        pairs = _eccentric_bearings(mbs, spec, errors, cranks, body, d, bores)
        for z in planes[d]:  # as build(): errors may interfere by a few µm at the nominal pose
            contacts.append(add_cycloid_pin_contact(mbs, node, cy, slice_law, disc=d, errors=errors,
                                                    initial_interference_m=50e-6, axial_m=z, lever_m=z - mid[d]))
        nodes.append(node)
        bodies.append(body)
        ecc_bearings.append(tuple(pairs))
    return DiscHandles(tuple(nodes), tuple(bodies), tuple(contacts), tuple(ecc_bearings), slices=face_slices)


def _disc_inertia(spec: ReducerSpec) -> tuple[float, float, float]:
    """A rigid disc as an annulus from the pin circle less a pin radius to its centre hole: mass (kg), moment of
    inertia about its axis and about a diameter through its centre (kg·m²)."""
    cy = spec.cycloid
    rho = spec.materials.gears_cranks_discs.density_kg_m3
    r_out, r_in, b = cy.pin_circle_radius_m - cy.pin_radius_m, cy.disc_center_hole_radius_m, cy.disc_thickness_m
    mass = rho * math.pi * (r_out**2 - r_in**2) * b
    return mass, 0.5 * mass * (r_out**2 + r_in**2), mass * ((r_out**2 + r_in**2) / 4 + b**2 / 12)


def _eccentric_bearings(mbs, spec: ReducerSpec, errors: ErrorSpec, cranks, body: int, d: int,
                        bores: np.ndarray) -> list[bearings.BearingPair]:
    """Disc ``d``'s eccentric bearings on rigid ``body``: one per crank between the crank's eccentric marker and a
    rigid marker at the bore (``bores``, disc frame, m), each with its clearance error."""
    from exudyn.itemInterface import MarkerBodyRigid

    pairs = []
    for k in range(spec.cranks.count):
        idx = k * spec.cycloid.disc_count + d
        extra = errors.eccentric_bearing_clearance_m[idx] if errors.eccentric_bearing_clearance_m else 0.0
        bore = mbs.AddMarker(MarkerBodyRigid(bodyNumber=body, localPosition=[bores[k, 0], bores[k, 1], 0.0]))
        pairs.append(bearings.build(mbs, cranks.eccentric_markers[k][d], bore, spec.bearings.eccentric,
                                    extra_clearance_m=extra))
    return pairs


def slice_line_loads(spec: ReducerSpec, slice_force_N: np.ndarray) -> np.ndarray:
    """Line loads (N/m) of contact slices: each slice's force over its share of the disc's thickness;
    ``slice_force_N`` has the slices on axis −2 (``QuasiStaticResult.pin_slice_force_N``: steps, discs, slices,
    pins)."""
    f = np.asarray(slice_force_N, float)
    return f / (spec.cycloid.disc_thickness_m / f.shape[-2])


def face_line_loads(line_load: np.ndarray, axis: int = -2) -> tuple[np.ndarray, np.ndarray]:
    """The line loads at a disc's two faces (−z, +z), extrapolated linearly from the two outer slices along
    ``axis`` (the slices' centres are a slice apart, the faces half a slice beyond); needs two slices or more."""
    q = np.moveaxis(np.asarray(line_load, float), axis, 0)
    return 1.5 * q[0] - 0.5 * q[1], 1.5 * q[-1] - 0.5 * q[-2]


def slice_planes(spec: ReducerSpec, slices: int = 1) -> np.ndarray:
    """Axial positions of each disc's contact slices from the discs' mid-plane, shape (discs, slices) (m): the
    centres of ``slices`` equal parts of the disc's thickness around its eccentric's plane
    (:func:`rvflex.geometry.pins.disc_planes`); one slice: the disc's mid-plane."""
    b = spec.cycloid.disc_thickness_m
    zeta = ((np.arange(slices) + 0.5) / slices - 0.5) * b
    return disc_planes(spec)[:, None] + zeta[None, :]


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


@dataclass(frozen=True)
class FEDiscPlacement:
    """How disc ``d`` of a unit is made from an FE disc (angles in rad).

    The FE disc is disc 0's geometry of a spec whose cranks (and so pillars) sit turned by
    ``holes_turn_rad`` against the teeth (:func:`fe_disc_spec`); it enters the model turned by
    ``beta_rad``. Disc d's profile sits turned by α_d = −φ_d/z_c against its bores: either a
    rotation β of the hole layout onto itself matches α_d to a whole number of teeth (then
    ``holes_turn_rad`` = 0, disc 0's reduction serves: the RV-40E's two discs, β = π), or the
    FE disc is the exact disc d: holes turned by −α (α = α_d wrapped to ±half a tooth) and β = α.
    """

    beta_rad: float
    holes_turn_rad: float


def fe_disc_placements(spec: ReducerSpec) -> tuple[FEDiscPlacement, ...]:
    """One :class:`FEDiscPlacement` per disc; the same ``holes_turn_rad`` means the same FE disc
    (and the same cached reduction)."""
    cy, cr = spec.cycloid, spec.cranks
    tooth = 2 * math.pi / cy.disc_teeth
    out = []
    for phase in cy.disc_phase_rad:
        alpha = -phase / cy.disc_teeth
        place = None
        for a_k in cr.angles_rad:  # a rotation of the layout onto itself takes crank 0 to some crank k
            beta = float((a_k - cr.angles_rad[0]) % (2 * math.pi))
            whole = (alpha - beta) / tooth
            if (abs(whole - round(whole)) < 1e-6 and _maps_onto(cr.angles_rad, beta, cr.angles_rad)
                    and _maps_onto(pillar_angles(spec), beta, pillar_angles(spec))):
                place = FEDiscPlacement(beta, 0.0)
                break
        if place is None:
            a = float(alpha - tooth * round(alpha / tooth))
            place = FEDiscPlacement(a, -a)
        out.append(place)
    return tuple(out)


def _turn_onto(spec: ReducerSpec, red, d: int) -> float:
    """The turn β (rad) that puts the FE disc ``red`` onto disc ``d``: its bores and pillar holes
    onto the disc's, and its profile onto the disc's to a whole number of teeth.

    Raises
    ------
    ValueError
        ``red`` is the reduction of another disc geometry (no such turn).
    """
    cy, cr = spec.cycloid, spec.cranks
    tooth = 2 * math.pi / cy.disc_teeth
    c0 = red.interfaces[0].centre_m
    h = math.atan2(c0[1], c0[0]) - cr.angles_rad[0]  # the FE disc's holes, turned against the teeth
    alpha = -cy.disc_phase_rad[d] / cy.disc_teeth
    for a_k in cr.angles_rad:
        beta = float((a_k - cr.angles_rad[0] - h) % (2 * math.pi))
        whole = (alpha - beta) / tooth
        if (abs(whole - round(whole)) < 1e-6 and _maps_onto(np.add(cr.angles_rad, h), beta, cr.angles_rad)
                and _maps_onto(pillar_angles(spec) + h, beta, pillar_angles(spec))):
            return beta
    raise ValueError(f"fidelity = 'flexible': the reduced disc given for disc {d} (phase {cy.disc_phase_rad[d]:.4f} "
                     f"rad) is another disc geometry (holes turned by {h:.6f} rad against the teeth); reduce "
                     f"fe_disc_spec(spec, fe_disc_placements(spec)[{d}].holes_turn_rad)")


def _maps_onto(angles, beta: float, target) -> bool:
    """Every angle of ``angles`` turned by ``beta`` is one of ``target`` (to 1e-6 rad)."""
    t = np.asarray(target, float)
    return all(np.min(np.abs(np.angle(np.exp(1j * (t - a - beta))))) < 1e-6 for a in np.asarray(angles, float))


def fe_disc_spec(spec: ReducerSpec, holes_turn_rad: float) -> ReducerSpec:
    """The spec whose disc 0 is the FE disc of a placement: cranks turned by ``holes_turn_rad``
    (the pillars follow them, :func:`rvflex.fe.geometry.pillar_angles`); ``spec`` itself for 0."""
    if holes_turn_rad == 0.0:
        return spec
    import dataclasses

    angles = tuple(float((a + holes_turn_rad) % (2 * math.pi)) for a in spec.cranks.angles_rad)
    return dataclasses.replace(spec, cranks=dataclasses.replace(spec.cranks, angles_rad=angles))


def _build_flexible(mbs, spec, errors, cranks, law, eccentric_offsets, axes, reduced, ground_coordinate,
                    carried, sliced) -> DiscHandles:
    """FFRF reduced-order discs (ObjectFFRFreducedOrder on a NodeRigidBodyRxyz held in the
    plane): bearings on MarkerSuperElementRigid at the bores, the contact with the modal flank
    displacement. Global deformation is in the modes; the local Hertz approach stays in the
    contact law (the flank rows average the mesh over a patch of a few mm of flank, so the
    mesh's own local contact deformation is not sampled)."""
    from exudyn.itemInterface import CoordinateConstraint, MarkerNodeCoordinate, MarkerSuperElementRigid

    if reduced is None or int(ground_coordinate) < 0:
        raise ValueError("fidelity = 'flexible': needs the reduced disc and a ground coordinate marker")
    cy = spec.cycloid
    per_disc = tuple(reduced) if isinstance(reduced, (tuple, list)) else (reduced,) * cy.disc_count
    if len(per_disc) != cy.disc_count:
        raise ValueError(f"fidelity = 'flexible': {len(per_disc)} reduced discs for {cy.disc_count} discs")
    ffrfs = {}  # one interface (cached on disk) per distinct FE disc
    nodes, bodies, contacts, ecc_bearings, modal_nodes = [], [], [], [], []
    for d in range(cy.disc_count):
        if errors.disc_bore_distance_error_m and errors.disc_bore_distance_error_m[d]:
            raise ValueError("fidelity = 'flexible': disc bore-distance errors need their own FE geometry (not yet)")
        red = per_disc[d]
        positions = red.node_positions_m
        if red.flank is None or red.flank.rows.shape[0] % cy.disc_teeth:
            raise ValueError("fidelity = 'flexible': the reduced disc has no flank mode rows on a whole-tooth grid")
        grid_per_tooth = red.flank.rows.shape[0] // cy.disc_teeth
        if id(red) not in ffrfs:
            ffrfs[id(red)] = ffrf_module.ffrf_interface(red)
        ffrf = ffrfs[id(red)]
        bores = bore_positions(spec, errors, d)
        centre = np.mean(axes + eccentric_offsets[:, d] - bores, axis=0)
        # the FE disc's profile frame is its body frame; disc d's profile is turned by −φ_d/z_c
        # against its bores, so the FE disc enters turned by β (fe_disc_placements)
        beta = _turn_onto(spec, red, d)
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
            fe_bore = int(np.argmin([np.hypot(*(rot[:2, :2] @ itf.centre_m[:2] - bores[k])) for itf in red.interfaces]))
            bnodes = _marker_nodes(positions, np.asarray(red.interfaces[fe_bore].nodes, dtype=int))
            w = np.full(len(bnodes), 1.0 / len(bnodes))
            ref = w @ positions[bnodes]
            target = rot[:2, :2].T @ bores[k]  # bore centre in the FE frame
            marker = mbs.AddMarker(MarkerSuperElementRigid(
                bodyNumber=body, offset=[target[0] - ref[0], target[1] - ref[1], -ref[2]],
                meshNodeNumbers=bnodes.tolist(), weightingFactors=w.tolist()))
            pairs.append(bearings.build(mbs, cranks.eccentric_markers[k][d], marker, spec.bearings.eccentric,
                                        extra_clearance_m=extra))
        # profile frame against the FE (node) frame: −φ_d/z_c − β, a whole number of teeth
        offset = -cy.disc_phase_rad[d] / cy.disc_teeth - beta
        phi = contact_mode_table(red.flank, offset, grid_per_tooth, cy.disc_teeth)
        # every slice sees the flank's in-plane modal motion (the modes are taken at the mid-plane)
        slice_law, planes = sliced
        for z in planes[d]:
            contacts.append(add_cycloid_pin_contact(mbs, node, cy, slice_law, disc=d, errors=errors,
                                                    initial_interference_m=50e-6, modal_node=modal, phi=phi,
                                                    offset_rad=offset, axial_m=z, **carried))
        nodes.append(node)
        bodies.append(body)
        modal_nodes.append(modal)
        ecc_bearings.append(tuple(pairs))
    return DiscHandles(tuple(nodes), tuple(bodies), tuple(contacts), tuple(ecc_bearings), tuple(modal_nodes),
                       slices=len(planes[0]))

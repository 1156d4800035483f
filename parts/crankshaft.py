"""Crankshafts with their planet gears: one planar body per crank on its support bearing in
the carrier, meshing with the sun, carrying one eccentric per disc.

:func:`build_spatial`: each crank a rigid body free in space (``NodeRigidBodyRxyz`` on its axis in the discs'
mid-plane) on two support bearings at ±``support_span_m``/2, its eccentrics at the discs' planes and its gear at
``gear_axial_position_m``, where the crank's tilt moves the gear's mesh with the sun."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rvflex.choices import BodyFidelity, check_choice
from rvflex.contact.gear_mesh import GearMeshHandles, add_gear_mesh
from rvflex.geometry.pins import disc_planes
from rvflex.parts import bearings
from rvflex.spec import ErrorSpec, ReducerSpec

__all__ = ["CrankHandles", "build", "build_spatial", "eccentric_offsets"]


@dataclass(frozen=True)
class CrankHandles:
    """Per crank: node and body; eccentric_markers[k][d] the rigid marker of disc d's
    eccentric; support bearing and gear mesh; a spatial crank's second support bearing (input plate) in
    input_supports (supports: the output plate's)."""

    nodes: tuple[int, ...]
    bodies: tuple[int, ...]
    eccentric_markers: tuple[tuple[int, ...], ...]
    supports: tuple[bearings.BearingPair, ...]
    meshes: tuple[GearMeshHandles, ...]
    input_supports: tuple[bearings.BearingPair, ...] = ()


def eccentric_offsets(spec: ReducerSpec, errors: ErrorSpec) -> np.ndarray:
    """Eccentric centres in each crank's frame, (cranks, discs, 2) (m): eccentricity plus the
    per-shaft eccentricity error, at the disc phase plus the per-shaft phase error, all shifted by
    the shaft's runout (``crank_runout_m`` at ``crank_runout_phase_rad``: the eccentrics off the
    journal axis the crank turns about, alike for every disc)."""
    c, cy = spec.cranks, spec.cycloid
    out = np.empty((c.count, cy.disc_count, 2))
    for k in range(c.count):
        e = cy.eccentricity_m + (errors.crank_eccentricity_error_m[k] if errors.crank_eccentricity_error_m else 0.0)
        dphi = errors.crank_phase_error_rad[k] if errors.crank_phase_error_rad else 0.0
        r = errors.crank_runout_m[k] if errors.crank_runout_m else 0.0
        psi = errors.crank_runout_phase_rad[k] if errors.crank_runout_phase_rad else 0.0
        for d, ph in enumerate(cy.disc_phase_rad):
            out[k, d] = e * math.cos(ph + dphi) + r * math.cos(psi), e * math.sin(ph + dphi) + r * math.sin(psi)
    return out


def build(mbs, spec: ReducerSpec, errors: ErrorSpec, carrier, sun_node: int, axes: np.ndarray, *,
          fidelity: BodyFidelity = "rigid") -> CrankHandles:
    """Add the cranks at ``axes`` (carrier frame, = reference positions at output angle 0).
    The cranks are rigid in every model: ``fidelity="flexible"`` is refused."""
    check_choice("fidelity", fidelity, BodyFidelity)
    if fidelity != "rigid":
        raise NotImplementedError(f"fidelity = {fidelity!r}: the cranks are rigid bodies (no FE crank yet)")
    from exudyn.itemInterface import MarkerBodyRigid, NodeRigidBody2D, ObjectRigidBody2D

    st = spec.input_stage
    rp = st.module_m * st.planet_teeth / 2
    rho = spec.materials.gears_cranks_discs.density_kg_m3
    mass = rho * math.pi * rp * rp * st.face_width_m + rho * math.pi * spec.cranks.eccentric_journal_radius_m**2 * 0.06
    inertia = 0.5 * rho * math.pi * rp**4 * st.face_width_m
    ecc = eccentric_offsets(spec, errors)
    nodes, bodies, markers, supports, meshes = [], [], [], [], []
    for k, axis in enumerate(axes):
        node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[axis[0], axis[1], 0.0]))
        body = mbs.AddObject(ObjectRigidBody2D(nodeNumber=node, mass=mass, inertia=inertia))
        extra = errors.crank_support_clearance_m[k] if errors.crank_support_clearance_m else 0.0
        supports.append(bearings.build(mbs, carrier.bore_markers[k],
                                       mbs.AddMarker(MarkerBodyRigid(bodyNumber=body, localPosition=[0.0, 0.0, 0.0])),
                                       spec.bearings.crank_support, extra_clearance_m=extra))
        markers.append(tuple(int(mbs.AddMarker(MarkerBodyRigid(bodyNumber=body, localPosition=[o[0], o[1], 0.0])))
                             for o in ecc[k]))
        meshes.append(add_gear_mesh(mbs, sun_node, node, st, planet_index=k, errors=errors))
        nodes.append(int(node))
        bodies.append(int(body))
    return CrankHandles(tuple(nodes), tuple(bodies), tuple(markers), tuple(supports), tuple(meshes))


def build_spatial(mbs, spec: ReducerSpec, errors: ErrorSpec, carrier, sun_node: int, axes: np.ndarray) -> CrankHandles:
    """Add the cranks as rigid bodies free in space at ``axes`` (carrier frame, = reference positions at output
    angle 0), each on two support bearings.

    A crank's node (``NodeRigidBodyRxyz``) sits on its axis in the discs' mid-plane. Each support bearing is
    ``spec.bearings.crank_support`` (give :func:`rvflex.parts.carrier.split_support_bearing`'s spec: one of the
    pair the planar model lumps) between the carrier's bore at ±``support_span_m``/2 (``carrier.bore_markers``
    +, ``carrier.input_seat_markers`` −) and the crank's journal there, both with the crank's support-clearance
    error; so the pair's tilt stiffness is each bearing's plus its radial stiffness over the span. The eccentrics
    sit at the discs' planes (:func:`rvflex.geometry.pins.disc_planes`), the planet gear at
    ``cranks.gear_axial_position_m`` (None: in the mid-plane), meshing with the planar sun through the gear's
    section (:func:`rvflex.contact.gear_mesh.add_gear_mesh` with ``planet_lever_m``).

    Parameters
    ----------
    mbs : exudyn.MainSystem
        The system to add to.
    spec : ReducerSpec
        The reducer, its crank support bearing one of a crank's two.
    errors : ErrorSpec
        Its errors (eccentrics, support clearances, gear errors).
    carrier : CarrierHandles
        The spatial carrier (:func:`rvflex.parts.carrier.build_spatial`).
    sun_node : int
        The sun's ``NodeRigidBody2D``.
    axes : numpy.ndarray
        Crank axes in the carrier frame, (cranks, 2) (m).

    Returns
    -------
    CrankHandles
        With both support bearings of each crank (``supports``: output plate, ``input_supports``: input plate).
    """
    from exudyn.itemInterface import MarkerBodyRigid, NodeRigidBodyRxyz, ObjectRigidBody

    st, cr = spec.input_stage, spec.cranks
    half = 0.5 * cr.support_span_m
    gear_z = 0.0 if cr.gear_axial_position_m is None else cr.gear_axial_position_m
    rp = st.module_m * st.planet_teeth / 2
    rho = spec.materials.gears_cranks_discs.density_kg_m3
    m_gear = rho * math.pi * rp * rp * st.face_width_m
    m_shaft = rho * math.pi * cr.eccentric_journal_radius_m**2 * cr.support_span_m
    mass = m_gear + m_shaft
    izz = 0.5 * m_gear * rp**2 + 0.5 * m_shaft * cr.eccentric_journal_radius_m**2
    ixx = m_gear * (rp**2 / 4 + gear_z**2) + m_shaft * cr.support_span_m**2 / 12  # about the node
    ecc = eccentric_offsets(spec, errors)
    planes = disc_planes(spec)
    nodes, bodies, markers, supports, inputs, meshes = [], [], [], [], [], []
    for k, axis in enumerate(axes):
        node = int(mbs.AddNode(NodeRigidBodyRxyz(referenceCoordinates=[axis[0], axis[1], 0.0, 0.0, 0.0, 0.0])))
        body = int(mbs.AddObject(ObjectRigidBody(nodeNumber=node, mass=mass, inertia=[ixx, ixx, izz, 0.0, 0.0, 0.0])))
        extra = errors.crank_support_clearance_m[k] if errors.crank_support_clearance_m else 0.0
        for seat, z, out in ((carrier.bore_markers[k], half, supports), (carrier.input_seat_markers[k], -half, inputs)):
            journal = mbs.AddMarker(MarkerBodyRigid(bodyNumber=body, localPosition=[0.0, 0.0, z]))
            out.append(bearings.build(mbs, seat, journal, spec.bearings.crank_support, extra_clearance_m=extra))
        markers.append(tuple(int(mbs.AddMarker(MarkerBodyRigid(bodyNumber=body, localPosition=[o[0], o[1], z])))
                             for o, z in zip(ecc[k], planes, strict=True)))
        meshes.append(add_gear_mesh(mbs, sun_node, node, st, planet_index=k, errors=errors, planet_lever_m=gear_z))
        nodes.append(node)
        bodies.append(body)
    return CrankHandles(tuple(nodes), tuple(bodies), tuple(markers), tuple(supports), tuple(meshes), tuple(inputs))

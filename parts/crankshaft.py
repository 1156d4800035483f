"""Crankshafts with their planet gears: one planar body per crank on its support bearing in
the carrier, meshing with the sun, carrying one eccentric per disc.

:func:`build_spatial`: each crank a rigid body free in space (``NodeRigidBodyRxyz`` on its axis in the discs'
mid-plane) on two support bearings at ±``support_span_m``/2, its eccentrics at the discs' planes and its gear at
``gear_axial_position_m``, where the crank's tilt moves the gear's mesh with the sun; or, with ``beam_elements``,
each crank a flexible (Timoshenko) shaft of rigid stations joined by the exact static stiffness of the shaft's
prismatic segments (:func:`beam_layout`, :func:`segment_stiffness`, :func:`add_shaft`; docs/spatial.md)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rvflex.choices import BodyFidelity, check_choice
from rvflex.contact.gear_mesh import GearMeshHandles, add_gear_mesh
from rvflex.contact.tapered_roller import support_rows
from rvflex.geometry.pins import disc_planes
from rvflex.parts import bearings
from rvflex.spec import ErrorSpec, Material, ReducerSpec, SpecError

__all__ = ["CrankBeam", "CrankHandles", "ShaftHandles", "add_shaft", "beam_layout", "build", "build_spatial",
           "eccentric_offsets", "segment_stiffness", "shaft_inertia", "shear_coefficient"]

PLANE_TOLERANCE_M = 1e-9
"""Axial planes of a beam crank closer than this are one station (a gear in a support's plane, say)."""


@dataclass(frozen=True)
class CrankHandles:
    """Per crank: node and body; eccentric_markers[k][d] the rigid marker of disc d's
    eccentric; support bearing and gear mesh; a spatial crank's second support bearing (input plate) in
    input_supports (supports: the output plate's).

    A beam crank (:func:`build_spatial` with ``beam_elements``) is a chain of station bodies: ``stations[k]``
    its nodes in axial order (ascending z, at ``beam.station_z_m``), ``segments[k]`` the connectors between
    consecutive stations, and its node and body (``nodes[k]``, ``bodies[k]``) the station at the planet gear's
    plane, whose (x, y, ψz) the gear mesh and the ideal kinematics take as the crank's. Empty (None) for rigid
    cranks."""

    nodes: tuple[int, ...]
    bodies: tuple[int, ...]
    eccentric_markers: tuple[tuple[int, ...], ...]
    supports: tuple[bearings.BearingPair, ...]
    meshes: tuple[GearMeshHandles, ...]
    input_supports: tuple[bearings.BearingPair, ...] = ()
    stations: tuple[tuple[int, ...], ...] = ()
    segments: tuple[tuple[int, ...], ...] = ()
    beam: CrankBeam | None = None


@dataclass(frozen=True)
class CrankBeam:
    """A crank as a shaft of solid circular prismatic segments between stations on its axis (lengths in m, from
    the discs' mid-plane).

    Parameters
    ----------
    station_z_m : tuple of float
        Axial position of every station, ascending.
    segment_radius_m : tuple of float
        Radius of the segment between stations j and j + 1 (one fewer than the stations).
    output_support, input_support : int
        The stations at the support bearings (output plate +z, input plate −z).
    eccentrics : tuple of int
        The station at each disc's plane (its eccentric), in disc order.
    gear : int
        The station at the planet gear's plane.
    elements : int
        Segments between consecutive key planes (supports, disc stack faces, eccentrics, gear).
    """

    station_z_m: tuple[float, ...]
    segment_radius_m: tuple[float, ...]
    output_support: int
    input_support: int
    eccentrics: tuple[int, ...]
    gear: int
    elements: int = 1


@dataclass(frozen=True)
class ShaftHandles:
    """Items of one shaft (:func:`add_shaft`): station nodes and bodies in axial order, and the segment connectors
    between consecutive stations."""

    nodes: tuple[int, ...]
    bodies: tuple[int, ...]
    segments: tuple[int, ...]


def shear_coefficient(poisson_ratio: float) -> float:
    """Timoshenko shear coefficient κ of a solid circular section, 6(1 + ν)/(7 + 6ν) (Cowper 1966; 0.886 at
    ν = 0.3)."""
    return 6.0 * (1.0 + poisson_ratio) / (7.0 + 6.0 * poisson_ratio)


def segment_stiffness(material: Material, radius_m: float, length_m: float) -> np.ndarray:
    """Diagonal stiffness of a prismatic solid circular shaft segment about its mid-point, as one linear 6-DOF
    spring between its two end stations (each attached at the mid-point).

    With the spring at the mid-point the lateral spring sees u_b − u_a − (θ_a + θ_b)·L/2 and the bending spring
    θ_b − θ_a: these are the shear (chord) and bending modes of the two-node Timoshenko element, uncoupled, and
    the spring's energy is the element's exactly (its stiffness 12EI/(L³(1+Φ)) [12, 6L, ..., (4+Φ)L², (2−Φ)L²]
    expanded): the static stiffness of the uniform segment under end loads, no discretisation error.

    Parameters
    ----------
    material : Material
        Young's modulus (Pa) and Poisson's ratio (shear modulus E/(2(1 + ν))).
    radius_m, length_m : float
        The segment's radius and length, m.

    Returns
    -------
    numpy.ndarray
        (k_x, k_y, k_z, k_ψx, k_ψy, k_ψz): lateral 12EI/(L³(1 + Φ)) twice (N/m), axial EA/L (N/m), bending EI/L
        twice and torsion GJ/L (N·m/rad); Φ = 12EI/(κGAL²), κ :func:`shear_coefficient`.
    """
    e, nu = material.youngs_modulus_Pa, material.poisson_ratio
    g = e / (2.0 * (1.0 + nu))
    area = math.pi * radius_m**2
    inertia = 0.25 * math.pi * radius_m**4
    phi = 12.0 * e * inertia / (shear_coefficient(nu) * g * area * length_m**2)
    lateral = 12.0 * e * inertia / (length_m**3 * (1.0 + phi))
    bending = e * inertia / length_m
    return np.array([lateral, lateral, e * area / length_m, bending, bending, g * 2.0 * inertia / length_m])


def shaft_inertia(station_z_m, segment_radius_m, density_kg_m3: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each station's share of a shaft's mass: half of each adjacent segment, its inertias about the station.

    Parameters
    ----------
    station_z_m, segment_radius_m : sequence of float
        Stations (ascending, m) and the radius of each segment between them (m).
    density_kg_m3 : float
        The shaft's density.

    Returns
    -------
    mass, ixx, izz : numpy.ndarray
        Per station: mass (kg), inertia about a transverse axis through the station and about the shaft's axis
        (kg·m²).
    """
    z = np.asarray(station_z_m, float)
    r = np.asarray(segment_radius_m, float)
    half = 0.5 * np.diff(z)
    m = density_kg_m3 * math.pi * r**2 * half  # each half segment
    ixx_half = m * (r**2 / 4.0 + half**2 / 3.0)  # a cylinder of length L/2 about its end
    mass, ixx, izz = np.zeros(len(z)), np.zeros(len(z)), np.zeros(len(z))
    for side in (slice(0, -1), slice(1, None)):
        mass[side] += m
        ixx[side] += ixx_half
        izz[side] += 0.5 * m * r**2
    return mass, ixx, izz


def beam_layout(spec: ReducerSpec, elements: int = 1, field: str = "options.spatial.crank") -> CrankBeam:
    """The stations and segments of each crank as a beam (every crank alike).

    Key planes: the two support bearings where they carry (±``support_span_m``/2, or with
    ``bearings.crank_support_pair`` the rows' pressure centres, :func:`rvflex.contact.tapered_roller.support_rows`:
    as shaft analysis takes a tapered roller bearing's reaction), each eccentric (the discs' planes), the faces
    of the disc stack (the outer faces of the outermost discs, ``disc_thickness_m`` wide, where they lie between
    the supports) and the planet gear (``gear_axial_position_m``); ``elements`` equal segments between each two
    neighbouring key planes. Radii: the stack (its eccentric journals, and the spacer between them) at
    ``eccentric_journal_radius_m``, the rest (from the stack to the support journals, and on to the gear's seat)
    at ``support_journal_radius_m``. The eccentric journals' offset (the eccentricity) from the crank axis is
    left out of the section: it couples the axial force, which the shaft does not carry, with bending.

    Parameters
    ----------
    spec : ReducerSpec
        Needs ``cranks.support_span_m``, ``cranks.support_journal_radius_m`` and ``cranks.gear_axial_position_m``.
    elements : int, optional
        Segments between neighbouring key planes (1 to 64).
    field : str, optional
        The option that asked for beam cranks, named in a refusal.

    Returns
    -------
    CrankBeam

    Raises
    ------
    SpecError
        Naming the first of those crank fields the spec does not give, or ``crank_elements`` out of range.
    """
    cr = spec.cranks
    if isinstance(elements, bool) or not isinstance(elements, int) or not 1 <= elements <= 64:
        raise SpecError("crank_elements", elements, "must be an integer from 1 to 64 (beam elements per crank "
                                                    "segment)")
    for name, what in (("support_span_m", "support span (m, between a crank's two support bearings)"),
                       ("support_journal_radius_m", "support journal radius (m, the crank's journal in its support "
                                                    "bearings)"),
                       ("gear_axial_position_m", "planet gear position (m along the axis, where the gear's torque "
                                                 "enters the crank)")):
        if getattr(cr, name) is None:
            raise SpecError(f"cranks.{name}", None, f"{spec.name} gives no crank {what}, which {field} = 'beam' "
                                                    f"needs: add {name} to [cranks]")
    half = support_rows(spec).half_span_m
    planes = disc_planes(spec)
    t = spec.cycloid.disc_thickness_m
    lo, hi = float(planes.min()) - 0.5 * t, float(planes.max()) + 0.5 * t
    named = [half, -half, *(float(z) for z in planes), float(cr.gear_axial_position_m)]
    keys: list[float] = []
    for z in sorted(named + [f for f in (lo, hi) if -half < f < half]):
        if not keys or z - keys[-1] > PLANE_TOLERANCE_M:
            keys.append(z)

    def key(z: float) -> int:
        return elements * int(np.argmin(np.abs(np.asarray(keys) - z)))

    z = np.concatenate([np.linspace(a, b, elements + 1)[:-1] for a, b in zip(keys[:-1], keys[1:])] + [keys[-1:]])
    mid = 0.5 * (z[:-1] + z[1:])
    in_stack = (mid > lo - PLANE_TOLERANCE_M) & (mid < hi + PLANE_TOLERANCE_M)
    radius = np.where(in_stack, cr.eccentric_journal_radius_m, cr.support_journal_radius_m)
    return CrankBeam(tuple(float(v) for v in z), tuple(float(v) for v in radius), key(half), key(-half),
                     tuple(key(float(p)) for p in planes), key(float(cr.gear_axial_position_m)), elements)


def add_shaft(mbs, xy, station_z_m, segment_radius_m, material: Material, *, extra_mass=None) -> ShaftHandles:
    """Add a shaft along z at ``xy`` (m): one rigid body per station (``NodeRigidBodyRxyz`` at (x, y, z), its
    share of the mass, :func:`shaft_inertia`), consecutive stations joined by one linear
    ``ObjectConnectorRigidBodySpringDamper`` at the segment's mid-point with :func:`segment_stiffness`.

    The connector's relative displacement and rotation are small whatever the shaft's spin (the stations spin
    alike), so its linear law is the segment's stiffness at any crank angle; the section is axisymmetric, so the
    joint frame's turn with the first station does not matter. No damping: the spec gives none
    (generalized-α's numerical damping takes the stations' high frequencies).

    Parameters
    ----------
    mbs : exudyn.MainSystem
        The system to add to.
    xy : sequence of float
        The shaft's axis (x, y), m.
    station_z_m, segment_radius_m : sequence of float
        Stations (ascending, m) and segment radii (m).
    material : Material
        The shaft's material.
    extra_mass : sequence of (int, float, float, float), optional
        Masses carried by stations: (station, kg, transverse and axial inertia about the station in kg·m²).

    Returns
    -------
    ShaftHandles
    """
    from exudyn.itemInterface import (
        MarkerBodyRigid,
        NodeRigidBodyRxyz,
        ObjectConnectorRigidBodySpringDamper,
        ObjectRigidBody,
    )

    z = [float(v) for v in station_z_m]
    if len(z) < 2 or len(segment_radius_m) != len(z) - 1 or np.any(np.diff(z) <= 0.0):
        raise ValueError("add_shaft: needs ascending stations and one radius per segment between them")
    mass, ixx, izz = shaft_inertia(z, segment_radius_m, material.density_kg_m3)
    for j, m, jt, ja in extra_mass or ():
        mass[j], ixx[j], izz[j] = mass[j] + m, ixx[j] + jt, izz[j] + ja
    nodes, bodies, segments = [], [], []
    for j, zj in enumerate(z):
        nodes.append(int(mbs.AddNode(NodeRigidBodyRxyz(referenceCoordinates=[xy[0], xy[1], zj, 0.0, 0.0, 0.0]))))
        bodies.append(int(mbs.AddObject(ObjectRigidBody(nodeNumber=nodes[-1], mass=mass[j],
                                                        inertia=[ixx[j], ixx[j], izz[j], 0.0, 0.0, 0.0]))))
    for j, r in enumerate(segment_radius_m):
        half = 0.5 * (z[j + 1] - z[j])
        a = mbs.AddMarker(MarkerBodyRigid(bodyNumber=bodies[j], localPosition=[0.0, 0.0, half]))
        b = mbs.AddMarker(MarkerBodyRigid(bodyNumber=bodies[j + 1], localPosition=[0.0, 0.0, -half]))
        k = segment_stiffness(material, float(r), 2.0 * half)
        segments.append(int(mbs.AddObject(ObjectConnectorRigidBodySpringDamper(
            markerNumbers=[a, b], stiffness=np.diag(k), damping=np.zeros((6, 6))))))
    return ShaftHandles(tuple(nodes), tuple(bodies), tuple(segments))


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


def build_spatial(mbs, spec: ReducerSpec, errors: ErrorSpec, carrier, sun_node: int, axes: np.ndarray, *,
                  beam_elements: int | None = None) -> CrankHandles:
    """Add the cranks as rigid bodies free in space at ``axes`` (carrier frame, = reference positions at output
    angle 0), each on two support bearings; with ``beam_elements``, as flexible shafts.

    A crank's node (``NodeRigidBodyRxyz``) sits on its axis in the discs' mid-plane. Each support bearing is one
    of :func:`rvflex.contact.tapered_roller.support_rows` (half the pair the planar model lumps, at
    ±``support_span_m``/2 or, with ``bearings.crank_support_pair``, a tapered roller row at its pressure
    centre) between the carrier's bore there (``carrier.bore_markers`` +, ``carrier.input_seat_markers`` −)
    and the crank's journal, both with the crank's support-clearance error; so the pair's tilt stiffness is
    each bearing's own plus its radial stiffness over the span between them. The eccentrics
    sit at the discs' planes (:func:`rvflex.geometry.pins.disc_planes`), the planet gear at
    ``cranks.gear_axial_position_m`` (None: in the mid-plane), meshing with the planar sun through the gear's
    section (:func:`rvflex.contact.gear_mesh.add_gear_mesh` with ``planet_lever_m``).

    Parameters
    ----------
    mbs : exudyn.MainSystem
        The system to add to.
    spec : ReducerSpec
        The reducer (its ``crank_support`` the planar model's lumped pair).
    errors : ErrorSpec
        Its errors (eccentrics, support clearances, gear errors).
    carrier : CarrierHandles
        The spatial carrier (:func:`rvflex.parts.carrier.build_spatial`).
    sun_node : int
        The sun's ``NodeRigidBody2D``.
    axes : numpy.ndarray
        Crank axes in the carrier frame, (cranks, 2) (m).
    beam_elements : int, optional
        None: rigid cranks. Else each crank a Timoshenko shaft (:func:`beam_layout` with this many elements
        between neighbouring key planes, :func:`add_shaft`, ``materials.gears_cranks_discs``): the support
        bearings, eccentrics and planet gear on the stations at their planes, the gear's mesh on its station
        (lever 0), which is the crank's node.

    Returns
    -------
    CrankHandles
        With both support bearings of each crank (``supports``: output plate, ``input_supports``: input plate).

    Raises
    ------
    SpecError
        Beam cranks on a spec without the crank fields :func:`beam_layout` needs, naming the field.
    """
    from exudyn.itemInterface import MarkerBodyRigid, NodeRigidBodyRxyz, ObjectRigidBody

    if beam_elements is not None:
        return _build_beam_cranks(mbs, spec, errors, carrier, sun_node, axes, beam_elements)

    st, cr = spec.input_stage, spec.cranks
    rows = support_rows(spec)
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
        for seat, z, out in ((carrier.bore_markers[k], rows.half_span_m, supports),
                             (carrier.input_seat_markers[k], -rows.half_span_m, inputs)):
            journal = mbs.AddMarker(MarkerBodyRigid(bodyNumber=body, localPosition=[0.0, 0.0, z]))
            out.append(bearings.build(mbs, seat, journal, rows.bearing, extra_clearance_m=extra))
        markers.append(tuple(int(mbs.AddMarker(MarkerBodyRigid(bodyNumber=body, localPosition=[o[0], o[1], z])))
                             for o, z in zip(ecc[k], planes, strict=True)))
        meshes.append(add_gear_mesh(mbs, sun_node, node, st, planet_index=k, errors=errors, planet_lever_m=gear_z))
        nodes.append(node)
        bodies.append(body)
    return CrankHandles(tuple(nodes), tuple(bodies), tuple(markers), tuple(supports), tuple(meshes), tuple(inputs))


def _build_beam_cranks(mbs, spec: ReducerSpec, errors: ErrorSpec, carrier, sun_node: int, axes: np.ndarray,
                       elements: int) -> CrankHandles:
    """:func:`build_spatial`'s beam cranks: one shaft per crank (:func:`add_shaft`), the planet gear's mass on its
    station."""
    from exudyn.itemInterface import MarkerBodyRigid

    beam = beam_layout(spec, elements)
    rows = support_rows(spec)
    st = spec.input_stage
    rp = st.module_m * st.planet_teeth / 2
    material = spec.materials.gears_cranks_discs
    m_gear = material.density_kg_m3 * math.pi * rp * rp * st.face_width_m
    gear = [(beam.gear, m_gear, m_gear * (rp**2 / 4 + st.face_width_m**2 / 12), 0.5 * m_gear * rp**2)]
    ecc = eccentric_offsets(spec, errors)
    nodes, bodies, markers, supports, inputs, meshes, stations, segments = [], [], [], [], [], [], [], []
    for k, axis in enumerate(axes):
        shaft = add_shaft(mbs, axis, beam.station_z_m, beam.segment_radius_m, material, extra_mass=gear)
        extra = errors.crank_support_clearance_m[k] if errors.crank_support_clearance_m else 0.0
        for seat, j, out in ((carrier.bore_markers[k], beam.output_support, supports),
                             (carrier.input_seat_markers[k], beam.input_support, inputs)):
            journal = mbs.AddMarker(MarkerBodyRigid(bodyNumber=shaft.bodies[j], localPosition=[0.0, 0.0, 0.0]))
            out.append(bearings.build(mbs, seat, journal, rows.bearing, extra_clearance_m=extra))
        markers.append(tuple(int(mbs.AddMarker(MarkerBodyRigid(bodyNumber=shaft.bodies[j],
                                                               localPosition=[o[0], o[1], 0.0])))
                             for o, j in zip(ecc[k], beam.eccentrics, strict=True)))
        node = shaft.nodes[beam.gear]
        meshes.append(add_gear_mesh(mbs, sun_node, node, st, planet_index=k, errors=errors, planet_lever_m=0.0))
        nodes.append(node)
        bodies.append(shaft.bodies[beam.gear])
        stations.append(shaft.nodes)
        segments.append(shaft.segments)
    return CrankHandles(tuple(nodes), tuple(bodies), tuple(markers), tuple(supports), tuple(meshes), tuple(inputs),
                        tuple(stations), tuple(segments), beam)

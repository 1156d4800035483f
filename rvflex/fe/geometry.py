"""netgen/OCC solids of the flexible parts, built from a :class:`~rvflex.spec.ReducerSpec`.

Frames (metres, z = reducer axis, origin on the part's own axis):

* **Disc**: the disc body frame of :mod:`rvflex.geometry.profile` and
  ``parts/cycloid_disc.py`` — origin at the disc centre, x through a tooth root, mid-plane
  z = 0. Crank bores at ``crank_circle_radius_m·(cos a_k, sin a_k)`` with ``a_k =
  cranks.angles_rad[k]`` (as :func:`rvflex.parts.cycloid_disc.bore_positions` without
  errors), pillar clearance holes at :func:`pillar_angles`.
* **Housing**: the pin-ring frame of ``parts/pin_ring.py`` (ground) — origin on the reducer
  axis, pin 0 on +x (as :func:`rvflex.geometry.pins.pin_centres` without errors), the disc
  stack centred on z = 0.
* **Carrier**: the carrier body frame of ``parts/carrier.py`` — origin on the reducer
  axis, crank seats at the same crank-circle positions; the disc stack is centred on
  z = 0, the input plate on z < 0 and the output plate (with the output face) on z > 0.

The disc outline is a periodic B-spline interpolating the exact modified profile at
``SAMPLES_PER_TOOTH`` points per tooth; :func:`spline_deviation_m` measures its distance
to the exact profile (< 1 µm is required and tested). Faces are built counter-clockwise
(a clockwise face hangs netgen); every interface face carries a name (see
:data:`DISC_FACES`, :data:`CARRIER_FACES`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rvflex.choices import FEPart
from rvflex.geometry.profile import CycloidProfile, build_profile
from rvflex.spec import ReducerSpec, SpecError

__all__ = [
    "AXIAL_GAP_M",
    "CARRIER_FACES",
    "DISC_FACES",
    "HOUSING_FACES",
    "HOUSING_WALL_FRACTION",
    "MIN_WEB_M",
    "SAMPLES_PER_TOOTH",
    "PartGeometry",
    "carrier_geometry",
    "check_disc_layout",
    "disc_geometry",
    "housing_geometry",
    "part_geometry",
    "pillar_angles",
    "spline_deviation_m",
]

SAMPLES_PER_TOOTH = 96  # spline through 96 exact points per tooth deviates 0.22 µm on the RV-40E (64: 0.85 µm)
AXIAL_GAP_M = 1e-3  # assumed axial clearance between the disc stack and each carrier plate
MIN_WEB_M = 1e-3  # thinnest ligament accepted between two holes or a hole and the tooth root

DISC_FACES = ("flank", "side", "center_hole", "bore<k>", "pillar_hole<j>")
HOUSING_FACES = ("mount_face", "free_face", "outer", "bore", "seat<i>")
HOUSING_WALL_FRACTION = 0.25  # assumed radial wall of the pin housing beyond the pin circle, × the pin-circle radius
CARRIER_FACES = ("output_face", "input_face", "inner_face", "main_in", "main_out", "seat_in<k>", "seat_out<k>",
                 "pillar<j>", "center_hole")


@dataclass(frozen=True, eq=False)
class PartGeometry:
    """An OCC solid with its named interfaces.

    Attributes
    ----------
    part : str
        ``"disc"``, ``"carrier"`` or ``"housing"``.
    shape : netgen.occ.Solid
        The solid (m); its faces carry the names of :data:`DISC_FACES` / :data:`CARRIER_FACES` /
        :data:`HOUSING_FACES`.
    interfaces : tuple of tuple of str
        One entry per Craig–Bampton interface, in order, each the face names it joins;
        the first is the floating-frame reference (clamped in the modes).
    interface_names : tuple of str
        A name per interface (``"bore0"``, ``"seat0"``, ...).
    interface_centres_m : ndarray (n_interfaces, 3)
        Nominal centre of each interface in the part frame (m).
    volume_m3 : float
        Solid volume (m³), used for the mesh-size estimate.
    """

    part: FEPart
    shape: object
    interfaces: tuple[tuple[str, ...], ...]
    interface_names: tuple[str, ...]
    interface_centres_m: np.ndarray
    volume_m3: float


def pillar_angles(spec: ReducerSpec) -> np.ndarray:
    """Polar angles of the carrier pillars (rad): evenly spaced, the first half a pillar
    pitch after the first crank (so two pillars sit 90° from two cranks, as the catalogue
    assumes). The spec has no pillar-angle field; this is the one place that decides it."""
    n = spec.carrier.pillar_count
    a0 = spec.cranks.angles_rad[0]
    return np.array([(a0 + math.pi / n + 2 * math.pi * j / n) % (2 * math.pi) for j in range(n)]) if n else np.zeros(0)


def _holes(spec: ReducerSpec) -> list[tuple[str, str, float, float, float]]:
    """(face name, spec field, x, y, radius) of every through hole of the disc."""
    c, ca, cy = spec.cranks, spec.carrier, spec.cycloid
    out = []
    for k, a in enumerate(c.angles_rad):
        out.append((f"bore{k}", "cranks.disc_bore_radius_m", c.crank_circle_radius_m * math.cos(a),
                    c.crank_circle_radius_m * math.sin(a), c.disc_bore_radius_m))
    for j, a in enumerate(pillar_angles(spec)):
        out.append((f"pillar_hole{j}", "carrier.disc_pillar_hole_radius_m", ca.pillar_circle_radius_m * math.cos(a),
                    ca.pillar_circle_radius_m * math.sin(a), ca.disc_pillar_hole_radius_m))
    if cy.disc_center_hole_radius_m > 0:
        out.append(("center_hole", "cycloid.disc_center_hole_radius_m", 0.0, 0.0, cy.disc_center_hole_radius_m))
    return out


def check_disc_layout(spec: ReducerSpec, profile: CycloidProfile | None = None) -> None:
    """Refuse a disc whose holes break the tooth outline or each other (before any meshing).

    Raises
    ------
    SpecError
        Naming the hole's field, when a hole comes closer than :data:`MIN_WEB_M` to the
        profile's root (the smallest radius of the exact profile) or to another hole.
    """
    prof = profile or build_profile(spec.cycloid)
    q, _, _ = prof.evaluate(np.linspace(0.0, 2 * np.pi, spec.cycloid.disc_teeth * 64, endpoint=False))
    r_root = float(np.abs(q).min())
    holes = _holes(spec)
    for name, field, x, y, r in holes:
        reach = math.hypot(x, y) + r
        if reach > r_root - MIN_WEB_M:
            raise SpecError(field, r, f"disc hole {name} reaches radius {reach * 1e3:.2f} mm, beyond the tooth root "
                                      f"at {r_root * 1e3:.2f} mm less a {MIN_WEB_M * 1e3:g} mm web: it breaks the "
                                      f"disc outline")
    for i, (n1, f1, x1, y1, r1) in enumerate(holes):
        for n2, _f2, x2, y2, r2 in holes[i + 1:]:
            d = math.hypot(x1 - x2, y1 - y2)
            if d < r1 + r2 + MIN_WEB_M:
                raise SpecError(f1, r1, f"disc holes {n1} and {n2} leave a {(d - r1 - r2) * 1e3:.2f} mm web "
                                        f"(< {MIN_WEB_M * 1e3:g} mm): they break into each other")


def _spline(profile: CycloidProfile, n_per_tooth: int):
    from netgen.occ import Pnt, SplineInterpolation

    n = profile.stage.disc_teeth * n_per_tooth
    q, _, _ = profile.evaluate(np.linspace(0.0, 2 * np.pi, n, endpoint=False))
    # the profile runs counter-clockwise in t, so the face built on it is counter-clockwise
    return SplineInterpolation([Pnt(float(x), float(y), 0.0) for x, y in zip(q.real, q.imag)], periodic=True)


def spline_deviation_m(profile: CycloidProfile, n_per_tooth: int = SAMPLES_PER_TOOTH, oversample: int = 16) -> float:
    """Largest distance (m) between the OCC outline spline and the exact profile, sampled
    at ``oversample`` points per interpolation interval and measured by the exact
    closest-point solve of :meth:`CycloidProfile.gap`."""
    edge = _spline(profile, n_per_tooth)
    s0, s1 = edge.parameter_interval
    n = profile.stage.disc_teeth * n_per_tooth * oversample
    pts = np.array([(p.x, p.y) for p in (edge.Value(s) for s in np.linspace(s0, s1, n, endpoint=False))])
    return float(np.abs(profile.gap(pts, np.zeros(len(pts))).gap_m).max())


def disc_geometry(spec: ReducerSpec, *, n_per_tooth: int = SAMPLES_PER_TOOTH) -> PartGeometry:
    """The cycloid disc (nominal modified profile, no manufacturing errors: µm errors do not
    change its stiffness) with crank bores, pillar clearance holes and centre hole.

    Interfaces: one per crank bore (``bore0`` is the floating-frame reference).
    """
    from netgen.occ import Cylinder, Face, Pnt, Vec, Wire, Z

    profile = build_profile(spec.cycloid)
    check_disc_layout(spec, profile)
    T = spec.cycloid.disc_thickness_m
    solid = Face(Wire([_spline(profile, n_per_tooth)])).Extrude(Vec(0, 0, T)).Move(Vec(0, 0, -T / 2))
    _name_flank(solid)
    for name, _field, x, y, r in _holes(spec):
        cyl = Cylinder(Pnt(x, y, -T), Z, r, 2 * T)
        cyl.faces.name = name
        solid = solid - cyl
    cranks = spec.cranks
    centres = np.array([[cranks.crank_circle_radius_m * math.cos(a), cranks.crank_circle_radius_m * math.sin(a), 0.0]
                        for a in cranks.angles_rad])
    names = tuple(f"bore{k}" for k in range(cranks.count))
    # OCC's volume of the periodic-spline solid is off by 7 %; the exact area (Green's formula on
    # the exact profile) minus the holes is what the mesh reproduces
    q, q1, _ = profile.evaluate(np.linspace(0.0, 2 * np.pi, spec.cycloid.disc_teeth * 512, endpoint=False))
    area = 0.5 * np.mean(q.real * q1.imag - q.imag * q1.real) * 2 * np.pi
    area -= sum(math.pi * r * r for *_, r in _holes(spec))
    return PartGeometry("disc", solid, tuple((n,) for n in names), names, centres, float(area * T))


def _name_flank(solid) -> None:
    """Name the one non-planar face of the extruded outline ``flank`` (the caps stay ``side``)."""
    for f in solid.faces:
        bb = f.bounding_box
        f.name = "side" if abs(bb[1].z - bb[0].z) < 1e-5 else "flank"


def carrier_geometry(spec: ReducerSpec) -> PartGeometry:
    """The carrier: input and output plates (discs of ``outer_radius_m``, ``plate_thickness_m``)
    joined by the pillars, with a crank bearing seat per crank in each plate.

    Simplifications (documented in docs/fe.md): plates are plain discs; the seat radius is
    the disc's crank-bore radius (the spec has no support-bearing size); the plate centre
    hole equals the disc centre hole; the plates sit :data:`AXIAL_GAP_M` outside the disc
    stack. Interfaces: ``output`` (the output plate's outer face, floating-frame
    reference), then ``seat_in<k>`` and ``seat_out<k>`` per crank.
    """
    from netgen.occ import Cylinder, Pnt, Z

    cy, ca, cr = spec.cycloid, spec.carrier, spec.cranks
    pos = cr.eccentric_axial_positions_m or (0.0,)
    z_in = min(pos) - cy.disc_thickness_m / 2 - AXIAL_GAP_M  # inner face of the input plate
    z_out = max(pos) + cy.disc_thickness_m / 2 + AXIAL_GAP_M
    tp = ca.plate_thickness_m
    seat_r = cr.disc_bore_radius_m
    if cr.crank_circle_radius_m + seat_r > ca.outer_radius_m - MIN_WEB_M:
        raise SpecError("carrier.outer_radius_m", ca.outer_radius_m,
                        f"the crank seats reach radius {(cr.crank_circle_radius_m + seat_r) * 1e3:.2f} mm: the plate "
                        f"is too small for them")
    if ca.pillar_count and ca.pillar_circle_radius_m + ca.pillar_radius_m > ca.outer_radius_m - MIN_WEB_M:
        raise SpecError("carrier.pillar_circle_radius_m", ca.pillar_circle_radius_m,
                        "the pillars reach beyond the carrier plates")

    def plate(z0: float, outer: str, inner: str, rim: str):
        p = Cylinder(Pnt(0, 0, z0), Z, ca.outer_radius_m, tp)
        for f in p.faces:
            bb = f.bounding_box
            if abs(bb[1].z - bb[0].z) > 1e-5:
                f.name = rim
            else:
                f.name = outer if abs(0.5 * (bb[0].z + bb[1].z) - (z0 if outer == "input_face" else z0 + tp)) < 1e-5 else inner
        return p

    solid = plate(z_in - tp, "input_face", "inner_face", "main_in") + plate(z_out, "output_face", "inner_face",
                                                                            "main_out")
    for j, a in enumerate(pillar_angles(spec)):
        pil = Cylinder(Pnt(ca.pillar_circle_radius_m * math.cos(a), ca.pillar_circle_radius_m * math.sin(a), z_in),
                       Z, ca.pillar_radius_m, z_out - z_in)
        pil.faces.name = f"pillar{j}"
        solid = solid + pil
    centres = [[0.0, 0.0, z_out + tp]]
    names = ["output"]
    groups = [("output_face",)]
    for k, a in enumerate(cr.angles_rad):
        x, y = cr.crank_circle_radius_m * math.cos(a), cr.crank_circle_radius_m * math.sin(a)
        for side, z0 in (("in", z_in - tp), ("out", z_out)):
            hole = Cylinder(Pnt(x, y, z0 - tp), Z, seat_r, 3 * tp)
            hole.faces.name = f"seat_{side}{k}"
            solid = solid - hole
            names.append(f"seat_{side}{k}")
            groups.append((f"seat_{side}{k}",))
            centres.append([x, y, z0 + tp / 2])
    if cy.disc_center_hole_radius_m > 0:
        hole = Cylinder(Pnt(0, 0, z_in - 2 * tp), Z, cy.disc_center_hole_radius_m, z_out - z_in + 4 * tp)
        hole.faces.name = "center_hole"
        solid = solid - hole
    return PartGeometry("carrier", solid, tuple(groups), tuple(names), np.array(centres), float(solid.mass))


def housing_geometry(spec: ReducerSpec) -> PartGeometry:
    """The pin housing: the ring that carries the pins in semicircular seats (grooves) cut into
    its bore, as the pin ring of an RV reducer's case.

    Simplifications (docs/flexible.md; the spec has no housing dimensions): a plain ring with its
    bore on the pin circle (each pin sits half in its seat), the outer radius
    ``pin_circle_radius_m·(1 + HOUSING_WALL_FRACTION)`` (assumed wall), as long axially as the
    disc stack plus :data:`AXIAL_GAP_M` each side (the pin length); the seats are the pin
    cylinders of the nominal pin radius. Interfaces: ``mount`` (the end face on the output side,
    where the case is bolted to the machine: the floating-frame reference, clamped to ground),
    then ``seat<i>`` per pin in pin order.
    """
    from netgen.occ import Cylinder, Pnt, Z

    cy, cr = spec.cycloid, spec.cranks
    pos = cr.eccentric_axial_positions_m or (0.0,)
    z0 = min(pos) - cy.disc_thickness_m / 2 - AXIAL_GAP_M
    z1 = max(pos) + cy.disc_thickness_m / 2 + AXIAL_GAP_M
    r_in = cy.pin_circle_radius_m
    r_out = r_in * (1.0 + HOUSING_WALL_FRACTION)
    if r_out - r_in - cy.pin_radius_m < 2 * MIN_WEB_M:
        raise SpecError("cycloid.pin_radius_m", cy.pin_radius_m,
                        f"the pin seats leave less than {2 * MIN_WEB_M * 1e3:g} mm of housing wall")
    length = z1 - z0
    ring = Cylinder(Pnt(0, 0, z0), Z, r_out, length) - Cylinder(Pnt(0, 0, z0 - length), Z, r_in, 3 * length)
    for f in ring.faces:
        bb = f.bounding_box
        if abs(bb[1].z - bb[0].z) < 1e-5:
            f.name = "mount_face" if bb[0].z > 0.5 * (z0 + z1) else "free_face"
        else:
            f.name = "outer" if max(abs(bb[1].x), abs(bb[1].y)) > 0.5 * (r_in + r_out) else "bore"
    names, groups, centres = ["mount"], [("mount_face",)], [[0.0, 0.0, z1]]
    for i in range(cy.pin_count):
        a = 2 * math.pi * i / cy.pin_count
        x, y = r_in * math.cos(a), r_in * math.sin(a)
        seat = Cylinder(Pnt(x, y, z0 - length), Z, cy.pin_radius_m, 3 * length)
        seat.faces.name = f"seat{i}"
        ring = ring - seat
        names.append(f"seat{i}")
        groups.append((f"seat{i}",))
        centres.append([x, y, 0.5 * (z0 + z1)])
    return PartGeometry("housing", ring, tuple(groups), tuple(names), np.array(centres), float(ring.mass))


def part_geometry(spec: ReducerSpec, part: FEPart) -> PartGeometry:
    """Geometry of ``part`` (``"disc"``, ``"carrier"`` or ``"housing"``)."""
    if part == "disc":
        return disc_geometry(spec)
    if part == "carrier":
        return carrier_geometry(spec)
    if part == "housing":
        return housing_geometry(spec)
    raise SpecError("part", part, "must be 'disc', 'carrier' or 'housing'")

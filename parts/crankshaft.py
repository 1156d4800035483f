"""Crankshafts with their planet gears: one planar body per crank on its support bearing in
the carrier, meshing with the sun, carrying one eccentric per disc."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rvflex.choices import BodyFidelity, check_choice
from rvflex.contact.gear_mesh import GearMeshHandles, add_gear_mesh
from rvflex.parts import bearings
from rvflex.spec import ErrorSpec, ReducerSpec

__all__ = ["CrankHandles", "build", "eccentric_offsets"]


@dataclass(frozen=True)
class CrankHandles:
    """Per crank: node and body; eccentric_markers[k][d] the rigid marker of disc d's
    eccentric; support bearing and gear mesh."""

    nodes: tuple[int, ...]
    bodies: tuple[int, ...]
    eccentric_markers: tuple[tuple[int, ...], ...]
    supports: tuple[bearings.BearingPair, ...]
    meshes: tuple[GearMeshHandles, ...]


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

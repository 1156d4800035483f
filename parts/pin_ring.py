"""Pin ring (housing): pins as exact circles, per-pin errors included, in a rigid or an
FE-reduced housing.

In the rigid fidelity the housing is ground; the pins live inside each disc's contact
element (:mod:`rvflex.contact.cycloid_pin`), which takes them from here. In the flexible
fidelity the housing is its Craig–Bampton reduction (:func:`rvflex.fe.reduce.reduce_part`
``(spec, "housing")``) with its mount face clamped to ground: the floating frame is then
ground itself, so the body is linear — reduced mass and stiffness on the modal coordinates
(an ``ObjectGenericODE2`` on a ``NodeGenericODE2``), no FFRF terms — and each pin sits at its
centre plus the in-plane motion of its seat (the seat's area-weighted mean displacement, the
coupling its attachment modes were computed for). The contact elements take the seat rows and
the modal node from here; by virtual work a pin force F loads the modes by S_iᵀF.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rvflex.choices import BodyFidelity, check_choice
from rvflex.geometry.pins import pin_centres, pin_radii
from rvflex.spec import ErrorSpec, ReducerSpec

__all__ = ["PinRingHandles", "build", "seat_rows"]


@dataclass(frozen=True, eq=False)
class PinRingHandles:
    """Pin centres (n, 2) in the housing frame and radii (n,), errors included (m); a flexible
    housing adds its modal node (NodeGenericODE2, −1 when rigid), its body and the seat rows
    (n, 2, h) (m per modal unit) that move each pin."""

    centres_m: np.ndarray
    radii_m: np.ndarray
    modal_node: int = -1
    body: int = -1
    seat_rows: np.ndarray | None = None


def seat_rows(reduced) -> np.ndarray:
    """In-plane displacement rows of every pin seat of a reduced housing, (n_pins, 2, h): the
    area-weighted mean of each seat's node rows (the pin centre's motion; transposed, the
    generalised force of a pin force), in pin order (interfaces ``seat<i>``)."""
    psi = reduced.mode_basis.reshape(reduced.n_nodes, 3, -1)
    seats = [i for i in reduced.interfaces if i.name.startswith("seat")]
    return np.ascontiguousarray(np.stack([np.einsum("j,jcm->cm", i.weights, psi[i.nodes, :2, :]) for i in seats]))


def build(mbs, spec: ReducerSpec, errors: ErrorSpec, *, fidelity: BodyFidelity = "rigid",
          reduced=None) -> PinRingHandles:
    """The pin ring of ``spec``: nothing is added to ``mbs`` in the rigid fidelity; the
    flexible one (``reduced``: the housing's :class:`rvflex.fe.reduce.ReducedPart`) adds the
    housing's modal node and its linear reduced body (mass, stiffness; no damping)."""
    check_choice("fidelity", fidelity, BodyFidelity)
    if fidelity == "flexible" and (reduced is None or reduced.part != "housing"):
        raise ValueError("fidelity = 'flexible': the housing needs its reduction (reduce_part(spec, 'housing'))")
    centres, radii = pin_centres(spec.cycloid, errors), pin_radii(spec.cycloid, errors)
    if fidelity == "rigid":
        return PinRingHandles(centres, radii)
    rows = seat_rows(reduced)
    if rows.shape[0] != spec.cycloid.pin_count:
        raise ValueError(f"flexible housing: the reduction has {rows.shape[0]} pin seats, the spec "
                         f"{spec.cycloid.pin_count} pins")
    from exudyn.itemInterface import NodeGenericODE2, ObjectGenericODE2

    h = reduced.n_modes
    node = mbs.AddNode(NodeGenericODE2(referenceCoordinates=[0.0] * h, initialCoordinates=[0.0] * h,
                                       initialCoordinates_t=[0.0] * h, numberOfODE2Coordinates=h))
    M = 0.5 * (reduced.mass_reduced + reduced.mass_reduced.T)
    Kr = 0.5 * (reduced.stiffness_reduced + reduced.stiffness_reduced.T)
    body = mbs.AddObject(ObjectGenericODE2(nodeNumbers=[node], massMatrix=M, stiffnessMatrix=Kr,
                                           dampingMatrix=np.zeros((h, h))))
    return PinRingHandles(centres, radii, int(node), int(body), rows)

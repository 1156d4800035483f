"""Input shaft with the sun gear: a planar body on the reducer axis whose angle is
prescribed (quasi-static stepping) and whose centre is held on the axis."""

from __future__ import annotations

from dataclasses import dataclass

from rvflex.choices import BodyFidelity, check_choice
from rvflex.spec import ReducerSpec

__all__ = ["InputHandles", "build"]


@dataclass(frozen=True)
class InputHandles:
    """node: the sun's NodeRigidBody2D; drive: the coordinate constraint on its angle
    (offset = input angle − reference, set by the solver)."""

    node: int
    body: int
    drive: int


def build(mbs, spec: ReducerSpec, ground_coordinate: int, *, fidelity: BodyFidelity = "rigid") -> InputHandles:
    """Add the input shaft; mass and inertia of a steel shaft of the sun's pitch diameter. The
    shaft is rigid in every model: ``fidelity="flexible"`` is refused."""
    check_choice("fidelity", fidelity, BodyFidelity)
    if fidelity != "rigid":
        raise NotImplementedError(f"fidelity = {fidelity!r}: the input shaft is a rigid body (no FE shaft yet)")
    from exudyn.itemInterface import MarkerNodeCoordinate, NodeRigidBody2D, ObjectConnectorCoordinate, ObjectRigidBody2D

    st = spec.input_stage
    r = st.module_m * st.sun_teeth / 2
    rho = spec.materials.gears_cranks_discs.density_kg_m3
    mass = rho * 3.141592653589793 * r * r * 0.08  # 80 mm shaft
    node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0.0, 0.0, 0.0]))
    body = mbs.AddObject(ObjectRigidBody2D(nodeNumber=node, mass=mass, inertia=0.5 * mass * r * r))
    for k in range(2):
        mbs.AddObject(ObjectConnectorCoordinate(markerNumbers=[ground_coordinate, mbs.AddMarker(
            MarkerNodeCoordinate(nodeNumber=node, coordinate=k))]))
    drive = mbs.AddObject(ObjectConnectorCoordinate(markerNumbers=[ground_coordinate, mbs.AddMarker(
        MarkerNodeCoordinate(nodeNumber=node, coordinate=2))], offset=0.0))
    return InputHandles(int(node), int(body), int(drive))

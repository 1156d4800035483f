"""Bearings of the reducer: the clearance bearing of :mod:`rvflex.contact.bearing` plus a weak
regularising spring in parallel, so quasi-static Newton stays regular while a bearing is open.

The spring is REGULARISER_SHARE × k_n radially: in contact it carries that share of the load
(1e-6: a 1e-11 m shift at 10 µm of deflection); inside the clearance it carries the whole,
negligible, load of a floating body.
"""

from __future__ import annotations

from dataclasses import dataclass

from rvflex.contact.bearing import BearingHandles, add_clearance_bearing
from rvflex.spec import Bearing

__all__ = ["BearingPair", "build", "REGULARISER_SHARE"]

REGULARISER_SHARE = 1e-6


@dataclass(frozen=True)
class BearingPair:
    """Items of one bearing: the clearance bearing and its regularising spring."""

    bearing: BearingHandles
    regulariser: int
    marker0: int
    marker1: int


def build(mbs, marker0: int, marker1: int, bearing: Bearing, *, extra_clearance_m: float = 0.0) -> BearingPair:
    """Add a clearance bearing between two rigid markers (axis: z of marker 0)."""
    from exudyn.itemInterface import ObjectConnectorCartesianSpringDamper

    handles = add_clearance_bearing(mbs, marker0, marker1, bearing, extra_clearance_m=extra_clearance_m)
    k = REGULARISER_SHARE * bearing.radial_stiffness_N_m
    reg = mbs.AddObject(ObjectConnectorCartesianSpringDamper(markerNumbers=[marker0, marker1], stiffness=[k, k, 0.0],
                                                             damping=[0.0, 0.0, 0.0]))
    return BearingPair(handles, int(reg), marker0, marker1)

"""A crank's two support bearings in the spatial model: where each carries its load and how stiff it is
along the axis and in tilt.

The planar model lumps a crank's two support bearings into one bushing (``spec.bearings.crank_support``);
the spatial model puts each of the two, with half the lumped radial stiffness and damping, at its own plane.
Where the spec gives the rows' geometry (``[bearings.crank_support_pair]``, :class:`TaperedRollerPair`),
each is a preloaded tapered roller row:

- **Where.** A roller's load acts along the normal to the cup raceway through the roller's mid-length
  contact. That normal meets the axis at the row's *pressure centre*
  (:attr:`rvflex.spec.TaperedRollerPair.pressure_centre_offset_m`), a = r_c·tan α from the roller's
  mid-plane (r_c the cup raceway's radius there, (d_m + D_w·cos α)/2 with the pitch diameter
  d_m = (d + D)/2 of bore d and outside diameter D, α the cup angle), outboard in a back-to-back pair and
  inboard face to face. Each row's radial spring sits at its pressure centre, so the pair resists a tilt
  over the span between them, ``support_span_m`` ± 2a.
- **Axial.** With every roller in contact (preloaded), a radial shift δ compresses the roller at azimuth
  φ by δ·cos α·cos φ and an axial one by δ·sin α, so with the roller's normal stiffness k_n the row's
  radial stiffness is k_r = (Z/2)·k_n·cos²α and its axial one Z·k_n·sin²α = 2·k_r·tan²α (Z rollers).
- **Own tilt.** Every roller's load line passes through the pressure centre, so a tilt about it loads a
  roller only by twisting its contact line: a line contact of length l turned by β carries k_n·l²/12·β,
  and a tilt θ turns the roller at azimuth φ by θ·sin φ, so the row's own tilt stiffness is
  (Z/2)·k_n·l²/12 = k_r·l²/(12·cos²α), small beside the pair's k_r·span²/2.

k_r is the spec's (half the lumped ``crank_support.radial_stiffness_N_m``): the geometry sets where and how
the rows carry, not how stiff the rollers are. Without the table each bearing is half the lumped bushing
at ±``support_span_m``/2 (its axial and tilt stiffness halved too).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from rvflex.spec import Bearing, ReducerSpec, TaperedRollerPair

__all__ = ["SupportRows", "half_bearing", "row_bearing", "support_rows"]


@dataclass(frozen=True, slots=True)
class SupportRows:
    """A crank's two support bearings as the spatial model places them.

    Attributes
    ----------
    bearing : Bearing
        Each of the two (radial, axial and own tilt stiffness, damping, clearance law).
    half_span_m : float
        Axial position of each from the discs' mid-plane, ± this (m): the pressure centres where the rows'
        geometry is given, else ``support_span_m``/2.
    pressure_centre_offset_m : float
        How far each row's pressure centre lies outboard (+) or inboard (−) of its roller mid-plane (m); 0
        without the rows' geometry.
    """

    bearing: Bearing
    half_span_m: float
    pressure_centre_offset_m: float


def half_bearing(bearing: Bearing) -> Bearing:
    """One of the two bearings the planar model lumps into ``bearing``: its stiffnesses and damping halved,
    the same clearance and law."""
    return dataclasses.replace(bearing, radial_stiffness_N_m=0.5 * bearing.radial_stiffness_N_m,
                               axial_stiffness_N_m=0.5 * bearing.axial_stiffness_N_m,
                               tilt_stiffness_Nm_rad=0.5 * bearing.tilt_stiffness_Nm_rad,
                               radial_damping_Ns_m=0.5 * bearing.radial_damping_Ns_m)


def row_bearing(pair: TaperedRollerPair, lumped: Bearing) -> Bearing:
    """One row of ``pair`` as a bushing: half of ``lumped``'s radial stiffness and damping, its clearance
    law, the axial stiffness 2·k_r·tan²α and the own tilt stiffness k_r·l²/(12·cos²α) of a preloaded row.

    Parameters
    ----------
    pair : TaperedRollerPair
        The rows' geometry.
    lumped : Bearing
        The planar model's lumped pair (``spec.bearings.crank_support``).

    Returns
    -------
    Bearing
    """
    half = half_bearing(lumped)
    k_r, alpha = half.radial_stiffness_N_m, pair.cup_angle_rad
    return dataclasses.replace(half, axial_stiffness_N_m=2.0 * k_r * math.tan(alpha) ** 2,
                               tilt_stiffness_Nm_rad=k_r * pair.roller_length_m**2 / (12.0 * math.cos(alpha) ** 2))


def support_rows(spec: ReducerSpec) -> SupportRows:
    """A crank's two support bearings as the spatial model builds them (needs ``cranks.support_span_m``).

    Parameters
    ----------
    spec : ReducerSpec
        The reducer.

    Returns
    -------
    SupportRows
    """
    half = 0.5 * spec.cranks.support_span_m
    pair = spec.bearings.crank_support_pair
    if pair is None:
        return SupportRows(half_bearing(spec.bearings.crank_support), half, 0.0)
    a = pair.pressure_centre_offset_m
    return SupportRows(row_bearing(pair, spec.bearings.crank_support), half + a, a)

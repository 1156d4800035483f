"""Initial clearance and free play of a disc among its pins, from the exact geometry.

The disc is held at the nominal centre of eccentric angle θ and turned about that centre;
every gap comes from the exact closest-point solve, so modifications and pin/disc errors
enter exactly (DESIGN.md: closed forms are tests, not substitutes).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from rvflex.geometry.pins import nominal_disc_pose, pin_angle_from_eccentric, pin_centres, pin_radii, to_disc_frame
from rvflex.geometry.profile import CycloidProfile, build_profile
from rvflex.spec_types import CycloidStage, ErrorSpec

__all__ = ["Clearance", "initial_clearance_numeric"]

BRACKET_RAD = 0.02  # > 60′: no usable reducer has more free play than this


@dataclass(frozen=True)
class Clearance:
    """Clearance of one disc at one eccentric angle (lengths in m, angles in rad).

    Attributes
    ----------
    phi : ndarray (z_b,)
        Pin angles from the eccentricity direction.
    nominal_gap_m : ndarray (z_b,)
        Normal gap of every pin with the disc at its nominal pose.
    turn_pos_rad, turn_neg_rad : float
        Disc rotation (CCW positive) at which the first pin touches, each way.
    gap_after_pos_m, gap_after_neg_m : ndarray (z_b,)
        Gaps once turned by ``turn_pos_rad`` / ``turn_neg_rad``: seed 000's Δ_i on the
        closing flank (0 at the first contacting pin).
    closing_pos, closing_neg : ndarray of bool
        Pins whose gap closes for a positive / negative turn.
    """

    phi: np.ndarray
    nominal_gap_m: np.ndarray
    turn_pos_rad: float
    turn_neg_rad: float
    gap_after_pos_m: np.ndarray
    gap_after_neg_m: np.ndarray
    closing_pos: np.ndarray
    closing_neg: np.ndarray

    @property
    def free_play_rad(self) -> float:
        """Total rotational free play of the disc between first contacts on either flank."""
        return self.turn_pos_rad - self.turn_neg_rad


def initial_clearance_numeric(stage: CycloidStage, errors: ErrorSpec | None = None, disc: int = 0,
                              eccentric_angle_rad: float = 0.0,
                              profile: CycloidProfile | None = None, *,
                              allow_interference: bool = False) -> Clearance:
    """Gaps of all pins at the nominal pose and after turning the disc to first contact.

    With ``allow_interference`` a profile that overlaps a pin at the nominal pose (a preloaded
    mesh, e.g. seed 003's negative moved + negative equidistant RV-80E) gives the nominal gaps,
    no turn (free play 0) and the nominal gaps as the gaps "after" turning.

    Raises
    ------
    ValueError
        If a pin interferes at the nominal pose (no clearance to close) and
        ``allow_interference`` is false.
    """
    prof = profile or build_profile(stage, errors, disc)
    pins, radii = pin_centres(stage, errors), pin_radii(stage, errors)
    centre, angle = nominal_disc_pose(stage, eccentric_angle_rad, disc)

    def gaps(turn: float) -> np.ndarray:
        return prof.gap(to_disc_frame(pins, centre, angle + turn), radii).gap_m

    g0 = gaps(0.0)
    phi = pin_angle_from_eccentric(stage, eccentric_angle_rad)
    if g0.min() < 0.0 and allow_interference:
        return Clearance(phi, g0, 0.0, 0.0, g0, g0, np.zeros(len(g0), bool), np.zeros(len(g0), bool))
    if g0.min() < 0.0:
        k = int(np.argmin(g0))
        raise ValueError(f"pin {k} interferes by {-g0[k] * 1e6:.3f} µm at the nominal pose: no clearance")
    slope = (gaps(1e-7) - gaps(-1e-7)) / 2e-7
    turn_pos = brentq(lambda b: gaps(b).min(), 0.0, BRACKET_RAD, xtol=1e-15, rtol=1e-14)
    turn_neg = brentq(lambda b: gaps(b).min(), -BRACKET_RAD, 0.0, xtol=1e-15, rtol=1e-14)
    return Clearance(phi, g0, turn_pos, turn_neg, gaps(turn_pos), gaps(turn_neg), slope < 0, slope > 0)

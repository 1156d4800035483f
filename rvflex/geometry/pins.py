"""Pin ring and disc kinematics in the cycloid stage.

Frames: the ring frame has its origin on the reducer axis and pin 0 on +x. A disc with
eccentric (crank) angle θ sits at centre e·(cos θ, sin θ) and, for a fixed ring, turns by
β = −θ/z_c; disc ``k`` with eccentric phase ϕ_k is the same part mounted so that its
profile frame is turned by −ϕ_k/z_c relative to the carrier (half a tooth for ϕ = π).
"""

from __future__ import annotations

import numpy as np

from rvflex.spec_types import CycloidStage, ErrorSpec, ReducerSpec

__all__ = ["disc_planes", "pin_centres", "pin_radii", "nominal_disc_pose", "to_disc_frame", "pin_angle_from_eccentric"]


def disc_planes(spec: ReducerSpec) -> np.ndarray:
    """Each disc's axial position from the discs' mid-plane (its crank eccentric's), shape (discs,) (m): where
    :func:`pin_centres` cuts a tilted pin ring (``ErrorSpec.pin_ring_tilt_rad``)."""
    z = np.asarray(spec.cranks.eccentric_axial_positions_m, float)
    return z - z.mean()


def pin_centres(stage: CycloidStage, errors: ErrorSpec | None = None, axial_m: float = 0.0) -> np.ndarray:
    """Pin centres in the ring frame, shape (z_b, 2) (m), including the ErrorSpec pin errors, in the
    plane at axial position ``axial_m`` from the discs' mid-plane (m; a disc's: its crank eccentric's).

    Applied: ``pin_circle_radius_error_m``, per-pin ``pin_radial_m`` (outward) and
    ``pin_tangential_m`` (arc length, counter-clockwise), the ring runout
    ``pin_ring_runout_m`` at ``pin_ring_runout_phase_rad`` (a shift of the whole ring), and the
    ring's tilt: a shift ``pin_ring_tilt_rad``·``axial_m`` towards ``pin_ring_tilt_phase_rad``.
    """
    zb = stage.pin_count
    r = np.full(zb, stage.pin_circle_radius_m)
    ang = 2 * np.pi * np.arange(zb) / zb
    shift = np.zeros(2)
    if errors is not None:
        r += errors.pin_circle_radius_error_m
        if errors.pin_radial_m:
            r += np.asarray(errors.pin_radial_m)
        if errors.pin_tangential_m:
            ang = ang + np.asarray(errors.pin_tangential_m) / stage.pin_circle_radius_m
        shift = errors.pin_ring_runout_m * np.array(
            [np.cos(errors.pin_ring_runout_phase_rad), np.sin(errors.pin_ring_runout_phase_rad)])
        shift = shift + errors.pin_ring_tilt_rad * axial_m * np.array(
            [np.cos(errors.pin_ring_tilt_phase_rad), np.sin(errors.pin_ring_tilt_phase_rad)])
    return np.column_stack([r * np.cos(ang), r * np.sin(ang)]) + shift


def pin_radii(stage: CycloidStage, errors: ErrorSpec | None = None) -> np.ndarray:
    """Pin radii, shape (z_b,) (m): nominal + ``pin_radius_error_m`` + ``pin_radius_individual_m``."""
    r = np.full(stage.pin_count, stage.pin_radius_m)
    if errors is not None:
        r += errors.pin_radius_error_m
        if errors.pin_radius_individual_m:
            r += np.asarray(errors.pin_radius_individual_m)
    return r


def nominal_disc_pose(stage: CycloidStage, eccentric_angle_rad: float, disc: int = 0) -> tuple[np.ndarray, float]:
    """Centre (m) and profile-frame angle (rad) of disc ``disc`` for a fixed ring.

    ``eccentric_angle_rad`` is the absolute angle θ of the first disc's eccentric.
    """
    theta = eccentric_angle_rad + stage.disc_phase_rad[disc]
    centre = stage.eccentricity_m * np.array([np.cos(theta), np.sin(theta)])
    return centre, -theta / stage.disc_teeth


def to_disc_frame(points: np.ndarray, centre: np.ndarray, angle_rad: float) -> np.ndarray:
    """Express ring-frame points (n, 2) in a disc frame at ``centre`` turned by ``angle_rad``."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    d = np.asarray(points, float) - centre
    return np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]])


def pin_angle_from_eccentric(stage: CycloidStage, eccentric_angle_rad: float) -> np.ndarray:
    """Angle φ_i of each pin from the eccentricity direction, wrapped to [0, 2π) (seed 000's φ_i)."""
    ang = 2 * np.pi * np.arange(stage.pin_count) / stage.pin_count
    return np.mod(ang - eccentric_angle_rad, 2 * np.pi)

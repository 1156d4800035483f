"""A tilting moment on the output: the carrier's tilt on its main bearing pair, carried into the gear train.

A robot arm loads the reducer's output with a tilting moment beside the torque. The output carrier runs on the
main bearing pair (``spec.bearings.main_pair``, :mod:`rvflex.contact.angular_contact`), which takes the moment and
lets the carrier tilt by θ = (θx, θy) (and move by a little, δ). The cranks run in the carrier's end plates and
the discs on the cranks' eccentrics, so each disc tilts with the carrier while the pins stay in the housing: a
point of a disc at axial position z (from the discs' mid-plane, where the pair's centre is taken to lie) moves
by θ × z plus δ against the pins. For the planar model of the gear train that is the pin ring moved the other
way, −(δ + θ × z), at every axial position: a ring runout −δ and a ring tilt (``ErrorSpec.pin_ring_runout_m``,
``pin_ring_tilt_rad``) added to the unit's own errors. With the pin contact in slices along the face width
(``ModelOptions.face_slices``) each slice sees its own shift, so the tilt loads the pins' two ends unequally.

The coupling is one way: the pair alone sets the tilt. The gear train's own resistance to the tilt (the discs
pressed sideways against the pins through the needle bearings) is small against the pair's tilt stiffness;
:func:`gear_train_moment_Nm` measures the moment the pin forces carry at the solved state, so a run states
how large the neglected share is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from rvflex.spec_types import ErrorSpec, ReducerSpec, SpecError

__all__ = ["MOMENT_SLICES", "OutputTilt", "carrier_tilt", "gear_train_moment_Nm", "tilted_errors"]

ARCMIN_PER_RAD = 180.0 * 60.0 / math.pi

MOMENT_SLICES = 4
"""Contact slices along the face width of a run under a moment (``rvflex te --moment``): the convergence study
(``python -m rvflex.scenarios.pin_slices``, docs/spatial.md) puts the TE peak-to-peak within 0.03″, its order-z_c
ripple within 0.005″ and the faces' line loads within 1 % of eight slices' from four, at 3–3.6× the planar run's
cost."""


@dataclass(frozen=True)
class OutputTilt:
    """The carrier on its main bearing pair under a tilting moment (:func:`carrier_tilt`).

    Parameters
    ----------
    moment_Nm : float
        The tilting moment's magnitude, N·m.
    moment_angle_rad : float
        Direction of the moment vector in the housing frame (from +x towards +y), rad.
    tilt_rad : tuple of float
        The carrier's small rotation (θx, θy), rad.
    shift_m : tuple of float
        The carrier's displacement (δx, δy) at the pair's centre, m.
    balls_in_contact : int
        Balls of the pair carrying load.
    """

    moment_Nm: float
    moment_angle_rad: float
    tilt_rad: tuple[float, float]
    shift_m: tuple[float, float]
    balls_in_contact: int

    @property
    def tilt_magnitude_rad(self) -> float:
        """|θ|, rad."""
        return float(math.hypot(*self.tilt_rad))

    @property
    def tilt_arcmin(self) -> float:
        """|θ| in arcmin (the unit of the catalogues' moment rigidity)."""
        return self.tilt_magnitude_rad * ARCMIN_PER_RAD

    def disc_shift_m(self, axial_m: float) -> np.ndarray:
        """In-plane displacement (x, y) of the carrier and what it carries at axial position ``axial_m`` (m): δ + θ × z."""
        tx, ty = self.tilt_rad
        return np.array([self.shift_m[0] + ty * axial_m, self.shift_m[1] - tx * axial_m])


def carrier_tilt(spec: ReducerSpec, moment_Nm: float, moment_angle_rad: float = 0.0) -> OutputTilt:
    """The carrier's tilt and shift on ``spec``'s main bearing pair under a tilting moment.

    Parameters
    ----------
    spec : ReducerSpec
        Needs ``bearings.main_pair`` and ``allowable_moment_Nm``.
    moment_Nm : float
        Magnitude, N·m, in (0, allowable moment].
    moment_angle_rad : float, optional
        Direction of the moment vector in the housing frame, rad (default 0: about +x).

    Returns
    -------
    OutputTilt

    Raises
    ------
    SpecError
        No main bearing pair (naming ``bearings.main_pair``), no allowable moment, or a moment outside
        (0, allowable] (naming ``moment_Nm``); a direction that is not finite (naming ``moment_angle_rad``).
    """
    from rvflex.contact.angular_contact import PairLoad, pair_model, solve

    if spec.bearings.main_pair is None:
        raise SpecError("bearings.main_pair", None, f"{spec.name} gives no main bearing pair geometry: add a "
                                                    "[bearings.main_pair] table to load the output with a moment")
    spec.check_moment("moment_Nm", moment_Nm)
    if not (isinstance(moment_angle_rad, (int, float)) and math.isfinite(moment_angle_rad)):
        raise SpecError("moment_angle_rad", moment_angle_rad, "must be a finite angle in radians")
    m = np.array([math.cos(moment_angle_rad), math.sin(moment_angle_rad)]) * moment_Nm
    state = solve(pair_model(spec.bearings.main_pair), PairLoad(moment_Nm=(float(m[0]), float(m[1]))))
    q = state.q
    return OutputTilt(float(moment_Nm), float(moment_angle_rad), (float(q[3]), float(q[4])),
                      (float(q[0]), float(q[1])), int(state.balls_in_contact))


def tilted_errors(errors: ErrorSpec | None, tilt: OutputTilt) -> ErrorSpec:
    """``errors`` with the pins moved against the tilted carrier: the ring runout −δ and the ring tilt that
    shifts it by −θ × z at axial position z, each added to the unit's own (as vectors)."""
    e = errors or ErrorSpec()
    tx, ty = tilt.tilt_rad
    # the ring against the carrier at z: −(δ + θ × z) = −δ + z·(−θy, θx)
    run = e.pin_ring_runout_m * np.array([math.cos(e.pin_ring_runout_phase_rad), math.sin(e.pin_ring_runout_phase_rad)])
    run = run - np.asarray(tilt.shift_m)
    tlt = e.pin_ring_tilt_rad * np.array([math.cos(e.pin_ring_tilt_phase_rad), math.sin(e.pin_ring_tilt_phase_rad)])
    tlt = tlt + np.array([-ty, tx])
    return replace(e, pin_ring_runout_m=float(np.hypot(*run)), pin_ring_runout_phase_rad=float(np.arctan2(run[1], run[0])),
                   pin_ring_tilt_rad=float(np.hypot(*tlt)), pin_ring_tilt_phase_rad=float(np.arctan2(tlt[1], tlt[0])))


def gear_train_moment_Nm(spec: ReducerSpec, slice_resultant_N: np.ndarray) -> np.ndarray:
    """The tilting moment (M_x, M_y) about the discs' mid-plane of the pins' forces on the discs, per step (N·m):
    each slice's resultant (x, y) acting at its axial position z, (z e_z) × F.

    ``slice_resultant_N`` (steps, discs, slices, 2) from a run with the contact in slices
    (``QuasiStaticResult.slice_resultant_N``). The discs sit apart along the axis and carry opposite forces, so
    an untilted unit has such a moment too (the cranks take it); what a tilt adds to it is the share of the
    external moment the gear train carries."""
    from rvflex.parts.cycloid_disc import slice_planes

    f = np.asarray(slice_resultant_N, float)
    z = slice_planes(spec, f.shape[2])  # (discs, slices)
    return np.stack([-np.einsum("nds,ds->n", f[..., 1], z), np.einsum("nds,ds->n", f[..., 0], z)], axis=-1)

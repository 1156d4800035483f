"""Loads on the output besides its torque: the carrier's tilt on its main bearing pair, carried into the gear train.

A robot arm loads the reducer's output with a tilting moment, an axial and a radial force beside the torque
(:class:`OutputLoad`). The output carrier runs on the main bearing pair (``spec.bearings.main_pair``,
:mod:`rvflex.contact.angular_contact`), which takes them and lets the carrier tilt by θ = (θx, θy) and move by δ.
The cranks run in the carrier's end plates and the discs on the cranks' eccentrics, so each disc tilts with the
carrier while the pins stay in the housing: a point of a disc at axial position z (from the discs' mid-plane,
where the pair's centre is taken to lie) moves by δ + θ × z against the pins. For the planar model of the gear
train that is the pin ring moved the other way, −(δ + θ × z), at every axial position: a ring runout −δ and a ring
tilt (``ErrorSpec.pin_ring_runout_m``, ``pin_ring_tilt_rad``) added to the unit's own errors. With the pin contact
in slices along the face width (``ModelOptions.face_slices``) each slice sees its own shift, so the tilt loads the
pins' two ends unequally.

The coupling is one way: the pair alone sets the tilt. The gear train's own resistance to the tilt (the discs
pressed sideways against the pins through the needle bearings) is small against the pair's tilt stiffness:
:func:`gear_train_moment_Nm` measures the moment the pin forces carry at a solved state, and the convergence study
(``python -m rvflex.scenarios.pin_slices``) states the share a tilt adds (a few per cent of the moment).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from rvflex.geometry.formulas import ARCMIN_PER_RAD
from rvflex.spec_types import ErrorSpec, ReducerSpec, SpecError

__all__ = ["MOMENT_SLICES", "OutputLoad", "OutputTilt", "STATIC_PRESSURE_LIMIT_PA", "carrier_tilt",
           "gear_train_moment_Nm", "tilted_errors"]

MOMENT_SLICES = 4
"""Contact slices along the face width of a run under a moment (``rvflex te --moment``): the convergence study
(``python -m rvflex.scenarios.pin_slices``, docs/spatial.md) puts the TE peak-to-peak within 0.03″, its order-z_c
ripple within 0.005″ and the faces' line loads within 1 % of eight slices' from four, at 3–3.6× the planar run's
cost."""


STATIC_PRESSURE_LIMIT_PA = 4.2e9
"""ISO 76's static-rating contact stress of ball bearings: an output load that takes a main bearing ball beyond it
is refused."""


@dataclass(frozen=True)
class OutputLoad:
    """Loads on the output besides its torque, at the main bearing pair's centre (on the axis, in the discs'
    mid-plane); directions in the housing frame, from +x towards +y.

    Parameters
    ----------
    moment_Nm : float
        Tilting moment, N·m: 0 or in (0, the spec's ``allowable_moment_Nm``].
    moment_angle_rad : float
        Direction of the moment vector, rad (0: about +x).
    axial_force_N : float
        Force along the reducer axis, N (positive along +z).
    radial_force_N : float
        Radial force, N (≥ 0), towards ``radial_angle_rad``.
    radial_angle_rad : float
        Direction of the radial force, rad.
    """

    moment_Nm: float = 0.0
    moment_angle_rad: float = 0.0
    axial_force_N: float = 0.0
    radial_force_N: float = 0.0
    radial_angle_rad: float = 0.0

    def __post_init__(self) -> None:
        for name in ("moment_Nm", "moment_angle_rad", "axial_force_N", "radial_force_N", "radial_angle_rad"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise SpecError(name, v, "must be a finite number (SI: N·m, N, rad)")
        if self.radial_force_N < 0.0:
            raise SpecError("radial_force_N", self.radial_force_N, "must not be negative (its direction goes in "
                                                                   "radial_angle_rad)")

    @property
    def any(self) -> bool:
        """True when the output carries a moment or a force."""
        return bool(self.moment_Nm or self.axial_force_N or self.radial_force_N)

    def coordinate_loads(self) -> np.ndarray:
        """The load as the spatial carrier's node takes it (:func:`rvflex.parts.carrier.build_spatial`).

        Returns
        -------
        numpy.ndarray
            (F_x, F_y, F_z, M_x, M_y) in N and N·m, on the node's x, y, z, ψx, ψy.
        """
        p = self.pair_load()
        return np.array([*p.force_N, *p.moment_Nm], float)

    def pair_load(self):
        """The load as the pair model takes it.

        Returns
        -------
        rvflex.contact.angular_contact.PairLoad
            Forces (F_x, F_y, F_z) in N and moment (M_x, M_y) in N·m at the pair's centre.
        """
        from rvflex.contact.angular_contact import PairLoad

        m, r = self.moment_Nm, self.radial_force_N
        return PairLoad(force_N=(r * math.cos(self.radial_angle_rad), r * math.sin(self.radial_angle_rad),
                                 float(self.axial_force_N)),
                        moment_Nm=(m * math.cos(self.moment_angle_rad), m * math.sin(self.moment_angle_rad)))


@dataclass(frozen=True)
class OutputTilt:
    """The carrier on its main bearing pair under an output load (:func:`carrier_tilt`).

    Parameters
    ----------
    load : OutputLoad
        The load.
    tilt_rad : tuple of float
        The carrier's small rotation (θx, θy), rad.
    shift_m : tuple of float
        The carrier's displacement (δx, δy) at the pair's centre, m.
    balls_in_contact : int
        Balls of the pair carrying load.
    peak_pressure_Pa : float
        The most loaded ball's peak Hertz pressure, Pa.
    """

    load: OutputLoad
    tilt_rad: tuple[float, float]
    shift_m: tuple[float, float]
    balls_in_contact: int
    peak_pressure_Pa: float

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


def carrier_tilt(spec: ReducerSpec, load: OutputLoad | float, moment_angle_rad: float = 0.0) -> OutputTilt:
    """The carrier's tilt and shift on ``spec``'s main bearing pair under an output load.

    Parameters
    ----------
    spec : ReducerSpec
        Needs ``bearings.main_pair`` (and ``allowable_moment_Nm`` for a moment).
    load : OutputLoad or float
        The load, or a tilting moment alone (N·m) towards ``moment_angle_rad``.
    moment_angle_rad : float, optional
        With a moment given as a number: its direction, rad.

    Returns
    -------
    OutputTilt

    Raises
    ------
    SpecError
        No main bearing pair (naming ``bearings.main_pair``), no allowable moment, a moment outside
        (0, allowable] (naming ``moment_Nm``), or a load that takes a ball beyond
        :data:`STATIC_PRESSURE_LIMIT_PA` (naming the force).
    """
    from rvflex.contact.angular_contact import pair_model, solve

    if not isinstance(load, OutputLoad):
        load = OutputLoad(moment_Nm=load, moment_angle_rad=moment_angle_rad)
    if spec.bearings.main_pair is None:
        raise SpecError("bearings.main_pair", None, f"{spec.name} gives no main bearing pair geometry: add a "
                                                    "[bearings.main_pair] table to load the output with a moment or "
                                                    "a force")
    if load.moment_Nm:
        spec.check_moment("moment_Nm", load.moment_Nm)
    state = solve(pair_model(spec.bearings.main_pair), load.pair_load())
    peak = float(state.peak_pressure_Pa.max())
    if peak > STATIC_PRESSURE_LIMIT_PA:
        name = "radial_force_N" if load.radial_force_N else "axial_force_N" if load.axial_force_N else "moment_Nm"
        raise SpecError(name, getattr(load, name), f"with the rest of the output load the main bearing pair's most "
                                                   f"loaded ball reaches {peak / 1e9:.2f} GPa, beyond the "
                                                   f"{STATIC_PRESSURE_LIMIT_PA / 1e9:g} GPa static limit (ISO 76)")
    q = state.q
    return OutputTilt(load, (float(q[3]), float(q[4])), (float(q[0]), float(q[1])), int(state.balls_in_contact), peak)


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

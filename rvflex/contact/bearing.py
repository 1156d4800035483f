"""Clearance bearing: a 6-DOF bushing whose radial stiffness switches on beyond a clearance.

Seed 001 models each crank-eccentric / disc-bore bearing as a bushing with the radial
stiffness ``IF(d − ε: 0, 0, k_n)``: no force while the radial relative displacement d is
inside the radial clearance ε, the full contact stiffness k_n beyond it. This module builds
that element on Exudyn's ``ObjectConnectorRigidBodySpringDamper`` with a *symbolic* force
law (``exudyn.symbolic``), which Exudyn records once and then evaluates in C++: no Python
runs per step or per Newton iteration.

The force law, in the joint frame J0 of marker 0 (its local z is the bearing axis; u is the
relative displacement of marker 1, d = |(u_x, u_y)|, x = d − ε)::

    radial   f_r = k_n · r_w(x) · (u_x, u_y) / d + c · s_w(x) · (v_x, v_y)
    axial    f_z = k_ax · u_z + c · v_z
    tilt     m_x = k_tilt · θ_x,  m_y = k_tilt · θ_y          (Tait–Bryan angles of J1 in J0)
    spin     m_z = 0                                          (a bearing turns freely)

A power-law bearing (``Bearing.load_exponent`` e, ``reference_load_N`` F_r; x_r = F_r/k_n) has
``f_r = k_n·x_r^(1−e)·r_w(x)^e · (u_x, u_y)/d``: the rolling contact's F = F_r·(x/x_r)^e past the clearance,
of secant stiffness k_n at F_r.

with the C¹ smoothed ramp r_w and its derivative, the contact indicator s_w = r_w'::

    r_w(x) = 0                  x ≤ −w           s_w(x) = 0
             (x + w)² / (4 w)   |x| < w                   (x + w) / (2 w)
             x                  x ≥ w                     1

Properties (w is the smoothing half-width, see :data:`DEFAULT_SMOOTHING_M`):

- exactly the sharp law of seed 001 outside the band |d − ε| < w: exactly zero force for
  d ≤ ε − w, exactly k_n·(d − ε) for d ≥ ε + w;
- inside the band the force is above the sharp law by at most k_n·w/4 (at d = ε), and a
  static equilibrium lies at most w inside the sharp one (at vanishing load);
- monotone and C¹ in the displacement vector u, and a central force (the gradient of a
  potential of |u|), so its stiffness matrix in u is continuous and symmetric; the
  stiffness ramps from 0 to k_n over 2w;
- the band is kept inside d ≥ 0 by using w_eff = min(w, ε): the force is exactly zero
  around d = 0 (no singular direction), and for ε = 0 the law is the linear spring k_n.

Damping: the bearing's ``radial_damping_Ns_m`` c acts on the radial relative velocity
(both in-plane components, so that ε = 0 gives isotropic linear damping) only while in
contact, scaled by the same indicator s_w; the same c acts axially at all times (a needle
bearing has no axial clearance in this model). Tilt and spin are undamped: the spec gives
no value for them; generalized-α's numerical damping takes care of their high frequencies.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from exudyn import symbolic as esym
from exudyn.advancedUtilities import CreateSymbolicUserFunction
from exudyn.itemInterface import ObjectConnectorRigidBodySpringDamper

from rvflex.spec import Bearing, SpecError

__all__ = [
    "DEFAULT_SMOOTHING_M",
    "BearingHandles",
    "add_clearance_bearing",
    "effective_smoothing_m",
    "radial_force_N",
    "contact_indicator",
]

DEFAULT_SMOOTHING_M = 0.1e-6
"""Default smoothing half-width w = 0.1 µm.

Accuracy: the law is exact once the bearing carries k_n·w (51 N for the RV-40E eccentric
bearing, k_n = 5.1e8 N/m). At the catalogue's lost-motion points (±3 % of 412 N·m) its four
eccentric bearings carry about 0.03·412 N·m / (4 · 36 mm) ≈ 86 N each tangentially, plus the
radial part of the pin forces, so there the law is exact; closer to zero load a position is
off by less than w, i.e. 0.1 µm ≈ 0.3″ at the 66 mm pin circle.

Robustness: the stiffness ramps over 2w = 0.2 µm, 200 times Exudyn's default
finite-difference increment for the Jacobian (relativeEpsilon 1e-7 × max(1 cm, |q|) = 1 nm
for displacements), so Newton sees the ramp. Measured: the sharp law (w = 0) fails to
converge when a loaded bearing is unloaded to zero in one static step; w = 0.02 µm to 0.5 µm
all converge in ≤ 10 iterations. Keep the increment ≪ w: a crank angle coordinate of
~1000 rad gives 1e-4 rad × 1.25 mm eccentricity ≈ 0.13 µm, so lower
``newton.numericalDifferentiation.relativeEpsilon`` (or keep angles small) in long runs.
"""

RIGID_MARKER_TYPES = frozenset({"BodyRigid", "NodeRigid", "SuperElementRigid", "KinematicTreeRigid"})
MAX_EXTRA_CLEARANCE_M = 1e-3  # as ErrorSpec: clearances are µm-scale, at most 1 mm
MAX_SMOOTHING_M = 10e-6  # far above any sensible width; catches µm passed as metres


@dataclass(frozen=True, slots=True)
class BearingHandles:
    """Items of one clearance bearing in an Exudyn system.

    Attributes
    ----------
    connector : int
        Object index of the ``ObjectConnectorRigidBodySpringDamper``; its ``ForceLocal``
        and ``TorqueLocal`` outputs are the bearing reaction (N, N·m) in marker 0's joint
        frame, acting on marker 1 as −force (restoring).
    clearance_m : float
        Radial clearance ε the law uses (bearing plus extra), m.
    smoothing_m : float
        Effective smoothing half-width w_eff = min(w, ε) the law uses, m.
    load_exponent : float
        Exponent e of the law past the clearance (1: linear).
    reference_approach_m : float
        x_r of the power law, m (0: linear).
    """

    connector: int
    clearance_m: float
    smoothing_m: float
    load_exponent: float = 1.0
    reference_approach_m: float = 0.0


def effective_smoothing_m(clearance_m: float, smoothing_m: float) -> float:
    """Smoothing half-width actually used, min(w, ε), so the band never reaches d = 0 (m)."""
    return min(smoothing_m, clearance_m)


def _ramp(x: np.ndarray, w: float) -> np.ndarray:
    if w == 0.0:
        return np.maximum(x, 0.0)
    return np.where(x <= -w, 0.0, np.where(x >= w, x, (x + w) ** 2 / (4.0 * w)))


def radial_force_N(d_m, *, stiffness_N_m: float, clearance_m: float,
                   smoothing_m: float = DEFAULT_SMOOTHING_M, load_exponent: float = 1.0,
                   reference_approach_m: float = 0.0) -> np.ndarray:
    """Magnitude of the radial spring force k_n·r_w(d − ε) (or k_n·x_r^(1−e)·r_w(d − ε)^e) for radial
    displacement(s) d.

    The same law the connector evaluates (module docstring); for post-processing and tests.

    Parameters
    ----------
    d_m : array_like
        Radial relative displacement d ≥ 0, m.
    stiffness_N_m : float
        Contact stiffness k_n, N/m.
    clearance_m : float
        Radial clearance ε, m.
    smoothing_m : float
        Smoothing half-width w, m (``min(w, ε)`` is used).
    load_exponent : float
        Exponent e of the power law (1: linear).
    reference_approach_m : float
        Its x_r = F_r/k_n, m (read when e ≠ 1).

    Returns
    -------
    ndarray
        Restoring force magnitude, N.
    """
    d = np.asarray(d_m, dtype=float)
    w = effective_smoothing_m(clearance_m, smoothing_m)
    r = _ramp(d - clearance_m, w)
    if load_exponent == 1.0:
        return stiffness_N_m * r
    return stiffness_N_m * reference_approach_m ** (1.0 - load_exponent) * r**load_exponent


def contact_indicator(d_m, *, clearance_m: float, smoothing_m: float = DEFAULT_SMOOTHING_M) -> np.ndarray:
    """Smoothed contact indicator s_w(d − ε) ∈ [0, 1] (dimensionless) that scales the radial damping."""
    x = np.asarray(d_m, dtype=float) - clearance_m
    w = effective_smoothing_m(clearance_m, smoothing_m)
    if w == 0.0:
        return np.where(x > 0.0, 1.0, 0.0) if clearance_m > 0.0 else np.ones_like(x)
    return np.where(x <= -w, 0.0, np.where(x >= w, 1.0, (x + w) / (2.0 * w)))


def _symbolic_law(eps: float, w: float, e: float = 1.0, x_r: float = 0.0):
    """Force-torque law for ``springForceTorqueUserFunction``, to be recorded symbolically.

    Linear coefficients come from the connector's stiffness and damping matrices (so they
    can be inspected and changed with ``SetObjectParameter``); ε, w and the power law's e and x_r
    are recorded as constants of the expression.
    """
    zero, one = esym.Real(0.0), esym.Real(1.0)

    def rvflex_clearance_bearing(mbs, t, itemNumber, displacement, rotation, velocity, angularVelocity,
                                 stiffness, damping, rotJ0, rotJ1, offset):
        ux, uy = displacement[0], displacement[1]
        k, c = stiffness[0, 0], damping[0, 0]
        if e != 1.0:  # the power law: g = k·x_r^(1−e)·r_w(x)^e / d
            kp = k * (x_r ** (1.0 - e))
            d = esym.sqrt(ux * ux + uy * uy)
            x = d - eps
            if eps == 0.0:  # r_w = d: g = kp·d^(e−1), zero at d = 0 (e > 1), no division
                g, s = kp * esym.pow(d, e - 1.0), one
            elif w == 0.0:
                g = esym.IfThenElse(x <= 0.0, zero, kp * esym.pow(x, e) / d)
                s = esym.IfThenElse(x <= 0.0, zero, one)
            else:
                band = kp * esym.pow((x + w) * (x + w) / (4.0 * w), e) / d
                g = esym.IfThenElse(x <= -w, zero, esym.IfThenElse(x >= w, kp * esym.pow(x, e) / d, band))
                s = esym.IfThenElse(x <= -w, zero, esym.IfThenElse(x >= w, one, (x + w) / (2.0 * w)))
        elif eps == 0.0:  # linear spring and damper: no switch at all
            g, s = k, one
        else:
            d = esym.sqrt(ux * ux + uy * uy)
            x = d - eps
            if w == 0.0:  # sharp law of seed 001; d > ε > 0 in the contact branch
                g = esym.IfThenElse(x <= 0.0, zero, k * (1.0 - eps / d))
                s = esym.IfThenElse(x <= 0.0, zero, one)
            else:  # g = k·r_w(x)/d: the band lies in d ≥ ε − w ≥ 0, and d > 0 there
                band = k * (x + w) * (x + w) / (4.0 * w * d)
                g = esym.IfThenElse(x <= -w, zero, esym.IfThenElse(x >= w, k * (1.0 - eps / d), band))
                s = esym.IfThenElse(x <= -w, zero, esym.IfThenElse(x >= w, one, (x + w) / (2.0 * w)))
        cs = c * s
        return [g * ux + cs * velocity[0],
                g * uy + cs * velocity[1],
                stiffness[2, 2] * displacement[2] + damping[2, 2] * velocity[2],
                stiffness[3, 3] * rotation[0],
                stiffness[4, 4] * rotation[1],
                zero]

    return rvflex_clearance_bearing


def _check_length(name: str, value: float, hi: float, rule: str) -> None:
    if not (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
            and 0.0 <= value <= hi):
        raise SpecError(name, value, rule)


def _check_marker(mbs, name: str, marker: int) -> None:
    try:
        marker_type = mbs.GetMarker(marker)["markerType"]
    except Exception as exc:  # Exudyn raises its own index/type errors
        raise SpecError(name, marker, "is not a marker of this system") from exc
    if marker_type not in RIGID_MARKER_TYPES:
        raise SpecError(name, marker, f"is a Marker{marker_type}; the bearing needs a rigid (position + "
                                      "orientation) marker, e.g. MarkerBodyRigid")


def add_clearance_bearing(mbs, marker0: int, marker1: int, bearing: Bearing, *,
                          extra_clearance_m: float = 0.0, smoothing_m: float = DEFAULT_SMOOTHING_M,
                          name: str = "") -> BearingHandles:
    """Add a clearance bearing (6-DOF bushing, seed 001) between two rigid markers.

    The bearing axis is the local z axis of marker 0's joint frame (give the marker a
    ``localHT`` to turn it). Radial force is zero inside the clearance ε and k_n·(d − ε)
    beyond it (or the bearing's power law), smoothed over |d − ε| < w (law and damping in the module docstring); axial
    and tilt stiffness are linear; rotation about the axis is free. Works with planar
    (``ObjectRigidBody2D``) and 3D rigid bodies alike.

    Parameters
    ----------
    mbs : exudyn.MainSystem
        System to add to.
    marker0, marker1 : int
        Rigid markers (``MarkerBodyRigid``, ``MarkerNodeRigid``, ...); marker 0 carries the
        joint frame (e.g. the disc bore), marker 1 the journal (e.g. the crank eccentric).
    bearing : rvflex.spec.Bearing
        Stiffnesses (N/m, N·m/rad), radial damping (N·s/m) and nominal clearance (m).
    extra_clearance_m : float, optional
        Radial clearance added to ``bearing.clearance_m`` (an ErrorSpec entry), m, ≥ 0.
    smoothing_m : float, optional
        Smoothing half-width w, m, ≥ 0 (default :data:`DEFAULT_SMOOTHING_M`, 0.1 µm;
        0 gives the sharp IF law). The law uses min(w, ε).
    name : str, optional
        Name of the connector object.

    Returns
    -------
    BearingHandles
        Connector index and the ε, w the law uses.

    Raises
    ------
    SpecError
        (a ValueError) naming the offending parameter: a negative or non-finite extra
        clearance or smoothing width, or a marker that is missing or not rigid.
    """
    if not isinstance(bearing, Bearing):
        raise SpecError("bearing", bearing, "must be an rvflex.spec.Bearing")
    _check_length("extra_clearance_m", extra_clearance_m, MAX_EXTRA_CLEARANCE_M,
                  "expected metres, 0 to 1 mm (a clearance cannot be negative)")
    _check_length("smoothing_m", smoothing_m, MAX_SMOOTHING_M, "expected metres, 0 to 10 µm")
    _check_marker(mbs, "marker0", marker0)
    _check_marker(mbs, "marker1", marker1)
    if int(marker0) == int(marker1):
        raise SpecError("marker1", marker1, "must differ from marker0")

    eps = float(bearing.clearance_m + extra_clearance_m)
    w = effective_smoothing_m(eps, float(smoothing_m))
    k, c = bearing.radial_stiffness_N_m, bearing.radial_damping_Ns_m
    k_ax, k_tilt = bearing.axial_stiffness_N_m, bearing.tilt_stiffness_Nm_rad
    # Recorded once into an expression tree evaluated in C++; the connector keeps a
    # reference to it, so it lives as long as the item.
    e = 1.0 if bearing.load_exponent is None else float(bearing.load_exponent)
    x_r = bearing.reference_approach_m
    law = CreateSymbolicUserFunction(mbs, _symbolic_law(eps, w, e, x_r), "springForceTorqueUserFunction",
                                     itemTypeName="ObjectConnectorRigidBodySpringDamper")
    connector = mbs.AddObject(ObjectConnectorRigidBodySpringDamper(
        name=name,
        markerNumbers=[marker0, marker1],
        stiffness=np.diag([k, k, k_ax, k_tilt, k_tilt, 0.0]),  # in-contact values; read by the law
        damping=np.diag([c, c, c, 0.0, 0.0, 0.0]),
        springForceTorqueUserFunction=law,
    ))
    return BearingHandles(connector=int(connector), clearance_m=eps, smoothing_m=w, load_exponent=e,
                          reference_approach_m=x_r)

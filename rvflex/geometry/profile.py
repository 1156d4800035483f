"""Cycloid disc profile: theoretical, modified (all four kinds) and with disc errors.

The profile lives in the disc's own frame (origin at the disc centre, x through a tooth
root). It is the inner envelope of the generating pins: see :mod:`._kernels` for the
exact parametrisation. :func:`build_profile` turns a :class:`~rvflex.spec.CycloidStage`
(and optionally the disc errors of an :class:`~rvflex.spec.ErrorSpec`) into a
:class:`CycloidProfile`, checking that the curve is closed, counter-clockwise and free of
self-intersection.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from rvflex.geometry import _kernels as K
from rvflex.spec_types import CycloidStage, ErrorSpec, SpecError

__all__ = ["CurveKey", "CycloidProfile", "GapResult", "build_profile", "check_stage", "harmonics_from_teeth"]

SAMPLES_PER_TOOTH = 256
COMPENSATION_SMOOTHING_RAD = 0.01


@dataclass(frozen=True)
class GapResult:
    """Closest-point result for a set of pins (all arrays have one row per pin).

    Attributes
    ----------
    gap_m : ndarray (n,)
        Signed gap, centre distance to the profile minus pin radius (m); < 0 is interference.
    t : ndarray (n,)
        Profile parameter of the closest point (rad).
    point_m : ndarray (n, 2)
        Closest profile point in the disc frame (m).
    normal : ndarray (n, 2)
        Outward unit normal of the profile there (points toward the pin).
    curvature_1_m : ndarray (n,)
        Signed profile curvature there (1/m), positive where the disc is convex.
    """

    gap_m: np.ndarray
    t: np.ndarray
    point_m: np.ndarray
    normal: np.ndarray
    curvature_1_m: np.ndarray


@dataclass(frozen=True, eq=False)
class CycloidProfile:
    """An exact cycloid disc profile (one disc), ready for closest-point queries.

    Build it with :func:`build_profile`. ``par``, ``herr`` and ``hpsi`` are the numba
    kernel's inputs; treat them as read-only.
    """

    stage: CycloidStage
    par: np.ndarray
    herr: np.ndarray
    hpsi: np.ndarray

    # ------------------------------------------------------------------ evaluation
    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Profile points Q(t) and derivatives Q'(t), Q''(t) as complex arrays (m)."""
        t = np.ascontiguousarray(np.atleast_1d(t), dtype=float)
        q, q1, q2 = (np.empty(t.shape, complex) for _ in range(3))
        K.sample(t, self.par, self.herr, self.hpsi, q, q1, q2)
        return q, q1, q2

    def points(self, n_per_tooth: int = 64) -> np.ndarray:
        """Closed polyline of the profile, shape (N + 1, 2), counter-clockwise (m)."""
        n = self.stage.disc_teeth * n_per_tooth
        q, _, _ = self.evaluate(np.linspace(0.0, 2 * np.pi, n + 1))
        return np.column_stack([q.real, q.imag])

    def normal(self, t: np.ndarray) -> np.ndarray:
        """Outward unit normal at t, shape (n, 2)."""
        _, q1, _ = self.evaluate(t)
        nrm = -1j * q1 / np.abs(q1)
        return np.column_stack([nrm.real, nrm.imag])

    def curvature(self, t: np.ndarray) -> np.ndarray:
        """Signed curvature at t (1/m), positive where the disc is convex."""
        _, q1, q2 = self.evaluate(t)
        return (q1.real * q2.imag - q1.imag * q2.real) / np.abs(q1) ** 3

    def pressure_angle(self, t: np.ndarray) -> np.ndarray:
        """Pressure angle at t (rad): angle between the profile normal and the velocity
        direction of that disc point when the disc turns about its centre (seed 003 eq. 26)."""
        q, q1, _ = self.evaluate(t)
        tang = q1 / np.abs(q1)
        radial = q / np.abs(q)
        # cos α = |normal · circumferential| = |tangent · radial|: 90° at root and tip
        cos_a = np.abs(tang.real * radial.real + tang.imag * radial.imag)
        return np.arccos(np.clip(cos_a, 0.0, 1.0))

    def tooth_phase_to_t(self, u: np.ndarray) -> np.ndarray:
        """Parameter t of the first tooth at tooth phase u (0 root, π tip)."""
        return np.asarray(u, float) / self.stage.disc_teeth

    # ------------------------------------------------------------------ closest point
    def gap(self, centres: np.ndarray, radii: np.ndarray, t_init: np.ndarray | None = None) -> GapResult:
        """Exact signed gaps of pins (centres in the disc frame, shape (n, 2); radii (n,)) in m.

        ``t_init`` (n,) warm-starts the solve from known parameters (e.g. ``GapResult.t``
        of the previous step); NaN entries start cold.

        Raises
        ------
        RuntimeError
            If the closest-point Newton iteration fails for a point (not seen for points
            within a tooth height of the profile: tests/test_geometry.py).
        """
        centres = np.ascontiguousarray(centres, dtype=float).reshape(-1, 2)
        radii = np.ascontiguousarray(np.broadcast_to(radii, centres.shape[:1]), dtype=float)
        n = centres.shape[0]
        g, t, kap = np.empty(n), np.empty(n), np.empty(n)
        q, nrm = np.empty((n, 2)), np.empty((n, 2))
        t0 = np.full(n, np.nan) if t_init is None else np.ascontiguousarray(t_init, dtype=float)
        bad = K.gaps(centres, radii, self.par, self.herr, self.hpsi, t0, g, t, q, nrm, kap)
        if bad:
            raise RuntimeError(f"closest-point solve did not converge for {bad} of {n} pins")
        return GapResult(g, t, q, nrm, kap)

    def brute_force_gap(self, centres: np.ndarray, radii: np.ndarray, samples: int = 1 << 22) -> np.ndarray:
        """Reference signed gaps (m) by exhaustive search over ``samples`` equally spaced
        parameters of the whole profile (no Newton): the check of :meth:`gap`.

        With 2²² samples of an RV-40E disc the spacing is 0.1 µm of arc, so the sampled
        minimum exceeds the true distance by less than 1e-12 m.
        """
        centres = np.ascontiguousarray(centres, dtype=float).reshape(-1, 2)
        radii = np.ascontiguousarray(np.broadcast_to(radii, centres.shape[:1]), dtype=float)
        q, q1, _ = self.evaluate(np.linspace(0.0, 2 * np.pi, samples, endpoint=False))
        out = np.empty(centres.shape[0])
        K.brute_force_gaps(centres, radii, q, q1, out)
        return out

    # ------------------------------------------------------------------ checks
    def check(self, *, field: str = "cycloid.modification") -> None:
        """Refuse a profile that is not a simple counter-clockwise closed curve.

        Three checks: (1) the generating pin stays inside the pin-centre curve's radius of
        curvature, 1 − r·κ_p > 0 on a dense sample with the minimum refined by bounded
        minimisation (else the envelope folds into a swallowtail, however small);
        (2) no two segments of the polyline (SAMPLES_PER_TOOTH per tooth) cross within
        ±1.5 teeth, where a fold of a tooth can reach; (3) positive signed area.
        The outcome is remembered per curve (:func:`_defect`): every model build checks its
        profiles, and a diagnosis builds the same discs some 70 times.
        """
        defect = _defect(CurveKey(self))
        if defect is None:
            return
        kind, a, b = defect
        zc = self.stage.disc_teeth
        if kind == "undercut":
            raise SpecError(field, _mod_repr(self.stage),
                            f"the profile self-intersects: the generating pin radius exceeds the pin-centre curve's "
                            f"radius of curvature near tooth phase {math.degrees((a * zc) % (2 * math.pi)):.1f}° "
                            f"(undercut); reduce the pin radius, the equidistant/tip modification or the eccentricity")
        if kind == "crossing":
            raise SpecError(field, _mod_repr(self.stage),
                            f"the profile self-intersects near tooth phases {math.degrees((a * zc) % (2 * np.pi)):.1f}°"
                            f" and {math.degrees((b * zc) % (2 * np.pi)):.1f}°")
        raise SpecError(field, _mod_repr(self.stage), "the profile is not counter-clockwise")

    def _defect(self) -> tuple[str, float, float] | None:
        """What :meth:`check` refuses: ("undercut", t, 0), ("crossing", t_i, t_j) or
        ("clockwise", 0, 0) (profile parameters, rad); None for a simple counter-clockwise curve."""
        zc = self.stage.disc_teeth
        ts = np.linspace(0.0, 2 * np.pi, zc * SAMPLES_PER_TOOTH, endpoint=False)
        margin = self._offset_margin(ts)
        k = int(np.argmin(margin))
        h = ts[1] - ts[0]
        worst = min(float(margin[k]), _minimise(lambda x: float(self._offset_margin(np.array([x]))[0]),
                                                ts[k] - h, ts[k] + h))
        if worst <= 0.0:
            return "undercut", float(ts[k]), 0.0
        q, q1, _ = self.evaluate(ts)
        xy, span = np.column_stack([q.real, q.imag]), SAMPLES_PER_TOOTH * 3 // 2
        if K.any_self_intersection(xy, span):  # the boxed test first; the first crossing pair only to name it
            i, j = K.first_self_intersection(xy, span)
            return "crossing", float(ts[i]), float(ts[j])
        area = 0.5 * np.sum(q.real * q1.imag - q.imag * q1.real) * h
        if area <= 0.0:
            return "clockwise", 0.0, 0.0
        return None

    def _offset_margin(self, ts: np.ndarray) -> np.ndarray:
        """1 − r(t)·κ_p(t): positive where the envelope of the generating pins is regular."""
        R, e, zb = self.par[K.P_R], self.par[K.P_E], self.par[K.P_ZB]
        ei, eb = np.exp(1j * ts), np.exp(1j * zb * ts)
        v = 1j * (R * ei - zb * e * eb)
        a = -(R * ei) + zb * zb * e * eb
        kappa = (v.conj() * a).imag / np.abs(v) ** 3
        r = np.empty(ts.shape)
        K.radii(np.ascontiguousarray(ts, dtype=float), self.par, self.herr, r)
        return 1.0 - r * kappa


class CurveKey:
    """A profile as a cache key: equal when its tooth count and kernel inputs (``par``, ``herr``,
    ``hpsi``: all the curve depends on) are equal."""

    __slots__ = ("key", "profile")

    def __init__(self, profile: CycloidProfile):
        self.profile = profile
        self.key = (profile.stage.disc_teeth, profile.par.tobytes(), profile.herr.tobytes(), profile.hpsi.tobytes())

    def __hash__(self) -> int:
        return hash(self.key)

    def __eq__(self, other) -> bool:
        return isinstance(other, CurveKey) and self.key == other.key


@functools.lru_cache(maxsize=64)
def _defect(curve: CurveKey) -> tuple[str, float, float] | None:
    # a pure function of the curve, kept per process (it is 60 % of a rigid model build: the disc's
    # profiles are checked four times a build, with nothing changed between a diagnosis's runs)
    return curve.profile._defect()


def _minimise(f, a: float, b: float) -> float:
    from scipy.optimize import minimize_scalar

    return float(minimize_scalar(f, bounds=(a, b), method="bounded", options={"xatol": 1e-12}).fun)


def _mod_repr(stage: CycloidStage) -> str:
    m = stage.modification
    return (f"moved {m.moved_m * 1e6:g} µm, equidistant {m.equidistant_m * 1e6:g} µm, tip {m.tip_amount_m * 1e6:g} µm,"
            f" root {m.root_amount_m * 1e6:g} µm, compensation {m.compensation_m * 1e6:g} µm"
            f" (pin radius {stage.pin_radius_m * 1e3:g} mm)")


def harmonics_from_teeth(values: np.ndarray, zc: int) -> np.ndarray:
    """Trigonometric interpolant through one value per tooth (at the tooth tips).

    Returns a (M + 1, 2) table of cos/sin coefficients of k·t, k = 0..M, such that
    Σ a_k cos(k t_j) + b_k sin(k t_j) = values[j] at t_j = (2j + 1)π/z_c, smooth in between.
    """
    values = np.asarray(values, float)
    if values.size == 0 or not np.any(values):
        return K.empty_harmonics()
    tj = (2 * np.arange(zc) + 1) * np.pi / zc
    m = zc // 2
    cols, keys = [], []
    for k in range(m + 1):
        cols.append(np.cos(k * tj))
        keys.append((k, 0))
        if k > 0:
            cols.append(np.sin(k * tj))
            keys.append((k, 1))
    A = np.column_stack(cols)
    if zc % 2 == 0:  # cos(z_c/2·t_j) vanishes at the tips: drop that column to keep the system square
        drop = keys.index((m, 0))
        A = np.delete(A, drop, axis=1)
        keys.pop(drop)
    coef = np.linalg.solve(A, values)
    table = np.zeros((m + 1, 2))
    for (k, j), c in zip(keys, coef):
        table[k, j] = c
    return table


def _zone_bounds(stage: CycloidStage, base: CycloidProfile) -> tuple[float, float]:
    """Tooth phases u where the base profile's pressure angle reaches the zone thresholds."""
    m = stage.modification
    zc = stage.disc_teeth
    us = np.linspace(1e-6, np.pi - 1e-6, 4001)
    alpha = base.pressure_angle(us / zc)
    k = int(np.argmin(alpha))
    u_min, a_min = us[k], alpha[k]

    def alpha_at(u: float) -> float:
        return float(base.pressure_angle(np.array([u / zc]))[0])

    u_tip, u_root = np.pi, 0.0
    if m.tip_amount_m:
        if m.tip_pressure_angle_rad <= a_min:
            raise SpecError("cycloid.modification.tip_pressure_angle_rad", m.tip_pressure_angle_rad,
                            f"must exceed the profile's minimum pressure angle {math.degrees(a_min):.2f}°")
        u_tip = brentq(lambda u: alpha_at(u) - m.tip_pressure_angle_rad, u_min, np.pi - 1e-9, xtol=1e-14)
    if m.root_amount_m:
        if m.root_pressure_angle_rad <= a_min:
            raise SpecError("cycloid.modification.root_pressure_angle_rad", m.root_pressure_angle_rad,
                            f"must exceed the profile's minimum pressure angle {math.degrees(a_min):.2f}°")
        u_root = brentq(lambda u: alpha_at(u) - m.root_pressure_angle_rad, 1e-9, u_min, xtol=1e-14)
    return u_tip, u_root


def build_profile(stage: CycloidStage, errors: ErrorSpec | None = None, disc: int = 0, *,
                  modified: bool = True, check: bool = True) -> CycloidProfile:
    """Build the exact profile of disc ``disc`` of ``stage``.

    Parameters
    ----------
    stage : CycloidStage
        Cycloid stage geometry and modification.
    errors : ErrorSpec, optional
        Disc errors used: ``disc_moved_error_m``, ``disc_equidistant_error_m``,
        ``disc_profile_error_m`` and ``disc_pitch_error_m`` of this disc.
    disc : int
        Disc index (0-based).
    modified : bool
        False gives the theoretical (unmodified, error-free) profile.
    check : bool
        Refuse self-intersecting profiles (:meth:`CycloidProfile.check`).
    """
    m = stage.modification
    zc, zb = stage.disc_teeth, stage.pin_count
    moved = m.moved_m if modified else 0.0
    equi = m.equidistant_m if modified else 0.0
    herr = hpsi = K.empty_harmonics()
    if modified and errors is not None:
        if errors.disc_moved_error_m:
            moved += errors.disc_moved_error_m[disc]
        if errors.disc_equidistant_error_m:
            equi += errors.disc_equidistant_error_m[disc]
        if errors.disc_profile_error_m:
            herr = harmonics_from_teeth(errors.disc_profile_error_m[disc], zc)
        if errors.disc_pitch_error_m:
            hpsi = harmonics_from_teeth(np.asarray(errors.disc_pitch_error_m[disc]) / stage.pin_circle_radius_m, zc)
    par = np.zeros(K.N_PAR)
    par[K.P_R] = stage.pin_circle_radius_m + moved
    par[K.P_E] = stage.eccentricity_m
    par[K.P_ZB] = zb
    par[K.P_ZC] = zc
    par[K.P_R0] = stage.pin_radius_m + equi
    par[K.P_K] = stage.k1
    par[K.P_W] = COMPENSATION_SMOOTHING_RAD
    par[K.P_TIP_U] = np.pi
    base = CycloidProfile(stage, par.copy(), herr, hpsi)
    if modified and (m.tip_amount_m or m.root_amount_m):
        u_tip, u_root = _zone_bounds(stage, base)
        par[K.P_TIP_U], par[K.P_TIP_A] = u_tip, m.tip_amount_m
        par[K.P_ROOT_U], par[K.P_ROOT_A] = u_root, m.root_amount_m
    if modified:
        par[K.P_COMP] = m.compensation_m
    prof = CycloidProfile(stage, par, herr, hpsi)
    if check:
        prof.check()
    return prof


def check_stage(stage: CycloidStage) -> None:
    """Validate that the stage's theoretical and modified profiles are simple closed curves."""
    build_profile(stage, modified=False, check=False).check(field="cycloid.pin_radius_m")
    build_profile(stage, modified=True, check=True)

"""Quasi-static model of a preloaded pair of angular-contact ball rows carrying a rigid body.

The output carrier is a rigid body on the two rows of the main bearing pair; the outer rings
are fixed (housing). Loads on the carrier: a force (F_x, F_y, F_z) at the pair's centre (the
middle plane between the rows, on the axis) and a tilting moment (M_x, M_y). Unknowns: the
carrier's displacement q = (δ_x, δ_y, δ_z, θ_x, θ_y); its turn about the axis is the gear
train's business, not the bearing's.

The model is the rigid-ring quasi-static model of Jones and Harris (Harris & Kotzalas, *Rolling
Bearing Analysis*, 5-DOF form, speed effects left out: a reducer's output turns at tens of rpm,
so centrifugal and gyroscopic ball loads are negligible). For every ball j the centres of
curvature of its inner and outer grooves are A = (f_i + f_o − 1)·D apart when the ball just
touches both; the line through them is the contact line at the nominal contact angle α₀. The
carrier carries the inner centres (small rotations, p ↦ p + δ + θ × p), the housing the outer
ones. With v_j the vector from the inner to the outer centre, the ball is squeezed by
δ_j = |v_j| − A and carries the Hertz point-contact load Q_j = K·max(δ_j, 0)^1.5 (K from the
ball's inner and outer contacts in series, exact elliptic-integral Hertz theory); the load acts
along v_j, so the contact angle follows the load. The preload is an axial shift of each row's
inner raceway that makes the row carry ``preload_N`` with no external load.

Equilibrium minimises the potential Π(q) = Σ_j (2/5)·K·max(δ_j, 0)^2.5 − f·q: each δ_j is a
convex function of q (the norm of an affine map) and the contact potential a convex,
non-decreasing function of δ_j, so Π is convex and a Newton iteration with a line search on Π
converges from any start (the Hessian is the symmetric tangent stiffness of the pair). Every
ball is evaluated in one numba call (:func:`pair_kernel`): no Python runs per ball. The same kernel is the
force and Jacobian of the pair's Exudyn element (:func:`rvflex.parts.main_bearing.add_pair_element`), so the
solver here and a multibody model share one law.

Contact laws (:data:`LAWS`): ``"hertz"`` (the bearing); ``"linear"`` (Q = k·max(δ, 0), the
closed-form checks and the Exudyn cross-check of :mod:`rvflex.parts.main_bearing`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numba as nb
import numpy as np
from scipy import optimize, special

from rvflex.spec import AngularContactPair, SpecError

__all__ = [
    "LAWS",
    "LAW_CODES",
    "HertzPointContact",
    "PairLoad",
    "PairModel",
    "PairState",
    "hertz_point_contact",
    "ball_raceway_contacts",
    "pair_kernel",
    "pair_model",
    "solve",
]

LAWS = ("hertz", "linear")
Law = Literal["hertz", "linear"]
LAW_CODES = {"hertz": 0, "linear": 1}
"""The laws' codes in :func:`pair_kernel`."""

_DOF = 5  # δx, δy, δz, θx, θy
_jit = nb.njit(cache=True, nogil=True)


# --------------------------------------------------------------------------- Hertz point contact


@dataclass(frozen=True)
class HertzPointContact:
    """Load–deflection constants of one elliptical Hertz contact: Q = stiffness·δ^1.5.

    Parameters
    ----------
    stiffness_N_m1p5 : float
        K in Q = K·δ^1.5, N/m^1.5.
    ellipticity : float
        κ = a/b, semi-major over semi-minor axis of the contact ellipse (–).
    a_star, b_star, delta_star : float
        Hamrock–Harris dimensionless semi-axes and deflection (–).
    curvature_sum_1_m : float
        Σρ, sum of the principal curvatures of both bodies, 1/m.
    compliance_1_Pa : float
        η = (1 − ν₁²)/E₁ + (1 − ν₂²)/E₂, 1/Pa.
    """

    stiffness_N_m1p5: float
    ellipticity: float
    a_star: float
    b_star: float
    delta_star: float
    curvature_sum_1_m: float
    compliance_1_Pa: float

    def semi_axes_m(self, load_N):
        """Semi-axes (a, b) of the contact ellipse under ``load_N`` (N; float or array), m."""
        c = np.cbrt(3.0 * np.asarray(load_N, dtype=float) * self.compliance_1_Pa / (2.0 * self.curvature_sum_1_m))
        return self.a_star * c, self.b_star * c

    def peak_pressure_Pa(self, load_N):
        """Peak contact pressure 3Q/(2πab) under ``load_N`` (N; float or array), Pa."""
        q = np.asarray(load_N, dtype=float)
        a, b = self.semi_axes_m(q)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(q > 0.0, 1.5 * q / (np.pi * a * b), 0.0)


def hertz_point_contact(rho: tuple[float, float, float, float], youngs_modulus_Pa: float,
                        poisson_ratio: float) -> HertzPointContact:
    """Hertz constants of two bodies of one material touching at a point.

    Parameters
    ----------
    rho : tuple of float
        Principal curvatures (ρ_1I, ρ_1II, ρ_2I, ρ_2II), 1/m: body 1 then body 2, plane I then
        plane II (concave negative).
    youngs_modulus_Pa : float
        Young's modulus of both bodies, Pa.
    poisson_ratio : float
        Poisson's ratio of both bodies (–).

    Returns
    -------
    HertzPointContact
        The contact's constants.
    """
    r1i, r1ii, r2i, r2ii = rho
    sum_rho = r1i + r1ii + r2i + r2ii
    f_rho = abs((r1i - r1ii) + (r2i - r2ii)) / sum_rho
    eta = 2.0 * (1.0 - poisson_ratio**2) / youngs_modulus_Pa

    def ellipticity_residual(kappa: float) -> float:
        m = 1.0 - 1.0 / kappa**2
        e, k = special.ellipe(m), special.ellipk(m)
        return ((kappa**2 + 1.0) * e - 2.0 * k) / ((kappa**2 - 1.0) * e) - f_rho

    if f_rho < 1e-12:  # sphere on sphere or plane: a circle
        kappa, ek, kk = 1.0, math.pi / 2, math.pi / 2
    else:
        kappa = optimize.brentq(ellipticity_residual, 1.0 + 1e-12, 1e4, xtol=1e-14, rtol=1e-14)
        m = 1.0 - 1.0 / kappa**2
        ek, kk = float(special.ellipe(m)), float(special.ellipk(m))
    a_star = (2.0 * kappa**2 * ek / math.pi) ** (1.0 / 3.0)
    b_star = (2.0 * ek / (math.pi * kappa)) ** (1.0 / 3.0)
    delta_star = 2.0 * kk / math.pi * (math.pi / (2.0 * kappa**2 * ek)) ** (1.0 / 3.0)
    # δ = δ*·(Σρ/2)·(3Qη/(2Σρ))^(2/3)  ⇒  Q = K·δ^1.5
    c = delta_star * sum_rho / 2.0 * (3.0 * eta / (2.0 * sum_rho)) ** (2.0 / 3.0)
    return HertzPointContact(c**-1.5, kappa, a_star, b_star, delta_star, sum_rho, eta)


def ball_raceway_contacts(pair: AngularContactPair) -> tuple[HertzPointContact, HertzPointContact]:
    """Hertz constants of a ball on its inner and on its outer raceway at the nominal contact angle.

    Parameters
    ----------
    pair : AngularContactPair
        The bearing pair.

    Returns
    -------
    tuple of HertzPointContact
        (inner, outer).
    """
    d, dm = pair.ball_diameter_m, pair.pitch_diameter_m
    gamma = d * math.cos(pair.contact_angle_rad) / dm
    ball = 2.0 / d
    inner = (ball, ball, ball * gamma / (1.0 - gamma), -1.0 / (pair.inner_conformity * d))
    outer = (ball, ball, -ball * gamma / (1.0 + gamma), -1.0 / (pair.outer_conformity * d))
    e, nu = pair.material.youngs_modulus_Pa, pair.material.poisson_ratio
    return hertz_point_contact(inner, e, nu), hertz_point_contact(outer, e, nu)


# --------------------------------------------------------------------------- the pair


@dataclass(frozen=True)
class PairModel:
    """Per-ball geometry and contact law of a preloaded pair, ready to solve (:func:`pair_model`).

    Parameters
    ----------
    pair : AngularContactPair
        The bearing pair it models.
    law : str
        ``"hertz"`` or ``"linear"``.
    stiffness : float
        Ball stiffness: K of Q = K·δ^1.5 (N/m^1.5) for ``"hertz"``, k of Q = k·δ (N/m) for ``"linear"``.
    centre_distance_m : float
        A = (f_i + f_o − 1)·D, the unloaded distance of the groove centres, m.
    inner_centres_m : numpy.ndarray
        (n, 3) positions of the inner groove centres on the carrier, preload shift included, m.
    outer_centres_m : numpy.ndarray
        (n, 3) positions of the outer groove centres on the housing, m.
    row : numpy.ndarray
        (n,) row of each ball (0: z < 0, 1: z > 0).
    azimuth_rad : numpy.ndarray
        (n,) angle of each ball about the axis, rad.
    preload_shift_m : float
        Axial shift of each row's inner raceway that makes the preload, m.
    inner, outer : HertzPointContact
        Hertz constants of the inner and outer ball contacts.
    """

    pair: AngularContactPair
    law: str
    stiffness: float
    centre_distance_m: float
    inner_centres_m: np.ndarray
    outer_centres_m: np.ndarray
    row: np.ndarray
    azimuth_rad: np.ndarray
    preload_shift_m: float
    inner: HertzPointContact
    outer: HertzPointContact

    @property
    def n_balls(self) -> int:
        """Balls in both rows (count)."""
        return len(self.row)

    @property
    def law_code(self) -> int:
        """The law's code in :func:`pair_kernel` (:data:`LAW_CODES`)."""
        return LAW_CODES[self.law]

    def ball_load_N(self, squeeze_m):
        """Ball load Q (N) of a squeeze δ = |v| − A (m; array), zero where the ball is free."""
        return _ball_laws(self.law_code, self.stiffness, squeeze_m)[0]

    def ball_stiffness_N_m(self, squeeze_m):
        """dQ/dδ (N/m) at a squeeze δ (m; array)."""
        return _ball_laws(self.law_code, self.stiffness, squeeze_m)[1]

    def jacobians(self) -> np.ndarray:
        """(n, 3, 5) maps of q = (δx, δy, δz, θx, θy) to each inner centre's displacement δ + θ × p (m per m or rad)."""
        p = self.inner_centres_m
        jac = np.zeros((self.n_balls, 3, _DOF))
        jac[:, 0, 0] = jac[:, 1, 1] = jac[:, 2, 2] = 1.0
        # θ × p with θ = (θx, θy, 0): (θy·pz, −θx·pz, θx·py − θy·px)
        jac[:, 0, 4] = p[:, 2]
        jac[:, 1, 3] = -p[:, 2]
        jac[:, 2, 3] = p[:, 1]
        jac[:, 2, 4] = -p[:, 0]
        return jac


@_jit
def _ball_law(law_code, stiffness, squeeze):
    """Energy (J), load Q (N) and dQ/dδ (N/m) of one ball at a squeeze δ (m): Hertz (code 0)
    (2/5)Kδ^2.5, Kδ^1.5, 1.5Kδ^0.5, or linear (code 1) kδ²/2, kδ, k; all zero while the ball is free (δ ≤ 0)."""
    if squeeze <= 0.0:
        return 0.0, 0.0, 0.0
    if law_code == 0:
        root = math.sqrt(squeeze)
        return 0.4 * stiffness * squeeze * squeeze * root, stiffness * squeeze * root, 1.5 * stiffness * root
    return 0.5 * stiffness * squeeze * squeeze, stiffness * squeeze, stiffness


@_jit
def _ball_laws_into(law_code, stiffness, squeeze, load, kt):
    """:func:`_ball_law`'s load and dQ/dδ at every squeeze of the flat array ``squeeze``, into ``load`` and ``kt``."""
    for j in range(squeeze.shape[0]):
        _, load[j], kt[j] = _ball_law(law_code, stiffness, squeeze[j])


def _ball_laws(law_code: int, stiffness: float, squeeze_m):
    """Load (N) and dQ/dδ (N/m) of the law (:func:`_ball_law`) at squeezes (m; scalar or array, shape kept)."""
    sq = np.asarray(squeeze_m, dtype=float)
    flat = np.ascontiguousarray(sq.ravel())
    load, kt = np.empty_like(flat), np.empty_like(flat)
    _ball_laws_into(law_code, float(stiffness), flat, load, kt)
    return load.reshape(sq.shape), kt.reshape(sq.shape)


@_jit
def pair_kernel(q, inner, outer, centre_distance, stiffness, law_code, force, kmat, load, unit, squeeze):
    """Contact forces and tangent stiffness of every ball of the pair at the carrier's displacement ``q``.

    The carrier moves each inner groove centre p to p + δ + θ × p, θ = (θx, θy, 0) (small rotations, as
    :func:`solve`); ball j's groove centres are v = outer − (p + δ + θ × p) apart and it is squeezed by
    |v| − A. Its load Q acts on the carrier along v̂, so with J_j = ∂(δ + θ × p)/∂q the generalized force is
    f = Σ_j Q_j J_jᵀ v̂_j and the stiffness −∂f/∂q = Σ_j (dQ/dδ − Q/|v|) J_jᵀ v̂ v̂ᵀ J_j + (Q/|v|) J_jᵀ J_j,
    the Hessian of the contact potential: symmetric.

    Parameters
    ----------
    q : numpy.ndarray
        (5,) the carrier's (δx, δy, δz, θx, θy), m and rad.
    inner, outer : numpy.ndarray
        (n, 3) inner groove centres on the carrier (preload shift included) and outer ones on the housing, m.
    centre_distance : float
        A, the groove centres' distance where a ball just touches both, m.
    stiffness : float
        K of Q = K·δ^1.5 (N/m^1.5, Hertz) or k of Q = k·δ (N/m, linear).
    law_code : int
        :data:`LAW_CODES`: 0 Hertz, 1 linear.
    force : numpy.ndarray
        (5,) out: generalized contact force on the carrier (N, N·m), conjugate to q.
    kmat : numpy.ndarray
        (5, 5) out: −∂force/∂q (N/m, N, N·m/rad).
    load, unit, squeeze : numpy.ndarray
        (n,), (n, 3), (n,) out: each ball's load (N), v̂ and squeeze (m).

    Returns
    -------
    float
        The contact potential Σ_j ∫Q dδ, J.
    """
    force[:] = 0.0
    kmat[:, :] = 0.0
    energy = 0.0
    ju = np.empty(5)
    for j in range(inner.shape[0]):
        px, py, pz = inner[j, 0], inner[j, 1], inner[j, 2]
        # inner centre moved by δ + θ × p, θ × p = (θy·pz, −θx·pz, θx·py − θy·px); the unloaded gap (outer − p,
        # ~0.1 mm) first, then the µm motion: the squeeze |v| − A keeps the precision the geometry has
        vx = (outer[j, 0] - px) - (q[0] + q[4] * pz)
        vy = (outer[j, 1] - py) - (q[1] - q[3] * pz)
        vz = (outer[j, 2] - pz) - (q[2] + q[3] * py - q[4] * px)
        length = math.sqrt(vx * vx + vy * vy + vz * vz)
        ux, uy, uz = vx / length, vy / length, vz / length
        unit[j, 0], unit[j, 1], unit[j, 2] = ux, uy, uz
        squeeze[j] = length - centre_distance
        e, qj, kt = _ball_law(law_code, stiffness, squeeze[j])
        load[j] = qj
        if qj == 0.0 and kt == 0.0:
            continue
        energy += e
        # J_jᵀ v̂: columns of J are e_x, e_y, e_z, ∂/∂θx = (0, −pz, py), ∂/∂θy = (pz, 0, −px)
        ju[0], ju[1], ju[2] = ux, uy, uz
        ju[3] = -uy * pz + uz * py
        ju[4] = ux * pz - uz * px
        geo = qj / length  # the loaded ball's lateral (geometric) stiffness
        for a in range(5):
            force[a] += qj * ju[a]
            for b in range(5):
                kmat[a, b] += (kt - geo) * ju[a] * ju[b]
        # + geo·J_jᵀJ_j
        kmat[0, 0] += geo
        kmat[1, 1] += geo
        kmat[2, 2] += geo
        kmat[0, 4] += geo * pz
        kmat[4, 0] += geo * pz
        kmat[1, 3] -= geo * pz
        kmat[3, 1] -= geo * pz
        kmat[2, 3] += geo * py
        kmat[3, 2] += geo * py
        kmat[2, 4] -= geo * px
        kmat[4, 2] -= geo * px
        kmat[3, 3] += geo * (pz * pz + py * py)
        kmat[4, 4] += geo * (pz * pz + px * px)
        kmat[3, 4] -= geo * py * px
        kmat[4, 3] -= geo * py * px
    return energy


def _row_geometry(pair: AngularContactPair, row_sign: float) -> tuple[np.ndarray, np.ndarray]:
    """The unit vector from the inner to the outer groove centre ((e_r, e_z) parts) and the inner
    centre's (r, z), for the row on the ``row_sign`` side of the middle plane; unloaded, no preload."""
    alpha, d = pair.contact_angle_rad, pair.ball_diameter_m
    # back-to-back (O): the contact line runs from the outer race towards the axis and away
    # from the middle plane; face-to-face (X): towards the middle plane
    s = row_sign if pair.arrangement == "back_to_back" else -row_sign
    u_in = np.array([-math.cos(alpha), s * math.sin(alpha)])  # from ball centre to the inner contact
    ball_centre = np.array([pair.pitch_diameter_m / 2.0, row_sign * pair.row_spacing_m / 2.0])
    return u_in, ball_centre - (pair.inner_conformity - 0.5) * d * u_in


def pair_model(pair: AngularContactPair, *, law: Law = "hertz", linear_stiffness_N_m: float | None = None) -> PairModel:
    """The solvable model of ``pair``: ball geometry, contact law and the preload shift.

    Parameters
    ----------
    pair : AngularContactPair
        The bearing pair.
    law : {"hertz", "linear"}, optional
        Ball load law; ``"linear"`` needs ``linear_stiffness_N_m``.
    linear_stiffness_N_m : float, optional
        k of the linear law Q = k·δ, N/m.

    Returns
    -------
    PairModel
        Ready for :func:`solve`.

    Raises
    ------
    SpecError
        An unknown law, or a linear law without a positive stiffness.
    """
    if law not in LAWS:
        raise SpecError("law", law, f"must be one of {', '.join(LAWS)}")
    inner, outer = ball_raceway_contacts(pair)
    if law == "hertz":
        k = (inner.stiffness_N_m1p5 ** (-2.0 / 3.0) + outer.stiffness_N_m1p5 ** (-2.0 / 3.0)) ** -1.5
    else:
        if linear_stiffness_N_m is None or not linear_stiffness_N_m > 0:
            raise SpecError("linear_stiffness_N_m", linear_stiffness_N_m, "the linear law needs a stiffness > 0 N/m")
        k = float(linear_stiffness_N_m)
    z = pair.balls_per_row
    psi = 2.0 * np.pi * np.arange(z) / z
    cos, sin = np.cos(psi), np.sin(psi)
    inner_c, outer_c, rows = [], [], []
    a = (pair.inner_conformity + pair.outer_conformity - 1.0) * pair.ball_diameter_m
    # preload: the row's inner raceway shifted axially by h against its contact lines; the
    # row then carries Z·Q·sin α' = preload, α' the preloaded contact angle
    ar, az = a * math.cos(pair.contact_angle_rad), a * math.sin(pair.contact_angle_rad)

    def row_axial(h: float) -> float:
        length = math.hypot(ar, az + h)
        return z * _ball_law(LAW_CODES[law], k, length - a)[1] * (az + h) / length - pair.preload_N

    h = 0.0 if pair.preload_N == 0.0 else optimize.brentq(row_axial, 0.0, a, xtol=1e-16, rtol=1e-15)
    for row, sign in ((0, -1.0), (1, 1.0)):
        u_in, c_in = _row_geometry(pair, sign)
        v_rz = a * u_in  # inner → outer groove centre, (e_r, e_z) parts
        r_in, z_in = c_in
        # the shift moves the inner centre against the contact line's axial direction
        z_pre = z_in - math.copysign(h, u_in[1])
        inner_c.append(np.column_stack([r_in * cos, r_in * sin, np.full(z, z_pre)]))
        outer_c.append(np.column_stack([(r_in + v_rz[0]) * cos, (r_in + v_rz[0]) * sin, np.full(z, z_in + v_rz[1])]))
        rows.append(np.full(z, row))
    return PairModel(pair, law, k, a, np.vstack(inner_c), np.vstack(outer_c), np.concatenate(rows),
                     np.concatenate([psi, psi]), h, inner, outer)


# --------------------------------------------------------------------------- loads and solution


@dataclass(frozen=True)
class PairLoad:
    """External load on the carrier, at the pair's centre (middle plane, on the axis).

    Parameters
    ----------
    force_N : tuple of float
        (F_x, F_y, F_z), N; F_z along the reducer axis.
    moment_Nm : tuple of float
        Tilting moment (M_x, M_y), N·m.
    """

    force_N: tuple[float, float, float] = (0.0, 0.0, 0.0)
    moment_Nm: tuple[float, float] = (0.0, 0.0)

    def vector(self) -> np.ndarray:
        """The generalized force (F_x, F_y, F_z, M_x, M_y) conjugate to q (N, N·m)."""
        return np.array([*self.force_N, *self.moment_Nm], dtype=float)


@dataclass(frozen=True)
class PairState:
    """Static equilibrium of the carrier on the pair (:func:`solve`).

    Parameters
    ----------
    q : numpy.ndarray
        (δx, δy, δz, θx, θy): displacement (m) and tilt (rad) of the carrier.
    ball_load_N : numpy.ndarray
        Load of each ball, N (0: out of contact).
    contact_angle_rad : numpy.ndarray
        Loaded contact angle of each ball, rad.
    peak_pressure_Pa : numpy.ndarray
        Peak Hertz pressure of each ball, the larger of its inner and outer contact, Pa.
    stiffness : numpy.ndarray
        (5, 5) tangent stiffness of the pair at this state (N/m, N/rad, N·m/rad).
    squeeze_m : numpy.ndarray
        Squeeze δ = |v| − A of each ball, m (negative: the ball is free by that much).
    iterations : int
        Newton iterations taken (count).
    """

    q: np.ndarray
    ball_load_N: np.ndarray
    contact_angle_rad: np.ndarray
    peak_pressure_Pa: np.ndarray
    stiffness: np.ndarray
    squeeze_m: np.ndarray
    iterations: int

    @property
    def tilt_rad(self) -> float:
        """Magnitude of the carrier's tilt, |(θx, θy)|, rad."""
        return float(math.hypot(self.q[3], self.q[4]))

    @property
    def balls_in_contact(self) -> int:
        """Balls carrying load (count)."""
        return int(np.count_nonzero(self.ball_load_N > 0.0))

    def tilt_stiffness_Nm_rad(self) -> float:
        """Tangent stiffness against a moment about x, the others free: 1/(K⁻¹)_θxθx, N·m/rad."""
        return float(1.0 / np.linalg.inv(self.stiffness)[3, 3])


def _evaluate(model: PairModel, q: np.ndarray):
    """Potential, gradient and Hessian of the contact part of Π at q, with per-ball data (:func:`pair_kernel`)."""
    n = model.n_balls
    force, hess = np.empty(_DOF), np.empty((_DOF, _DOF))
    load, unit, squeeze = np.empty(n), np.empty((n, 3)), np.empty(n)
    energy = pair_kernel(np.asarray(q, dtype=float), model.inner_centres_m, model.outer_centres_m,
                         model.centre_distance_m, model.stiffness, model.law_code, force, hess, load, unit, squeeze)
    return energy, -force, hess, load, unit, squeeze


def solve(model: PairModel, load: PairLoad, *, start: np.ndarray | None = None, tol_m: float = 1e-12,
          max_iterations: int = 200) -> PairState:
    """Static equilibrium of the carrier under ``load``.

    Newton's method on the convex potential Π with a backtracking line search (Armijo), unknowns
    scaled so one unit is 1 µm at the balls; converged when the step moves no ball centre by more
    than ``tol_m``.

    Parameters
    ----------
    model : PairModel
        From :func:`pair_model`.
    load : PairLoad
        External load at the pair's centre.
    start : numpy.ndarray, optional
        Starting q (e.g. the previous step of a load sweep); default zero.
    tol_m : float, optional
        Convergence tolerance on the displacement of any ball centre, m.
    max_iterations : int, optional
        Newton iterations before giving up (count).

    Returns
    -------
    PairState
        The equilibrium.

    Raises
    ------
    RuntimeError
        No convergence within ``max_iterations``.
    """
    reach = 0.5 * model.pair.pitch_diameter_m
    scale = np.array([1e-6, 1e-6, 1e-6, 1e-6 / reach, 1e-6 / reach])  # one unit: 1 µm at the balls
    f = load.vector()
    q = np.zeros(_DOF) if start is None else np.asarray(start, dtype=float).copy()
    energy, grad, hess, _, _, _ = _evaluate(model, q)
    ref = float(np.abs(np.diag(hess) * scale**2).max())
    if ref == 0.0:  # no preload, start at zero: every ball just touches and nothing is stiff yet
        ref = float(model.ball_stiffness_N_m(np.array([1e-6]))[0] * model.n_balls * 1e-12)
    iterations = 0
    while iterations < max_iterations:
        iterations += 1
        g = (grad - f) * scale
        h = hess * np.outer(scale, scale)
        # a tiny Levenberg shift keeps the step defined while balls are unloaded (Hertz has no
        # stiffness at first touch); the line search on the exact Π keeps the fixed point exact
        step = -np.linalg.solve(h + 1e-10 * ref * np.eye(_DOF), g)
        pi0 = energy - f @ q
        t = 1.0
        while True:
            trial = q + t * step * scale
            e_t, g_t, h_t, _, _, _ = _evaluate(model, trial)
            if e_t - f @ trial <= pi0 + 1e-4 * t * (g @ step):
                break
            t *= 0.5
            if t < 1e-12:  # Π cannot tell the points apart: floating-point floor
                break
        if t < 1e-12:
            if np.abs(step).max() * 1e-6 < 1e3 * tol_m:  # at the floor and as close as it resolves
                break
            raise RuntimeError(f"main bearing pair: the line search stalled {np.abs(step).max():.3g} µm from "
                               f"equilibrium (load {f.tolist()})")
        q, energy, grad, hess = trial, e_t, g_t, h_t
        if np.abs(step).max() * 1e-6 < tol_m:  # the full Newton step, not a damped one, is below tol
            break
    else:  # noqa: PLW0120 -- the loop ends by break when converged
        raise RuntimeError(f"main bearing pair: no equilibrium after {max_iterations} Newton iterations "
                           f"(load {f.tolist()})")
    _, grad, hess, ball_load, unit, squeeze = _evaluate(model, q)
    p_in = model.inner.peak_pressure_Pa(ball_load)
    p_out = model.outer.peak_pressure_Pa(ball_load)
    angle = np.arcsin(np.clip(np.abs(unit[:, 2]), 0.0, 1.0))
    return PairState(q, ball_load, angle, np.maximum(p_in, p_out), hess, squeeze, iterations)

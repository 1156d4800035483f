"""Involute sun–planet mesh of the first (involute) stage as one Exudyn force element.

The mesh acts between two planar rigid nodes (``NodeRigidBody2D``: x, y, θ in the xy plane,
z the reducer axis, θ positive counter-clockwise): the sun on the input shaft and one
planet (crank). It is one ``ObjectGenericODE2`` on the nodes [sun, planet] whose force and
Jacobian user functions call a numba kernel (no Python loop per contact, a few µs a call).

Kinematics (exact for involute flanks, any centre positions)
-------------------------------------------------------------
Base radii r_bs = m·z_s·cos α/2, r_bp = m·z_p·cos α/2, r_B = r_bs + r_bp; α is the
standard pressure angle at the standard centre distance a_0 = m(z_s + z_p)/2.
c_s, c_p are the centres of the base circles (node position plus the eccentricity/runout
offsets, which turn with their gear), d = c_p − c_s, a = |d|, γ = arg d (centre-line
angle, tracked continuously over any number of carrier turns) and α' the operating
pressure angle, cos α' = r_B/a.

An involute crosses its line of action at a distance from the base tangent point equal to
the unwound base arc, so the overlap (interference) of the two flanks along the line of
action is, for the drive flank (+, loaded when the sun drives counter-clockwise) and the
coast flank (−)::

    g± = ±δ + ρ − b/2
    δ  = r_bs·(θ_s − γ) + r_bp·(θ_p − γ) − [same at the reference configuration]
    ρ  = −r_B·(inv α' − inv α) + (Δr_s + Δr_p)·sin α,      inv x = tan x − x

δ is the transmission deflection along the line of action (positive when the sun is ahead
of the planet: a positive, i.e. counter-clockwise, sun torque loads the drive flank);
rotations enter relative to the centre line, so turning the carrier with locked gears
leaves δ unchanged. ρ is the radial approach: ∂ρ/∂a = −sin α', i.e. pulling the gears
apart by Δa opens each flank by Δa·sin α'. ``stage.backlash_m`` is the circumferential
backlash j_t at the pitch circle (as in seed 002's ε); the normal backlash along the line of
action is b = j_t·cos α at a = a_0, so with the planet locked the sun turns through
b/r_bs = j_t/r_s (r_s the sun's pitch radius). The reference configuration of the two nodes is the centred mesh (δ = 0).

Drive line of action: n₊ = (cos(γ + π/2 − α'), sin(γ + π/2 − α')), the force on the planet
points along n₊, the reaction on the sun along −n₊; coast: n₋ = (cos(γ − π/2 + α'), ...).

Errors (``ErrorSpec``), all exact geometry; first-order effect on the flank overlaps
-------------------------------------------------------------------------------------
* Sun base-circle eccentricity ε_s at phase φ_εs and sun assembly runout ρ_s at phase φ_ρs:
  the sun's base circle centre sits at ε_s·e^{i(θ_s+φ_εs)} + ρ_s·e^{i(θ_s+φ_ρs)} from the
  node (phases in the gear's body frame from its x axis). Runout is taken as the radius of
  this once-per-revolution offset (half a dial-indicator TIR reading).
* Planet base-circle eccentricity ε_p (phase φ_εp) and runout ρ_p (no phase field in
  ``ErrorSpec``: along the planet's body x axis), entry ``planet_index`` of the tuples.
* To first order these add e± to g±, once per revolution of their gear::

      e₊ =  ε_s·sin(θ_s + φ_εs − γ + α) + ρ_s·sin(θ_s + φ_ρs − γ + α)
          − ε_p·sin(θ_p + φ_εp − γ + α) − ρ_p·sin(θ_p − γ + α)
      e₋ = −ε_s·sin(θ_s + φ_εs − γ − α) − ρ_s·sin(θ_s + φ_ρs − γ − α)
          + ε_p·sin(θ_p + φ_εp − γ − α) + ρ_p·sin(θ_p − γ − α)

  i.e. the offset vector projected on the line of action: full amplitude ε on the loaded
  flank, ε·sin α when the offset points along the centre line. With the planet locked under
  a positive sun torque the sun angle carries the transmission error −e₊/r_bs.
* Pitch-radius errors Δr_s, Δr_p (positive = larger gear) act as tooth-thickness changes,
  like a profile shift: each flank stands proud by Δr·sin α, so both overlaps grow by
  (Δr_s + Δr_p)·sin α (backlash shrinks by twice that; a constant mesh shift under load).
* Input-shaft angle error a at phase ψ (``input_shaft_angle_error_rad``): the sun's teeth stand at
  θ_s + a·cos(θ_s − ψ) while its node (the input as driven and read) is at θ_s, as when the input
  shaft runs off-centre to the motor or an off-centre input encoder reads it. It moves every
  planet's flanks alike, by r_bs·a·cos(θ_s − ψ) along the line of action, so unlike a radial
  offset of the sun (whose projections on the planets' lines of action sum to zero) it turns the
  output: TE a/i·cos(θ_in − ψ), once per input revolution.
* Base-pitch error f_pb of the planet (seed 002's E_bp, ``planet_base_pitch_error_m``):
  a once-per-tooth mesh displacement along the line of action, e_pb = ½·f_pb·cos φ with the
  mesh phase φ = z_s(θ_s − γ): the tooth-transfer step of a single-pair mesh reduced to its
  fundamental (peak-to-peak f_pb). It shifts the transmission deflection, δ → δ − e_pb.

Force law (from a potential, so the stiffness Jacobian is symmetric)
--------------------------------------------------------------------
k(φ) = k_mean + k_amp·cos φ with the mesh phase φ = z_s·(θ_s − γ) (one period per tooth,
φ = 0 when the sun's body x axis lies on the centre line). The elastic potential is
V = k(φ)·[Ψ(g₊) + Ψ(g₋)] with Ψ' = s, s(g) = (g + √(g² + w²))/2 a smoothed max(g, 0) of
width w = ``smoothing_m`` (default 10 nm). Generalized forces are −∂V/∂q, so each flank
carries the normal force k·s(g±) along its line of action at the base tangents (equal and
opposite on the two gears; momentum and angular momentum are conserved) plus the small
conservative term −k'(φ)·(Ψ₊ + Ψ₋)·∂φ/∂q from the stiffness variation (relative size
k_amp·z_s·g/(2·k·r_bs), ≈ 2e-6 at 2 N·m on the RV-40E sun). Without backlash
s(δ) − s(−δ) = δ exactly, so the law is exactly linear, F = k·δ. With backlash the smoothed
contact reaches into the dead zone as a weak spring, k·w²/(4·d²) per flank at a distance d
from contact (72 N/m at the centre of 50 µm backlash, k = 9e8 N/m): it keeps the static
Jacobian regular in the free play, and in a loaded mesh the unloaded flank carries
k·w²/(4b) ≈ 4.5e-4 N, a share 5e-6 of a 100 N mesh force. The loaded flank's deflection
is shifted by w²/(4g) (0.2 nm at 100 N). With b = 0 both flanks touch at δ = 0 and each
carries k·w/2 (4.5 N): the net law k·δ stays exact, but the gears are pressed apart by
k·w·sin α' ≈ 3 N.

δ is unambiguous within ±π·r_B of the rolling estimate (±0.106 m along the line, ±12.5 rad
of sun rotation against a held planet); beyond that it wraps by 2π·r_B. Equilibria are µm
from the estimate, but a Newton iterate can leave the window when a load step starts in open
backlash, where the only stiffness is the 72 N/m above (5.2e-3 N·m/rad at the RV-40E sun):
keep such steps small (load continuation) or add weak springs, as DESIGN.md asks.

Damping c·ġ acts only in contact: the dissipation function D = ½·c·Σ s'(g±)·ġ±² gives
f = −c·Σ s'(g±)·ġ±·∂g±/∂q (s' is the smoothed contact indicator, 0 open, 1 closed).

Implementation
--------------
No built-in Exudyn connector sees both nodes' (x, y, θ): the rigid-body spring-damper hands
its user function relative displacement and rotation only (θ_p − θ_s, while the mesh needs
r_bs·θ_s + r_bp·θ_p), coordinate spring-dampers see one coordinate per side, and
``ObjectConnectorCoordinateVector`` is a constraint. Exudyn 1.13.6 can record a symbolic
``forceUserFunction`` of ``ObjectGenericODE2`` but not its ``jacobianUserFunction``, so a
symbolic force would be differentiated numerically (one-sided steps; not the exact
symmetric Hessian). Hence one ``ObjectGenericODE2`` with a numba force kernel and its
analytic Jacobian. Exudyn's convention, checked against its own numerical differentiation
in the tests: the Jacobian user function returns ∂(−f)/∂q·fODE2 + ∂(−f)/∂q̇·fODE2_t, with
f the force the user function returns (right-hand side) and q excluding reference values.

A spatial crank (planet on a ``NodeRigidBodyRxyz``, ``planet_lever_m`` given): the object sits on [sun, planet]
with 3 + 6 coordinates; the kernel sees the planet gear's section at its axial lever from the crank's node
(:mod:`rvflex.contact.tilt_map`: the crank's tilt moves the gear's centre in the plane), its force and Jacobians
mapped back onto the crank's six coordinates with the exact Jacobian of that pose.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import exudyn as exu
import numba as nb
import numpy as np
from exudyn.itemInterface import ObjectGenericODE2, VObjectGenericODE2

from rvflex.contact.tilt_map import add_curvature, section_pose
from rvflex.spec import ErrorSpec, InputStage, SpecError

__all__ = [
    "SMOOTHING_M",
    "GearMeshHandles",
    "MeshState",
    "add_gear_mesh",
    "evaluate",
    "mesh_state",
    "base_radii",
    "normal_backlash_m",
    "mesh_kernel",
]

SMOOTHING_M = 1e-8  # m; ≪ the 20 nm geometry budget of DESIGN.md, ≫ Newton's length resolution

# parameter vector of the kernel
(P_RBS, P_RBP, P_RB, P_INV_A, P_RHO0, P_HALF_B, P_KM, P_KA, P_ZS, P_C, P_W,
 P_XS0, P_YS0, P_TS0, P_XP0, P_YP0, P_TP0, P_G0, P_ESX, P_ESY, P_EPX, P_EPY, P_EPB, P_UC, P_US) = range(25)
N_PAR = 25
# kernel state vector (see MeshState)
(S_DELTA, S_GP, S_GM, S_FP, S_FM, S_K, S_PHI, S_A, S_GAMMA, S_ALPHA) = range(10)
N_STATE = 10

_jit = nb.njit(cache=True, nogil=True)
_TWO_PI = 2.0 * math.pi


@_jit
def _ramp(g, w):
    """Smoothed max(g, 0): s, s', s'' and the potential Ψ (Ψ' = s, Ψ(0) = 0), all cancellation-free."""
    h = math.sqrt(g * g + w * w)
    s = 0.5 * (g + h) if g >= 0.0 else 0.5 * w * w / (h - g)
    s1 = s / h
    s2 = 0.5 * w * w / (h * h * h)
    psi = 0.5 * g * s + 0.25 * w * w * math.log(2.0 * s / w)
    return s, s1, s2, psi


@_jit
def _kernel(q, qt, par, f, dfdq, dfdqt, state, with_jacobian):
    """Generalized force ``f`` (6) on [x_s, y_s, θ_s, x_p, y_p, θ_p] and, if ``with_jacobian``,
    ∂f/∂q and ∂f/∂q̇ (6×6). ``q``, ``qt`` are displacements from the nodes' reference values.

    The sun's teeth stand at θ_s + u(θ_s), u = u_c·cos θ_s + u_s·sin θ_s (the input-shaft angle
    error): the mesh is evaluated at that angle and its force and derivatives are carried back to
    θ_s by the chain rule (∂u/∂θ_s and ∂²u/∂θ_s² exact), so the Jacobian stays the exact Hessian."""
    uc = par[P_UC]
    us = par[P_US]
    if uc == 0.0 and us == 0.0:
        _mesh_kernel(q, qt, par, f, dfdq, dfdqt, state, with_jacobian)
        return
    ths = par[P_TS0] + q[2]
    u = uc * math.cos(ths) + us * math.sin(ths)
    u1 = -uc * math.sin(ths) + us * math.cos(ths)  # du/dθ_s
    u2 = -u  # d²u/dθ_s²
    kap = 1.0 + u1  # dθ_teeth/dθ_s
    qe = q.copy()
    qe[2] += u
    qte = qt.copy()
    qte[2] *= kap
    _mesh_kernel(qe, qte, par, f, dfdq, dfdqt, state, with_jacobian)
    if with_jacobian:
        # f = Tᵀ·f_e(q_e(q), q̇_e(q, q̇)), T = diag(1, 1, κ, 1, 1, 1), ∂q̇_e2/∂q_2 = u''·q̇_2, ∂κ/∂q_2 = u''
        for i in range(6):
            dfdq[i, 2] = dfdq[i, 2] * kap + dfdqt[i, 2] * u2 * qt[2]
            dfdqt[i, 2] *= kap
        for j in range(6):
            dfdq[2, j] *= kap
            dfdqt[2, j] *= kap
        dfdq[2, 2] += u2 * f[2]
    f[2] *= kap


mesh_kernel = _kernel
"""The mesh kernel, for compiled callers that evaluate a mesh without its Exudyn element (rvflex.engine)."""


@_jit
def _mesh_kernel(q, qt, par, f, dfdq, dfdqt, state, with_jacobian):
    """:func:`_kernel` of gears whose teeth turn with their nodes (no input-shaft angle error)."""
    rbs = par[P_RBS]
    rbp = par[P_RBP]
    rb = par[P_RB]
    w = par[P_W]
    ths = par[P_TS0] + q[2]
    thp = par[P_TP0] + q[5]
    cs = math.cos(ths)
    sn = math.sin(ths)
    cp = math.cos(thp)
    sp = math.sin(thp)
    # base-circle centre offsets (turn with their gear) and their θ-derivatives
    esx = cs * par[P_ESX] - sn * par[P_ESY]
    esy = sn * par[P_ESX] + cs * par[P_ESY]
    epx = cp * par[P_EPX] - sp * par[P_EPY]
    epy = sp * par[P_EPX] + cp * par[P_EPY]
    dx = (par[P_XP0] + q[3] + epx) - (par[P_XS0] + q[0] + esx)
    dy = (par[P_YP0] + q[4] + epy) - (par[P_YS0] + q[1] + esy)
    a = math.sqrt(dx * dx + dy * dy)
    ux = dx / a
    uy = dy / a
    vx = -uy
    vy = ux
    # centre-line angle on the branch nearest to the rolling estimate, so that γ stays
    # continuous over any number of carrier turns (fails only for |δ| > π·r_B)
    gam_hint = par[P_G0] + (rbs * q[2] + rbp * q[5]) / rb
    wr = math.atan2(dy, dx) - gam_hint
    wr -= _TWO_PI * math.floor((wr + math.pi) / _TWO_PI)
    delta = -rb * wr
    gam = gam_hint + wr
    ca = rb / a
    sa = math.sqrt(1.0 - ca * ca)  # NaN if the base circles overlap: the solver then fails loudly
    alpha = math.atan2(sa, ca)
    rho = -rb * (sa / ca - alpha - par[P_INV_A]) + par[P_RHO0]
    zs = par[P_ZS]
    phi = zs * (ths - gam)
    # base-pitch excitation e = ½f_pb·cos φ shifts the transmission deflection: δ → δ − e
    epb = par[P_EPB]
    e0 = epb * math.cos(phi)
    e1 = -epb * math.sin(phi)  # de/dφ
    e2 = -e0  # d²e/dφ²
    delta -= e0
    gp = delta + rho - par[P_HALF_B]
    gm = -delta + rho - par[P_HALF_B]

    # first derivatives: γ (Gg), a (Ga), δ (Jt), ρ (Jr), g± (Jp, Jm), φ (Gf)
    ves = vx * -esy + vy * esx  # v·∂c_s/∂θ_s
    vep = vx * -epy + vy * epx
    ues = ux * -esy + uy * esx
    uep = ux * -epy + uy * epx
    Gg = np.empty(6)
    Ga = np.empty(6)
    Gg[0] = -vx / a
    Gg[1] = -vy / a
    Gg[2] = -ves / a
    Gg[3] = vx / a
    Gg[4] = vy / a
    Gg[5] = vep / a
    Ga[0] = -ux
    Ga[1] = -uy
    Ga[2] = -ues
    Ga[3] = ux
    Ga[4] = uy
    Ga[5] = uep
    Gf = -zs * Gg
    Gf[2] += zs
    Jt = -rb * Gg - e1 * Gf
    Jt[2] += rbs
    Jt[5] += rbp
    Jr = -sa * Ga
    Jp = Jt + Jr
    Jm = Jr - Jt
    cphi = math.cos(phi)
    sphi = math.sin(phi)
    k = par[P_KM] + par[P_KA] * cphi
    dk = -par[P_KA] * sphi
    ddk = -par[P_KA] * cphi
    spp, s1p, s2p, psip = _ramp(gp, w)
    smm, s1m, s2m, psim = _ramp(gm, w)
    c = par[P_C]
    gdp = 0.0
    gdm = 0.0
    for i in range(6):
        gdp += Jp[i] * qt[i]
        gdm += Jm[i] * qt[i]
    psi = psip + psim
    ap = k * spp + c * s1p * gdp  # normal force on the drive flank (N)
    am = k * smm + c * s1m * gdm
    for i in range(6):
        f[i] = -ap * Jp[i] - am * Jm[i] - dk * psi * Gf[i]

    state[S_DELTA] = delta
    state[S_GP] = gp
    state[S_GM] = gm
    state[S_FP] = ap
    state[S_FM] = am
    state[S_K] = k
    state[S_PHI] = phi
    state[S_A] = a
    state[S_GAMMA] = gam
    state[S_ALPHA] = alpha
    if not with_jacobian:
        return

    # second derivatives: Hγ = −(Ga Ggᵀ + Gg Gaᵀ)/a + θθ terms,  Ha = a·Gg Ggᵀ + θθ terms
    Hg = np.empty((6, 6))
    Ha = np.empty((6, 6))
    for i in range(6):
        for j in range(6):
            Hg[i, j] = -(Ga[i] * Gg[j] + Gg[i] * Ga[j]) / a
            Ha[i, j] = a * Gg[i] * Gg[j]
    ve_s = vx * esx + vy * esy  # ∂²d/∂θ_s² = +e_s, ∂²d/∂θ_p² = −e_p
    ve_p = vx * epx + vy * epy
    ue_s = ux * esx + uy * esy
    ue_p = ux * epx + uy * epy
    Hg[2, 2] += ve_s / a
    Hg[5, 5] -= ve_p / a
    Ha[2, 2] += ue_s
    Ha[5, 5] -= ue_p
    drho2 = -ca * ca / (a * sa)  # ∂²ρ/∂a², with ∂ρ/∂a = −sin α'
    Ht = np.empty((6, 6))  # ∂²δ/∂q²
    Hr = np.empty((6, 6))  # ∂²ρ/∂q²
    for i in range(6):
        for j in range(6):
            # ∂²(δ − e)/∂q², with ∂²φ/∂q² = −z_s·Hγ
            Ht[i, j] = -rb * Hg[i, j] - e2 * Gf[i] * Gf[j] + e1 * zs * Hg[i, j]
            Hr[i, j] = drho2 * Ga[i] * Ga[j] - sa * Ha[i, j]
    # H·q̇ for the damping terms
    hp = np.zeros(6)
    hm = np.zeros(6)
    for i in range(6):
        for j in range(6):
            hp[i] += (Hr[i, j] + Ht[i, j]) * qt[j]
            hm[i] += (Hr[i, j] - Ht[i, j]) * qt[j]
    kp = k * s1p + c * s2p * gdp  # d(normal force)/dg, drive flank
    km = k * s1m + c * s2m * gdm
    for i in range(6):
        for j in range(6):
            hess = (kp * Jp[i] * Jp[j] + ap * (Hr[i, j] + Ht[i, j])
                    + km * Jm[i] * Jm[j] + am * (Hr[i, j] - Ht[i, j])
                    + dk * (spp * (Jp[i] * Gf[j] + Gf[i] * Jp[j]) + smm * (Jm[i] * Gf[j] + Gf[i] * Jm[j]))
                    + ddk * psi * Gf[i] * Gf[j] - dk * psi * zs * Hg[i, j]
                    + c * (s1p * Jp[i] * hp[j] + s1m * Jm[i] * hm[j]))
            dfdq[i, j] = -hess
            dfdqt[i, j] = -c * (s1p * Jp[i] * Jp[j] + s1m * Jm[i] * Jm[j])


@_jit
def _force(q, qt, par):
    f = np.empty(6)
    _kernel(q, qt, par, f, np.empty((0, 0)), np.empty((0, 0)), np.empty(N_STATE), False)
    return f


@_jit
def _exudyn_jacobian(q, qt, par, f_ode2, f_ode2_t):
    """Jacobian in Exudyn's convention: of the left-hand side (−f), times the factors."""
    f = np.empty(6)
    dfdq = np.empty((6, 6))
    dfdqt = np.empty((6, 6))
    _kernel(q, qt, par, f, dfdq, dfdqt, np.empty(N_STATE), True)
    return -(f_ode2 * dfdq + f_ode2_t * dfdqt)


@_jit
def _tilted(q, qt, par, lever, f_ode2, f_ode2_t, f, lhs, with_jacobian):
    """The mesh with the planet on a NodeRigidBodyRxyz: ``q``, ``qt`` (9,) the sun's (x, y, θ) and the crank's
    (x, y, z, ψx, ψy, ψz) displacements; the gear's section at ``lever`` (m) is the kernel's planet. Fills the
    force ``f`` (9,) and, ``with_jacobian``, ``lhs`` (9, 9) in Exudyn's convention (as :func:`_exudyn_jacobian`)."""
    s = np.empty(3)
    jac = np.empty((3, 6))
    section_pose(q[3:9], lever, s, jac)
    t = np.zeros((6, 9))  # ∂(sun, section)/∂(sun, crank)
    for i in range(3):
        t[i, i] = 1.0
        for j in range(6):
            t[3 + i, 3 + j] = jac[i, j]
    q6 = np.empty(6)
    qt6 = np.empty(6)
    q6[:3] = q[:3]
    qt6[:3] = qt[:3]
    q6[3:] = s
    qt6[3:] = jac @ qt[3:9]
    f6 = np.empty(6)
    dfdq = np.empty((6, 6))
    dfdqt = np.empty((6, 6))
    _kernel(q6, qt6, par, f6, dfdq, dfdqt, np.empty(N_STATE), with_jacobian)
    f[:] = t.T @ f6
    if with_jacobian:
        lhs[:, :] = t.T @ (-(f_ode2 * dfdq + f_ode2_t * dfdqt)) @ t
        add_curvature(q[3:9], lever, f6[3:], f_ode2, lhs, 3)


# --------------------------------------------------------------------------- public API


@dataclass(frozen=True)
class GearMeshHandles:
    """Items of one sun–planet mesh.

    ``parameters`` is the resolved kernel parameter vector (geometry, stiffness, errors and
    the nodes' reference configuration, SI), kept so :func:`mesh_state` and :func:`evaluate`
    need nothing but the handles.
    """

    mesh_object: int  # ObjectGenericODE2 on [sun_node, planet_node]
    sun_node: int
    planet_node: int
    parameters: tuple[float, ...]
    planet_lever_m: float | None = None  # a spatial crank: the gear's axial lever from its node (m); None: planar


@dataclass(frozen=True, slots=True)
class MeshState:
    """Mesh quantities at one configuration (SI: m, N, N/m, rad)."""

    deflection_m: float  # δ, along the line of action, + when the sun leads (drive flank side)
    drive_overlap_m: float  # g₊ = δ + ρ − b/2 (> 0: drive flank in contact)
    coast_overlap_m: float  # g₋ = −δ + ρ − b/2
    drive_force_N: float  # normal force on the drive flank, k·s(g₊) + damping
    coast_force_N: float  # normal force on the coast flank
    force_N: float  # drive − coast; the sun torque it balances is r_bs·force_N
    stiffness_N_m: float  # k(φ)
    mesh_phase_rad: float  # φ = z_s·(θ_s − γ)
    centre_distance_m: float  # a, between the base-circle centres
    centre_line_angle_rad: float  # γ, continuous over carrier turns
    operating_pressure_angle_rad: float  # α', cos α' = r_B/a


def normal_backlash_m(stage: InputStage) -> float:
    """Normal backlash b = j_t·cos α along the line of action from the circumferential
    backlash j_t = ``stage.backlash_m`` at the pitch circle (m)."""
    return stage.backlash_m * math.cos(stage.pressure_angle_rad)


def base_radii(stage: InputStage) -> tuple[float, float]:
    """Base-circle radii (r_bs, r_bp) = m·z·cos α/2 of sun and planet (m)."""
    c = stage.module_m * math.cos(stage.pressure_angle_rad) / 2.0
    return c * stage.sun_teeth, c * stage.planet_teeth


def _check_stage(stage: InputStage) -> None:
    if not isinstance(stage, InputStage):
        raise SpecError("stage", type(stage).__name__, "must be an rvflex.spec.InputStage")
    # InputStage validates itself; re-check what the force law relies on in case it was bypassed
    checks = (
        ("mesh_stiffness_mean_N_m", stage.mesh_stiffness_mean_N_m > 0.0, "must be a positive stiffness in N/m"),
        ("mesh_stiffness_amplitude_N_m",
         0.0 <= stage.mesh_stiffness_amplitude_N_m <= stage.mesh_stiffness_mean_N_m,
         "must lie in [0, mesh_stiffness_mean_N_m] N/m so that k(φ) ≥ 0"),
        ("mesh_damping_Ns_m", stage.mesh_damping_Ns_m >= 0.0, "must be a non-negative damping in N·s/m"),
        ("backlash_m", stage.backlash_m >= 0.0, "must be a non-negative backlash in m"),
    )
    for name, ok, rule in checks:
        value = getattr(stage, name)
        if not (isinstance(value, (int, float)) and math.isfinite(value) and ok):
            raise SpecError(f"stage.{name}", value, rule)


def _planet_entry(errors: ErrorSpec, field: str, planet_index: int) -> float:
    values = getattr(errors, field)
    if not values:
        return 0.0
    if planet_index >= len(values):
        raise SpecError("planet_index", planet_index,
                        f"errors.{field} has {len(values)} entries (one per crank); index out of range")
    return float(values[planet_index])


def _node_index(mbs, node, name: str, kind_needed: str = "RigidBody2D") -> int:
    """``node`` (int or exudyn.NodeIndex) as an int, if it is a node of ``mbs`` of type ``kind_needed``."""
    count = mbs.systemData.NumberOfNodes()
    try:
        index = int(node) if not isinstance(node, (bool, float)) else -1
    except TypeError:
        index = -1
    if not 0 <= index < count:
        raise SpecError(name, node, f"must be the index of a node in mbs (0 … {count - 1})")
    kind = mbs.GetNode(index)["nodeType"]
    if kind != kind_needed:
        what = "a NodeRigidBody2D (x, y, θ)" if kind_needed == "RigidBody2D" else f"a Node{kind_needed}"
        raise SpecError(name, node, f"must be {what}, got a {kind} node")
    return index


def add_gear_mesh(mbs, sun_node: int, planet_node: int, stage: InputStage, *, planet_index: int = 0,
                  errors: ErrorSpec | None = None, name: str = "",
                  smoothing_m: float = SMOOTHING_M, planet_lever_m: float | None = None) -> GearMeshHandles:
    """Add the involute mesh between ``sun_node`` and ``planet_node`` to ``mbs``.

    Parameters
    ----------
    mbs : exudyn.MainSystem
        System to add to (before ``Assemble``).
    sun_node, planet_node : int
        ``NodeRigidBody2D`` nodes of sun and planet. Their reference configuration is the
        centred mesh (δ = 0); their centre distance must be within one module of
        m(z_s + z_p)/2.
    stage : InputStage
        Teeth, module (m), pressure angle (rad), mesh stiffness mean/amplitude (N/m),
        damping (N·s/m) and circumferential backlash at the pitch circle (m).
    planet_index : int, optional
        Which crank this planet is: selects the entries of the per-planet error tuples.
    errors : ErrorSpec, optional
        Sun/planet base eccentricity, runout and pitch-radius errors (m, rad); ``None`` =
        perfect gears.
    name : str, optional
        Name of the Exudyn object.
    smoothing_m : float, optional
        Width w (m) of the smoothed contact onset, default :data:`SMOOTHING_M`.
    planet_lever_m : float, optional
        A spatial crank: ``planet_node`` is its ``NodeRigidBodyRxyz`` (reference tilt zero) and the gear's
        mid-plane lies this far along the axis from the node (m); the crank's tilt moves the gear's centre
        (module docstring). None (default): a planar planet.

    Returns
    -------
    GearMeshHandles

    Raises
    ------
    rvflex.spec.SpecError
        (a ``ValueError``) naming the offending parameter: non-2D or equal nodes, negative
        stiffness/damping/backlash, ``planet_index`` outside the error tuples, a centre
        distance that does not fit the stage.
    """
    _check_stage(stage)
    if isinstance(planet_index, bool) or not isinstance(planet_index, (int, np.integer)) or planet_index < 0:
        raise SpecError("planet_index", planet_index, "must be a non-negative integer (crank number)")
    if not (isinstance(smoothing_m, (int, float)) and math.isfinite(smoothing_m) and 0.0 < smoothing_m <= 1e-6):
        raise SpecError("smoothing_m", smoothing_m, "must be a positive width in m, at most 1 µm")
    errors = ErrorSpec() if errors is None else errors
    if not isinstance(errors, ErrorSpec):
        raise SpecError("errors", type(errors).__name__, "must be an rvflex.spec.ErrorSpec or None")
    sun_node = _node_index(mbs, sun_node, "sun_node")
    spatial = planet_lever_m is not None
    if spatial and not (isinstance(planet_lever_m, (int, float)) and math.isfinite(planet_lever_m)):
        raise SpecError("planet_lever_m", planet_lever_m, "must be a finite axial distance in m")
    planet_node = _node_index(mbs, planet_node, "planet_node", "RigidBodyRxyz" if spatial else "RigidBody2D")
    if sun_node == planet_node:
        raise SpecError("planet_node", planet_node, "must differ from sun_node")
    ref_s, ref_p = (np.asarray(mbs.GetNodeParameter(n, "referenceCoordinates"), dtype=np.float64)
                    for n in (sun_node, planet_node))
    if spatial:
        if np.any(ref_p[3:5] != 0.0):
            raise SpecError("planet_node", planet_node, "a spatial planet's reference tilt (ψx, ψy) must be zero")
        ref_p = ref_p[[0, 1, 5]]  # the gear's in-plane reference pose: the node's (x, y, ψz)

    rbs, rbp = base_radii(stage)
    rb = rbs + rbp
    alpha = stage.pressure_angle_rad
    a_ref = math.hypot(ref_p[0] - ref_s[0], ref_p[1] - ref_s[1])
    a0 = stage.centre_distance_m
    if not abs(a_ref - a0) <= stage.module_m:
        raise SpecError("planet_node", planet_node,
                        f"reference centre distance {a_ref * 1e3:.4f} mm must be within one module of "
                        f"m(z_s + z_p)/2 = {a0 * 1e3:.4f} mm")

    # errors: base-circle centre offsets in each gear's body frame, flank offset of pitch errors
    es = (errors.sun_base_eccentricity_m * np.array([math.cos(errors.sun_base_eccentricity_phase_rad),
                                                      math.sin(errors.sun_base_eccentricity_phase_rad)])
          + errors.sun_runout_m * np.array([math.cos(errors.sun_runout_phase_rad),
                                            math.sin(errors.sun_runout_phase_rad)]))
    ecc_p = _planet_entry(errors, "planet_base_eccentricity_m", planet_index)
    phase_p = _planet_entry(errors, "planet_base_eccentricity_phase_rad", planet_index)
    runout_p = _planet_entry(errors, "planet_runout_m", planet_index)
    pitch_error = _planet_entry(errors, "planet_base_pitch_error_m", planet_index)
    pitch_p = _planet_entry(errors, "planet_pitch_radius_error_m", planet_index)
    ep = ecc_p * np.array([math.cos(phase_p), math.sin(phase_p)]) + runout_p * np.array([1.0, 0.0])
    rho0 = (errors.sun_pitch_radius_error_m + pitch_p) * math.sin(alpha)

    par = np.zeros(N_PAR)
    par[P_RBS], par[P_RBP], par[P_RB] = rbs, rbp, rb
    par[P_INV_A] = math.tan(alpha) - alpha
    par[P_RHO0] = rho0
    par[P_HALF_B] = 0.5 * normal_backlash_m(stage)
    par[P_EPB] = 0.5 * pitch_error
    par[P_KM] = stage.mesh_stiffness_mean_N_m
    par[P_KA] = stage.mesh_stiffness_amplitude_N_m
    par[P_ZS] = stage.sun_teeth
    par[P_C] = stage.mesh_damping_Ns_m
    par[P_W] = smoothing_m
    par[P_XS0:P_TS0 + 1] = ref_s
    par[P_XP0:P_TP0 + 1] = ref_p
    # reference centre line of the nominal centres: δ = 0 there (errors then show as TE)
    par[P_G0] = math.atan2(ref_p[1] - ref_s[1], ref_p[0] - ref_s[0])
    par[P_ESX], par[P_ESY] = es
    par[P_EPX], par[P_EPY] = ep
    # the sun's teeth at θ_s + a·cos(θ_s − ψ) = θ_s + u_c·cos θ_s + u_s·sin θ_s
    a_in, psi_in = errors.input_shaft_angle_error_rad, errors.input_shaft_angle_error_phase_rad
    par[P_UC], par[P_US] = a_in * math.cos(psi_in), a_in * math.sin(psi_in)

    if spatial:
        lever = float(planet_lever_m)
        f9, lhs = np.empty(9), np.empty((9, 9))

        def force(mbs_, t, item, q, q_t):
            _tilted(np.asarray(q, dtype=np.float64), np.asarray(q_t, dtype=np.float64), par, lever, 1.0, 0.0, f9,
                    lhs, False)
            return f9

        def jacobian(mbs_, t, item, q, q_t, f_ode2, f_ode2_t):
            _tilted(np.asarray(q, dtype=np.float64), np.asarray(q_t, dtype=np.float64), par, lever, f_ode2,
                    f_ode2_t, f9, lhs, True)
            return lhs
    else:
        def force(mbs_, t, item, q, q_t):
            return _force(np.asarray(q, dtype=np.float64), np.asarray(q_t, dtype=np.float64), par)

        def jacobian(mbs_, t, item, q, q_t, f_ode2, f_ode2_t):
            return _exudyn_jacobian(np.asarray(q, dtype=np.float64), np.asarray(q_t, dtype=np.float64), par,
                                    f_ode2, f_ode2_t)

    obj = mbs.AddObject(ObjectGenericODE2(
        name=name, nodeNumbers=[sun_node, planet_node],
        forceUserFunction=force, jacobianUserFunction=jacobian,
        visualization=VObjectGenericODE2(show=False)))
    return GearMeshHandles(mesh_object=int(obj), sun_node=sun_node, planet_node=planet_node,
                           parameters=tuple(float(x) for x in par),
                           planet_lever_m=float(planet_lever_m) if spatial else None)


def evaluate(handles: GearMeshHandles, q, q_t=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Generalized force and its derivatives at node displacements ``q`` (6, from reference).

    Returns ``(f, df/dq, df/dq̇)`` on [x_s, y_s, θ_s, x_p, y_p, θ_p] (N, N·m; N/m, N, N·m/rad;
    N·s/m ...): ``f`` is the force acting on the nodes (right-hand side).
    """
    q = np.ascontiguousarray(q, dtype=np.float64)
    qt = np.zeros(6) if q_t is None else np.ascontiguousarray(q_t, dtype=np.float64)
    if q.shape != (6,) or qt.shape != (6,):
        raise SpecError("q", q.shape, "needs 6 coordinates [x_s, y_s, θ_s, x_p, y_p, θ_p]")
    f, dfdq, dfdqt = np.empty(6), np.empty((6, 6)), np.empty((6, 6))
    _kernel(q, qt, np.asarray(handles.parameters), f, dfdq, dfdqt, np.empty(N_STATE), True)
    return f, dfdq, dfdqt


def _state(handles: GearMeshHandles, q: np.ndarray, qt: np.ndarray) -> MeshState:
    st = np.empty(N_STATE)
    _kernel(q, qt, np.asarray(handles.parameters), np.empty(6), np.empty((0, 0)), np.empty((0, 0)), st, False)
    v = [float(x) for x in st]
    return MeshState(
        deflection_m=v[S_DELTA], drive_overlap_m=v[S_GP], coast_overlap_m=v[S_GM],
        drive_force_N=v[S_FP], coast_force_N=v[S_FM], force_N=v[S_FP] - v[S_FM],
        stiffness_N_m=v[S_K], mesh_phase_rad=v[S_PHI], centre_distance_m=v[S_A],
        centre_line_angle_rad=v[S_GAMMA], operating_pressure_angle_rad=v[S_ALPHA])


def mesh_state(mbs, handles: GearMeshHandles, configuration=exu.ConfigurationType.Current, *,
               q=None, q_t=None) -> MeshState:
    """Mesh deflection, flank overlaps and forces of ``handles`` in ``mbs`` (or at given ``q``, ``q_t``).

    ``q``/``q_t`` (6 displacements from the reference configuration; 9 for a spatial crank, its node's six)
    override the state read from ``mbs`` in ``configuration``; pass ``mbs=None`` then.
    """
    if q is None:
        ot = exu.OutputVariableType
        q = np.concatenate([mbs.GetNodeOutput(n, ot.Coordinates, configuration)
                            for n in (handles.sun_node, handles.planet_node)])
        q_t = np.concatenate([mbs.GetNodeOutput(n, ot.Coordinates_t, configuration)
                              for n in (handles.sun_node, handles.planet_node)])
    q = np.ascontiguousarray(q, dtype=np.float64)
    qt = np.zeros(len(q)) if q_t is None else np.ascontiguousarray(q_t, dtype=np.float64)
    if handles.planet_lever_m is not None and len(q) == 9:  # a spatial crank: its gear's section
        sec, jac = np.empty(3), np.empty((3, 6))
        section_pose(q[3:], handles.planet_lever_m, sec, jac)
        q, qt = np.concatenate([q[:3], sec]), np.concatenate([qt[:3], jac @ qt[3:]])
    return _state(handles, q, qt)

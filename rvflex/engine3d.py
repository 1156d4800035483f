"""Spatial force elements of the compiled quasi-static step (:mod:`rvflex.engine`): rigid bodies free in space.

The spatial rigid model (:func:`rvflex.model.build_reducer` with ``options.spatial``) puts the carrier, the
cranks and the discs on ``NodeRigidBodyRxyz`` nodes: coordinates q = (x, y, z, ψx, ψy, ψz), rotation
R = Rx(ψx)·Ry(ψy)·Rz(ψz). The engine replicates its elements with the same force laws as Exudyn:

- ``ConnectorRigidBodySpringDamper`` with rvflex's clearance-bearing law (:mod:`rvflex.contact.bearing`), as
  Exudyn defines it: the markers' joint frames J0 = R₀, J1 = R₁ (``rotationMarker0/1`` the identity), the
  relative displacement d = R₀ᵀ(p₁ − p₀) and rotation θ = the Tait–Bryan (xyz) angles of R₀ᵀR₁; the law's force
  f_L = (g·d_x, g·d_y, k_ax·d_z) and torque m_L = (k_tx·θ_x, k_ty·θ_y, 0) in J0, applied as the global wrench
  (R₀f_L, R₀m_L) on marker 1 and its negative on marker 0 through the markers' position Jacobians ∂p/∂q and
  rotation Jacobians G (ω = G·ψ̇): f₁ = −(J_pᵀR₀f_L + Gᵀ R₀m_L) (:func:`bushings3d`);
- ``ConnectorCartesianSpringDamper`` between 3D markers: k ∘ (p₁ − p₀ − offset) in the global frame;
- the main bearing pair element (:func:`rvflex.contact.angular_contact.pair_kernel` on the carrier's
  x, y, z, ψx, ψy less the seat offset);
- a tilting disc's contact slice and a tilting crank's gear mesh: the planar kernel on the in-plane pose of the
  body's section (:mod:`rvflex.contact.tilt_map`), mapped back onto the body's six coordinates.

The Jacobians are exact: for a bushing, with u = (d, θ_x, θ_y) the law's arguments, ∂d/∂q from p and R₀,
∂θ/∂q = G(θ)⁻¹R₀ᵀ(G₁∂ψ₁ − G₀∂ψ₀) (the relative rotation's increment in J0), and the terms of R₀, ∂p/∂ψ and
G turning with the bodies (second derivatives of R). Exudyn differentiates these connectors numerically.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from rvflex.contact.angular_contact import pair_kernel
from rvflex.contact.gear_mesh import N_STATE as MESH_STATE
from rvflex.contact.gear_mesh import mesh_kernel
from rvflex.contact.tilt_map import add_curvature, map_to_body, section_pose

__all__ = ["B3_CARTESIAN", "B3_CLEARANCE", "LAW_CARTESIAN", "LAW_CLEARANCE", "bushings3d", "clearance_ramp",
           "connector_law3d", "marker3d", "mesh_tilted", "pair_elements", "rotation_set", "slice_section",
           "slice_to_body", "spatial_data", "workspace3d"]

# point connectors: law kinds of the planar ones (rvflex.engine), and the laws a 3D one carries (bits)
LAW_CLEARANCE, LAW_CARTESIAN = 0, 1
B3_CLEARANCE, B3_CARTESIAN = 1, 2

_jit = nb.njit(cache=True, nogil=True)


@_jit
def clearance_ramp(x, w):
    """r_w(x) and its derivative (rvflex.contact.bearing's smoothed clearance ramp; m, –)."""
    if w == 0.0:
        return (x, 1.0) if x > 0.0 else (0.0, 0.0)
    if x <= -w:
        return 0.0, 0.0
    if x >= w:
        return x, 1.0
    return (x + w) * (x + w) / (4.0 * w), (x + w) / (2.0 * w)


@_jit
def _axis_factor(angle, axis, out):
    """The rotation about ``axis`` by ``angle`` (rad) and its first and second derivatives: ``out`` (3, 3, 3)."""
    c, s = math.cos(angle), math.sin(angle)
    i, j = (axis + 1) % 3, (axis + 2) % 3
    for o in range(3):
        for a in range(3):
            for b in range(3):
                out[o, a, b] = 0.0
    out[0, axis, axis] = 1.0
    out[0, i, i], out[0, i, j], out[0, j, i], out[0, j, j] = c, -s, s, c
    out[1, i, i], out[1, i, j], out[1, j, i], out[1, j, j] = -s, -c, c, -s
    out[2, i, i], out[2, i, j], out[2, j, i], out[2, j, j] = -c, s, -s, -c


@_jit
def _triple(a, b, c, out):
    """out = a·b·c (3 × 3)."""
    for i in range(3):
        for j in range(3):
            s = 0.0
            for k in range(3):
                ab = a[i, 0] * b[0, k] + a[i, 1] * b[1, k] + a[i, 2] * b[2, k]
                s += ab * c[k, j]
            out[i, j] = s


@_jit
def rotation_set(psi, fac, r, dr, ddr, second):
    """R = Rx(ψ₀)·Ry(ψ₁)·Rz(ψ₂) in ``r`` (3, 3), ∂R/∂ψᵢ in ``dr`` (3, 3, 3) and, with ``second``, ∂²R/∂ψᵢ∂ψⱼ in
    ``ddr`` (3, 3, 3, 3); ``psi`` (3,) rad, ``fac`` (3, 3, 3, 3) work space."""
    for a in range(3):
        _axis_factor(psi[a], a, fac[a])
    _triple(fac[0, 0], fac[1, 0], fac[2, 0], r)
    _triple(fac[0, 1], fac[1, 0], fac[2, 0], dr[0])
    _triple(fac[0, 0], fac[1, 1], fac[2, 0], dr[1])
    _triple(fac[0, 0], fac[1, 0], fac[2, 1], dr[2])
    if not second:
        return
    for i in range(3):
        for j in range(i, 3):
            o0 = (1 if i == 0 else 0) + (1 if j == 0 else 0)
            o1 = (1 if i == 1 else 0) + (1 if j == 1 else 0)
            o2 = (1 if i == 2 else 0) + (1 if j == 2 else 0)
            _triple(fac[0, o0], fac[1, o1], fac[2, o2], ddr[i, j])
            if j != i:
                for a in range(3):
                    for b in range(3):
                        ddr[j, i, a, b] = ddr[i, j, a, b]


@_jit
def _vee_product(a, b, out):
    """The axial vector of the skew matrix a·bᵀ (added to ``out``, 3)."""
    # W = a·bᵀ; vee(W) = (W21, W02, W10)
    w21 = a[2, 0] * b[1, 0] + a[2, 1] * b[1, 1] + a[2, 2] * b[1, 2]
    w02 = a[0, 0] * b[2, 0] + a[0, 1] * b[2, 1] + a[0, 2] * b[2, 2]
    w10 = a[1, 0] * b[0, 0] + a[1, 1] * b[0, 1] + a[1, 2] * b[0, 2]
    out[0] += w21
    out[1] += w02
    out[2] += w10


@_jit
def workspace3d(bodies):
    """Work arrays of :func:`bushings3d` (for ``bodies`` spatial bodies), the tilted slices and meshes (one
    assembly's)."""
    nb = bodies + 1  # and ground: R = I, no derivatives
    return (np.zeros((3, 3, 3, 3)),  # fac: the axis factors of R
            np.zeros((nb, 3, 3)), np.zeros((nb, 3, 3, 3)), np.zeros((nb, 3, 3, 3, 3)),  # R, ∂R, ∂²R of each body
            np.zeros((nb, 3, 3)), np.zeros((nb, 3, 3, 3)),  # G and ∂G/∂ψ (column i by ψ_j) of each body
            np.zeros((2, 3)), np.zeros((2, 3, 6)),  # p, ∂p/∂q of each marker
            np.zeros((2, 3, 6)), np.zeros((2, 3, 6)),  # ∂(R₀f_L)/∂q_t, ∂(R₀m_L)/∂q_t
            # from 10: a section's pose q, s, ∂s/∂q and its force, K, D on the body; from 16: a tilted mesh's buffers
            np.zeros(6), np.zeros(3), np.zeros((3, 6)), np.zeros(6), np.zeros((6, 6)), np.zeros((6, 6)),
            np.zeros(6), np.zeros(6), np.zeros(6), np.zeros((6, 6)), np.zeros((6, 6)), np.zeros(MESH_STATE),  # mesh
            np.zeros(3),
            # from 23: a bushing's Δ, d, f_L, m_L, R₀f_L, R₀m_L, ∂f_L/∂d, R₀ᵀR₁, ∂θ/∂q_t and its markers' body slots
            np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), np.zeros((3, 3)),
            np.zeros((3, 3)), np.zeros((3, 6)), np.zeros(2, dtype=np.int64))


@_jit
def _body_frames(qa, first, fac, rot, drot, ddrot, gm, dgm):
    """R, ∂R/∂ψ, ∂²R/∂ψ², G (ω = G·ψ̇, column i the axial vector of ∂R/∂ψᵢ·Rᵀ) and ∂G/∂ψ of each spatial body
    (its coordinates from ``first``, absolute ``qa``), once per assembly: every marker on a body shares them; the
    slot past the last body is ground's."""
    nb = first.shape[0]
    col = np.zeros(3)
    for sl in range(nb + 1):
        if sl == nb:
            rot[sl, :, :] = 0.0
            for i in range(3):
                rot[sl, i, i] = 1.0
            drot[sl, :, :, :] = 0.0
            ddrot[sl, :, :, :, :] = 0.0
            gm[sl, :, :] = 0.0
            dgm[sl, :, :, :] = 0.0
            continue
        b = first[sl]
        rotation_set(qa[b + 3:b + 6], fac, rot[sl], drot[sl], ddrot[sl], True)
        for i in range(3):
            col[:] = 0.0
            _vee_product(drot[sl, i], rot[sl], col)
            for k in range(3):
                gm[sl, k, i] = col[k]
            for j in range(3):  # ∂/∂ψⱼ vee(∂R/∂ψᵢ·Rᵀ) = vee(∂²R/∂ψᵢ∂ψⱼ·Rᵀ + ∂R/∂ψᵢ·∂Rᵀ/∂ψⱼ)
                v = dgm[sl, i, j]
                v[:] = 0.0
                _vee_product(ddrot[sl, i, j], rot[sl], v)
                _vee_product(drot[sl, i], drot[sl, j], v)


@_jit
def bushings3d(qa, b3, f, kt, w):
    """Add the 3D point connectors' forces (``f``, RHS) and LHS Jacobian (``kt`` = −∂f/∂q) at absolute coordinates
    ``qa`` (module docstring).

    ``b3`` = (first ODE2 index of each marker's Rxyz body or −1 for ground (c, 2), its body's slot among ``first``
    or −1 (c, 2), the first ODE2 index of each such body (bodies,), each marker's local point or, on ground, global
    point (c, 2, 3) m, the laws acting between the two points (c,) (B3_CLEARANCE, B3_CARTESIAN or both: a bearing
    and its regulariser share their markers), their parameters (c, 13): clearance (k N/m, ε m, w m, k_ax N/m,
    k_tx, k_ty N·m/rad), Cartesian (k_x, k_y, k_z N/m, offset x, y, z m), the clearance law's torsion k_tz N·m/rad
    (0 for a bearing; a beam crank's segment twists)); ``w`` :func:`workspace3d` for those bodies."""
    idx, slot, first, lps, kind, par = b3
    fac, brot, bdrot, bddrot, bgm, bdgm, pos, jp, dfp, dfr = w[:10]
    _body_frames(qa, first, fac, brot, bdrot, bddrot, bgm, bdgm)
    ground = first.shape[0]
    delta, d, fl, ml, fp, fr, amat, rel, theta, sl = w[23], w[24], w[25], w[26], w[27], w[28], w[29], w[30], w[31], w[32]
    for c in range(idx.shape[0]):
        for s in range(2):  # each marker's point and ∂p/∂q = [I | ∂R/∂ψⱼ·lp]
            sl[s] = slot[c, s] if slot[c, s] >= 0 else ground
            r, dr, lp, b = brot[sl[s]], bdrot[sl[s]], lps[c, s], idx[c, s]
            for k in range(3):
                pos[s, k] = (qa[b + k] if b >= 0 else 0.0) + r[k, 0] * lp[0] + r[k, 1] * lp[1] + r[k, 2] * lp[2]
                for j in range(3):
                    jp[s, k, j] = 1.0 if k == j and b >= 0 else 0.0
                    jp[s, k, 3 + j] = dr[j, k, 0] * lp[0] + dr[j, k, 1] * lp[1] + dr[j, k, 2] * lp[2]
        rot0, rot1, drot0 = brot[sl[0]], brot[sl[1]], bdrot[sl[0]]
        for k in range(3):
            delta[k] = pos[1, k] - pos[0, k]
        dfp[:, :, :] = 0.0
        dfr[:, :, :] = 0.0
        fp[:] = 0.0
        fr[:] = 0.0
        if kind[c] & B3_CLEARANCE:
            r0 = rot0
            for k in range(3):
                d[k] = r0[0, k] * delta[0] + r0[1, k] * delta[1] + r0[2, k] * delta[2]
                for m in range(3):
                    rel[k, m] = r0[0, k] * rot1[0, m] + r0[1, k] * rot1[1, m] + r0[2, k] * rot1[2, m]
            thx = math.atan2(-rel[1, 2], rel[2, 2])
            thy = math.atan2(rel[0, 2], math.sqrt(abs(1.0 - rel[0, 2] * rel[0, 2])))
            thz = math.atan2(-rel[0, 1], rel[0, 0])  # the xyz angles of R₀ᵀR₁, as Exudyn's connector takes them
            k_r, eps, wid = par[c, 0], par[c, 1], par[c, 2]
            amat[:, :] = 0.0
            if eps == 0.0:
                g, gp, dr = k_r, 0.0, 1.0
            else:
                dr = math.sqrt(d[0] * d[0] + d[1] * d[1])
                rw, drw = clearance_ramp(dr - eps, wid)
                if rw == 0.0 and drw == 0.0:
                    g, gp = 0.0, 0.0
                else:
                    g = k_r * rw / dr
                    gp = (k_r * drw - g) / dr  # dg/d|d|
            fl[0], fl[1], fl[2] = g * d[0], g * d[1], par[c, 3] * d[2]
            ml[0], ml[1], ml[2] = par[c, 4] * thx, par[c, 5] * thy, par[c, 12] * thz
            amat[0, 0] = g + gp * d[0] * d[0] / dr
            amat[0, 1] = gp * d[0] * d[1] / dr
            amat[1, 0] = amat[0, 1]
            amat[1, 1] = g + gp * d[1] * d[1] / dr
            amat[2, 2] = par[c, 3]
            for k in range(3):
                fp[k] = r0[k, 0] * fl[0] + r0[k, 1] * fl[1] + r0[k, 2] * fl[2]
                fr[k] = r0[k, 0] * ml[0] + r0[k, 1] * ml[1] + r0[k, 2] * ml[2]
            # ∂θ/∂ψ: δθ = G(θ)⁻¹·R₀ᵀ(G₁δψ₁ − G₀δψ₀), G(θ)⁻¹ of the xyz angles
            sx, cx, sy, cy = math.sin(thx), math.cos(thx), math.sin(thy), math.cos(thy)
            gi00, gi01, gi02 = 1.0, sy * sx / cy, -sy * cx / cy
            gi10, gi11, gi12 = 0.0, cx, sx
            gi21, gi22 = -sx / cy, cx / cy
            for t in range(2):
                sg = 1.0 if t == 1 else -1.0
                theta[:, :] = 0.0
                for j in range(3):  # R₀ᵀG_t column j, then G(θ)⁻¹ rows
                    v0 = r0[0, 0] * bgm[sl[t], 0, j] + r0[1, 0] * bgm[sl[t], 1, j] + r0[2, 0] * bgm[sl[t], 2, j]
                    v1 = r0[0, 1] * bgm[sl[t], 0, j] + r0[1, 1] * bgm[sl[t], 1, j] + r0[2, 1] * bgm[sl[t], 2, j]
                    v2 = r0[0, 2] * bgm[sl[t], 0, j] + r0[1, 2] * bgm[sl[t], 1, j] + r0[2, 2] * bgm[sl[t], 2, j]
                    theta[0, 3 + j] = sg * (gi00 * v0 + gi01 * v1 + gi02 * v2)
                    theta[1, 3 + j] = sg * (gi10 * v0 + gi11 * v1 + gi12 * v2)
                    theta[2, 3 + j] = sg * (gi21 * v1 + gi22 * v2)
                for j in range(6):
                    # ∂d/∂q_t = ±R₀ᵀ∂p_t/∂q_t (+ ∂R₀ᵀ/∂ψ₀·Δ on marker 0's rotations)
                    dd0 = sg * (r0[0, 0] * jp[t, 0, j] + r0[1, 0] * jp[t, 1, j] + r0[2, 0] * jp[t, 2, j])
                    dd1 = sg * (r0[0, 1] * jp[t, 0, j] + r0[1, 1] * jp[t, 1, j] + r0[2, 1] * jp[t, 2, j])
                    dd2 = sg * (r0[0, 2] * jp[t, 0, j] + r0[1, 2] * jp[t, 1, j] + r0[2, 2] * jp[t, 2, j])
                    if t == 0 and j >= 3:
                        dm = drot0[j - 3]
                        dd0 += dm[0, 0] * delta[0] + dm[1, 0] * delta[1] + dm[2, 0] * delta[2]
                        dd1 += dm[0, 1] * delta[0] + dm[1, 1] * delta[1] + dm[2, 1] * delta[2]
                        dd2 += dm[0, 2] * delta[0] + dm[1, 2] * delta[1] + dm[2, 2] * delta[2]
                    a0 = amat[0, 0] * dd0 + amat[0, 1] * dd1
                    a1 = amat[1, 0] * dd0 + amat[1, 1] * dd1
                    a2 = amat[2, 2] * dd2
                    b0 = par[c, 4] * theta[0, j]
                    b1 = par[c, 5] * theta[1, j]
                    b2 = par[c, 12] * theta[2, j]
                    for k in range(3):
                        dfp[t, k, j] = r0[k, 0] * a0 + r0[k, 1] * a1 + r0[k, 2] * a2
                        dfr[t, k, j] = r0[k, 0] * b0 + r0[k, 1] * b1 + r0[k, 2] * b2
                    if t == 0 and j >= 3:  # R₀ turns with marker 0
                        dm = drot0[j - 3]
                        for k in range(3):
                            dfp[t, k, j] += dm[k, 0] * fl[0] + dm[k, 1] * fl[1] + dm[k, 2] * fl[2]
                            dfr[t, k, j] += dm[k, 0] * ml[0] + dm[k, 1] * ml[1] + dm[k, 2] * ml[2]
        if kind[c] & B3_CARTESIAN:  # global springs on the same two points
            for k in range(3):
                fp[k] += par[c, 6 + k] * (delta[k] - par[c, 9 + k])
                for t in range(2):
                    sg = 1.0 if t == 1 else -1.0
                    for j in range(6):
                        dfp[t, k, j] += sg * par[c, 6 + k] * jp[t, k, j]
        for s in range(2):
            b = idx[c, s]
            if b < 0:
                continue
            sg = -1.0 if s == 1 else 1.0  # the wrench acts on marker 1 as −(R₀f_L, R₀m_L), on marker 0 as +
            gs = bgm[sl[s]]
            for a in range(6):
                gen = jp[s, 0, a] * fp[0] + jp[s, 1, a] * fp[1] + jp[s, 2, a] * fp[2]
                if a >= 3:
                    gen += gs[0, a - 3] * fr[0] + gs[1, a - 3] * fr[1] + gs[2, a - 3] * fr[2]
                f[b + a] += sg * gen
            for t in range(2):
                bt = idx[c, t]
                if bt < 0:
                    continue
                for a in range(6):
                    for j in range(6):
                        v = jp[s, 0, a] * dfp[t, 0, j] + jp[s, 1, a] * dfp[t, 1, j] + jp[s, 2, a] * dfp[t, 2, j]
                        if a >= 3:
                            v += gs[0, a - 3] * dfr[t, 0, j] + gs[1, a - 3] * dfr[t, 1, j] + gs[2, a - 3] * dfr[t, 2, j]
                        kt[b + a, bt + j] -= sg * v
            # ∂p/∂ψ and G turn with the marker's own body: ∂²p/∂ψᵢ∂ψⱼ·F + ∂Gᵢ/∂ψⱼ·M
            lp, ddr, dg = lps[c, s], bddrot[sl[s]], bdgm[sl[s]]
            torque = fr[0] != 0.0 or fr[1] != 0.0 or fr[2] != 0.0
            for i in range(3):
                for j in range(3):
                    dij = ddr[i, j]
                    h = 0.0
                    for k in range(3):
                        h += (dij[k, 0] * lp[0] + dij[k, 1] * lp[1] + dij[k, 2] * lp[2]) * fp[k]
                    if torque:
                        h += dg[i, j, 0] * fr[0] + dg[i, j, 1] * fr[1] + dg[i, j, 2] * fr[2]
                    kt[b + 3 + i, b + 3 + j] -= sg * h


@_jit
def pair_elements(x, bp, f, kt):
    """Add the main bearing pair elements' forces and LHS Jacobians at displacements ``x``: ``bp`` = (first ODE2
    index of each carrier node (e,), seat offsets (e, 5) m, inner and outer groove centres (e, n, 3) m, (A m, K,
    law code) (e, 3), and the kernel's buffers)."""
    idx, seat, inner, outer, par, f5, k5, load, unit, squeeze, q5 = bp
    for e in range(idx.shape[0]):
        b = idx[e]
        for i in range(5):
            q5[i] = x[b + i] - seat[e, i]
        pair_kernel(q5, inner[e], outer[e], par[e, 0], par[e, 1], int(par[e, 2]), f5, k5, load[e], unit[e],
                    squeeze[e])
        for i in range(5):
            f[b + i] += f5[i]
            for j in range(5):
                kt[b + i, b + j] += k5[i, j]


@_jit
def slice_section(qa, b, lever, w):
    """The in-plane pose (x, y, θ) of a tilting disc's section at ``lever`` (m) from its node, whose coordinates
    start at ``b`` in the absolute ``qa``: filled into the section buffers of ``w`` (:func:`workspace3d`)."""
    q6, s, jac = w[10], w[11], w[12]
    for i in range(6):
        q6[i] = qa[b + i]
    section_pose(q6, lever, s, jac)
    return s


@_jit
def slice_to_body(b, lever, fd, kd, dd, f, kt, w):
    """Add a slice's force ``fd`` (3,) and LHS Jacobian ``kd`` (3, 3) on its section (:func:`slice_section`, same
    ``w``) to the body's six coordinates from ``b`` (:func:`rvflex.contact.tilt_map.map_to_body`)."""
    q6, jac, f6, k6, d6 = w[10], w[12], w[13], w[14], w[15]
    map_to_body(q6, lever, jac, fd, kd, dd, f6, k6, d6)
    for a in range(6):
        f[b + a] += f6[a]
        for c in range(6):
            kt[b + a, b + c] += k6[a, c]


@_jit
def mesh_tilted(x, sun, planet, lever, par, f, kt, w):
    """Add the involute mesh of the planar sun (coordinates from ``sun``) and a tilting crank's gear (the crank's
    Rxyz coordinates from ``planet``, the gear ``lever`` m along its axis) at displacements ``x``: the mesh kernel
    on the gear's section, mapped back onto the crank (as :func:`rvflex.contact.gear_mesh.add_gear_mesh`'s
    spatial element)."""
    q6, s, jac = w[10], w[11], w[12]
    meshq, meshqt, meshf, meshdf, meshdft, meshst, meshf3 = w[16], w[17], w[18], w[19], w[20], w[21], w[22]
    for i in range(6):
        q6[i] = x[planet + i]
    section_pose(q6, lever, s, jac)
    for i in range(3):
        meshq[i] = x[sun + i]
        meshq[3 + i] = s[i]
        meshqt[i] = 0.0
        meshqt[3 + i] = 0.0
    mesh_kernel(meshq, meshqt, par, meshf, meshdf, meshdft, meshst, True)
    for i in range(3):
        f[sun + i] += meshf[i]
        for j in range(3):
            kt[sun + i, sun + j] -= meshdf[i, j]
        for c in range(6):  # sun rows against the crank: −∂f_s/∂s·T
            v = meshdf[i, 3] * jac[0, c] + meshdf[i, 4] * jac[1, c] + meshdf[i, 5] * jac[2, c]
            kt[sun + i, planet + c] -= v
    for a in range(6):
        f[planet + a] += jac[0, a] * meshf[3] + jac[1, a] * meshf[4] + jac[2, a] * meshf[5]
        for j in range(3):  # crank rows against the sun: −Tᵀ∂f_p/∂q_s
            v = jac[0, a] * meshdf[3, j] + jac[1, a] * meshdf[4, j] + jac[2, a] * meshdf[5, j]
            kt[planet + a, sun + j] -= v
        for c in range(6):  # −Tᵀ∂f_p/∂s·T
            v = 0.0
            for i in range(3):
                if jac[i, a] == 0.0:
                    continue
                for j in range(3):
                    v += jac[i, a] * meshdf[3 + i, 3 + j] * jac[j, c]
            kt[planet + a, planet + c] -= v
    for i in range(3):
        meshf3[i] = meshf[3 + i]
    add_curvature(q6, lever, meshf3, 1.0, kt, planet)


# ------------------------------------------------------------ reading the Exudyn system (rvflex.engine)


def marker3d(mbs, marker: int, objects: list[dict], bodies: dict, nodes: dict) -> tuple[int, np.ndarray] | None:
    """A marker of a 3D point connector (:func:`bushings3d`) as :func:`rvflex.engine.compiled_step` reads the system
    (``objects``: the objects' parameters, ``bodies``/``nodes``: its bodies by object and node): (the first
    coordinate of its spatial rigid body, −1 on ground; its local point, on ground its global one (m)); None when
    it is not one of those."""
    m = mbs.GetMarker(marker)
    kind = m["markerType"]
    if kind == "BodyRigid":
        b = int(m["bodyNumber"])
        lp = np.asarray(m["localPosition"], float)
        if objects[b]["objectType"] == "Ground":
            if not np.array_equal(np.asarray(objects[b].get("referenceRotation", np.eye(3)), float), np.eye(3)):
                return None
            return -1, np.asarray(objects[b]["referencePosition"], float) + lp
        body = bodies.get(b)
        return (body.x, lp.copy()) if body is not None and body.spatial else None
    if kind == "NodeRigid":
        body = nodes.get(int(m["nodeNumber"]))
        return (body.x, np.zeros(3)) if body is not None and body.spatial else None
    return None


def connector_law3d(o: dict, clearance: tuple[float, ...] | None) -> tuple[int, list[float]] | None:
    """Law and parameters of a 3D point connector (:func:`bushings3d`: its bit and row) from its object parameters
    ``o`` and, for a RigidBodySpringDamper, rvflex's clearance law (ε, w, e, x_r) (None: not one); None for a
    connector it does not replicate (the power law, e ≠ 1, is replicated in the plane only)."""
    if o["objectType"] == "ConnectorCartesianSpringDamper":
        if o.get("springForceUserFunction", 0) != 0:
            return None
        return B3_CARTESIAN, [0.0] * 6 + [*np.asarray(o["stiffness"], float), *np.asarray(o["offset"], float), 0.0]
    if clearance is None or o.get("useIntrinsicFormulation") or clearance[2] != 1.0:
        return None
    for key in ("rotationMarker0", "rotationMarker1"):  # J0, J1 = the markers' own frames
        if not np.array_equal(np.asarray(o[key], float), np.eye(3)):
            return None
    k = np.asarray(o["stiffness"], float)
    if k[0, 0] != k[1, 1] or np.count_nonzero(k - np.diag(np.diag(k))):  # the law: isotropic radially, diagonal
        return None
    return B3_CLEARANCE, [k[0, 0], clearance[0], clearance[1], k[2, 2], k[3, 3], k[4, 4]] + [0.0] * 6 + [k[5, 5]]


def spatial_data(mbs, sides3: list, kinds: list, pars: list, pairs: list, levers: list, first: list,
                  ms_tilt: list, ms_lever: list) -> dict:
    """The spatial group of :func:`rvflex.engine.compiled_step`'s data, by the engine's keys: the 3D point
    connectors (``sides3``: each one's two :func:`marker3d`; ``kinds``, ``pars``: :func:`connector_law3d`'s), the
    pair elements (:class:`rvflex.parts.main_bearing.PairElement`), each contact's tilting body (its first
    coordinate in ``first``) and lever (``levers``; None: a planar disc, −1 and 0 then), each mesh's."""
    nb_ = max([p.model.n_balls for p in pairs], default=0)
    bp_inner, bp_outer = np.zeros((len(pairs), nb_, 3)), np.zeros((len(pairs), nb_, 3))
    for e, p in enumerate(pairs):
        bp_inner[e], bp_outer[e] = p.model.inner_centres_m, p.model.outer_centres_m
    merged = {}  # a bearing and its regulariser between the same two points: one row with both laws
    for pts, kind, par in zip(sides3, kinds, pars, strict=True):
        key = tuple((p[0], *np.asarray(p[1], float).tolist()) for p in pts)
        old = merged.get(key)
        if old is None or old[1] & kind:
            merged[key if old is None else (key, len(merged))] = (pts, kind, list(par))
        else:
            merged[key] = (pts, old[1] | kind, [a + b for a, b in zip(old[2], par, strict=True)])
    sides3, kinds, pars = ([m[i] for m in merged.values()] for i in range(3))
    bodies = sorted({p[0] for pts in sides3 for p in pts if p[0] >= 0})  # the connected bodies' first coordinates
    return {
        "b3_idx": np.array([[p[0] for p in pts] for pts in sides3], dtype=np.int64).reshape(-1, 2),
        "b3_slot": np.array([[bodies.index(p[0]) if p[0] >= 0 else -1 for p in pts] for pts in sides3],
                            dtype=np.int64).reshape(-1, 2),
        "b3_first": np.array(bodies, dtype=np.int64),
        "b3_lp": np.array([[p[1] for p in pts] for pts in sides3], float).reshape(-1, 2, 3),
        "b3_kind": np.array(kinds, dtype=np.int64), "b3_par": np.array(pars, float).reshape(-1, 13),
        "bp_idx": np.array([mbs.GetNodeODE2Index(p.node) for p in pairs], dtype=np.int64),
        "bp_seat": np.array([p.seat_m for p in pairs], float).reshape(-1, 5),
        "bp_inner": bp_inner, "bp_outer": bp_outer,
        "bp_par": np.array([[p.model.centre_distance_m, p.model.stiffness, p.model.law_code] for p in pairs],
                           float).reshape(-1, 3),
        "bp_f5": np.zeros(5), "bp_k5": np.zeros((5, 5)), "bp_load": np.zeros((len(pairs), nb_)),
        "bp_unit": np.zeros((len(pairs), nb_, 3)), "bp_squeeze": np.zeros((len(pairs), nb_)), "bp_q5": np.zeros(5),
        "ct_tilt": np.array([-1 if lever is None else b for lever, b in zip(levers, first, strict=True)],
                            dtype=np.int64),
        "ct_lever": np.array([0.0 if lever is None else lever for lever in levers], float),
        "ms_tilt": np.array(ms_tilt, dtype=np.bool_), "ms_lever": np.array(ms_lever, float),
    }

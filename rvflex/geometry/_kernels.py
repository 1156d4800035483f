"""Numba kernels: exact evaluation of the (modified, erroneous) cycloid profile and the
closest-point gap between pins and that profile.

The profile is described by a parameter vector ``par`` (see ``P_*`` indices) and two
harmonic tables (profile error and pitch warp). In the disc's own frame, with
parameter t ∈ [0, 2π) and tooth phase τ = z_c·t (τ = 0 at a tooth root):

    pin-centre curve   p(t) = R·e^{it} − e·e^{i z_b t}
    outward normal     n(t) = −i·p'(t)/|p'(t)|
    generating radius  r(t) = r0 + pressure-angle zones + compensation − profile error
    profile            Q(t) = e^{iψ(t)}·(p(t) − r(t)·n(t))          (ψ: pitch warp)

All derivatives are analytic, so Newton on the closest-point condition
(Q(t) − c)·Q'(t) = 0 converges to machine precision in a few iterations.
Points are complex numbers (x + iy) throughout.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

P_R, P_E, P_ZB, P_ZC, P_R0, P_K, P_COMP, P_TIP_U, P_TIP_A, P_ROOT_U, P_ROOT_A, P_W = range(12)
N_PAR = 12
NEWTON_TOL_T = 1e-11  # rad of t: 7e-13 m of arc on an RV-40E disc; the gap error is second order
NEWTON_MAXIT = 30
SCAN_SAMPLES = 256  # per two tooth pitches each side, for the fallback scan
COLD_SAMPLES_PER_PITCH = 16  # cold-start scan of the pin-centre curve, ±1 pitch about the polar angle

_jit = nb.njit(cache=True, fastmath={"contract", "afn", "arcp", "nsz"}, nogil=True)  # no "nnan": NaN marks a cold start


@_jit
def _blend(s):
    """C² quintic blend b(s) = 10s³ − 15s⁴ + 6s⁵ on [0, 1] with b', b'' (zero slope and curvature at both ends)."""
    s2 = s * s
    b = s2 * s * (10.0 - 15.0 * s + 6.0 * s2)
    db = 30.0 * s2 * (1.0 - 2.0 * s + s2)
    ddb = 60.0 * s * (1.0 - 3.0 * s + 2.0 * s2)
    return b, db, ddb


@_jit
def _radius(t, par, herr):
    """Generating pin radius r(t) and its first two t-derivatives."""
    zc = par[P_ZC]
    r = par[P_R0]
    dr = 0.0
    ddr = 0.0
    tau = zc * t
    # pressure-angle zones, symmetric about root (u = 0) and tip (u = π)
    tw = tau % (2.0 * math.pi)
    if tw <= math.pi:
        u = tw
        sgn = 1.0
    else:
        u = 2.0 * math.pi - tw
        sgn = -1.0
    a_tip = par[P_TIP_A]
    if a_tip != 0.0 and u > par[P_TIP_U]:
        span = math.pi - par[P_TIP_U]
        b, db, ddb = _blend((u - par[P_TIP_U]) / span)
        r += a_tip * b
        dr += a_tip * db / span * sgn * zc
        ddr += a_tip * ddb / (span * span) * zc * zc
    a_root = par[P_ROOT_A]
    if a_root != 0.0 and u < par[P_ROOT_U]:
        span = par[P_ROOT_U]
        b, db, ddb = _blend((span - u) / span)
        r += a_root * b
        dr += -a_root * db / span * sgn * zc
        ddr += a_root * ddb / (span * span) * zc * zc
    # deformation compensation δ·|sin τ|/S(τ), |q| smoothed as q²/√(q² + w²)
    comp = par[P_COMP]
    if comp != 0.0:
        k = par[P_K]
        w2 = par[P_W] * par[P_W]
        q = math.sin(tau)
        cq = math.cos(tau)
        h = q * q + w2
        g = q * q / math.sqrt(h)
        gq = q * (q * q + 2.0 * w2) / h ** 1.5
        gqq = w2 * (2.0 * w2 - q * q) / h ** 2.5
        g1 = gq * cq
        g2 = gqq * cq * cq - gq * q
        s = math.sqrt(1.0 + k * k - 2.0 * k * cq)
        s1 = k * q / s
        s2 = (k * cq - s1 * s1) / s
        c0 = g / s
        c1 = g1 / s - g * s1 / (s * s)
        c2 = g2 / s - 2.0 * g1 * s1 / (s * s) - g * s2 / (s * s) + 2.0 * g * s1 * s1 / (s * s * s)
        r += comp * c0
        dr += comp * c1 * zc
        ddr += comp * c2 * zc * zc
    # profile error (positive = material added = smaller generating radius)
    h, h1, h2 = _harmonic(t, herr)
    return r - h, dr - h1, ddr - h2


@_jit
def _harmonic(t, table):
    """Σ a_k cos(k t) + b_k sin(k t) over the rows (a_k, b_k) of ``table``, with its first
    two derivatives: the smooth per-tooth interpolants of profile and pitch errors."""
    v = 0.0
    d1 = 0.0
    d2 = 0.0
    for kk in range(table.shape[0]):
        ck = table[kk, 0]
        sk = table[kk, 1]
        if ck == 0.0 and sk == 0.0:
            continue
        c = math.cos(kk * t)
        sn = math.sin(kk * t)
        v += ck * c + sk * sn
        d1 += kk * (-ck * sn + sk * c)
        d2 -= kk * kk * (ck * c + sk * sn)
    return v, d1, d2


@_jit
def profile_point(t, par, herr, hpsi):
    """Profile point Q(t) and its derivatives Q'(t), Q''(t) as complex numbers (m)."""
    R = par[P_R]
    e = par[P_E]
    zb = par[P_ZB]
    ei = complex(math.cos(t), math.sin(t))
    eb = complex(math.cos(zb * t), math.sin(zb * t))
    p = R * ei - e * eb
    v = 1j * (R * ei - zb * e * eb)  # p'
    a = -(R * ei) + zb * zb * e * eb  # p''
    j = -1j * (R * ei) + 1j * zb * zb * zb * e * eb  # p'''
    vv = v.real * v.real + v.imag * v.imag
    sv = math.sqrt(vv)
    T = v / sv
    # T' = i·ω·T, ω = Im(conj(v)·a)/|v|²
    im_va = (v.conjugate() * a).imag
    re_va = (v.conjugate() * a).real
    om = im_va / vv
    om1 = ((v.conjugate() * j).imag * vv - im_va * 2.0 * re_va) / (vv * vv)
    n = -1j * T
    n1 = om * T
    n2 = om1 * T + 1j * om * om * T
    r, r1, r2 = _radius(t, par, herr)
    q = p - r * n
    q1 = v - r1 * n - r * n1
    q2 = a - r2 * n - 2.0 * r1 * n1 - r * n2
    psi, w1, w2 = _harmonic(t, hpsi)
    if psi == 0.0 and w1 == 0.0 and w2 == 0.0:
        return q, q1, q2
    rot = complex(math.cos(psi), math.sin(psi))
    return (rot * q, rot * (q1 + 1j * w1 * q),
            rot * (q2 + 1j * w2 * q + 2j * w1 * q1 - w1 * w1 * q))


@_jit
def _wrap(x):
    """Wrap an angle to [−π, π)."""
    return (x + math.pi) % (2.0 * math.pi) - math.pi


@_jit
def _cold_start(c, par):
    """Start parameter of a cold closest-point solve for a point ``c`` anywhere near the
    profile: the best of ``2·COLD_SAMPLES_PER_PITCH + 1`` samples of |p(t) − c|² over
    t ∈ arg c ± one pitch, p the pin-centre curve.

    Why p and not the polar relation |p(t)| = |c|: that inversion is exact only for points
    on p (pin centres). A flank point lies a generating radius r ≈ 2e inside p, where |c|
    leaves the range [R − e, R + e] (RV-40E: every tip point) or sits at its edge, and the
    inversion lands on the tooth root, up to half a pitch from the answer; Newton then
    wandered off by several teeth for 7 of the RV-80E disc's 2936 flank nodes. The profile
    is parallel to p (up to µm modifications and errors), so both share the closest
    parameter, and that parameter lies within asin(e/R) + asin(|c − p|/|c|) of arg c,
    under one pitch for any point within 10 mm of an RV disc's pin-centre curve. The
    samples step by complex rotation (no trigonometry inside the loop).
    """
    R = par[P_R]
    e = par[P_E]
    zb = par[P_ZB]
    h = 2.0 * math.pi / (par[P_ZC] * COLD_SAMPLES_PER_PITCH)
    t0 = math.atan2(c.imag, c.real) - COLD_SAMPLES_PER_PITCH * h
    ei = complex(math.cos(t0), math.sin(t0))
    eb = complex(math.cos(zb * t0), math.sin(zb * t0))
    di = complex(math.cos(h), math.sin(h))
    db = complex(math.cos(zb * h), math.sin(zb * h))
    best = 1e300
    kb = 0
    for k in range(2 * COLD_SAMPLES_PER_PITCH + 1):
        w = R * ei - e * eb - c
        dd = w.real * w.real + w.imag * w.imag
        if dd < best:
            best = dd
            kb = k
        ei *= di
        eb *= db
    return t0 + kb * h, h


@_jit
def _newton(c, t, par, herr, hpsi, max_step):
    """Safeguarded Newton on (Q(t) − c)·Q'(t) = 0; returns t, Q, Q', Q'' at t and convergence."""
    q, q1, q2 = profile_point(t, par, herr, hpsi)
    for _ in range(NEWTON_MAXIT):
        dq = q - c
        f = dq.real * q1.real + dq.imag * q1.imag
        df = q1.real * q1.real + q1.imag * q1.imag + dq.real * q2.real + dq.imag * q2.imag
        if df <= 0.0:  # not in a minimum's basin: step along the descent direction
            step = max_step if f < 0.0 else -max_step
        else:
            step = min(max_step, max(-max_step, -f / df))
        if abs(step) < NEWTON_TOL_T:  # converged: q, q1, q2 are those of the final t
            return t, q, q1, q2, True
        t += step
        q, q1, q2 = profile_point(t, par, herr, hpsi)
    return t, q, q1, q2, False


@_jit
def _closest_on_offset(c, t, par, max_step):
    """Closest point when the generating radius is constant (equidistant and moved
    modifications, no disc errors): the profile is the exact offset of the pin-centre curve
    p, so both share the closest parameter and normal. Newton runs on p alone (4 trig
    calls per iteration instead of a full profile evaluation); same outputs as
    :func:`closest_point`."""
    R = par[P_R]
    e = par[P_E]
    zb = par[P_ZB]
    r0 = par[P_R0]
    ok = False
    for _ in range(NEWTON_MAXIT):
        ei = complex(math.cos(t), math.sin(t))
        eb = complex(math.cos(zb * t), math.sin(zb * t))
        p = R * ei - e * eb
        v = 1j * (R * ei - zb * e * eb)
        a = -(R * ei) + zb * zb * e * eb
        w = p - c
        f = w.real * v.real + w.imag * v.imag
        df = v.real * v.real + v.imag * v.imag + w.real * a.real + w.imag * a.imag
        if df <= 0.0:
            break
        step = min(max_step, max(-max_step, -f / df))
        if abs(step) < NEWTON_TOL_T:
            ok = True
            break
        t += step
    vv = v.real * v.real + v.imag * v.imag
    sv = math.sqrt(vv)
    n = -1j * v / sv
    kp = (v.real * a.imag - v.imag * a.real) / (vv * sv)
    dq = c - p
    d = dq.real * n.real + dq.imag * n.imag + r0
    return t, d, p - r0 * n, n, kp / (1.0 - r0 * kp), ok


@_jit
def closest_point(c, par, herr, hpsi, t0=math.nan):
    """Exact closest point on the profile to point ``c`` (disc frame).

    ``t0`` is an optional warm start (e.g. the previous step's parameter); NaN means a
    cold start from a scan of one pitch either side of the polar angle of ``c``
    (:func:`_cold_start`).

    Returns
    -------
    t : float
        Profile parameter of the closest point.
    d : float
        Signed distance from the profile to c along the profile's outward normal (m);
        positive outside the disc material.
    q : complex
        Closest profile point (m).
    nq : complex
        Outward unit normal of the profile at q.
    kappa : float
        Signed curvature of the profile at q (1/m), positive where the disc is convex.
    ok : bool
        Newton converged to a minimum.
    """
    if not math.isnan(t0):
        res = _closest_from(c, par, herr, hpsi, t0, 0.25 * math.pi / par[P_ZC], True)
        # a warm start that ends more than a quarter tooth away from where it started (cached at
        # a wild Newton iterate, another tooth's minimum) or does not converge must not decide
        # the answer: the contact force would depend on the solver's history and Newton can cycle
        if res[5] and abs(_wrap(res[0] - t0)) < 0.5 * math.pi / par[P_ZC]:
            return res
    t, h = _cold_start(c, par)
    return _closest_from(c, par, herr, hpsi, t, h, False)


@_jit
def _closest_from(c, par, herr, hpsi, t, max_step, warm):
    """:func:`closest_point` from the start parameter ``t``, Newton steps at most
    ``max_step``. A warm start first projects c onto the pin-centre curve's tangent
    (brings a previous step's t within ~1e-7 of the answer); a cold start from
    :func:`_cold_start` does not: that projection is an unbounded step, safe only near
    the answer."""
    if warm:
        R = par[P_R]
        e = par[P_E]
        zb = par[P_ZB]
        ei = complex(math.cos(t), math.sin(t))
        eb = complex(math.cos(zb * t), math.sin(zb * t))
        v = 1j * (R * ei - zb * e * eb)
        w = c - (R * ei - e * eb)
        t += (w.real * v.real + w.imag * v.imag) / (v.real * v.real + v.imag * v.imag)
    pitch = 2.0 * math.pi / par[P_ZC]
    if (par[P_TIP_A] == 0.0 and par[P_ROOT_A] == 0.0 and par[P_COMP] == 0.0
            and herr.shape[0] == 0 and hpsi.shape[0] == 0):
        res = _closest_on_offset(c, t, par, max_step)
        if res[5]:
            return res
    t_mid = t
    t, q, q1, q2, ok = _newton(c, t, par, herr, hpsi, max_step)
    if not ok:  # far from the curve (not seen for points within a tooth height): scan about the start, then polish
        best = 1e300
        for k in range(-SCAN_SAMPLES, SCAN_SAMPLES + 1):
            tk = t_mid + k * (2.0 * pitch / SCAN_SAMPLES)
            qk = profile_point(tk, par, herr, hpsi)[0] - c
            dd = qk.real * qk.real + qk.imag * qk.imag
            if dd < best:
                best = dd
                t = tk
        t, q, q1, q2, ok = _newton(c, t, par, herr, hpsi, pitch / SCAN_SAMPLES)
    s = math.sqrt(q1.real * q1.real + q1.imag * q1.imag)
    nq = -1j * q1 / s
    dq = c - q
    d = dq.real * nq.real + dq.imag * nq.imag
    kappa = (q1.real * q2.imag - q1.imag * q2.real) / (s * s * s)
    return t, d, q, nq, kappa, ok


@_jit
def gaps(centres, radii, par, herr, hpsi, t_init, out_gap, out_t, out_q, out_n, out_kappa):
    """Signed gap of every pin (centre in the disc frame, radius) to the profile.

    gap = signed distance of the centre from the profile − pin radius (m); negative means
    interference. ``t_init`` holds warm-start parameters (NaN: cold start). Fills the
    ``out_*`` arrays; returns the number of pins whose Newton iteration did not converge
    (0 in normal use).
    """
    bad = 0
    for k in range(centres.shape[0]):
        c = complex(centres[k, 0], centres[k, 1])
        t, d, q, nq, kap, ok = closest_point(c, par, herr, hpsi, t_init[k])
        if not ok:
            bad += 1
        out_gap[k] = d - radii[k]
        out_t[k] = t
        out_q[k, 0] = q.real
        out_q[k, 1] = q.imag
        out_n[k, 0] = nq.real
        out_n[k, 1] = nq.imag
        out_kappa[k] = kap
    return bad


@_jit
def sample(ts, par, herr, hpsi, out_q, out_q1, out_q2):
    """Evaluate Q, Q', Q'' at the parameters ``ts`` (complex arrays out)."""
    for k in range(ts.shape[0]):
        q, q1, q2 = profile_point(ts[k], par, herr, hpsi)
        out_q[k] = q
        out_q1[k] = q1
        out_q2[k] = q2


@_jit
def radii(ts, par, herr, out):
    """Generating pin radius r(t) at the parameters ``ts`` (m)."""
    for k in range(ts.shape[0]):
        out[k] = _radius(ts[k], par, herr)[0]


@_jit
def brute_force_gaps(centres, radii, qs, q1s, out):
    """Reference gaps by exhaustive search over dense profile samples ``qs`` (with
    tangents ``q1s``): the nearest sample and the sign from its outward normal."""
    for k in range(centres.shape[0]):
        c = complex(centres[k, 0], centres[k, 1])
        best = 1e300
        jb = 0
        for j in range(qs.shape[0]):
            d = qs[j] - c
            dd = d.real * d.real + d.imag * d.imag
            if dd < best:
                best = dd
                jb = j
        nq = -1j * q1s[jb]
        d = c - qs[jb]
        sgn = 1.0 if d.real * nq.real + d.imag * nq.imag >= 0.0 else -1.0
        out[k] = sgn * math.sqrt(best) - radii[k]


@_jit
def _orient(ax, ay, bx, by, cx, cy):
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@_jit
def _crosses(xy, i, j):
    n = xy.shape[0]
    i1, j1 = (i + 1) % n, (j + 1) % n
    ax, ay, bx, by = xy[i, 0], xy[i, 1], xy[i1, 0], xy[i1, 1]
    cx, cy, dx, dy = xy[j, 0], xy[j, 1], xy[j1, 0], xy[j1, 1]
    return (_orient(ax, ay, bx, by, cx, cy) * _orient(ax, ay, bx, by, dx, dy) < 0.0
            and _orient(cx, cy, dx, dy, ax, ay) * _orient(cx, cy, dx, dy, bx, by) < 0.0)


SELF_INTERSECTION_CHUNK = 8  # segments per bounding box: on a smooth curve only neighbouring boxes overlap


@_jit
def any_self_intersection(xy, span):
    """Whether two segments of a closed polyline (the closing segment implied) cross, each compared with
    the next ``span`` segments, as :func:`first_self_intersection` compares them. Segments are grouped
    into bounding boxes of ``SELF_INTERSECTION_CHUNK``; only pairs in overlapping boxes are tested (a
    smooth profile of 10⁴ segments: some 2·10⁵ tests instead of 4·10⁶)."""
    n = xy.shape[0]
    c = SELF_INTERSECTION_CHUNK
    nc = (n + c - 1) // c
    box = np.empty((nc, 4))
    for k in range(nc):
        x0 = x1 = xy[k * c, 0]
        y0 = y1 = xy[k * c, 1]
        for m in range(k * c + 1, min(n, k * c + c) + 1):  # the chunk's segments' end points
            x, y = xy[m % n, 0], xy[m % n, 1]
            x0, x1, y0, y1 = min(x0, x), max(x1, x), min(y0, y), max(y1, y)
        box[k, 0], box[k, 1], box[k, 2], box[k, 3] = x0, x1, y0, y1
    reach = min(nc - 1, (span + c - 1) // c + 1)
    for k in range(nc):
        for d in range(reach + 1):
            k2 = (k + d) % nc
            if (box[k, 1] < box[k2, 0] or box[k2, 1] < box[k, 0] or box[k, 3] < box[k2, 2]
                    or box[k2, 3] < box[k, 2]):
                continue
            for i in range(k * c, min(n, k * c + c)):
                for j in range(k2 * c, min(n, k2 * c + c)):
                    dj = (j - i) % n
                    if dj < 2 or dj > span or (j + 1) % n == i:
                        continue
                    if _crosses(xy, i, j):
                        return True
    return False


@_jit
def first_self_intersection(xy, span):
    """First pair of crossing segments of a closed polyline (the closing segment implied),
    comparing each segment with the next ``span`` segments; (-1, -1) when none cross."""
    n = xy.shape[0]
    for i in range(n):
        for dj in range(2, span + 1):
            j = (i + dj) % n
            if (j + 1) % n != i and _crosses(xy, i, j):
                return i, j
    return -1, -1


def empty_harmonics() -> np.ndarray:
    """Harmonic table with no terms (shape (0, 2))."""
    return np.zeros((0, 2))

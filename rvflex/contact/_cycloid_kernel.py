"""Numba kernel of the cycloid–pin contact: all pins of one disc in one call.

Coordinates of the disc: q = (x, y, θ) of a planar rigid body (NodeRigidBody2D); the
profile frame is the body frame turned by a constant ``offset`` (disc phase). Pins are
fixed circles in the ring (ground) frame.

For each pin the exact gap g(q) (closest point on the profile, see
:mod:`rvflex.geometry._kernels`) gives the potential-based generalised force
Q = Σ f_i·∂g_i/∂q with f_i = f(x_i) ≥ 0, x_i = −g_i the penetration; the Jacobian of the
left-hand side is K = Σ f'_i·∂g_i/∂q ⊗ ∂g_i/∂q − f_i·∂²g_i/∂q² (symmetric without friction)
and D = Σ c·∂g_i/∂q ⊗ ∂g_i/∂q. A flexible disc adds columns (the contact point's mode-shape
row projected on the normal) to ∂g_i/∂q; the law layer below is unchanged.

Multi-point contact: the sum runs over contact points, not pins. A pin has one point per
separate local minimum of its distance to the profile with a gap below ``CONTACT_RANGE_M``.
Where the profile is convex, or concave with a radius of curvature larger than the pin
(every unmodified cycloid), the distance has one minimum near the pin and the closest-point
solve finds it. Two minima need a maximum between them, and a maximum of the distance at
distance d needs a concave stretch of radius of curvature below d (1 + κ·d < 0): a relieved
root whose radius is smaller than the pin. The contact precomputes those stretches
("zones", see ``concave_zones`` in :mod:`rvflex.contact.cycloid_pin`). For a pin whose
circle, widened by the contact range and the relief depth, reaches one of a zone's
bounding circles, the slope of the distance at the zone's sample points tells where further
minima lie (left of it, right of it, between two samples); a bracketed Newton solve finds
each, and every distinct minimum within the contact range is a point. The samples bound
every stretch where the radius of curvature is below the pin's minus the contact range
(there the distance has at most one critical point, a maximum, so no minimum hides between
two samples) and split the stretches between them in four.

What stays a model limit: a point is born or dies where a minimum and a maximum of the
distance merge, at a flank point whose radius of curvature equals the pin centre's distance.
Were the pin penetrating there, its force would start or stop with a step; that needs a
flank as tight as the pin to within the penetration (a conformal contact, which a line law
does not describe anyway). It does not occur on seed 003's relieved roots: the rim points
persist, and the root-bottom point appears and vanishes at least 5 µm open even with the
disc pressed 10 µm into the root (measured rolling over ±0.3 rad of eccentric angle).
Each point's gap, ∂g/∂q and ∂²g/∂q² are those of an ordinary closest point (the implicit
function theorem holds at any non-degenerate minimum), so the Jacobian stays exact. A
profile without zones pays nothing.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from rvflex.geometry._kernels import closest_point, profile_point

LAW_LINEAR, LAW_POWER, LAW_LINE, LAW_STRIP = 0, 1, 2, 3
STRIP_FACTOR = 4.0 * math.sqrt(2.0) / 3.0
# law parameter vector
L_KIND, L_K, L_EXP, L_C, L_MU, L_VREG, L_WIDTH, L_COMPL1, L_COMPL2, L_INV_RB, L_SEAT = range(11)
N_LAW = 11
SEAT_TOL_M = 1e-18  # m: the split of the approach solved to rounding (~1e-22 m at µm approaches), so the
# force and its derivatives agree with central differences as the laws without a seat do
SEAT_MAXIT = 60
CURVATURE_STEP_T = 1e-6  # profile-parameter step of the central difference dκ/dt (error ~1e-12 relative)
# per-pin and per-point output columns
O_GAP, O_FORCE, O_PX, O_PY, O_T, O_FT = range(6)
N_OUT = 6
MAX_POINTS = 4  # contact points per pin: two rims and the bottom of a relieved root need 3
CONTACT_RANGE_M = 50e-6  # a further local minimum with a gap below this is a contact point (the guard's depth)
# concave-zone table columns: parameter range [t_a, t_b] in [0, 2π) (t_a sorted); the number of slope
# samples and their parameters (offsets from t_a, ascending, t_a and t_b included); the bounding
# circles (x, y, R) of ZONE_ARCS equal parameter pieces of Q([t_a, t_b])
ZONE_ARCS = 8
ZONE_SLOPE_MAX = 16
Z_TA, Z_TB, Z_NS, Z_S0 = 0, 1, 2, 3
Z_CX, Z_CY, Z_R = Z_S0 + ZONE_SLOPE_MAX, Z_S0 + ZONE_SLOPE_MAX + 1, Z_S0 + ZONE_SLOPE_MAX + 2
N_ZONE = Z_S0 + ZONE_SLOPE_MAX + 3 * ZONE_ARCS
ZONE_REACH_M = 50e-6  # a pin bridging a zone is this much farther from it than from its rims, at most (relief depth)
LOCAL_NEWTON_TOL_T = 1e-11  # rad of t, as the closest-point solve
LOCAL_NEWTON_MAXIT = 40
DUPLICATE_T = 1e-8  # two Newton solves ending closer than this found the same minimum (rad of t)

_jit = nb.njit(cache=True, nogil=True)


@_jit
def _line_force(delta, kap, r_pin, law):
    """Force (N), dF/dδ (N/m) and dF/dκ (N·m) of the seed-002 line-contact law for approach δ
    at flank curvature κ.

    δ(F) = 2F/(πb)·[k1(ln(4ρ_e/c) − ½) + k2(ln(4r/c) − ½)], c² = 4F(k1 + k2)/(πb(κ + 1/r)),
    1/ρ_e = √(κ² + 1/R_b²) (R_b bounds the flank radius, see ContactLaw.body_radius_m),
    inverted by Newton; dδ/dF = δ/F − (k1 + k2)/(πb), ∂δ/∂κ = aF[(k1 + k2)/(2(κ + 1/r)) − k1κρ_e²].
    """
    b = law[L_WIDTH]
    k1 = law[L_COMPL1]
    k2 = law[L_COMPL2]
    curv = kap + 1.0 / r_pin
    conformal = curv <= 0.0
    if conformal:  # concave flank tighter than the pin: cannot occur on a valid profile
        curv = 1e-3 / r_pin
    a = 2.0 / (math.pi * b)
    bc = 4.0 * (k1 + k2) / (math.pi * b * curv)
    inv_rb = law[L_INV_RB]
    rho_e = 1.0 / max(math.sqrt(kap * kap + inv_rb * inv_rb), 1e-12)
    # start from a linear compliance evaluated at a typical force level
    f = delta / (a * (k1 + k2) * 5.0)
    for _ in range(50):
        c = math.sqrt(bc * f)
        dl = a * f * (k1 * (math.log(4.0 * rho_e / c) - 0.5) + k2 * (math.log(4.0 * r_pin / c) - 0.5))
        ddl = dl / f - 0.5 * a * (k1 + k2)
        step = (dl - delta) / ddl
        f_new = f - step
        if f_new <= 0.0:
            f_new = 0.5 * f
        if abs(f_new - f) <= 1e-13 * f:
            f = f_new
            break
        f = f_new
    c = math.sqrt(bc * f)
    dl = a * f * (k1 * (math.log(4.0 * rho_e / c) - 0.5) + k2 * (math.log(4.0 * r_pin / c) - 0.5))
    ddl = dl / f - 0.5 * a * (k1 + k2)
    dk = 0.0 if conformal else a * f * (0.5 * (k1 + k2) / curv - k1 * kap * rho_e * rho_e)
    return f, 1.0 / ddl, -dk / ddl


@_jit
def _normal_law(x, kap, r_pin, law):
    """Elastic normal force f(x) ≥ 0 (N), f'(x) (N/m) and ∂f/∂κ (N·m) for penetration x (m)
    at flank curvature κ (1/m).

    With a seat compliance s = ``law[L_SEAT]`` (m/N) in series, the penetration is shared: the contact
    takes x_c and the pin's seat s·f(x_c), x_c + s·f(x_c) = x, solved by Newton kept inside [0, x] (the
    left side grows with x_c at slope ≥ 1); then f' = f'_c/(1 + s·f'_c) ≤ 1/s and likewise ∂f/∂κ.
    """
    if x <= 0.0:
        return 0.0, 0.0, 0.0
    s = law[L_SEAT]
    if s <= 0.0:
        return _contact_law(x, kap, r_pin, law)
    lo, hi = 0.0, x
    xc = x - s * _contact_law(x, kap, r_pin, law)[0]
    if not 0.0 < xc < x:
        xc = 0.5 * x
    converged = False
    for _ in range(SEAT_MAXIT):
        f, df, dfk = _contact_law(xc, kap, r_pin, law)
        g = xc + s * f - x
        if g > 0.0:
            hi = xc
        else:
            lo = xc
        if abs(g) <= SEAT_TOL_M:
            converged = True
            break
        nxt = xc - g / (1.0 + s * df)
        xc = nxt if lo < nxt < hi else 0.5 * (lo + hi)
    if not converged:  # the last step moved x_c past the values evaluated at it
        f, df, dfk = _contact_law(xc, kap, r_pin, law)
    den = 1.0 + s * df
    return f, df / den, dfk / den


@_jit
def _contact_law(x, kap, r_pin, law):
    """The contact's own force, f'(x) and ∂f/∂κ at its approach x (m), without a seat compliance."""
    if x <= 0.0:
        return 0.0, 0.0, 0.0
    kind = law[L_KIND]
    if kind == LAW_LINEAR:
        return law[L_K] * x, law[L_K], 0.0
    if kind == LAW_POWER:
        e = law[L_EXP]
        f = law[L_K] * x**e
        return f, e * f / x, 0.0
    if kind == LAW_STRIP:
        # penalty k per unit length along the flank, integrated over the overlap chord of a
        # circle of relative radius R: (4√2/3)·k·√R·x^1.5 (the fine-segment limit of
        # Exudyn's ObjectContactCurveCircles, contact model 0)
        inv_r = 1.0 / r_pin + kap
        f = STRIP_FACTOR * law[L_K] * math.sqrt(1.0 / inv_r) * x**1.5
        return f, 1.5 * f / x, -0.5 * f / inv_r
    return _line_force(x, kap, r_pin, law)


@_jit
def _parameter_rate(t, par, herr, hpsi, cx, cy, a1x, a1y, a2x, a2y, a3x, a3y):
    """Profile derivatives Q', Q'' at the contact parameter t and its rate ∂t/∂q (3 values)
    from (Q − c)·Q' = 0: ∂t/∂c = Q'ᵀ/(|Q'|² + (Q − c)·Q''), with the columns a_b = ∂c/∂q_b."""
    qq, q1, q2 = profile_point(t, par, herr, hpsi)
    den = q1.real * q1.real + q1.imag * q1.imag + (qq.real - cx) * q2.real + (qq.imag - cy) * q2.imag
    return (q1, q2, (q1.real * a1x + q1.imag * a1y) / den, (q1.real * a2x + q1.imag * a2y) / den,
            (q1.real * a3x + q1.imag * a3y) / den)


@_jit
def _curvature(t, par, herr, hpsi):
    """Signed curvature of the profile at parameter t (1/m)."""
    _q, q1, q2 = profile_point(t, par, herr, hpsi)
    s = math.sqrt(q1.real * q1.real + q1.imag * q1.imag)
    return (q1.real * q2.imag - q1.imag * q2.real) / (s * s * s)


def empty_points(n_pins: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-point outputs (n, MAX_POINTS, N_OUT) with every row unused (NaN, zero force and
    friction) and their counts (n,) = 0, as :func:`evaluate` expects them on a first call."""
    pout = np.full((n_pins, MAX_POINTS, N_OUT), np.nan)
    pout[:, :, O_FORCE] = 0.0
    pout[:, :, O_FT] = 0.0
    return pout, np.zeros(n_pins, dtype=np.int64)


@_jit
def _local_minimum(c, t, a, b, max_step, par, herr, hpsi):
    """Newton on (Q(t) − c)·Q'(t) = 0 from ``t`` that ends only at a minimum of |Q(t) − c|.

    Downhill steps of at most ``max_step`` until the slope changes sign, then Newton kept
    inside the bracket [a, b] (slope < 0 at a, > 0 at b; ±inf: not known yet), bisecting
    where it would leave it or where the distance is not convex. Returns t, d, Q, N, κ (as
    :func:`closest_point`) and convergence.
    """
    ok = False
    q, q1, q2 = profile_point(t, par, herr, hpsi)
    for _ in range(LOCAL_NEWTON_MAXIT):
        dq = q - c
        f = dq.real * q1.real + dq.imag * q1.imag
        df = q1.real * q1.real + q1.imag * q1.imag + dq.real * q2.real + dq.imag * q2.imag
        if f < 0.0:
            a = t
        else:
            b = t
        if df > 0.0:
            tn = t - f / df
            if abs(tn - t) < LOCAL_NEWTON_TOL_T:
                ok = True
                break
        else:
            tn = math.nan
        if a > -math.inf and b < math.inf:
            if not a < tn < b:  # NaN too
                tn = 0.5 * (a + b)
        elif math.isnan(tn) or abs(tn - t) > max_step:
            tn = t + (max_step if f < 0.0 else -max_step)
        t = tn
        q, q1, q2 = profile_point(t, par, herr, hpsi)
    s = math.sqrt(q1.real * q1.real + q1.imag * q1.imag)
    nq = -1j * q1 / s
    dq = c - q
    d = dq.real * nq.real + dq.imag * nq.imag
    kappa = (q1.real * q2.imag - q1.imag * q2.real) / (s * s * s)
    return t, d, q, nq, kappa, ok


@_jit
def _zone_points(c, r_pin, t1, zones, window, par, herr, hpsi, pts, npts):
    """Add to ``pts`` (rows t, d, Q.x, Q.y, N.x, N.y, κ; ``npts`` filled) every further local
    minimum of the distance from ``c`` found from the concave zones within ``window`` of t1
    that the pin's circle, widened by CONTACT_RANGE_M + ZONE_REACH_M, reaches. Returns the
    new count and the number of minima dropped because ``pts`` was full."""
    nz = zones.shape[0]
    two_pi = 2.0 * math.pi
    tw = t1 % two_pi
    base = t1 - tw
    j0 = np.searchsorted(zones[:, Z_TA], tw)
    dropped = 0
    reach = r_pin + CONTACT_RANGE_M + ZONE_REACH_M
    slope = np.empty(ZONE_SLOPE_MAX)
    for direction in range(2):
        for step in range(nz):
            jj = j0 + step if direction == 0 else j0 - 1 - step
            j = jj % nz
            shift = two_pi * ((jj - j) // nz)
            ta = zones[j, Z_TA] + shift
            tb = zones[j, Z_TB] + shift
            if (direction == 0 and ta - tw > window) or (direction == 1 and tw - tb > window):
                break
            near = False
            for b in range(ZONE_ARCS):
                dx = c.real - zones[j, Z_CX + 3 * b]
                dy = c.imag - zones[j, Z_CY + 3 * b]
                if math.sqrt(dx * dx + dy * dy) - zones[j, Z_R + 3 * b] <= reach:
                    near = True
                    break
            if not near:
                continue
            # slope of the squared distance at the zone's samples (see concave_zones): a minimum
            # lies left of t_a if the slope is positive there, right of t_b if negative there,
            # and between two samples where it turns from negative to positive
            ns = int(zones[j, Z_NS])
            for k in range(ns):
                qk, q1k, _ = profile_point(base + ta + zones[j, Z_S0 + k], par, herr, hpsi)
                slope[k] = (qk.real - c.real) * q1k.real + (qk.imag - c.imag) * q1k.imag
            for k in range(-1, ns):
                if k == -1:  # left of the zone; already known if the closest point lies there
                    if slope[0] <= 0.0 or base + ta - window < t1 < base + ta:
                        continue
                    seed, lo, hi = base + ta, -math.inf, base + ta
                elif k == ns - 1:  # right of the zone
                    if slope[k] >= 0.0 or base + tb < t1 < base + tb + window:
                        continue
                    seed, lo, hi = base + tb, base + tb, math.inf
                else:
                    lo = base + ta + zones[j, Z_S0 + k]
                    hi = base + ta + zones[j, Z_S0 + k + 1]
                    if not (slope[k] < 0.0 <= slope[k + 1]):
                        continue
                    seed = 0.5 * (lo + hi)
                t, d, q, nq, kap, ok = _local_minimum(c, seed, lo, hi, tb - ta, par, herr, hpsi)
                if not ok or d - r_pin >= CONTACT_RANGE_M:
                    continue
                new = True
                for p in range(npts):
                    if abs(pts[p, 0] - t) < DUPLICATE_T:
                        new = False
                        break
                if not new:
                    continue
                if npts == pts.shape[0]:
                    dropped += 1
                    continue
                pts[npts, 0] = t
                pts[npts, 1] = d
                pts[npts, 2] = q.real
                pts[npts, 3] = q.imag
                pts[npts, 4] = nq.real
                pts[npts, 5] = nq.imag
                pts[npts, 6] = kap
                npts += 1
    return npts, dropped


@_jit
def evaluate(q, qd, offset, pins, radii, par, herr, hpsi, law, t_cache, phi, eta, eta_d, force, kmat, dmat, out,
             zones, zone_window, pout, npts_out):
    """:func:`evaluate_tracked` with every pin evaluated (no record of the pins' last gaps)."""
    return evaluate_tracked(q, qd, offset, pins, radii, par, herr, hpsi, law, t_cache, phi, eta, eta_d, force, kmat,
                            dmat, out, zones, zone_window, pout, npts_out, np.empty((0, 3)), False)


@_jit
def evaluate_tracked(q, qd, offset, pins, radii, par, herr, hpsi, law, t_cache, phi, eta, eta_d, force, kmat, dmat,
                     out, zones, zone_window, pout, npts_out, last, skip_open):
    """Generalised force (3 + m,), LHS Jacobians K, D ((3 + m)²) and per-pin outputs (n, N_OUT)
    of a disc with rigid coordinates ``q = (x, y, θ)`` and m modal coordinates ``eta``.

    ``phi`` (n_grid, 2, m) holds the in-plane modal displacement of the flank in the profile
    frame on the uniform grid t_j = 2πj/n_grid of the profile parameter (linear
    interpolation); the flank point moves by u = Φ(t)·η, which closes the gap by N·u. A rigid
    disc passes m = 0. The sliding of the sample point t(q) is in ∂g/∂q and K; left out of K,
    second order in u: ∂²(N·u)/∂q² and the change of the closest point with η.

    ``zones`` (n_zones, N_ZONE) lists the concave zones where a pin can have further contact
    points (none: one point per pin), searched within ``zone_window`` (rad of t) of the
    closest point. ``out`` (n, N_OUT) sums each pin's points: the force and friction summed,
    the gap, point and parameter of its deepest point; ``pout`` (n, MAX_POINTS, N_OUT) has
    every point and ``npts_out`` (n,) their count. On entry ``npts_out`` must hold the count
    of the previous call on these arrays, rows past it unused (NaN, zero force): fresh arrays
    come from :func:`empty_points`.

    ``last`` (n, 3) records, per pin of a rigid disc, where its centre was in the profile frame (c_x, c_y)
    when it was last evaluated and the gap it then had, certified as a lower bound of its distance to the
    whole profile (−inf: none; a flexible disc records none); a call with ``last`` of another length records
    nothing. With ``skip_open``, a pin whose recorded gap exceeds how far its centre has moved since is
    skipped: the distance to a curve changes no faster than the point moves, so it is still open, its
    force zero, and its outputs stay those of its last evaluation (exact but for its gap, which is not
    updated). Within a Newton step the disc moves by micrometres and most pins stand open by more: they cost
    nothing after the step's first evaluation.

    Returns the largest penetration (m) over the pins evaluated and the number of closest-point failures (a
    pin with more than MAX_POINTS points counts as a failure).
    """
    x0 = q[0]
    y0 = q[1]
    th = q[2] + offset
    ct = math.cos(th)
    st = math.sin(th)
    m = eta.shape[0]
    n = 3 + m
    ng = phi.shape[0]
    for a in range(n):
        force[a] = 0.0
        for b in range(n):
            kmat[a, b] = 0.0
            dmat[a, b] = 0.0
    max_pen = -1e300
    bad = 0
    gq = np.empty(n)
    sk = np.empty(m)
    h_grid = 2.0 * math.pi / max(ng, 1)
    hq = np.empty((3, 3))
    gt = np.empty(3)
    pts = np.empty((pout.shape[1], 7))  # a pin's contact points: t, d, Q.x, Q.y, N.x, N.y, κ
    nz = zones.shape[0]
    track = last.shape[0] == pins.shape[0]
    for i in range(pins.shape[0]):
        # pin centre in the profile frame: c = R(−θ)(P − C)
        dx = pins[i, 0] - x0
        dy = pins[i, 1] - y0
        cx = ct * dx + st * dy
        cy = -st * dx + ct * dy
        if skip_open and track:
            mx = cx - last[i, 0]
            my = cy - last[i, 1]
            if last[i, 2] > math.sqrt(mx * mx + my * my):
                continue
        c = complex(cx, cy)
        t, d, qp, nq, kap, ok = closest_point(c, par, herr, hpsi, t_cache[i])
        if ok:
            t_cache[i] = t
        else:  # never warm-start from a failed solve
            bad += 1
            t_cache[i] = math.nan
        pts[0, 0] = t
        pts[0, 1] = d
        pts[0, 2] = qp.real
        pts[0, 3] = qp.imag
        pts[0, 4] = nq.real
        pts[0, 5] = nq.imag
        pts[0, 6] = kap
        npts = 1
        if nz > 0 and ok:
            npts, dropped = _zone_points(c, radii[i], t, zones, zone_window, par, herr, hpsi, pts, npts)
            bad += dropped
        # rows past the previous call's count are unused already (see ``pout``): clear only those
        # this call leaves, so a profile without zones never touches rows 1…
        for p in range(npts, min(npts_out[i], pout.shape[1])):
            for col in range(N_OUT):
                pout[i, p, col] = math.nan
            pout[i, p, O_FORCE] = 0.0
            pout[i, p, O_FT] = 0.0
        npts_out[i] = npts
        out[i, O_GAP] = math.inf
        out[i, O_FORCE] = 0.0
        out[i, O_FT] = 0.0
        for p in range(npts):
            t = pts[p, 0]
            d = pts[p, 1]
            qp = complex(pts[p, 2], pts[p, 3])
            nq = complex(pts[p, 4], pts[p, 5])
            kap = pts[p, 6]
            gap = d - radii[i]
            nx = nq.real
            ny = nq.imag
            if m > 0:
                # modal flank displacement at t, normal component: ∂g/∂η_k = −N·Φ_k(t)
                s = (t / (2.0 * math.pi)) % 1.0 * ng
                j0 = int(s) % ng
                j1 = (j0 + 1) % ng
                w = s - math.floor(s)
                for k in range(m):
                    un = (nx * ((1.0 - w) * phi[j0, 0, k] + w * phi[j1, 0, k])
                          + ny * ((1.0 - w) * phi[j0, 1, k] + w * phi[j1, 1, k]))
                    gq[3 + k] = -un
                    gap -= un * eta[k]
            pen = -gap
            if pen > max_pen:
                max_pen = pen
            # world normal n = R(θ)N and world contact point (on the disc)
            wnx = ct * nx - st * ny
            wny = st * nx + ct * ny
            px = x0 + ct * qp.real - st * qp.imag
            py = y0 + st * qp.real + ct * qp.imag
            pout[i, p, O_GAP] = gap
            pout[i, p, O_PX] = px
            pout[i, p, O_PY] = py
            pout[i, p, O_T] = t
            pout[i, p, O_FORCE] = 0.0
            pout[i, p, O_FT] = 0.0
            if gap < out[i, O_GAP]:  # the pin's gap, point and parameter: its deepest point's
                out[i, O_GAP] = gap
                out[i, O_PX] = px
                out[i, O_PY] = py
                out[i, O_T] = t
            if pen <= 0.0:
                continue
            # ∂g/∂q: −n for translation, −(c × N) for rotation
            gq[0] = -wnx
            gq[1] = -wny
            gq[2] = -(cx * ny - cy * nx)
            # columns of ∂c/∂q: a1 = −R(−θ)e_x, a2 = −R(−θ)e_y, a3 = −J c
            a1x, a1y = -ct, st
            a2x, a2y = -st, -ct
            a3x, a3y = cy, -cx
            if m > 0:
                # the flank point of the modal displacement slides with t(q): ∂(N·Φ_k)/∂q =
                # s_k·∂t/∂q, s_k = N'·Φ_k + N·Φ_k'; it enters ∂g/∂q (through u = Φη) and the
                # modal–rigid blocks of K (fn·s_k·∂t/∂q, symmetric)
                q1, q2, wt0, wt1, wt2 = _parameter_rate(t, par, herr, hpsi, cx, cy, a1x, a1y, a2x, a2y, a3x, a3y)
                sq = math.sqrt(q1.real * q1.real + q1.imag * q1.imag)
                d12 = (q1.real * q2.real + q1.imag * q2.imag) / (sq * sq * sq)
                dnx = q2.imag / sq - q1.imag * d12
                dny = -q2.real / sq + q1.real * d12
                su = 0.0
                for k in range(m):
                    phx = (1.0 - w) * phi[j0, 0, k] + w * phi[j1, 0, k]
                    phy = (1.0 - w) * phi[j0, 1, k] + w * phi[j1, 1, k]
                    sk[k] = (dnx * phx + dny * phy + nx * (phi[j1, 0, k] - phi[j0, 0, k]) / h_grid
                             + ny * (phi[j1, 1, k] - phi[j0, 1, k]) / h_grid)
                    su += sk[k] * eta[k]
                gq[0] -= su * wt0
                gq[1] -= su * wt1
                gq[2] -= su * wt2
            pen_rate = -(gq[0] * qd[0] + gq[1] * qd[1] + gq[2] * qd[2])
            for k in range(m):
                pen_rate -= gq[3 + k] * eta_d[k]
            f_el, df_el, dfk = _normal_law(pen, kap, radii[i], law)
            fn = f_el + law[L_C] * pen_rate
            if fn <= 0.0:  # the damper would pull: the pin leaves the flank
                continue
            pout[i, p, O_FORCE] = fn
            out[i, O_FORCE] += fn
            # ∂²g/∂q²: level-set curvature of the distance plus the rotation of c
            tx = -ny  # profile tangent (disc frame), N = −i·T  ⇒  T = i·N
            ty = nx
            keff = kap / (1.0 + kap * d)
            s1 = tx * a1x + ty * a1y
            s2 = tx * a2x + ty * a2y
            s3 = tx * a3x + ty * a3y
            sv = (s1, s2, s3)
            for a in range(3):
                for b in range(3):
                    hq[a, b] = keff * sv[a] * sv[b]
            if dfk != 0.0:
                # the law depends on the curvature at the contact point, which slides along the
                # flank: ∂κ/∂q = κ'(t)·∂t/∂q (∂t/∂q already known for a flexible disc)
                if m == 0:
                    q1, q2, wt0, wt1, wt2 = _parameter_rate(t, par, herr, hpsi, cx, cy, a1x, a1y, a2x, a2y, a3x, a3y)
                h = CURVATURE_STEP_T
                gk = dfk * (_curvature(t + h, par, herr, hpsi) - _curvature(t - h, par, herr, hpsi)) / (2.0 * h)
                dk0 = gk * wt0
                dk1 = gk * wt1
                dk2 = gk * wt2
                for a in range(n):
                    kmat[a, 0] -= gq[a] * dk0
                    kmat[a, 1] -= gq[a] * dk1
                    kmat[a, 2] -= gq[a] * dk2
            # N·∂²c/∂θ∂x = N·J R(−θ)e_x, N·∂²c/∂θ² = −N·c
            jx = (st, ct)  # J·R(−θ)e_x with R(−θ)e_x = (ct, −st) and J(v) = (−v_y, v_x)
            jy = (-ct, st)  # J·R(−θ)e_y with R(−θ)e_y = (st, ct)
            hx = nx * jx[0] + ny * jx[1]
            hy = nx * jy[0] + ny * jy[1]
            hq[0, 2] += hx
            hq[2, 0] += hx
            hq[1, 2] += hy
            hq[2, 1] += hy
            hq[2, 2] += -(nx * cx + ny * cy)
            for a in range(n):
                force[a] += fn * gq[a]
                for b in range(n):
                    kmat[a, b] += df_el * gq[a] * gq[b]
                    dmat[a, b] += law[L_C] * gq[a] * gq[b]
            for a in range(3):
                for b in range(3):
                    kmat[a, b] -= fn * hq[a, b]
            if m > 0:
                for k in range(m):
                    c0 = fn * sk[k]
                    kmat[3 + k, 0] += c0 * wt0
                    kmat[3 + k, 1] += c0 * wt1
                    kmat[3 + k, 2] += c0 * wt2
                    kmat[0, 3 + k] += c0 * wt0
                    kmat[1, 3 + k] += c0 * wt1
                    kmat[2, 3 + k] += c0 * wt2
            mu = law[L_MU]
            if mu > 0.0:
                # regularised Coulomb friction at the contact point, opposing the disc's sliding
                wtx = -wny
                wty = wnx
                rx = px - x0
                ry = py - y0
                gt[0] = wtx
                gt[1] = wty
                gt[2] = rx * wty - ry * wtx
                vt = gt[0] * qd[0] + gt[1] * qd[1] + gt[2] * qd[2]
                vr = law[L_VREG]
                th_v = math.tanh(vt / vr)
                ft = -mu * fn * th_v
                pout[i, p, O_FT] = ft
                out[i, O_FT] += ft
                sech2 = 1.0 - th_v * th_v
                for a in range(3):
                    force[a] += ft * gt[a]
                    for b in range(3):
                        # F_t = −μ·F_n·tanh(v_t/v_reg), F_n = f(x) − c·∂g/∂q·q̇
                        dmat[a, b] += mu * fn * sech2 / vr * gt[a] * gt[b] - mu * th_v * law[L_C] * gt[a] * gq[b]
                        kmat[a, b] += mu * th_v * gt[a] * (-df_el * gq[b])
                # friction acts on the rigid coordinates only: the tangential flank displacement of
                # the modes is left out (friction is off in the catalogue models)
        if track:
            last[i, 0] = cx
            last[i, 1] = cy
            # the gap certified for the whole profile: the closest point's (every minimum of the distance found,
            # on a profile without concave zones the only one); with zones, minima beyond the contact range
            # are not searched, so no more than that range. None for a flexible disc (its flank moves with η)
            # or a failed solve
            g = out[i, O_GAP] if nz == 0 else min(out[i, O_GAP], CONTACT_RANGE_M)
            last[i, 2] = g if ok and m == 0 else -math.inf
    return max_pen, bad


@_jit
def evaluate_housing(q, qd, offset, pins, radii, par, herr, hpsi, law, t_cache, phi, eta, eta_d, seat, xi, xi_d,
                     force, kmat, dmat, out, zones, zone_window, pout, npts_out, f_pin, k_pin, d_pin):
    """:func:`evaluate` with pins carried by a flexible housing: pin i sits at P_i + S_i·ξ, with
    ``seat`` (n, 2, h) the in-plane seat displacement rows S_i (ring frame) of the housing's h
    modal coordinates ``xi`` (rates ``xi_d``).

    The contact of a pin depends on the pin centre relative to the disc only, c = R(−θ)(P − x),
    so a pin moved by v = S_i·ξ is the disc moved by −v: each pin is :func:`evaluate`\\ d alone at
    x − S_i·ξ (rates likewise) and its force and Jacobians map to the coordinates (x, y, θ, η, ξ)
    by T_i = [1, −E S_i] (E: the x, y rows): Q += T_iᵀ f_i, K += T_iᵀ K_i T_i — exact, since T_i
    is constant. ``force`` (3 + m + h,), ``kmat``, ``dmat`` the results; ``f_pin`` (3 + m,),
    ``k_pin``, ``d_pin`` ((3 + m)²) per-pin work buffers. Contact points are reported in the
    ring frame (the disc's point, moved back by v). Returns as :func:`evaluate`.
    """
    n = 3 + eta.shape[0]
    h = xi.shape[0]
    for a in range(n + h):
        force[a] = 0.0
        for b in range(n + h):
            kmat[a, b] = 0.0
            dmat[a, b] = 0.0
    qe = np.empty(3)
    qde = np.empty(3)
    max_pen = -1e300
    bad = 0
    for i in range(pins.shape[0]):
        vx = 0.0
        vy = 0.0
        wx = 0.0
        wy = 0.0
        for k in range(h):
            vx += seat[i, 0, k] * xi[k]
            vy += seat[i, 1, k] * xi[k]
            wx += seat[i, 0, k] * xi_d[k]
            wy += seat[i, 1, k] * xi_d[k]
        qe[0] = q[0] - vx
        qe[1] = q[1] - vy
        qe[2] = q[2]
        qde[0] = qd[0] - wx
        qde[1] = qd[1] - wy
        qde[2] = qd[2]
        pen, b = evaluate(qe, qde, offset, pins[i:i + 1], radii[i:i + 1], par, herr, hpsi, law, t_cache[i:i + 1],
                          phi, eta, eta_d, f_pin, k_pin, d_pin, out[i:i + 1], zones, zone_window, pout[i:i + 1],
                          npts_out[i:i + 1])
        bad += b
        if pen > max_pen:
            max_pen = pen
        out[i, O_PX] += vx
        out[i, O_PY] += vy
        for p in range(npts_out[i]):
            pout[i, p, O_PX] += vx
            pout[i, p, O_PY] += vy
        if out[i, O_FORCE] <= 0.0:
            continue  # no loaded point: f_pin, k_pin, d_pin are zero
        for a in range(n):
            force[a] += f_pin[a]
            for b2 in range(n):
                kmat[a, b2] += k_pin[a, b2]
                dmat[a, b2] += d_pin[a, b2]
        for k in range(h):
            s0 = seat[i, 0, k]
            s1 = seat[i, 1, k]
            force[n + k] -= s0 * f_pin[0] + s1 * f_pin[1]
            for a in range(n):
                kmat[a, n + k] -= k_pin[a, 0] * s0 + k_pin[a, 1] * s1
                kmat[n + k, a] -= s0 * k_pin[0, a] + s1 * k_pin[1, a]
                dmat[a, n + k] -= d_pin[a, 0] * s0 + d_pin[a, 1] * s1
                dmat[n + k, a] -= s0 * d_pin[0, a] + s1 * d_pin[1, a]
            for l2 in range(h):
                t0 = seat[i, 0, l2]
                t1 = seat[i, 1, l2]
                kmat[n + k, n + l2] += (s0 * (k_pin[0, 0] * t0 + k_pin[0, 1] * t1)
                                        + s1 * (k_pin[1, 0] * t0 + k_pin[1, 1] * t1))
                dmat[n + k, n + l2] += (s0 * (d_pin[0, 0] * t0 + d_pin[0, 1] * t1)
                                        + s1 * (d_pin[1, 0] * t0 + d_pin[1, 1] * t1))
    return max_pen, bad

"""Compiled quasi-static step of a reducer, planar (rigid or with FE-reduced discs, carrier and housing) or
spatial rigid: Newton's method on the whole system in one numba call.

Exudyn's static solver takes a step of the rigid model in about 0.3 ms of its own work beside the contact
kernels (residual and Jacobian through the item list, Python user functions per disc and mesh, the
connectors' Jacobians by finite differences), and of a model with FE discs in about ten times that (its
FFRF bodies' Jacobian costs ten residuals). The step itself is a few Newton iterations on 15–200 unknowns,
each one evaluation of the contact kernels and a dense solve. :class:`CompiledStep` reads the assembled
Exudyn system once per run (bodies, markers, connectors, loads and the contact and mesh elements' own kernel
data) and solves each step in compiled code with the same force laws:

- ``ConnectorRigidBodySpringDamper`` with rvflex's clearance-bearing law (:mod:`rvflex.contact.bearing`):
  the central radial force k·r_w(d − ε)·d/|d| (or the bearing's power law in r_w) between the two marker
  points, applied at each marker;
  its axial and tilt springs act only where a marker on an FE body moves out of the plane with the modes;
- ``ConnectorCartesianSpringDamper``: k_x, k_y springs on the markers' relative position;
- ``ConnectorCoordinateSpringDamper`` (the output regulariser) and ``LoadCoordinate`` (the output torque);
- ``ConnectorCoordinate`` holding a coordinate at its offset (the input drive, the sun's centre, an FE
  body's z, ψx, ψy): the coordinate is prescribed, not solved for;
- the cycloid–pin contacts (with an FE disc's flank modes) and the involute meshes through their own numba
  kernels (``rvflex.contact.cycloid_pin.evaluate_kernel``, ``rvflex.contact.gear_mesh.mesh_kernel``);
- ``ObjectFFRFreducedOrder`` bodies held in the plane: at rest the floating frame's inertia terms vanish and
  the modal coordinates η carry the constant reduced stiffness, −K·η; a ``MarkerSuperElementRigid`` on
  one sits at the frame's position + R(ψz)·(its point + P·η), P the weighted mode rows of its nodes (the
  offset does not turn with the nodes, as in Exudyn), its tilt the least-squares rotation of its nodes;
- the flexible housing, a linear ``ObjectGenericODE2`` on its modal coordinates ξ (−K·ξ), whose seats carry
  the pins in the contacts (``rvflex.contact.cycloid_pin.evaluate_housing_kernel``);
- the spatial rigid model's elements (:mod:`rvflex.engine3d`): ``ObjectRigidBody`` on ``NodeRigidBodyRxyz``
  (x, y, z, ψx, ψy, ψz free; no static force of its own), the clearance bushings and Cartesian springs between
  such bodies as Exudyn's 3D connectors define them (relative displacement and Tait–Bryan rotation in marker
  0's joint frame), the main bearing pair element, the contact slices of a tilting disc and the gear mesh of a
  tilting crank (each planar kernel on its section's in-plane pose, mapped back onto the body).

Exudyn stays the model of record: a system holding any other item (a connector law not listed, an FE body
free out of its plane, a connector between a planar and a spatial body) gets no compiled step
(:func:`compiled_step` returns None) and is solved by Exudyn; the residual at any state equals Exudyn's
``ComputeNewtonResidual`` (tests/test_engine.py, tests/test_engine_spatial.py) and the quasi-static TE equals
that of Exudyn's static solver within 1e-4″. The solved state is written back
to the Exudyn system, so whatever reads the system next sees it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba as nb
import numpy as np

from rvflex.contact import cycloid_pin as K
from rvflex.contact.gear_mesh import N_STATE as MESH_STATE
from rvflex.contact.gear_mesh import mesh_kernel
from rvflex.engine3d import (
    LAW_CARTESIAN,
    LAW_CLEARANCE,
    bushings3d,
    clearance_ramp,
    connector_law3d,
    marker3d,
    mesh_tilted,
    pair_elements,
    slice_section,
    slice_to_body,
    spatial_data,
    workspace3d,
)

__all__ = ["CompiledStep", "compiled_step", "ideal_kinematics", "ring_torque", "solve_dense", "StepFailed"]

# Newton: the same caps and tolerances as the chord Newton of rvflex.solve (see there why a move is capped)
CAP_M = 1e-5
CAP_RADIUS_M = 0.03
# a crank's spin moves its eccentric (~1.5 mm off its axis) and its gear's teeth (~30 mm): with clearance in
# its bearings the eccentric floats by µm from one position to the next, its spin by ~0.5 mrad at 576
# positions (RV-40E, 12 µm), which CAP_RADIUS_M would cap at 0.33 mrad an iteration; at this radius the
# gear's teeth still move at most 30 µm (measured: 8.5 → 6.8 Newton evaluations per step, TE equal to 1e-9″)
CRANK_CAP_RADIUS_M = 0.01
TOLERANCE = 1e-10
RESIDUAL = 1e-2
MAX_ITERATIONS = 60
MAX_HALVINGS = 12  # a damped Newton step is halved at most this often (to 1/4096 of it)
CONTRACTION = 0.25  # a chord iteration keeps its Jacobian while the residual shrinks by at least this (rvflex.solve's)
CHORD_ITERATIONS = 100  # as rvflex.solve's chord Newton: crossing a free play takes ~60 capped iterations
# Newton's modes: full steps; steps halved back where they do not lower the residual; a kept Jacobian
PLAIN, DAMPED, CHORD = 0, 1, 2
LOAD_RAMP_MIN = 1.0 / 64  # the smallest load increment of a step taken under a growing load
# status codes of the compiled Newton
CONVERGED, STALLED, KERNEL_FAILED, SINGULAR = 0, 1, 2, 3

# the contact group's arrays in the order _assemble unpacks them
_CONTACT_KEYS = ("ct_rig", "ct_ref", "ct_offset", "ct_pins", "ct_radii", "ct_par", "ct_herr", "ct_hpsi", "ct_law",
                 "ct_tcache", "ct_zones", "ct_window", "ct_out", "ct_pout", "ct_count", "ct_mod", "ct_phi", "ct_f",
                 "ct_k", "ct_d", "ct_eta", "ct_etad", "ct_hmod", "ct_seat", "ct_xi", "ct_xid", "ct_pf", "ct_pk",
                 "ct_pd", "ct_last")
CT_PINS, CT_OUT, CT_F = (_CONTACT_KEYS.index(k) for k in ("ct_pins", "ct_out", "ct_f"))
# the spatial group's arrays (rvflex.engine3d) in the order _assemble unpacks them
_SPATIAL_KEYS = ("b3_idx", "b3_slot", "b3_first", "b3_lp", "b3_kind", "b3_par", "bp_idx", "bp_seat", "bp_inner", "bp_outer", "bp_par",
                 "bp_f5", "bp_k5", "bp_load", "bp_unit", "bp_squeeze", "bp_q5", "ct_tilt", "ct_lever", "ms_tilt",
                 "ms_lever")
SP_FIRST = _SPATIAL_KEYS.index("b3_first")



def _drop_stale_cache() -> None:
    """Remove this module's numba cache when a kernel it calls has changed.

    numba keys a cached function on its own module's source only; the compiled step (and its spatial
    elements, :mod:`rvflex.engine3d`) links the contact, mesh, pair and geometry kernels into its own code,
    so after an edit of one of them the cache would go on running the old kernel. A stamp of their sources beside the cache tells; a read-only install (no
    stamp written) compiles as numba decides."""
    import hashlib
    from importlib.util import find_spec
    from pathlib import Path

    kernels = ("rvflex.contact._cycloid_kernel", "rvflex.contact.gear_mesh", "rvflex.geometry._kernels",
               "rvflex.contact.tilt_map", "rvflex.contact.angular_contact", "rvflex.engine3d")
    try:
        digest = hashlib.sha1(b"".join(Path(find_spec(m).origin).read_bytes() for m in kernels)).hexdigest()
        cache = Path(__file__).parent / "__pycache__"
        stamp = cache / f"engine.kernels-{digest[:16]}.stamp"
        if stamp.exists() or not cache.is_dir():
            return
        for f in [*cache.glob("engine.*.nbi"), *cache.glob("engine.*.nbc"), *cache.glob("engine3d.*.nbi"),
                  *cache.glob("engine3d.*.nbc"), *cache.glob("engine.kernels-*.stamp")]:
            f.unlink(missing_ok=True)
        stamp.touch()
    except OSError:
        pass


_drop_stale_cache()
_jit = nb.njit(cache=True, nogil=True)


class StepFailed(RuntimeError):
    """A compiled step did not converge (the caller solves it again with Exudyn)."""


@_jit
def _point_connectors(qa, pc, f, kt, jidx, jv):
    """Add the point connectors' forces (f, RHS) and LHS Jacobian (kt = −∂f/∂q) at absolute coordinates qa.

    ``pc`` = (x index of each marker's body or −1 for ground, its angle's index, the ODE2 index of each modal
    coordinate that moves the marker (−1 past the last), the marker's in-plane modal rows P (body frame),
    local or ground position, law kind, law parameters). A marker on an FE body sits at the body frame's
    position + R(θ)(local + P·η)."""
    idx, th_idx, mcol, pmod, lp, kind, par = pc
    nc = idx.shape[0]
    mmax = mcol.shape[2]
    p = np.empty((2, 2))
    r = np.empty((2, 2))
    nj = np.zeros(2, dtype=np.int64)
    for c in range(nc):
        for s in range(2):
            b = idx[c, s]
            if b < 0:  # a ground marker: lp holds its global position
                r[s, 0] = 0.0
                r[s, 1] = 0.0
                p[s, 0] = lp[c, s, 0]
                p[s, 1] = lp[c, s, 1]
                nj[s] = 0
                continue
            lx, ly = lp[c, s, 0], lp[c, s, 1]
            for j in range(mmax):
                i = mcol[c, s, j]
                if i < 0:
                    break
                lx += pmod[c, s, 0, j] * qa[i]
                ly += pmod[c, s, 1, j] * qa[i]
            ct, st = math.cos(qa[th_idx[c, s]]), math.sin(qa[th_idx[c, s]])
            r[s, 0] = ct * lx - st * ly
            r[s, 1] = st * lx + ct * ly
            p[s, 0] = qa[b] + r[s, 0]
            p[s, 1] = qa[b + 1] + r[s, 1]
            # ∂p/∂q: the columns (coordinate, ∂px, ∂py) of this marker
            jidx[s, 0], jv[s, 0, 0], jv[s, 0, 1] = b, 1.0, 0.0
            jidx[s, 1], jv[s, 1, 0], jv[s, 1, 1] = b + 1, 0.0, 1.0
            jidx[s, 2], jv[s, 2, 0], jv[s, 2, 1] = th_idx[c, s], -r[s, 1], r[s, 0]
            k = 3
            for j in range(mmax):
                i = mcol[c, s, j]
                if i < 0:
                    break
                jidx[s, k] = i
                jv[s, k, 0] = ct * pmod[c, s, 0, j] - st * pmod[c, s, 1, j]
                jv[s, k, 1] = st * pmod[c, s, 0, j] + ct * pmod[c, s, 1, j]
                k += 1
            nj[s] = k
        dx = p[1, 0] - p[0, 0]
        dy = p[1, 1] - p[0, 1]
        # F: force on marker 1 (marker 0 gets −F); A = ∂F/∂d
        if kind[c] == LAW_CLEARANCE:
            k, eps, w, e = par[c, 0], par[c, 1], par[c, 2], par[c, 3]
            if eps == 0.0 and e == 1.0:
                fx, fy = -k * dx, -k * dy
                a00, a01, a10, a11 = -k, 0.0, 0.0, -k
            else:
                d = math.sqrt(dx * dx + dy * dy)
                if d == 0.0:
                    continue  # a power law without clearance: no force and no stiffness at zero approach
                rw, drw = clearance_ramp(d - eps, w)
                if rw == 0.0 and drw == 0.0:
                    continue
                if e != 1.0:  # the power law F = k·x_r^(1−e)·r_w^e (par[c, 4] = k·x_r^(1−e))
                    fr = par[c, 4] * rw**e
                    drw = par[c, 4] * e * rw ** (e - 1.0) * drw / k
                    rw = fr / k
                g = k * rw / d  # force per unit displacement, central
                gp = (k * drw - g) / d  # dg/dd
                ux, uy = dx / d, dy / d
                fx, fy = -g * dx, -g * dy
                a00 = -(g + gp * d * ux * ux)
                a01 = -(gp * d * ux * uy)
                a10 = a01
                a11 = -(g + gp * d * uy * uy)
        else:
            kx, ky = par[c, 0], par[c, 1]
            fx = -kx * (dx - par[c, 2])
            fy = -ky * (dy - par[c, 3])
            a00, a01, a10, a11 = -kx, 0.0, 0.0, -ky
        for s in range(2):
            if idx[c, s] < 0:
                continue
            sg = 1.0 if s == 1 else -1.0
            gx, gy = sg * fx, sg * fy
            for a in range(nj[s]):  # generalized force Jₛᵀ·G
                f[jidx[s, a]] += jv[s, a, 0] * gx + jv[s, a, 1] * gy
            # Jacobian rows of marker s against the columns of marker t: ∂(Jₛᵀ·sgF)/∂q_t, ∂d/∂q_t = ±J_t
            for t in range(2):
                if idx[c, t] < 0:
                    continue
                st_ = sg * (1.0 if t == 1 else -1.0)
                for bb in range(nj[t]):
                    gdx = st_ * (a00 * jv[t, bb, 0] + a01 * jv[t, bb, 1])  # ∂(sgF)/∂q_t,bb
                    gdy = st_ * (a10 * jv[t, bb, 0] + a11 * jv[t, bb, 1])
                    col = jidx[t, bb]
                    for a in range(nj[s]):
                        kt[jidx[s, a], col] -= jv[s, a, 0] * gdx + jv[s, a, 1] * gdy
            # the lever and the modal rows turn with θ_s: ∂(r_s × G)/∂θ_s = −r_s·G, ∂(RPⱼ·G)/∂θ_s = RPⱼ × G
            th = th_idx[c, s]
            kt[th, th] -= -(r[s, 0] * gx + r[s, 1] * gy)
            for a in range(3, nj[s]):
                cross = jv[s, a, 0] * gy - jv[s, a, 1] * gx
                kt[th, jidx[s, a]] -= cross
                kt[jidx[s, a], th] -= cross


@_jit
def _workspace(m_pc, n_ct):
    """Work arrays of one assembly: a disc's rigid coordinates and rates, the mesh kernel's buffers, the point
    connectors' marker Jacobians (3 + the most modal coordinates moving a marker), a contact element's
    coordinate indices (``n_ct``, its most coordinates)."""
    return (np.zeros(3), np.zeros(3), np.zeros(6), np.zeros(6), np.zeros(6), np.zeros((6, 6)), np.zeros((6, 6)),
            np.zeros(MESH_STATE), np.zeros((2, 3 + m_pc), dtype=np.int64), np.zeros((2, 3 + m_pc, 2)),
            np.zeros(n_ct, dtype=np.int64))


@_jit
def _contact_size(ct):
    """The most coordinates of a contact element (3 + disc modes + housing modes)."""
    n = 0
    for d in range(ct[0].shape[0]):
        n = max(n, ct[CT_F][d].shape[0])
    return n


@_jit
def _assemble(x, ref, pc, cs, ld, ct, ff, ms, sp, f, kt, qa, wk, wk3, skip_open):
    """Force (RHS) and LHS Jacobian of the whole system at displacement x; returns (max penetration, bad pins).
    With ``skip_open`` a rigid disc's pins that surely stand open are not evaluated again (their gaps in the
    contacts' outputs are then those of their last evaluation; ``evaluate_tracked`` of the contact kernel).

    ``pc``: point connectors (:func:`_point_connectors`); ``cs``: coordinate springs to ground (index, k,
    offset); ``ld``: coordinate loads (index, value); ``ct``: cycloid–pin contacts (their kernel's data, the
    ODE2 indices of each disc's (x, y, θ) and first modal coordinate, its flank mode rows and buffers);
    ``ff``: FE bodies' modal stiffness (first modal coordinate, count, matrix); ``ms``: involute meshes;
    ``sp``: the spatial elements (:mod:`rvflex.engine3d`): 3D point connectors, main bearing pair elements, and
    per contact and mesh the first coordinate of its tilting (Rxyz) body (−1: planar) and its section's lever;
    ``wk3``: their work arrays."""
    work3, qd, meshq, meshqt, meshf, meshdf, meshdft, meshst, jidx, jv, idx_a = wk
    cs_idx, cs_k, cs_off = cs
    ld_idx, ld_val = ld
    (ct_rig, ct_ref, ct_offset, ct_pins, ct_radii, ct_par, ct_herr, ct_hpsi, ct_law, ct_tcache, ct_zones, ct_window,
     ct_out, ct_pout, ct_count, ct_mod, ct_phi, ct_f, ct_k, ct_d, ct_eta, ct_etad, ct_hmod, ct_seat, ct_xi, ct_xid,
     ct_pf, ct_pk, ct_pd, ct_last) = ct
    ff_start, ff_m, ff_k = ff
    ms_idx, ms_par = ms
    (b3_idx, b3_slot, b3_first, b3_lp, b3_kind, b3_par, bp_idx, bp_seat, bp_inner, bp_outer, bp_par, bp_f5, bp_k5,
     bp_load, bp_unit, bp_squeeze, bp_q5, ct_tilt, ct_lever, ms_tilt, ms_lever) = sp
    n = x.shape[0]
    for i in range(n):
        qa[i] = ref[i] + x[i]
        f[i] = 0.0
        for j in range(n):
            kt[i, j] = 0.0
    _point_connectors(qa, pc, f, kt, jidx, jv)
    if b3_idx.shape[0]:
        bushings3d(qa, (b3_idx, b3_slot, b3_first, b3_lp, b3_kind, b3_par), f, kt, wk3)
    if bp_idx.shape[0]:
        pair_elements(x, (bp_idx, bp_seat, bp_inner, bp_outer, bp_par, bp_f5, bp_k5, bp_load, bp_unit, bp_squeeze,
                          bp_q5), f, kt)
    for c in range(cs_idx.shape[0]):  # coordinate springs to ground: −k(q − offset)
        i = cs_idx[c]
        f[i] -= cs_k[c] * (x[i] - cs_off[c])
        kt[i, i] += cs_k[c]
    for c in range(ld_idx.shape[0]):
        f[ld_idx[c]] += ld_val[c]
    for b in range(ff_start.shape[0]):  # FE bodies: −K·η on their modal coordinates (constant K, body frame)
        i0, m = ff_start[b], ff_m[b]
        for i in range(m):
            s = 0.0
            for j in range(m):
                s += ff_k[b, i, j] * x[i0 + j]
                kt[i0 + i, i0 + j] += ff_k[b, i, j]
            f[i0 + i] -= s
    pen = -np.inf
    bad = 0
    for d in range(ct_rig.shape[0]):
        eta, xi = ct_eta[d], ct_xi[d]
        m, h = eta.shape[0], xi.shape[0]
        tilt = ct_tilt[d]
        if tilt >= 0:  # a slice of a tilting disc: its section's in-plane pose
            sec = slice_section(qa, tilt, ct_lever[d], wk3)
            for i in range(3):
                work3[i] = sec[i]
        else:
            for i in range(3):
                work3[i] = ct_ref[d, i] + x[ct_rig[d, i]]
        for j in range(m):
            eta[j] = x[ct_mod[d] + j]
        for j in range(h):
            xi[j] = x[ct_hmod[d] + j]
        fd, kd = ct_f[d], ct_k[d]
        if h:  # pins on a flexible housing's seats
            p, nbad = K.evaluate_housing_kernel(work3, qd, ct_offset[d], ct_pins[d], ct_radii[d], ct_par[d],
                                                ct_herr[d], ct_hpsi[d], ct_law[d], ct_tcache[d], ct_phi[d], eta,
                                                ct_etad[d], ct_seat[d], xi, ct_xid[d], fd, kd, ct_d[d], ct_out[d],
                                                ct_zones[d], ct_window[d], ct_pout[d], ct_count[d], ct_pf[d],
                                                ct_pk[d], ct_pd[d])
        else:
            p, nbad = K.evaluate_tracked_kernel(work3, qd, ct_offset[d], ct_pins[d], ct_radii[d], ct_par[d],
                                                ct_herr[d], ct_hpsi[d], ct_law[d], ct_tcache[d], ct_phi[d], eta,
                                                ct_etad[d], fd, kd, ct_d[d], ct_out[d], ct_zones[d], ct_window[d],
                                                ct_pout[d], ct_count[d], ct_last[d], skip_open)
        if p > pen:
            pen = p
        bad += nbad
        if tilt >= 0:
            slice_to_body(tilt, ct_lever[d], fd, kd, ct_d[d], f, kt, wk3)
            continue
        # the element's coordinates (x, y, θ, η…, ξ…) in the system's
        for a in range(3 + m + h):
            idx_a[a] = ct_rig[d, a] if a < 3 else (ct_mod[d] + a - 3 if a < 3 + m else ct_hmod[d] + a - 3 - m)
        for a in range(3 + m + h):
            f[idx_a[a]] += fd[a]
            for bb in range(3 + m + h):
                kt[idx_a[a], idx_a[bb]] += kd[a, bb]
    for m in range(ms_idx.shape[0]):
        if ms_tilt[m]:  # the planet gear on a tilting crank
            mesh_tilted(x, ms_idx[m, 0], ms_idx[m, 1], ms_lever[m], ms_par[m], f, kt, wk3)
            continue
        for s in range(2):
            for i in range(3):
                meshq[3 * s + i] = x[ms_idx[m, s] + i]
                meshqt[3 * s + i] = 0.0
        mesh_kernel(meshq, meshqt, ms_par[m], meshf, meshdf, meshdft, meshst, True)
        for s in range(2):
            bs = ms_idx[m, s]
            for i in range(3):
                f[bs + i] += meshf[3 * s + i]
                for t in range(2):
                    bt = ms_idx[m, t]
                    for j in range(3):
                        kt[bs + i, bt + j] -= meshdf[3 * s + i, 3 * t + j]
    return pen, bad


@_jit
def _newton(x, free, cap, ref, pc, cs, ld, ct, ff, ms, sp, wk3, max_iterations, mode, skip_open):
    """Newton's method on the free coordinates from x (updated in place); returns (status, evaluations,
    max penetration, residual norm).

    ``mode``: PLAIN, full Newton steps; DAMPED, a step that does not lower the residual norm (Armijo, 1e-4),
    or reaches a state the contact kernel cannot evaluate, is halved back along itself, up to MAX_HALVINGS
    times; CHORD, the factorised Jacobian is kept while each iteration shrinks the residual by CONTRACTION
    (the chord Newton of rvflex.solve on the compiled residual). The plain iteration takes most steps in
    three to five evaluations; the others are the retries of a step it cannot take (out of zero torque or
    from a cold start against a stiff output regulariser, contacts setting in and out from one iterate to
    the next can make the full steps cycle, where a kept Jacobian still contracts)."""
    damped = mode == DAMPED
    n = x.shape[0]
    nf = free.shape[0]
    f = np.zeros(n)
    kt = np.zeros((n, n))
    qa = np.zeros(n)
    wk = _workspace(pc[2].shape[2], _contact_size(ct))
    a = np.zeros((nf, nf))
    r = np.zeros(nf)
    step = np.zeros(nf)
    perm = np.zeros(nf, dtype=np.int64)
    evaluations = 0
    norm = np.inf
    pen = -np.inf
    lam = 1.0  # the share of the last Newton step taken
    last = np.inf  # the residual norm at the last accepted state
    halvings = 0
    for it in range(max_iterations + 1):
        pen, bad = _assemble(x, ref, pc, cs, ld, ct, ff, ms, sp, f, kt, qa, wk, wk3, skip_open)
        evaluations += 1
        norm = 0.0
        if not bad:
            for i in range(nf):
                r[i] = f[free[i]]
                norm += r[i] * r[i]
            norm = math.sqrt(norm)
        if damped and it > 0 and halvings < MAX_HALVINGS and (bad or not norm <= (1.0 - 1e-4 * lam) * last):
            half = 0.5 * lam  # back along the step to half of what was taken
            for i in range(nf):
                x[free[i]] -= (lam - half) * step[i]
            lam = half
            halvings += 1
            continue
        if bad:
            return KERNEL_FAILED, evaluations, pen, norm
        if not np.isfinite(norm):
            return STALLED, evaluations, pen, norm
        factor = mode != CHORD or it == 0 or norm > CONTRACTION * last
        last, lam, halvings = norm, 1.0, 0
        if it == max_iterations:
            break
        if factor:
            for i in range(nf):
                for j in range(nf):
                    a[i, j] = kt[free[i], free[j]]
        if mode == CHORD:
            if factor and not lu_factor(a, perm):
                return SINGULAR, evaluations, pen, norm
            lu_solve(a, perm, r)
        elif not solve_dense(a, r, perm):
            return SINGULAR, evaluations, pen, norm
        excess = 0.0
        move = 0.0
        for i in range(nf):
            e = abs(r[i]) / cap[i]
            if e > excess:
                excess = e
            if abs(r[i]) > move:
                move = abs(r[i])
        scale = 1.0 / excess if excess > 1.0 else 1.0
        for i in range(nf):
            step[i] = scale * r[i]
            x[free[i]] += step[i]
        # converged when the residual is small and so is the correction just taken: Newton's error after it
        # is of the order of its square, so the state needs no further evaluation
        if norm < RESIDUAL and move < TOLERANCE:
            return CONVERGED, evaluations, pen, norm
    return STALLED, evaluations, pen, norm


@_jit
def _solve_retried(x, guess, free, cap, ref, pc, cs, ld, ct, ff, ms, sp, wk3, max_iterations, skip_open):
    """:func:`_newton` from x, and where it fails again from there, damped and then with a kept Jacobian (x is
    the solution, ``guess`` a work copy of the start); returns (status, evaluations, retries, max penetration,
    residual norm)."""
    for i in range(x.shape[0]):
        guess[i] = x[i]
    evaluations = 0
    retries = 0
    status, ev, pen, norm = _newton(x, free, cap, ref, pc, cs, ld, ct, ff, ms, sp, wk3, max_iterations, PLAIN, skip_open)
    evaluations += ev
    for mode in (DAMPED, CHORD):
        if status == CONVERGED:
            break
        for i in range(x.shape[0]):
            x[i] = guess[i]
        status, ev, pen, norm = _newton(x, free, cap, ref, pc, cs, ld, ct, ff, ms, sp, wk3,
                                        max_iterations if mode == DAMPED else CHORD_ITERATIONS, mode, skip_open)
        evaluations += ev
        retries += 1
    return status, evaluations, retries, pen, norm


@_jit
def ideal_kinematics(q, theta_in, ratio, pin_count, sun, carrier, crank_axes, crank_x, crank_y, crank_th, disc_base,
                      eccentricity, disc_phase, disc_x, disc_y, disc_th, modal, station_src, station_dst):
    """:meth:`rvflex.model.ReducerModel.kinematic_coordinates` in place on ``q`` (the reference coordinates; m,
    rad): one compiled call per quasi-static step instead of some thirty small numpy operations. A beam crank's
    stations (``station_dst``) sit and turn with its node (``station_src``: its x, y, ψz for each)."""
    th_c = theta_in / ratio
    alpha = -pin_count * th_c  # crank angle relative to the carrier
    c, s = math.cos(th_c), math.sin(th_c)
    q[sun] = theta_in
    q[carrier] = th_c
    for i in range(crank_x.shape[0]):
        ax, ay = crank_axes[i, 0], crank_axes[i, 1]
        q[crank_x[i]] = c * ax - s * ay
        q[crank_y[i]] = s * ax + c * ay
        q[crank_th[i]] = th_c + alpha
    for d in range(disc_x.shape[0]):
        vx = disc_base[d, 0] + eccentricity * math.cos(alpha + disc_phase[d])
        vy = disc_base[d, 1] + eccentricity * math.sin(alpha + disc_phase[d])
        q[disc_x[d]] = c * vx - s * vy
        q[disc_y[d]] = s * vx + c * vy
        q[disc_th[d]] += th_c  # a flexible disc may sit turned by a half turn (its reference angle)
    for j in modal:
        q[j] = 0.0
    for i in range(station_dst.shape[0]):
        q[station_dst[i]] = q[station_src[i]]


@_jit
def ring_torque(force, px, py, pins):
    """Torque (N·m) of a disc's pin forces about the output axis: each pin's normal force ``force`` (N) acts
    on the disc along the normal from the pin's centre ``pins`` (n, 2; m) through its contact point (``px``,
    ``py``; m); pins out of contact (zero force) give nothing."""
    t = 0.0
    for p in range(force.shape[0]):
        if not force[p] > 0.0:
            continue
        nx, ny = pins[p, 0] - px[p], pins[p, 1] - py[p]
        ln = math.sqrt(nx * nx + ny * ny)
        if ln > 0.0:
            t -= force[p] * (pins[p, 0] * ny - pins[p, 1] * nx) / ln
    return t


@_jit
def _resultant_into(r, force, px, py, pins):
    """``r`` (2,) set to the resultant (x, y) of a disc's pin forces on the disc (N): :func:`pin_resultant`."""
    r[0] = 0.0
    r[1] = 0.0
    for p in range(force.shape[0]):
        if not force[p] > 0.0:
            continue
        nx, ny = px[p] - pins[p, 0], py[p] - pins[p, 1]
        ln = math.sqrt(nx * nx + ny * ny)
        if ln > 0.0:
            r[0] += force[p] * nx / ln
            r[1] += force[p] * ny / ln


def pin_resultant(force, px, py, pins) -> np.ndarray:
    """Resultant (x, y) of a disc's pin forces on the disc (N), each along the normal from the pin's centre
    through its contact point, as in :func:`ring_torque`."""
    r = np.zeros(2)
    _resultant_into(r, np.ascontiguousarray(force, float), np.ascontiguousarray(px, float),
                    np.ascontiguousarray(py, float), np.ascontiguousarray(pins, float))
    return r


# why a run of steps stopped (beside the Newton statuses): a penetration beyond the contacts' guard, a jump
PENETRATED, JUMPED = 10, 11


@_jit
def _steps(theta, ratio, kin, hist_th, hist_e, nh, last_te, max_jump, max_pen, car, drive, regulariser, x_out,
           out, forces, gaps, torques, resultants, states, records, x, free, cap, ref, fixed_idx, fixed_value, pc, cs,
           ld, ct, ff, ms, sp, max_iterations, sun, carrier, crank_axes, crank_x, crank_y, crank_th, disc_base, eccentricity, disc_phase,
           disc_x, disc_y, disc_th, modal, station_src, station_dst, pin_count):
    """The recorded steps at input angles ``theta`` in one call, each as :meth:`CompiledStep.solve` and the
    caller's loop take it: the guess is the ideal kinematics plus the elastic part extrapolated from the last
    ``nh`` (≤ 3) converged steps (``hist_th``, ``hist_e``, updated in place), the drive and the output regulariser
    set to the step's angle, Newton, the contacts' penetration guard and the jump check against the last TE.
    A step the plain Newton cannot take is tried again from its guess, damped and then with a kept
    Jacobian. Records the output angle (``out``), and with ``states`` the pins' forces and gaps and the discs'
    ring torques and pin-force resultants; without, the pins of a rigid disc that surely stand open are not
    evaluated again (``skip_open`` of :func:`_assemble`). ``records`` (steps, n or 0) takes each step's absolute
    coordinates where it has columns (the spatial model's tilts are read from them). ``x_out`` holds the last converged state (absolute). Returns (steps
    done, status of the step that stopped the run or CONVERGED, evaluations, retries, the last TE, nh)."""
    n = theta.shape[0]
    ct_out, ct_pins = ct[CT_OUT], ct[CT_PINS]  # the contacts' per-pin outputs of their last evaluation, pins
    guess = np.zeros(x.shape[0])
    wk3 = workspace3d(sp[SP_FIRST].shape[0])  # the spatial elements' work arrays, once per run
    evaluations = 0
    retried = 0
    for s in range(n):
        th = theta[s]
        for i in range(kin.shape[0]):
            kin[i] = ref[i]
        ideal_kinematics(kin, th, ratio, pin_count, sun, carrier, crank_axes, crank_x, crank_y, crank_th, disc_base,
                         eccentricity, disc_phase, disc_x, disc_y, disc_th, modal, station_src, station_dst)
        for i in range(x.shape[0]):
            x[i] = kin[i] - ref[i]
        for j in range(nh):  # Lagrange weights at th
            w = 1.0
            for m in range(nh):
                if m != j:
                    w *= (th - hist_th[m]) / (hist_th[j] - hist_th[m])
            for i in range(x.shape[0]):
                x[i] += w * hist_e[j, i]
        fixed_value[drive] = th
        cs[2][regulariser] = th / ratio
        for i in range(fixed_idx.shape[0]):
            x[fixed_idx[i]] = fixed_value[i]
        status, ev, tries, pen, norm = _solve_retried(x, guess, free, cap, ref, pc, cs, ld, ct, ff, ms, sp, wk3,
                                                      max_iterations, not states)
        evaluations += ev
        retried += tries
        if status != CONVERGED:
            return s, status, evaluations, retried, last_te, nh
        if pen > max_pen:
            return s, PENETRATED, evaluations, retried, last_te, nh
        te = x[car] + ref[car] - th / ratio
        if abs(te - last_te) > max_jump:
            return s, JUMPED, evaluations, retried, last_te, nh
        last_te = te
        out[s] = x[car] + ref[car]
        if records.shape[1]:
            for i in range(x.shape[0]):
                records[s, i] = x[i] + ref[i]
        if states:
            for d in range(forces.shape[1]):
                for p in range(forces.shape[2]):
                    forces[s, d, p] = ct_out[d][p, K.O_FORCE]
                    gaps[s, d, p] = ct_out[d][p, K.O_GAP]
                torques[s, d] = ring_torque(ct_out[d][:, K.O_FORCE], ct_out[d][:, K.O_PX], ct_out[d][:, K.O_PY], ct_pins[d])
                _resultant_into(resultants[s, d], ct_out[d][:, K.O_FORCE], ct_out[d][:, K.O_PX], ct_out[d][:, K.O_PY],
                                ct_pins[d])
        if nh == 3:  # keep the last three
            for j in range(2):
                hist_th[j] = hist_th[j + 1]
                for i in range(x.shape[0]):
                    hist_e[j, i] = hist_e[j + 1, i]
            nh = 2
        hist_th[nh] = th
        for i in range(x.shape[0]):
            hist_e[nh, i] = x[i] + ref[i] - kin[i]
            x_out[i] = x[i] + ref[i]
        nh += 1
    return n, CONVERGED, evaluations, retried, last_te, nh


@_jit
def lu_factor(a, piv):
    """LU factors of a in place (unit lower part below the diagonal), partial pivoting with the row
    exchanges in ``piv`` (row k was exchanged with row piv[k]); False when a is singular."""
    n = a.shape[0]
    for k in range(n):
        p, big = k, abs(a[k, k])
        for i in range(k + 1, n):
            if abs(a[i, k]) > big:
                p, big = i, abs(a[i, k])
        if big == 0.0 or not np.isfinite(big):
            return False
        piv[k] = p
        if p != k:
            for j in range(n):
                a[k, j], a[p, j] = a[p, j], a[k, j]
        for i in range(k + 1, n):
            a[i, k] /= a[k, k]
            m = a[i, k]
            if m != 0.0:
                for j in range(k + 1, n):
                    a[i, j] -= m * a[k, j]
    return True


@_jit
def lu_solve(a, piv, b):
    """Solve with :func:`lu_factor`'s factors in place (x in b)."""
    n = b.shape[0]
    for k in range(n):
        p = piv[k]
        if p != k:
            b[k], b[p] = b[p], b[k]
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= a[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= a[i, j] * b[j]
        b[i] = s / a[i, i]


@_jit
def solve_dense(a, b, perm):
    """Solve a·x = b in place (x in b) by :func:`lu_factor` and :func:`lu_solve`; a is overwritten. False when a
    is singular. For the ~15 unknowns of a rigid reducer this is a fraction of a µs, where LAPACK's call costs
    ~10 µs; at the FE carrier's 85–112 unknowns LAPACK would be 2–3× faster, but may run on several threads."""
    if not lu_factor(a, perm):
        return False
    lu_solve(a, perm, b)
    return True


@dataclass(frozen=True)
class _Body:
    """Where a body's coordinates sit in the ODE2 vector: its frame's x (y follows) and angle, and for an FE body
    (ObjectFFRFreducedOrder) its first modal coordinate with the mesh's reference positions and mode basis;
    ``spatial``: a rigid body free in space (ObjectRigidBody on a NodeRigidBodyRxyz: x, y, z, ψx, ψy, ψz from x)."""

    x: int
    angle: int
    modal: int = -1
    positions: np.ndarray | None = None  # (nodes, 3), m
    modes: np.ndarray | None = None  # (3·nodes, m)
    spatial: bool = False


@dataclass(frozen=True)
class _Marker:
    """A marker as the compiled step sees it: its body's x and angle index (−1: ground), its local (global on
    ground) point, and on an FE body the modal coordinates' first index with the marker's modal position rows
    (3, m) and rotation rows (3, m) in the body frame."""

    x: int
    angle: int
    point: np.ndarray
    modal: int = -1
    position_rows: np.ndarray | None = None
    rotation_rows: np.ndarray | None = None


def _rigid_rows(positions: np.ndarray, rows: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Rotation rows (3, m) of the least-squares rigid motion of weighted nodes: per mode, the small rotation ω
    with u_i ≈ t + ω × r_i (r_i about the weighted centroid), as a MarkerSuperElementRigid takes its
    orientation from its nodes (exact for the rigid motion of a bore ring or of RBE3 nodes)."""
    r = positions - w @ positions
    u = rows.reshape(len(w), 3, -1)
    u = u - np.einsum("i,ijk->jk", w, u)[None]
    skew = np.zeros((len(w), 3, 3))
    skew[:, 0, 1], skew[:, 0, 2], skew[:, 1, 2] = -r[:, 2], r[:, 1], -r[:, 0]
    skew -= skew.transpose(0, 2, 1)
    a = np.einsum("i,ikj,ikl->jl", w, skew, skew)  # Σ w r̃ᵀr̃
    b = -np.einsum("i,ikj,ikm->jm", w, skew, u)  # −Σ w r̃ᵀu
    return np.linalg.solve(a, b)


def _marker(mbs, marker: int, objects: list[dict], bodies: dict, nodes: dict) -> _Marker | None:
    """The marker ``marker`` for the compiled step (``objects``, ``bodies``, ``nodes`` as :func:`_bodies`'s);
    None when it is not one it knows."""
    m = mbs.GetMarker(marker)
    kind = m["markerType"]
    if kind == "BodyRigid":
        b = int(m["bodyNumber"])
        lp = np.asarray(m["localPosition"], float)
        if objects[b]["objectType"] == "Ground":
            return _Marker(-1, -1, np.asarray(objects[b]["referencePosition"], float)[:2] + lp[:2])
        body = bodies.get(b)
        if body is None or body.modal >= 0 or body.spatial:
            return None
        return _Marker(body.x, body.angle, lp[:2].copy())
    if kind == "NodeRigid":  # the frame of a planar or FE body
        body = nodes.get(int(m["nodeNumber"]))
        return None if body is None or body.spatial else _Marker(body.x, body.angle, np.zeros(2))
    if kind == "SuperElementRigid":
        body = bodies.get(int(m["bodyNumber"]))
        if body is None or body.modal < 0 or m.get("rotationsExponentialMap", 2) != 2:
            return None
        idx = np.asarray(m["meshNodeNumbers"], int)
        w = np.asarray(m["weightingFactors"], float)
        offset = np.asarray(m["offset"], float)
        rows = body.modes[(3 * idx[:, None] + np.arange(3)).ravel()]
        pos_rows = np.einsum("i,ijk->jk", w, rows.reshape(len(idx), 3, -1))
        rot_rows = _rigid_rows(body.positions[idx], rows, w)
        point = w @ body.positions[idx] + offset
        if abs(point[2]) > 1e-9:  # out of the plane: the in-plane laws would miss its lever
            return None
        return _Marker(body.x, body.angle, point[:2], body.modal, pos_rows, rot_rows)
    return None


def _current():
    import exudyn as exu

    return exu.ConfigurationType.Current


class CompiledStep:
    """The compiled static step of one reducer model (build with :func:`compiled_step`).

    ``solve`` has the interface of the Newton objects of :mod:`rvflex.solve`: the equilibrium from a guess
    with the drive, the output regulariser and the output load as currently set in the Exudyn system.
    """

    def __init__(self, model, data: dict):
        self.model = model
        self.d = data
        self.fallbacks = 0
        self.retried = 0  # retries of steps the plain Newton could not take (damped, then chord)
        self.iterations = 0
        self.evaluations = 0
        self.solved = False  # the last solve converged (its pin outputs are the step's)
        self.skip_open = False  # single solves skip the surely open pins (no pin outputs then; _assemble)
        self.backup = None  # the caller's Newton to try when this one fails (rvflex.solve sets its chord Newton)
        d = data
        # the compiled functions' argument groups (arrays shared with ``d``: _runtime's updates reach them)
        self.packs = ((d["pc_idx"], d["pc_angle"], d["pc_mcol"], d["pc_rows"], d["pc_lp"], d["pc_kind"], d["pc_par"]),
                      (d["cs_idx"], d["cs_k"], d["cs_off"]), (d["ld_idx"], d["ld_val"]),
                      tuple(d[k] for k in _CONTACT_KEYS), (d["ff_start"], d["ff_m"], d["ff_k"]),
                      (d["ms_idx"], d["ms_par"]), tuple(d[k] for k in _SPATIAL_KEYS))
        self.records = np.zeros((0, 0))  # the absolute coordinates of the last run's steps (spatial model)
        self.wk3 = workspace3d(len(d["b3_first"]))  # the spatial elements' work arrays of single solves

    def reset(self) -> None:
        """Forget the last solve (interface of rvflex.solve's Newtons: Exudyn's solver takes the step)."""
        self.solved = False
        if self.backup is not None:
            self.backup.reset()

    def counts(self) -> dict:
        """What the step has done so far: ``free`` coordinates, Newton ``evaluations`` and linear ``solves``,
        ``retried`` (retries of steps the plain Newton could not take: damped, then with a kept Jacobian),
        ``fallbacks`` (steps it could not take) and ``backup_steps`` (those its backup then took)."""
        return {"free": int(len(self.d["free"])), "evaluations": self.evaluations, "solves": self.iterations,
                "retried": self.retried, "fallbacks": self.fallbacks,
                "backup_steps": getattr(self.backup, "steps", 0)}

    def _runtime(self) -> None:
        """Read what a run changes between steps: the prescribed coordinates, the regulariser and the load."""
        mbs, d = self.model.mbs, self.d
        for k, obj in enumerate(d["fixed_objects"]):
            d["fixed_value"][k] = mbs.GetObjectParameter(obj, "offset")
        for k, obj in enumerate(d["spring_objects"]):
            d["cs_k"][k] = mbs.GetObjectParameter(obj, "stiffness")
            d["cs_off"][k] = mbs.GetObjectParameter(obj, "offset")
        for k, ld in enumerate(d["load_items"]):
            d["ld_val"][k] = mbs.GetLoadParameter(ld, "load")

    def residual(self, q_abs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """RHS force and LHS Jacobian of the whole system at absolute coordinates ``q_abs`` (N, N·m; every
        ODE2 coordinate, the prescribed ones included): for tests against Exudyn's residual."""
        self._runtime()
        n = len(q_abs)
        x = np.asarray(q_abs, float) - self.model.reference
        f, kt = np.zeros(n), np.zeros((n, n))
        pc, cs, ld, ct, ff, ms, sp = self.packs
        _assemble(x, self.d["ref"], pc, cs, ld, ct, ff, ms, sp, f, kt, np.zeros(n),
                  _workspace(pc[2].shape[2], _contact_size(ct)), workspace3d(sp[SP_FIRST].shape[0]), False)
        return f, kt

    def _attempt(self, guess: np.ndarray) -> tuple[int, np.ndarray, float, float]:
        """Newton from ``guess`` (displacements) with its retries (:func:`_solve_retried`): (status, state,
        max penetration, residual norm)."""
        d = self.d
        x = guess.copy()
        status, ev, tries, pen, norm = _solve_retried(x, np.empty_like(x), d["free"], d["cap"], d["ref"], *self.packs,
                                                      self.wk3, MAX_ITERATIONS, self.skip_open)
        self.evaluations += ev
        self.iterations += ev  # each evaluation is followed by one linear solve (or a halving)
        self.retried += tries
        return status, x, pen, norm

    def solve(self, q_abs: np.ndarray) -> np.ndarray:
        """Equilibrium from the guess ``q_abs`` (absolute ODE2 coordinates); raises :class:`StepFailed`
        when Newton does not converge and the model's ContactError on an overloaded contact.

        A step Newton cannot take from the guess is taken again under a growing share of the loads, as
        Exudyn's static solver ramps its load factor: from the unloaded state to the full load in adaptive
        increments (doubled after a success, halved after a failure, down to LOAD_RAMP_MIN)."""
        self.solved = False
        self._runtime()
        d = self.d
        guess = np.asarray(q_abs, float) - self.model.reference
        guess[d["fixed_idx"]] = d["fixed_value"]
        status, x, pen, norm = self._attempt(guess)
        loads = d["ld_val"]
        if status != CONVERGED and np.any(loads != 0.0):
            full = loads.copy()
            share, inc = 0.0, 0.25
            try:
                while share < 1.0 and inc >= LOAD_RAMP_MIN:
                    loads[:] = min(1.0, share + inc) * full
                    status, x1, pen, norm = self._attempt(guess)
                    if status == CONVERGED:
                        share, guess, inc = min(1.0, share + inc), x1, min(0.5, 2.0 * inc)
                    else:
                        inc *= 0.5
            finally:
                loads[:] = full
            x = guess
            if share < 1.0:
                status = STALLED
        if status != CONVERGED:
            raise StepFailed(f"compiled Newton: status {status}, residual {norm:.3e}")
        # the deepest penetration over every disc, checked by the contacts' own guard (which names the first
        # disc's node even when another one penetrates)
        contacts = self.model.discs.contacts
        for c in contacts:
            c._work.penetration = pen
        contacts[0].check_penetration()
        # the system holds the state, as after Exudyn's solver: whatever reads it next (a pin state, the
        # loaded state a torque stepping hands on, Exudyn's solver taking the next step) sees this one
        self.model.mbs.systemData.SetODE2Coordinates(x, configuration=_current())
        self.solved = not self.skip_open  # the pins' outputs are this step's where every pin was evaluated
        return x + self.model.reference

    def steps(self, theta: np.ndarray, history: list, last_te: float, max_jump: float, out: np.ndarray,
              forces: np.ndarray, gaps: np.ndarray, torques: np.ndarray, resultants: np.ndarray,
              states: bool) -> tuple[int, list, float, np.ndarray | None]:
        """Recorded steps at the input angles ``theta`` (rad) in one compiled call, as the caller's loop takes them
        one by one with :meth:`solve` (the extrapolated guess from ``history``, a list of (θ_in, elastic part)
        of the last converged steps, the penetration guard and the jump check beyond ``max_jump`` rad against
        ``last_te``), under the load and regulariser stiffness currently set in the Exudyn system. Fills
        ``out``, and with ``states`` ``forces``, ``gaps``, the discs' ring ``torques`` and pin-force ``resultants``
        (steps, contacts, 2), for the steps taken and stops before the first
        that fails (which the caller takes its own way). Returns (steps taken, history, last TE, last state or
        None when none was taken); the Exudyn system is left at the last state with its drive and regulariser."""
        d, model = self.d, self.model
        if d["drive_slot"] < 0 or d["regulariser_slot"] < 0 or not len(theta):
            return 0, history, last_te, None
        self._runtime()
        nh = len(history)
        n2 = len(model.reference)
        hist_th, hist_e = np.zeros(3), np.zeros((3, n2))
        for j, (tj, ej) in enumerate(history[-3:]):
            hist_th[j], hist_e[j] = tj, ej
        x, x_out, kin = np.zeros(n2), np.zeros(n2), np.zeros(n2)
        records = np.zeros((len(theta), n2 if model.spatial else 0))
        contacts = model.discs.contacts
        done, status, ev, retried, last_te, nh = _steps(
            np.ascontiguousarray(theta, float), float(model.ratio), kin, hist_th, hist_e, min(nh, 3), float(last_te),
            float(max_jump), float(min(c.max_penetration_m for c in contacts)), int(model.output_index),
            d["drive_slot"], d["regulariser_slot"], x_out, out, forces, gaps, torques, resultants, bool(states), records,
            x, d["free"],
            d["cap"],
            d["ref"], d["fixed_idx"], d["fixed_value"], *self.packs, MAX_ITERATIONS, *model._kinematics,
            float(model.spec.cycloid.pin_count))
        self.evaluations += ev
        self.iterations += ev
        self.retried += retried
        self.records = records[:done]
        if done == 0:
            return 0, history, last_te, None
        th = float(theta[done - 1])
        mbs = model.mbs
        mbs.SetObjectParameter(model.sun.drive, "offset", th)
        mbs.SetObjectParameter(model.carrier.regulariser, "offset", th / model.ratio)
        mbs.systemData.SetODE2Coordinates(x_out - model.reference, configuration=_current())
        # the pins' outputs are the last step's where it converged and every pin was evaluated (with ``states``;
        # else the open pins' gaps are those of their last evaluation)
        self.solved = status == CONVERGED and bool(states)
        return done, [(float(hist_th[j]), hist_e[j].copy()) for j in range(nh)], last_te, x_out

    def pin_outputs(self, disc: int) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
        """Per-pin normal force (N) and gap (m) of contact ``disc`` at the last solved state, its ring torque
        (N·m, :func:`ring_torque`) and the resultant (x, y) of its pin forces on the disc (N,
        :func:`pin_resultant`)."""
        out, pins = self.d["ct_out"][disc], self.d["ct_pins"][disc]
        return (out[:, K.O_FORCE].copy(), out[:, K.O_GAP].copy(),
                float(ring_torque(out[:, K.O_FORCE], out[:, K.O_PX], out[:, K.O_PY], pins)),
                pin_resultant(out[:, K.O_FORCE], out[:, K.O_PX], out[:, K.O_PY], pins))



def _bodies(mbs, objects: list[dict]) -> tuple[dict, dict] | None:
    """Every body of the system (``objects``: its objects' parameters, in order) by object and by node
    (:class:`_Body`); None when one of them is of a kind the compiled step does not replicate (an FE body with
    user functions or out-of-plane freedom is declined later, by its constraints)."""
    bodies, nodes = {}, {}
    for i, o in enumerate(objects):
        if o["objectType"] == "RigidBody2D":
            x = int(mbs.GetNodeODE2Index(o["nodeNumber"]))
            bodies[i] = nodes[int(o["nodeNumber"])] = _Body(x, x + 2)
        elif o["objectType"] == "FFRFreducedOrder":
            if o.get("forceUserFunction") or o.get("massMatrixUserFunction"):
                return None
            frame, modal = (int(n) for n in o["nodeNumbers"])
            if mbs.GetNode(frame)["nodeType"] != "RigidBodyRxyz":
                return None
            x = int(mbs.GetNodeODE2Index(frame))
            body = _Body(x, x + 5, int(mbs.GetNodeODE2Index(modal)),
                         np.asarray(o["referencePositions"], float).reshape(-1, 3), np.asarray(o["modeBasis"], float))
            bodies[i] = nodes[frame] = body
        elif o["objectType"] == "RigidBody":  # static: no force of its own (no velocity, no gravity load)
            node = int(o["nodeNumber"])
            if mbs.GetNode(node)["nodeType"] != "RigidBodyRxyz":
                return None
            x = int(mbs.GetNodeODE2Index(node))
            bodies[i] = nodes[node] = _Body(x, x + 5, spatial=True)
    return bodies, nodes


def compiled_step(model) -> CompiledStep | None:
    """The compiled step of ``model``, or None when its system holds an item the compiled step does not
    replicate (other connector laws, an FE body free out of its plane, user functions on an FE body, a connector
    between a planar and a spatial body): that model is solved by Exudyn. The spatial model (rigid bodies on
    NodeRigidBodyRxyz, the main bearing pair element, tilting contact slices and gear meshes, a beam crank's
    segments) is replicated by :mod:`rvflex.engine3d`'s elements."""
    mbs = model.mbs
    sd = mbs.systemData
    bearing_law = {}  # connector → (ε, w, e, x_r) of rvflex's clearance law
    pairs = [model.carrier.main, *model.cranks.supports, *model.input_seat_supports]
    pairs += [p for row in model.discs.eccentric_bearings for p in row]
    for p in pairs:
        if p is not None:  # the spatial carrier has the pair element instead of a main bearing
            b = p.bearing
            bearing_law[b.connector] = (b.clearance_m, b.smoothing_m, b.load_exponent, b.reference_approach_m)
    for row in model.cranks.segments:  # a beam crank's segments: the same law, linear, without clearance
        for segment in row:
            bearing_law[segment] = (0.0, 0.0, 1.0, 0.0)
    pair = getattr(model.carrier, "pair", None)
    contacts = {c.object_index: c for c in model.discs.contacts}
    meshes = {h.mesh_object: h for h in model.cranks.meshes}
    objects = [mbs.GetObject(i) for i in range(sd.NumberOfObjects())]  # read once: an FE body's are megabytes
    found = _bodies(mbs, objects)
    if found is None:
        return None
    bodies, nodes = found
    stiffness = {b.modal: None for b in bodies.values() if b.modal >= 0}  # FE bodies' modal stiffness
    sides, pc_kind, pc_par = [], [], []
    sides3, b3_kind, b3_par = [], [], []  # 3D point connectors (rvflex.engine3d.bushings3d)
    fixed_idx, fixed_objects, cs_idx, spring_objects = [], [], [], []
    ct, ms_idx, ms_par, ms_lever, ms_tilt, bp = [], [], [], [], [], []

    def coordinate(marker: int) -> int | None:
        m = mbs.GetMarker(marker)
        if m["markerType"] != "NodeCoordinate":
            return None
        node = mbs.GetNode(m["nodeNumber"])
        if node["nodeType"] == "PointGround":
            return -1
        return int(mbs.GetNodeODE2Index(m["nodeNumber"])) + int(m["coordinate"])

    def out_of_plane(pts: list[_Marker], k_axial: float, k_tilt: float) -> bool:
        """Add a connector's axial and tilt springs where they act on an FE body's modes (the marker's z and
        tilt are linear in them; the other marker is held in the plane): False when both markers move."""
        moving = [p for p in pts if p.modal >= 0]
        if len(moving) > 1:
            return False
        for p in moving:
            z, tilt = p.position_rows[2], p.rotation_rows[:2]
            stiffness[p.modal] = stiffness[p.modal] + k_axial * np.outer(z, z) + k_tilt * tilt.T @ tilt
        return True

    for i, o in enumerate(objects):
        kind = o["objectType"]
        if kind in ("Ground", "RigidBody2D", "RigidBody"):
            continue
        if kind == "FFRFreducedOrder":
            b = bodies[i]
            stiffness[b.modal] = np.asarray(o["stiffnessMatrixReduced"].Convert2DenseMatrix(), float)
            if stiffness[b.modal].shape != (b.modes.shape[1],) * 2:
                return None
            continue
        if not o.get("activeConnector", True):
            continue
        if kind in ("ConnectorRigidBodySpringDamper", "ConnectorCartesianSpringDamper"):
            pts3 = [marker3d(mbs, m, objects, bodies, nodes) for m in o["markerNumbers"]]
            if None not in pts3 and max(p[0] for p in pts3) >= 0:  # between spatial bodies (or one and ground)
                law = connector_law3d(o, bearing_law.get(i))
                if law is None:
                    return None
                sides3.append(pts3)
                b3_kind.append(law[0])
                b3_par.append(law[1])
                continue
            pts = [_marker(mbs, m, objects, bodies, nodes) for m in o["markerNumbers"]]
            if None in pts or np.any(np.asarray(o["offset"], float)[:2] != 0.0) and kind != "ConnectorCartesianSpringDamper":
                return None
            if kind == "ConnectorRigidBodySpringDamper":
                if i not in bearing_law or o.get("useIntrinsicFormulation"):
                    return None
                k = np.asarray(o["stiffness"], float)
                if k[3, 3] != k[4, 4] or not out_of_plane(pts, k[2, 2], k[3, 3]):
                    return None
                eps, w, e, x_r = bearing_law[i]
                pc_kind.append(LAW_CLEARANCE)
                pc_par.append([k[0, 0], eps, w, e, k[0, 0] * x_r ** (1.0 - e) if e != 1.0 else k[0, 0]])
            else:
                k, off = np.asarray(o["stiffness"], float), np.asarray(o["offset"], float)
                if off[2] != 0.0 or not out_of_plane(pts, k[2], 0.0):
                    return None
                pc_kind.append(LAW_CARTESIAN)
                pc_par.append([k[0], k[1], off[0], off[1], 0.0])
            sides.append(pts)
        elif kind == "ConnectorCoordinate":
            c0, c1 = (coordinate(m) for m in o["markerNumbers"])
            if c0 != -1 or c1 is None or c1 < 0 or o.get("factor1", 1.0) != 1.0 or o.get("velocityLevel"):
                return None
            fixed_idx.append(c1)
            fixed_objects.append(i)
        elif kind == "ConnectorCoordinateSpringDamper":
            c0, c1 = (coordinate(m) for m in o["markerNumbers"])
            if c0 != -1 or c1 is None or c1 < 0:
                return None
            cs_idx.append(c1)
            spring_objects.append(i)
        elif kind == "GenericODE2" and i in contacts:
            c = contacts[i]
            if int(c.node) not in nodes or (c.housing_node >= 0 and c.housing_node != model.pins.modal_node):
                return None
            if c.tilted != nodes[int(c.node)].spatial or c.tilted and (c.n_modes or c.n_housing_modes):
                return None
            ct.append(c)
        elif kind == "GenericODE2" and i == model.pins.body and model.pins.modal_node >= 0:
            # the flexible housing: a linear body on its modal coordinates, clamped (no frame, no FFRF terms)
            if o.get("forceUserFunction") or o.get("massMatrixUserFunction") or o.get("jacobianUserFunction"):
                return None
            k = o["stiffnessMatrix"]
            k = np.asarray(k.Convert2DenseMatrix() if hasattr(k, "Convert2DenseMatrix") else k, float)
            stiffness[int(mbs.GetNodeODE2Index(model.pins.modal_node))] = k
        elif kind == "GenericODE2" and i in meshes:
            h = meshes[i]
            planet = nodes.get(int(h.planet_node))
            if (h.planet_lever_m is not None) != (planet is not None and planet.spatial):
                return None
            ms_idx.append([mbs.GetNodeODE2Index(h.sun_node), mbs.GetNodeODE2Index(h.planet_node)])
            ms_par.append(h.parameters)
            ms_lever.append(-1.0 if h.planet_lever_m is None else h.planet_lever_m)
            ms_tilt.append(h.planet_lever_m is not None)
        elif kind == "GenericODE2" and pair is not None and i == pair.object:
            if not (int(pair.node) in nodes and nodes[int(pair.node)].spatial):
                return None
            bp.append(pair)
        else:
            return None
    load_items, ld_idx = [], []
    for i in range(sd.NumberOfLoads()):
        ld = mbs.GetLoad(i)
        if ld["loadType"] != "Coordinate":
            return None
        c = coordinate(ld["markerNumber"])
        if c is None or c < 0:
            return None
        load_items.append(i)
        ld_idx.append(c)
    n2 = sd.ODE2Size()
    if sd.AEsize() != len(fixed_idx) or len(set(fixed_idx)) != len(fixed_idx):
        return None
    held = set(fixed_idx)
    for b in bodies.values():  # an FE body's frame must be held in the plane (z, ψx, ψy)
        if b.modal >= 0 and not {b.x + 2, b.x + 3, b.x + 4} <= held:
            return None
    free = np.array([j for j in range(n2) if j not in held], dtype=np.int64)
    cap = np.full(n2, np.inf)
    for name, idx in model.planar_index().items():
        cap[idx[:2]] = CAP_M
        cap[idx[2]] = CAP_M / (CRANK_CAP_RADIUS_M if name.startswith("crank") else CAP_RADIUS_M)
    for idx in model.spatial_index().values():  # a spatial body's z and tilts (an FE frame's are held)
        cap[idx[2]] = CAP_M
        cap[idx[3:5]] = CAP_M / CAP_RADIUS_M
    # point connectors: per marker, the modal coordinates that move it (only those with a nonzero row)
    moved = [[np.flatnonzero(np.any(p.position_rows[:2] != 0.0, axis=0)) if p.modal >= 0 else np.zeros(0, int)
              for p in pts] for pts in sides]
    mmax = max([len(j) for row in moved for j in row], default=0)
    pc_mcol = np.full((len(sides), 2, mmax), -1, dtype=np.int64)
    pc_rows = np.zeros((len(sides), 2, 2, mmax))
    for c, pts in enumerate(sides):
        for s, p in enumerate(pts):
            j = moved[c][s]
            if len(j):
                pc_mcol[c, s, :len(j)] = p.modal + j
                pc_rows[c, s, :, :len(j)] = p.position_rows[:2, j]
    ff = sorted(stiffness)
    fm = max([stiffness[s].shape[0] for s in ff], default=0)
    ff_k = np.zeros((len(ff), fm, fm))
    for b, s in enumerate(ff):
        ff_k[b, :stiffness[s].shape[0], :stiffness[s].shape[0]] = stiffness[s]
    data = {
        "ref": np.asarray(model.reference, float).copy(),
        "free": free, "cap": cap[free].copy(),
        "fixed_idx": np.array(fixed_idx, dtype=np.int64), "fixed_objects": fixed_objects,
        "fixed_value": np.zeros(len(fixed_idx)),
        # the input drive's and the output regulariser's places among them (-1: not there, no batched steps)
        "drive_slot": fixed_objects.index(model.sun.drive) if model.sun.drive in fixed_objects else -1,
        "regulariser_slot": (spring_objects.index(model.carrier.regulariser)
                             if model.carrier.regulariser in spring_objects else -1),
        "pc_idx": np.array([[p.x for p in pts] for pts in sides], dtype=np.int64).reshape(-1, 2),
        "pc_angle": np.array([[p.angle for p in pts] for pts in sides], dtype=np.int64).reshape(-1, 2),
        "pc_mcol": pc_mcol, "pc_rows": pc_rows,
        "pc_lp": np.array([[p.point for p in pts] for pts in sides], float).reshape(-1, 2, 2),
        "pc_kind": np.array(pc_kind, dtype=np.int64), "pc_par": np.array(pc_par, float).reshape(-1, 5),
        "cs_idx": np.array(cs_idx, dtype=np.int64), "spring_objects": spring_objects,
        "cs_k": np.zeros(len(cs_idx)), "cs_off": np.zeros(len(cs_idx)),
        "ld_idx": np.array(ld_idx, dtype=np.int64), "load_items": load_items, "ld_val": np.zeros(len(ld_idx)),
        "ff_start": np.array(ff, dtype=np.int64), "ff_m": np.array([stiffness[s].shape[0] for s in ff], dtype=np.int64),
        "ff_k": ff_k,
        "ct_rig": np.array([nodes[int(c.node)].x + np.asarray(c.rigid_index) for c in ct], dtype=np.int64).reshape(-1, 3),
        "ct_mod": np.array([mbs.GetNodeODE2Index(c.modal_node) if c.modal_node >= 0 else -1 for c in ct],
                           dtype=np.int64),
        "ct_hmod": np.array([mbs.GetNodeODE2Index(c.housing_node) if c.housing_node >= 0 else -1 for c in ct],
                            dtype=np.int64),
        "ct_ref": np.array([np.asarray(c.reference, float)[list(c.rigid_index)] for c in ct]).reshape(-1, 3),
        "ct_offset": np.array([c.offset_rad for c in ct], float),
        "ct_window": np.array([c.zone_window_rad for c in ct], float),
        "ms_idx": np.array(ms_idx, dtype=np.int64).reshape(-1, 2),
        "ms_par": np.array(ms_par, float).reshape(-1, len(ms_par[0]) if ms_par else 0),
        **spatial_data(mbs, sides3, b3_kind, b3_par, bp, [c.lever_m for c in ct],
                        [nodes[int(c.node)].x for c in ct], ms_tilt, ms_lever),
    }
    for key, get in (("ct_pins", lambda c: np.ascontiguousarray(c.pins_m, float)),
                     ("ct_radii", lambda c: np.ascontiguousarray(c.radii_m, float)),
                     ("ct_par", lambda c: np.ascontiguousarray(c.profile.par, float)),
                     ("ct_herr", lambda c: np.ascontiguousarray(c.profile.herr, float)),
                     ("ct_hpsi", lambda c: np.ascontiguousarray(c.profile.hpsi, float)),
                     ("ct_law", lambda c: np.ascontiguousarray(c._law_vec, float)),
                     ("ct_tcache", lambda c: c._t_cache),  # shared: the closest-point warm start carries over
                     ("ct_zones", lambda c: np.ascontiguousarray(c.zones, float)),
                     ("ct_out", lambda c: np.zeros((len(c.radii_m), K.N_OUT))),
                     ("ct_pout", lambda c: K.empty_points(len(c.radii_m))[0]),
                     ("ct_count", lambda c: K.empty_points(len(c.radii_m))[1]),
                     ("ct_phi", lambda c: np.ascontiguousarray(c.phi, float)),
                     ("ct_f", lambda c: np.zeros(3 + c.n_modes + c.n_housing_modes)),
                     ("ct_k", lambda c: np.zeros((3 + c.n_modes + c.n_housing_modes,) * 2)),
                     ("ct_d", lambda c: np.zeros((3 + c.n_modes + c.n_housing_modes,) * 2)),
                     ("ct_eta", lambda c: np.zeros(c.n_modes)),
                     ("ct_etad", lambda c: np.zeros(c.n_modes)),
                     ("ct_seat", lambda c: np.ascontiguousarray(c.seat, float)),
                     ("ct_xi", lambda c: np.zeros(c.n_housing_modes)),
                     ("ct_xid", lambda c: np.zeros(c.n_housing_modes)),
                     ("ct_pf", lambda c: np.zeros(3 + c.n_modes)),  # the housing kernel's per-pin buffers
                     ("ct_pk", lambda c: np.zeros((3 + c.n_modes,) * 2)),
                     ("ct_pd", lambda c: np.zeros((3 + c.n_modes,) * 2)),
                     # each pin's centre and certified gap at its last evaluation (none yet)
                     ("ct_last", lambda c: np.tile([0.0, 0.0, -np.inf], (len(c.radii_m), 1)))):
        arrays = [get(c) for c in ct]
        # one stacked array where every disc's has the same shape (the usual case: cheaper to pass and index),
        # else a tuple of them (the warm starts always: the contacts' own arrays); the compiled functions index
        # both alike (a numba typed list would do too, but its methods compile in every process, 0.4 s)
        same = len({(a.shape, a.dtype) for a in arrays}) == 1
        data[key] = np.stack(arrays) if same and key != "ct_tcache" else tuple(arrays)
    return CompiledStep(model, data)

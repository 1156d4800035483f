"""Compiled quasi-static step of a rigid planar reducer: Newton's method on the whole system in one
numba call.

Exudyn's static solver takes a step of the rigid model in about 0.3 ms of its own work beside the contact
kernels (residual and Jacobian through the item list, Python user functions per disc and mesh, the
connectors' Jacobians by finite differences). The step itself is a few Newton iterations on ~15 unknowns,
each one evaluation of the contact kernels and a 15 × 15 solve. :class:`CompiledStep` reads the assembled
Exudyn system once per run (bodies, markers, connectors, loads and the contact and mesh elements' own kernel
data) and solves each step in compiled code with the same force laws:

- ``ConnectorRigidBodySpringDamper`` with rvflex's clearance-bearing law (:mod:`rvflex.contact.bearing`):
  the central radial force k·r_w(d − ε)·d/|d| between the two marker points, applied at each marker
  (the law's axial and tilt terms are out of the plane);
- ``ConnectorCartesianSpringDamper``: k_x, k_y springs on the markers' relative position;
- ``ConnectorCoordinateSpringDamper`` (the output regulariser) and ``LoadCoordinate`` (the output torque);
- ``ConnectorCoordinate`` holding a coordinate at its offset (the input drive and the sun's centre): the
  coordinate is prescribed, not solved for;
- the cycloid–pin contacts and the involute meshes through their own numba kernels
  (``rvflex.contact.cycloid_pin.evaluate_kernel``, ``rvflex.contact.gear_mesh.mesh_kernel``).

Exudyn stays the model of record: a system holding any other item (FE bodies, a flexible housing, a
connector law not listed) gets no compiled step (:func:`compiled_step` returns None) and is solved by
Exudyn; the residual at any state equals Exudyn's ``ComputeNewtonResidual`` (tests/test_engine.py) and the
quasi-static TE equals that of Exudyn's static solver within 1e-4″. The solved state is written back to the
Exudyn system, so whatever reads the system next sees it.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numba.typed import List

from rvflex.contact import cycloid_pin as K
from rvflex.contact.gear_mesh import N_STATE as MESH_STATE
from rvflex.contact.gear_mesh import mesh_kernel

__all__ = ["CompiledStep", "compiled_step", "ideal_kinematics", "solve_dense", "StepFailed"]

# point connectors: law kinds
LAW_CLEARANCE, LAW_CARTESIAN = 0, 1
# Newton: the same caps and tolerances as the chord Newton of rvflex.solve (see there why a move is capped)
CAP_M = 1e-5
CAP_RADIUS_M = 0.03
TOLERANCE = 1e-10
RESIDUAL = 1e-2
MAX_ITERATIONS = 60
# status codes of the compiled Newton
CONVERGED, STALLED, KERNEL_FAILED, SINGULAR = 0, 1, 2, 3



def _drop_stale_cache() -> None:
    """Remove this module's numba cache when a kernel it calls has changed.

    numba keys a cached function on its own module's source only; the compiled step links the contact,
    mesh and geometry kernels into its own code, so after an edit of one of them the cache would go on
    running the old kernel. A stamp of their sources beside the cache tells; a read-only install (no
    stamp written) compiles as numba decides."""
    import hashlib
    from importlib.util import find_spec
    from pathlib import Path

    kernels = ("rvflex.contact._cycloid_kernel", "rvflex.contact.gear_mesh", "rvflex.geometry._kernels")
    try:
        digest = hashlib.sha1(b"".join(Path(find_spec(m).origin).read_bytes() for m in kernels)).hexdigest()
        cache = Path(__file__).parent / "__pycache__"
        stamp = cache / f"engine.kernels-{digest[:16]}.stamp"
        if stamp.exists() or not cache.is_dir():
            return
        for f in [*cache.glob("engine.*.nbi"), *cache.glob("engine.*.nbc"), *cache.glob("engine.kernels-*.stamp")]:
            f.unlink(missing_ok=True)
        stamp.touch()
    except OSError:
        pass


_drop_stale_cache()
_jit = nb.njit(cache=True, nogil=True)


class StepFailed(RuntimeError):
    """A compiled step did not converge (the caller solves it again with Exudyn)."""


@_jit
def _ramp(x, w):
    """r_w(x) and its derivative (rvflex.contact.bearing's smoothed clearance ramp)."""
    if w == 0.0:
        return (x, 1.0) if x > 0.0 else (0.0, 0.0)
    if x <= -w:
        return 0.0, 0.0
    if x >= w:
        return x, 1.0
    return (x + w) * (x + w) / (4.0 * w), (x + w) / (2.0 * w)


@_jit
def _point_connectors(qa, idx, lp, kind, par, f, kt):
    """Add the point connectors' forces (f, RHS) and LHS Jacobian (kt = −∂f/∂q) at absolute coordinates qa."""
    nc = idx.shape[0]
    p = np.empty((2, 2))
    r = np.empty((2, 2))
    for c in range(nc):
        for s in range(2):
            b = idx[c, s]
            if b < 0:  # a ground marker: lp holds its global position
                r[s, 0] = 0.0
                r[s, 1] = 0.0
                p[s, 0] = lp[c, s, 0]
                p[s, 1] = lp[c, s, 1]
            else:
                ct, st = math.cos(qa[b + 2]), math.sin(qa[b + 2])
                r[s, 0] = ct * lp[c, s, 0] - st * lp[c, s, 1]
                r[s, 1] = st * lp[c, s, 0] + ct * lp[c, s, 1]
                p[s, 0] = qa[b] + r[s, 0]
                p[s, 1] = qa[b + 1] + r[s, 1]
        dx = p[1, 0] - p[0, 0]
        dy = p[1, 1] - p[0, 1]
        # F: force on marker 1 (marker 0 gets −F); A = ∂F/∂d
        if kind[c] == LAW_CLEARANCE:
            k, eps, w = par[c, 0], par[c, 1], par[c, 2]
            if eps == 0.0:
                fx, fy = -k * dx, -k * dy
                a00, a01, a10, a11 = -k, 0.0, 0.0, -k
            else:
                d = math.sqrt(dx * dx + dy * dy)
                rw, drw = _ramp(d - eps, w)
                if rw == 0.0 and drw == 0.0:
                    continue
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
            b = idx[c, s]
            if b < 0:
                continue
            sg = 1.0 if s == 1 else -1.0
            gx, gy = sg * fx, sg * fy
            f[b] += gx
            f[b + 1] += gy
            f[b + 2] += r[s, 0] * gy - r[s, 1] * gx
            # Jacobian rows of body s against the columns of body t: ∂(J_sᵀ·sgF)/∂q_t
            for t in range(2):
                bt = idx[c, t]
                if bt < 0:
                    continue
                st_ = sg * (1.0 if t == 1 else -1.0)  # ∂d/∂q_t = ±J_t
                # J_t = [[1, 0, −r_ty], [0, 1, r_tx]]
                j0 = (1.0, 0.0, -r[t, 1])
                j1 = (0.0, 1.0, r[t, 0])
                for col in range(3):
                    gdx = st_ * (a00 * j0[col] + a01 * j1[col])  # ∂(sgF_x)/∂q_t,col
                    gdy = st_ * (a10 * j0[col] + a11 * j1[col])
                    kt[b, bt + col] -= gdx
                    kt[b + 1, bt + col] -= gdy
                    kt[b + 2, bt + col] -= r[s, 0] * gdy - r[s, 1] * gdx
            # the lever r_s turns with θ_s: ∂(r_s × G)/∂θ_s = −r_s·G
            kt[b + 2, b + 2] -= -(r[s, 0] * gx + r[s, 1] * gy)


@_jit
def _assemble(x, ref, pc_idx, pc_lp, pc_kind, pc_par, cs_idx, cs_k, cs_off, ld_idx, ld_val,
              ct_node, ct_ref, ct_offset, ct_pins, ct_radii, ct_par, ct_herr, ct_hpsi, ct_law, ct_tcache, ct_zones,
              ct_window, ct_out, ct_pout, ct_count, ms_idx, ms_par, f, kt, qa, work3, workk, workd, meshq,
              meshqt, meshf, meshdf, meshdft, meshst):
    """Force (RHS) and LHS Jacobian of the whole system at displacement x; returns (max penetration, bad pins)."""
    n = x.shape[0]
    for i in range(n):
        qa[i] = ref[i] + x[i]
        f[i] = 0.0
        for j in range(n):
            kt[i, j] = 0.0
    _point_connectors(qa, pc_idx, pc_lp, pc_kind, pc_par, f, kt)
    for c in range(cs_idx.shape[0]):  # coordinate springs to ground: −k(q − offset)
        i = cs_idx[c]
        f[i] -= cs_k[c] * (x[i] - cs_off[c])
        kt[i, i] += cs_k[c]
    for c in range(ld_idx.shape[0]):
        f[ld_idx[c]] += ld_val[c]
    pen = -np.inf
    bad = 0
    phi = np.zeros((0, 2, 0))
    eta = np.zeros(0)
    qd = np.zeros(3)  # a quasi-static step: no velocities (the kernel only reads them)
    for d in range(ct_node.shape[0]):
        b = ct_node[d]
        for i in range(3):
            work3[i] = ct_ref[d, i] + x[b + i]
        p, nbad = K.evaluate_kernel(work3, qd, ct_offset[d], ct_pins[d], ct_radii[d], ct_par[d], ct_herr[d], ct_hpsi[d],
                             ct_law[d], ct_tcache[d], phi, eta, eta, meshf[:3], workk, workd, ct_out[d], ct_zones[d],
                             ct_window[d], ct_pout[d], ct_count[d])
        if p > pen:
            pen = p
        bad += nbad
        for i in range(3):
            f[b + i] += meshf[i]
            for j in range(3):
                kt[b + i, b + j] += workk[i, j]
    for m in range(ms_idx.shape[0]):
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
def _newton(x, free, cap, ref, pc_idx, pc_lp, pc_kind, pc_par, cs_idx, cs_k, cs_off, ld_idx, ld_val,
            ct_node, ct_ref, ct_offset, ct_pins, ct_radii, ct_par, ct_herr, ct_hpsi, ct_law, ct_tcache, ct_zones,
            ct_window, ct_out, ct_pout, ct_count, ms_idx, ms_par, max_iterations):
    """Newton's method on the free coordinates from x (updated in place); returns (status, evaluations,
    max penetration, residual norm)."""
    n = x.shape[0]
    nf = free.shape[0]
    f = np.zeros(n)
    kt = np.zeros((n, n))
    qa = np.zeros(n)
    work3 = np.zeros(3)
    workk = np.zeros((3, 3))
    workd = np.zeros((3, 3))
    meshq = np.zeros(6)
    meshqt = np.zeros(6)
    meshf = np.zeros(6)
    meshdf = np.zeros((6, 6))
    meshdft = np.zeros((6, 6))
    meshst = np.zeros(MESH_STATE)
    a = np.zeros((nf, nf))
    r = np.zeros(nf)
    perm = np.zeros(nf, dtype=np.int64)
    evaluations = 0
    norm = np.inf
    pen = -np.inf
    for it in range(max_iterations + 1):
        pen, bad = _assemble(x, ref, pc_idx, pc_lp, pc_kind, pc_par, cs_idx, cs_k, cs_off, ld_idx, ld_val,
                             ct_node, ct_ref, ct_offset, ct_pins, ct_radii, ct_par, ct_herr, ct_hpsi, ct_law,
                             ct_tcache, ct_zones, ct_window, ct_out, ct_pout, ct_count, ms_idx, ms_par, f, kt, qa,
                             work3, workk, workd, meshq, meshqt, meshf, meshdf, meshdft, meshst)
        evaluations += 1
        if bad:
            return KERNEL_FAILED, evaluations, pen, norm
        norm = 0.0
        for i in range(nf):
            r[i] = f[free[i]]
            norm += r[i] * r[i]
            for j in range(nf):
                a[i, j] = kt[free[i], free[j]]
        norm = math.sqrt(norm)
        if not np.isfinite(norm):
            return STALLED, evaluations, pen, norm
        if it == max_iterations:
            break
        if not solve_dense(a, r, perm):
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
            x[free[i]] += scale * r[i]
        # converged when the residual is small and so is the correction just taken: Newton's error after it
        # is of the order of its square, so the state needs no further evaluation
        if norm < RESIDUAL and move < TOLERANCE:
            return CONVERGED, evaluations, pen, norm
    return STALLED, evaluations, pen, norm


@_jit
def ideal_kinematics(q, theta_in, ratio, pin_count, sun, carrier, crank_axes, crank_x, crank_y, crank_th, disc_base,
                      eccentricity, disc_phase, disc_x, disc_y, disc_th, modal):
    """:meth:`rvflex.model.ReducerModel.kinematic_coordinates` in place on ``q`` (the reference coordinates; m,
    rad): one compiled call per quasi-static step instead of some thirty small numpy operations."""
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


# why a run of steps stopped (beside the Newton statuses): a penetration beyond the contacts' guard, a jump
PENETRATED, JUMPED = 10, 11


@_jit
def _steps(theta, ratio, kin, hist_th, hist_e, nh, last_te, max_jump, max_pen, car, drive, regulariser, x_out,
           out, forces, gaps, states, x, free, cap, ref, fixed_idx, fixed_value, pc_idx, pc_lp, pc_kind, pc_par,
           cs_idx, cs_k, cs_off, ld_idx, ld_val, ct_node, ct_ref, ct_offset, ct_pins, ct_radii, ct_par, ct_herr,
           ct_hpsi, ct_law, ct_tcache, ct_zones, ct_window, ct_out, ct_pout, ct_count, ms_idx, ms_par, max_iterations,
           sun, carrier, crank_axes, crank_x, crank_y, crank_th, disc_base, eccentricity, disc_phase, disc_x, disc_y,
           disc_th, modal, pin_count):
    """The recorded steps at input angles ``theta`` in one call, each as :meth:`CompiledStep.solve` and the
    caller's loop take it: the guess is the ideal kinematics plus the elastic part extrapolated from the last
    ``nh`` (≤ 3) converged steps (``hist_th``, ``hist_e``, updated in place), the drive and the output regulariser
    set to the step's angle, Newton, the contacts' penetration guard and the jump check against the last TE.
    Records the output angle (``out``), and with ``states`` the pins' forces and gaps; ``x_out`` holds the last
    converged state (absolute). Returns (steps done, status of the step that stopped the run or CONVERGED,
    evaluations, the last TE, nh)."""
    n = theta.shape[0]
    evaluations = 0
    for s in range(n):
        th = theta[s]
        for i in range(kin.shape[0]):
            kin[i] = ref[i]
        ideal_kinematics(kin, th, ratio, pin_count, sun, carrier, crank_axes, crank_x, crank_y, crank_th, disc_base,
                         eccentricity, disc_phase, disc_x, disc_y, disc_th, modal)
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
        cs_off[regulariser] = th / ratio
        for i in range(fixed_idx.shape[0]):
            x[fixed_idx[i]] = fixed_value[i]
        status, ev, pen, norm = _newton(x, free, cap, ref, pc_idx, pc_lp, pc_kind, pc_par, cs_idx, cs_k, cs_off,
                                        ld_idx, ld_val, ct_node, ct_ref, ct_offset, ct_pins, ct_radii, ct_par, ct_herr,
                                        ct_hpsi, ct_law, ct_tcache, ct_zones, ct_window, ct_out, ct_pout, ct_count,
                                        ms_idx, ms_par, max_iterations)
        evaluations += ev
        if status != CONVERGED:
            return s, status, evaluations, last_te, nh
        if pen > max_pen:
            return s, PENETRATED, evaluations, last_te, nh
        te = x[car] + ref[car] - th / ratio
        if abs(te - last_te) > max_jump:
            return s, JUMPED, evaluations, last_te, nh
        last_te = te
        out[s] = x[car] + ref[car]
        if states:
            for d in range(forces.shape[1]):
                for p in range(forces.shape[2]):
                    forces[s, d, p] = ct_out[d][p, K.O_FORCE]
                    gaps[s, d, p] = ct_out[d][p, K.O_GAP]
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
    return n, CONVERGED, evaluations, last_te, nh


@_jit
def solve_dense(a, b, perm):
    """Solve a·x = b in place (x in b) by Gaussian elimination with partial pivoting; a is overwritten.
    False when a is singular. For the ~15 unknowns of a rigid reducer this is a fraction of a µs, where
    LAPACK's call costs ~10 µs."""
    n = b.shape[0]
    for i in range(n):
        perm[i] = i
    for k in range(n):
        p, big = k, abs(a[k, k])
        for i in range(k + 1, n):
            if abs(a[i, k]) > big:
                p, big = i, abs(a[i, k])
        if big == 0.0 or not np.isfinite(big):
            return False
        if p != k:
            for j in range(n):
                a[k, j], a[p, j] = a[p, j], a[k, j]
            b[k], b[p] = b[p], b[k]
        piv = a[k, k]
        for i in range(k + 1, n):
            m = a[i, k] / piv
            if m != 0.0:
                for j in range(k + 1, n):
                    a[i, j] -= m * a[k, j]
                b[i] -= m * b[k]
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= a[i, j] * b[j]
        b[i] = s / a[i, i]
    return True


def _marker_point(mbs, marker: int, body_start: dict) -> tuple[int, np.ndarray] | None:
    """(ODE2 start index of the marker's body or −1 for ground, local or global position); None when the
    marker is not one the compiled step knows."""
    m = mbs.GetMarker(marker)
    if m["markerType"] != "BodyRigid":
        return None
    b = int(m["bodyNumber"])
    o = mbs.GetObject(b)
    lp = np.asarray(m["localPosition"], float)
    if o["objectType"] == "Ground":
        return -1, np.asarray(o["referencePosition"], float)[:2] + lp[:2]
    if o["objectType"] != "RigidBody2D" or b not in body_start:
        return None
    return body_start[b], lp[:2]


def _current():
    import exudyn as exu

    return exu.ConfigurationType.Current


class CompiledStep:
    """The compiled static step of one rigid reducer model (build with :func:`compiled_step`).

    ``solve`` has the interface of the Newton objects of :mod:`rvflex.solve`: the equilibrium from a guess
    with the drive, the output regulariser and the output load as currently set in the Exudyn system.
    """

    def __init__(self, model, data: dict):
        self.model = model
        self.d = data
        self.fallbacks = 0
        self.iterations = 0
        self.evaluations = 0
        self.solved = False  # the last solve converged (its pin outputs are the step's)
        self.backup = None  # the caller's Newton to try when this one fails (rvflex.solve sets its chord Newton)

    def reset(self) -> None:
        """Forget the last solve (interface of rvflex.solve's Newtons: Exudyn's solver takes the step)."""
        self.solved = False
        if self.backup is not None:
            self.backup.reset()

    def counts(self) -> dict:
        """What the step has done so far: ``free`` coordinates, Newton ``evaluations`` and linear ``solves``,
        ``fallbacks`` (steps it could not take) and ``backup_steps`` (those its backup then took)."""
        return {"free": int(len(self.d["free"])), "evaluations": self.evaluations, "solves": self.iterations,
                "fallbacks": self.fallbacks, "backup_steps": getattr(self.backup, "steps", 0)}

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
        d = self.d
        n = len(q_abs)
        x = np.asarray(q_abs, float) - self.model.reference
        f, kt = np.zeros(n), np.zeros((n, n))
        _assemble(x, d["ref"], d["pc_idx"], d["pc_lp"], d["pc_kind"], d["pc_par"], d["cs_idx"], d["cs_k"],
                  d["cs_off"], d["ld_idx"], d["ld_val"], *self._contacts(), d["ms_idx"], d["ms_par"], f, kt,
                  np.zeros(n), np.zeros(3), np.zeros((3, 3)), np.zeros((3, 3)), np.zeros(6), np.zeros(6),
                  np.zeros(6), np.zeros((6, 6)), np.zeros((6, 6)), np.zeros(MESH_STATE))
        return f, kt

    def _contacts(self) -> tuple:
        d = self.d
        return (d["ct_node"], d["ct_ref"], d["ct_offset"], d["ct_pins"], d["ct_radii"], d["ct_par"], d["ct_herr"],
                d["ct_hpsi"], d["ct_law"], d["ct_tcache"], d["ct_zones"], d["ct_window"], d["ct_out"], d["ct_pout"],
                d["ct_count"])

    def solve(self, q_abs: np.ndarray) -> np.ndarray:
        """Equilibrium from the guess ``q_abs`` (absolute ODE2 coordinates); raises :class:`StepFailed`
        when Newton does not converge and the model's ContactError on an overloaded contact."""
        self.solved = False
        self._runtime()
        d = self.d
        x = np.asarray(q_abs, float) - self.model.reference
        x[d["fixed_idx"]] = d["fixed_value"]
        status, ev, pen, norm = _newton(x, d["free"], d["cap"], d["ref"], d["pc_idx"], d["pc_lp"], d["pc_kind"],
                                        d["pc_par"], d["cs_idx"], d["cs_k"], d["cs_off"], d["ld_idx"], d["ld_val"],
                                        *self._contacts(), d["ms_idx"], d["ms_par"], MAX_ITERATIONS)
        self.evaluations += ev
        self.iterations += ev  # each evaluation is followed by one linear solve
        if status != CONVERGED:
            raise StepFailed(f"compiled Newton: status {status} after {ev} evaluations, residual {norm:.3e}")
        # the deepest penetration over every disc, checked by the contacts' own guard (which names the first
        # disc's node even when another one penetrates)
        contacts = self.model.discs.contacts
        for c in contacts:
            c._work.penetration = pen
        contacts[0].check_penetration()
        # the system holds the state, as after Exudyn's solver: whatever reads it next (a pin state, the
        # loaded state a torque stepping hands on, Exudyn's solver taking the next step) sees this one
        self.model.mbs.systemData.SetODE2Coordinates(x, configuration=_current())
        self.solved = True
        return x + self.model.reference

    def steps(self, theta: np.ndarray, history: list, last_te: float, max_jump: float, out: np.ndarray,
              forces: np.ndarray, gaps: np.ndarray, states: bool) -> tuple[int, list, float, np.ndarray | None]:
        """Recorded steps at the input angles ``theta`` (rad) in one compiled call, as the caller's loop takes them
        one by one with :meth:`solve` (the extrapolated guess from ``history``, a list of (θ_in, elastic part)
        of the last converged steps, the penetration guard and the jump check beyond ``max_jump`` rad against
        ``last_te``), under the load and regulariser stiffness currently set in the Exudyn system. Fills
        ``out``, ``forces`` and ``gaps`` (with ``states``) for the steps taken and stops before the first
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
        contacts = model.discs.contacts
        done, status, ev, last_te, nh = _steps(
            np.ascontiguousarray(theta, float), float(model.ratio), kin, hist_th, hist_e, min(nh, 3), float(last_te),
            float(max_jump), float(min(c.max_penetration_m for c in contacts)), int(model.output_index),
            d["drive_slot"], d["regulariser_slot"], x_out, out, forces, gaps, bool(states), x, d["free"], d["cap"],
            d["ref"], d["fixed_idx"], d["fixed_value"], d["pc_idx"], d["pc_lp"], d["pc_kind"], d["pc_par"], d["cs_idx"],
            d["cs_k"], d["cs_off"], d["ld_idx"], d["ld_val"], *self._contacts(), d["ms_idx"], d["ms_par"],
            MAX_ITERATIONS, *model._kinematics, float(model.spec.cycloid.pin_count))
        self.evaluations += ev
        self.iterations += ev
        if done == 0:
            return 0, history, last_te, None
        th = float(theta[done - 1])
        mbs = model.mbs
        mbs.SetObjectParameter(model.sun.drive, "offset", th)
        mbs.SetObjectParameter(model.carrier.regulariser, "offset", th / model.ratio)
        mbs.systemData.SetODE2Coordinates(x_out - model.reference, configuration=_current())
        self.solved = status == CONVERGED  # else ct_out holds the failed step's last evaluation
        return done, [(float(hist_th[j]), hist_e[j].copy()) for j in range(nh)], last_te, x_out

    def pin_outputs(self, disc: int) -> tuple[np.ndarray, np.ndarray]:
        """Per-pin normal force (N) and gap (m) of disc ``disc`` at the last solved state."""
        out = self.d["ct_out"][disc]
        return out[:, K.O_FORCE].copy(), out[:, K.O_GAP].copy()


def compiled_step(model) -> CompiledStep | None:
    """The compiled step of ``model``, or None when its system holds an item the compiled step does not
    replicate (FE bodies, a flexible housing, other connector laws): that model is solved by Exudyn."""
    if model.modal_nodes:
        return None
    mbs = model.mbs
    sd = mbs.systemData
    bearing_law = {}  # connector → (ε, w) of rvflex's clearance law
    pairs = [model.carrier.main, *model.cranks.supports, *model.input_seat_supports]
    pairs += [p for row in model.discs.eccentric_bearings for p in row]
    for p in pairs:
        bearing_law[p.bearing.connector] = (p.bearing.clearance_m, p.bearing.smoothing_m)
    contacts = {c.object_index: c for c in model.discs.contacts}
    meshes = {h.mesh_object: h for h in model.cranks.meshes}
    body_start = {}
    for i in range(sd.NumberOfObjects()):
        o = mbs.GetObject(i)
        if o["objectType"] == "RigidBody2D":
            body_start[i] = int(mbs.GetNodeODE2Index(o["nodeNumber"]))
    pc_idx, pc_lp, pc_kind, pc_par = [], [], [], []
    fixed_idx, fixed_objects, cs_idx, spring_objects = [], [], [], []
    ct, ms_idx, ms_par = [], [], []

    def coordinate(marker: int) -> int | None:
        m = mbs.GetMarker(marker)
        if m["markerType"] != "NodeCoordinate":
            return None
        node = mbs.GetNode(m["nodeNumber"])
        if node["nodeType"] == "PointGround":
            return -1
        return int(mbs.GetNodeODE2Index(m["nodeNumber"])) + int(m["coordinate"])

    for i in range(sd.NumberOfObjects()):
        o = mbs.GetObject(i)
        kind = o["objectType"]
        if kind in ("Ground", "RigidBody2D"):
            continue
        if not o.get("activeConnector", True):
            continue
        if kind in ("ConnectorRigidBodySpringDamper", "ConnectorCartesianSpringDamper"):
            pts = [_marker_point(mbs, m, body_start) for m in o["markerNumbers"]]
            if None in pts or np.any(np.asarray(o["offset"], float)[:2] != 0.0) and kind != "ConnectorCartesianSpringDamper":
                return None
            if kind == "ConnectorRigidBodySpringDamper":
                if i not in bearing_law or o.get("useIntrinsicFormulation"):
                    return None
                k = np.asarray(o["stiffness"], float)
                eps, w = bearing_law[i]
                pc_kind.append(LAW_CLEARANCE)
                pc_par.append([k[0, 0], eps, w, 0.0])
            else:
                k, off = np.asarray(o["stiffness"], float), np.asarray(o["offset"], float)
                pc_kind.append(LAW_CARTESIAN)
                pc_par.append([k[0], k[1], off[0], off[1]])
            pc_idx.append([pts[0][0], pts[1][0]])
            pc_lp.append([pts[0][1], pts[1][1]])
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
            if c.modal_node >= 0 or c.housing_node >= 0 or tuple(c.rigid_index) != (0, 1, 2):
                return None
            ct.append(c)
        elif kind == "GenericODE2" and i in meshes:
            h = meshes[i]
            ms_idx.append([mbs.GetNodeODE2Index(h.sun_node), mbs.GetNodeODE2Index(h.planet_node)])
            ms_par.append(h.parameters)
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
    free = np.array([j for j in range(n2) if j not in set(fixed_idx)], dtype=np.int64)
    cap = np.full(n2, np.inf)
    for idx in model.planar_index().values():
        cap[idx[:2]] = CAP_M
        cap[idx[2]] = CAP_M / CAP_RADIUS_M
    data = {
        "ref": np.asarray(model.reference, float).copy(),
        "free": free, "cap": cap[free].copy(),
        "fixed_idx": np.array(fixed_idx, dtype=np.int64), "fixed_objects": fixed_objects,
        "fixed_value": np.zeros(len(fixed_idx)),
        # the input drive's and the output regulariser's places among them (-1: not there, no batched steps)
        "drive_slot": fixed_objects.index(model.sun.drive) if model.sun.drive in fixed_objects else -1,
        "regulariser_slot": (spring_objects.index(model.carrier.regulariser)
                             if model.carrier.regulariser in spring_objects else -1),
        "pc_idx": np.array(pc_idx, dtype=np.int64).reshape(-1, 2),
        "pc_lp": np.array(pc_lp, float).reshape(-1, 2, 2),
        "pc_kind": np.array(pc_kind, dtype=np.int64), "pc_par": np.array(pc_par, float).reshape(-1, 4),
        "cs_idx": np.array(cs_idx, dtype=np.int64), "spring_objects": spring_objects,
        "cs_k": np.zeros(len(cs_idx)), "cs_off": np.zeros(len(cs_idx)),
        "ld_idx": np.array(ld_idx, dtype=np.int64), "load_items": load_items, "ld_val": np.zeros(len(ld_idx)),
        "ct_node": np.array([mbs.GetNodeODE2Index(c.node) for c in ct], dtype=np.int64),
        "ct_ref": np.array([np.asarray(c.reference, float)[:3] for c in ct]).reshape(-1, 3),
        "ct_offset": np.array([c.offset_rad for c in ct], float),
        "ct_window": np.array([c.zone_window_rad for c in ct], float),
        "ms_idx": np.array(ms_idx, dtype=np.int64).reshape(-1, 2),
        "ms_par": np.array(ms_par, float).reshape(-1, len(ms_par[0]) if ms_par else 0),
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
                     ("ct_count", lambda c: K.empty_points(len(c.radii_m))[1])):
        arrays = [get(c) for c in ct]
        # one stacked array where every disc's has the same shape (the usual case: cheaper to pass and index),
        # else a typed list; the compiled functions index both alike
        same = len({(a.shape, a.dtype) for a in arrays}) == 1
        data[key] = np.stack(arrays) if same and key != "ct_tcache" else List(arrays)
    return CompiledStep(model, data)

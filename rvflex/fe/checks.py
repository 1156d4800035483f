"""The reduced-vs-full static checks done when a part is reduced: the disc under rated tooth loads
at several angles, the carrier under its bearings' load, the pin housing under the pin forces
(docs/fe.md, docs/flexible.md)."""

from __future__ import annotations

import math

import numpy as np

from rvflex.fe.couplings import nodeset, rbe3_loads, rigid_map
from rvflex.fe.loads import disc_rated_load_case
from rvflex.fe.solver import Solver, free_mask, galerkin
from rvflex.fe.types import CHECK_ANGLES_PITCH, ReducedPart, StaticCheck

__all__ = ["carrier_check", "disc_check", "housing_check", "static_check"]


def disc_check(spec, profile, flank, s, solver, K, Psi, n_static, T_all, nn) -> StaticCheck:
    """Rated tooth loads, bores held: full K_ii⁻¹f vs reduced internal modes, at the disc
    angles :data:`CHECK_ANGLES_PITCH` (contact points anywhere between the attachment
    patches); the worst angle is reported."""
    mask = free_mask(np.concatenate([T.nonzero()[0] // 3 for T in T_all]), nn)
    Ss = [T.toarray() - solver.solve(K @ T.toarray()) * mask[:, None] for T in T_all]
    Kr = Psi[:, n_static:].T @ (K @ Psi[:, n_static:])
    flank_pct = itf_pct = d_max = r_max = 0.0
    by_angle = []
    for frac in CHECK_ANGLES_PITCH:
        t, _pts, forces = disc_rated_load_case(spec, profile, disc_angle_rad=frac * 2 * np.pi / spec.cycloid.pin_count)
        W = flank.weights(t, s.patch_half_width_m, s.patch_shape).toarray()
        F = np.zeros(3 * nn)
        for c in range(2):
            F[3 * flank.nodes + c] = W.T @ forces[:, c]
        u_full = solver.solve(F[:, None])[:, 0]
        u_red = Psi[:, n_static:] @ np.linalg.solve(Kr, Psi[:, n_static:].T @ F)
        dirs = forces / np.linalg.norm(forces, axis=1, keepdims=True)

        def along(u, W=W, dirs=dirs):
            U = u.reshape(nn, 3)[flank.nodes, :2]
            return np.sum((W @ U) * dirs, axis=1)

        d_full, d_red = along(u_full), along(u_red)
        flank_pct = max(flank_pct, 100 * np.max(np.abs(d_red - d_full)) / np.max(np.abs(d_full)))
        # reduced bore forces are the generalised forces of the static interface modes (Ψ_sᵀ K u_red = 0
        # for interior fields, so −Ψ_sᵀ f); full ones are the nodal reactions K u − f summed over each bore
        r_full = np.array([(T.T @ (K @ u_full - F))[:3] for T in T_all])
        r_red = np.array([(-S.T @ F)[:3] for S in Ss])
        itf_pct = max(itf_pct, 100 * np.max(np.abs(r_red - r_full)) / np.max(np.abs(r_full)))
        by_angle.append(float(np.max(np.abs(d_full))))
        d_max, r_max = max(d_max, by_angle[-1]), max(r_max, float(np.max(np.abs(r_full))))
    return StaticCheck(float(flank_pct), float(itf_pct),
                       f"rated torque {spec.rated_torque_Nm:g} N·m over {spec.cycloid.disc_count} discs, "
                       f"{len(t)} loaded pins (rigid-disc load sharing, max {np.linalg.norm(forces, axis=1).max():.0f} N),"
                       f" bores held, worst of {len(CHECK_ANGLES_PITCH)} disc angles", d_max, r_max, tuple(by_angle))


def housing_check(spec, solver, fem, itfs, K, Psi, nn) -> StaticCheck:
    """The pin housing as the model uses it against the full FE model: the rated torque's
    reaction as equal tangential forces on every pin (two discs half a turn apart load all of
    them), mount face held.

    *Full*: each force on its seat as a pressure ∝ cos over the loaded half of the seat; the
    seat displacement is the pressure-weighted mean along the force. *Reduced*: the same force
    distributed by the seat's area weights (the coupling through which the model's pin loads
    its seat) and measured with them (how the model moves the pin). The reduction is exact for
    those loads (attachment modes), so the difference is the interface idealisation: uniform
    against cosine pressure, reported as ``interface_pct``; ``flank_pct`` is the reduction
    alone (reduced against full under the model's own seat loads).
    """
    pos = fem.GetNodePositionsAsArray()
    seats = itfs[1:]
    force = spec.rated_torque_Nm / (len(seats) * spec.cycloid.pin_circle_radius_m)
    F_full, F_model, dirs, press = np.zeros(3 * nn), np.zeros(3 * nn), [], []
    for itf in seats:
        c = itf.centre_m
        d = np.array([-c[1], c[0], 0.0]) / math.hypot(c[0], c[1])
        dirs.append(d)
        r = pos[itf.nodes] - c
        w = itf.weights * np.clip((r[:, :2] @ d[:2]) / np.linalg.norm(r[:, :2], axis=1), 0.0, None)
        w /= w.sum()
        press.append(w)
        for k in range(2):
            F_full[3 * itf.nodes + k] += force * d[k] * w
            F_model[3 * itf.nodes + k] += force * d[k] * itf.weights
    u_full = solver.solve(F_full[:, None])[:, 0]
    u_model_full = solver.solve(F_model[:, None])[:, 0]
    u_red = galerkin(K, Psi, F_model[:, None])[:, 0]

    def seat_disp(u, weights):
        return np.array([w @ (u.reshape(nn, 3)[itf.nodes] @ d) for itf, d, w in zip(seats, dirs, weights)])

    s_full = seat_disp(u_full, press)
    s_model = seat_disp(u_model_full, [i.weights for i in seats])
    s_red = seat_disp(u_red, [i.weights for i in seats])
    red_pct = 100 * np.max(np.abs(s_red - s_model)) / np.max(np.abs(s_model))
    itf_pct = 100 * np.max(np.abs(s_red - s_full)) / np.max(np.abs(s_full))
    return StaticCheck(float(red_pct), float(itf_pct),
                       f"rated torque {spec.rated_torque_Nm:g} N·m as {len(seats)} tangential pin forces of "
                       f"{force:.0f} N, mount face held; flank_pct: reduced vs full under the model's seat loads; "
                       f"interface_pct: against cosine seat pressure", float(np.max(np.abs(s_model))),
                       float(np.max(np.abs(s_full))))


def carrier_check(spec, bfK, fem, itfs, K, Psi, nn, geom, coupling: str = "rbe3") -> StaticCheck:
    """The carrier as the multibody model uses it against the full FE model under the
    bearings' own load. Rated torque into the crank seats, output face held.

    *Full*: elastic seats under the bearing pressure (∝ cos over the loaded half of each
    seat); seat displacement = the pressure-weighted mean along the load (work-conjugate to
    the pressure: what the rollers see). *Reduced*: the reduced body loaded as the model's
    seat markers load it — each seat's resultant through its coupling (RBE3: distributed by
    the marker weights; RBE2: the rigid ring) — and measured as the marker measures it
    (weighted mean of the seat nodes). Both: pillar mid-span displacement along the torque.
    The difference is reduction + interface idealisation (docs/fe.md): RBE2 seats ≈ 14 %
    (their rigid rings stiffen the plates), RBE3 seats ≈ 3 % (uniform vs cosine load
    distribution; the reduction itself is exact for the couplings' loads)."""
    pos = fem.GetNodePositionsAsArray()
    ref = itfs[0]
    cr = spec.cranks
    force_per_seat = spec.rated_torque_Nm / (cr.count * cr.crank_circle_radius_m * 2)
    F = np.zeros(3 * nn)
    F_model = np.zeros(3 * nn)
    seats = itfs[1:]
    dirs, press = [], []
    for itf in seats:
        c = itf.centre_m
        d = np.array([-c[1], c[0], 0.0]) / math.hypot(c[0], c[1])  # tangential: torque about +z
        dirs.append(d)
        r = pos[itf.nodes] - c
        cosang = np.clip((r[:, :2] @ d[:2]) / np.linalg.norm(r[:, :2], axis=1), 0.0, None)  # loaded half of the bore
        w = itf.weights * cosang
        w /= w.sum()
        press.append(w)
        f = np.zeros(3 * nn)
        for k in range(3):
            f[3 * itf.nodes + k] += force_per_seat * d[k] * w
        F += f
        T = rigid_map(pos, itf.nodes, pos[itf.nodes].T @ itf.weights, nn)
        F_model += rbe3_loads(pos, itf, nn) @ (T.T @ f)  # the same resultant (force, moment) through the coupling
    solver = Solver(bfK, ref.nodes, nn)
    u_full = solver.solve(F[:, None])[:, 0]
    u_red = galerkin(K, Psi, F_model[:, None])[:, 0]

    def seat_disp(u, weights):
        return np.array([w @ (u.reshape(nn, 3)[itf.nodes] @ d) for itf, d, w in zip(seats, dirs, weights)])

    s_full, s_red = seat_disp(u_full, press), seat_disp(u_red, [itf.weights for itf in seats])
    itf_pct = 100 * np.max(np.abs(s_red - s_full)) / np.max(np.abs(s_full))
    # pillar mid-span: surface nodes of each pillar within 2 mm of the mid-plane z = 0
    vals_f, vals_r = [], []
    for j in range(spec.carrier.pillar_count):
        nodes = nodeset(fem, f"pillar{j}")
        nodes = nodes[np.abs(pos[nodes, 2]) < 2e-3]
        if nodes.size == 0:
            continue
        c = pos[nodes].mean(axis=0)
        d = np.array([-c[1], c[0], 0.0]) / math.hypot(c[0], c[1])
        vals_f.append(np.mean(u_full.reshape(nn, 3)[nodes] @ d))
        vals_r.append(np.mean(u_red.reshape(nn, 3)[nodes] @ d))
    vf, vr = np.array(vals_f), np.array(vals_r)
    flank_pct = 100 * np.max(np.abs(vr - vf)) / np.max(np.abs(vf)) if vf.size else float("nan")
    return StaticCheck(float(flank_pct), float(itf_pct),
                       f"rated torque {spec.rated_torque_Nm:g} N·m into {len(seats)} crank seats (cosine bearing "
                       f"pressure, {force_per_seat:.0f} N each), output face held; pillar mid-span and seat "
                       f"displacements; reduced body with {coupling.upper()} seats", float(np.max(np.abs(vf))) if vf.size else float("nan"),
                       float(np.max(np.abs(s_full))))


def static_check(rp: ReducedPart) -> StaticCheck:
    """The reduced-vs-full static check stored with ``rp`` (computed at reduction time)."""
    return rp.check

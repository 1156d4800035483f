"""Loads on the disc flank: patch weights over the exact profile (arc length, consistent with the
flank surface mass) and the rated-torque pin forces of the static check."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from rvflex.fe.couplings import nodeset
from rvflex.fe.types import FEError
from rvflex.spec import ReducerSpec

__all__ = ["Flank", "disc_rated_load_case", "flank_of"]


def _arc_length_table(profile, n: int = 1 << 15) -> tuple[np.ndarray, np.ndarray, float]:
    """(t, s(t)) of the exact profile on a fine grid and its total length (m)."""
    t = np.linspace(0.0, 2 * np.pi, n + 1)
    _, q1, _ = profile.evaluate(t)
    v = np.abs(q1)
    s = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
    return t, s, float(s[-1])


@dataclass(frozen=True, eq=False)
class Flank:
    """Flank nodes with their profile parameters, arc lengths and the surface mass matrix."""

    nodes: np.ndarray
    t: np.ndarray
    s: np.ndarray
    length: float
    mass: sp.csr_matrix  # flank surface mass restricted to the flank nodes (m²)
    t_tab: np.ndarray
    s_tab: np.ndarray

    def s_of_t(self, t: np.ndarray) -> np.ndarray:
        return np.interp(np.asarray(t) % (2 * np.pi), self.t_tab, self.s_tab)

    def weights(self, t_centres: np.ndarray, half_width: float, shape: str = "hat") -> sp.csr_matrix:
        """Consistent patch weights (n_centres × n_flank_nodes), each row summing to 1."""
        sc = np.atleast_1d(self.s_of_t(t_centres))
        order = np.argsort(self.s)
        s_sorted = self.s[order]
        rows, cols, vals = [], [], []
        for i, c in enumerate(sc):
            for shift in (-self.length, 0.0, self.length):  # periodic in arc length
                lo, hi = np.searchsorted(s_sorted, [c + shift - half_width, c + shift + half_width])
                idx = order[lo:hi]
                x = np.abs(self.s[idx] - c - shift) / half_width
                h = 1.0 - x if shape == "hat" else np.cos(0.5 * np.pi * x) ** 2
                rows.append(np.full(idx.size, i))
                cols.append(idx)
                vals.append(h)
        hat = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                            shape=(sc.size, self.s.size))
        w = hat @ self.mass  # hat values at nodes times the surface mass: consistent loads
        w = sp.csr_matrix(w.multiply(1.0 / np.asarray(w.sum(axis=1))))
        return w


def flank_of(mesh, fem, profile, order: int) -> Flank:
    import ngsolve as ngs

    fs = ngs.H1(mesh, order=1) if order == 1 else ngs.NodalFESpace(mesh, order=2)
    u, v = fs.TnT()
    bf = ngs.BilinearForm(fs)
    bf += u * v * ngs.ds("flank")
    bf.Assemble()
    ms = sp.csr_matrix(bf.mat.CSR())
    nodes = np.array(sorted(nodeset(fem, "flank")), dtype=int)
    if ms.shape[0] != fem.NumberOfNodes():
        raise FEError(f"flank surface space has {ms.shape[0]} dofs for {fem.NumberOfNodes()} mesh nodes")
    ms = ms[nodes][:, nodes].tocsr()
    xy = fem.GetNodePositionsAsArray()[nodes, :2]
    g = profile.gap(xy, np.zeros(len(xy)))
    t_tab, s_tab, length = _arc_length_table(profile)
    f = Flank(nodes, g.t % (2 * np.pi), np.empty(0), length, ms, t_tab, s_tab)
    return Flank(nodes, f.t, f.s_of_t(f.t), length, ms, t_tab, s_tab)


def disc_rated_load_case(spec: ReducerSpec, profile, *, disc_angle_rad: float | None = None,
                         torque_Nm: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pin forces on one disc at rated torque: contact parameters t (rad), contact points
    (n, 2) and forces on the disc (n, 2) in N, body frame.

    Pins at the theoretical meshing pose for disc rotation β (pin j at p(θ_j − β) in the
    disc frame, contact point by the exact closest-point solve); load sharing by the
    rigid-disc law F_j ∝ l_j (the moment arm of the contact normal), for l_j > 0, scaled
    so that Σ F_j·l_j equals the disc's share T/disc_count. The default β puts the contact
    points between the attachment patches (0.37 of a pin pitch).
    """
    cy = spec.cycloid
    zb = cy.pin_count
    beta = 0.37 * 2 * np.pi / zb if disc_angle_rad is None else disc_angle_rad
    torque = (spec.rated_torque_Nm if torque_Nm is None else torque_Nm) / cy.disc_count
    th = 2 * np.pi * np.arange(zb) / zb - beta
    e, R = cy.eccentricity_m, cy.pin_circle_radius_m
    p = R * np.exp(1j * th) - e * np.exp(1j * zb * th)
    g = profile.gap(np.column_stack([p.real, p.imag]), np.full(zb, cy.pin_radius_m), t_init=th % (2 * np.pi))
    force_dir = -g.normal
    arm = g.point_m[:, 0] * force_dir[:, 1] - g.point_m[:, 1] * force_dir[:, 0]
    loaded = arm > 0.05 * arm.max()
    f = np.zeros(zb)
    f[loaded] = torque * arm[loaded] / np.sum(arm[loaded] ** 2)
    sel = f > 0
    return g.t[sel], g.point_m[sel], f[sel, None] * force_dir[sel]

"""Craig–Bampton reduction of the flexible parts: NGSolve elasticity → Exudyn ``FEMinterface``.

Pipeline (:func:`reduce_part`): OCC solid (:mod:`rvflex.fe.geometry`) → netgen tet mesh →
``FEMinterface.ImportMeshFromNGsolve`` (mass and stiffness of linear elasticity with the
spec's material) → Hurty–Craig–Bampton basis with RBE2 (rigid) interfaces → frozen
:class:`ReducedPart`, cached on disk by :mod:`rvflex.fe.cache`.

The basis, in column order (all in the part's body frame, Exudyn node ordering x0 y0 z0 x1 ...):

1. **static interface modes** — unit rigid motions (3 translations, 3 rotations about the
   weighted interface centre) of every interface but the first, the interior relaxed
   (K_ii u_i = −K_ib u_b); the first interface is the floating-frame reference, clamped
   in all modes (``excludeRigidBodyMotion`` in Exudyn's terms);
2. **internal modes** — the Rayleigh–Ritz combination of ``n_modes`` fixed-interface
   eigenmodes and, for the disc, *attachment modes*: static responses (interfaces held)
   to unit normal (and, with ``attach_tangential``, tangential) loads on flank patches,
   ``attach_per_tooth`` per tooth all around the profile. Fixed-interface eigenmodes alone miss the local flank response under pin loads
   (measured: see docs/fe.md); the attachment modes make the basis reproduce it. The Ritz
   step makes the internal block of the reduced mass and stiffness matrices diagonal.

Pin forces enter the disc as *patch loads*: a force F at profile parameter t is spread over
the flank with a hat weight of half-width ``patch_half_width_m`` in arc length, uniform
through the thickness, with consistent nodal weights (flank surface mass matrix). The same
weights average the displacement, so :meth:`FlankRows.rows_at` is both the displacement
operator and (transposed) the generalised-force operator of a pin contact. This keeps the
local Hertz approach out of the FE (it stays in the contact law): deformation at scales
below the patch width is not represented by the modes.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from rvflex.spec import ReducerSpec, SpecError

__all__ = [
    "DEFAULTS",
    "STEPS",
    "FEError",
    "FlankRows",
    "Interface",
    "PartSettings",
    "ReducedPart",
    "StaticCheck",
    "VirtualNodes",
    "convergence_study",
    "disc_rated_load_case",
    "estimate_memory_bytes",
    "free_free_frequencies_hz",
    "rbe3_virtual_nodes",
    "reduce_part",
    "settings_for",
    "static_check",
]

CODE_VERSION = "fe-2"  # bump when the reduction's numbers change for the same inputs (part of the cache key)
BYTES_PER_TET = {1: 10_000, 2: 60_000}  # measured peak RSS per tet of mesh + import + HCB (docs/fe.md)
MAX_MODE_FRACTION = 0.05  # at most one internal mode per 20 free DOFs: beyond, the mesh cannot resolve them
ROWS_PER_TOOTH = 64
STEPS = ("mesh", "assemble", "factorise", "static modes", "eigenmodes", "attachment modes", "Ritz", "static check")  # grid of the flank mode rows (patch-smoothed, so linear interpolation is accurate)


class FEError(RuntimeError):
    """A netgen/NGSolve/Exudyn failure, re-raised with the part and the settings that caused it."""


@dataclass(frozen=True, slots=True)
class PartSettings:
    """Mesh and reduction settings of one part (lengths in m).

    ``n_modes`` counts the fixed-interface eigenmodes; the disc adds
    ``attach_per_tooth × disc_teeth`` attachment modes (twice that with ``attach_tangential``)
    and every part ``6 × (interfaces − 1)`` static modes, so the reduced body has more
    coordinates than ``n_modes``.
    """

    maxh_m: float
    n_modes: int
    mesh_order: int = 2
    patch_half_width_m: float = 2.5e-3
    attach_per_tooth: int = 0
    curvature_safety: float = 2.0
    patch_shape: str = "hat"
    attach_tangential: bool = False
    seat_coupling: str = "rbe3"  # carrier crank seats: "rbe3" distributing coupling (default) or "rbe2" rigid rings

    def __post_init__(self) -> None:
        if not (isinstance(self.maxh_m, (int, float)) and 0.3e-3 <= self.maxh_m <= 0.05):
            raise SpecError("maxh_m", self.maxh_m, "expected metres, 0.3 mm to 50 mm")
        if not (isinstance(self.n_modes, int) and 0 <= self.n_modes <= 2000):
            raise SpecError("n_modes", self.n_modes, "must be an integer from 0 to 2000")
        if self.mesh_order not in (1, 2):
            raise SpecError("mesh_order", self.mesh_order, "must be 1 (linear tets) or 2 (quadratic tets)")
        if not 0.2e-3 <= self.patch_half_width_m <= 20e-3:
            raise SpecError("patch_half_width_m", self.patch_half_width_m, "expected metres, 0.2 mm to 20 mm")
        if self.patch_shape not in ("hat", "cos2"):
            raise SpecError("patch_shape", self.patch_shape, "must be 'hat' or 'cos2'")
        if not 0.5 <= self.curvature_safety <= 5.0:
            raise SpecError("curvature_safety", self.curvature_safety, "netgen's curvaturesafety, 0.5 to 5 (2 is its default)")
        if not (isinstance(self.attach_per_tooth, int) and 0 <= self.attach_per_tooth <= 16):
            raise SpecError("attach_per_tooth", self.attach_per_tooth, "must be an integer from 0 to 16")
        if self.seat_coupling not in ("rbe2", "rbe3"):
            raise SpecError("seat_coupling", self.seat_coupling, "must be 'rbe3' (distributing) or 'rbe2' (rigid)")


# Chosen by the convergence study of docs/fe.md (static flank/seat response vs maxh and modes).
DEFAULTS = {
    "disc": PartSettings(maxh_m=6e-3, n_modes=10, mesh_order=2, patch_half_width_m=3e-3, attach_per_tooth=2,
                         curvature_safety=1.0, attach_tangential=True),
    "carrier": PartSettings(maxh_m=6e-3, n_modes=10, mesh_order=2, curvature_safety=1.0),
}


def settings_for(part: str, *, maxh_m: float | None = None, n_modes: int | None = None, **over) -> PartSettings:
    """The default settings of ``part`` with the given overrides."""
    if part not in DEFAULTS:
        raise SpecError("part", part, "must be 'disc' or 'carrier'")
    import dataclasses

    base = DEFAULTS[part]
    kw = dict(over)
    if maxh_m is not None:
        kw["maxh_m"] = maxh_m
    if n_modes is not None:
        kw["n_modes"] = n_modes
    return dataclasses.replace(base, **kw)


@dataclass(frozen=True, eq=False)
class Interface:
    """A rigid (RBE2) interface: mesh nodes, their surface-area weights (sum 1) and centre (m)."""

    name: str
    nodes: np.ndarray
    weights: np.ndarray
    centre_m: np.ndarray


@dataclass(frozen=True, eq=False)
class FlankRows:
    """In-plane modal displacement rows of the disc flank (body frame).

    ``rows[i]`` (2 × n_modes) maps modal coordinates q to the (x, y) displacement (m) of the
    flank patch centred at profile parameter ``t_grid[i]`` (rad, the parameter of
    :class:`rvflex.geometry.profile.CycloidProfile`, e.g. ``GapResult.t``): the average over
    the patch (hat of half-width ``patch_half_width_m`` in arc length) and through the
    thickness. Transposed, it gives the generalised force of a pin force F applied there:
    Q = rows(t)ᵀ F.
    """

    t_grid: np.ndarray
    rows: np.ndarray
    patch_half_width_m: float

    def rows_at(self, t: np.ndarray | float) -> np.ndarray:
        """Rows at parameters ``t`` (rad, any real; periodic in 2π), shape (len(t), 2, n_modes),
        by linear interpolation on the grid."""
        t = np.atleast_1d(np.asarray(t, float)) % (2 * np.pi)
        n = self.t_grid.size
        h = 2 * np.pi / n
        x = t / h
        i0 = np.floor(x).astype(int) % n
        a = (x - np.floor(x))[:, None, None]
        return (1 - a) * self.rows[i0] + a * self.rows[(i0 + 1) % n]


@dataclass(frozen=True, eq=False)
class StaticCheck:
    """Reduced vs full NGSolve static solution of the part's rated-load case.

    ``flank_pct``: largest error of the loaded patch displacements along their loads
    (disc: loaded pins; carrier: pillar mid-span), in % of the largest full one.
    ``interface_pct``: disc — error of the bore reaction forces (% of the largest);
    carrier — error of the seat displacements (RBE2 seats vs elastic seats) in % of the
    largest. ``case``: words describing the load case. ``flank_full_m``: the largest full
    flank (pillar) displacement (m); ``interface_full``: the largest full bore reaction (N,
    disc) or seat displacement (m, carrier) — the figures of the convergence study;
    ``flank_full_by_angle_m``: disc, the largest full flank displacement at each angle of
    :data:`CHECK_ANGLES_PITCH`.
    """

    flank_pct: float
    interface_pct: float
    case: str
    flank_full_m: float = float("nan")
    interface_full: float = float("nan")
    flank_full_by_angle_m: tuple = ()

    @property
    def max_pct(self) -> float:
        return max(self.flank_pct, self.interface_pct)


@dataclass(frozen=True, eq=False)
class ReducedPart:
    """A Craig–Bampton-reduced part, ready for Exudyn.

    Attributes
    ----------
    part : str
        ``"disc"`` or ``"carrier"``.
    settings : PartSettings
    key : str
        Cache key (content hash of geometry, material, settings, code version).
    fem : exudyn.FEM.FEMinterface
        Nodes, tets, surface, mass and stiffness (SI) and ``modeBasis``: pass it to
        ``ObjectFFRFreducedOrderInterface(fem).AddObjectFFRFreducedOrder(mbs, ...)``.
        Treat as read-only.
    node_positions_m : ndarray (n_nodes, 3)
        Reference node positions in the body frame (m).
    interfaces : tuple of Interface
        In basis order; the first is the floating-frame reference (clamped in all modes).
    n_static, n_eigen, n_attach : int
        Column counts of the basis blocks (static interface modes first).
    freqs_hz : ndarray
        Fixed-interface eigenfrequencies of the ``n_eigen`` eigenmodes (Hz).
    mass_reduced, stiffness_reduced : ndarray (n_modes, n_modes)
        Ψᵀ M Ψ (kg·m²-consistent) and Ψᵀ K Ψ (N/m) of the basis.
    flank : FlankRows or None
        Disc only: the flank mode rows.
    check : StaticCheck
        The reduced-vs-full static check done when the part was reduced.
    wall_s : float
        Wall time of the cold reduction (s).
    """

    part: str
    settings: PartSettings
    key: str
    fem: object
    node_positions_m: np.ndarray
    interfaces: tuple[Interface, ...]
    n_static: int
    n_eigen: int
    n_attach: int
    freqs_hz: np.ndarray
    mass_reduced: np.ndarray
    stiffness_reduced: np.ndarray
    flank: FlankRows | None
    check: StaticCheck
    wall_s: float
    meta: dict = field(default_factory=dict)

    @property
    def mode_basis(self) -> np.ndarray:
        """Ψ, (3·n_nodes, n_modes), Exudyn ordering (x0, y0, z0, x1, ...), m per modal unit."""
        return self.fem.modeBasis["matrix"]

    @property
    def n_modes(self) -> int:
        return int(self.mode_basis.shape[1])

    @property
    def n_nodes(self) -> int:
        return int(self.node_positions_m.shape[0])

    def interface(self, name: str) -> Interface:
        """The interface called ``name``."""
        for itf in self.interfaces:
            if itf.name == name:
                return itf
        raise KeyError(f"{self.part} has no interface {name!r}; it has {[i.name for i in self.interfaces]}")


# --------------------------------------------------------------------------- estimates


def _available_bytes() -> int:
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 8 << 30


def estimate_tets(volume_m3: float, maxh_m: float, part: str, curvature_safety: float = 2.0) -> int:
    """Tet count estimate: 4·V/maxh³ (fitted to netgen's graded meshes, docs/fe.md) plus the
    floor that the curvature of the tooth profile forces on the disc (RV-40E: ≈ 6 000 tets
    at curvaturesafety 1, 23 000 at 2, whatever maxh)."""
    floor = 6_000 * curvature_safety**2 if part == "disc" else 3_000
    return int(4.0 * volume_m3 / maxh_m**3 + floor)


def estimate_memory_bytes(n_tets: int, settings: PartSettings, n_extra_modes: int = 0) -> int:
    """Peak memory estimate of a reduction (bytes): measured bytes per tet plus the dense
    mode basis (nodes ≈ 1.45·tets for quadratic, 0.25·tets for linear tets) kept ~4×."""
    nodes = n_tets * (1.45 if settings.mesh_order == 2 else 0.25)
    basis = 4 * 8 * 3 * nodes * (settings.n_modes + n_extra_modes + 30)
    return int(n_tets * BYTES_PER_TET[settings.mesh_order] + basis + (300 << 20))


# --------------------------------------------------------------------------- loads


def _arc_length_table(profile, n: int = 1 << 15) -> tuple[np.ndarray, np.ndarray, float]:
    """(t, s(t)) of the exact profile on a fine grid and its total length (m)."""
    t = np.linspace(0.0, 2 * np.pi, n + 1)
    _, q1, _ = profile.evaluate(t)
    v = np.abs(q1)
    s = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
    return t, s, float(s[-1])


@dataclass(frozen=True, eq=False)
class _Flank:
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


def _flank(mesh, fem, profile, order: int) -> _Flank:
    import ngsolve as ngs

    fs = ngs.H1(mesh, order=1) if order == 1 else ngs.NodalFESpace(mesh, order=2)
    u, v = fs.TnT()
    bf = ngs.BilinearForm(fs)
    bf += u * v * ngs.ds("flank")
    bf.Assemble()
    ms = sp.csr_matrix(bf.mat.CSR())
    nodes = np.array(sorted(_nodeset(fem, "flank")), dtype=int)
    if ms.shape[0] != fem.NumberOfNodes():
        raise FEError(f"flank surface space has {ms.shape[0]} dofs for {fem.NumberOfNodes()} mesh nodes")
    ms = ms[nodes][:, nodes].tocsr()
    xy = fem.GetNodePositionsAsArray()[nodes, :2]
    g = profile.gap(xy, np.zeros(len(xy)))
    t_tab, s_tab, length = _arc_length_table(profile)
    f = _Flank(nodes, g.t % (2 * np.pi), np.empty(0), length, ms, t_tab, s_tab)
    return _Flank(nodes, f.t, f.s_of_t(f.t), length, ms, t_tab, s_tab)


def _area_weights(fem, nodes: np.ndarray) -> np.ndarray:
    """Surface-area node weights (sum 1) of a node set: a third of each surface triangle
    whose three nodes are in the set (as ``FEMinterface.GetNodeWeightsFromSurfaceAreas``)."""
    pos = fem.GetNodePositionsAsArray()
    tr = np.asarray(fem.surface[0]["Trigs"])
    inset = np.zeros(len(pos), bool)
    inset[nodes] = True
    tr = tr[inset[tr].all(axis=1)]
    area = 0.5 * np.linalg.norm(np.cross(pos[tr[:, 1]] - pos[tr[:, 0]], pos[tr[:, 2]] - pos[tr[:, 0]]), axis=1)
    w = np.bincount(tr.ravel(), weights=np.repeat(area / 3, 3), minlength=len(pos))[nodes]
    if w.sum() <= 0:
        raise FEError(f"node set of {len(nodes)} nodes has no surface triangles")
    return w / w.sum()


def _boundary_node_sets(mesh, fem) -> list[dict]:
    """Exudyn node sets ({'Name', 'NodeNumbers', 'NodeWeights', 'type'}) of every named boundary."""
    el = mesh.ngmesh.Elements2D().NumPy()
    names = list(mesh.GetBoundaries())
    out = []
    for name in dict.fromkeys(names):
        ids = [i + 1 for i, n in enumerate(names) if n == name]
        v = el["nodes"][np.isin(el["index"], ids)].ravel()
        nodes = np.unique(v[v > 0] - 1)
        out.append({"Name": name, "NodeNumbers": nodes, "NodeWeights": _area_weights(fem, nodes), "type": "boundary"})
    return out


def _nodeset(fem, name: str) -> np.ndarray:
    for ns in fem.nodeSets:
        if ns["Name"] == name:
            return np.asarray(ns["NodeNumbers"], dtype=int)
    raise FEError(f"the mesh has no boundary {name!r}")


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


# --------------------------------------------------------------------------- reduction


def _ex2ng(v: np.ndarray, nn: int) -> np.ndarray:
    return v.reshape(nn, 3).T.reshape(-1)


def _ng2ex(v: np.ndarray, nn: int) -> np.ndarray:
    return v.reshape(3, nn).T.reshape(-1)


class _Solver:
    """Sparse Cholesky of K with a set of nodes held (NGSolve), applied to Exudyn-ordered arrays."""

    def __init__(self, bfK, held_nodes: np.ndarray, nn: int):
        import ngsolve as ngs

        self.nn = nn
        free = ngs.BitArray(3 * nn)
        free[:] = True
        for c in range(3):
            for a in held_nodes:
                free[int(c * nn + a)] = False
        with ngs.TaskManager():
            self.inv = bfK.mat.Inverse(free, inverse="sparsecholesky")
        self.vec = bfK.mat.CreateColVector()
        self.out = bfK.mat.CreateColVector()

    def solve(self, F: np.ndarray) -> np.ndarray:
        """Displacements (held nodes zero) for load columns F (3·nn, m), Exudyn ordering."""
        import ngsolve as ngs

        F = F.reshape(F.shape[0], -1)
        U = np.empty_like(F)
        if F.shape[1] == 1:  # the eigensolver's one vector at a time: no thread start-up per call
            self.vec.FV().NumPy()[:] = _ex2ng(F[:, 0], self.nn)
            self.out.data = self.inv * self.vec
            U[:, 0] = _ng2ex(self.out.FV().NumPy(), self.nn)
            return U
        for j0 in range(0, F.shape[1], 32):  # blocks of right-hand sides: one pass over the factor each
            cols = range(j0, min(j0 + 32, F.shape[1]))
            mv = ngs.MultiVector(self.vec, len(cols))
            for i, j in enumerate(cols):
                mv[i].FV().NumPy()[:] = _ex2ng(F[:, j], self.nn)
            out = ngs.MultiVector(self.vec, len(cols))
            with ngs.TaskManager():
                out[:] = self.inv * mv
            for i, j in enumerate(cols):
                U[:, j] = _ng2ex(out[i].FV().NumPy(), self.nn)
        return U


def _rigid_map(pos: np.ndarray, nodes: np.ndarray, centre: np.ndarray, nn: int) -> sp.csr_matrix:
    """(3·nn × 6) map of an interface's rigid motion (translation, small rotation about centre)."""
    rows, cols, vals = [], [], []
    for a in nodes:
        r = pos[a] - centre
        # u = t + ω × r: columns 0-2 translation, 3-5 rotation
        block = np.array([[1, 0, 0, 0, r[2], -r[1]], [0, 1, 0, -r[2], 0, r[0]], [0, 0, 1, r[1], -r[0], 0]], float)
        for c in range(3):
            for k in range(6):
                if block[c, k] != 0.0:
                    rows.append(3 * a + c)
                    cols.append(k)
                    vals.append(block[c, k])
    return sp.csr_matrix((vals, (rows, cols)), shape=(3 * nn, 6))


def _interfaces(fem, geom) -> tuple[Interface, ...]:
    """Interface node sets with area weights nudged so that their weighted centroid is the
    nominal centre exactly (a faceted coarse bore is off by up to ~0.1 mm otherwise, and
    Exudyn's ``MarkerSuperElementRigid`` puts its reference point at that centroid). Where
    positive weights cannot do it (very coarse linear meshes), the plain area weights stay
    and ``centre_m`` is still the nominal centre: compare with ``weights @ nodes``."""
    pos = fem.GetNodePositionsAsArray()
    taken: set[int] = set()
    out = []
    for name, faces, centre in zip(geom.interface_names, geom.interfaces, geom.interface_centres_m):
        nodes = np.unique(np.concatenate([_nodeset(fem, f) for f in faces]))
        nodes = np.array([a for a in nodes if a not in taken], dtype=int)  # interfaces must not share nodes
        taken.update(nodes.tolist())
        w = _centred_weights(_area_weights(fem, nodes), pos[nodes], np.asarray(centre, float))
        out.append(Interface(name, nodes, w, np.asarray(centre, float)))
    return tuple(out)


def _centred_weights(w: np.ndarray, x: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """The weights closest to ``w`` (relative change, least squares) with Σw = 1 and Σw·x = centre.

    Directions in which the nodes do not spread (z on a flat face) are left out.
    """
    C = np.vstack([np.ones_like(w), x.T])
    d = np.concatenate([[1.0], centre])
    spread = np.ptp(x, axis=0) > 1e-9
    keep = np.concatenate([[True], spread])
    C, d = C[keep], d[keep]
    Wc = C * w  # C·diag(w)
    w2 = w + Wc.T @ np.linalg.solve(Wc @ C.T, d - C @ w)
    return w2 if np.all(w2 > 0) else w  # a very coarse face cannot be centred with positive weights: keep areas


def _rbe3_moments(w: np.ndarray, x: np.ndarray):
    """Weighted centroid c = Σ w_i x_i, arms r_i = x_i − c, second moment S = Σ w_i r_i r_iᵀ and the
    polar tensor J = tr(S)·1 − S of an RBE3 coupling with nodes x (n, 3) and weights w."""
    c = w @ x
    r = x - c
    S = np.einsum("i,ij,ik->jk", w, r, r)
    return c, r, S, np.trace(S) * np.eye(3) - S


def rbe3_loads(pos: np.ndarray, itf: Interface, nn: int) -> np.ndarray:
    """(3·nn × 6) nodal loads of a distributing (RBE3) coupling at ``itf`` for a unit force
    along x, y, z and a unit moment about x, y, z at the weighted centroid: f_i = w_i·F and
    f_i = w_i·(I⁻¹m) × r_i with I = Σ w_i (|r_i|²·1 − r_i r_iᵀ), r_i = x_i − Σ w x. The force
    columns are what Exudyn's ``MarkerSuperElementRigid`` with the same nodes and weights
    applies (its position is the weighted mean of the nodes, so its force Jacobian is wᵀ)."""
    w = itf.weights
    _, r, _, inertia = _rbe3_moments(w, pos[itf.nodes])
    F = np.zeros((3 * nn, 6))
    for k in range(3):
        F[3 * itf.nodes + k, k] = w
        a = np.linalg.solve(inertia, np.eye(3)[k])
        F[(3 * itf.nodes[:, None] + np.arange(3)).ravel(), 3 + k] = (w[:, None] * np.cross(a, r)).ravel()
    return F


@dataclass(frozen=True, eq=False)
class VirtualNodes:
    """Massless nodes that carry the distributing (RBE3) motion of interfaces (body frame).

    ``positions_m`` (n, 3) and mode rows ``rows`` (3·n × n_modes, Exudyn ordering x0, y0, z0, x1, …);
    ``groups[k]`` are the indices (into ``positions_m``) of the nodes of ``names[k]``.
    """

    names: tuple[str, ...]
    positions_m: np.ndarray
    rows: np.ndarray
    groups: tuple[tuple[int, ...], ...]

    def group(self, name: str) -> tuple[int, ...]:
        return self.groups[self.names.index(name)]


# a regular tetrahedron with centroid 0 and ¼·Σ t tᵀ = 1: scaled by S^½ it has the seat's second moment
_TETRA = np.array([[1.0, 1.0, 1.0], [1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0]])


def rbe3_virtual_nodes(mode_basis: np.ndarray, pos: np.ndarray, interfaces) -> VirtualNodes:
    """Four virtual nodes per interface whose rigid motion is the interface's RBE3 motion.

    For an interface with nodes x_i, weights w_i (Σ w = 1), centroid c = Σ w_i x_i, r_i = x_i − c,
    second moment S = Σ w_i r_i r_iᵀ and J = tr(S)·1 − S: the mean translation a = Σ w_i Φ_i and
    the weighted rotation θ = J⁻¹ Σ w_i r_i × Φ_i (the rows Φ_i of the mode basis). The four
    nodes sit at c + s_j, s_j = V Λ^½ t_j (S = V Λ Vᵀ, t_j a regular tetrahedron), so they have
    the interface's centroid and second moment; their rows are a + θ × s_j. A
    ``MarkerSuperElementRigid`` with weights ¼ on them then has exactly the position map (Σ w_i Φ_i)
    and rotation map ((J + D)⁻¹ (Σ w_i p_i × Φ_i), p_i = x_i − reference point, D from the reference
    point's distance to c) of the marker on all interface nodes — for any marker offset — and by
    virtual work the same load distribution.
    """
    names, ps, rows, groups = [], [], [], []
    for itf in interfaces:
        w = np.asarray(itf.weights, float)
        if abs(w.sum() - 1.0) > 1e-9:
            raise ValueError(f"interface {itf.name}: weights sum to {w.sum()}, not 1")
        nodes = np.asarray(itf.nodes, int)
        c, r, S, J = _rbe3_moments(w, pos[nodes])
        phi = mode_basis[(3 * nodes[:, None] + np.arange(3)).ravel()].reshape(len(nodes), 3, -1)  # (n, 3, m)
        a = np.einsum("i,ijm->jm", w, phi)
        b = np.einsum("i,ijm->jm", w, np.cross(r[:, :, None], phi, axisa=1, axisb=1, axisc=1))
        theta = np.linalg.solve(J, b)  # (3, m)
        lam, V = np.linalg.eigh(S)
        s = _TETRA @ (V * np.sqrt(np.clip(lam, 0.0, None))).T  # (4, 3)
        start = sum(len(g) for g in groups)
        names.append(itf.name)
        groups.append(tuple(range(start, start + len(s))))
        ps.append(c + s)
        rows.append((a[None] + np.cross(theta[None], s[:, :, None], axisa=1, axisb=1, axisc=1)).reshape(-1, a.shape[1]))
    return VirtualNodes(tuple(names), np.vstack(ps), np.vstack(rows), tuple(groups))


def _mass_orthonormal(B: np.ndarray, M) -> np.ndarray:
    """An M-orthonormal basis of span(B), dropping directions below 1e-10 of the largest."""
    B = B / np.sqrt(np.einsum("ij,ij->j", B, M @ B))  # unit M-norm first: attachment modes are ~1e-9 m/N
    G = B.T @ (M @ B)
    lam, V = np.linalg.eigh(0.5 * (G + G.T))
    keep = lam > 1e-10 * lam.max()
    return B @ (V[:, keep] / np.sqrt(lam[keep]))


def _progress(progress, msg: str) -> None:
    if progress is not None:
        progress(msg)


def _build(spec: ReducerSpec, part: str, s: PartSettings, key: str, progress=None) -> ReducedPart:
    import ngsolve as ngs
    from exudyn.FEM import FEMinterface
    from netgen.occ import OCCGeometry

    from rvflex.fe.geometry import part_geometry
    from rvflex.geometry.profile import build_profile

    t_start = time.perf_counter()
    what = f"{part} (maxh {s.maxh_m * 1e3:g} mm, order {s.mesh_order}, {s.n_modes} modes)"
    geom = part_geometry(spec, part)
    n_att_planned = (s.attach_per_tooth * spec.cycloid.disc_teeth * (2 if s.attach_tangential else 1)
                     if part == "disc" else 0)
    tets_est = estimate_tets(geom.volume_m3, s.maxh_m, part, s.curvature_safety)
    need = estimate_memory_bytes(tets_est, s, n_att_planned)
    avail = _available_bytes()
    if need > 0.8 * avail:
        raise SpecError("maxh_m", s.maxh_m, f"the {part} mesh would have ≈{tets_est:,} tets and need ≈{need / 2**30:.1f} "
                                            f"GiB, more than 80 % of the {avail / 2**30:.1f} GiB available; use a "
                                            f"larger maxh")
    dof_est = 3 * tets_est * (1.45 if s.mesh_order == 2 else 0.25)
    if s.n_modes + n_att_planned > MAX_MODE_FRACTION * dof_est:
        raise SpecError("n_modes", s.n_modes, f"{s.n_modes + n_att_planned} internal modes exceed what a mesh of "
                                              f"≈{int(dof_est):,} DOFs resolves ({MAX_MODE_FRACTION:.0%} of them)")
    mat = spec.materials.gears_cranks_discs if part == "disc" else spec.materials.carriers
    _progress(progress, "mesh")
    try:
        ngmesh = OCCGeometry(geom.shape).GenerateMesh(maxh=s.maxh_m, curvaturesafety=s.curvature_safety)
        mesh = ngs.Mesh(ngmesh)
        _progress(progress, "assemble")
        fem = FEMinterface()
        with ngs.TaskManager():
            _bfM, bfK, _fes = fem.ImportMeshFromNGsolve(mesh, density=mat.density_kg_m3,
                                                      youngsModulus=mat.youngs_modulus_Pa,
                                                      poissonsRatio=mat.poisson_ratio, meshOrder=s.mesh_order,
                                                      createBoundaryNodeSets=False)
        fem.nodeSets = _boundary_node_sets(mesh, fem)  # vectorised: Exudyn's loops take ~10 s here
    except SpecError:
        raise
    except Exception as exc:  # netgen/NGSolve raise plain exceptions: say which part and settings
        raise FEError(f"meshing/assembly of the {what} failed: {exc}") from exc
    nn = fem.NumberOfNodes()
    pos = fem.GetNodePositionsAsArray()
    M = fem.GetMassMatrix(sparse=True).tocsr()
    K = fem.GetStiffnessMatrix(sparse=True).tocsr()
    itfs = _interfaces(fem, geom)
    # carrier with distributing (RBE3) seats: only the output face is held; the seats are
    # elastic and get attachment modes for the loads their couplings distribute
    rbe3 = part == "carrier" and s.seat_coupling == "rbe3"
    held = itfs[0].nodes if rbe3 else np.concatenate([i.nodes for i in itfs])
    n_free = 3 * (nn - held.size)
    n_int_req = s.n_modes + n_att_planned
    if n_int_req > MAX_MODE_FRACTION * n_free:
        raise SpecError("n_modes", s.n_modes, f"{n_int_req} internal modes exceed what this mesh resolves: "
                                              f"{n_free:,} free DOFs allow {int(MAX_MODE_FRACTION * n_free)}")
    try:
        _progress(progress, "factorise")
        solver = _Solver(bfK, held, nn)
        # 1. static interface modes (interior relaxed); the first interface stays clamped
        _progress(progress, "static modes")
        T_all = [_rigid_map(pos, i.nodes, i.centre_m, nn) for i in itfs]
        static = []
        for T in ([] if rbe3 else T_all[1:]):
            Ub = T.toarray()
            static.append(Ub - solver.solve(K @ Ub) * _free_mask(held, nn)[:, None])
        S = np.hstack(static) if static else np.zeros((3 * nn, 0))
        # 2. fixed-interface eigenmodes: shift-invert Lanczos on the interior, the Cholesky as (K_ii)⁻¹
        _progress(progress, "eigenmodes")
        E = np.zeros((3 * nn, 0))
        lam_eig = np.zeros(0)
        if s.n_modes:
            lam_eig, E = _fixed_interface_modes(K, M, solver, held, nn, s.n_modes)
        # 3. attachment modes: unit normal patch loads around the flank (disc)
        profile = flank = None
        A = np.zeros((3 * nn, 0))
        if part == "disc":
            profile = build_profile(spec.cycloid)
            flank = _flank(mesh, fem, profile, s.mesh_order)
        _progress(progress, "attachment modes")
        if rbe3:  # 6 unit loads per seat, distributed as its RBE3 coupling does (forces, then moments)
            A = solver.solve(np.hstack([rbe3_loads(pos, i, nn) for i in itfs[1:]]))
        if n_att_planned:
            n_c = s.attach_per_tooth * spec.cycloid.disc_teeth
            tc = (np.arange(n_c) + 0.5) * 2 * np.pi / n_c
            Wd = flank.weights(tc, s.patch_half_width_m, s.patch_shape).toarray()
            nrm = profile.normal(tc)
            dirs = [nrm, np.column_stack([-nrm[:, 1], nrm[:, 0]])] if s.attach_tangential else [nrm]
            F = np.zeros((3 * nn, n_c * len(dirs)))
            for k, d in enumerate(dirs):  # normal (and tangential) unit patch loads
                for c in range(2):
                    F[3 * flank.nodes + c, k * n_c:(k + 1) * n_c] = -(Wd * d[:, c][:, None]).T
            A = solver.solve(F)
        # Rayleigh–Ritz on the internal span: diagonal internal mass and stiffness
        _progress(progress, "Ritz")
        B = _mass_orthonormal(np.hstack([E, A]), M) if E.shape[1] + A.shape[1] else np.zeros((3 * nn, 0))
        Kr = B.T @ (K @ B)
        lam_r, V = np.linalg.eigh(0.5 * (Kr + Kr.T))
        Psi_int = B @ V
        Psi = np.hstack([S, Psi_int])
    except SpecError:
        raise
    except Exception as exc:
        raise FEError(f"Craig–Bampton reduction of the {what} failed: {exc}") from exc
    fem.modeBasis = {"matrix": Psi, "type": "HCBmodes"}
    fem.eigenValues = lam_eig
    mass_r = Psi.T @ (M @ Psi)
    stiff_r = Psi.T @ (K @ Psi)
    rows = None
    if flank is not None:
        tg = np.arange(spec.cycloid.disc_teeth * ROWS_PER_TOOTH) * 2 * np.pi / (spec.cycloid.disc_teeth * ROWS_PER_TOOTH)
        W = flank.weights(tg, s.patch_half_width_m, s.patch_shape)
        Pf = Psi.reshape(nn, 3, -1)[flank.nodes, :2, :]  # (n_flank, 2, modes)
        rows = FlankRows(tg, np.stack([W @ Pf[:, 0, :], W @ Pf[:, 1, :]], axis=1), s.patch_half_width_m)
    _progress(progress, "static check")
    if part == "disc":
        chk = _disc_check(spec, profile, flank, s, solver, K, Psi, S.shape[1], T_all, nn)
    else:
        chk = _carrier_check(spec, bfK, fem, itfs, K, Psi, nn, geom, s.seat_coupling)
    wall = time.perf_counter() - t_start
    return ReducedPart(part, s, key, fem, pos, itfs, S.shape[1], E.shape[1], A.shape[1],
                       np.sqrt(lam_eig) / (2 * np.pi), mass_r, stiff_r, rows, chk, wall,
                       {"n_tets": int(mesh.ne), "ritz_freqs_hz": (np.sqrt(np.abs(lam_r)) / (2 * np.pi)).tolist()})


def _fixed_interface_modes(K, M, solver: _Solver, held: np.ndarray, nn: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``n`` lowest eigenpairs (ω², Exudyn-ordered modes) with all interface nodes held."""
    from scipy.sparse.linalg import LinearOperator, eigsh

    free = np.flatnonzero(_free_mask(held, nn))
    Kii, Mii = K[free][:, free], M[free][:, free]

    def apply_inv(x):
        full = np.zeros(3 * nn)
        full[free] = np.ravel(x)
        return solver.solve(full[:, None])[free, 0]

    op = LinearOperator(Kii.shape, matvec=apply_inv, dtype=float)
    lam, vec = eigsh(Kii, k=n, M=Mii, sigma=0.0, which="LM", OPinv=op, v0=np.ones(free.size))  # fixed v0: repeatable
    order = np.argsort(lam)
    E = np.zeros((3 * nn, n))
    E[free] = vec[:, order]
    return np.abs(lam[order]), E


def _free_mask(held: np.ndarray, nn: int) -> np.ndarray:
    m = np.ones(3 * nn)
    for c in range(3):
        m[3 * held + c] = 0.0
    return m


def _galerkin(K, Psi: np.ndarray, F: np.ndarray) -> np.ndarray:
    Kr = Psi.T @ (K @ Psi)
    return Psi @ np.linalg.solve(Kr, Psi.T @ F)


CHECK_ANGLES_PITCH = (0.12, 0.37, 0.62, 0.87)  # disc angles of the static check, in pin pitches


def _disc_check(spec, profile, flank, s, solver, K, Psi, n_static, T_all, nn) -> StaticCheck:
    """Rated tooth loads, bores held: full K_ii⁻¹f vs reduced internal modes, at the disc
    angles :data:`CHECK_ANGLES_PITCH` (contact points anywhere between the attachment
    patches); the worst angle is reported."""
    mask = _free_mask(np.concatenate([T.nonzero()[0] // 3 for T in T_all]), nn)
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


def _carrier_check(spec, bfK, fem, itfs, K, Psi, nn, geom, coupling: str = "rbe3") -> StaticCheck:
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
        T = _rigid_map(pos, itf.nodes, pos[itf.nodes].T @ itf.weights, nn)
        F_model += rbe3_loads(pos, itf, nn) @ (T.T @ f)  # the same resultant (force, moment) through the coupling
    solver = _Solver(bfK, ref.nodes, nn)
    u_full = solver.solve(F[:, None])[:, 0]
    u_red = _galerkin(K, Psi, F_model[:, None])[:, 0]

    def seat_disp(u, weights):
        return np.array([w @ (u.reshape(nn, 3)[itf.nodes] @ d) for itf, d, w in zip(seats, dirs, weights)])

    s_full, s_red = seat_disp(u_full, press), seat_disp(u_red, [itf.weights for itf in seats])
    itf_pct = 100 * np.max(np.abs(s_red - s_full)) / np.max(np.abs(s_full))
    # pillar mid-span: surface nodes of each pillar within 2 mm of the mid-plane z = 0
    vals_f, vals_r = [], []
    for j in range(spec.carrier.pillar_count):
        nodes = _nodeset(fem, f"pillar{j}")
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


def reduce_part(spec: ReducerSpec, part: str, *, maxh_m: float | None = None, n_modes: int | None = None,
                cache_dir: str | os.PathLike | None = None, use_cache: bool = True, progress=None,
                **settings) -> ReducedPart:
    """Reduce ``part`` (``"disc"`` or ``"carrier"``) of ``spec``, from the disk cache when possible.

    Parameters
    ----------
    spec : ReducerSpec
    part : {"disc", "carrier"}
    maxh_m : float, optional
        Largest element size (m); default :data:`DEFAULTS`.
    n_modes : int, optional
        Fixed-interface eigenmodes; default :data:`DEFAULTS`.
    cache_dir : path, optional
        Cache directory; default ``$RVFLEX_CACHE_DIR`` or ``~/.cache/rvflex``.
    use_cache : bool
        False computes afresh and does not write the cache.
    progress : callable(str), optional
        Called with the name of each long step.
    **settings
        Further :class:`PartSettings` fields (``mesh_order``, ``patch_half_width_m``,
        ``attach_per_tooth``).

    Returns
    -------
    ReducedPart
        ``rp.meta["cached"]`` tells whether it came from the cache.

    Raises
    ------
    SpecError
        Bad settings, a disc whose holes break its outline, a mesh that would not fit in
        memory, more modes than the mesh resolves — all before the long steps.
    FEError
        netgen/NGSolve/Exudyn failed (the message names the part and settings).
    """
    from rvflex.fe import cache

    s = settings_for(part, maxh_m=maxh_m, n_modes=n_modes, **settings)
    key = cache.key_for(spec, part, s, CODE_VERSION)
    if use_cache:
        hit = cache.load(key, cache_dir)
        if hit is not None:
            return hit
    rp = _build(spec, part, s, key, progress)
    if use_cache:
        cache.store(rp, cache_dir)
    rp.meta["cached"] = False
    return rp


def free_free_frequencies_hz(rp: ReducedPart, n: int = 6) -> np.ndarray:
    """The ``n`` lowest elastic free–free eigenfrequencies (Hz) of the reduced body: the
    Craig–Bampton basis plus the 6 rigid-body motions, as the floating frame adds them."""
    from scipy.linalg import eigh

    pos = rp.node_positions_m
    nn = pos.shape[0]
    R = _rigid_map(pos, np.arange(nn), np.zeros(3), nn).toarray()
    M = rp.fem.GetMassMatrix(sparse=True)
    B = np.hstack([R, rp.mode_basis])
    Mb = B.T @ (M @ B)
    Kb = np.zeros_like(Mb)
    Kb[6:, 6:] = rp.stiffness_reduced
    lam = eigh(0.5 * (Kb + Kb.T), 0.5 * (Mb + Mb.T), eigvals_only=True)
    return np.sqrt(np.abs(lam[6:6 + n])) / (2 * np.pi)


def convergence_study(spec: ReducerSpec, part: str, variants, *, metric=None, cache_dir=None,
                      progress=None) -> list[dict]:
    """Reduce ``part`` for each settings variant (dicts of :func:`reduce_part` keywords, e.g.
    ``{"maxh_m": 3e-3}``, ``{"n_modes": 20}``) and tabulate the results.

    ``metric(rp) -> dict`` adds columns (e.g. the loaded TE of a model built on ``rp``, for
    the TE-change study of docs/fe.md); the default columns are the nodes, modes, first
    eigenfrequency, the static-check errors and the full flank/interface responses.
    """
    rows = []
    for v in variants:
        rp = reduce_part(spec, part, cache_dir=cache_dir, progress=progress, **v)
        row = {**v, "n_nodes": rp.n_nodes, "n_tets": rp.meta.get("n_tets"), "n_modes_total": rp.n_modes,
               "f1_hz": float(rp.freqs_hz[0]) if rp.freqs_hz.size else float("nan"),
               "flank_pct": rp.check.flank_pct, "interface_pct": rp.check.interface_pct,
               "flank_full_m": rp.check.flank_full_m, "interface_full": rp.check.interface_full,
               "wall_s": rp.wall_s, "cached": rp.meta.get("cached", False)}
        if metric is not None:
            row.update(metric(rp))
        rows.append(row)
    return rows

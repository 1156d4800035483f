"""Interfaces of a meshed part and their couplings: node sets and area weights, the rigid
(RBE2) map of an interface, distributing (RBE3) loads and the virtual nodes that carry an RBE3
interface's motion into Exudyn."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from rvflex.fe.types import FEError, Interface, VirtualNodes

__all__ = ["area_weights", "boundary_node_sets", "centred_weights", "interfaces_of", "nodeset", "rbe3_loads", "rbe3_moments", "rbe3_virtual_nodes", "rigid_map"]


def area_weights(fem, nodes: np.ndarray) -> np.ndarray:
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


def boundary_node_sets(mesh, fem) -> list[dict]:
    """Exudyn node sets ({'Name', 'NodeNumbers', 'NodeWeights', 'type'}) of every named boundary."""
    el = mesh.ngmesh.Elements2D().NumPy()
    names = list(mesh.GetBoundaries())
    out = []
    for name in dict.fromkeys(names):
        ids = [i + 1 for i, n in enumerate(names) if n == name]
        v = el["nodes"][np.isin(el["index"], ids)].ravel()
        nodes = np.unique(v[v > 0] - 1)
        out.append({"Name": name, "NodeNumbers": nodes, "NodeWeights": area_weights(fem, nodes), "type": "boundary"})
    return out


def nodeset(fem, name: str) -> np.ndarray:
    for ns in fem.nodeSets:
        if ns["Name"] == name:
            return np.asarray(ns["NodeNumbers"], dtype=int)
    raise FEError(f"the mesh has no boundary {name!r}")


def rigid_map(pos: np.ndarray, nodes: np.ndarray, centre: np.ndarray, nn: int) -> sp.csr_matrix:
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


def interfaces_of(fem, geom, centred: bool = True) -> tuple[Interface, ...]:
    """Interface node sets with area weights nudged so that their weighted centroid is the
    nominal centre exactly (a faceted coarse bore is off by up to ~0.1 mm otherwise, and
    Exudyn's ``MarkerSuperElementRigid`` puts its reference point at that centroid). Where
    positive weights cannot do it (very coarse linear meshes), the plain area weights stay
    and ``centre_m`` is still the nominal centre: compare with ``weights @ nodes``.
    ``centred=False`` keeps the area weights everywhere (the housing's half-cylinder pin
    seats, whose area centroid lies outside the pin centre)."""
    pos = fem.GetNodePositionsAsArray()
    taken: set[int] = set()
    out = []
    for name, faces, centre in zip(geom.interface_names, geom.interfaces, geom.interface_centres_m):
        nodes = np.unique(np.concatenate([nodeset(fem, f) for f in faces]))
        nodes = np.array([a for a in nodes if a not in taken], dtype=int)  # interfaces must not share nodes
        taken.update(nodes.tolist())
        w = area_weights(fem, nodes)
        if centred:
            w = centred_weights(w, pos[nodes], np.asarray(centre, float))
        out.append(Interface(name, nodes, w, np.asarray(centre, float)))
    return tuple(out)


def centred_weights(w: np.ndarray, x: np.ndarray, centre: np.ndarray) -> np.ndarray:
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


def rbe3_moments(w: np.ndarray, x: np.ndarray):
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
    _, r, _, inertia = rbe3_moments(w, pos[itf.nodes])
    F = np.zeros((3 * nn, 6))
    for k in range(3):
        F[3 * itf.nodes + k, k] = w
        a = np.linalg.solve(inertia, np.eye(3)[k])
        F[(3 * itf.nodes[:, None] + np.arange(3)).ravel(), 3 + k] = (w[:, None] * np.cross(a, r)).ravel()
    return F


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
        c, r, S, J = rbe3_moments(w, pos[nodes])
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

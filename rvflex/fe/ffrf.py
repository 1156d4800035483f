"""Exudyn's FFRF reduced-order interface of a reduced part, cached on disk.

``ObjectFFRFreducedOrderInterface(fem)`` precomputes the floating-frame inertia tensors from
every mesh node (Ψ̃, Ψ̃ᵀMΨ, …): about a minute for a 40k-node disc with 96 modes, more than
the rest of a model build. The tensors depend only on the reduced part, so they are stored
next to its cache file under the same content key and loaded in well under a second.
The file is written atomically (unique temporary name, then rename), so concurrent sweep
workers never see a partial file; a file that does not load is rebuilt, never used.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from rvflex.fe.cache import cache_root
from rvflex.io import write_atomic

__all__ = ["ffrf_interface", "with_virtual_nodes"]

_FORMAT = "rvflex-ffrf-1"
_SCALARS = ("nModes", "nNodes", "dim3D", "nODE2rot", "nODE2rigid", "nODE2FFRFreduced", "totalMass")


def _path(reduced, cache_dir) -> Path:
    """The interface file of ``reduced`` (a part scaled from another modulus shares that part's)."""
    ref = reduced.meta.get("scaled_from")
    return cache_root(cache_dir) / f"ffrf-{ref['key'] if ref else reduced.key}.npz"


def _build(reduced, node_type):
    from exudyn.FEM import ObjectFFRFreducedOrderInterface

    return ObjectFFRFreducedOrderInterface(reduced.fem, rigidBodyNodeType=node_type)


def _save(obj, path: Path) -> None:
    arrays = {k: v for k, v in obj.__dict__.items() if isinstance(v, np.ndarray)}
    arrays.update({f"scalar_{k}": np.asarray(getattr(obj, k)) for k in _SCALARS})
    arrays["trigList"] = np.asarray(obj.trigList, dtype=np.int64).reshape(-1, 3)
    arrays["format"] = np.asarray(_FORMAT)
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    write_atomic(path, buf.getvalue())


def _load(path: Path, node_type):
    from exudyn.FEM import ObjectFFRFreducedOrderInterface

    with np.load(path, allow_pickle=False) as z:
        if str(z["format"]) != _FORMAT:
            raise ValueError("format")
        obj = ObjectFFRFreducedOrderInterface.__new__(ObjectFFRFreducedOrderInterface)
        for k in z.files:
            if k.startswith("scalar_"):
                v = z[k]
                setattr(obj, k[7:], v.item() if v.ndim == 0 else v)
            elif k not in ("format", "trigList"):
                setattr(obj, k, z[k])
        obj.trigList = z["trigList"].tolist()
    obj.postProcessingModes = {}
    obj.rigidBodyNodeType = node_type
    return obj


def ffrf_interface(reduced, *, cache_dir: str | os.PathLike | None = None):
    """The ``ObjectFFRFreducedOrderInterface`` of ``reduced`` (a ReducedPart) for a
    NodeRigidBodyRxyz reference node: from the disk cache when a valid file exists, else
    computed and stored. Reuse one interface for several bodies of the same part.

    A part that is another one at a different Young's modulus (``meta["scaled_from"]``, see
    :func:`rvflex.fe.cache.load_at_modulus`) shares that part's file: every tensor but the reduced
    stiffness comes from the mode basis and the mass matrix, which the modulus leaves alone, and the
    reduced stiffness is scaled by the modulus factor."""
    import exudyn as exu

    node_type = exu.NodeType.RotationRxyz
    factor = float(reduced.meta.get("scaled_from", {}).get("modulus_factor", 1.0))
    path = _path(reduced, cache_dir)
    if path.is_file():
        try:
            obj = _load(path, node_type)
        except Exception:  # corrupt or foreign file: rebuild, never use
            path.unlink(missing_ok=True)
        else:
            obj.stiffnessMatrixReduced = obj.stiffnessMatrixReduced * factor
            return obj
    obj = _build(reduced, node_type)
    k = obj.stiffnessMatrixReduced
    obj.stiffnessMatrixReduced = k / factor  # stored as the reference part's
    _save(obj, path)
    obj.stiffnessMatrixReduced = k
    return obj


def with_virtual_nodes(obj, virtual):
    """A copy of the interface ``obj`` with the massless nodes ``virtual`` (a
    :class:`rvflex.fe.reduce.VirtualNodes`) appended after the mesh nodes: their rows go to the
    mode basis and their positions to the reference positions, nothing else. The FFRF inertia
    terms (mass, inertia, χ_u, the mΨ… tensors) were computed from the mesh's mass matrix, in
    which these nodes have no rows, so they stay as they are: the nodes are massless and only
    give markers something to hold. Returns (copy, index of the first virtual node).
    ``obj`` itself (and its cache file) is unchanged."""
    import copy

    from exudyn.FEM import ComputeSkewMatrix

    out = copy.copy(obj)
    first = int(obj.nNodes)
    rows = np.asarray(virtual.rows, float)
    if rows.shape != (3 * len(virtual.positions_m), obj.modeBasis.shape[1]):
        raise ValueError(f"virtual node rows {rows.shape} do not fit the mode basis {obj.modeBasis.shape}")
    out.modeBasis = np.vstack([obj.modeBasis, rows])
    out.xRef = np.concatenate([np.asarray(obj.xRef, float), np.asarray(virtual.positions_m, float).ravel()])
    out.nNodes = first + len(virtual.positions_m)
    if getattr(obj, "PsiTilde", None) is not None:  # only the Python user-function path reads it
        out.PsiTilde = np.vstack([obj.PsiTilde, ComputeSkewMatrix(rows)])
    return out, first

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

Modules: :mod:`~rvflex.fe.types` (settings, the reduced part and its pieces),
:mod:`~rvflex.fe.couplings` (interfaces, RBE2 maps, RBE3 loads and virtual nodes),
:mod:`~rvflex.fe.loads` (flank patches, rated pin forces), :mod:`~rvflex.fe.solver` (held-node
Cholesky solves), :mod:`~rvflex.fe.hcb` (the build and its estimates),
:mod:`~rvflex.fe.checks` (reduced-vs-full static checks), and here the cached
:func:`reduce_part`. The names of those modules that users and tests use are re-exported here.
"""

from __future__ import annotations

import multiprocessing as mp
import os

import numpy as np

from rvflex.choices import FEPart
from rvflex.fe import cache
from rvflex.fe.checks import static_check
from rvflex.fe.couplings import nodeset, rbe3_loads, rbe3_virtual_nodes, rigid_map
from rvflex.fe.hcb import STEPS, build, estimate_memory_bytes
from rvflex.fe.isolated import build_isolated
from rvflex.fe.loads import disc_rated_load_case
from rvflex.fe.types import (
    CHECK_ANGLES_PITCH,
    CODE_VERSION,
    DEFAULTS,
    DISC_FLANK_BASIS,
    FEError,
    FlankRows,
    Interface,
    PartSettings,
    ReducedPart,
    StaticCheck,
    VirtualNodes,
    settings_for,
)
from rvflex.spec import ReducerSpec

__all__ = [
    "CHECK_ANGLES_PITCH",
    "CODE_VERSION",
    "DEFAULTS",
    "DISC_FLANK_BASIS",
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
    "rbe3_loads",
    "rbe3_virtual_nodes",
    "reduce_part",
    "settings_for",
    "static_check",
]

_build = build  # the uncached step; a module attribute so tests can stand in for it
_nodeset = nodeset  # old private name (tests)


def reduce_part(spec: ReducerSpec, part: FEPart, *, maxh_m: float | None = None, n_modes: int | None = None,
                cache_dir: str | os.PathLike | None = None, use_cache: bool = True, progress=None,
                **settings) -> ReducedPart:
    """Reduce ``part`` (``"disc"``, ``"carrier"`` or ``"housing"``) of ``spec``, from the disk cache when possible.

    Parameters
    ----------
    spec : ReducerSpec
    part : {"disc", "carrier", "housing"}
    maxh_m : float, optional
        Largest element size (m); default :data:`DEFAULTS` (the flexible presets' reduction of
        ``part``).
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
        ``rp.meta["cached"]`` tells whether it came from the cache; ``rp.meta["scaled_from"]`` (key,
        modulus factor) that it is the cached part of another Young's modulus, its stiffness scaled
        (:func:`rvflex.fe.cache.load_at_modulus`: the same basis, nothing meshed).

    Raises
    ------
    SpecError
        Bad settings, a disc whose holes break its outline, a mesh that would not fit in
        memory, more modes than the mesh resolves — all before the long steps.
    FEError
        netgen/NGSolve/Exudyn failed (the message names the part and settings).
    """
    s = settings_for(part, maxh_m=maxh_m, n_modes=n_modes, **settings)
    key = cache.key_for(spec, part, s, CODE_VERSION)
    if use_cache:
        free, e = cache.modulus_free_key(spec, part, s, CODE_VERSION), cache.modulus(spec, part)
        hit = cache.load(key, cache_dir)
        if hit is not None:
            cache.note_modulus(free, key, e, cache_dir)  # (a reduction cached before such notes were kept)
            return hit
        hit = cache.load_at_modulus(free, key, e, part, cache_dir)  # the same part at another Young's modulus
        if hit is not None:
            return hit
    if mp.parent_process() is not None:  # a pool worker: OCC meshing is not fork-safe (rvflex.fe.isolated)
        rp = build_isolated(spec, part, s, key, cache_dir, use_cache)
    else:
        rp = _build(spec, part, s, key, progress)
        if use_cache:
            cache.store(rp, cache_dir)
        rp.meta["cached"] = False
    if use_cache:
        cache.note_modulus(free, key, e, cache_dir)
    return rp


def free_free_frequencies_hz(rp: ReducedPart, n: int = 6) -> np.ndarray:
    """The ``n`` lowest elastic free–free eigenfrequencies (Hz) of the reduced body: the
    Craig–Bampton basis plus the 6 rigid-body motions, as the floating frame adds them."""
    from scipy.linalg import eigh  # noqa: PLC0415 -- SciPy's dense eigensolver, only here

    pos = rp.node_positions_m
    nn = pos.shape[0]
    R = rigid_map(pos, np.arange(nn), np.zeros(3), nn).toarray()
    M = rp.fem.GetMassMatrix(sparse=True)
    B = np.hstack([R, rp.mode_basis])
    Mb = B.T @ (M @ B)
    Kb = np.zeros_like(Mb)
    Kb[6:, 6:] = rp.stiffness_reduced
    lam = eigh(0.5 * (Kb + Kb.T), 0.5 * (Mb + Mb.T), eigvals_only=True)
    return np.sqrt(np.abs(lam[6:6 + n])) / (2 * np.pi)


def convergence_study(spec: ReducerSpec, part: FEPart, variants, *, metric=None, cache_dir=None,
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

"""The in-plane pose of a cross-section of a tilted rigid body, and planar forces mapped back onto it.

A planar force element (the cycloid–pin contact of one face slice, the involute mesh of a crank's gear) acts in
a plane z = const on the in-plane pose (x, y, θ) of the section of a body that sits there. For a
``NodeRigidBodyRxyz`` body (coordinates q = (x, y, z, ψx, ψy, ψz), rotation R = Rx(ψx)·Ry(ψy)·Rz(ψz)) the
section at axial lever ℓ from the node is taken as the body point (0, 0, ℓ) and the turn ψz::

    s(q) = (x + ℓ·sin ψy,  y − ℓ·sin ψx·cos ψy,  ψz)

which is the exact in-plane position of that point (R·(0, 0, ℓ)), so an untilted body gives s = (x, y, ψz)
exactly, whatever ℓ. The element's generalized force f₃ on s and its left-hand-side Jacobians K₃ = −∂f₃/∂s,
D₃ = −∂f₃/∂ṡ map to the body by virtual work with T = ∂s/∂q (3 × 6)::

    f = Tᵀ f₃,   K = Tᵀ K₃ T − Σᵢ f₃ᵢ ∂²sᵢ/∂q²,   D = Tᵀ D₃ T

(ṡ = T q̇). The curvature term keeps K the exact Jacobian, and symmetric where K₃ is (no friction). The axial
coordinate z does not enter: a section slides along pins parallel to the axis without changing its contact.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

__all__ = ["NODE", "add_curvature", "map_to_body", "section_force", "section_pose"]

NODE = 6  # coordinates of a NodeRigidBodyRxyz: x, y, z, ψx, ψy, ψz

_jit = nb.njit(cache=True, nogil=True)


@_jit
def section_pose(q, lever, s, jac):
    """The in-plane pose ``s`` (3,) (m, m, rad) of the section at ``lever`` (m) of a body at coordinates ``q`` (6,)
    (m, rad; absolute, or displacements with the reference tilt zero), and ``jac`` = ∂s/∂q (3, 6), in place."""
    sx, cx = math.sin(q[3]), math.cos(q[3])
    sy, cy = math.sin(q[4]), math.cos(q[4])
    s[0] = q[0] + lever * sy
    s[1] = q[1] - lever * sx * cy
    s[2] = q[5]
    for i in range(3):
        for j in range(6):
            jac[i, j] = 0.0
    jac[0, 0] = 1.0
    jac[0, 4] = lever * cy
    jac[1, 1] = 1.0
    jac[1, 3] = -lever * cx * cy
    jac[1, 4] = lever * sx * sy
    jac[2, 5] = 1.0


@_jit
def map_to_body(q, lever, jac, f3, k3, d3, f, k, d):
    """The section's force ``f3`` (3,) and LHS Jacobians ``k3``, ``d3`` (3, 3) on the body's coordinates: ``f`` (6,),
    ``k``, ``d`` (6, 6) filled in place (module docstring); ``jac`` from :func:`section_pose` at the same ``q``."""
    for a in range(6):
        fa = 0.0
        for i in range(3):
            fa += jac[i, a] * f3[i]
        f[a] = fa
        for b in range(6):
            ka = 0.0
            da = 0.0
            for i in range(3):
                if jac[i, a] == 0.0:
                    continue
                for j in range(3):
                    ka += jac[i, a] * k3[i, j] * jac[j, b]
                    da += jac[i, a] * d3[i, j] * jac[j, b]
            k[a, b] = ka
            d[a, b] = da
    add_curvature(q, lever, f3, 1.0, k, 0)


@_jit
def add_curvature(q, lever, f3, scale, k, at):
    """Add −``scale``·Σᵢ f3ᵢ·∂²sᵢ/∂q² (the curvature term of K) to ``k`` at the body's coordinates, which start at
    row and column ``at`` of ``k``; only the tilts (ψx, ψy) enter s nonlinearly."""
    sx, cx = math.sin(q[3]), math.cos(q[3])
    sy, cy = math.sin(q[4]), math.cos(q[4])
    i, j = at + 3, at + 4
    k[j, j] -= scale * (f3[0] * (-lever * sy) + f3[1] * (lever * sx * cy))
    k[i, i] -= scale * f3[1] * (lever * sx * cy)
    k[i, j] -= scale * f3[1] * (lever * cx * sy)
    k[j, i] -= scale * f3[1] * (lever * cx * sy)


def section_force(q: np.ndarray, lever: float, f3: np.ndarray, k3: np.ndarray,
                  d3: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`map_to_body` with new arrays: force (6,) (N, N·m), K and D (6, 6) on the body's coordinates ``q``
    (6,) (m, rad) from the section's ``f3`` (3,), ``k3``, ``d3`` (3, 3; zero if None) at ``lever`` (m)."""
    q = np.asarray(q, float)
    jac, s = np.empty((3, NODE)), np.empty(3)
    section_pose(q, float(lever), s, jac)
    f, k, d = np.empty(NODE), np.empty((NODE, NODE)), np.empty((NODE, NODE))
    map_to_body(q, float(lever), jac, np.asarray(f3, float), np.asarray(k3, float),
                np.zeros((3, 3)) if d3 is None else np.asarray(d3, float), f, k, d)
    return f, k, d

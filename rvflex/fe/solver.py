"""Sparse solves on a meshed part: the Cholesky factor of K with nodes held (NGSolve), applied to
Exudyn-ordered arrays (x0, y0, z0, x1, ...), and the Galerkin projection on a basis."""

from __future__ import annotations

import numpy as np

__all__ = ["Solver", "free_mask", "galerkin"]


def _ex2ng(v: np.ndarray, nn: int) -> np.ndarray:
    return v.reshape(nn, 3).T.reshape(-1)


def _ng2ex(v: np.ndarray, nn: int) -> np.ndarray:
    return v.reshape(3, nn).T.reshape(-1)


class Solver:
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


def free_mask(held: np.ndarray, nn: int) -> np.ndarray:
    m = np.ones(3 * nn)
    for c in range(3):
        m[3 * held + c] = 0.0
    return m


def galerkin(K, Psi: np.ndarray, F: np.ndarray) -> np.ndarray:
    Kr = Psi.T @ (K @ Psi)
    return Psi @ np.linalg.solve(Kr, Psi.T @ F)

"""Planar force elements on the section of a tilting rigid body (rvflex.contact.tilt_map): the section's pose is
the rotated body point, and the mapped force's Jacobian is exact (curvature term included) and symmetric."""

from __future__ import annotations

import numpy as np
from exudyn.rigidBodyUtilities import RotXYZ2RotationMatrix

from rvflex.contact.tilt_map import section_force, section_pose


def _central_jacobian(force, q: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """−∂f/∂q (Exudyn's left-hand-side convention) by central differences."""
    out = np.empty((len(q), len(q)))
    for j, h in enumerate(steps):
        e = np.zeros(len(q))
        e[j] = h
        out[:, j] = -(np.array(force(q + e)) - np.array(force(q - e))) / (2 * h)
    return out


def test_the_section_pose_is_the_rotated_body_point():
    """s(q) is the in-plane position of the body point (0, 0, ℓ) under Exudyn's Rxyz rotation, exactly, and the
    node's own (x, y, ψz) when untilted: the mapping adds nothing to a planar state."""
    rng = np.random.default_rng(3)
    s, jac = np.empty(3), np.empty((3, 6))
    for _ in range(20):
        q = np.concatenate([rng.normal(0, 1e-3, 3), rng.normal(0, 0.05, 2), rng.uniform(-30, 30, 1)])
        lever = rng.uniform(-0.03, 0.03)
        section_pose(q, lever, s, jac)
        p = q[:3] + RotXYZ2RotationMatrix(q[3:]) @ np.array([0.0, 0.0, lever])
        np.testing.assert_allclose(s, [p[0], p[1], q[5]], rtol=0, atol=1e-15)
        q[3:5] = 0.0
        section_pose(q, lever, s, jac)
        assert np.array_equal(s, q[[0, 1, 5]])


def test_the_tilt_map_gives_the_exact_jacobian_of_the_mapped_force():
    """A section force from a quadratic potential on s (f₃ = −A(s − s₀), K₃ = A) mapped at large tilts (0.2 rad)
    and a 30 mm lever, where the curvature term −Σ f₃ᵢ ∂²sᵢ/∂q² is large: the mapped K equals central differences
    of the mapped force to 1e-8 of its largest entry and is symmetric (the Hessian of the potential in q), and
    leaving the curvature term out would fail the comparison by orders of magnitude."""
    rng = np.random.default_rng(7)
    a = rng.normal(size=(3, 3))
    a = a @ a.T + np.diag([1e8, 1e8, 1e4])  # N/m, N/m, N·m/rad: a contact-like stiffness
    s0 = np.array([2e-3, -1e-3, 0.01])
    lever = 0.03

    def mapped(q):
        s, jac = np.empty(3), np.empty((3, 6))
        section_pose(q, lever, s, jac)
        f3 = -a @ (s - s0)
        return section_force(q, lever, f3, a)

    for _ in range(5):
        q = np.concatenate([rng.normal(0, 1e-3, 3), rng.uniform(-0.2, 0.2, 2), rng.uniform(-3, 3, 1)])
        f, k, d = mapped(q)
        assert not d.any()
        fd = _central_jacobian(lambda x: mapped(x)[0], q, np.full(6, 1e-6))
        scale = np.abs(k).max()
        assert np.abs(k - fd).max() <= 1e-8 * scale
        assert np.abs(k - k.T).max() <= 1e-12 * scale
        s, jac = np.empty(3), np.empty((3, 6))
        section_pose(q, lever, s, jac)
        without = jac.T @ a @ jac  # the map without its curvature term
        assert np.abs(without - fd).max() > 1e-5 * scale

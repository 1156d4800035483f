"""Modal columns of the cycloid–pin contact (flexible discs): the flank displacement Φ(t)·η
closes the gap along the flank normal, and the Jacobian carries its columns."""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np


def _modal(contact, phi):
    return dc.replace(contact, phi=np.ascontiguousarray(phi), _t_cache=np.full(len(contact.radii_m), np.nan))


def test_translation_modes_move_the_flank_like_a_rigid_translation(loaded):
    """Two 'modes' that translate the whole flank by a unit in x and y of the profile frame:
    η = (δx, δy) must give the gaps of the rigid disc moved by R(θ)(δx, δy); the contact
    linearises in u, so they agree to |δ|²/(2R) with R the radius of the pin-centre offset
    curve, down to ≈ 0.3 mm on the concave flank (3.3 mm flank, 3 mm pin): 1.2e-11 m at
    |δ| = 0.086 µm."""
    contact, q = loaded
    ng = 256
    phi = np.zeros((ng, 2, 2))
    phi[:, 0, 0] = 1.0
    phi[:, 1, 1] = 1.0
    flex = _modal(contact, phi)
    delta = np.array([0.7e-7, -0.5e-7])
    th = q[2] + contact.offset_rad
    rot = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    moved = q.copy()
    moved[:2] += rot @ delta
    g_modal = flex.evaluate(q, eta=delta)[3][:, 0]
    g_rigid = contact.evaluate(moved)[3][:, 0]
    assert np.max(np.abs(g_modal - g_rigid)) < 3e-11
    # and the modal forces are the rigid forces resolved in the profile frame (to the turn
    # of the normals over the translation, |δ|/ρ ≈ 3e-5)
    f_modal = flex.evaluate(q, eta=delta)[0]
    f_rigid = contact.evaluate(moved)[0]
    assert np.allclose(f_modal[3:], rot.T @ f_rigid[:2], rtol=1e-4, atol=1e-4 * np.abs(f_rigid[:2]).max())


def test_jacobian_with_modal_columns_matches_finite_differences(loaded):
    """K = −∂Q/∂(q, η) against central differences for smooth synthetic flank fields, at the
    undeformed state and deformed by |u| ≈ 0.3 µm: every block to 1e-5 of K (measured
    ≤ 1e-7; left out are terms second order in u). The sliding of the flank sample point
    with the contact parameter is in K: without it the floating disc of an open bearing
    clearance (regularisers of ~500 N/m) saw an O(f/ρ) error and Newton crawled."""
    contact, q = loaded
    ng = 2048
    t = 2 * math.pi * np.arange(ng) / ng
    phi = np.zeros((ng, 2, 3))
    phi[:, 0, 0], phi[:, 1, 0] = np.cos(3 * t), np.sin(3 * t)
    phi[:, 0, 1], phi[:, 1, 1] = 0.5 * np.sin(2 * t), np.cos(5 * t)
    phi[:, 0, 2], phi[:, 1, 2] = np.cos(t) ** 2, 0.3
    flex = _modal(contact, phi)
    for eta in (np.zeros(3), np.array([2e-7, -1e-7, 0.5e-7])):
        _, k, _, out, _ = flex.evaluate(q, eta=eta)
        assert np.count_nonzero(out[:, 1]) >= 5
        x = np.concatenate([q, eta])
        fd = np.empty((6, 6))
        for j in range(6):
            h = np.zeros(6)
            h[j] = 1e-9
            fp = flex.evaluate((x + h)[:3], eta=(x + h)[3:])[0]
            fm = flex.evaluate((x - h)[:3], eta=(x - h)[3:])[0]
            fd[:, j] = -(fp - fm) / 2e-9
        scale = np.abs(fd).max()
        assert np.max(np.abs(k - fd)) <= 1e-5 * scale

"""Multi-point pin contact: a pin in a relieved root sharper than itself touches both rims.

Seed 003's pressure-angle scheme (RV-80E, 15 µm root relief beyond 75°) has a concave root
with a 2.2 mm radius of curvature against a 3 mm pin: the distance from a pin centre in the
root has a minimum on each rim (and one at the bottom, 15 µm deeper).
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np
import pytest

from rvflex import catalog
from rvflex.contact import _cycloid_kernel as K
from rvflex.contact.cycloid_pin import ContactLaw, concave_zones
from rvflex.contact.single_disc import build_single_disc, quasi_static_te
from rvflex.geometry.pins import nominal_disc_pose, pin_centres, pin_radii, to_disc_frame
from rvflex.geometry.profile import build_profile
from rvflex.scenarios.rv80e_modifications import scheme_spec
from rvflex.spec import ErrorSpec
from rvflex.units import ARCSEC_PER_RAD

PRESS_M = 6e-6  # disc centre moved towards pin 0: both rims of its root penetrate (rims open 3.4 µm at θ = 0)


@pytest.fixture(scope="module")
def relieved():
    """The RV-80E stage with seed 003's pressure-angle profile (tip and root relief)."""
    return scheme_spec(catalog.load("rv80e"), "pressure-angle").cycloid


@pytest.fixture(scope="module")
def bench(relieved):
    return build_single_disc(relieved, ContactLaw.linear(2e8))


def _pressed(stage, theta):
    """Disc pose at eccentric angle θ with the centre moved PRESS_M towards pin 0."""
    centre, angle = nominal_disc_pose(stage, theta)
    u = pin_centres(stage)[0]
    u = u / np.linalg.norm(u)
    return np.array([centre[0] + PRESS_M * u[0], centre[1] + PRESS_M * u[1], angle])


def test_zones_only_where_the_root_is_sharper_than_the_pin(relieved):
    """One zone per tooth root on the relieved profile; none on unrelieved profiles (their
    root radius, 3.10–3.12 mm, exceeds the 3 mm pin by more than the contact range)."""
    zc = relieved.disc_teeth
    zones = concave_zones(build_profile(relieved), relieved.pin_radius_m)
    assert zones.shape == (zc, K.N_ZONE)
    zones[:] = np.nan  # each caller gets its own copy of the zones kept per curve
    zones = concave_zones(build_profile(relieved), relieved.pin_radius_m)
    assert zones.shape == (zc, K.N_ZONE) and np.isfinite(zones).all()
    root_phase = np.angle(np.exp(1j * zc * 0.5 * (zones[:, 0] + zones[:, 1])))
    assert np.abs(root_phase).max() < 1e-9  # centred on the roots
    assert np.all(zc * (zones[:, 1] - zones[:, 0]) < math.radians(10.0))
    rv80e = catalog.load("rv80e")
    for scheme in ("none", "moved+equidistant", "pressure-angle (tip only)"):
        stage = scheme_spec(rv80e, scheme).cycloid
        assert concave_zones(build_profile(stage), stage.pin_radius_m).shape == (0, K.N_ZONE)
    rv40e = catalog.load("rv40e").cycloid
    assert concave_zones(build_profile(rv40e), rv40e.pin_radius_m).shape == (0, K.N_ZONE)


def _brute_force_minima(profile, c, t_mid, half_window, r_pin, coarse=20001, fine=4001):
    """Gaps (m) of every local minimum of |Q(t) − c| − r within ``half_window`` of t_mid
    below the contact range, by exhaustive sampling only: a coarse grid locates the
    minima, a fine grid ±2 coarse steps around each gives its value (sample spacing
    ~1e-9 m of arc, so the sampled minimum exceeds the true one by < 1e-15 m)."""
    t = t_mid + np.linspace(-half_window, half_window, coarse)
    q, _, _ = profile.evaluate(t)
    g = np.abs(q - c) - r_pin
    idx = np.flatnonzero((g[1:-1] < g[:-2]) & (g[1:-1] <= g[2:])) + 1
    h = t[1] - t[0]
    out = []
    for i in idx:
        tf = t[i] + np.linspace(-2 * h, 2 * h, fine)
        qf, _, _ = profile.evaluate(tf)
        gf = np.abs(qf - c) - r_pin
        if gf.min() < K.CONTACT_RANGE_M:
            out.append(float(gf.min()))
    return sorted(out)


@pytest.mark.parametrize("theta", [-0.06, -0.02, 0.0, 0.013, 0.05])
def test_every_minimum_near_the_root_is_found_exactly(relieved, bench, theta):
    """All 40 pins at a pressed pose: the contact's points are the local minima of the
    distance within half a tooth pitch found by brute force, each gap to 1e-12 m; pin 0 (in
    or beside the root) has 2 or 3 (both rims; the bottom, 9 µm open, around θ = 0)."""
    contact = bench.contact
    q = _pressed(relieved, theta)
    *_, pout, count, _ = contact.evaluate_points(q)
    assert count[0] >= 2
    x = to_disc_frame(pin_centres(relieved), q[:2], q[2] + contact.offset_rad)
    r = pin_radii(relieved)
    half = math.pi / relieved.disc_teeth
    for i in range(relieved.pin_count):
        ref = _brute_force_minima(contact.profile, complex(*x[i]), pout[i, 0, K.O_T], half, r[i])
        ours = sorted(g for g in pout[i, :count[i], K.O_GAP] if g < K.CONTACT_RANGE_M)  # the closest point always counts
        assert len(ours) == len(ref), (i, ours, ref)
        assert np.all(np.abs(np.subtract(ours, ref)) <= 1e-12)


def _roll(contact, stage, thetas):
    f, pin0 = [], []
    for th in thetas:
        force, _, _, _, pout, _, _ = contact.evaluate_points(_pressed(stage, th))
        f.append(force)
        pin0.append(np.nansum(pout[0, :, K.O_FORCE]))
    return np.array(f), np.array(pin0)


def test_force_is_continuous_as_the_pin_rolls_through_the_root(relieved, bench):
    """Pin 0 rolls through its root (eccentric angle −0.08…0.08 rad, both rims pressed
    around θ = 0): the generalised force changes by an amount proportional to the step —
    halving the step halves the largest change (a jump would stay). Pin 0 carries 0.8–1.2 kN
    throughout; the one-point contact dropped it to 0 where the closest point changed rims."""
    contact = bench.contact
    n = 801
    f1, p1 = _roll(contact, relieved, np.linspace(-0.08, 0.08, n))
    f2, p2 = _roll(contact, relieved, np.linspace(-0.08, 0.08, 2 * n - 1))
    j1 = np.abs(np.diff(f1, axis=0)).max(axis=0)
    j2 = np.abs(np.diff(f2, axis=0)).max(axis=0)
    assert np.all(j2 <= 0.6 * j1)
    assert p1.min() > 500.0
    assert np.abs(np.diff(p2)).max() <= 0.6 * np.abs(np.diff(p1)).max()


@pytest.mark.parametrize("law", [
    ContactLaw.linear(2e8, damping_Ns_m=300.0),
    ContactLaw.line(0.010, catalog.load("rv80e").materials.gears_cranks_discs, catalog.load("rv80e").materials.pins,
                    damping_Ns_m=300.0, body_radius_m=0.07),
], ids=["linear", "line"])
def test_jacobian_of_two_point_contact_matches_finite_differences(relieved, law):
    """K and D against central differences at a pose where pin 0 presses both rims (and
    other pins their flanks): to 1e-5 of K, as for one point per pin; K symmetric for the
    linear law (the forces derive from a potential, point by point)."""
    contact = build_single_disc(relieved, law).contact
    q = _pressed(relieved, 0.004)
    qd = np.array([1e-3, -2e-3, 0.02])
    f, k, d, _, pout, count, _ = contact.evaluate_points(q, qd)
    assert count[0] >= 2 and np.count_nonzero(pout[0, :, K.O_FORCE] > 0) == 2
    fd_k, fd_d = np.empty((3, 3)), np.empty((3, 3))
    for j in range(3):
        h = np.zeros(3)
        h[j] = 1e-9
        fd_k[:, j] = -(contact.evaluate(q + h, qd)[0] - contact.evaluate(q - h, qd)[0]) / 2e-9
        hv = np.zeros(3)
        hv[j] = 1e-4
        fd_d[:, j] = -(contact.evaluate(q, qd + hv)[0] - contact.evaluate(q, qd - hv)[0]) / 2e-4
    scale = np.abs(fd_k).max()
    assert np.max(np.abs(k - fd_k)) <= 1e-5 * scale
    assert np.max(np.abs(d - fd_d)) <= 1e-5 * np.abs(fd_d).max()
    if law.kind == "linear":
        assert np.max(np.abs(k - k.T)) <= 1e-9 * scale


def test_modal_jacobian_of_two_point_contact(relieved, bench):
    """A flexible disc gets the same points: with smooth synthetic flank fields, K over
    (x, y, θ, η) against central differences at the two-rim pose, to 1e-5 of K."""
    ng = 39 * 256
    t = 2 * math.pi * np.arange(ng) / ng
    phi = np.zeros((ng, 2, 2))
    phi[:, 0, 0], phi[:, 1, 0] = np.cos(3 * t), np.sin(3 * t)
    phi[:, 0, 1], phi[:, 1, 1] = 0.5 * np.sin(2 * t), 0.3
    flex = dc.replace(bench.contact, phi=phi, _t_cache=np.full(relieved.pin_count, np.nan))
    q = _pressed(relieved, 0.004)
    eta = np.array([1e-7, -0.5e-7])
    _, k, _, _, pout, count, _ = flex.evaluate_points(q, eta=eta)
    assert np.count_nonzero(pout[0, :, K.O_FORCE] > 0) == 2
    x = np.concatenate([q, eta])
    fd = np.empty((5, 5))
    for j in range(5):
        h = np.zeros(5)
        h[j] = 1e-9
        fd[:, j] = -(flex.evaluate((x + h)[:3], eta=(x + h)[3:])[0] - flex.evaluate((x - h)[:3], eta=(x - h)[3:])[0]) / 2e-9
    assert np.max(np.abs(k - fd)) <= 1e-5 * np.abs(fd).max()


def test_quasi_static_te_converges_through_the_concave_root(relieved):
    """Pin 0 set 4.2 µm inwards (its root rims open 3.4 µm, so it presses both, preloaded),
    the disc rolled quasi-statically by Exudyn's static solver through that root
    (eccentric angle −0.2…0.2 rad): every step converges (with the one-point contact
    Exudyn's static solver stopped on this roll), pin 0 loads both rims at θ = 0, and TE is continuous — halving the
    step halves its largest change — and antisymmetric about the root (the stage is)."""
    err = ErrorSpec(pin_radial_m=(-4.2e-6,) + (0.0,) * (relieved.pin_count - 1))
    law = ContactLaw.linear(2e8)
    te = {}
    for n in (101, 201):
        b = build_single_disc(relieved, law, errors=err)
        te[n] = quasi_static_te(b, np.linspace(-0.2, 0.2, n))
    jump = {n: np.abs(np.diff(v)).max() for n, v in te.items()}
    assert jump[201] <= 0.6 * jump[101]
    assert np.abs(te[201] + te[201][::-1]).max() * ARCSEC_PER_RAD < 1e-6
    assert np.ptp(te[201]) * ARCSEC_PER_RAD > 0.5  # the preloaded pin turns the disc: a real signal
    b = build_single_disc(relieved, law, errors=err)
    quasi_static_te(b, np.linspace(-0.2, 0.0, 101))
    st = b.contact.pin_state(b.mbs)
    assert np.count_nonzero(st.points_force_N[0] > 0) == 2

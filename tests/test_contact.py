"""Cycloid–pin contact element: exact kinematics, load sharing, Jacobians, bad input."""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np
import pytest

from rvflex import catalog
from rvflex.contact.cycloid_pin import ContactError, ContactLaw, add_cycloid_pin_contact
from rvflex.contact.single_disc import build_single_disc, quasi_static_te
from rvflex.geometry import formulas as F
from rvflex.geometry.clearance import initial_clearance_numeric
from rvflex.geometry.pins import nominal_disc_pose

ARCSEC = F.ARCSEC_PER_RAD


@pytest.fixture(scope="module")
def rv40e():
    return catalog.load("rv40e")


def _perfect(stage):
    return dc.replace(stage, modification=dc.replace(stage.modification, moved_m=0.0, equidistant_m=0.0))


def test_perfect_geometry_no_load_follows_the_kinematic_ratio(rv40e):
    """Theoretical profile, no load: TE over one disc revolution (39 eccentric turns, 16
    static steps each) with every step's predictor 1e-5 rad (2″) off, so Newton must find
    the angle. DESIGN.md: TE peak-to-peak ≤ 0.05″ and mean ratio exact to 1e-9."""
    stage = _perfect(rv40e.cycloid)
    bench = build_single_disc(stage, ContactLaw.linear(1e8))
    theta = np.linspace(0.0, 2 * np.pi * stage.disc_teeth, 16 * stage.disc_teeth + 1)
    te = quasi_static_te(bench, theta, predictor_offset_rad=1e-5)
    assert np.ptp(te) * ARCSEC <= 0.05
    # output turned −θ/z_c + TE: over one disc revolution the ratio error is ΔTE/Δθ_out
    assert abs((te[-1] - te[0]) / (2 * np.pi)) < 1e-9


def _analytic_sharing(stage, torque, k):
    """Quasi-static load sharing of a rigid disc turned by β about its fixed centre with a
    linear contact law: F_i = k·max(0, β·l_i − Δ_i), Σ F_i·l_i = T (seeds 000/002)."""
    cl = initial_clearance_numeric(stage)
    side = cl.closing_pos  # a resisting torque turns the disc positive (it lags): that flank loads
    phi = np.where(cl.phi > np.pi, 2 * np.pi - cl.phi, cl.phi)
    lever = F.lever_arm(stage, phi)
    gap = cl.nominal_gap_m  # exact clearances at the nominal pose (Δ_i + β0·l_i)

    def moment(beta):
        return np.sum(k * np.clip(beta * lever - gap, 0, None) * lever * side)

    lo, hi = 0.0, 1e-2
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if moment(mid) < torque else (lo, mid)
    beta = 0.5 * (lo + hi)
    return k * np.clip(beta * lever - gap, 0, None) * side, beta


@pytest.mark.parametrize("torque", [50.0, 206.0])
def test_load_sharing_matches_the_analytic_law(rv40e, torque):
    """RV-40E disc (Δr_p 12 µm, Δr_rp 20 µm), linear law 2e8 N/m, centre fixed at eccentric
    angle 0, half the rated 412 N·m on one disc and a quarter of that: the pins in contact
    and their forces follow the quasi-static law within 10 % of the peak force."""
    k = 2e8
    bench = build_single_disc(rv40e.cycloid, ContactLaw.linear(k), resisting_torque_Nm=torque)
    te = quasi_static_te(bench, np.array([0.0]))
    state = bench.contact.pin_state(bench.mbs)
    expected, beta = _analytic_sharing(rv40e.cycloid, torque, k)
    assert np.array_equal(state.in_contact, expected > 0)
    assert np.max(np.abs(state.force_N - expected)) <= 0.1 * expected.max()
    assert -te[0] == pytest.approx(beta, rel=0.05)  # the disc lags by the turn that closes the gaps


@pytest.mark.parametrize("law", [
    ContactLaw.linear(2e8, damping_Ns_m=300.0),
    ContactLaw.hertz(5e9, 1.5, damping_Ns_m=300.0),
    ContactLaw.line(0.010, catalog.load("rv40e").materials.gears_cranks_discs, catalog.load("rv40e").materials.pins,
                    damping_Ns_m=300.0, body_radius_m=0.066),
    ContactLaw.strip(1e10),  # its forces are small: the damper's omitted q̇-term (below) would dominate
    ContactLaw.linear(2e8, damping_Ns_m=300.0, friction_coefficient=0.08, friction_velocity_m_s=1e-3),
    ContactLaw.hertz(2e8, 0.95, damping_Ns_m=300.0, seat_compliance_m_N=2e-9),
], ids=["linear", "hertz", "line", "strip", "friction", "softening_seat"])
def test_jacobians_match_finite_differences(rv40e, law):
    """K = −∂Q/∂q and D = −∂Q/∂q̇ against central differences at a loaded state (disc
    turned 3″ into the pins, moving). Position steps 1e-9 m / 1e-9 rad: the laws are
    smooth there, so the difference error is ~1e-7 of the entries. Without friction K is
    symmetric (forces derive from a potential)."""
    stage = rv40e.cycloid
    bench = build_single_disc(stage, law)
    c = bench.contact
    centre, angle = nominal_disc_pose(stage, 0.3)
    closing = initial_clearance_numeric(stage, eccentric_angle_rad=0.3).turn_neg_rad
    q = np.array([centre[0], centre[1], angle + closing - 1.5e-5])
    qd = np.array([1e-3, -2e-3, 0.02])
    f, k, d, out, _ = c.evaluate(q, qd)
    assert np.count_nonzero(out[:, 1]) >= 5
    fd_k, fd_d = np.empty((3, 3)), np.empty((3, 3))
    for j in range(3):
        h = np.zeros(3)
        h[j] = 1e-9
        fd_k[:, j] = -(c.evaluate(q + h, qd)[0] - c.evaluate(q - h, qd)[0]) / 2e-9
        hv = np.zeros(3)
        # without friction the force is affine in q̇: a large step keeps solver noise (1e-9 N)
        # out; friction's tanh(v_t/v_reg) needs a step well below v_reg
        hv[j] = 1e-4 if law.friction_coefficient == 0 else 1e-7
        fd_d[:, j] = -(c.evaluate(q, qd + hv)[0] - c.evaluate(q, qd - hv)[0]) / (2 * hv[j])
    scale_k = np.abs(fd_k).max()
    scale_d = np.abs(fd_d).max()
    # the line and strip laws' dependence on the flank curvature at the sliding contact point
    # is in K (κ'(t) by a central difference, ~1e-10); left out by design: the damper's
    # geometric term c·(∂²g/∂q²·q̇), zero in statics and ~1e-5 of K here, and friction's
    # turning of the tangent (< 2e-2 of K); both only slow Newton, never change its answer
    tol_k = 1e-5 if law.friction_coefficient == 0 else 2e-2
    assert np.max(np.abs(k - fd_k)) <= tol_k * scale_k
    if law.damping_Ns_m == 0.0 and law.friction_coefficient == 0.0:
        assert not d.any() and scale_d < 1e-9 * scale_k  # no velocity dependence at all
    else:
        assert np.max(np.abs(d - fd_d)) <= 1e-5 * scale_d
    if law.friction_coefficient == 0.0 and law.kind in ("linear", "power"):  # a seat keeps the potential
        assert np.max(np.abs(k - k.T)) <= 1e-9 * scale_k


def test_line_law_inverts_the_seed002_deflection(rv40e):
    """The line law's force at approach δ(F) of the hand-checked Hertz formula is F (no
    bound on the flank radius), and its δ- and κ-derivatives match central differences."""
    m = rv40e.materials
    law = ContactLaw.line(0.010, m.gears_cranks_discs, m.pins, body_radius_m=math.inf).vector()
    from rvflex.contact._cycloid_kernel import _normal_law

    for f in (10.0, 1000.0, 8000.0):
        delta = F.hertz_line_deflection(f, 0.010, 0.020, 0.003, m.gears_cranks_discs.youngs_modulus_Pa,
                                        m.gears_cranks_discs.poisson_ratio, m.pins.youngs_modulus_Pa,
                                        m.pins.poisson_ratio)
        kap = 1 / 0.020
        force, stiff, dfk = _normal_law(delta, kap, 0.003, law)
        assert force == pytest.approx(f, rel=1e-10)
        h = 1e-12
        assert stiff == pytest.approx((_normal_law(delta + h, kap, 0.003, law)[0]
                                       - _normal_law(delta - h, kap, 0.003, law)[0]) / (2 * h), rel=1e-5)
        hk = 1e-3
        assert dfk == pytest.approx((_normal_law(delta, kap + hk, 0.003, law)[0]
                                     - _normal_law(delta, kap - hk, 0.003, law)[0]) / (2 * hk), rel=1e-5)


@pytest.mark.parametrize("exponent", [0.9, 1.0, 1.5])
def test_a_seat_compliance_in_series_shares_the_approach_with_the_contact(exponent):
    """With a seat compliance s in series, a penetration x is the contact's approach x_c plus the seat's s·F, and
    F = k·x_c^e: checked against the closed form F = x/(1/k + s) of the linear law and, for a softening (0.9),
    linear and Hertz (1.5) power law, against x = (F/k)^(1/e) + s·F at approaches from 0.01 to 20 µm; the
    stiffness matches central differences and never exceeds 1/s (a softening law alone is infinitely stiff at zero
    approach)."""
    from rvflex.contact._cycloid_kernel import _normal_law

    s = 2e-9  # m/N: a seat as compliant as a 5e8 N/m pin contact
    k = {0.9: 2e7, 1.0: 5e8, 1.5: 5e9}[exponent] * (1e-6 ** (1.0 - exponent))  # ~500 N at 1 µm of contact approach
    law = ContactLaw.hertz(k, exponent, seat_compliance_m_N=s).vector()
    for x in (1e-8, 1e-7, 1e-6, 5e-6, 2e-5):
        force, stiff, dfk = _normal_law(x, 50.0, 0.003, law)
        assert force > 0 and dfk == 0.0
        assert (force / k) ** (1.0 / exponent) + s * force == pytest.approx(x, rel=1e-12, abs=1e-20)
        if exponent == 1.0:
            assert force == pytest.approx(x / (1.0 / k + s), rel=1e-12)
        h = 1e-3 * x
        fd = (_normal_law(x + h, 50.0, 0.003, law)[0] - _normal_law(x - h, 50.0, 0.003, law)[0]) / (2 * h)
        assert stiff == pytest.approx(fd, rel=1e-5) and stiff < 1.0 / s
    alone = ContactLaw.hertz(k, exponent).vector() if exponent >= 1.0 else None
    if alone is not None:  # the seat only softens: at every approach the force is below the contact's alone
        assert _normal_law(1e-6, 50.0, 0.003, law)[0] < _normal_law(1e-6, 50.0, 0.003, alone)[0]


def test_a_seat_compliance_softens_the_line_law_by_its_own_approach(rv40e):
    """Seed 002's line contact with a seat in series: the force at approach δ(F) + s·F is F, and its δ- and
    κ-derivatives match central differences; a law cut into slices keeps the whole contact's law, each slice's
    seat carrying its share of the load."""
    m = rv40e.materials
    s = 1e-9
    law = ContactLaw.line(0.010, m.gears_cranks_discs, m.pins, body_radius_m=math.inf, seat_compliance_m_N=s)
    v = law.vector()
    from rvflex.contact._cycloid_kernel import _normal_law

    kap = 1 / 0.020
    for f in (10.0, 1000.0, 8000.0):
        delta = F.hertz_line_deflection(f, 0.010, 0.020, 0.003, m.gears_cranks_discs.youngs_modulus_Pa,
                                        m.gears_cranks_discs.poisson_ratio, m.pins.youngs_modulus_Pa,
                                        m.pins.poisson_ratio)
        force, stiff, dfk = _normal_law(delta + s * f, kap, 0.003, v)
        assert force == pytest.approx(f, rel=1e-9)
        x, h, hk = delta + s * f, 1e-12, 1e-3
        assert stiff == pytest.approx((_normal_law(x + h, kap, 0.003, v)[0] - _normal_law(x - h, kap, 0.003, v)[0])
                                      / (2 * h), rel=1e-5)
        assert dfk == pytest.approx((_normal_law(x, kap + hk, 0.003, v)[0] - _normal_law(x, kap - hk, 0.003, v)[0])
                                    / (2 * hk), rel=1e-5)
        slices = law.sliced(4).vector()
        assert 4 * _normal_law(x, kap, 0.003, slices)[0] == pytest.approx(f, rel=1e-9)


def test_a_softening_contact_law_needs_a_seat_and_a_seat_compliance_must_be_a_compliance():
    """A power law below exponent 1 alone is refused (its stiffness is infinite at zero approach), with a seat in
    series it is accepted from 0.9; a negative or infinite seat compliance is one message naming it."""
    with pytest.raises(ValueError, match=r"exponent = 0\.95: must lie in \[1, 3\] \(from 0\.9 with a seat"):
        ContactLaw.hertz(2e8, 0.95)
    assert ContactLaw.hertz(2e8, 0.9, seat_compliance_m_N=1e-9).exponent == 0.9
    with pytest.raises(ValueError, match=r"exponent = 0\.85: must lie in \[0\.9, 3\]"):
        ContactLaw.hertz(2e8, 0.85, seat_compliance_m_N=1e-9)
    for bad in (-1e-9, math.inf, math.nan):
        with pytest.raises(ValueError, match="seat_compliance_m_N = .*must be a finite compliance ≥ 0"):
            ContactLaw.linear(2e8, seat_compliance_m_N=bad)


def test_line_law_is_smooth_through_the_flank_inflection(rv40e):
    """With the flank radius bounded by the body (R_b = pin-circle radius) the force at a
    fixed approach stays smooth as the curvature passes through zero, where the unbounded
    ln(4ρ/c) would send it to zero with an infinite slope (Newton then cycles); at a typical
    flank radius of 20 mm the bound moves the force by < 0.5 %."""
    from rvflex.contact._cycloid_kernel import _normal_law

    m = rv40e.materials
    bounded = ContactLaw.line(0.010, m.gears_cranks_discs, m.pins, body_radius_m=0.066).vector()
    free = ContactLaw.line(0.010, m.gears_cranks_discs, m.pins, body_radius_m=math.inf).vector()
    delta = 2e-6
    kaps = np.linspace(-5.0, 5.0, 2001)  # 1/m: flank radius beyond 200 mm on both sides of the inflection
    f = np.array([_normal_law(delta, k, 0.003, bounded)[0] for k in kaps])
    slope = np.abs(np.diff(f) / np.diff(kaps))
    assert f.min() > 0.9 * f.max()
    assert slope.max() < 2.0 * np.abs([_normal_law(delta, k, 0.003, bounded)[2] for k in kaps]).max() + 1e-9
    f_free_near = _normal_law(delta, 1e-9, 0.003, free)[0]
    assert f_free_near < 0.8 * f.max()  # the unbounded law's dip that the bound removes
    f20 = _normal_law(delta, 50.0, 0.003, bounded)[0]
    assert f20 == pytest.approx(_normal_law(delta, 50.0, 0.003, free)[0], rel=5e-3)


def test_bad_input_is_refused(rv40e):
    import exudyn as exu
    from exudyn.itemInterface import NodePoint, NodeRigidBody2D

    stage = rv40e.cycloid
    mbs = exu.SystemContainer().AddSystem()
    point = mbs.AddNode(NodePoint(referenceCoordinates=[0, 0, 0]))
    with pytest.raises(ValueError, match=r"disc_node = 0: must be a NodeRigidBody2D"):
        add_cycloid_pin_contact(mbs, point, stage, ContactLaw.linear(1e8))
    centre, angle = nominal_disc_pose(stage, 0.0)
    turned = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[centre[0], centre[1], angle - 5e-4]))
    with pytest.raises(ValueError, match=r"initial configuration: pin \d+ interferes with disc 0 by \d+\.\d+ µm"):
        add_cycloid_pin_contact(mbs, turned, stage, ContactLaw.linear(1e8))
    from rvflex.spec import ErrorSpec

    with pytest.raises(ValueError, match=r"pin_radial_m = .*needs 40 values \(one per pin of the stage\) or none"):
        add_cycloid_pin_contact(mbs, turned, stage, ContactLaw.linear(1e8), errors=ErrorSpec(pin_radial_m=(1e-6,) * 39))
    with pytest.raises(ValueError, match=r"stiffness = -1.0: must be positive"):
        ContactLaw.linear(-1.0)
    with pytest.raises(ValueError, match=r"damping_Ns_m = -5.0: must not be negative"):
        ContactLaw.linear(1e8, damping_Ns_m=-5.0)


def test_deep_penetration_stops_the_run(rv40e):
    bench = build_single_disc(rv40e.cycloid, ContactLaw.linear(1e8))
    centre, angle = nominal_disc_pose(rv40e.cycloid, 0.0)
    bench.contact._force_uf(bench.mbs, 0.25, 0, np.array([0.0, 0.0, -1.5e-3]), np.zeros(3))  # ~100 µm deep
    with pytest.raises(ContactError, match=r"penetration \d+\.\d µm exceeds 50 µm at t = 0.25 s"):
        bench.contact.check_penetration(0.25)

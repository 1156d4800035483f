"""Exact cycloid geometry: profiles of every modification kind, closest-point gaps, and the
papers' closed forms (Δ_i, ε, Hertz) against the exact geometry or a hand calculation."""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np
import pytest

from rvflex import catalog
from rvflex.geometry import build_profile
from rvflex.geometry import formulas as F
from rvflex.geometry._kernels import P_ROOT_U, P_TIP_U, _radius
from rvflex.geometry.clearance import initial_clearance_numeric
from rvflex.geometry.pins import nominal_disc_pose, pin_centres, pin_radii, to_disc_frame
from rvflex.spec import ErrorSpec

UM = 1e-6


@pytest.fixture(scope="module")
def rv40e():
    return catalog.load("rv40e")


@pytest.fixture(scope="module")
def rv80e():
    return catalog.load("rv80e")


def _with_mod(stage, **kw):
    return dc.replace(stage, modification=dc.replace(stage.modification, **kw))


KINDS = {
    "theoretical": dict(moved_m=0.0, equidistant_m=0.0),
    "equidistant": dict(moved_m=0.0, equidistant_m=20e-6),
    "moved": dict(moved_m=-12e-6, equidistant_m=0.0),
    "moved+equidistant": dict(moved_m=12e-6, equidistant_m=20e-6),
    "pressure_angle": dict(tip_amount_m=45e-6, root_amount_m=15e-6),  # seed 003 Table 2
    "compensated": dict(compensation_m=5e-6),
    "all four": dict(moved_m=12e-6, equidistant_m=20e-6, tip_amount_m=45e-6, root_amount_m=15e-6,
                     compensation_m=5e-6),
}


def _crossings(xy: np.ndarray) -> int:
    """Properly crossing segment pairs of a closed polyline (independent of the library's check)."""
    a, b = xy, np.roll(xy, -1, axis=0)
    n, count = len(a), 0

    def cross(u, v):
        return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]

    for i in range(n):
        j = np.arange(i + 2, n if i else n - 1)
        c, d = a[j], b[j]
        o1, o2 = cross(b[i] - a[i], c - a[i]), cross(b[i] - a[i], d - a[i])
        o3, o4 = cross(d - c, a[i] - c), cross(d - c, b[i] - c)
        count += int(np.count_nonzero((o1 * o2 < 0) & (o3 * o4 < 0)))
    return count


@pytest.mark.parametrize("kind", list(KINDS))
@pytest.mark.parametrize("name", ["rv40e", "rv80e"])
def test_profile_closed_ccw_simple(name, kind):
    stage = _with_mod(catalog.load(name).cycloid, **KINDS[kind])
    prof = build_profile(stage, modified=kind != "theoretical")
    q0, d0, _ = prof.evaluate(np.array([0.0]))
    q1, d1, _ = prof.evaluate(np.array([2 * np.pi]))
    assert abs(q1[0] - q0[0]) < 1e-15 and abs(d1[0] - d0[0]) < 1e-12 * abs(d0[0])  # closed, C¹ at the seam
    xy = prof.points(48)[:-1]
    area = 0.5 * np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1])
    r_root = stage.pin_circle_radius_m - stage.eccentricity_m - stage.pin_radius_m
    assert area > math.pi * r_root**2  # counter-clockwise, encloses at least the root circle
    assert _crossings(xy) == 0


@pytest.mark.parametrize("kind", list(KINDS))
def test_profile_derivatives_match_finite_differences(rv40e, kind):
    zc = rv40e.cycloid.disc_teeth
    errors = ErrorSpec(disc_profile_error_m=(tuple(0.5 * UM * np.sin(np.arange(zc))),) * 2,
                       disc_pitch_error_m=(tuple(2 * UM * np.cos(0.3 * np.arange(zc))),) * 2)
    prof = build_profile(_with_mod(rv40e.cycloid, **KINDS[kind]), errors)
    t = np.linspace(0.013, 2 * np.pi - 0.01, 157)
    h = 1e-7  # the compensation's |sin| smoothing (0.01 rad of τ) makes Q'''' large near the root
    qp, dp, _ = prof.evaluate(t + h)
    qm, dm, _ = prof.evaluate(t - h)
    q, d, dd = prof.evaluate(t)
    # central differences: truncation h²/6·|Q''''| and rounding eps·|Q|/h both ≪ 1e-6 relative
    assert np.max(np.abs((qp - qm) / (2 * h) - d)) < 1e-7 * np.max(np.abs(d))
    assert np.max(np.abs((dp - dm) / (2 * h) - dd)) < 1e-6 * np.max(np.abs(dd))


@pytest.mark.parametrize("theta", [0.0, 0.1, 1.234, 4.0])
def test_theoretical_profile_is_conjugate_to_every_pin(rv40e, theta):
    """Unmodified, error-free: every pin touches the disc at every crank angle (gap 0)."""
    c = rv40e.cycloid
    prof = build_profile(c, modified=False)
    for disc in range(c.disc_count):
        x = to_disc_frame(pin_centres(c), *nominal_disc_pose(c, theta, disc))
        assert np.max(np.abs(prof.gap(x, pin_radii(c)).gap_m)) < 1e-13


def test_equidistant_modification_opens_an_exact_uniform_gap(rv40e):
    c = _with_mod(rv40e.cycloid, **KINDS["equidistant"])
    x = to_disc_frame(pin_centres(c), *nominal_disc_pose(c, 0.7))
    g = build_profile(c).gap(x, pin_radii(c)).gap_m
    assert np.max(np.abs(g - 20 * UM)) < 1e-13


def test_moved_modification_matches_first_order_clearance(rv40e):
    """Δr_p alone: gap = −Δr_p(1 − K1 cosφ)/S to first order. The second-order rest grows
    like Δr_p²/(r_p·S³) toward the root, where S = √(1 + K1² − 2K1 cosφ) is small:
    65 nm at φ = 9°, below 10 nm once φ ≥ 30°."""
    c = _with_mod(rv40e.cycloid, **KINDS["moved"])
    cl = initial_clearance_numeric(c)
    diff = np.abs(cl.nominal_gap_m - F.nominal_clearance(c, cl.phi))
    assert np.max(diff) < 0.1 * UM
    away = (cl.phi >= math.radians(30)) & (cl.phi <= math.radians(330))
    assert np.max(diff[away]) < 0.01 * UM


@pytest.fixture(scope="module")
def errors40(rv40e):
    rng = np.random.default_rng(7)
    zb, zc = rv40e.cycloid.pin_count, rv40e.cycloid.disc_teeth
    return ErrorSpec(
        pin_radial_m=tuple(rng.uniform(-8, 8, zb) * UM), pin_tangential_m=tuple(rng.uniform(-5, 5, zb) * UM),
        pin_radius_error_m=-4 * UM, pin_radius_individual_m=tuple(rng.uniform(-1, 1, zb) * UM),
        pin_circle_radius_error_m=10 * UM, pin_ring_runout_m=5 * UM, pin_ring_runout_phase_rad=0.4,
        disc_profile_error_m=tuple(tuple(rng.uniform(-2, 2, zc) * UM) for _ in range(2)),
        disc_pitch_error_m=tuple(tuple(np.cumsum(rng.uniform(-1, 1, zc)) * UM) for _ in range(2)),
        disc_moved_error_m=(1 * UM, -0.5 * UM), disc_equidistant_error_m=(-2 * UM, 1 * UM),
    )


@pytest.mark.parametrize("with_errors", [False, True])
def test_closest_point_gap_matches_brute_force(rv40e, errors40, with_errors):
    """Newton gap vs an exhaustive search over 2²¹ profile samples (at most 0.35 µm of arc
    apart: the sampled minimum exceeds the true distance by (Δs/2)²/(2d) < 1e-10 m for
    centre distances d ≥ 2 mm), 2 discs × 40 pins, at their working positions and
    displaced by up to 10 µm and 1 mm."""
    c = rv40e.cycloid
    errors = errors40 if with_errors else None
    rng = np.random.default_rng(3)
    for disc in range(2):
        prof = build_profile(c, errors, disc)
        x = to_disc_frame(pin_centres(c, errors), *nominal_disc_pose(c, 0.3, disc))
        r = pin_radii(c, errors)
        for shake in (0.0, 1e-5, 1e-3):
            xs = x + rng.uniform(-shake, shake, x.shape)
            g = prof.gap(xs, r).gap_m
            assert np.max(np.abs(g - prof.brute_force_gap(xs, r, 1 << 21))) < 1e-10


def test_warm_start_gives_the_same_gap(rv40e):
    c = rv40e.cycloid
    prof = build_profile(c)
    x0 = to_disc_frame(pin_centres(c), *nominal_disc_pose(c, 0.3))
    x1 = to_disc_frame(pin_centres(c), *nominal_disc_pose(c, 0.31))
    cold = prof.gap(x1, pin_radii(c))
    warm = prof.gap(x1, pin_radii(c), prof.gap(x0, pin_radii(c)).t)
    assert np.max(np.abs(cold.gap_m - warm.gap_m)) < 1e-15
    assert np.max(np.abs(cold.t - warm.t)) < 1e-10


@pytest.mark.parametrize("unit", ["rv40e", "rv80e"])
@pytest.mark.parametrize("offset_m", [-10 * UM, 0.0, 10 * UM, 3e-3], ids=["inside", "on", "outside", "pin"])
def test_cold_solve_finds_every_point_near_the_profile(unit, offset_m):
    """Points Q(t) + d·n(t) at 256 phases per tooth: the cold solve returns gap d and
    parameter t exactly. Flank points (d ≈ 0) lie a generating radius ≈ 2e inside the
    pin-centre curve, where inverting |p(t)| = |c| put the start on the tooth root, half a
    pitch off; on the RV-80E (r = 2e − 22 µm) Newton then did not converge for 39 of these
    9984 points at d = 0, all near a tooth tip, and for 7 of its FE disc's flank nodes."""
    c = catalog.load(unit).cycloid
    prof = build_profile(c)
    t = np.linspace(0.0, 2 * np.pi, c.disc_teeth * 256, endpoint=False) + 1e-4
    q, q1, _ = prof.evaluate(t)
    pts = q - offset_m * 1j * q1 / np.abs(q1)  # outward normal −i·Q'/|Q'|
    g = prof.gap(np.column_stack([pts.real, pts.imag]), np.zeros(t.size))  # raises if any solve fails
    assert np.max(np.abs(g.gap_m - offset_m)) < 1e-10
    assert np.max(np.abs((g.t - t + np.pi) % (2 * np.pi) - np.pi)) < 1e-8


@pytest.mark.parametrize("with_errors", [False, True])
def test_a_lost_warm_start_falls_back_to_a_cold_solve(rv40e, errors40, with_errors):
    """A warm start far from the pin's minimum (a stale parameter cached at a wild Newton
    iterate, up to half a turn off) must not decide the gap: the contact force would then
    depend on the solver's history and Newton can cycle (found on a Monte Carlo point)."""
    c = rv40e.cycloid
    prof = build_profile(c, errors40 if with_errors else None)
    x = to_disc_frame(pin_centres(c), *nominal_disc_pose(c, 0.3))
    r = pin_radii(c)
    cold = prof.gap(x, r)
    stale = cold.t + np.random.default_rng(5).uniform(-math.pi, math.pi, len(r))
    warm = prof.gap(x, r, stale)
    assert np.max(np.abs(cold.gap_m - warm.gap_m)) < 1e-12


def test_pin_and_disc_errors_enter_exactly(rv40e):
    """Pin 0 sits in a tooth root (normal radial): a radial pin error changes its gap by
    exactly that amount; a uniform disc profile error closes every gap by exactly its size;
    a uniform pitch error is a rigid rotation of the profile."""
    c = _with_mod(rv40e.cycloid, moved_m=0.0, equidistant_m=0.0)
    pose = nominal_disc_pose(c, 0.0)
    base = build_profile(c).gap(to_disc_frame(pin_centres(c), *pose), pin_radii(c)).gap_m
    e = ErrorSpec(pin_radial_m=(3 * UM,) + (0.0,) * 39)
    g = build_profile(c, e).gap(to_disc_frame(pin_centres(c, e), *pose), pin_radii(c, e)).gap_m
    assert g[0] - base[0] == pytest.approx(3 * UM, abs=1e-13)
    e = ErrorSpec(disc_profile_error_m=((1.5 * UM,) * 39, (0.0,) * 39))
    g = build_profile(c, e).gap(to_disc_frame(pin_centres(c), *pose), pin_radii(c)).gap_m
    assert np.max(np.abs(g - base + 1.5 * UM)) < 1e-13
    e = ErrorSpec(disc_pitch_error_m=((4 * UM,) * 39, (0.0,) * 39))
    psi = 4 * UM / c.pin_circle_radius_m
    g = build_profile(c, e).gap(to_disc_frame(pin_centres(c), pose[0], pose[1] - psi), pin_radii(c)).gap_m
    assert np.max(np.abs(g - base)) < 1e-13


def test_pressure_angle_zones_follow_seed003(rv80e):
    """Zones start where the pressure angle reaches 65° (tip) and 75° (root); the added
    generating radius is 0 with zero slope there and reaches 45 / 15 µm at the apex."""
    c = _with_mod(rv80e.cycloid, **KINDS["pressure_angle"])
    prof = build_profile(c)
    zc = c.disc_teeth
    u_tip, u_root = prof.par[P_TIP_U], prof.par[P_ROOT_U]
    ref = build_profile(_with_mod(c, tip_amount_m=0.0, root_amount_m=0.0))
    assert math.degrees(ref.pressure_angle(np.array([u_tip / zc]))[0]) == pytest.approx(65.0, abs=1e-9)
    assert math.degrees(ref.pressure_angle(np.array([u_root / zc]))[0]) == pytest.approx(75.0, abs=1e-9)

    r0 = c.pin_radius_m + c.modification.equidistant_m
    assert _radius(np.pi / zc, prof.par, prof.herr)[0] - r0 == pytest.approx(45e-6, abs=1e-15)
    assert _radius(0.0, prof.par, prof.herr)[0] - r0 == pytest.approx(15e-6, abs=1e-15)
    for u in (u_tip, u_root):
        r, dr, _ = _radius(u / zc, prof.par, prof.herr)
        assert abs(r - r0) < 1e-18 and abs(dr) < 1e-12
    mid = 0.5 * (u_tip + u_root) / zc
    assert _radius(mid, prof.par, prof.herr)[0] == r0  # working zone keeps the conjugate profile


def test_initial_clearance_numeric_vs_seed000_closed_form(rv40e):
    """Δ_i from the exact geometry (disc turned about its centre until the first pin
    touches) against the closed form. Agreement: 0.2 µm near the root (φ = 9°, where the
    first-order expansion in Δr/(r_p·S) is worst) and 0.025 µm over φ = 18°…171°; the first
    contact falls at the pin next to cos φ = K1 (40.7°)."""
    c = rv40e.cycloid
    cl = initial_clearance_numeric(c)
    side = cl.closing_pos
    phi = cl.phi[side]
    num, cf = cl.gap_after_pos_m[side], F.initial_clearance(c, phi)
    assert np.max(np.abs(num - cf)) < 0.25 * UM
    core = (phi > math.radians(15)) & (phi < math.radians(175))
    assert np.max(np.abs(num - cf)[core]) < 0.025 * UM
    first = phi[np.argmin(num)]
    assert abs(first - math.acos(c.k1)) < math.pi / c.pin_count  # nearest pin to cos φ = K1
    assert np.min(num) == pytest.approx(0.0, abs=1e-12)
    # the two flanks mirror each other
    assert cl.turn_pos_rad == pytest.approx(-cl.turn_neg_rad, rel=1e-9)


def test_backlash_formula_for_the_seed002_rv40e_example(rv40e):
    """Seed 002's ε on the RV-40E with its catalogue modification (Δr_p 12 µm, Δr_rp 20 µm).

    Hand calculation: K1 = 0.757576, √(1 − K1²) = 0.652754;
    Δφ4 = 2·(20 − 12·0.652754) µm = 24.3339 µm; e·z_c = 48.75 mm ⇒ 4.99157e-4 rad = 1.7160′.
    First stage: 50 µm/(121 × 9 mm) = 4.5914e-5 rad = 0.1578′. Total 1.8738′.
    The exact geometry's free play (disc turned from flank to flank) must equal the
    modification term. Seed 002 reports 0.54–1.22′ simulated and 1.30′ measured for its
    traditionally modified unit, whose modification amounts it does not give; our one-flank
    closing angle (0.858′) lies in its simulated range.
    """
    terms = F.reducer_backlash_arcmin(rv40e)
    assert terms["modification"] == pytest.approx(1.7160, abs=1e-4)
    assert terms["first_stage"] == pytest.approx(0.1578, abs=1e-4)
    assert terms["total"] == pytest.approx(1.8738, abs=1e-4)
    cl = initial_clearance_numeric(rv40e.cycloid)
    exact = cl.free_play_rad * F.ARCMIN_PER_RAD
    assert exact == pytest.approx(terms["modification"], rel=1e-3)
    assert 0.54 <= cl.turn_pos_rad * F.ARCMIN_PER_RAD <= 1.22


def test_hertz_line_deflection_against_hand_calculation():
    """F = 1000 N, b = 10 mm, ρ = 20 mm, r_rp = 3 mm, 20CrMnMo disc on a GCr15 pin.

    k1 = (1 − 0.254²)/207 GPa = 4.51925e-12, k2 = (1 − 0.3²)/219 GPa = 4.15525e-12 (1/Pa);
    1/ρ + 1/r = 383.333 1/m; c = √(4·1000·8.6745e-12/(π·0.01·383.333)) = 53.677 µm;
    δ = 2·1000/(π·0.01)·[k1(ln(0.08/c) − 0.5) + k2(ln(0.012/c) − 0.5)]
      = 63661.98·[4.51925e-12·6.8068 + 4.15525e-12·4.9097] = 3.2571 µm.
    """
    d = F.hertz_line_deflection(1000.0, 0.010, 0.020, 0.003, 2.07e11, 0.254, 2.19e11, 0.3)
    assert d == pytest.approx(3.2571e-6, rel=2e-4)
    # line contact stiffens slowly: twice the force, a bit less than twice the approach
    d2 = F.hertz_line_deflection(2000.0, 0.010, 0.020, 0.003, 2.07e11, 0.254, 2.19e11, 0.3)
    assert 1.8 * d < d2 < 2.0 * d
    assert F.hertz_line_deflection(0.0, 0.01, 0.02, 0.003, 2.07e11, 0.254, 2.19e11, 0.3) == 0.0


def test_load_sharing_law_peaks_at_cos_phi_equal_k1(rv40e):
    c = rv40e.cycloid
    phi = np.linspace(0.0, np.pi, 100001)
    share = F.load_sharing(c, phi)
    assert phi[np.argmax(share)] == pytest.approx(math.acos(c.k1), abs=1e-4)
    assert share.max() == pytest.approx(1.0, abs=1e-9)
    assert F.lever_arm(c, np.array([math.acos(c.k1)]))[0] == pytest.approx(c.eccentricity_m * c.disc_teeth)


def test_the_boxed_self_intersection_test_agrees_with_the_pairwise_one():
    """The profile check's bounding-box test finds a crossing exactly when comparing every segment with
    the next ``span`` ones does: looped and smooth trochoids (a·k > 1 loops), with and without noise,
    many sizes and spans, and the first pair it names crosses (the independent count above)."""
    from rvflex.geometry._kernels import any_self_intersection, first_self_intersection

    rng = np.random.default_rng(3)
    found = 0
    for _ in range(300):
        n = int(rng.integers(60, 1500))
        t = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
        k = int(rng.integers(3, 30))
        a = rng.uniform(0.5, 2.0) / k
        xy = np.column_stack([np.cos(t) + a * np.cos(k * t), np.sin(t) - a * np.sin(k * t)])
        xy += rng.normal(0.0, rng.choice([0.0, 1e-4]), xy.shape)
        span = int(rng.integers(3, n // 2))
        i, j = first_self_intersection(xy, span)
        assert any_self_intersection(xy, span) == (i >= 0)
        if i >= 0:
            found += 1
            p, q, r, s = xy[i], xy[(i + 1) % n], xy[j], xy[(j + 1) % n]
            side = lambda u, v, w: np.sign((v[0] - u[0]) * (w[1] - u[1]) - (v[1] - u[1]) * (w[0] - u[0]))  # noqa: E731
            assert side(p, q, r) * side(p, q, s) < 0 and side(r, s, p) * side(r, s, q) < 0
    assert 50 < found < 300  # both outcomes are exercised

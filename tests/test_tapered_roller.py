"""The crank support pair as tapered roller rows (rvflex.contact.tapered_roller): each row's pressure centre,
axial and own tilt stiffness against a row of rollers summed numerically, contact line by contact line; the
spec's refusals; the spatial model's crank tilt over the rows' span."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from rvflex import catalog
from rvflex.contact.tapered_roller import half_bearing, support_rows
from rvflex.spec import SpecError, dumps_spec, loads_spec


@pytest.fixture(scope="module", name="rv40e")
def _rv40e():
    return catalog.load("rv40e")


@pytest.fixture(scope="module", name="rv80e")
def _rv80e():
    return catalog.load("rv80e")


def _row_stiffness(pair, k_n: float, points: int = 4001) -> tuple[np.ndarray, float]:
    """The 5×5 stiffness (x, y, z, θx, θy) about the roller mid-plane of one row, by summing the rollers'
    contact lines: roller j at azimuth φ_j touches the cup along a line at angle α to the axis through
    (r_c, 0), its load along the line's normal; every point of the line a spring k_n/points along that normal.
    Returns K and the cup radius r_c the rollers touch at mid-length."""
    alpha, z = pair.cup_angle_rad, pair.rollers
    r_c = 0.25 * (pair.bore_diameter_m + pair.outer_diameter_m) + 0.5 * pair.roller_diameter_m * math.cos(alpha)
    s = np.linspace(-0.5, 0.5, points) * pair.roller_length_m
    w = np.full(points, k_n * pair.roller_length_m / (points - 1))
    w[[0, -1]] *= 0.5  # trapezoid weights: ∫ k_n/l ds over the line
    w /= pair.roller_length_m
    k = np.zeros((5, 5))
    for phi in 2 * math.pi * np.arange(z) / z:
        e_r, e_z = np.array([math.cos(phi), math.sin(phi), 0.0]), np.array([0.0, 0.0, 1.0])
        n = math.cos(alpha) * e_r - math.sin(alpha) * e_z  # cup normal, inner ring → cup
        u = math.sin(alpha) * e_r + math.cos(alpha) * e_z  # along the contact line
        p = r_c * e_r + s[:, None] * u
        g = np.hstack([np.broadcast_to(n, p.shape), np.cross(p, n)[:, :2]])  # δ = (d + θ × p)·n
        k += (g * w[:, None]).T @ g
    return k, r_c


@pytest.mark.parametrize("unit", ["rv40e", "rv80e", "rv160n"])
def test_a_row_carries_at_its_pressure_centre_with_the_axial_and_tilt_stiffness_of_its_rollers(unit):
    spec = catalog.load(unit)
    pair = spec.bearings.crank_support_pair
    rows = support_rows(spec)
    k_r = rows.bearing.radial_stiffness_N_m
    k_n = 2.0 * k_r / (pair.rollers * math.cos(pair.cup_angle_rad) ** 2)  # the roller stiffness giving k_r
    k, r_c = _row_stiffness(pair, k_n)
    assert k[0, 0] == pytest.approx(k_r, rel=1e-9) and k[1, 1] == pytest.approx(k_r, rel=1e-9)
    assert k[2, 2] == pytest.approx(rows.bearing.axial_stiffness_N_m, rel=1e-9)
    # the pressure centre: the point on the axis about which a radial displacement and the tilt uncouple
    c = k[0, 4] / k[0, 0]
    assert abs(c) == pytest.approx(rows.pressure_centre_offset_m, rel=1e-9)
    assert c == pytest.approx(r_c * math.tan(pair.cup_angle_rad), rel=1e-9)
    # about it the row's own tilt stiffness is the contact lines' twist, k_n·l²/12 per roller and sin²φ
    t = np.eye(5)
    t[0, 4], t[1, 3] = -c, c  # the mid-plane's displacement in a motion given at (0, 0, c): d − θ × (c·e_z)
    k_c = t.T @ k @ t
    assert k_c[4, 4] == pytest.approx(rows.bearing.tilt_stiffness_Nm_rad, rel=1e-6)
    assert abs(k_c[0, 4]) < 1e-9 * k_c[0, 0] * r_c
    assert rows.half_span_m == pytest.approx(0.5 * spec.cranks.support_span_m + c, rel=1e-12)


def test_without_the_rows_geometry_each_support_is_half_the_lumped_bushing(rv40e):
    spec = dataclasses.replace(rv40e, bearings=dataclasses.replace(rv40e.bearings, crank_support_pair=None))
    rows = support_rows(spec)
    assert rows.half_span_m == 0.5 * spec.cranks.support_span_m and rows.pressure_centre_offset_m == 0.0
    assert rows.bearing == half_bearing(spec.bearings.crank_support)
    assert rows.bearing.tilt_stiffness_Nm_rad == 0.5 * spec.bearings.crank_support.tilt_stiffness_Nm_rad


def test_a_face_to_face_pair_has_its_pressure_centres_inboard(rv80e):
    pair = rv80e.bearings.crank_support_pair
    x = dataclasses.replace(rv80e, bearings=dataclasses.replace(
        rv80e.bearings, crank_support_pair=dataclasses.replace(pair, arrangement="face_to_face")))
    assert support_rows(x).half_span_m == pytest.approx(
        0.5 * rv80e.cranks.support_span_m - pair.pressure_centre_offset_m, rel=1e-12)


def test_the_pair_round_trips_through_toml(rv80e):
    back = loads_spec(dumps_spec(rv80e))
    assert back.bearings.crank_support_pair == rv80e.bearings.crank_support_pair


@pytest.mark.parametrize(("change", "field"), [
    (dict(rollers=20), "rollers"),
    (dict(cup_angle_rad=0.9), "cup_angle_rad"),
    (dict(roller_diameter_m=0.012), "roller_diameter_m"),
    (dict(kind="ball"), "kind"),
    (dict(outer_diameter_m=0.010), "outer_diameter_m"),
])
def test_a_bad_row_is_refused_naming_its_field(rv80e, change, field):
    with pytest.raises(SpecError) as info:
        dataclasses.replace(rv80e.bearings.crank_support_pair, **change)
    assert info.value.field == field and "\n" not in str(info.value)


def test_a_pair_that_does_not_fit_the_crank_is_refused(rv80e):
    pair = rv80e.bearings.crank_support_pair
    with pytest.raises(SpecError) as info:
        dataclasses.replace(rv80e, bearings=dataclasses.replace(
            rv80e.bearings, crank_support_pair=dataclasses.replace(pair, bore_diameter_m=0.016)))
    assert info.value.field == "bearings.crank_support_pair.bore_diameter_m" and "support_journal_radius_m" in str(
        info.value)
    steep = dataclasses.replace(pair, arrangement="face_to_face", cup_angle_rad=0.75)
    short = dataclasses.replace(rv80e.cranks, support_span_m=0.026)
    with pytest.raises(SpecError) as info:
        dataclasses.replace(rv80e, cranks=short,
                            bearings=dataclasses.replace(rv80e.bearings, crank_support_pair=steep))
    assert info.value.field == "bearings.crank_support_pair.arrangement" and "eccentrics" in str(info.value)

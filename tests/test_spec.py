"""Specs: TOML round trip, catalogue sourcing, and every bad-input case of the foundation issue."""

from __future__ import annotations

import dataclasses as dc
import re
from importlib import resources

import numpy as np
import pytest

from rvflex import catalog
from rvflex.geometry import build_profile
from rvflex.spec import (
    ErrorSpec,
    SpecError,
    dumps_errors,
    dumps_spec,
    load_spec,
    loads_errors,
    loads_spec,
)


@pytest.fixture(scope="module")
def rv40e():
    return catalog.load("rv40e")


def _edit(text: str, table: str, key: str, value: str | None) -> str:
    """Replace (or, with value None, delete) ``key`` inside ``[table]`` of a TOML text."""
    out, current, done = [], "", False
    for line in text.splitlines():
        m = re.match(r"^\[(.+)\]\s*(#.*)?$", line)
        if m:
            current = m.group(1)
        elif current == table and re.match(rf"^{re.escape(key)}\s*=", line):
            done = True
            if value is None:
                continue
            line = f"{key} = {value}"
        out.append(line)
    assert done, f"{table}.{key} not found"
    return "\n".join(out) + "\n"


def test_catalogue_ratios_and_k1():
    rv40, rv80 = catalog.load("rv40e"), catalog.load("rv80e")
    assert rv40.ratio == rv40.nominal_ratio == 121.0
    assert rv80.ratio == rv80.nominal_ratio == 81.0
    assert rv40.cycloid.k1 == pytest.approx(1.25 * 40 / 66, rel=1e-15)
    assert rv40.cycloid.k1 < 1 and rv80.cycloid.k1 < 1
    # seed 004 numbers, in SI
    c = rv40.cycloid
    assert (c.disc_teeth, c.pin_count) == (39, 40)
    assert (c.pin_circle_radius_m, c.pin_radius_m, c.eccentricity_m) == (0.066, 0.003, 0.00125)
    assert (c.modification.moved_m, c.modification.equidistant_m) == (1.2e-5, 2.0e-5)
    assert rv40.rated_torque_Nm == 412.0


@pytest.mark.parametrize("name", catalog.names())
def test_every_catalogue_value_has_a_source(name):
    text = resources.files("rvflex.catalog").joinpath(f"{name}.toml").read_text(encoding="utf-8")
    for line in text.splitlines():
        if "=" in line and not line.lstrip().startswith("#"):
            comment = line.split("#", 1)[1] if "#" in line else ""
            assert re.search(r"seed 00\d|assumed|issue \d+", comment), f"{name}.toml: no source for: {line}"


@pytest.mark.parametrize("name", catalog.names())
def test_spec_toml_round_trip_is_exact(name, tmp_path):
    spec = catalog.load(name)
    text = dumps_spec(spec)
    again = loads_spec(text)
    assert again == spec
    assert dumps_spec(again) == text
    path = tmp_path / "s.toml"
    path.write_text(text)
    assert load_spec(path) == spec


def test_error_toml_round_trip_is_exact(rv40e):
    zc, zb = rv40e.cycloid.disc_teeth, rv40e.cycloid.pin_count
    errors = ErrorSpec(
        sun_base_eccentricity_m=10e-6, sun_runout_m=5e-6, planet_base_eccentricity_m=(10e-6, 10e-6),
        pin_radial_m=tuple(8e-6 * (-1) ** k for k in range(zb)), pin_radius_error_m=-4e-6,
        carrier_bore_eccentricity_m=(5e-6, 5e-6), carrier_runout_m=5e-6, pin_circle_radius_error_m=10e-6,
        crank_eccentricity_error_m=(-2e-6, 2e-6), eccentric_bearing_clearance_m=(12e-6,) * 4,
        disc_pitch_error_m=(tuple(1e-6 * k / zc for k in range(zc)),) * 2,
        disc_profile_error_m=(tuple(0.3e-6 for _ in range(zc)), tuple(-0.1e-6 for _ in range(zc))),
        input_shaft_angle_error_rad=3e-4, input_shaft_angle_error_phase_rad=-1.2,
        crank_runout_m=(3e-6, 0.0), crank_runout_phase_rad=(0.5, 0.0),
        pin_ring_tilt_rad=3e-4, pin_ring_tilt_phase_rad=0.4,
    )
    again = loads_errors(dumps_errors(errors), spec=rv40e)
    assert again == errors
    assert loads_errors("", spec=rv40e) == ErrorSpec()


@pytest.mark.parametrize(("text", "field", "rule"), [
    ("input_shaft_angle_error_rad = 0.3", "input_shaft_angle_error_rad", "0 to 10 mrad"),
    ("input_shaft_angle_error_rad = -1e-4", "input_shaft_angle_error_rad", "0 to 10 mrad"),
    ("crank_runout_m = [3e-6, 3e-6, 3e-6]", "crank_runout_m", "needs 2 values (one per crank of"),
    ("crank_runout_m = [3e-3, 0.0]", "crank_runout_m[0]", "expected metres"),
    ("crank_runout_phase_rad = [7.0, 0.0]", "crank_runout_phase_rad[0]", "radians within ±2π"),
    ("pin_ring_tilt_rad = 0.05", "pin_ring_tilt_rad", "at most ±10 mrad"),
])
def test_bad_input_shaft_and_crank_runout_errors_are_refused_naming_the_field(rv40e, text, field, rule):
    with pytest.raises(SpecError) as info:
        loads_errors(text, spec=rv40e)
    assert info.value.field == field and rule in str(info.value), str(info.value)


# ------------------------------------------------------------------------------ bad input

BASE = resources.files("rvflex.catalog").joinpath("rv40e.toml").read_text(encoding="utf-8")


@pytest.mark.parametrize(
    ("table", "key", "value", "field", "rule"),
    [
        ("cycloid", "pin_circle_radius_m", "66.0", "cycloid.pin_circle_radius_m", "expected metres"),
        ("cycloid", "pin_count", "41", "cycloid.pin_count", "z_b = z_c + 1"),
        ("cycloid", "eccentricity_m", "0.0017", "cycloid.eccentricity_m", "K1 = e·z_b/r_p = 1.0303 must be < 1"),
        ("cycloid", "pin_radius_m", "0.0053", "cycloid.pin_radius_m", "pin cannot fit"),
        ("materials.pins", "youngs_modulus_Pa", "219.0", "materials.pins.youngs_modulus_Pa", "expected Pa"),
        ("input_stage", "sun_teeth", "16", "ratio", "must equal 1 + (z2/z1)·z_b"),
        ("cycloid.modification", "moved_m", "0.012", "cycloid.modification.moved_m", "expected metres"),
    ],
)
def test_bad_values_are_refused_with_field_value_and_rule(table, key, value, field, rule):
    with pytest.raises(SpecError) as info:
        loads_spec(_edit(BASE, table, key, value), "rv40e-bad.toml")
    msg = str(info.value)
    assert msg.startswith("rv40e-bad.toml: "), msg
    assert field in msg and rule in msg, msg
    assert info.value.field == field


def test_unknown_misspelled_key_is_refused_with_a_suggestion():
    text = BASE.replace("pin_radius_m = 0.003 ", "pin_raduis_m = 0.003 ")
    with pytest.raises(SpecError, match=r"cycloid\.pin_raduis_m = 0\.003: unknown key in \[cycloid\] "
                                        r"\(did you mean 'pin_radius_m'\?\)"):
        loads_spec(text, "x.toml")


def test_missing_key_is_refused():
    with pytest.raises(SpecError, match=r"x\.toml: cycloid\.eccentricity_m = None: missing key"):
        loads_spec(_edit(BASE, "cycloid", "eccentricity_m", None), "x.toml")


def test_wrong_type_is_refused():
    with pytest.raises(SpecError, match=r"cycloid\.disc_teeth = '39': must be an integer"):
        loads_spec(_edit(BASE, "cycloid", "disc_teeth", '"39"'), "x.toml")


def _small_ring(pin_radius: str) -> str:
    """A small pin ring (r_p 10 mm, e 0.2 mm, 40 pins) whose pin-centre curve has its
    smallest radius of curvature, 0.742 mm, on the flank (tooth phase 67.5°)."""
    text = _edit(BASE, "cycloid", "pin_circle_radius_m", "0.010")
    text = _edit(text, "cycloid", "eccentricity_m", "0.0002")
    text = _edit(text, "cycloid", "pin_radius_m", pin_radius)
    text = _edit(text, "cycloid", "disc_center_hole_radius_m", "0.002")
    return _edit(text, "cycloid.modification", "moved_m", "0.0")


def test_small_ring_radius_of_curvature():
    t = np.linspace(0.0, 2 * np.pi / 39, 200_001)
    ei, eb = np.exp(1j * t), np.exp(40j * t)
    v, a = 1j * (0.010 * ei - 40 * 0.0002 * eb), -(0.010 * ei) + 1600 * 0.0002 * eb
    rho_min = 1.0 / ((v.conj() * a).imag / np.abs(v) ** 3).max()
    assert rho_min == pytest.approx(0.742e-3, abs=0.5e-6)


def test_undercut_pin_is_refused():
    """A 0.76 mm pin fits between its neighbours (0.78 mm) but exceeds ρ_min = 0.742 mm."""
    with pytest.raises(SpecError, match=r"cycloid\.pin_radius_m = .*self-intersects.*undercut"):
        loads_spec(_edit(_small_ring("0.00076"), "cycloid.modification", "equidistant_m", "0.0"), "x.toml")


def test_self_intersecting_modification_is_refused():
    """0.70 mm pins on the small ring: a generating radius below ρ_min = 0.742 mm is a valid
    profile, one above it folds into a swallowtail (checked independently below)."""
    ok = loads_spec(_edit(_small_ring("0.0007"), "cycloid.modification", "equidistant_m", "2.0e-5"), "ok.toml")
    assert ok.cycloid.modification.equidistant_m == 2e-5
    # the compensation δ·|sin τ|/S is 0.91·δ at the critical tooth phase 67.5°
    for key, value in (("equidistant_m", "6.0e-5"), ("compensation_m", "6.0e-5")):
        text = _edit(_small_ring("0.0007"), "cycloid.modification", "equidistant_m", "0.0")
        with pytest.raises(SpecError, match=r"cycloid\.modification = .*self-intersects"):
            loads_spec(_edit(text, "cycloid.modification", key, value), "x.toml")


def test_refused_profile_really_self_intersects():
    """Independent of the checker: the unchecked 0.76 mm generating-pin profile crosses itself."""
    spec = loads_spec(_edit(_small_ring("0.0007"), "cycloid.modification", "equidistant_m", "2.0e-5"))
    bad = dc.replace(spec.cycloid.modification, equidistant_m=6.0e-5)
    stage = object.__new__(type(spec.cycloid))  # bypass validation to look at the refused geometry
    for f in dc.fields(spec.cycloid):
        object.__setattr__(stage, f.name, getattr(spec.cycloid, f.name))
    object.__setattr__(stage, "modification", bad)
    xy = build_profile(stage, check=False).points(2000)[:-1]
    assert _crossings(xy[: 3 * 2000]) > 0
    xy_ok = build_profile(spec.cycloid, check=False).points(2000)[:-1]
    assert _crossings(xy_ok[: 3 * 2000]) == 0


def test_a_refused_profile_is_refused_again_under_the_field_that_asks():
    """The check's outcome is kept per curve (a diagnosis builds the same discs some 70 times): the same
    swallowtail is refused each time it is checked, each refusal naming the field its caller gives, and
    a profile that differs from it by 1 nm of equidistant modification is checked on its own."""
    spec = loads_spec(_edit(_small_ring("0.0007"), "cycloid.modification", "equidistant_m", "2.0e-5"))
    stage = object.__new__(type(spec.cycloid))  # bypass validation to check the refused geometry directly
    for f in dc.fields(spec.cycloid):
        object.__setattr__(stage, f.name, getattr(spec.cycloid, f.name))
    object.__setattr__(stage, "modification", dc.replace(spec.cycloid.modification, equidistant_m=6.0e-5))
    bad = build_profile(stage, check=False)
    for field in ("cycloid.modification", "errors.disc_equidistant_error_m", "cycloid.modification"):
        with pytest.raises(SpecError, match=rf"^{field.replace('.', '[.]')} = .*self-intersects"):
            bad.check(field=field)
    build_profile(spec.cycloid, check=False).check()  # 2e-5 m: a valid profile, before and after
    object.__setattr__(stage, "modification", dc.replace(spec.cycloid.modification, equidistant_m=6.0e-5 + 1e-9))
    with pytest.raises(SpecError, match="self-intersects"):
        build_profile(stage, check=False).check()


def _crossings(xy: np.ndarray) -> int:
    """Number of properly crossing pairs among the open polyline's segments (numpy, O(n²))."""
    a, b = xy[:-1], xy[1:]
    count = 0
    def cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]

    for i in range(len(a)):
        c, d = a[i + 2:], b[i + 2:]
        o1 = cross(b[i] - a[i], c - a[i])
        o2 = cross(b[i] - a[i], d - a[i])
        o3 = cross(d - c, a[i] - c)
        o4 = cross(d - c, b[i] - c)
        count += int(np.count_nonzero((o1 * o2 < 0) & (o3 * o4 < 0)))
    return count


def test_dataclass_replace_revalidates(rv40e):
    with pytest.raises(SpecError, match="pin_count"):
        dc.replace(rv40e.cycloid, disc_teeth=40)


def test_error_counts_are_checked_against_the_spec(rv40e):
    with pytest.raises(SpecError, match=r"e\.toml: pin_radial_m = .*needs 40 values \(one per pin of rv40e\)"):
        loads_errors("pin_radial_m = [1e-6, 2e-6]\n", "e.toml", rv40e)
    with pytest.raises(SpecError, match=r"crank_eccentricity_error_m\[1\] = 2\.0: expected metres"):
        loads_errors("crank_eccentricity_error_m = [2e-6, 2.0]\n", "e.toml", rv40e)
    with pytest.raises(SpecError, match=r"main_bearing_clearance_m = -1e-06: a clearance cannot be negative"):
        loads_errors("main_bearing_clearance_m = -1e-6\n", "e.toml", rv40e)
    with pytest.raises(SpecError, match=r"unknown key in top level \(did you mean 'pin_radial_m'\?\)"):
        loads_errors("pin_radail_m = []\n", "e.toml", rv40e)

"""TE orders named by the parts that turn at them (rvflex.diagnosis.orders): the kinematics of the
catalogue units, the effect table, and the table checked against the rigid model's quasi-static TE
with one error at a time (each check a few model runs of ~1–5 s)."""

from __future__ import annotations

import dataclasses as dc
import functools
from fractions import Fraction

import numpy as np
import pytest

from rvflex import catalog
from rvflex.diagnosis.effects import EFFECTS
from rvflex.diagnosis.orders import (
    MEAN_ONLY,
    NO_PART_NOTE,
    PART_ERRORS,
    effects_at,
    lacking_lookalikes,
    name_orders,
    parts_at,
    rotations,
)
from rvflex.geometry.formulas import ARCSEC_PER_RAD
from rvflex.metrics import order_spectrum
from rvflex.spec import ErrorSpec
from rvflex.units import UM


def _order(spec, key: str) -> Fraction:
    return next(r.order for r in rotations(spec) if r.key == key)


def _keys(entries) -> dict[str, int]:
    return {p["key"]: p["harmonic"] for p in entries}


# --------------------------------------------------------------------------- kinematics


def test_rv160n_orders_are_named_by_the_parts_that_turn_at_them():
    """RV-160N (i = 81, z1 = 22, z2 = 44, z_b = 40, three cranks): 81 is the input shaft against the
    housing, 80 against the carrier, 39 the cranks against the housing, 40 the cranks against the
    carrier and the pin passing, 3 the crank-count pattern, 1760 the first-stage mesh."""
    spec = catalog.load("rv160n")
    assert _keys(parts_at(spec, 81)) == {"input_housing": 1}
    assert _keys(parts_at(spec, 80)) == {"input_carrier": 1, "crank_carrier": 2, "eccentric_bearings": 2,
                                         "pin_passing": 2}
    assert _keys(parts_at(spec, 39)) == {"crank_housing": 1}
    assert _keys(parts_at(spec, 40)) == {"crank_carrier": 1, "eccentric_bearings": 1, "pin_passing": 1}
    assert _keys(parts_at(spec, 3)) == {"output": 3, "discs": 3, "crank_pattern": 1, "pillar_pattern": 1}
    assert _keys(parts_at(spec, 1760)) == {"first_stage_mesh": 1}
    assert _keys(parts_at(spec, 1560)) == {"tooth_mesh": 1}
    assert {p["relative_to"] for p in parts_at(spec, 81)} == {"housing"}
    assert "crank-count pattern (3 cranks" in parts_at(spec, 3)[2]["part"]


@pytest.mark.parametrize(("unit", "ratio", "first_mesh", "cranks"), [
    ("rv40e", 121, 1440, 2), ("rv80e", 81, 1280, 2), ("rv160n", 81, 1760, 3)])
def test_catalogue_units_turn_at_their_own_counts(unit, ratio, first_mesh, cranks):
    """Every order follows from the unit's counts: i = 1 + (z2/z1)·z_b equals the catalogue ratio, the
    cranks turn z_b times against the carrier and z_c times against the housing, the meshes are
    z1·(i − 1) and z_c·z_b."""
    spec = catalog.load(unit)
    zb, zc = spec.cycloid.pin_count, spec.cycloid.disc_teeth
    assert _order(spec, "input_housing") == ratio == pytest.approx(spec.ratio, rel=1e-12)
    assert _order(spec, "input_carrier") == ratio - 1
    assert _order(spec, "crank_carrier") == _order(spec, "pin_passing") == zb
    assert _order(spec, "crank_housing") == zc
    assert _order(spec, "first_stage_mesh") == first_mesh == spec.input_stage.planet_teeth * zb
    assert _order(spec, "tooth_mesh") == zb * zc
    assert _order(spec, "crank_pattern") == cranks
    assert [_order(spec, f"pin_ring_lobing_{n}") for n in (2, 3, 4)] == [2 * zc, 3 * zc, 4 * zc]
    cage = _order(spec, "eccentric_bearing_cages")  # between 0 and the crank order, never a whole number here
    assert 0 < cage < zb and cage.denominator > 1


def test_a_ratio_that_is_no_whole_number_is_handled_exactly():
    """z1 = 14, z2 = 34 (same centre distance as the RV-80E's 16/32): i = 1 + 34·40/14 = 687/7. The input
    shaft turns 687/7 times per output revolution: order 687 is its 7th harmonic, 98 (the rounded
    ratio) names no input part, and the first-stage mesh z1·(i − 1) = z2·z_b = 1360 is a whole order."""
    base = catalog.load("rv80e")
    spec = dc.replace(base, ratio=687 / 7, input_stage=dc.replace(base.input_stage, sun_teeth=14, planet_teeth=34))
    assert _order(spec, "input_housing") == Fraction(687, 7)
    assert _order(spec, "crank_carrier") == 40
    assert _order(spec, "first_stage_mesh") == 1360
    assert _keys(parts_at(spec, 687)) == {"input_housing": 7}
    assert _keys(parts_at(spec, 680)) == {"input_carrier": 7}
    assert parts_at(spec, 687, max_harmonic=6) == []
    assert not {"input_housing", "input_carrier"} & set(_keys(parts_at(spec, 98)))


def test_name_orders_maps_the_library_effects_where_the_model_shows_them():
    """RV-40E: order 1 is the output encoder's (not the disc pitch error's: the model shows that at z_b);
    40 the disc pitch error's; 78 the pin-ring runout's and 2-lobed pins'; 117 (3·z_c) nobody's (the discs'
    phases cancel it); 156 the 4-lobed pins'; 121 (the ratio) the input shaft's eccentricity; 1440
    lacks a first-stage mesh error; 37 is no part's; 1482 = 1560 − 78 a sideband of the tooth mesh."""
    spec = catalog.load("rv40e")
    one, forty, k78, k117, k156, k121, k1440, k37, k1482 = name_orders(
        spec, [1, 40, 78, 117, 156, 121, 1440, 37, 1482])
    assert one["candidates"] == ["output_encoder_eccentricity"]
    assert "cycloid_pitch_error" in forty["candidates"]
    assert not {"pin_ring_runout", "pin_position_h2", "pin_position_h3"} & set(forty["candidates"])
    assert any("planet gear runout" in s for s in forty["lacking"])
    assert {"pin_ring_runout", "pin_position_h2"} <= set(k78["candidates"])
    assert "cycloid_pitch_error" not in k78["candidates"]
    assert k117["candidates"] == [] and "cancel" in k117["note"] and _keys(k117["parts"])["pin_ring_lobing_3"] == 1
    assert "pin_position_h4" in k156["candidates"] and "pin-ring lobing (4 lobes)" not in k156["lacking"]
    assert k121["candidates"] == ["input_shaft_eccentricity"] and k121["lacking"] == []
    assert any("first-stage mesh" in s for s in k1440["lacking"])
    assert k37["parts"] == [] and k37["note"] == NO_PART_NOTE
    assert k1482["parts"] == [] and {s["key"] for s in k1482["sidebands"]} >= {"crank_housing"}
    assert "pin_ring_runout" in k1482["candidates"]
    only = name_orders(spec, [78, 40], candidates=("pin_ring_runout", "cycloid_pitch_error"))
    assert [o["candidates"] for o in only] == [["pin_ring_runout"], ["cycloid_pitch_error"]]
    with pytest.raises(ValueError, match="not registered"):
        name_orders(spec, [78], candidates=("no_such_effect",))
    with pytest.raises(ValueError, match="positive integer"):
        name_orders(spec, [78.5])


def test_every_registered_effect_is_placed_once():
    """Each built-in effect acts at some part's orders or on the mean only, never both, and the tables name
    no effect that is not registered."""
    placed = {name for err in PART_ERRORS.values() for name in err.effects}
    assert placed <= set(EFFECTS) and set(MEAN_ONLY) <= set(EFFECTS)
    assert not placed & set(MEAN_ONLY)
    assert set(EFFECTS) == placed | set(MEAN_ONLY)


def test_the_output_encoders_eccentricity_is_order_one_only():
    """The measurement effect a·cos θ + b·sin θ: all of its TE at order 1, and order 1 names it."""
    n = 256
    pos = 2 * np.pi * np.arange(n) / n
    te = EFFECTS["output_encoder_eccentricity"].measure(pos, np.zeros(n), (3e-5, -2e-5))
    orders, amp = order_spectrum(te, 1.0)
    assert orders[np.argmax(amp)] == 1 and np.sort(amp)[-2] < 1e-9 * amp.max()
    assert "output_encoder_eccentricity" in effects_at(catalog.load("rv40e"), 1)


# --------------------------------------------------------------------------- the model


@functools.lru_cache(maxsize=None)
def _te(unit: str, errors: ErrorSpec, n: int) -> np.ndarray:
    """Rigid quasi-static TE (rad) at rated load over one output revolution, ``n`` positions."""
    from rvflex.model import build_reducer
    from rvflex.solve import quasi_static

    spec = catalog.load(unit)
    model = build_reducer(spec, errors)
    theta = np.linspace(0.0, 2 * np.pi * model.ratio, n, endpoint=False)
    return quasi_static(model, theta, spec.rated_torque_Nm).te_rad


def _added(unit: str, errors: ErrorSpec, n: int | None = None) -> tuple[np.ndarray, int]:
    """Amplitude (arcsec) per order of the TE ``errors`` add to the error-free unit, and the grid. The
    default grid is twice the tooth mesh z_c·z_b: every harmonic of the tooth mesh folds onto orders 0
    and z_c·z_b, and orders up to z_c·z_b/2 get at least 4 samples."""
    n = n or int(2 * _order(catalog.load(unit), "tooth_mesh"))
    _, amp = order_spectrum(_te(unit, errors, n) - _te(unit, ErrorSpec(), n), 1.0)
    return amp, n


def _strongest(amp: np.ndarray, n: int, unit: str) -> int:
    """The strongest order other than the tooth mesh's fold-over bins (0 and z_c·z_b on the default grid)."""
    a = amp.copy()
    a[0] = 0.0
    mesh = int(_order(catalog.load(unit), "tooth_mesh"))
    if n == 2 * mesh:
        a[mesh] = 0.0
    return int(np.argmax(a))


def _effect(name: str, unit: str, x) -> ErrorSpec:
    return EFFECTS[name].apply_to(catalog.load(unit), ErrorSpec(), np.asarray(x, float))[1]


def test_housing_fixed_runouts_show_at_twice_the_pin_sweep_and_a_turning_carrier_runout_at_twice_z_b():
    """RV-40E: a pin-ring runout and the model's carrier runout (the main-bearing seat offset in the
    housing) are swept by the load zone at z_c: 2·z_c = 78, nothing at 39 (the discs' phases). The
    crank bores all offset alike (a carrier runout turning with the carrier) show at 2·z_b = 80 instead."""
    spec = catalog.load("rv40e")
    for errors in (_effect("pin_ring_runout", "rv40e", (5 * UM, 0.0)), ErrorSpec(carrier_runout_m=5 * UM)):
        amp, n = _added("rv40e", errors)
        k = _strongest(amp, n, "rv40e")
        assert k == 78 and amp[78] > 0.05 and amp[39] < 0.05 * amp[78]
        named = name_orders(spec, [k])[0]
        assert _keys(named["parts"])["crank_housing"] == 2 and "pin_ring_runout" in named["candidates"]
        assert "pin_ring_runout" not in effects_at(spec, 39)
    amp, n = _added("rv40e", ErrorSpec(carrier_bore_eccentricity_m=(5 * UM, 5 * UM),
                                       carrier_bore_eccentricity_phase_rad=(0.0, 0.0)))
    k = _strongest(amp, n, "rv40e")
    assert k == 80 and amp[40] < 0.05 * amp[80]
    named = name_orders(spec, [k])[0]
    assert _keys(named["parts"])["crank_carrier"] == 2
    assert any("carrier runout turning with the carrier" in s for s in named["lacking"])


@pytest.mark.parametrize("unit", ["rv40e", "rv160n"])
def test_a_tilted_pin_ring_shows_at_z_c_where_a_runout_cancels_and_the_library_names_it_there(unit):
    """The pins leaning against the crank axis by 2 µm at each disc plane (the discs see the ring offset
    oppositely, ErrorSpec.pin_ring_tilt_rad): the discs' kinematic errors at the odd harmonics of the load
    zone's sweep add instead of cancelling, so the TE shows at z_c = 39 on the two- and the three-crank unit,
    at several arcseconds (a runout of the same size: ≤ 0.1″ at 78), and twice z_c at under 5 % of it. The
    table names the effect pin_ring_tilt there, and not at twice z_c."""
    spec = catalog.load(unit)
    z = max(spec.cranks.eccentric_axial_positions_m) - float(np.mean(spec.cranks.eccentric_axial_positions_m))
    amp, n = _added(unit, ErrorSpec(pin_ring_tilt_rad=2 * UM / z, pin_ring_tilt_phase_rad=0.4))
    zc = spec.cycloid.disc_teeth
    assert _strongest(amp, n, unit) == zc and amp[zc] > 3.0 and amp[2 * zc] < 0.05 * amp[zc]
    named = name_orders(spec, [zc])[0]
    assert _keys(named["parts"])["crank_housing"] == 1
    assert "pin_ring_tilt" in named["candidates"] and "pin_ring_tilt" not in effects_at(spec, 2 * zc)


def test_pin_ring_lobing_shows_where_the_table_puts_it():
    """RV-40E: 2 lobes → 78 = 2·z_c; 3 lobes → 234 = 6·z_c (3·z_c = 117 cancelled by the discs'
    phases); 4 lobes → 156 = 4·z_c."""
    spec = catalog.load("rv40e")
    cases = ((_effect("pin_position_h2", "rv40e", (4 * UM, 0.0)), 78, "pin_position_h2"),
             (_effect("pin_position_h3", "rv40e", (4 * UM, 0.0)), 234, "pin_position_h3"),
             (_effect("pin_position_h4", "rv40e", (3 * UM, 0.0)), 156, "pin_position_h4"))
    for errors, expect, effect in cases:
        amp, n = _added("rv40e", errors)
        assert _strongest(amp, n, "rv40e") == expect
        named = name_orders(spec, [expect])[0]
        assert effect in named["candidates"]
        if expect == 234:
            assert amp[117] < 0.02 * amp[234] and "pin_position_h3" not in effects_at(spec, 117)


def test_a_disc_pitch_error_shows_where_the_load_zone_sweeps_the_disc_not_once_per_revolution():
    """RV-40E, once-per-disc cumulative pitch error (cycloid_pitch_error, 5 µm): the load zone sweeps the
    disc's teeth z_b times per output revolution, so the TE is at 40 (and 80), not at order 1."""
    spec = catalog.load("rv40e")
    amp, n = _added("rv40e", _effect("cycloid_pitch_error", "rv40e", (5 * UM, 0.0)))
    assert _strongest(amp, n, "rv40e") == 40 and amp[40] > 0.1
    assert amp[1] < 0.01 * amp[40]
    assert "cycloid_pitch_error" in effects_at(spec, 40)
    assert "cycloid_pitch_error" not in effects_at(spec, 1)


def test_eccentric_bearing_clearance_shows_at_the_crank_harmonics_the_crank_count_allows():
    """A clearance alike on every eccentric bearing: RV-40E (2 cranks) at 2·z_b = 80, RV-160N (3 cranks) at
    6·z_b = 240 and not at 40, 80 or 120 (multiples of the crank count that the discs' phases keep)."""
    for unit, expect in (("rv40e", 80), ("rv160n", 240)):
        spec = catalog.load(unit)
        amp, n = _added(unit, _effect("eccentric_bearing_clearance", unit, (8 * UM,)))
        assert _strongest(amp, n, unit) == expect
        assert "eccentric_bearing_clearance" in effects_at(spec, expect)
        for other in (40, 120) + ((80,) if unit == "rv160n" else ()):
            assert amp[other] < 0.2 * amp[expect]
            assert "eccentric_bearing_clearance" not in effects_at(spec, other)


def test_a_planet_runout_turns_with_its_crank_and_the_library_lacks_it():
    """RV-160N, one planet 10 µm runout: TE at the crank order z_b = 40; the library has no such effect."""
    spec = catalog.load("rv160n")
    errors = ErrorSpec(planet_runout_m=(10 * UM, 0.0, 0.0))
    amp, n = _added("rv160n", errors)
    assert _strongest(amp, n, "rv160n") == 40 and amp[40] > 0.1
    assert any("planet gear runout" in s for s in name_orders(spec, [40])[0]["lacking"])


def test_the_suns_runout_is_second_order_at_twice_the_input_order_against_the_carrier():
    """RV-40E, input_stage_runout at its bound (20 µm): the sun is held on the axis and its two planets'
    meshes cancel the first harmonic, so the TE is tiny and at 2·(i − 1) = 240, nothing at i − 1 or at the
    input's own order i (where only an angle error of the sun, input_shaft_eccentricity, acts)."""
    spec = catalog.load("rv40e")
    amp, n = _added("rv40e", _effect("input_stage_runout", "rv40e", (20 * UM, 0.0)))
    assert _strongest(amp, n, "rv40e") == 240
    assert 5e-4 < amp[240] < 0.01
    assert amp[120] < 0.2 * amp[240] and amp[121] < 0.2 * amp[240]
    assert "input_stage_runout" in effects_at(spec, 240)
    assert "input_stage_runout" not in effects_at(spec, 120) and "input_stage_runout" not in effects_at(spec, 121)


def test_a_planet_pitch_error_shows_at_the_first_stage_mesh():
    """RV-160N, a 5 µm base-pitch error of one planet: TE at z1·(i − 1) = 1760 (4 positions per order)."""
    spec = catalog.load("rv160n")
    mesh = int(_order(spec, "first_stage_mesh"))
    amp, n = _added("rv160n", ErrorSpec(planet_base_pitch_error_m=(5 * UM, 0.0, 0.0)), 4 * mesh)
    assert int(np.argmax(amp[1:])) + 1 == mesh == 1760 and amp[mesh] > 0.05
    assert _keys(parts_at(spec, mesh)) == {"first_stage_mesh": 1}


def test_crank_errors_act_on_the_mean_and_the_tooth_mesh_only():
    """RV-40E, 4 positions per tooth-mesh order: the error-free TE is the tooth mesh z_c·z_b = 1560; a
    common crank eccentricity error (−3 µm) changes it there and at no crank order; a crank phase error
    (0.5 mrad) moves the mean only — as the table places them."""
    spec = catalog.load("rv40e")
    mesh = int(_order(spec, "tooth_mesh"))
    n = 4 * mesh
    _, base = order_spectrum(_te("rv40e", ErrorSpec(), n), 1.0)
    assert int(np.argmax(base[1:])) + 1 == mesh
    amp, _ = _added("rv40e", _effect("crank_eccentricity_error", "rv40e", (-3 * UM, 0.0)), n)
    assert int(np.argmax(amp[1:])) + 1 == mesh and amp[mesh] > 0.05
    assert amp[40] < 0.1 * amp[mesh] and amp[80] < 0.1 * amp[mesh]
    assert "crank_eccentricity_error" in effects_at(spec, mesh)
    assert "crank_eccentricity_error" not in effects_at(spec, 40)
    errors = _effect("crank_phase_error", "rv40e", (5e-4, 0.0))
    d = _te("rv40e", errors, n) - _te("rv40e", ErrorSpec(), n)
    _, amp = order_spectrum(d, 1.0)
    assert abs(d.mean()) * ARCSEC_PER_RAD > 0.5 and amp[1:].max() < 0.005
    assert "crank_phase_error" in MEAN_ONLY


def _coefficient(unit: str, errors: ErrorSpec, order: int) -> complex:
    """Complex Fourier coefficient (arcsec) at ``order`` of the TE ``errors`` add, on the default grid."""
    n = int(2 * _order(catalog.load(unit), "tooth_mesh"))
    d = (_te(unit, errors, n) - _te(unit, ErrorSpec(), n)) * ARCSEC_PER_RAD
    return complex(2 * np.fft.rfft(d)[order] / n)


@pytest.mark.parametrize(("unit", "size"), [("rv40e", 3 * UM), ("rv160n", 2 * UM)])
def test_four_lobed_pins_show_at_four_times_z_c_on_two_and_three_crank_units(unit, size):
    """pin_position_h4: the load zone sweeps a 4-lobed ring at 4·z_c = 156 (both units have 39 lobes), and the
    discs' 180° phases keep that harmonic (4·π); nothing at z_c, 2·z_c or 3·z_c (< 5 % of it; measured 1e-11″).
    The pattern's negative (the ring turned 45°) gives the opposite order-156 coefficient (measured to 1e-11
    relative; bound 1e-6, the solver's tolerance: the part alike for both signs lies at 0 and 312), so cos/sin
    amplitudes parameterise it, as for 2 lobes."""
    spec = catalog.load(unit)
    zc = spec.cycloid.disc_teeth
    amp, n = _added(unit, _effect("pin_position_h4", unit, (size, 0.0)))
    assert _strongest(amp, n, unit) == 4 * zc == 156 and amp[156] > 0.3
    assert max(amp[zc], amp[2 * zc], amp[3 * zc]) < 0.05 * amp[156]
    plus = _coefficient(unit, _effect("pin_position_h4", unit, (size, 0.0)), 156)
    minus = _coefficient(unit, _effect("pin_position_h4", unit, (-size, 0.0)), 156)
    assert abs(plus + minus) < 1e-6 * abs(plus)
    assert "pin_position_h4" in effects_at(spec, 156)
    assert not {"pin_position_h4"} & {*effects_at(spec, zc), *effects_at(spec, 2 * zc), *effects_at(spec, 3 * zc)}
    assert "pin-ring lobing (4 lobes)" not in name_orders(spec, [156])[0]["lacking"]


@pytest.mark.parametrize("unit", ["rv40e", "rv160n"])
def test_an_input_shaft_eccentricity_turns_the_output_at_the_ratio_order(unit):
    """input_shaft_eccentricity, a = 0.3 mrad at ψ = 1 rad: the sun's teeth at θ_in + a·cos(θ_in − ψ) turn every
    planet alike, so the output follows by a/i: TE = (a/i)·cos(θ_in − ψ) at order i (121 RV-40E, 81 RV-160N),
    equal to it within 1 % of a/i at every position (measured: other orders ≤ 1e-3 of it, the tooth mesh's
    sideband 1560 − 121). A radial sun runout of 20 µm, against it, gives ≤ 0.01″ (its projections cancel)."""
    spec = catalog.load(unit)
    i = int(_order(spec, "input_housing"))
    a, psi = 3e-4, 1.0
    errors = _effect("input_shaft_eccentricity", unit, (a * np.cos(psi), a * np.sin(psi)))
    assert errors.input_shaft_angle_error_rad == pytest.approx(a) and errors.input_shaft_angle_error_phase_rad == 1.0
    n = int(2 * _order(spec, "tooth_mesh"))
    theta_in = np.linspace(0.0, 2 * np.pi * spec.ratio, n, endpoint=False)
    d = _te(unit, errors, n) - _te(unit, ErrorSpec(), n)
    np.testing.assert_allclose(d, a / spec.ratio * np.cos(theta_in - psi), rtol=0, atol=0.01 * a / spec.ratio)
    amp, _ = _added(unit, errors)
    assert _strongest(amp, n, unit) == i and amp[i] == pytest.approx(a / spec.ratio * ARCSEC_PER_RAD, rel=1e-3)
    assert amp[2 * i] < 1e-3 * amp[i] and amp[i - 1] < 1e-3 * amp[i]
    runout, _ = _added(unit, _effect("input_stage_runout", unit, (20 * UM, 0.0)))
    assert runout[i] < 0.01 and runout[1:n // 2].max() < 0.01 * amp[i]
    assert effects_at(spec, i) == ["input_shaft_eccentricity"]
    assert "input_shaft_eccentricity" not in effects_at(spec, 2 * i) + effects_at(spec, i - 1)
    assert name_orders(spec, [i])[0]["lacking"] == []


@pytest.mark.parametrize("unit", ["rv40e", "rv160n"])
def test_one_cranks_runout_shows_at_z_b_and_a_runout_alike_on_every_crank_at_no_order(unit):
    """crank_runout, 3 µm of crank 0's eccentrics off its journal axis, turning with the crank: the cranks pull the
    discs apart once per crank turn against the carrier, TE at z_b = 40 (several arcsec) and < 1 % of it at
    2·z_b, at z_c = 39 or at the crank count; turned by a quarter in the crank's frame, the same amplitude (within
    1 %: a polar effect). The same runout on every crank moves the discs without a fight: no order reaches
    1 % of the one-crank amplitude, nor does a common or differential crank eccentricity error — so one
    crank's runout is the crank-order effect, and a planet runout (not in the library) is its look-alike."""
    spec = catalog.load(unit)
    nc, zb, zc = spec.cranks.count, spec.cycloid.pin_count, spec.cycloid.disc_teeth
    amp, n = _added(unit, _effect("crank_runout", unit, (3 * UM, 0.0)))
    assert _strongest(amp, n, unit) == zb == 40 and amp[40] > 2.0
    assert max(amp[2 * zb], amp[zc], amp[nc]) < 0.01 * amp[40]
    turned, _ = _added(unit, _effect("crank_runout", unit, (0.0, 3 * UM)))
    assert turned[40] == pytest.approx(amp[40], rel=0.01)
    mesh = int(_order(spec, "tooth_mesh"))
    for errors in (ErrorSpec(crank_runout_m=(3 * UM,) * nc),
                   _effect("crank_eccentricity_error", unit, (-3 * UM, 0.0)),
                   _effect("crank_eccentricity_error", unit, (0.0, 3 * UM))):
        alike, _ = _added(unit, errors)
        assert alike[1:mesh].max() < 0.01 * amp[40]
    assert "crank_runout" in effects_at(spec, 40)
    assert "crank_runout" not in effects_at(spec, 80) + effects_at(spec, zc)
    tie = lacking_lookalikes(spec, "crank_runout")
    assert tie["order"] == 40 and any("planet gear runout" in s for s in tie["lacking"])
    assert not any("crank eccentric runout" in s for s in name_orders(spec, [40])[0]["lacking"])


def test_nothing_the_library_models_acts_at_the_crank_count_order_of_a_three_crank_unit():
    """RV-160N at rated load: a 10 µm pin-ring runout and a 4 µm 3-lobed pin pattern, which act at 78 and
    234, put under 1e-3″ on orders 1 … 6 (the carrier turns its three cranks past uniform pins; TE at n_c = 3
    needs a carrier-fixed pattern meeting a housing-fixed one), and the table names order 3 by the crank and
    pillar patterns, with no candidate and those patterns as lacking."""
    spec = catalog.load("rv160n")
    runout = _effect("pin_ring_runout", "rv160n", (10 * UM, 0.0))
    lobes = _effect("pin_position_h3", "rv160n", (4 * UM, 0.0))
    for errors, order, least in ((runout, 78, 0.1), (lobes, 234, 0.1)):
        amp, _ = _added("rv160n", errors, 1280)
        assert amp[order] > least
        assert amp[1:7].max() < 1e-3
    named = name_orders(spec, [3])[0]
    assert named["candidates"] == []
    assert {PART_ERRORS["crank_pattern"].description, PART_ERRORS["pillar_pattern"].description} <= set(named["lacking"])


def test_an_order_beside_the_pin_passing_is_named_a_sideband():
    """RV-80E (pin passing at 40 against the carrier): 82 = 2·40 + 2 and 158 = 4·40 − 2 are no part's own order
    but the pin passing's ripple, present in every unit, modulated twice per output revolution (a ring runout the
    two discs see, the output flange); 37 = 40 − 3 borders it by nothing that turns slowly enough (the crank
    pattern's 2 and the output's 1 in their first two harmonics) and stays unexplained."""
    spec = catalog.load("rv80e")
    k82, k158, k37 = name_orders(spec, [82, 158, 37])
    for row, harmonic, sign in ((k82, 2, "+"), (k158, 4, "−")):
        assert row["parts"] == []
        assert {(s["mesh_key"], s["mesh_harmonic"], s["sign"]) for s in row["sidebands"]
                if s["key"] == "output"} == {("pin_passing", harmonic, sign)}
        assert row["note"].startswith("no part turns at this order itself: a sideband")
        assert f"{harmonic}× pin passing {sign} 2: output flange" in row["note"]
    assert k37["sidebands"] == [] and k37["note"] == NO_PART_NOTE


def test_a_runout_in_a_unit_with_needle_clearance_shows_off_the_pin_period_at_part_load():
    """RV-80E (z_b = 40, z_c = 39) with 2 µm of clearance in every eccentric (needle) bearing: an 8 µm pin-ring
    runout lets the discs float against the ring the carrier carries them past once per output revolution, so
    besides 2·z_c = 78 it shows at 2 (twice the carrier against the housing), at 2·z_b ± 2 = 78, 82 and at
    2·z_c + 2·z_b = 158 (the sidebands of the bearings' order), orders no healthy unit has (not multiples of z_b).
    The free play is what makes them: without clearance the runout gives ≤ 0.02″ there; rated torque closes it
    (≤ 15 % of the part-load amplitudes). The table names the runout at those orders."""
    from rvflex.model import build_reducer
    from rvflex.solve import quasi_static

    spec = catalog.load("rv80e")
    n = 576  # > 2·158 samples per output revolution; every order below 288 resolved

    def amplitudes(clearance: float, runout: float, load: float) -> np.ndarray:
        errors = ErrorSpec(pin_ring_runout_m=runout, pin_ring_runout_phase_rad=0.8,
                           eccentric_bearing_clearance_m=(clearance,) * 4)
        model = build_reducer(spec, errors)
        theta = np.linspace(0.0, 2 * np.pi * model.ratio, n, endpoint=False)
        return order_spectrum(quasi_static(model, theta, load).te_rad, 1.0)[1]

    orders = [2, 78, 82, 158]
    part = amplitudes(2 * UM, 8 * UM, 240.0)
    assert all(part[k] > 0.1 for k in orders), part[orders]
    assert all(amplitudes(0.0, 8 * UM, 240.0)[k] < 0.02 for k in orders)
    assert all(k % spec.cycloid.pin_count for k in orders)
    rated = amplitudes(2 * UM, 8 * UM, spec.rated_torque_Nm)
    assert all(rated[k] < 0.15 * part[k] for k in orders), rated[orders] / part[orders]
    assert part[80] == pytest.approx(amplitudes(2 * UM, 0.0, 240.0)[80], rel=0.25)  # the clearance's own order
    assert all("pin_ring_runout" in row["candidates"] for row in name_orders(spec, orders))

    # three cranks hold the discs: on the RV-160N the same runout and clearance give nothing at 2 (the runout's
    # 2·z_c grows instead), and the table does not name the runout there
    s3 = catalog.load("rv160n")
    errors = ErrorSpec(pin_ring_runout_m=8 * UM, pin_ring_runout_phase_rad=0.8,
                       eccentric_bearing_clearance_m=(2 * UM,) * (s3.cranks.count * len(s3.cycloid.disc_phase_rad)))
    model = build_reducer(s3, errors)
    theta = np.linspace(0.0, 2 * np.pi * model.ratio, n, endpoint=False)
    three = order_spectrum(quasi_static(model, theta, 0.3 * s3.rated_torque_Nm).te_rad, 1.0)[1]
    assert three[2] < 0.01 and three[78] > 0.1
    assert "pin_ring_runout" not in name_orders(s3, [2])[0]["candidates"]

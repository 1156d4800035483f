"""Smoke tests of the seed 000 and seed 003 scenarios at short duration, and the RV-80E
catalogue entry's modification reading (seed 003 eq. 24)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rvflex import catalog
from rvflex.geometry.profile import build_profile
from rvflex.scenarios import rv80e_modifications as m3
from rvflex.scenarios import seed000_dynamic_te as s0
from rvflex.scenarios.loaded_te import seed001_errors


def test_shar110e_spec_every_value_sourced():
    text = s0.SPEC_PATH.read_text(encoding="utf-8")
    for line in text.splitlines():
        if "=" in line and not line.lstrip().startswith("#"):
            comment = line.split("#", 1)[1] if "#" in line else ""
            assert "seed 00" in comment or "assumed" in comment, line
    spec = s0.shar110e_spec()
    assert spec.nominal_ratio == spec.ratio == 81.0
    assert spec.rated_output_speed_rpm == pytest.approx(1600.0 / 81.0)


def test_seed000_dynamic_short_run_engages_and_disengages_pins():
    """0.03 output revolutions at 1600 rpm input (91 ms, more than one 75 ms crank turn): every
    pin force is ≥ 0, pins engage and disengage (each disc has loaded and unloaded pins at every
    instant, and a loaded pin comes free within the window), and the resisting load winds the
    output back (mean TE < 0)."""
    spec = s0.shar110e_spec()
    r = s0.run_seed000(s0.Seed000(spec, errors=seed001_errors(spec), revolutions=0.03, record_every=4))
    f = r.pin_force_N
    assert f.shape[1:] == (2, spec.cycloid.pin_count)
    assert np.all(f >= 0.0)
    loaded = f > 1.0
    assert np.all(loaded.sum(axis=2) >= 2) and np.all(loaded.sum(axis=2) < spec.cycloid.pin_count // 2)
    k = int(np.argmax(f[0, 0]))  # the most loaded pin of disc 1 at the start is free later on
    assert loaded[0, 0, k] and not loaded[:, 0, k].all()
    # the mean wind-up at rated load: a few arcminutes for a 1078 N·m unit, resisting (negative)
    assert -900.0 < r.metrics.mean_windup_arcsec < -60.0
    assert 0.0 < r.metrics.te_pp_arcsec < 100.0


def test_rv80e_catalogue_reads_eq24_literally_and_meets_the_lost_motion_class():
    """Seed 003 eq. 24: R' = R − ΔR, r' = r − Δr with ΔR = 0.027 mm, Δr = 0.022 mm. The
    resulting 5 µm tip/root clearance and working-zone preload keep the lost motion inside the
    maker's ≤ 1′ class (the +22/−27 µm reading gave 4.8′)."""
    from rvflex.scenarios.lost_motion import LostMotion, run_lost_motion
    from rvflex.spec import ErrorSpec

    spec = catalog.load("rv80e")
    m = spec.cycloid.modification
    assert (m.moved_m, m.equidistant_m) == (-2.7e-5, -2.2e-5)
    _, met = run_lost_motion(LostMotion(spec, ErrorSpec(), spec.rated_torque_Nm, 100))
    assert 0.0 < met.lost_motion_arcmin < 1.0
    assert 100.0 < met.torsional_stiffness_Nm_per_arcmin < 400.0  # rigid discs: near the class's 196


def test_pressure_angle_root_relief_is_sharper_than_the_pin():
    """Why seed 003's full pressure-angle scheme does not converge: its root relief makes the
    root concave with a radius below the 3 mm pin radius (pins bridge the root); the tip-only
    variant and the other schemes stay conformable."""
    spec = catalog.load("rv80e")
    pitch = 2 * math.pi / spec.cycloid.disc_teeth
    t = np.linspace(0.0, pitch, 100001)
    for scheme, sharper in (("pressure-angle", True), ("pressure-angle (tip only)", False), ("none", False),
                            ("moved+equidistant", False)):
        c = m3.scheme_spec(spec, scheme).cycloid
        kmin = float(build_profile(c).curvature(t).min())
        assert (kmin < -1.0 / c.pin_radius_m) is sharper, scheme


def test_rv80e_schemes_quasi_static_order():
    """Coarse quasi-static TE: the moved + equidistant profile (preload varying along the flank)
    has more TE than the conjugate theoretical profile, as in seed 003; neither converges to
    a degenerate zero. The full pressure-angle scheme (root relief sharper than the pin: two
    contact points per root pin) converges and falls between them, seed 003's order
    (measured at 256 positions: 0.065″ < 0.240″ < 0.329″)."""
    res = m3.run_schemes(positions=256, modes=("quasi-static",))
    none = res["none"]["quasi-static"]["te_pp_arcsec"]
    me = res["moved+equidistant"]["quasi-static"]["te_pp_arcsec"]
    pa = res["pressure-angle"]["quasi-static"]["te_pp_arcsec"]
    tip = res["pressure-angle (tip only)"]["quasi-static"]["te_pp_arcsec"]
    assert 0.0 < none < me < 5.0
    assert none <= tip < me
    assert none < pa < me

"""The unit's moment rigidity (``MomentRigidity(model="unit")``): the spatial rigid reducer solved by Exudyn at one
crank position with the moment on its carrier, against the main bearing pair alone. Reduced sweeps (two moment
steps each side for the unit, four for the pair): the secant uses only the ends and zero."""

from __future__ import annotations

import numpy as np
import pytest

from rvflex import catalog
from rvflex.spec import SpecError
from scenarios.moment_rigidity import MomentRigidity

SYMMETRY = 0.05
"""± symmetry of the unit's tilt about its zero-moment tilt under rated torque, relative (measured 2.4–3.0 %)."""


@pytest.fixture(scope="module", params=catalog.names())
def rated(request):
    return MomentRigidity(catalog.load(request.param), steps=4, unit_steps=2).run()


def test_every_built_in_unit_gives_a_unit_figure_at_or_a_little_above_the_pairs(rated):
    """The gear train resists the tilt in parallel with the pair: the unit is at least as stiff, and only a little
    (one-way measurements put the gear train's share at 1–3 %; measured 1.0025, 1.0040, 1.0037 for the RV-160N,
    RV-40E, RV-80E at rated torque)."""
    m = rated.metrics
    assert m.model == "unit" and m.moment_rigidity_Nm_per_arcmin == m.unit_moment_rigidity_Nm_per_arcmin
    assert np.isfinite(rated.unit_tilt_rad).all() and len(rated.unit_tilt_rad) == 5
    assert m.unit_torque_Nm == rated.scenario.spec.rated_torque_Nm
    ratio = m.unit_moment_rigidity_Nm_per_arcmin / m.pair_moment_rigidity_Nm_per_arcmin
    assert 1.0 <= ratio <= 1.10
    assert np.all(np.diff(rated.unit_tilt_rad) > 0)  # more moment, more tilt


def test_the_tilt_is_symmetric_in_the_moments_sign(rated):
    """About the zero-moment tilt (the gear train's own couple under torque tilts the carrier a little), +M and −M
    tilt the unit alike within :data:`SYMMETRY`: the offset puts the two ends at slightly different points of the
    pair's S-shaped curve."""
    t = rated.unit_tilt_rad
    k = len(t) // 2
    up, down = t[-1] - t[k], t[k] - t[0]
    assert abs(up - down) <= SYMMETRY * 0.5 * (up + down)


def test_at_zero_torque_the_curve_is_odd():
    """Without torque nothing offsets the carrier: the tilt is odd in the moment to the solver's tolerance, and the
    gear train takes next to no share (measured 1.0000 for the RV-40E)."""
    r = MomentRigidity(catalog.load("rv40e"), steps=4, unit_steps=2, torque_Nm=0.0).run()
    t = r.unit_tilt_rad
    assert t[::-1] == pytest.approx(-t, rel=1e-9, abs=1e-15)
    m = r.metrics
    assert m.unit_moment_rigidity_Nm_per_arcmin == pytest.approx(m.pair_moment_rigidity_Nm_per_arcmin, rel=1e-3)


def test_a_moment_beyond_the_allowable_is_one_clear_line():
    spec = catalog.load("rv80e")
    with pytest.raises(SpecError) as err:
        MomentRigidity(spec, 2.0 * spec.allowable_moment_Nm, model="unit")
    assert str(err.value).splitlines() == ["moment_Nm = 7800.0: must lie in (0, 3900] N·m (the allowable moment of "
                                           "rv80e)"]


def test_an_unknown_model_or_a_negative_torque_is_refused():
    spec = catalog.load("rv40e")
    with pytest.raises(SpecError, match="model = 'both': must be one of unit, pair"):
        MomentRigidity(spec, model="both")
    with pytest.raises(SpecError, match="torque_Nm = -1.0"):
        MomentRigidity(spec, torque_Nm=-1.0)

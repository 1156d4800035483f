"""The flexible pin housing: the pin ring FE-reduced (mount face clamped to ground), its pin
seats carrying the pins into every disc's contact. Coarse reduction (8 mm linear tets, 8
fixed-interface modes + 2 attachment modes per seat: ≈ 3 s cold) so CI stays quick."""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np
import pytest
from conftest import COARSE_DISC

from rvflex import catalog
from rvflex.geometry.formulas import ARCSEC_PER_RAD

COARSE_HOUSING = {"maxh_m": 8e-3, "n_modes": 8, "mesh_order": 1}
"""8 mm linear tets, 8 fixed-interface + 80 seat attachment modes: ≈ 3 s cold on the RV-40E."""


def _carried(contact, seat, phi=None):
    """The contact with its pins on a housing of seat rows ``seat`` (n, 2, h) (and flank rows)."""
    over = {"seat": np.ascontiguousarray(seat), "_t_cache": np.full(len(contact.radii_m), np.nan)}
    if phi is not None:
        over["phi"] = np.ascontiguousarray(phi)
    return dc.replace(contact, **over)


def test_a_seat_translation_moves_the_pins_like_the_disc_moved_back(loaded):
    """Seat rows that translate every pin by (δx, δy) per unit ξ: the gaps are those of the
    disc moved by −δ (to round-off: the contact depends on the pin centre relative to the disc),
    the contact points move with the pins, and the housing's generalised force is minus the
    disc's force (the pins' reaction)."""
    contact, q = loaded
    n = len(contact.radii_m)
    seat = np.zeros((n, 2, 2))
    seat[:, 0, 0] = 1.0
    seat[:, 1, 1] = 1.0
    xi = np.array([0.7e-7, -0.5e-7])
    f_h, _, _, out_h, _ = _carried(contact, seat).evaluate(q, xi=xi)
    moved = q.copy()
    moved[:2] -= xi
    f_r, _, _, out_r, _ = contact.evaluate(moved)
    assert np.max(np.abs(out_h[:, 0] - out_r[:, 0])) < 1e-15
    # the point itself to the closest-point solve's tolerance (1e-11 rad of t × |Q'| ≈ 0.07 m)
    assert np.max(np.abs(out_h[:, 2:4] - (out_r[:, 2:4] + xi))) < 2e-12
    assert np.count_nonzero(out_h[:, 1]) >= 5
    assert np.allclose(f_h[:3], f_r, rtol=1e-9, atol=1e-9)
    assert np.allclose(f_h[3:], -f_r[:2], rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("flexible_disc", [False, True])
def test_jacobian_with_housing_columns_matches_finite_differences(loaded, flexible_disc):
    """K = −∂Q/∂(q, η, ξ) against central differences, random seat rows (every pin its own), at
    rest and deformed by ≈ 0.2 µm, a rigid disc and one with synthetic flank modes: every block
    to 1e-5 of K (the map of each pin to the disc coordinates is exact and linear)."""
    contact, q = loaded
    n = len(contact.radii_m)
    rng = np.random.default_rng(7)
    seat = rng.normal(size=(n, 2, 3))
    phi = None
    m = 0
    if flexible_disc:
        ng = 2048
        t = 2 * math.pi * np.arange(ng) / ng
        phi = np.zeros((ng, 2, 2))
        phi[:, 0, 0], phi[:, 1, 0] = np.cos(3 * t), np.sin(3 * t)
        phi[:, 0, 1], phi[:, 1, 1] = 0.5 * np.sin(2 * t), np.cos(5 * t)
        m = 2
    c = _carried(contact, seat, phi)
    dim = 3 + m + 3
    for state in (np.zeros(m + 3), 1e-7 * rng.normal(size=m + 3)):
        x = np.concatenate([q, state])
        _, k, d, out, _ = c.evaluate(x[:3], eta=x[3:3 + m], xi=x[3 + m:])
        assert np.count_nonzero(out[:, 1]) >= 5
        fd = np.empty((dim, dim))
        for j in range(dim):
            h = np.zeros(dim)
            h[j] = 1e-9
            fp = c.evaluate((x + h)[:3], eta=(x + h)[3:3 + m], xi=(x + h)[3 + m:])[0]
            fm = c.evaluate((x - h)[:3], eta=(x - h)[3:3 + m], xi=(x - h)[3 + m:])[0]
            fd[:, j] = -(fp - fm) / 2e-9
        assert np.max(np.abs(k - fd)) <= 1e-5 * np.abs(fd).max()
        assert np.allclose(k, k.T, atol=1e-6 * np.abs(k).max())  # a potential: no friction, symmetric


@pytest.fixture(scope="module")
def housing(fe_cache):
    from rvflex.fe.reduce import reduce_part

    spec = catalog.load("rv40e")
    return spec, reduce_part(spec, "housing", **COARSE_HOUSING)


def test_the_seat_attachment_modes_make_the_reduction_exact_for_pin_loads(housing):
    """Mount face held, rated torque as tangential pin forces through the seats' couplings:
    reduced = full to round-off (attachment modes); against a cosine seat pressure the seat
    displacement differs by the idealisation (uniform against cosine: 5–25 %); the seats
    move a fraction of a µm (a 16.5 mm steel wall)."""
    _, rp = housing
    assert rp.part == "housing" and len(rp.interfaces) == 41 and rp.n_attach == 80
    assert rp.check.flank_pct < 1e-6
    assert 5.0 < rp.check.interface_pct < 25.0
    assert 0.02e-6 < rp.check.flank_full_m < 1e-6


def _te(spec, theta, reduced_housing=None):
    from rvflex.model import build_reducer
    from rvflex.solve import quasi_static

    model = build_reducer(spec, None, "rigid", reduced_housing=reduced_housing)
    return quasi_static(model, theta, spec.rated_torque_Nm).te_rad * ARCSEC_PER_RAD


def test_stiff_limit_housing_recovers_the_rigid_housing_and_elasticity_is_linear(housing):
    """RV-40E at rated torque over one crank turn (12 positions), rigid discs: the elastic
    housing adds wind-up (−0.5 … −10″: the pin forces ovalise and twist the ring); its
    stiffness × 10 divides that by 10 (within 15 %, the contact is nonlinear); × 1e3 (E × 1e3)
    gives the rigid housing's TE to 0.01″ — the modal node, seat rows and carried pins add
    nothing but the housing's elasticity."""
    spec, rp = housing
    theta = np.linspace(0.0, 2 * np.pi * spec.nominal_ratio / spec.cycloid.pin_count, 12, endpoint=False)
    rigid = _te(spec, theta)
    base = _te(spec, theta, rp) - rigid
    assert -10.0 < base.mean() < -0.5
    ten = _te(spec, theta, dc.replace(rp, stiffness_reduced=rp.stiffness_reduced * 10.0)) - rigid
    assert ten.mean() == pytest.approx(base.mean() / 10.0, rel=0.15)
    stiff = _te(spec, theta, dc.replace(rp, stiffness_reduced=rp.stiffness_reduced * 1e3)) - rigid
    assert np.abs(stiff).max() < 0.01


def test_housing_options_select_the_flexible_housing():
    """``housing`` beside ``discs`` and ``carrier``: the preset, the TOML table and its errors."""
    from rvflex.options import HOUSING_FE, ModelOptions
    from rvflex.spec import SpecError

    full = ModelOptions.preset("flexible-all")
    assert full.housing is HOUSING_FE and full.flexible_discs_on and full.flexible_carrier_on
    assert full.fidelity == "flexible-all"
    coarse = ModelOptions.from_table({"fidelity": "flexible-all", "housing": {"n_modes": 4}})
    assert coarse.housing.n_modes == 4 and coarse.housing.maxh_m == HOUSING_FE.maxh_m
    assert "housing FE" in coarse.describe()
    with pytest.raises(SpecError, match=r"\[model\].housing"):
        ModelOptions.from_table({"fidelity": "flexible", "housing": {"n_modes": 4}})
    with pytest.raises(SpecError, match="housing"):
        ModelOptions(housing="soft")


def test_seed001_parts_scenario_adds_each_parts_wind_up(fe_cache, coarse_disc, housing):
    """The part-by-part scenario on coarse reductions (catalogue RV-40E, no errors, 16 positions
    of one output revolution): every FE part added winds the unit up further, the shares add
    up to 1 and the all-flexible variant is ModelOptions.flexible_all with these reductions."""
    from rvflex.options import CARRIER_FE, DISC_FE, HOUSING_FE, ModelOptions
    from rvflex.scenarios.seed001_flexible import Seed001Parts, run_seed001_parts
    from rvflex.spec import ErrorSpec

    spec, _ = coarse_disc
    sc = Seed001Parts(spec, ErrorSpec(), positions_per_rev=16, discs=dc.replace(DISC_FE, **COARSE_DISC),
                      carrier=dc.replace(CARRIER_FE, maxh_m=8e-3, n_modes=6, mesh_order=1),
                      housing=dc.replace(HOUSING_FE, **COARSE_HOUSING))
    assert list(sc.variants) == ["rigid", "+discs", "+carrier", "+housing"]
    assert sc.variants["+housing"] == dc.replace(ModelOptions.flexible_all(), discs=sc.discs, carrier=sc.carrier,
                                                 housing=sc.housing)
    rows = run_seed001_parts(sc, progress=None)
    w = [r["windup_arcsec"] for r in rows]
    assert w[0] < 0 and all(b < a for a, b in zip(w, w[1:]))  # the output lags more with each elastic part
    assert sum(r["share_of_windup"] for r in rows) == pytest.approx(1.0, abs=1e-12)
    assert 0.005 < rows[3]["share_of_windup"] < 0.05  # the housing: ≈ 1 % (docs/flexible.md)


def test_the_flexible_housing_runs_dynamically(housing):
    """Generalized-α with the housing's reduced mass and stiffness (rigid discs, 412 N·m, 15 rpm
    output, 0.02 s ramp + 0.02 output revolutions): at 10 Hz pin-mesh frequency against housing
    modes above 5 kHz the run is quasi-static, so the wind-up the housing adds is the
    quasi-static one (−2.4″ over a crank turn; within 15 %: the windows differ and the added
    part ripples by ≈ ±0.1″)."""
    from rvflex.model import build_reducer
    from rvflex.solve import dynamic

    spec, rp = housing
    added = []
    for red in (None, rp):
        r = dynamic(build_reducer(spec, None, "rigid", reduced_housing=red), 15.0, 0.02, spec.rated_torque_Nm,
                    ramp_s=0.02)
        te = r.te_rad * ARCSEC_PER_RAD
        added.append(te[len(te) // 2:].mean())
    theta = np.linspace(0.0, 2 * np.pi * spec.nominal_ratio / spec.cycloid.pin_count, 12, endpoint=False)
    quasi = (_te(spec, theta, rp) - _te(spec, theta)).mean()
    assert added[1] - added[0] == pytest.approx(quasi, rel=0.15)

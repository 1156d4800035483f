"""The model discrepancy of the diagnosis: groups per order band and run, the residual it is estimated
from, and the evidence of an effect against it — on features written here, independently of the
model, so that each expectation can be computed by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rvflex.diagnosis.discrepancy import Discrepancy, evidence, feature_groups, residual
from rvflex.diagnosis.effects import EFFECTS
from rvflex.diagnosis.linear import Problem, bounds, lin_fit, make_candidate, nuisance_columns
from rvflex.diagnosis.plan import HYST_FRACTIONS, PlanRun, feature_layout
from rvflex.diagnosis.settings import DiagnosisSettings
from rvflex.diagnosis.verdict import is_significant

Z_B = 40
MAX_ORDER = 127
ARCSEC = 206264.806
FLOOR = 0.05  # arcsec: the order floor of every TE coefficient here
PLAN = (PlanRun("te", "fwd", 1, 400.0), PlanRun("te", "rev", -1, 400.0),
        PlanRun("hysteresis", "cycle", torque_max_Nm=400.0, torque_path_Nm=(0.0, 400.0, 0.0, -400.0, 0.0)))
ECC = EFFECTS["output_encoder_eccentricity"]  # two parameters (rad): TE order 1, cos and sin


def _bench(ecc_arcsec: tuple[float, float], seed: int = 0):
    """Measured features: a model-form discrepancy of 3″ (random phase per run) on the pin-mesh orders 40,
    80, 120, an encoder eccentricity (a, b in arcsec on order 1, the same in both TE runs), and 0.02″ of
    noise on every TE order; zero wind-ups and torque-cycle angles. The model is zero everywhere."""
    rng = np.random.default_rng(seed)
    lay = feature_layout(PLAN, MAX_ORDER)
    y = np.zeros(lay.n)
    for r in lay.te_runs:
        a, b = y[lay.cos[r]], y[lay.sin[r]]
        a += rng.normal(0, 0.02, MAX_ORDER)
        b += rng.normal(0, 0.02, MAX_ORDER)
        for k in (40, 80, 120):
            ph = rng.uniform(0, 2 * np.pi)
            a[k - 1] += 3.0 * math.cos(ph)
            b[k - 1] += 3.0 * math.sin(ph)
        a[0] += ecc_arcsec[0]
        b[0] += ecc_arcsec[1]
        y[lay.cos[r]], y[lay.sin[r]] = a, b
    w = np.full(lay.n, 1.0 / FLOOR)
    prob = Problem.build(y, lay, w, nuisance_columns(lay))
    J = np.zeros((lay.n, 2))
    for r in lay.te_runs:
        J[lay.cos[r].start, 0] = J[lay.sin[r].start, 1] = ARCSEC  # features (arcsec) per rad
    return prob, J


def _fit(prob, J, effects):
    n = prob.lay.n
    n_nuis = prob.nuis.shape[1]
    base = np.zeros(n)
    if not effects:
        x, nu, d, rss, A = lin_fit(prob, base, np.zeros((n, 0)), np.zeros(0), np.zeros(0), np.zeros(0))
        return make_candidate((), x, nu, d, rss, A, n, n_nuis, base, refined=True)
    lo, hi = bounds(effects)
    x, nu, d, rss, A = lin_fit(prob, base, J, np.zeros(2), lo, hi)
    return make_candidate(effects, x, nu, d, rss, A, n, n_nuis, base + J @ x, refined=True, jacobian=J)


def test_the_groups_partition_the_features_by_run_band_and_kind():
    lay = feature_layout(PLAN, MAX_ORDER)
    groups = feature_groups(lay, PLAN, Z_B)
    # every feature's energy in exactly one group: the groups split any vector's squared norm without overlap
    r = np.random.default_rng(0).normal(size=lay.n)
    assert sum(g.energy(r) for g in groups) == pytest.approx(float(r @ r), rel=1e-12)
    assert sum(g.size for g in groups) == lay.n
    mesh = [g for g in groups if g.kind == "mesh orders"]
    assert len(mesh) == 2 and all(g.size == 2 * 3 for g in mesh)  # orders 40, 80, 120: cos and sin
    first = [g for g in groups if g.orders == (1, 1)]
    assert len(first) == 2 and all(g.size == 2 for g in first)
    assert [g.kind for g in groups][-3:] == ["wind-up", "loading curve", "hysteresis"]
    assert groups[-1].size == groups[-2].size == 2 * len(HYST_FRACTIONS)


def test_a_torque_cycle_splits_into_its_loading_curve_and_its_hysteresis():
    # an offset of both branches (a softer unit's same twist both ways) lies in the loading curve alone; branches
    # opened apart symmetrically (friction) in the hysteresis alone
    lay = feature_layout(PLAN, MAX_ORDER)
    curve, loop = feature_groups(lay, PLAN, Z_B)[-2:]
    m = curve.size
    same, opened = np.zeros(lay.n), np.zeros(lay.n)
    same[curve.rows] = 1.0
    opened[curve.rows[:m]], opened[curve.rows[m:]] = 1.0, -1.0
    assert curve.energy(same) == pytest.approx(2 * m) and loop.energy(same) == pytest.approx(0.0, abs=1e-12)
    assert loop.energy(opened) == pytest.approx(2 * m) and curve.energy(opened) == pytest.approx(0.0, abs=1e-12)


def test_the_residual_reproduces_the_fits_weighted_rss():
    prob, J = _bench((3.0, 2.0))
    for c in (_fit(prob, J, ()), _fit(prob, J, (ECC,))):
        r = residual(prob, c)
        assert math.isclose(float(r @ r), c.rss, rel_tol=1e-9)


def test_an_effect_confined_to_one_band_is_evidenced_against_a_larger_discrepancy_elsewhere():
    """A 3.6″ order-1 eccentricity beside 3″ of model-form discrepancy on three mesh orders: it removes
    only 18 % of the weighted gap (the fixed 25 % rule rejected it), but it clears its own band down to
    the floor. Against the discrepancy: each TE run's order-1 group goes from RSS (3.6/0.05)² = 5200 over
    2 features (−2 log L = 2·log(5200/2) + 2 = 17.7) to noise below the floor (≈ 0), 35 for both runs;
    less 2·log(n) for the two parameters, ≈ 22."""
    prob, J = _bench((3.0, 2.0))
    none, c = _fit(prob, J, ()), _fit(prob, J, (ECC,))
    groups = feature_groups(prob.lay, PLAN, Z_B)
    ev = evidence(prob, c, none, Discrepancy.of(prob, none, groups), 0.0)  # each group's own variance
    expected = 2 * (2 * math.log((3.0**2 + 2.0**2) / FLOOR**2 / 2) + 2) - 2 * math.log(prob.lay.n)
    assert abs(ev - expected) < 1.5  # the noise moves each group's RSS by a few per cent
    shrink = 100 * (1 - math.sqrt(c.rss / none.rss))
    assert shrink < 25.0
    # one pooled variance (the default): RSS 32 000 over n features, σ² = 32 000/n; the effect removes 10 400
    pooled = evidence(prob, c, none, Discrepancy.of(prob, none, groups))
    assert math.isclose(pooled, 10400 / (float(residual(prob, none) @ residual(prob, none)) / prob.lay.n)
                        - 2 * math.log(prob.lay.n), rel_tol=0.05)
    import dataclasses as dc

    cand = dc.replace(c, score=ev, gap_shrink_pct=shrink)
    assert is_significant(cand, DiagnosisSettings())
    assert not is_significant(dc.replace(cand, score=none.bic - c.bic), DiagnosisSettings(evidence_model="bic"))
    disc = Discrepancy.of(prob, none, groups)
    by_label = {g.label: s for g, s in zip(disc.groups, disc.sigma)}
    assert by_label["fwd: pin-mesh orders"] > 40  # 3″ on 0.05″ floors at 3 of 6 features: σ = √(3·60²/6) = 42
    assert by_label["fwd: orders 64–127"] == 1.0  # noise below the floor


def test_an_effect_without_signal_gains_no_evidence():
    """The same bench without the eccentricity: the effect fits noise on order 1 only, every group stays at
    its floor or its discrepancy, and the evidence is the parameter penalty, −2·log(n)."""
    prob, J = _bench((0.0, 0.0), seed=3)
    none, c = _fit(prob, J, ()), _fit(prob, J, (ECC,))
    groups = feature_groups(prob.lay, PLAN, Z_B)
    for pooling in (0.0, None):
        ev = evidence(prob, c, none, Discrepancy.of(prob, none, groups), pooling)
        assert ev < 0.0
        assert math.isclose(ev, -2 * math.log(prob.lay.n), abs_tol=0.5)

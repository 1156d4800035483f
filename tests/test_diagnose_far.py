"""Diagnosis through a realistic model-form gap: the data anchor (the unit's stiffness read from the
bench), the orders the bench resolves, the new effect forms, and the rule that an effect the runs
cannot determine is never a finding."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rvflex import catalog
from rvflex.diagnosis.anchor import ANCHOR_MIN_RATIO, anchor, compliance, scale_stiffness
from rvflex.diagnosis.bench import read_bench
from rvflex.diagnosis.effects import EFFECTS
from rvflex.diagnosis.features import features
from rvflex.diagnosis.linear import make_candidate
from rvflex.diagnosis.plan import HYST_FRACTIONS, PlanRun, feature_layout
from rvflex.diagnosis.replay import evaluate
from rvflex.diagnosis.settings import DiagnosisSettings
from rvflex.diagnosis.verdict import undetermined_effect
from rvflex.options import ModelOptions
from rvflex.solve import hysteresis_cycle
from rvflex.spec import ErrorSpec

SPEC = catalog.load("rv40e")
TR = SPEC.rated_torque_Nm
CAL = ("contact_stiffness", "contact_law_form", "needle_bearing_stiffness", "mesh_stiffness", "crank_bearing_clearance")


def _cycle_plan(steps: int = 24) -> tuple[PlanRun, ...]:
    return (PlanRun("hysteresis", "h", torque_max_Nm=TR, torque_path_Nm=tuple(map(float, hysteresis_cycle(TR, steps))),
                    temperature_C=23.0),)


def test_the_anchor_reads_the_units_compliance_from_the_torque_cycle_beyond_half_load():
    """Branch angles written independently of the anchor's code: a 1.2 ″/N·m slope below ±50 % of the
    amplitude (free play and stiffening there) and 0.25 ″/N·m beyond it, on both branches, plus a
    hysteresis offset. The compliance read is the slope beyond ±50 % (the catalogue's stiffness), and
    the anchor against a model twice as compliant is ×2 (applied: beyond ANCHOR_MIN_RATIO)."""
    plan = _cycle_plan()
    lay = feature_layout(plan, 16)
    t = np.concatenate([-HYST_FRACTIONS[::-1], HYST_FRACTIONS]) * TR

    def branch(c_far, offset):
        near = np.clip(t, -0.5 * TR, 0.5 * TR)
        return 1.2 * near + c_far * (t - near) + offset

    f = np.zeros(lay.n)
    f[lay.hyst[0]] = np.concatenate([branch(0.25, 30.0), branch(0.25, -30.0)])
    c, src = compliance(f, lay, plan)
    assert src == "torque cycle" and c == pytest.approx(0.25, rel=1e-9)
    g = f.copy()
    g[lay.hyst[0]] = np.concatenate([branch(0.5, 10.0), branch(0.5, -10.0)])
    a = anchor(f, g, lay, plan)  # bench f, model g: the unit is twice as stiff
    assert a.ratio == pytest.approx(2.0, rel=1e-9) and a.scale == pytest.approx(2.0) and a.applied
    assert a.bench_Nm_per_arcmin == pytest.approx(60 / 0.25) and "2.00× stiffer" in a.sentence()
    near = anchor(f, f * 1.1, lay, plan)  # within the component priors: not applied
    assert near.ratio < ANCHOR_MIN_RATIO and not near.applied
    far = anchor(f, g * 10.0, lay, plan)  # ×20: clipped to the global range, and said so
    assert far.scale == pytest.approx(3.0) and "another unit" in far.sentence()


def test_the_anchor_reads_the_wind_up_change_between_two_loads_without_a_torque_cycle():
    """Without a torque cycle the unit's compliance comes from the mean TE of two forward runs at 412
    and 206 N·m (the common TE offset cancels in their difference)."""
    plan = (PlanRun("te", "a", 1, 412.0), PlanRun("te", "b", 1, 206.0), PlanRun("te", "c", -1, 412.0))
    lay = feature_layout(plan, 8)
    f = np.zeros(lay.n)
    for r, p in enumerate(plan):
        f[lay.dc[r]] = 500.0 - p.direction * 0.3 * p.load_Nm  # output lags by 0.3 ″/N·m, offset 500″
    c, src = compliance(f, lay, plan)
    assert src == "wind-up" and abs(c) == pytest.approx(0.3, rel=1e-9)
    none = anchor(f[:0], f[:0], feature_layout((), 8), ())
    assert not none.source and not none.applied and "do not measure" in none.sentence()


def test_scaling_every_stiffness_by_two_halves_the_torque_cycle_compliance():
    """scale_stiffness multiplies every modulus, bearing and mesh stiffness: the rigid model's
    torque-cycle slope beyond ±50 % T_r (contact and needle bearings in series) halves to within 3 %
    (the line contact's compliance has a logarithmic term in the contact width, which depends on E)."""
    plan = _cycle_plan()
    s = DiagnosisSettings(max_order=16, hysteresis_steps=24).for_spec(SPEC)
    c = []
    for spec in (SPEC, scale_stiffness(SPEC, 2.0)):
        f, lay = features(evaluate(spec, ErrorSpec(), plan, s), plan, s)
        c.append(compliance(f, lay, plan)[0])
    assert c[0] > 0 and c[1] / c[0] == pytest.approx(0.5, abs=0.015)
    assert scale_stiffness(SPEC, 1.0) is SPEC
    # the main bearing pair's stiffness is its balls' Hertz contacts: their modulus scales
    pair, doubled = SPEC.bearings.main_pair, scale_stiffness(SPEC, 2.0).bearings.main_pair
    assert doubled.material.youngs_modulus_Pa == 2.0 * pair.material.youngs_modulus_Pa
    assert doubled.ball_diameter_m == pair.ball_diameter_m


def test_a_series_compliance_twists_the_output_with_the_torque_and_adds_no_ripple():
    """output_series_compliance adds −d·θ_s(L) to a TE run (lagging like the wind-up) and θ_s(T) to a
    torque cycle, with θ_s = a_lin·T/T_r + a_nl·sgn(T)(|T|/T_r)^(2/3); the TE ripple is unchanged."""
    e = EFFECTS["output_series_compliance"]
    plan = (PlanRun("te", "f", 1, 0.5 * TR), PlanRun("te", "r", -1, 0.5 * TR)) + _cycle_plan()
    s = DiagnosisSettings(max_order=16, hysteresis_steps=24).for_spec(SPEC)
    x = np.array([20e-6, 10e-6])
    base = evaluate(SPEC, ErrorSpec(), plan, s)
    with_c = evaluate(SPEC, ErrorSpec(), plan, s, ((e, x),))
    twist = 20e-6 * 0.5 + 10e-6 * 0.5 ** (2 / 3)
    np.testing.assert_allclose(with_c.te[0] - base.te[0], -twist, atol=1e-15)
    np.testing.assert_allclose(with_c.te[1] - base.te[1], +twist, atol=1e-15)
    t = np.asarray(base.torque[2]) / TR
    np.testing.assert_allclose(with_c.theta[2] - base.theta[2],
                               20e-6 * t + 10e-6 * np.sign(t) * np.abs(t) ** (2 / 3), atol=1e-15)


def test_output_friction_has_a_coulomb_and_a_load_proportional_part():
    """A TE run at load L sees L + T_c + μ·L; in a torque cycle the mesh lags the applied torque by
    T_c + μ|T| once sliding."""
    e = EFFECTS["output_friction"]
    te = e.conditions(PlanRun("te", "f", 1, 400.0), np.array([0.01, 0.02]), SPEC)
    assert te.load_Nm == pytest.approx(400.0 + 0.01 * TR + 0.02 * 400.0)
    path = (0.0, 100.0, 200.0, 100.0, 0.0)
    cyc = e.conditions(PlanRun("hysteresis", "h", torque_max_Nm=200.0, torque_path_Nm=path), np.array([0.0, 0.1]), SPEC)
    # sliding up: T − 0.1·T; at the reversal stuck until T has fallen by 2·T_f
    assert cyc.torque_eff_Nm == pytest.approx((0.0, 90.0, 180.0, 110.0, 0.0))


def test_an_effect_whose_interval_includes_zero_is_not_a_finding():
    """A candidate whose 95 % magnitude interval reaches zero, or whose parameter sits at its bound,
    is never a finding: undetermined_effect names why. Built from a fit whose column is weak (the
    interval spans zero) and one whose column is strong."""
    e = EFFECTS["eccentric_bearing_clearance"]
    n = 60
    rng = np.random.default_rng(3)
    col = rng.normal(size=(n, 1))
    weak = make_candidate((e,), np.array([2e-6]), np.zeros(0), 0.0, float(n), col * 1e4, n, 0, np.zeros(n),
                          refined=True)
    assert weak.magnitude_interval[0][0] == 0.0
    assert "includes zero" in undetermined_effect(weak)
    strong = make_candidate((e,), np.array([2e-6]), np.zeros(0), 0.0, float(n), col * 1e8, n, 0, np.zeros(n),
                            refined=True)
    assert strong.magnitude_interval[0][0] > 0.0 and undetermined_effect(strong) == ""
    at_bound = make_candidate((e,), np.array([e.params[0].high]), np.zeros(0), 0.0, float(n), col * 1e8, n, 0,
                              np.zeros(n), refined=True)
    assert "bound" in undetermined_effect(at_bound)


def test_the_withheld_runs_confirm_by_the_pooled_share_or_by_replicated_folds():
    """An effect is confirmed when the pooled prediction of the withheld runs improves by 10 %, or when two
    folds each improve with evidence >= 10 (2 log of a "very strong" Bayes factor against the pooled
    discrepancy), none is worse by as much, and the pooled prediction improves at all. One strong fold alone
    (a foreign-bench control's thermal candidate: +5 %, folds 18, 0, 0) does not confirm; a friction that
    predicts both halves of the torque cycle (+8.7 %, folds -6, 22, 23) does."""
    from rvflex.diagnosis.settings import DiagnosisSettings
    from rvflex.diagnosis.verdict import withheld_confirms

    s = DiagnosisSettings()

    def wh(pct, *ev):
        return {"improvement_pct": pct, "folds": [{"evidence": v} for v in ev]}

    assert withheld_confirms(wh(12.0, -50.0, 0.0, 0.0), s)  # the pooled rule alone, as before
    assert withheld_confirms(wh(8.7, -6.0, 22.0, 23.0), s)
    assert not withheld_confirms(wh(5.0, 18.0, 0.0, 0.0), s)
    assert not withheld_confirms(wh(6.0, -15.0, 30.0, 30.0), s)  # one fold predicted worse by >= 10
    assert not withheld_confirms(wh(-1.0, 2.0, 12.0, 12.0), s)  # the pooled prediction is worse
    assert not withheld_confirms(wh(None), s) and not withheld_confirms(wh(8.7, None, 22.0, 23.0), s)
    assert not withheld_confirms(wh(8.7, -6.0, 22.0, 23.0), DiagnosisSettings(confirming_folds=None))


def test_the_clearance_class_bounds_the_units_total_crank_bearing_clearance():
    """The calibrated crank-bearing clearance adds to the spec's nominal one at most what is left of the
    class: the clearance that alone spends the maker's lost-motion class, LM·r_c/2 (1′ on the RV-40E's
    36 mm crank circle: 5.24 µm; the runs see the total only). The catalogue unit (0 µm stated) gets all of
    it, a spec stating 3 µm the rest, one stating 5.5 µm none, with the reason; a spec that states no
    lost-motion class keeps the 0 … 10 µm class."""
    import dataclasses

    from rvflex.diagnosis.nominal import nominal_parameters

    def clearance(stated_m, spec=SPEC):
        b = spec.bearings
        spec = dataclasses.replace(spec, bearings=dataclasses.replace(
            b, eccentric=dataclasses.replace(b.eccentric, clearance_m=stated_m)))
        cal, dropped = nominal_parameters(("contact_stiffness", "crank_bearing_clearance"), spec)
        return {e.name: e for e in cal}.get("crank_bearing_clearance"), dropped

    top = math.radians(1.0 / 60.0) * 0.036 / 2  # 1′ over the RV-40E's 36 mm crank circle radius, both ways
    assert SPEC.catalogue_lost_motion_arcmin == 1.0 and SPEC.cranks.crank_circle_radius_m == 0.036
    whole, _ = clearance(0.0)
    assert whole.params[0].high == pytest.approx(top, abs=1e-12)
    part, _ = clearance(3e-6)
    assert part.params[0].high == pytest.approx(top - 3e-6, abs=1e-12)
    assert part.params[0].step == pytest.approx(top - 3e-6)  # the step stays inside the room
    none, dropped = clearance(5.5e-6)
    assert none is None and "5.5 µm" in dropped["crank_bearing_clearance"]
    unstated, _ = clearance(3e-6, dataclasses.replace(SPEC, catalogue_lost_motion_arcmin=None))
    assert unstated.params[0].high == pytest.approx(7e-6, abs=1e-12)


@pytest.mark.parametrize("name", ["rv80e", "rv160n"])
def test_a_crank_bearing_clearance_opens_twice_its_size_over_the_crank_circle_at_the_output(name):
    """The clearance class rests on a lever: a radial clearance c in every eccentric bearing lets the carrier
    turn c/r_c either way against the discs, 2c/r_c of free play at the output, on two cranks and on three.
    The model's backlash (width at zero torque of the rigid unit's torque cycle) grows by that for 4 µm, to
    within 6 % (measured: −4.6 % on the RV-80E, whose preloaded profile takes up a little of it; +5.0 % on the
    RV-160N)."""
    from rvflex.scenarios.lost_motion import LostMotion, run_lost_motion

    spec = catalog.load(name)
    n = spec.cranks.count * spec.cycloid.disc_count
    c = 4e-6
    base, wide = (run_lost_motion(LostMotion(spec, ErrorSpec(eccentric_bearing_clearance_m=(x,) * n),
                                             spec.rated_torque_Nm, steps=120))[1] for x in (0.0, c))
    grown = math.radians((wide.backlash_arcmin - base.backlash_arcmin) / 60.0)
    assert grown == pytest.approx(2 * c / spec.cranks.crank_circle_radius_m, rel=0.06)


def test_a_clearance_beyond_the_class_is_stated_with_its_total_and_the_class_top_is_no_limit():
    """With the crank-bearing clearance calibrated at its class top and the eccentric-bearing clearance fitted
    beyond it, the verdict gives the total the runs determine (6.11 + 2.79 = 8.90 µm) and does not call the
    class top a bound the fit hit: that is where the effect begins. A bound of another parameter still is."""
    import dataclasses

    from rvflex.diagnosis.linear import make_candidate
    from rvflex.diagnosis.nominal import NOMINAL, nominal_parameters
    from rvflex.diagnosis.settings import DiagnosisSettings
    from rvflex.diagnosis.verdict import verdict

    spec = catalog.load("rv80e")
    clr = {e.name: e for e in nominal_parameters(None, spec)[0]}["crank_bearing_clearance"]
    top = clr.params[0].high
    assert top == pytest.approx(6.109e-6, rel=1e-3)
    n = 40

    def said(effects, x):
        c = make_candidate(effects, np.array(x), np.zeros(0), 0.0, 10.0, np.eye(n)[:, :len(x)], n, 0, np.zeros(n),
                           refined=True)
        c = dataclasses.replace(c, gap_shrink_pct=65.0, withheld={"improvement_pct": 61.0})
        return verdict([c], c, None, True, DiagnosisSettings(), {}, {})

    ecc = EFFECTS["eccentric_bearing_clearance"]
    v = said((clr, ecc), [top, 2.79e-6])
    assert "explains the gap" in v
    assert "8.90 µm in all" in v and "class of at most 6.11 µm" in v and "hits a parameter bound" not in v, v
    stiff = NOMINAL["contact_stiffness"]
    v = said((stiff, clr, ecc), [stiff.params[0].low, top, 2.79e-6])
    assert "hits a parameter bound (contact_stiffness.compliance_change)" in v, v


def test_the_selfcheck_hides_a_clearance_beyond_the_class():
    """A hidden crank-bearing clearance is what lies beyond the nominal class (0 … 5.24 µm of total on the
    RV-40E): the self-check's drawn 8 µm becomes the excess over the class top, 5.24 − 3 + 8 = 10.24 µm on a
    3 µm nominal clearance (total 13.24 µm); other effects keep their drawn values."""
    from rvflex.diagnosis.nominal import clearance_class_top
    from rvflex.diagnosis.selfcheck import beyond_the_class

    ecc, run = EFFECTS["eccentric_bearing_clearance"], EFFECTS["pin_ring_runout"]
    out = dict((e.name, x) for e, x in beyond_the_class([(ecc, np.array([8e-6])), (run, np.array([4e-6, 1e-6]))],
                                                           SPEC, 3e-6))
    assert out[ecc.name][0] == pytest.approx(clearance_class_top(SPEC) - 3e-6 + 8e-6, abs=1e-12)
    assert np.array_equal(out[run.name], [4e-6, 1e-6])


def test_the_selfcheck_never_hides_an_effect_at_its_bound():
    """A parameter at its bound is reported as a limit, never as a finding (rule of the verdict), so a hidden
    value there is one no diagnosis may name: a draw beyond its side of the range (a negative thermal
    mismatch, 6.9-16 ppm/K drawn against the -5 ppm/K bound) is redrawn inside it, at 40-80 % of that side."""
    from rvflex.diagnosis.selfcheck import draw_truth

    rng = np.random.default_rng(7)
    effects = tuple(EFFECTS.values())
    thermal = []
    for _ in range(1000):  # thermal is one of ~20 effects: ~40 negative draws
        for e, x in draw_truth(rng, effects, 2):
            assert np.all(x > e.lower) and np.all(x < e.upper), (e.name, x)
            if e.name == "thermal_expansion":
                thermal.append(x[0])
    neg = [v for v in thermal if v < 0]  # before: every dominant one at -5e-6 exactly
    assert len(neg) > 20 and len(set(neg)) == len(neg) and min(neg) > -5e-6


def test_the_analysed_orders_follow_the_bench_sampling(tmp_path):
    """1024 samples per revolution resolve orders up to 255 (MAX_ORDER_CAP; a 3rd-harmonic pin pattern's
    TE sits at order 6·z_c = 234), 512 up to 128; the model grid follows, alias-free."""
    from rvflex.diagnosis.bench import BenchDataset, BenchRun, write_bench

    ratio = SPEC.nominal_ratio
    for n, k in ((1024, 255), (512, 128)):
        p = 2 * np.pi * np.arange(n) / n
        run = BenchRun("te.csv", "te", np.arange(n) * 0.01, ratio * p, p, np.full(n, 412.0), direction="forward",
                       load_Nm=412.0, speed_out_rpm=15.0)
        write_bench(tmp_path / str(n), BenchDataset(SPEC, "rv40e", (run,)))
        s = DiagnosisSettings().for_dataset(read_bench(tmp_path / str(n)))
        assert s.max_order == k and s.positions_per_rev >= 2 * k + 2


# ----------------------------------------------------------------------------- far from the catalogue: CI size

CI = DiagnosisSettings(hysteresis_steps=24, refine_top=2, refine_iterations=3, workers=2)


def _far_bench(tmp_path, hidden, scale, samples_per_rev=512, positions=640, clearance_m=3e-6):
    """A bench from another model family (power-law contact, needle bearings and mesh) whose every
    stiffness is ``scale`` times the diagnosing model's, with a nominal crank-bearing clearance; rigid
    for CI time. The generator's grid (640 positions) resolves the pin-mesh harmonics up to 7·z_b and
    folds none into the analysed orders (at 256, 4·z_b fell on order 96 and 5·z_b on 56: TE no model
    of the unit has)."""
    from rvflex.diagnosis.selfcheck import GeneratorModel, RealisticMismatch, generate_case

    drawn = {"contact_scale": scale, "needle_bearing_scale": scale, "mesh_scale": scale, "clearance_m": clearance_m,
             "global_scale": scale}
    gen = RealisticMismatch(options=ModelOptions.rigid(), samples_per_rev=samples_per_rev, fixed=tuple(drawn.items()))
    generate_case(tmp_path / "bench", tmp_path / "truth.json", SPEC, hidden, np.random.default_rng(11),
                  gen=GeneratorModel(positions_per_rev=positions, hysteresis_steps=48), realistic=gen)
    return read_bench(tmp_path / "bench")


@pytest.mark.slow
def test_a_far_mismatch_control_is_nominal_parameters_off(tmp_path):
    """No hidden effect; every stiffness of the unit 1.8× the model's (the foreign bench's RV-40E
    measures 275–290 N·m/arcmin against the catalogue model's 159): the anchor reads it from the torque
    cycle, calibration takes the rest, and no effect is accepted."""
    from rvflex.diagnosis.fit import diagnose

    ds = _far_bench(tmp_path, [], 1.8)
    diag = diagnose(ds, settings=CI, nominal=CAL, cache_dir=tmp_path / "cache",
                    effects=("eccentric_bearing_clearance", "pin_ring_runout", "output_series_compliance"))
    assert diag.anchor.applied and diag.anchor.ratio == pytest.approx(1.8, rel=0.2), diag.anchor
    assert diag.verdict.startswith("On the torque cycle the unit is")
    assert diag.chosen is None, diag.verdict
    assert "Nominal parameters off; no unmodelled effect" in diag.verdict


@pytest.mark.slow
def test_a_clearance_is_found_through_a_1_8_stiffness_mismatch(tmp_path):
    """A 10 µm eccentric-bearing clearance beyond a 3 µm nominal one, in a unit 1.8× stiffer than the
    model (the foreign bench's H01): accepted, with the total clearance (nominal + excess, the part the
    data determine) within ±25 % of 13 µm. (The self-check's generator takes a hidden clearance as the
    excess over the 5.24 µm class top, ``beyond_the_class``: 7.76 µm here, 13 µm total.) (The same test with an 8 µm pin-ring runout instead fails on
    this rigid power-law generator: the runout removes 11 % of what calibration leaves and predicts the
    withheld runs worse; the foreign bench's 8 µm ring offset is found. Stated in docs/diagnosis.md.)"""
    from rvflex.diagnosis.fit import diagnose
    from rvflex.diagnosis.nominal import clearance_class_top

    # the generator adds what the class leaves above the 3 µm nominal clearance
    hidden = [(EFFECTS["eccentric_bearing_clearance"], np.array([13e-6 - clearance_class_top(SPEC)]))]
    ds = _far_bench(tmp_path, hidden, 1.8)
    diag = diagnose(ds, settings=CI, nominal=CAL, cache_dir=tmp_path / "cache",
                    effects=("eccentric_bearing_clearance", "pin_ring_runout", "disc_modification_deviation"))
    assert diag.anchor.applied and diag.anchor.ratio > 1.25
    assert diag.chosen is not None and diag.chosen.name == "eccentric_bearing_clearance", diag.verdict
    total = diag.chosen.magnitude_of("eccentric_bearing_clearance") + diag.chosen.magnitude_of("crank_bearing_clearance")
    assert total == pytest.approx(13e-6, rel=0.25)


@pytest.mark.slow
def test_an_order_234_signature_is_found_from_1024_sample_runs(tmp_path):
    """A 4 µm 3rd-harmonic pin pattern puts its TE at order 6·z_c = 234, beyond the former 127 analysed
    orders: from 1024-sample runs the diagnosis analyses orders up to 255 and finds it."""
    from rvflex.diagnosis.fit import diagnose

    e = EFFECTS["pin_position_h3"]
    hidden = [(e, np.array([4e-6 * math.cos(0.8), 4e-6 * math.sin(0.8)]))]
    ds = _far_bench(tmp_path, hidden, 1.0, samples_per_rev=1024, positions=1024, clearance_m=1e-6)
    diag = diagnose(ds, settings=CI, nominal=CAL, cache_dir=tmp_path / "cache",
                    effects=("pin_position_h2", "pin_position_h3", "pin_ring_runout"))
    assert diag.settings.max_order == 255
    assert diag.chosen is not None and diag.chosen.name == "pin_position_h3", diag.verdict


def test_an_effect_the_calibration_can_stand_in_for_is_named_as_a_tie():
    """Signatures written here: a series compliance whose two columns, at their typical size, are
    combinations of the contact and needle-bearing stiffness columns within those parameters' prior
    ranges (0.3·a + 0.2·b and 0.1·a + 0.4·b) is a look-alike of the calibration and named with its
    separating runs; an encoder eccentricity with independent columns is not."""
    from rvflex.diagnosis.calibration import calibration_lookalikes, lookalike_sentence
    from rvflex.diagnosis.linear import Sensitivities
    from rvflex.diagnosis.nominal import NOMINAL

    rng = np.random.default_rng(7)
    n = 200
    a, b = rng.normal(size=n), rng.normal(size=n)
    ser, enc = EFFECTS["output_series_compliance"], EFFECTS["output_encoder_eccentricity"]
    steps = [p.step for p in ser.params]
    sens = Sensitivities(plus={"contact_stiffness": a[:, None], "needle_bearing_stiffness": b[:, None],
                               ser.name: np.column_stack([(0.3 * a + 0.2 * b) / steps[0], (0.1 * a + 0.4 * b) / steps[1]]),
                               enc.name: rng.normal(size=(n, 2)) / enc.params[0].step}, minus={})
    cal = (NOMINAL["contact_stiffness"], NOMINAL["needle_bearing_stiffness"])
    calibrated = make_candidate(cal, np.zeros(2), np.zeros(0), 0.0, float(n), np.column_stack([a, b]), n, 0,
                                np.zeros(n), refined=True)
    out = calibration_lookalikes((ser, enc), calibrated, sens, np.ones(n))
    assert list(out) == [ser.name]
    names, runs, ratio, part = out[ser.name]
    assert set(names) == {"contact_stiffness", "needle_bearing_stiffness"} and ratio < 1e-6 and part == ()
    assert runs[0] == ser.separating_runs
    text = lookalike_sentence(out)
    assert ser.name in text and "at the reducer's flange" in text and "100 %" in text
    # 80 % reproduced (a part c the stiffnesses cannot make): a tie only while what is left is below the
    # discrepancy — its energy (0.08²·n ≈ 1.3 floor units²) over the pooled variance under the threshold
    c = rng.normal(size=n)
    sens.plus[ser.name] = np.column_stack([(0.3 * a + 0.2 * b + 0.08 * c) / steps[0],
                                           (0.1 * a + 0.4 * b + 0.08 * c) / steps[1]])
    assert calibration_lookalikes((ser,), calibrated, sens, np.ones(n)) == {}  # beyond CALIBRATION_PREFERRED
    assert ser.name in calibration_lookalikes((ser,), calibrated, sens, np.ones(n), pool=1.0, threshold=10.0)
    assert calibration_lookalikes((ser,), calibrated, sens, np.ones(n), pool=0.05, threshold=10.0) == {}
    # the linear part alone reproduced (the stiffening part has c of its own): that part is named
    sens.plus[ser.name] = np.column_stack([(0.3 * a + 0.2 * b) / steps[0], (0.1 * a + 0.4 * b + 0.3 * c) / steps[1]])
    out = calibration_lookalikes((ser,), calibrated, sens, np.ones(n))
    assert out[ser.name][3] == ("linear_twist_rad",)
    assert "output_series_compliance (its linear_twist_rad) from the calibrated" in lookalike_sentence(out)
    assert calibration_lookalikes((enc,), calibrated, sens, np.ones(n)) == {}
    # an effect on the nominal clearance's own quantity is what lies beyond its range: never listed
    ecc = EFFECTS["eccentric_bearing_clearance"]
    sens.plus[ecc.name] = a[:, None] / ecc.params[0].step
    assert calibration_lookalikes((ecc,), calibrated, sens, np.ones(n)) == {}


def test_the_separable_part_is_what_the_calibration_cannot_make_within_its_ranges():
    """Signatures written here: a change 0.3·a + 0.2·b + 0.08·c of the contact (a) and needle-bearing (b)
    columns and a part c of its own leaves ‖0.08·c‖ separable; the same change at ten times the size asks the
    stiffnesses for steps beyond their prior ranges, so more of it is separable; a two-sided effect's negative
    value takes its −step secant."""
    from rvflex.diagnosis.calibration import separable
    from rvflex.diagnosis.linear import Sensitivities
    from rvflex.diagnosis.nominal import NOMINAL

    rng = np.random.default_rng(3)
    n = 300
    a, b, c = rng.normal(size=n), rng.normal(size=n), rng.normal(size=n)
    cal = (NOMINAL["contact_stiffness"], NOMINAL["needle_bearing_stiffness"])
    sens = Sensitivities(plus={"contact_stiffness": a[:, None], "needle_bearing_stiffness": b[:, None]}, minus={})
    calibrated = make_candidate(cal, np.zeros(2), np.zeros(0), 0.0, float(n), np.column_stack([a, b]), n, 0,
                                np.zeros(n), refined=True)
    sig = 0.3 * a + 0.2 * b + 0.08 * c
    size, sep = separable(sig, calibrated, sens, np.ones(n))
    assert size == pytest.approx(np.linalg.norm(sig))
    assert sep == pytest.approx(np.linalg.norm(0.08 * c), rel=0.05)  # (c is nearly orthogonal to a and b)
    _, sep10 = separable(10 * sig, calibrated, sens, np.ones(n))
    assert sep10 > 10 * sep * 1.5  # 3·a is beyond the contact stiffness's range: the calibration cannot take it all
    thermal = EFFECTS["thermal_expansion"]
    sens = Sensitivities(plus={thermal.name: a[:, None]}, minus={thermal.name: -b[:, None]})
    assert np.allclose(sens.change_at(thermal.name, [2e-6]), 2e-6 * a)
    assert np.allclose(sens.change_at(thermal.name, [-2e-6]), 2e-6 * b)


@pytest.mark.slow
def test_a_series_compliance_the_calibration_mimics_is_found_from_the_nominal_model(tmp_path):
    """The hidden effect of the same-family self-check's seed 1, case 0, on a bench generated afresh (another
    noise draw, four candidates): a series compliance (linear and stiffening twist 113 and 112 µrad at rated
    torque) on the unit as the model has it. The calibration takes it as stiff contacts (×3.33, at its bound)
    and soft needle bearings (×0.46); linearised about that mix the compliance finds nothing (measured: a
    modification deviation is accepted instead; asserted: not the compliance). Linearised also about the
    nominal model (``nominal_start``, the default) it is found and ranked first; its size (37″ at rated torque)
    is within what healthy units of other model forms reach (a flange or coupling compliance is among their
    forms: the shipped null distribution), so it is graded consistent, not established."""
    from rvflex.diagnosis.fit import diagnose
    from rvflex.diagnosis.selfcheck import generate_case

    ser = EFFECTS["output_series_compliance"]
    generate_case(tmp_path / "bench", tmp_path / "truth.json", SPEC, [(ser, np.array([1.128e-4, 1.116e-4]))],
                  np.random.default_rng(7))
    ds = read_bench(tmp_path / "bench")
    effects = ("output_series_compliance", "disc_modification_deviation", "thermal_expansion",
               "eccentric_bearing_clearance")
    found = diagnose(ds, cache_dir=tmp_path / "cache", effects=effects)
    top = found.candidates[0]
    assert top.name == ser.name and top.refined, found.verdict
    assert top.grade["grade"] == "consistent but not established" and found.chosen is None
    assert any("healthy units of other model forms reach" in f for f in top.grade["fails"])
    calibrated = {e.name: float(x[0]) for e, x in found.baseline.split()}
    assert calibrated["contact_stiffness"] == pytest.approx(-0.7, abs=0.01)  # its bound, ×3.33: the mimicking mix
    assert calibrated["needle_bearing_stiffness"] > 0.5
    about_calibration = diagnose(ds, settings=DiagnosisSettings(nominal_start=False), cache_dir=tmp_path / "cache",
                                 effects=effects)
    assert about_calibration.chosen is None or about_calibration.chosen.name != ser.name


def test_the_fidelity_difference_measured_about_the_calibration_is_the_model_run_there():
    """A fidelity effect acts as the difference its model makes, added by its share. Measured about the
    nominal model, the point contact's difference is wrong about a calibration with the contact twice as
    stiff and a 6 µm crank-bearing clearance (the point law's stiffness grows as the moduli^1.5, the line
    law's as the moduli; the free play moves where the pins first touch); measured again about that point
    (what the diagnosis does about its calibration), the blended features are the model run's there.
    Rigid contact-law form for CI time; the diagnosis blends it on the flexible model."""
    import dataclasses as dc

    from rvflex.diagnosis.nominal import NOMINAL
    from rvflex.diagnosis.refine import evaluate_sets
    from rvflex.diagnosis.runs import ModelRunner
    from rvflex.diagnosis.sensitivity import rebase_fidelity, sensitivities

    law_form = dc.replace(NOMINAL["contact_law_form"], options=ModelOptions.rigid())
    clr, stiff = NOMINAL["crank_bearing_clearance"], NOMINAL["contact_stiffness"]
    plan = (PlanRun("te", "f", 1, 0.5 * TR),) + _cycle_plan(16)
    s = DiagnosisSettings(hysteresis_steps=16).for_spec(SPEC)
    runner = ModelRunner(SPEC, ErrorSpec(), plan, s, None, None)
    f0, resp0, _ = runner.run([()])[0]
    _, lay = features(resp0, plan, s)
    sens, failed = sensitivities(runner, (law_form, clr, stiff), f0, resp0, plan, s, lay)
    assert not failed
    base = ((stiff, np.array([-0.5])), (clr, np.array([6e-6])))
    point = base + ((law_form, np.array([1.0])),)
    exact = runner.run([point])[0][0]
    fb, rb, _ = runner.run([base])[0]
    runs = runner.model_runs
    again = runner.run([base])[0][0]  # the same point again, no disk cache: not run again, a copy of the run
    assert runner.model_runs == runs and np.array_equal(again, fb) and again is not fb
    twice = runner.run([((clr, np.array([3e-6])),)] * 2)  # one batch asking twice: run once, two copies
    assert runner.model_runs == runs + 1 and np.array_equal(twice[0][0], twice[1][0]) and twice[0][0] is not twice[1][0]
    rebased, failed = rebase_fidelity(runner, sens, (stiff, clr, law_form), base, fb, rb, resp0, lay)
    assert not failed and rebased.base == {}  # no effect coupled to a fidelity model: nothing to offset
    te = np.zeros(lay.n, bool)
    for r in lay.te_runs:
        te[lay.cos[r]] = te[lay.sin[r]] = True
    law = exact - fb  # the difference the law makes at that point

    def error(sn, part):
        f = evaluate_sets(runner, sn, resp0, [point], f0, lay)[0][0]
        return float(np.linalg.norm((f - exact)[part]) / np.linalg.norm(law[part]))

    # measured: 46 % of the law's difference missed on all features, 100 % on the TE orders
    assert error(sens, slice(None)) > 0.3 and error(sens, te) > 0.6
    # the model's numerical noise cleared (denoise_orders), nothing else
    assert error(rebased, slice(None)) < 0.02 and error(rebased, te) < 0.02


def test_the_contact_stiffness_range_keeps_the_anchored_moduli_within_the_spec_rule():
    """The contact stiffness scales the disc and pin moduli; anchored ×1.68 (the foreign bench's H02), its
    ×3.3 component bound would put the 219 GPa pins at 1230 GPa, which a spec refuses (so the model cannot be run there):
    the range stops at 1000 GPa. At the catalogue stiffness the stated range stays."""
    from rvflex.diagnosis.nominal import MODULUS_MAX_PA, NOMINAL, stiffness_scale, within_spec_rules

    cal = (NOMINAL["contact_stiffness"], NOMINAL["needle_bearing_stiffness"])
    assert within_spec_rules(cal, SPEC) == cal
    anchored = scale_stiffness(SPEC, 1.68)
    cut = within_spec_rules(cal, anchored)
    assert cut[1] == cal[1]
    e_max = max(anchored.materials.gears_cranks_discs.youngs_modulus_Pa, anchored.materials.pins.youngs_modulus_Pa)
    assert e_max * stiffness_scale(cal[0].params[0].low) > MODULUS_MAX_PA  # the stated bound breaks the rule
    assert MODULUS_MAX_PA * 0.99 < e_max * stiffness_scale(cut[0].params[0].low) <= MODULUS_MAX_PA
    scale_stiffness(anchored, stiffness_scale(cut[0].params[0].low))  # a spec the rule accepts


def test_a_calibration_at_the_cut_contact_stiffness_bound_is_flagged_at_its_bound():
    """The calibration table flags a value at the range it was calibrated in: the contact stiffness cut by the
    modulus rule (anchored ×1.68) and held at that cut bound is at its bound, though the stated range goes on;
    the row names both ranges."""
    from types import SimpleNamespace

    from rvflex.diagnosis.nominal import NOMINAL, describe_calibration, within_spec_rules

    stated = NOMINAL["contact_stiffness"]
    cut = within_spec_rules((stated,), scale_stiffness(SPEC, 1.68))[0]
    lo = cut.params[0].low
    assert lo > stated.params[0].low + 0.01 * (stated.params[0].high - stated.params[0].low)  # inside the stated range
    at_cut = SimpleNamespace(calibrated=[(cut, np.array([lo]), np.array([[lo, lo + 0.1]]))])
    row, = describe_calibration(at_cut, anchor_scale=1.68)
    assert row["at_prior_bound"]
    assert row["prior_range"] == [lo, cut.params[0].high]
    assert row["stated_range"] == [stated.params[0].low, stated.params[0].high]
    assert "1000 GPa modulus rule" in row["cut_by"]
    assert describe_calibration(SimpleNamespace(calibrated=[(stated, np.array([0.0]), np.array([[-0.1, 0.1]]))]))[0][
        "cut_by"] is None  # the stated range, uncut
    inside = SimpleNamespace(calibrated=[(cut, np.array([0.5 * (lo + cut.params[0].high)]), np.array([[lo, 0.0]]))])
    assert not describe_calibration(inside, anchor_scale=1.68)[0]["at_prior_bound"]


def test_the_runs_of_one_variant_share_one_model_build(monkeypatch):
    """The replay builds a model once per distinct (spec, errors) variant and runs its campaign on it; every run
    sets its own state, so the responses are those of a model built for each run alone to within the solver's
    tolerance (measured 1.4e-8″ with a clearance, far below the 0.01″ the diagnosis resolves; bound 1e-6″)."""
    import rvflex.model
    from rvflex.diagnosis.nominal import NOMINAL

    plan = (PlanRun("te", "f", 1, 0.5 * TR), PlanRun("te", "r", -1, 0.5 * TR)) + _cycle_plan(16)
    s = DiagnosisSettings(hysteresis_steps=16).for_spec(SPEC)
    active = ((NOMINAL["contact_stiffness"], np.array([-0.4])), (NOMINAL["crank_bearing_clearance"], np.array([3e-6])))
    builds = []
    build = rvflex.model.build_reducer
    monkeypatch.setattr(rvflex.model, "build_reducer", lambda *a, **k: builds.append(1) or build(*a, **k))
    shared = evaluate(SPEC, ErrorSpec(), plan, s, active)
    assert len(builds) == 1  # the effect gives each run an equal, not the same, variant
    for r, p in enumerate(plan):
        alone = evaluate(SPEC, ErrorSpec(), (p,), s, active)
        a, b = (alone.te[0], shared.te[r]) if p.kind == "te" else (alone.theta[0], shared.theta[r])
        assert np.max(np.abs(a - b)) * 206264.8 < 1e-6
    assert len(builds) == 1 + len(plan)


def test_a_model_run_split_into_parts_in_a_pool_is_the_run_of_one_process():
    """In a pool a model run is split into its plan runs, each built and run on its own (both workers stay
    busy): the joined response is the one-process run's within 1e-9 rad (2e-4″, ten times the solver's
    step tolerance; each part starts from its own build), one model run is counted per run, not per part,
    and a run failing in every part fails with the one-process run's message."""
    import dataclasses as dc

    from rvflex.diagnosis.nominal import NOMINAL
    from rvflex.diagnosis.runs import ModelRunner

    plan = (PlanRun("te", "f", 1, 0.5 * TR), PlanRun("te", "r", -1, 0.5 * TR)) + _cycle_plan(16)
    s = DiagnosisSettings(hysteresis_steps=16).for_spec(SPEC)
    clr = NOMINAL["crank_bearing_clearance"]
    points = [(), ((clr, np.array([3e-6])),), ((clr, np.array([-1e-3])),)]  # the last breaks a spec rule
    one = ModelRunner(SPEC, ErrorSpec(), plan, dc.replace(s, workers=1), None, None)
    pool = ModelRunner(SPEC, ErrorSpec(), plan, dc.replace(s, workers=2), None, None)
    a, b = one.run(points), pool.run(points)
    assert one.model_runs == pool.model_runs == 3
    for (_fa, ra, ma), (_fb, rb, mb) in zip(a[:2], b[:2]):
        assert ma == mb == ""
        for x, y in zip(ra.te + ra.theta, rb.te + rb.theta):
            assert (x is None) == (y is None)
            if x is not None:
                np.testing.assert_allclose(y, x, rtol=0.0, atol=1e-9)
    assert a[2][0] is None and b[2][0] is None and a[2][2] == b[2][2]
    assert b[2][2].startswith("effect value breaks a spec rule")


def test_a_failed_run_is_remembered_per_solver_revision_and_a_converged_one_for_good(tmp_path):
    """The disk cache keeps a failed model run under the solver revision that failed it: a solver that has
    since learnt to take the step runs the point again (measured: far seed 1, case 18, whose fitted values
    failed until a loading step that fails was left out), while a converged run stays valid."""
    import pickle

    from rvflex.diagnosis.nominal import NOMINAL
    from rvflex.diagnosis.runs import FAILURE_REVISION, ModelRunner

    plan = (PlanRun("te", "f", 1, 0.25 * TR),)
    s = DiagnosisSettings().for_spec(SPEC)
    broken = ((NOMINAL["crank_bearing_clearance"], np.array([-1e-3])),)  # breaks a spec rule: fails at once

    def runner():
        return ModelRunner(SPEC, ErrorSpec(), plan, s, None, tmp_path)

    first = runner()
    assert first.run([broken])[0][0] is None and first.model_runs == 1
    assert [p.name for p in tmp_path.iterdir()] == [f"{first.key(broken)}.failed-{FAILURE_REVISION}.pkl"]
    again = runner()
    assert again.run([broken])[0][2].startswith("effect value breaks a spec rule") and again.model_runs == 0
    # a failure an older solver wrote under the plain key is not believed: the point is run again
    (tmp_path / f"{first.key(())}.pkl").write_bytes(pickle.dumps((None, None, "an older solver failed")))
    newer = runner()
    f, _, msg = newer.run([()])[0]
    assert f is not None and msg == "" and newer.model_runs == 1
    last = runner()
    assert last.run([()])[0][0] is not None and last.model_runs == 0  # the converged run is read back


def test_an_effects_secant_is_measured_again_about_the_calibrated_clearance():
    """A candidate's signature depends on the point it acts at: with the eccentric bearings tight, an RV-80E's
    pin-ring runout is held by the cranks and shows at order 2·z_c = 78 of the TE hardly at all; with 2 µm of
    clearance the discs follow it. A secant taken about the nominal model misses that change of an 8 µm runout
    about a calibration with 2 µm of clearance almost entirely; taken again about that point
    (:func:`~rvflex.diagnosis.sensitivity.rebase_effects`, what the diagnosis does about its calibration), the
    linearised change follows the model run's up to the secant's curvature."""
    from rvflex.diagnosis.nominal import NOMINAL
    from rvflex.diagnosis.runs import ModelRunner
    from rvflex.diagnosis.sensitivity import rebase_effects, sensitivities

    spec = catalog.load("rv80e")
    runout, clr = EFFECTS["pin_ring_runout"], NOMINAL["crank_bearing_clearance"]
    plan = (PlanRun("te", "f", 1, 240.0),)
    s = DiagnosisSettings(max_order=80).for_spec(spec)
    runner = ModelRunner(spec, ErrorSpec(), plan, s, None, None)
    f0, resp0, _ = runner.run([()])[0]
    _, lay = features(resp0, plan, s)
    sens, failed = sensitivities(runner, (runout,), f0, resp0, plan, s, lay)
    assert not failed
    base = ((clr, np.array([2e-6])),)
    x = np.array([8e-6, 0.0])
    fb = runner.run([base])[0][0]
    exact = runner.run([base + ((runout, x),)])[0][0] - fb  # the runout's change about the clearance
    again, failed = rebase_effects(runner, sens, (runout, clr), base, fb, resp0, s, lay)
    assert not failed and again.plus.keys() == sens.plus.keys()

    def order78(df):  # amplitude at order 78 (the TE features are in arcsec)
        return math.hypot(df[lay.cos[0]][77], df[lay.sin[0]][77])

    nominal, rebased, true = order78(sens.change_at(runout.name, x)), order78(again.change_at(runout.name, x)), order78(exact)
    print(f"order 78 at 8 µm: model {true:.3f}″, nominal secant {nominal:.3f}″, rebased secant {rebased:.3f}″")
    assert true > 0.3 and nominal < 0.05 * true
    # the secant at the typical step (5 µm) sees the response's curvature (the runout first takes up the clearance),
    # which the refinement with the model in the loop follows; about the nominal model there is nothing to follow
    assert rebased > 10 * nominal and rebased > 0.3 * true

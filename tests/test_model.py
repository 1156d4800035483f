"""The assembled planar RV reducer and quasi-static stepping (reduced resolution)."""

from __future__ import annotations

import numpy as np
import pytest

from rvflex import catalog
from rvflex.cli import main
from rvflex.geometry.formulas import ARCSEC_PER_RAD
from rvflex.scenarios.loaded_te import LoadedTE, perfect_spec, run_loaded_te, seed001_errors
from rvflex.spec import ErrorSpec, SpecError


@pytest.fixture(scope="module")
def rv40e():
    return catalog.load("rv40e")


def test_perfect_geometry_no_load_is_exactly_kinematic(rv40e):
    """Theoretical geometry, no clearances, no load, one output revolution at 128 positions:
    TE peak-to-peak ≤ 0.05″ and the mean ratio exact to 1e-9 (DESIGN.md)."""
    res, met = run_loaded_te(LoadedTE(perfect_spec(rv40e), ErrorSpec(), 0.0, positions_per_rev=128))
    assert met.te_pp_arcsec <= 0.05
    slope = np.polyfit(res.theta_in, res.theta_out, 1)[0]
    assert abs(slope * res.ratio - 1.0) < 1e-9


def test_windup_is_nearly_proportional_to_load_and_mirrors_in_reverse(rv40e):
    """Perfect geometry (no clearance): the elastic wind-up at rated torque is about twice that
    at half of it — bearings and mesh are linear, the line-contact law stiffens only
    logarithmically (so within 10 %) — and the reverse run mirrors the forward one (1 %)."""
    spec = perfect_spec(rv40e)
    half = run_loaded_te(LoadedTE(spec, ErrorSpec(), 206.0, revolutions=0.05, positions_per_rev=320))[1]
    full = run_loaded_te(LoadedTE(spec, ErrorSpec(), 412.0, revolutions=0.05, positions_per_rev=320))[1]
    back = run_loaded_te(LoadedTE(spec, ErrorSpec(), 412.0, revolutions=0.05, positions_per_rev=320, direction=-1))[1]
    assert full.mean_windup_arcsec < 0 < back.mean_windup_arcsec  # the output lags the motion both ways
    assert full.mean_windup_arcsec / half.mean_windup_arcsec == pytest.approx(2.0, rel=0.1)
    assert back.mean_windup_arcsec == pytest.approx(-full.mean_windup_arcsec, rel=0.01)
    # above rated torque (150 %: the load is ramped past rated at the first pose) the same
    # near-linearity holds
    over = run_loaded_te(LoadedTE(spec, ErrorSpec(), 618.0, revolutions=0.05, positions_per_rev=320))[1]
    assert over.mean_windup_arcsec / full.mean_windup_arcsec == pytest.approx(1.5, rel=0.1)


def test_seed001_errors_run_and_raise_te_above_the_perfect_unit(rv40e):
    """All seed 001 Table 2 errors with the 12 µm bearing clearance converge at rated load and
    give a TE well above the error-free catalogue unit's (same modification)."""
    clean = run_loaded_te(LoadedTE(rv40e, ErrorSpec(), 412.0, revolutions=0.1, positions_per_rev=640))[1]
    worn = run_loaded_te(LoadedTE(rv40e, seed001_errors(rv40e), 412.0, revolutions=0.1, positions_per_rev=640))[1]
    assert worn.te_pp_arcsec > 10 * clean.te_pp_arcsec


def test_chord_newton_finds_the_equilibria_of_exudyns_static_solver(rv40e):
    """The quasi-static stepping's chord Newton (Jacobian kept between steps, capped moves,
    extrapolated guesses) against Exudyn's static solver at every step, seed 001 errors with
    the 12 µm clearances at rated load over 96 positions (two crank turns relative to the
    carrier, contact sets changing): the same equilibria. Both stop at a last correction of
    ~1e-10 rad, so 1e-4″ (5e-10 rad) is the tolerance."""
    from rvflex.model import build_reducer
    from rvflex.solve import quasi_static

    model = build_reducer(rv40e, seed001_errors(rv40e), "rigid")
    theta = np.linspace(0.0, 4 * np.pi * model.ratio / rv40e.cycloid.pin_count, 96, endpoint=False)
    chord = quasi_static(model, theta, 412.0, chord_newton=True).te_rad
    exudyn = quasi_static(model, theta, 412.0, chord_newton=False).te_rad
    assert np.ptp(chord) * ARCSEC_PER_RAD > 1.0  # a loaded, varying TE, not a trivial one
    assert np.abs(chord - exudyn).max() * ARCSEC_PER_RAD < 1e-4


def test_the_rigid_default_steps_by_the_compiled_step_to_the_equilibria_of_exudyns_static_solver(rv40e):
    """The rigid default takes its steps by the compiled Newton of :mod:`rvflex.engine` from the extrapolated
    guess: the nominal unit and seed 001's errors with their 12 µm clearances at rated load over 96 positions
    give the TE of Exudyn's static solver from the kinematic guess at every step (``chord_newton=False``) to
    1e-4″ (both stop at ~1e-10 rad), every step taken by the compiled step (a step that fell back to Exudyn
    would not show in the TE), and the pin forces of the same equilibria."""
    from rvflex import solve
    from rvflex.model import build_reducer

    for errors in (ErrorSpec(), seed001_errors(rv40e)):
        model = build_reducer(rv40e, errors, "rigid")
        theta = np.linspace(0.0, 4 * np.pi * model.ratio / rv40e.cycloid.pin_count, 96, endpoint=False)
        fast = solve.quasi_static(model, theta, 412.0)
        exudyn = solve.quasi_static(model, theta, 412.0, chord_newton=False)
        assert np.ptp(fast.te_rad) * ARCSEC_PER_RAD > 0.1  # a loaded, varying TE, not a trivial one
        assert np.abs(fast.te_rad - exudyn.te_rad).max() * ARCSEC_PER_RAD < 1e-4
        # 1e-10 m of convergence against ~1e8–1e9 N/m of contact stiffness: well below 1 N
        assert np.abs(fast.pin_force_N - exudyn.pin_force_N).max() < 1.0
        # the compiled step took the run: at most the loading continuation's first-pose steps fell back to Exudyn
        continuation = len(solve.REGULARISER_CONTINUATION_NM_RAD) + len(solve.LOAD_CONTINUATION)
        counts = fast.compiled
        assert counts is not None and counts["fallbacks"] <= continuation and counts["evaluations"] >= 2 * len(theta)


def test_a_rigid_system_the_compiled_step_cannot_replicate_steps_by_exudyns_kept_newton(rv40e, monkeypatch):
    """Where the compiled step declines a system (``engine.compiled_step`` returns None), the rigid default takes its steps by Exudyn's Newton kept from step to step, from the extrapolated
    guess (``solve._KeptNewton``): the nominal unit at rated load over 96 positions gives the TE of Exudyn's
    static solver from the kinematic guess at every step (``chord_newton=False``) to 1e-4″ (both stop at
    Exudyn's tolerances, ~1e-10 rad), and the kept Newton took every step (a step that fell back would
    not show in the TE). With seed 001's errors and 12 µm clearances, where the extrapolation guesses badly,
    the run hands its steps back to Exudyn's solver (``KEPT_FALLBACKS``: after 5 fallbacks, measured) and
    still agrees."""
    from rvflex import solve
    from rvflex.model import build_reducer

    monkeypatch.setattr(solve, "compiled_step", lambda m: None)
    solved, kept_newtons = [], []
    kept_solve, kept_init = solve._KeptNewton.solve, solve._KeptNewton.__init__
    monkeypatch.setattr(solve._KeptNewton, "solve", lambda self, q: solved.append(1) or kept_solve(self, q))
    monkeypatch.setattr(solve._KeptNewton, "__init__", lambda self, m: kept_newtons.append(self) or kept_init(self, m))
    for errors in (ErrorSpec(), seed001_errors(rv40e)):
        model = build_reducer(rv40e, errors, "rigid")
        theta = np.linspace(0.0, 4 * np.pi * model.ratio / rv40e.cycloid.pin_count, 96, endpoint=False)
        solved.clear()
        kept = solve.quasi_static(model, theta, 412.0).te_rad
        exudyn = solve.quasi_static(model, theta, 412.0, chord_newton=False).te_rad
        assert np.ptp(kept) * ARCSEC_PER_RAD > 0.1  # a loaded, varying TE, not a trivial one
        assert np.abs(kept - exudyn).max() * ARCSEC_PER_RAD < 1e-4
        if errors == ErrorSpec():
            assert len(solved) == len(theta) and kept_newtons[-1].fallbacks == 0
        else:
            assert kept_newtons[-1].fallbacks == solve.KEPT_FALLBACKS


def test_bad_te_input_is_refused(rv40e, tmp_path, capsys):
    with pytest.raises(SpecError, match=r"^load_Nm = 3000.0: must lie in \[0, 2058\] N·m"):
        LoadedTE(rv40e, ErrorSpec(), 3000.0)
    assert main(["te", "--reducer", "rv40e", "--load", "-5", "--json", str(tmp_path / "t.json")]) == 2
    assert "--load = -5.0: must lie in [0, 2058] N·m" in capsys.readouterr().err
    assert main(["te", "--reducer", "rv40e", "--mode", "dynamic", "--speed-out", "0",
                 "--json", str(tmp_path / "t.json")]) == 2
    assert "--speed-out = 0.0: must be positive in dynamic mode" in capsys.readouterr().err
    assert not (tmp_path / "t.json").exists()


def test_model_backlash_matches_the_backlash_formula(rv40e):
    """Catalogue RV-40E, pure clearances (its modification and gear backlash, no errors): the
    zero-torque backlash of the hysteresis test (elastic lines at 50–100 % T_r extrapolated)
    against seed 002's ε. The issue asks for 15 %; the rigid planar model gives 1 %."""
    from rvflex.geometry.formulas import reducer_backlash_arcmin
    from rvflex.scenarios.lost_motion import LostMotion, run_lost_motion

    res, met = run_lost_motion(LostMotion(rv40e, ErrorSpec(), 412.0, steps=80))
    eps = reducer_backlash_arcmin(rv40e)["total"]
    assert met.backlash_arcmin == pytest.approx(eps, rel=0.15)
    assert met.backlash_arcmin == pytest.approx(eps, rel=0.01)
    # without friction the loop closes: no hysteresis loss; lost motion exceeds the backlash by
    # the elastic turn at ±3 % T_r
    assert met.hysteresis_loss_arcmin < 1e-6
    assert met.backlash_arcmin < met.lost_motion_arcmin < met.backlash_arcmin + 2 * 0.03 * 412.0 / 50.0
    # a rigid-disc model is stiffer than the catalogue's ~113 N·m/arcmin for the whole unit
    assert 113.0 < met.torsional_stiffness_Nm_per_arcmin < 400.0


def test_dynamic_at_low_speed_agrees_with_quasi_static(rv40e):
    """RV-40E at 412 N·m: a generalized-α run (0.1 ms step, smooth 0.2 s ramp to 15 rpm at the
    output, 0.02 output revolutions at speed) against quasi-static equilibria at the same input
    angles: peak-to-peak of the difference ≤ 0.5″ (the issue's consistency check)."""
    from rvflex.model import build_reducer
    from rvflex.solve import dynamic, quasi_static

    dyn = dynamic(build_reducer(rv40e), 15.0, 0.02, 412.0, step_s=1e-4)
    steady = dyn.time_s > 0.25
    th = dyn.theta_in[steady][::40]
    te_dyn = dyn.te_rad[steady][::40]
    qs = quasi_static(build_reducer(rv40e), th, 412.0)
    diff = (te_dyn - qs.te_rad) * ARCSEC_PER_RAD
    assert np.ptp(diff) <= 0.5
    assert abs(diff.mean()) <= 0.5


def test_a_dynamic_run_starts_from_the_loaded_state_after_items_were_added(rv40e):
    """A sensor added after the build leaves the system to be assembled; the run must still start from the
    loaded static state (assembling resets the coordinates to the unloaded ones): the first steps' TE is the
    static TE within 0.5″, where an unloaded start under the full torque is off by about 200″."""
    import exudyn as exu
    from exudyn.itemInterface import SensorNode

    from rvflex.model import build_reducer
    from rvflex.solve import dynamic, quasi_static

    model = build_reducer(rv40e)
    model.mbs.AddSensor(SensorNode(nodeNumber=model.discs.contacts[0].node, storeInternal=True, writeToFile=False,
                                   outputVariableType=exu.OutputVariableType.Coordinates))
    dyn = dynamic(model, 15.0, 0.0005, 412.0, step_s=1e-4, ramp_s=0.02)
    static = quasi_static(build_reducer(rv40e), np.array([0.0]), 412.0).te_rad[0]
    assert np.abs(dyn.te_rad[1:6] - static).max() * ARCSEC_PER_RAD < 0.5


def test_error_groups_partition_every_error_source(rv40e):
    """Every ErrorSpec field belongs to exactly one group of the decomposition, and the seed 001
    set splits into groups that add back up to the whole set."""
    import dataclasses as dc

    from rvflex.scenarios.error_decomposition import ERROR_GROUPS, split_errors

    for f in dc.fields(ErrorSpec):
        owners = [g for g, prefixes in ERROR_GROUPS.items() if f.name.startswith(prefixes)]
        assert len(owners) == 1, (f.name, owners)
    full = seed001_errors(rv40e)
    merged = {}
    for part in split_errors(full).values():
        merged.update({f.name: getattr(part, f.name) for f in dc.fields(part) if getattr(part, f.name) != f.default})
    assert ErrorSpec(**merged) == full


def test_compensated_modification_reduces_backlash_by_the_compensated_approach(rv40e):
    """Seed 002's deformation-compensated profile (δ_max = Hertz approach of the most loaded pin at
    rated torque) against the traditional one: the backlash falls by the two flanks'
    compensation at the pitch lever arm, 2·δ_max/(e·z_c), within 10 %; the 50–100 % slope does not
    fall, and the secant stiffness over ±T_r (free play included: seed 002's 72 → 95 N·m/arcmin
    kind of figure) rises, to 2T/(2T/k + backlash) within 1 % (elastic lines straight above 50 %)."""
    from rvflex.geometry.formulas import ARCMIN_PER_RAD
    from rvflex.scenarios.lost_motion import LostMotion, run_lost_motion
    from rvflex.scenarios.modification_comparison import compensated_spec, compensation_amount_m

    delta = compensation_amount_m(rv40e)
    assert 0.5e-6 < delta < 5e-6  # a few µm of Hertz approach at ~700 N on a 10 mm line
    trad = run_lost_motion(LostMotion(rv40e, ErrorSpec(), 412.0, steps=80))[1]
    comp = run_lost_motion(LostMotion(compensated_spec(rv40e, delta), ErrorSpec(), 412.0, steps=80))[1]
    expected = 2 * delta / (rv40e.cycloid.eccentricity_m * rv40e.cycloid.disc_teeth) * ARCMIN_PER_RAD
    assert trad.backlash_arcmin - comp.backlash_arcmin == pytest.approx(expected, rel=0.1)
    assert comp.torsional_stiffness_Nm_per_arcmin >= trad.torsional_stiffness_Nm_per_arcmin * (1 - 1e-3)
    assert comp.secant_stiffness_Nm_per_arcmin > 1.02 * trad.secant_stiffness_Nm_per_arcmin
    for m in (trad, comp):
        two_t = 2 * 412.0
        assert m.secant_stiffness_Nm_per_arcmin == pytest.approx(
            two_t / (two_t / m.torsional_stiffness_Nm_per_arcmin + m.backlash_arcmin), rel=0.01)


def test_reversal_backlash_equals_the_lost_motion_at_the_same_load(rv40e, tmp_path):
    """Two procedures, one quantity: reversing the input under a ±3 % T_r resisting load loses the
    output angle that the locked-input torque cycle measures as lost motion at ±3 % T_r (1 %);
    the command writes its JSON key."""
    import json

    from rvflex.scenarios.lost_motion import LostMotion, run_lost_motion
    from rvflex.scenarios.reversal_backlash import ReversalBacklash, run_reversal_backlash

    lost, _, _ = run_reversal_backlash(ReversalBacklash(rv40e, ErrorSpec(), 0.03 * 412.0))
    lm = run_lost_motion(LostMotion(rv40e, ErrorSpec(), 412.0, steps=80))[1]
    assert lost == pytest.approx(lm.lost_motion_arcmin, rel=0.01)
    assert main(["backlash", "--reducer", "rv40e", "--json", str(tmp_path / "b.json")]) == 0
    assert json.loads((tmp_path / "b.json").read_text())["reversal_backlash_arcmin"] == pytest.approx(lost, rel=1e-9)


@pytest.mark.parametrize(("errors", "order"), [
    (ErrorSpec(planet_base_eccentricity_m=(10e-6, 0.0)), 40),  # z_b: the crank turns against the carrier
    (ErrorSpec(pin_radial_m=(8e-6,) + (0.0,) * 39), 78),  # 2·z_c: the load zones sweep the fixed pins
    (ErrorSpec(pin_ring_runout_m=5e-6), 78),
    (ErrorSpec(disc_profile_error_m=((2e-6,) + (0.0,) * 38, (0.0,) * 39)), 40),  # z_b: the load zone sweeps the disc
], ids=["planet eccentricity", "one pin", "pin-ring runout", "one disc tooth"])
def test_each_error_source_excites_its_predicted_order(rv40e, errors, order):
    """docs/te_orders.md: injected alone at rated load, each source's strongest added TE order
    (spectrum with the error minus the error-free unit's) is the kinematically predicted one."""
    from rvflex.scenarios.te_orders import added_orders

    assert added_orders(rv40e, errors, 412.0, top=1)[0][0] == order


def test_builtin_seed001_error_set_is_the_scenario_set(rv40e):
    """The shipped rv40e_seed001 error file is exactly seed001_errors(rv40e) (regenerate it with
    that function when the reading of seed 001 changes)."""
    assert catalog.load_error_set("rv40e_seed001", rv40e) == seed001_errors(rv40e)
    assert "rv40e_seed001" not in catalog.names()


def test_the_chord_newton_starts_afresh_after_exudyns_solver_ran_in_a_torque_cycle(rv40e):
    """A torque cycle through a free play where Exudyn's static solver fails once (zero torque →
    −2 N·m; a pin circle 2.1 µm large, as a 10.6 ppm/K housing mismatch at 23 °C gives, and a 9 nm
    crank-bearing clearance): the chord Newton initialised before that failed run must not be reused
    (it then saw no output load and held the descending branch at −60″ down to −412 N·m). The cycle is
    the same by either solver wherever it is loaded (0.01″: both stop at ~1e-10 rad) and antisymmetric
    (the geometry is symmetric in the load's sign)."""
    from rvflex.model import build_reducer
    from rvflex.solve import hysteresis_cycle, torque_stepping

    errors = ErrorSpec(pin_circle_radius_error_m=2.0988e-6, eccentric_bearing_clearance_m=(9.09e-9,) * 4)
    path = hysteresis_cycle(412.0, 40)
    chord = torque_stepping(build_reducer(rv40e, errors), path, chord_newton=True, skip_unsolved=True).theta_out
    exudyn = torque_stepping(build_reducer(rv40e, errors), path, chord_newton=False, skip_unsolved=True).theta_out
    at = np.argmin(path)
    assert exudyn[at] * ARCSEC_PER_RAD < -150.0  # loaded, out of the free play
    loaded = path != 0.0  # at zero torque the unit floats in its free play: no unique equilibrium
    assert np.abs(chord - exudyn)[loaded].max() * ARCSEC_PER_RAD < 0.01
    assert chord[at] == pytest.approx(-chord[np.argmax(path)], abs=0.01 / ARCSEC_PER_RAD)


def test_a_rigid_run_that_exudyns_solver_must_bisect_goes_on_by_the_chord_newton(rv40e):
    """Both crank eccentricities 3 µm too large at 103 N·m (the discs preloaded against the pins):
    Exudyn's solver bisects step after step (188 s for 448 positions, measured), so the default
    hands the run to the chord Newton after the first bisection. Its TE is the chord Newton's from
    the start to 1e-4″ (both stop at ~1e-10 rad) and varies (a loaded, meshing run)."""
    from rvflex.model import build_reducer
    from rvflex.solve import quasi_static

    errors = ErrorSpec(crank_eccentricity_error_m=(3e-6, 3e-6))
    model = build_reducer(rv40e, errors)
    theta = np.linspace(0.0, 2 * np.pi * model.ratio, 448, endpoint=False)[:64]  # 64 of 448 positions
    auto = quasi_static(model, theta, 103.0).te_rad
    chord = quasi_static(build_reducer(rv40e, errors), theta, 103.0, chord_newton=True).te_rad
    assert np.ptp(chord) * ARCSEC_PER_RAD > 0.05
    assert np.abs(auto - chord).max() * ARCSEC_PER_RAD < 1e-4


def test_a_seat_compliance_in_series_is_the_series_stiffness_on_the_whole_reducer(rv40e):
    """A linear pin contact k with a seat compliance s in series is, on the rigid RV-40E at rated torque, the same
    reducer as a linear contact of 1/(1/k + s): wind-up and TE agree to the solver's tolerance (1e-4″); against k
    alone the seat adds wind-up. The seat enters every pin contact, not a lumped output compliance."""
    import dataclasses

    from rvflex.contact.cycloid_pin import ContactLaw
    from rvflex.options import ModelOptions

    spec, k, s = perfect_spec(rv40e), 5e8, 1e-9

    def run(law):
        opts = dataclasses.replace(ModelOptions.rigid(), contact_law=law)
        return run_loaded_te(LoadedTE(spec, ErrorSpec(), 412.0, revolutions=0.05, positions_per_rev=320,
                                      options=opts))

    seat, series, alone = (run(law) for law in (ContactLaw.linear(k, seat_compliance_m_N=s),
                                                ContactLaw.linear(1.0 / (1.0 / k + s)), ContactLaw.linear(k)))
    assert seat[1].mean_windup_arcsec == pytest.approx(series[1].mean_windup_arcsec, abs=1e-4)
    assert np.max(np.abs(seat[0].te_rad - series[0].te_rad)) * ARCSEC_PER_RAD < 1e-4
    assert seat[1].mean_windup_arcsec < alone[1].mean_windup_arcsec < 0  # more lag with the seat

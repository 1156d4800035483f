"""The diagnosis on any unit: a calibration parameter (or candidate effect) the model cannot evaluate
is named in the verdict with a one-line reason, never a traceback."""

from __future__ import annotations

from pathlib import Path

import pytest

from rvflex.diagnosis.settings import DiagnosisSettings

BENCH = Path(__file__).parent / "fixtures" / "bench_rv40e_small"


def test_a_calibration_parameter_the_model_cannot_evaluate_is_named_in_the_verdict(tmp_path, monkeypatch,
                                                                                   netgen_fails):
    """netgen failing to mesh the disc (as in tests/test_cli.py), a cold FE cache: the flexible model,
    and with it the disc-flexibility calibration, cannot be evaluated. The diagnosis goes on with the
    rigid model; the verdict names the parameter, what the model does without it and why, in one
    line; the contact stiffness is still calibrated. Serial (workers=1): the build runs in this process."""
    from rvflex.diagnosis.bench import read_bench
    from rvflex.diagnosis.fit import diagnose

    monkeypatch.setenv("RVFLEX_CACHE_DIR", str(tmp_path / "fe"))  # cold: the reduction must run
    quick = DiagnosisSettings(max_order=15, hysteresis_steps=16, refine_top=1, refine_iterations=1, workers=1)
    diag = diagnose(read_bench(BENCH), settings=quick, effects=("crank_eccentricity_error",),
                    nominal=("contact_stiffness", "disc_flexibility"), cache_dir=tmp_path / "runs")
    v = diag.verdict
    assert "Traceback" not in v and 'File "' not in v and "\n" not in v, v
    assert "Not calibrated: disc flexibility, left out of the model (model evaluation failed at the sensitivity step" in v, v
    assert "surface meshing failed" in v, v
    assert "disc_flexibility" in diag.unavailable and "contact_stiffness" not in diag.unavailable
    assert [e.name for e in diag.baseline.effects] == ["contact_stiffness"]
    assert diag.candidates and diag.candidates[0].name == "crank_eccentricity_error"


def test_a_reason_keeps_the_error_and_drops_a_traceback():
    """What a child process's standard error used to put into an FE failure (joined by " | "), and a
    multi-line message: one line, the context and the exception kept, the frames left out."""
    from rvflex.diagnosis.verdict import REASON_CHARS, not_evaluated_sentence, reason_line

    child = ("te_fwd_rated.csv: FEError: the disc reduction (built in a separate process, rc 1) did not reach the "
             "cache /c: Traceback (most recent call last): | File \"/x/rvflex/fe/isolated.py\", line 64, in _main | "
             "cache.store(build(job['spec'])) | rvflex.fe.types.FEError: closest-point solve did not converge for 7 "
             "of 2936 pins")
    assert reason_line(child) == ("te_fwd_rated.csv: FEError: the disc reduction (built in a separate process, rc 1) "
                                  "did not reach the cache /c: rvflex.fe.types.FEError: closest-point solve did not "
                                  "converge for 7 of 2936 pins")
    assert reason_line("first\n  second") == "first second"
    assert len(reason_line("x" * 1000)) == REASON_CHARS and reason_line("x" * 1000).endswith("…")
    s = not_evaluated_sentence({"contact_law_form": "not calibrated: " + child,
                                "thermal_expansion": "needs 'temperature_C' for every run in bench.toml"},
                               {"pin_ring_runout": "model evaluation failed at the sensitivity step: SolveError: x"})
    assert s.startswith("Not calibrated: contact law form, held at its nominal value (te_fwd_rated.csv: FEError:")
    assert "Not evaluated: thermal_expansion (needs 'temperature_C' for every run in bench.toml); pin_ring_runout (" in s
    assert "Traceback" not in s and 'File "' not in s
    assert not_evaluated_sentence({}, {}) == ""


def test_every_nominal_parameter_has_a_verdict_wording():
    """Each nominal parameter that cannot be calibrated is stated as held at its nominal value, or,
    a fidelity share whose nominal is the flexible model, as left out of the model."""
    from rvflex.diagnosis.nominal import NOMINAL
    from rvflex.diagnosis.verdict import not_evaluated_sentence

    for name in NOMINAL:
        kept = "left out of the model" if name == "disc_flexibility" else "held at its nominal value"
        assert not_evaluated_sentence({name: "not calibrated: why"}, {}) == \
            f"Not calibrated: {name.replace('_', ' ')}, {kept} (why)."


def test_bench_diagnosis_times_a_model_run_of_each_unit_side_by_side(tmp_path, capsys):
    """``rvflex bench diagnosis`` (a speed target belongs in a benchmark, not a timed test): both
    units run the same plan (three TE runs, one torque cycle) on the same grid, the reference's ratio
    is 1, the table and the target line are printed and the JSON written."""
    import json

    from rvflex.cli import main

    out = tmp_path / "b.json"
    assert main(["bench", "diagnosis", "--kinds", "rigid", "--max-order", "7", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    doc = json.loads(out.read_text())
    rows = {r["unit"]: r for r in doc["rows"]}
    assert set(rows) == {"rv40e", "rv80e"} and doc["ratio"]["rv40e"]["rigid"] == 1.0
    assert rows["rv40e"]["positions_per_rev"] == rows["rv80e"]["positions_per_rev"]  # both have 40 pins
    assert all(r["te_runs"] == 3 and r["torque_steps"] > 40 and r["cpu_s"] > 0 for r in rows.values())
    assert "target rv80e: model run ≤ 1.5× the rv40e's (CPU): " in text and "target rv40e" not in text
    assert doc["ratio"]["rv80e"]["rigid"] == pytest.approx(rows["rv80e"]["cpu_s"] / rows["rv40e"]["cpu_s"])


def test_the_crank_effects_act_on_a_three_crank_unit():
    """The crank eccentricity and phase errors, two parameters each, on the three-crank fixture: every
    crank gets a value (crank 2 the common part, or no phase of its own), the model runs, and each
    moves the TE; on a two-crank unit the values are those of before (c ± d; x per crank)."""
    import numpy as np

    from rvflex import catalog
    from rvflex.diagnosis.effects import EFFECTS
    from rvflex.diagnosis.replay import evaluate
    from rvflex.diagnosis.selfcheck import campaign_plan
    from rvflex.spec import ErrorSpec, load_spec

    ecc, phase = EFFECTS["crank_eccentricity_error"], EFFECTS["crank_phase_error"]
    two = catalog.load("rv40e")
    assert ecc.apply_to(two, ErrorSpec(), np.array([3e-6, 1e-6]))[1].crank_eccentricity_error_m == (3e-6 + 1e-6, 3e-6 - 1e-6)
    # the phases are relative to the last crank: one parameter on a two-crank unit, two on a three-crank one
    assert phase.for_unit(two).n == 1
    assert phase.for_unit(two).apply_to(two, ErrorSpec(), np.array([5e-4]))[1].crank_phase_error_rad == (5e-4, 0.0)
    spec = load_spec(Path(__file__).parent / "fixtures" / "drive3_user.toml")
    assert spec.cranks.count == 3
    assert ecc.apply_to(spec, ErrorSpec(), np.array([3e-6, 1e-6]))[1].crank_eccentricity_error_m == (3e-6 + 1e-6, 3e-6 - 1e-6,
                                                                                       3e-6)
    assert phase.for_unit(spec).n == 2
    assert phase.apply_to(spec, ErrorSpec(), np.array([5e-4, -2e-4]))[1].crank_phase_error_rad == (5e-4, -2e-4, 0.0)
    plan = campaign_plan(spec, 16)[:1]  # TE at rated torque
    settings = DiagnosisSettings(max_order=15, workers=1)
    base = evaluate(spec, ErrorSpec(), plan, settings).te[0]
    for e, x in ((ecc, [3e-6, 3e-6]), (phase, [5e-4, 0.0])):
        te = evaluate(spec, ErrorSpec(), plan, settings, ((e, np.array(x)),)).te[0]
        assert np.max(np.abs(te - base)) > 0.05 * 4.85e-6, e.name  # TE moved by more than 0.05″

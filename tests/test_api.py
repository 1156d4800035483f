"""The Python API (``import rvflex``): scenarios in, labelled results out.

The loaded-TE result's Dataset, DataFrame, metrics and netCDF file hold the same numbers as the
CLI's JSON; a run on a passed-in model leaves it as found (items and the next run's answer);
plots leave matplotlib's backend and pyplot's figures alone; bad input is refused naming what
was passed; the README's Python block runs as written."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import rvflex

README = Path(__file__).resolve().parents[1] / "README.md"


@pytest.fixture(scope="module")
def rv40e():
    return rvflex.load_reducer("rv40e")


@pytest.fixture(scope="module")
def te_result(rv40e):
    return rvflex.run(rvflex.LoadedTE(rv40e, load_Nm=412.0, positions_per_rev=256))


def test_import_is_lazy():
    """``import rvflex`` loads none of the engine (Exudyn, numba, xarray): they load on first
    use of a top-level name (PEP 562)."""
    code = ("import sys, rvflex; heavy = [m for m in ('exudyn', 'numba', 'xarray', 'rvflex.model', 'numpy') "
            "if m in sys.modules]; print(heavy); rvflex.LoadedTE; print('rvflex.model' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split("\n")
    assert out[0] == "[]" and out[1] == "True"


def test_loaded_te_result_is_labelled_and_matches_the_cli(te_result, tmp_path):
    """The issue's check: ``te`` (arcsec) over ``position`` (256), the DataFrame with the same
    numbers, te_pp equal to the CLI's for the same inputs (the same code path: bit-equal), and
    the netCDF file reopening identical to the Dataset."""
    import xarray as xr

    r = te_result
    ds = r.to_xarray()
    assert ds["te"].dims == ("position",) and ds.sizes["position"] == 256
    for name in ds.variables:
        assert {"units", "long_name"} <= set(ds[name].attrs), name
    assert ds["te"].attrs["units"] == "arcsec" and ds["position"].attrs["units"] == "rad"
    assert ds.attrs["reducer"] == "rv40e" and ds.attrs["scenario"] == "LoadedTE"
    # TE pp of the Dataset is the metric; the position coordinate is θ_in/i over one revolution
    assert float(ds["te"].max() - ds["te"].min()) == pytest.approx(r.metrics.te_pp_arcsec, abs=1e-12)
    assert float(ds["position"][1] - ds["position"][0]) == pytest.approx(2 * np.pi / 256, rel=1e-12)
    df = r.to_dataframe()
    assert len(df) == 256 and np.array_equal(df["te_arcsec"].to_numpy(), ds["te"].to_numpy())
    assert np.array_equal(df["position_rad"].to_numpy(), ds["position"].to_numpy())

    from rvflex.cli import main

    assert main(["te", "--reducer", "rv40e", "--load", "412", "--positions", "256", "--json", str(tmp_path / "t.json")]) == 0
    assert json.loads((tmp_path / "t.json").read_text())["te_pp_arcsec"] == r.metrics.te_pp_arcsec
    assert r.metrics_dict()["te_pp_arcsec"] == r.metrics.te_pp_arcsec

    paths = r.write(tmp_path / "out")
    assert sorted(p.name for p in paths) == ["load_sharing.png", "te.csv", "te.nc", "te.png"]
    with xr.open_dataset(tmp_path / "out" / "te.nc") as back:
        assert back.load().identical(ds)


def test_plots_leave_matplotlib_alone(te_result, rv40e, tmp_path):
    """Plotting and writing from the API neither switch the backend nor leave pyplot figures."""
    import matplotlib
    import matplotlib.pyplot as plt

    backend = matplotlib.get_backend()
    figures = plt.get_fignums()
    ax = te_result.plot()
    assert ax.figure.axes == [ax]
    te_result.plot_orders()
    te_result.write(tmp_path / "te")
    lm = rvflex.run(rvflex.LostMotion(rv40e, steps=40))
    lm.plot()
    lm.write(tmp_path / "lm")
    assert matplotlib.get_backend() == backend and plt.get_fignums() == figures


def test_a_passed_model_is_reused_and_left_as_found(rv40e):
    """Every scenario (and the dynamic mode, which used to add sensors) runs on a prebuilt model
    without adding items; a second run on the same model gives the same TE as a fresh model
    (the first run leaves no state behind: same equilibria to 1e-6″)."""
    model = rvflex.build_reducer(rv40e)
    items = model.item_count
    q0 = np.asarray(model.mbs.systemData.GetODE2Coordinates())
    short = rvflex.LoadedTE(rv40e, load_Nm=412.0, revolutions=0.02, positions_per_rev=1600)
    first = rvflex.run(short, model=model)
    rvflex.run(rvflex.LostMotion(rv40e, steps=40), model=model)
    rvflex.run(rvflex.ReversalBacklash(rv40e, positions=8), model=model)
    rvflex.run(rvflex.LoadedTE(rv40e, load_Nm=412.0, revolutions=0.001, positions_per_rev=16000, mode="dynamic",
                               speed_out_rpm=15.0), model=model)
    assert model.item_count == items
    assert np.array_equal(np.asarray(model.mbs.systemData.GetODE2Coordinates()), q0)
    again = rvflex.run(short, model=model).to_xarray()["te"]
    fresh = rvflex.run(short).to_xarray()["te"]
    assert np.abs(again - fresh).max() < 1e-6 and np.abs(first.to_xarray()["te"] - fresh).max() < 1e-6


def test_bad_input_is_refused_naming_it(rv40e, te_result, tmp_path):
    """Not a scenario → TypeError naming the type; a model of another spec or options →
    SpecError naming it; Result.write into a file → SpecError, the file untouched and nothing
    else written."""
    with pytest.raises(TypeError, match=r"expected a scenario .*rvflex\.LoadedTE.*got str"):
        rvflex.run("te")
    with pytest.raises(TypeError, match="expected a ReducerSpec.*got str"):
        rvflex.LoadedTE("rv40e")
    rv80e = rvflex.load_reducer("rv80e")
    with pytest.raises(rvflex.SpecError, match="another spec"):
        rvflex.run(rvflex.LoadedTE(rv40e, positions_per_rev=16, revolutions=0.01), model=rvflex.build_reducer(rv80e))
    with pytest.raises(rvflex.SpecError, match="another options"):
        rvflex.run(rvflex.LoadedTE(rv40e, positions_per_rev=16, revolutions=0.01, options="flexible"),
                   model=rvflex.build_reducer(rv40e))
    with pytest.raises(TypeError, match="ReducerModel.*got str"):
        rvflex.run(rvflex.LoadedTE(rv40e, positions_per_rev=16, revolutions=0.01), model="rv40e")
    with pytest.raises(rvflex.SpecError, match="options"):
        rvflex.LoadedTE(rv40e, options="elastic")
    target = tmp_path / "a_file"
    target.write_text("keep")
    with pytest.raises(rvflex.SpecError, match="is a file"):
        te_result.write(target)
    assert target.read_text() == "keep" and sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]


def test_model_options_presets_are_the_one_default():
    """The presets hold the model's reductions; a preset name maps to its preset everywhere
    (build_reducer, scenarios, the CLI)."""
    from rvflex.options import CARRIER_FE, DISC_FE, as_options

    assert rvflex.ModelOptions.rigid().fidelity == "rigid"
    assert rvflex.ModelOptions.flexible_discs() == as_options("flexible")
    assert rvflex.ModelOptions.flexible_discs_and_carrier() == as_options("flexible-carrier")
    assert (DISC_FE.n_modes, DISC_FE.attach_per_tooth, DISC_FE.maxh_m, DISC_FE.mesh_order) == (12, 0, 6e-3, 2)
    assert (CARRIER_FE.n_modes, CARRIER_FE.seat_coupling) == (10, "rbe3")
    with pytest.raises(rvflex.SpecError, match="rigid in these options"):
        rvflex.ModelOptions.rigid().with_fe("discs", n_modes=24)


def _readme_python_block() -> str:
    text = README.read_text()
    m = re.search(r"<!-- ci:python-example -->\s*```python\n(.*?)```", text, re.S)
    assert m, "README.md needs a ```python block after <!-- ci:python-example -->"
    return m.group(1)


@pytest.mark.flexible
@pytest.mark.slow
def test_readme_python_example_runs(fe_cache, tmp_path, monkeypatch, capsys):
    """The README's Python block, as written (a private FE cache; cold: one default disc
    reduction): it prints the TE table and writes its figure and result files; the elastic
    discs wind the unit up further (TE is negative under a resisting torque)."""
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(compile(_readme_python_block(), "README.md", "exec"), namespace)
    assert "rigid" in capsys.readouterr().out
    assert (tmp_path / "te_rigid_vs_flexible.png").stat().st_size > 0
    assert {p.name for p in (tmp_path / "out" / "te_flexible").iterdir()} == {"te.csv", "te.png", "load_sharing.png",
                                                                             "te.nc"}
    te = namespace["te"]
    assert te["flexible"].mean() < te["rigid"].mean() < 0.0


def test_sweep_table_as_dataframe_and_dataset(tmp_path):
    """A sweep's table comes back as a DataFrame (one row per point) and a Dataset over
    ``point`` with units: the factor deviations in m, TE in arcsec, the same numbers as the rows."""
    design = rvflex.load_design(Path(__file__).resolve().parents[1] / "scenarios" / "designs" / "smoke.toml")
    res = rvflex.sweep(design, tmp_path / "s.sqlite", executor="serial")
    assert (tmp_path / "s.sqlite").is_file()  # the store: a rerun resumes from it
    df, ds = res.to_dataframe(), res.to_xarray()
    assert len(df) == len(res.rows) == ds.sizes["point"] and df.index.name == "point"
    metric = "te_pp_arcsec" if design.scenario == "te" else "lost_motion_arcmin"
    assert np.array_equal(df[metric].to_numpy(), [r[metric] for r in res.rows])
    assert np.array_equal(ds[metric].to_numpy(), df[metric].to_numpy())
    assert ds[metric].attrs["units"] == metric.rsplit("_", 1)[1]
    assert all(ds[f.name].attrs["units"] == "m" for f in design.factors)


def test_python_errors_name_the_parameter_and_the_cli_the_flag(rv40e, tmp_path, capsys):
    """An error raised through the Python API names the Python parameter; the same error from the
    command names its flag (with the flag's spelling of the value)."""
    from rvflex.cli import main

    cases = [(dict(load_Nm=-5.0), r"^load_Nm = -5.0: must lie in \[0, 2058\] N·m",
              ["--load", "-5"], "--load = -5.0: must lie in [0, 2058] N·m"),
             (dict(positions_per_rev=8), r"^positions_per_rev = 8: must be at least 16",
              ["--positions", "8"], "--positions = 8: must be at least 16"),
             (dict(revolutions=0.0), r"^revolutions = 0.0: must be positive",
              ["--revs", "0"], "--revs = 0.0: must be positive"),
             (dict(mode="dynamic", direction=-1), r"^direction = -1: dynamic runs go forward",
              ["--mode", "dynamic", "--direction", "reverse"], "--direction = 'reverse': dynamic runs go forward")]
    for kwargs, python_message, argv, cli_message in cases:
        with pytest.raises(rvflex.SpecError, match=python_message):
            rvflex.LoadedTE(rv40e, **kwargs)
        assert main(["te", "--reducer", "rv40e", *argv, "--json", str(tmp_path / "t.json")]) == 2
        assert cli_message in capsys.readouterr().err
    with pytest.raises(rvflex.SpecError, match=r"^torque_Nm = 3000.0: must lie in \(0, 2058\] N·m"):
        rvflex.LostMotion(rv40e, torque_Nm=3000.0)
    assert main(["lost-motion", "--reducer", "rv40e", "--torque", "3000"]) == 2
    assert "--torque = 3000.0: must lie in (0, 2058] N·m" in capsys.readouterr().err
    assert not (tmp_path / "t.json").exists()


def test_unknown_names_get_a_did_you_mean(rv40e, capsys):
    """A misspelt built-in reducer, error set, preset, choice or top-level name is refused with
    the closest known name suggested (in Python and on the command line); a name close to
    nothing gets no suggestion."""
    from rvflex.cli import main

    with pytest.raises(rvflex.SpecError, match=r"^name_or_path = 'rv40': unknown reducer; built-in: rv160n, rv40e, rv80e; "
                                               r"did you mean 'rv40e'\?$"):
        rvflex.load_reducer("rv40")
    with pytest.raises(rvflex.SpecError, match=r"did you mean 'rv80e'\?$"):
        rvflex.load_reducer("RV80E")
    with pytest.raises(rvflex.SpecError, match=r"unknown reducer; built-in: rv160n, rv40e, rv80e$"):
        rvflex.load_reducer("harmonic")
    with pytest.raises(rvflex.SpecError, match=r"did you mean 'rv40e_seed001'\?$"):
        rvflex.load_errors("rv40e_seed01", rv40e)
    with pytest.raises(rvflex.SpecError, match=r"^options = 'flexble'.*did you mean 'flexible'\?$"):
        rvflex.LoadedTE(rv40e, options="flexble")
    with pytest.raises(rvflex.SpecError, match=r"^mode = 'dynamc'.*did you mean 'dynamic'\?$"):
        rvflex.LoadedTE(rv40e, mode="dynamc")
    with pytest.raises(AttributeError, match=r"no attribute 'LoadTE'; did you mean 'LoadedTE'\?$"):
        rvflex.LoadTE  # noqa: B018 -- the attribute access is the test
    assert main(["te", "--reducer", "rv40"]) == 2
    assert "--reducer = 'rv40': unknown reducer; built-in: rv160n, rv40e, rv80e; did you mean 'rv40e'?" in \
        capsys.readouterr().err


def test_dir_lists_the_public_names_only():
    """``dir(rvflex)`` is the curated surface (``__all__``), each name resolvable; the module's own
    imports and the submodules loading a name pulled in stay out."""
    import rvflex.api  # noqa: F401 -- a loaded submodule must not show up in dir()

    names = dir(rvflex)
    assert names == sorted(rvflex.__all__)
    assert not {"TYPE_CHECKING", "annotations", "importlib", "api", "spec"} & set(names)
    assert {"LoadedTE", "LostMotion", "ReversalBacklash", "load_reducer", "run", "Result"} <= set(names)
    assert all(getattr(rvflex, n) is not None for n in names)
    # tools (IPython, inspect) probe private names: they are refused without loading anything
    code = ("import sys, rvflex; hasattr(rvflex, '__wrapped__'); hasattr(rvflex, '_ipython_display_'); "
            "print([m for m in ('numpy', 'rvflex.choices') if m in sys.modules])")
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True).stdout.strip() == "[]"



def _readme_block(marker: str) -> str:
    m = re.search(rf"<!-- {marker} -->\s*```python\n(.*?)```", README.read_text(), re.S)
    assert m, f"README.md needs a ```python block after <!-- {marker} -->"
    return m.group(1)


def test_readme_studies_example_runs(tmp_path, monkeypatch, capsys):
    """The README's sweep-and-diagnosis block, as written, from a folder that has the repository's
    ``scenarios`` and ``tests`` (its paths are relative to the repository root), with ``import
    rvflex`` alone: the sweep's table; the diagnosis of the small bench finds its hidden effect
    (the truth beside it: a 4 µm common crank-eccentricity error) within ±25 %, and writes
    exactly the report files of ``rvflex diagnose --out``, diagnosis.json being the document
    ``--json`` writes; pyplot's figures are left alone."""
    import matplotlib.pyplot as plt

    from rvflex.diagnosis.report import json_document

    root = README.parent
    for name in ("scenarios", "tests"):
        (tmp_path / name).symlink_to(root / name)
    monkeypatch.chdir(tmp_path)
    figures = plt.get_fignums()
    namespace: dict = {}
    exec(compile(_readme_block("ci:python-studies"), "README.md", "exec"), namespace)
    out = capsys.readouterr().out
    assert "te_pp_arcsec" in out and "crank_eccentricity_error" in out
    sweep, d = namespace["sweep"], namespace["d"]
    assert sweep.finished == 6 and sweep.failed == 0 and sweep.to_xarray()["te_pp_arcsec"].attrs["units"] == "arcsec"
    truth = json.loads((root / "tests" / "fixtures" / "bench_rv40e_small.truth.json").read_text())["effects"][0]
    # the hidden 4 µm ranks first at its size and passes every acceptance test with a relative evidence beyond the
    # controls'; whether it is named depends on the size healthy RV-40E units of other model forms reach (the
    # shipped null distribution's figure): beyond it, established and named, within it, consistent and not named
    lead = d.candidates[0]
    assert lead.name == truth["name"] == "crank_eccentricity_error", d.verdict
    assert lead.magnitude_of(truth["name"]) == pytest.approx(truth["magnitude"], rel=0.25)
    name = truth["name"]
    size = lead.grade["magnitude_thresholds"][name]
    assert lead.grade["null_unit"] == "rv40e" and size is not None
    assert lead.grade["relative_evidence"][name] > lead.grade["relative_thresholds"][name]
    if lead.magnitude_of(name) > size:
        assert d.chosen is not None and d.chosen.name == name and lead.grade["grade"] == "established", d.verdict
        assert f"{name} explains the gap" in d.verdict and not lead.grade["fails"]
    else:
        assert d.chosen is None and lead.grade["grade"] == "consistent but not established", d.verdict
        assert any("healthy units of other model forms reach" in f for f in lead.grade["fails"])
        assert "explains the gap" not in d.verdict and f"Consistent but not established: {name}" in d.verdict
    written = {p.name for p in (tmp_path / "out" / "diagnosis").iterdir()}
    assert written == {"report.md", "diagnosis.json", "te_measured_model_corrected.png", "residual_orders.png",
                       "hysteresis_loops.png", "effect_ranking.png"}
    doc = json.loads((tmp_path / "out" / "diagnosis" / "diagnosis.json").read_text())
    assert doc == json.loads(json.dumps(json_document(d)))
    assert (tmp_path / "diagnosis_te.png").stat().st_size > 0
    ranking = d.to_dataframe("ranking")
    assert list(ranking["effect"]) == [c.name for c in d.candidates] and ranking["accepted"].sum() == (d.chosen is not None)
    ax = d.plot(run=3)  # the torque cycle: torque over output angle
    assert ax.get_ylabel() == "output torque (N·m)" and plt.get_fignums() == figures


def test_studies_refuse_bad_input_naming_the_parameter_and_the_cli_the_flag(tmp_path, capsys):
    """rvflex.diagnose, selfcheck and sweep refuse bad arguments before any model run, naming the
    Python parameter (with the closest known name); the commands name their flags."""
    from rvflex.cli import main

    bench = README.parent / "tests" / "fixtures" / "bench_rv40e_small"
    with pytest.raises(rvflex.SpecError, match=r"^effects = 'crank_eccentricity': unknown name; known: .*"
                                               r"did you mean 'crank_eccentricity_error'\?$"):
        rvflex.diagnose(bench, effects=("crank_eccentricity",))
    with pytest.raises(rvflex.SpecError, match=r"^effects = 'pin_ring_runout': must be a tuple of names"):
        rvflex.diagnose(bench, effects="pin_ring_runout")
    with pytest.raises(rvflex.SpecError, match=r"^nominal = 'contact_stifness'.*did you mean 'contact_stiffness'"):
        rvflex.diagnose(bench, nominal=("contact_stifness",))
    with pytest.raises(TypeError, match=r"bench must be a folder or a BenchDataset"):
        rvflex.diagnose(42)
    with pytest.raises(TypeError, match=r"settings must be an rvflex.DiagnosisSettings"):
        rvflex.diagnose(rvflex.read_bench(bench), settings={"max_order": 15})
    with pytest.raises(rvflex.SpecError, match=r"^cases = 0: must be an integer ≥ 1"):
        rvflex.selfcheck(cases=0)
    with pytest.raises(rvflex.SpecError, match=r"^mismatch = 'realstic'.*did you mean 'realistic'"):
        rvflex.selfcheck(mismatch="realstic")
    with pytest.raises(rvflex.SpecError, match=r"^reducer = 'rv40':.*did you mean 'rv40e'"):
        rvflex.selfcheck(reducer="rv40")
    with pytest.raises(TypeError, match=r"design must be an rvflex.Design or a design TOML path"):
        rvflex.sweep({"kind": "L9"})
    for argv, message in [(["diagnose", str(bench), "--effects", "crank_eccentricity"],
                           "--effects = 'crank_eccentricity': unknown name"),
                          (["selfcheck", "--cases", "0"], "--cases = 0: must be an integer ≥ 1"),
                          (["selfcheck", "--reducer", "rv40"], "--reducer = 'rv40'"),
                          (["selfcheck", "--reuse-benches"], "--reuse-benches = True: needs --out")]:
        assert main([*argv, "--json", str(tmp_path / "x.json")]) == 2
        assert message in capsys.readouterr().err
    assert not (tmp_path / "x.json").exists()


def test_a_quick_selfcheck_from_python(tmp_path):
    """rvflex.selfcheck with one case, two candidate effects and quick settings: the score document
    (the keys of ``rvflex selfcheck --json``, the settings it ran with, JSON-serialisable); the
    hidden effect is among the two best ranked (drawn at 0.6–1.4× its typical size, well above
    the noise); the bench it wrote is readable and its truth is kept outside it."""
    effects = ("crank_eccentricity_error", "pin_ring_runout")
    quick = rvflex.DiagnosisSettings(max_order=15, hysteresis_steps=16, refine_top=1, refine_iterations=2)
    doc = rvflex.selfcheck(tmp_path, cases=1, seed=1, effects=effects, nominal=(), settings=quick)
    json.dumps(doc)
    assert {"cases", "top1_rate", "top2_rate", "magnitude_within_25pct_rate", "median_gap_shrink_pct",
            "control_correct_rate", "calibration_rate", "wall_s", "per_case", "settings"} <= doc.keys()
    assert doc["cases"] == doc["effect_cases"] == 1 and doc["top2_rate"] == 1.0
    assert doc["settings"]["effects"] == effects and doc["settings"]["diagnosis"]["max_order"] == 15
    assert len(rvflex.read_bench(tmp_path / "datasets" / "case_00").runs) == 4
    assert not list((tmp_path / "datasets").rglob("*.json"))
    # the case's diagnosis is kept as `rvflex diagnose --json` writes it, and the score row reads the same ranking
    report = json.loads((tmp_path / "reports" / "case_00.json").read_text())
    assert [e["name"] for e in report["effects"]][:2] == doc["per_case"][0]["ranked"][:2]
    # run again with reuse_benches: the same bench (same key) is diagnosed again, not rewritten, with the same
    # ranking; a bench whose key does not match (another draw) is written afresh
    bench = tmp_path / "datasets" / "case_00" / "bench.toml"
    stamp = bench.stat().st_mtime_ns
    again = rvflex.selfcheck(tmp_path, cases=1, seed=1, effects=effects, nominal=(), settings=quick, reuse_benches=True)
    assert again["benches_reused"] == 1 and bench.stat().st_mtime_ns == stamp
    assert again["per_case"][0]["ranked"][:2] == doc["per_case"][0]["ranked"][:2]
    (tmp_path / "truth" / "case_00.key").write_text("another draw")
    third = rvflex.selfcheck(tmp_path, cases=1, seed=1, effects=effects, nominal=(), settings=quick, reuse_benches=True)
    assert third["benches_reused"] == 0 and bench.stat().st_mtime_ns != stamp

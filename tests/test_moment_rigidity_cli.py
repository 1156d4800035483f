"""`rvflex moment-rigidity`: the printed figure, its JSON and files (the unit's and the pair's figures), and the
one-line refusals (a moment beyond the allowable, a spec without the main bearing pair)."""

from __future__ import annotations

import dataclasses
import json

import pytest

from rvflex import catalog
from rvflex.cli import main
from rvflex.spec import dumps_spec


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("mr")
    code = main(["moment-rigidity", "--reducer", "rv40e", "--steps", "10", "--json", str(out / "m.json"),
                 "--out", str(out / "files")])
    return code, out


def test_json_has_the_figure_the_curve_and_the_inputs(run):
    code, out = run
    assert code == 0
    doc = json.loads((out / "m.json").read_text())
    assert doc.keys() >= {"reducer", "metrics", "curve", "inputs", "wall_s"}
    met, curve = doc["metrics"], doc["curve"]
    assert met["moment_Nm"] == 2300.0 == doc["inputs"]["allowable_moment_Nm"]
    assert len(curve["moment_Nm"]) == len(curve["tilt_arcmin"]) == 21
    # each figure is the secant of the curve it ships with; the default figure is the unit's
    secant = 2 * curve["moment_Nm"][-1] / (curve["tilt_arcmin"][-1] - curve["tilt_arcmin"][0])
    assert met["pair_moment_rigidity_Nm_per_arcmin"] == pytest.approx(secant, rel=1e-12)
    unit = doc["unit_curve"]
    assert met["model"] == doc["inputs"]["model"] == "unit" and len(unit["moment_Nm"]) == 9
    assert unit["moment_Nm"][0] == -2300.0 and unit["moment_Nm"][-1] == 2300.0
    secant = 2 * unit["moment_Nm"][-1] / (unit["tilt_arcmin"][-1] - unit["tilt_arcmin"][0])
    assert met["moment_rigidity_Nm_per_arcmin"] == met["unit_moment_rigidity_Nm_per_arcmin"]
    assert met["unit_moment_rigidity_Nm_per_arcmin"] == pytest.approx(secant, rel=1e-12)
    assert met["unit_torque_Nm"] == doc["inputs"]["torque_Nm"] == 412.0  # the rated torque
    assert 0 < met["contact_loss_moment_Nm"] < met["moment_Nm"]
    assert doc["inputs"]["main_pair"]["preload_N"] == 1000.0
    assert met["catalogue_moment_rigidity_Nm_per_arcmin"] is None  # none sourced for the built-in units


def test_out_writes_plot_curve_and_json(run):
    _, out = run
    files = out / "files"
    png = (files / "moment_rigidity.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 30_000
    assert (files / "moment_rigidity.csv").read_text().splitlines()[0] == \
        "moment_Nm,tilt_arcmin,peak_pressure_Pa,balls_in_contact"
    assert json.loads((files / "moment_rigidity.json").read_text())["reducer"] == "rv40e"


def test_printed_line_states_the_figure_and_its_basis(capsys):
    assert main(["moment-rigidity", "--reducer", "rv80e", "--moment", "1000", "--steps", "4"]) == 0
    text = capsys.readouterr().out
    assert "moment rigidity" in text and "N·m/arcmin (secant over ±1000 N·m)" in text
    assert "main bearing ball contacts only" in text


def test_model_pair_gives_the_pair_alone(tmp_path, capsys):
    assert main(["moment-rigidity", "--reducer", "rv40e", "--model", "pair", "--steps", "4",
                 "--json", str(tmp_path / "p.json")]) == 0
    doc = json.loads((tmp_path / "p.json").read_text())
    met = doc["metrics"]
    assert doc["unit_curve"] is None and met["unit_moment_rigidity_Nm_per_arcmin"] is None
    assert met["model"] == "pair" and met["moment_rigidity_Nm_per_arcmin"] == met["pair_moment_rigidity_Nm_per_arcmin"]
    assert "of the unit" not in capsys.readouterr().out


@pytest.mark.parametrize("model", ["unit", "pair"])
def test_a_moment_beyond_the_allowable_is_one_line_naming_flag_and_limit(tmp_path, capsys, model):
    code = main(["moment-rigidity", "--reducer", "rv40e", "--model", model, "--moment", "5000",
                 "--json", str(tmp_path / "x.json")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert err == ["rvflex: error: --moment = 5000.0: must lie in (0, 2300] N·m (the allowable moment of rv40e)"]
    assert not (tmp_path / "x.json").exists()


def test_a_spec_without_the_pair_is_one_line(tmp_path, capsys):
    spec = catalog.load("rv40e")
    bare = dataclasses.replace(spec, bearings=dataclasses.replace(spec.bearings, main_pair=None))
    path = tmp_path / "mine.toml"
    path.write_text(dumps_spec(bare))
    code = main(["moment-rigidity", "--reducer", str(path)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert "bearings.main_pair = None: rv40e gives no main bearing pair geometry" in err[0]
    # the same file serves the planar commands as before
    assert main(["geometry", "--reducer", str(path), "--json", str(tmp_path / "g.json")]) == 0

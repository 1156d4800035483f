"""The `rvflex geometry` command: JSON keys, figure, and refusal of bad input without output; the
help of the commands states the defaults the code uses; `rvflex reduce` defaults to the presets; a
failing FE build and a non-converging run are one line and exit code 1 (no traceback without --debug)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from rvflex.cli import main

KEYS = {"ratio", "K1", "zc", "zb", "min_initial_clearance_um", "max_pressure_angle_deg",
        "backlash_formula_arcmin", "gap_max_error_m", "gap_eval_us_80_pins"}


@pytest.fixture(scope="module")
def geometry_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("geom")
    code = main(["geometry", "--reducer", "rv40e", "--json", str(out / "g.json"), "--out", str(out / "plots")])
    return code, out


def test_geometry_json(geometry_run):
    code, out = geometry_run
    assert code == 0
    g = json.loads((out / "g.json").read_text())
    assert KEYS <= g.keys()
    assert g["ratio"] == 121.0 and g["K1"] < 1 and (g["zc"], g["zb"]) == (39, 40)
    assert g["gap_max_error_m"] <= 1e-9
    # seed 004 modification: tip/root clearance Δr_rp − Δr_p = 8 µm is the smallest
    assert g["min_initial_clearance_um"] == pytest.approx(8.0, abs=1e-6)
    # pressure angle over the loaded flank: between the cycloid's minimum (≈ 39°) and 90°
    assert 39.0 < g["max_pressure_angle_deg"] < 90.0
    assert g["backlash_formula_arcmin"] == pytest.approx(1.8738, abs=1e-4)
    assert g["gap_eval_us_80_pins"] > 0


def test_geometry_writes_a_real_png(geometry_run):
    _, out = geometry_run
    png = out / "plots" / "profile.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert png.stat().st_size > 50_000  # three panels of lines and labels, not an empty canvas
    assert json.loads((out / "plots" / "geometry.json").read_text()).keys() >= KEYS


def test_unknown_reducer_is_refused_and_nothing_written(tmp_path, capsys):
    code = main(["geometry", "--reducer", "rv41e", "--json", str(tmp_path / "g.json"), "--out", str(tmp_path / "o")])
    assert code == 2
    err = capsys.readouterr().err
    assert "--reducer = 'rv41e': unknown reducer; built-in: rv160n, rv40e, rv80e" in err
    assert list(tmp_path.iterdir()) == []


def test_bad_spec_file_is_refused_with_one_message(tmp_path):
    from importlib import resources

    text = resources.files("rvflex.catalog").joinpath("rv40e.toml").read_text()
    bad = tmp_path / "mine.toml"
    bad.write_text(text.replace("pin_circle_radius_m = 0.066 ", "pin_circle_radius_m = 66.0 "))
    proc = subprocess.run([sys.executable, "-m", "rvflex.cli", "geometry", "--reducer", str(bad),
                           "--json", str(tmp_path / "g.json")], capture_output=True, text=True)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert lines == [f"rvflex: error: {bad}: cycloid.pin_circle_radius_m = 66.0: expected metres, 5 mm to 1 m"]
    assert not (tmp_path / "g.json").exists()


def test_bench_contact_json_keys(tmp_path):
    """The benchmark command end to end (with a coarse polygon to keep it short)."""
    path = tmp_path / "c.json"
    assert main(["bench", "contact", "--segments", "2000", "--json", str(path)]) == 0
    c = json.loads(path.read_text())
    assert {"eval_us_per_call", "noise_floor_te_pp_arcsec", "ours_steps_per_s", "curvecircles_steps_per_s",
            "speedup", "ours_geom_error_m", "curvecircles_geom_error_m"} <= c.keys()
    assert c["noise_floor_te_pp_arcsec"] <= 0.05
    assert c["ours_geom_error_m"] < 1e-9 < c["curvecircles_geom_error_m"]
    assert c["speedup"] > 1.0


# --------------------------------------------------------------------------- help states the code's defaults


def _help(capsys, *argv: str) -> str:
    """The --help text of ``rvflex argv``, whitespace collapsed."""
    with pytest.raises(SystemExit):
        main([*argv, "--help"])
    return " ".join(capsys.readouterr().out.split())


def test_model_command_help_states_the_preset_reductions(capsys):
    from rvflex.options import CARRIER_FE, DISC_FE

    for command in ("te", "lost-motion", "backlash"):
        text = _help(capsys, command)
        assert (f"preset's disc settings: {DISC_FE.maxh_m:g} m, order {DISC_FE.mesh_order}, {DISC_FE.n_modes} modes, "
                f"{DISC_FE.attach_per_tooth} attachment patches/tooth; carrier: {CARRIER_FE.maxh_m:g} m, order "
                f"{CARRIER_FE.mesh_order}, {CARRIER_FE.n_modes} modes, {CARRIER_FE.seat_coupling} seats") in text
        assert f"fixed-interface eigenmodes (default {DISC_FE.n_modes})" in text
        assert "(default rigid)" in text and "default: no errors" in text
    from rvflex.scenarios.reversal_backlash import DEFAULT_LOAD_FRACTION

    assert f"default: {DEFAULT_LOAD_FRACTION * 100:g} % of rated" in _help(capsys, "backlash")


def test_reduce_help_states_the_one_default_reduction_per_part(capsys):
    from rvflex.fe.reduce import DEFAULTS, DISC_FLANK_BASIS
    from rvflex.options import CARRIER_FE, DISC_FE

    assert DEFAULTS["disc"] is DISC_FE and DEFAULTS["carrier"] is CARRIER_FE
    text = _help(capsys, "reduce")
    assert (f"disc maxh {DISC_FE.maxh_m * 1e3:g} mm, {DISC_FE.n_modes} eigenmodes, order-{DISC_FE.mesh_order} tets, "
            "curvature safety 1, no flank attachment modes") in text
    assert f"carrier maxh {CARRIER_FE.maxh_m * 1e3:g} mm, {CARRIER_FE.n_modes} eigenmodes" in text
    assert f"(default {DISC_FE.n_modes} for the disc, {CARRIER_FE.n_modes} for the carrier)" in text
    assert f"--modes {DISC_FLANK_BASIS.n_modes} --attach {DISC_FLANK_BASIS.attach_per_tooth}" in text


def test_reduce_command_reduces_with_the_model_presets(monkeypatch, capsys):
    """``rvflex reduce`` without settings reduces each part exactly as the flexible presets do
    (the uncached build step is stood in for, so nothing is meshed); flags override fields."""
    from rvflex.fe import reduce
    from rvflex.fe.reduce import DISC_FLANK_BASIS
    from rvflex.options import ModelOptions

    seen = {}

    class Built(Exception):
        pass

    def stand_in(spec, part, settings, key, progress):
        seen[part] = settings
        raise Built

    monkeypatch.setattr(reduce, "_build", stand_in)
    for part, want in (("disc", ModelOptions.flexible_discs().discs),
                       ("carrier", ModelOptions.flexible_discs_and_carrier().carrier)):
        assert main(["reduce", "--reducer", "rv40e", "--part", part, "--no-cache"]) == 1  # Built: a failure
        assert seen[part] == want
    assert main(["reduce", "--reducer", "rv40e", "--part", "disc", "--no-cache", "--modes", "10", "--attach", "2"]) == 1
    assert seen["disc"] == DISC_FLANK_BASIS
    seen.clear()
    assert main(["reduce", "--reducer", "rv40e", "--part", "carrier", "--attach", "2"]) == 2
    assert "--attach = 2: flank attachment modes apply to --part disc only" in capsys.readouterr().err
    assert not seen


# --------------------------------------------------------------------------- failures: one line, no traceback

FIXTURES = Path(__file__).parent / "fixtures"


def _last_line(err: str) -> str:
    return err.replace("\r", "\n").strip().splitlines()[-1]


def test_a_failing_fe_build_is_one_message_and_exit_1(tmp_path, monkeypatch, capsys, netgen_fails):
    """netgen failing to mesh the disc (as in tests/test_fe.py) under ``rvflex te --fidelity
    flexible``: one line naming the unit, the run, the part and its settings; exit code 1; no
    traceback unless --debug. ``rvflex.run`` raises RunError with the same line, the FEError as cause."""
    import rvflex
    from rvflex.fe.types import FEError

    monkeypatch.setenv("RVFLEX_CACHE_DIR", str(tmp_path))  # cold: the reduction must run
    want = ("rv40e, loaded TE (flexible, 412 N·m, 16 positions/rev): meshing/assembly of the disc (maxh 6 mm, "
            "order 2, 12 modes) failed: netgen: surface meshing failed")
    assert main(["te", "--reducer", "rv40e", "--fidelity", "flexible", "--positions", "16"]) == 1
    err = capsys.readouterr().err
    assert _last_line(err) == f"rvflex: error: {want}"
    assert "Traceback" not in err and sum(ln.startswith("rvflex:") for ln in err.splitlines()) == 1
    assert main(["te", "--reducer", "rv40e", "--fidelity", "flexible", "--positions", "16", "--debug"]) == 1
    err = capsys.readouterr().err
    assert "Traceback (most recent call last)" in err and "FEError" in err and _last_line(err) == f"rvflex: error: {want}"
    with pytest.raises(rvflex.RunError) as info:
        rvflex.run(rvflex.LoadedTE(rvflex.load_reducer("rv40e"), positions_per_rev=16, options="flexible"))
    assert str(info.value) == want and isinstance(info.value.__cause__, FEError)
    assert (info.value.unit, info.value.failure.split(":")[0]) == ("rv40e", "meshing/assembly of the disc (maxh 6 mm, order 2, 12 modes) failed")


def test_a_non_converging_run_is_one_message_and_exit_1(monkeypatch):
    """A unit whose hysteresis cycle does not converge at its ±3 % step under Exudyn's solver (an equilibrium
    where a contact begins, measured in the seed-3 self-check; tests/fixtures/rv40e_kinked_free_play*.toml;
    the compiled step, with its exact Jacobian, takes it): with ``RVFLEX_SOLVER=exudyn`` the real command in
    its own process prints one line on stderr, nothing on stdout (Exudyn's banners are for --debug), and exits
    1. ``rvflex.run`` raises RunError with the SolveError as cause."""
    import rvflex
    from rvflex.solve import SOLVER_ENV, SolveError

    monkeypatch.setenv(SOLVER_ENV, "exudyn")
    args = ["lost-motion", "--reducer", str(FIXTURES / "rv40e_kinked_free_play.toml"),
            "--errors", str(FIXTURES / "rv40e_kinked_free_play.errors.toml"), "--steps", "40"]
    proc = subprocess.run([sys.executable, "-m", "rvflex.cli", *args], capture_output=True, text=True)
    want = ("rv40e-kinked-free-play, lost motion (rigid, ±412 N·m, 40 steps): torque step 4 (12.360 N·m) did not "
            "converge: SolveStatic terminated due to errors")
    assert proc.returncode == 1
    assert proc.stdout.strip() == ""
    assert _last_line(proc.stderr) == f"rvflex: error: {want}" and "Traceback" not in proc.stderr
    spec = rvflex.load_reducer(FIXTURES / "rv40e_kinked_free_play.toml")
    errors = rvflex.load_errors(FIXTURES / "rv40e_kinked_free_play.errors.toml", spec)
    with pytest.raises(rvflex.RunError) as info:
        rvflex.run(rvflex.LostMotion(spec, errors, steps=40))
    assert str(info.value) == want and isinstance(info.value.__cause__, SolveError)


def test_reduce_command_reduces_the_disc_a_three_crank_unit_needs(monkeypatch, capsys):
    """``rvflex reduce --part disc --disc 1`` on the RV-160N class (three cranks, discs 180° apart):
    the reduction of disc 1's own geometry — cranks turned by π/39 against the teeth (the build
    step is stood in for, so nothing is meshed); on the RV-40E disc 1 is disc 0 turned: the same spec."""
    import math

    from rvflex import catalog
    from rvflex.fe import reduce

    seen = []

    def stand_in(spec, part, settings, key, progress):
        seen.append(spec)
        raise RuntimeError("stood in")

    monkeypatch.setattr(reduce, "_build", stand_in)
    assert main(["reduce", "--reducer", "rv160n", "--part", "disc", "--disc", "1", "--no-cache"]) == 1
    a0 = catalog.load("rv160n").cranks.angles_rad
    assert seen[-1].cranks.angles_rad == pytest.approx([(a + math.pi / 39) % (2 * math.pi) for a in a0], abs=1e-12)
    assert main(["reduce", "--reducer", "rv40e", "--part", "disc", "--disc", "1", "--no-cache"]) == 1
    assert seen[-1] == catalog.load("rv40e")
    assert main(["reduce", "--reducer", "rv40e", "--part", "carrier", "--disc", "1"]) == 2
    assert "--disc = 1: applies to --part disc, 0 to 1" in capsys.readouterr().err


def test_a_failing_build_of_a_discs_own_fe_body_names_that_disc(tmp_path, monkeypatch):
    """Three cranks: disc 1 has its own FE body; when its meshing fails (disc 0 reduced before
    netgen breaks), the RunError names disc 1 and its geometry."""
    import netgen.occ

    import rvflex
    from rvflex.fe.reduce import reduce_part
    from rvflex.scenarios.unit_matrix import COARSE_DISC, options_for

    class Broken:
        def __init__(self, shape):
            pass

        def GenerateMesh(self, **kw):
            raise RuntimeError("netgen: surface meshing failed")

    monkeypatch.setenv("RVFLEX_CACHE_DIR", str(tmp_path))
    spec = rvflex.load_reducer(FIXTURES / "drive3_user.toml")
    reduce_part(spec, "disc", **COARSE_DISC)  # disc 0 in the cache
    monkeypatch.setattr(netgen.occ, "OCCGeometry", Broken)
    with pytest.raises(rvflex.RunError) as info:
        rvflex.run(rvflex.LoadedTE(spec, positions_per_rev=16, options=options_for("flexible", coarse=True)))
    assert info.value.failure.startswith("disc 1's own FE body (cranks and pillars turned by 0.089760 rad against "
                                         "the teeth): meshing/assembly of the disc (maxh 8 mm, order 1, 12 modes) "
                                         "failed: netgen: surface meshing failed")

"""``rvflex validate``: row structure, bad input, a failing reproduction, and one quick
reproduction (seed 002, about 20 s) checked for physical sense."""

from __future__ import annotations

import json
import math

import pytest

from rvflex import validate
from rvflex.cli import main

KEYS = {"seed", "quantity", "unit", "published", "rvflex", "band_low", "band_high", "inside", "command", "wall_s"}


def test_unknown_only_lists_the_known_reproductions(capsys):
    assert main(["validate", "--only", "seed9"]) == 2
    err = capsys.readouterr().err
    assert "unknown reproduction seed9" in err
    for name in ("seed000", "seed001", "seed002", "seed003", "seed004"):
        assert name in err


def test_every_seed_has_checks_with_bands_stated_before_running():
    assert list(validate.REPRODUCTIONS) == ["seed000", "seed001", "seed002", "seed003", "seed004"]
    for rep in validate.REPRODUCTIONS.values():
        assert rep.checks
        for c in rep.checks:
            assert c.command and c.unit and c.quantity
            if c.published is not None and math.isfinite(c.published):
                assert c.band_low <= c.band_high
                # ±50 % of a published absolute figure, or a class interval 0…limit, or ≥ 8/10
                assert c.band_low <= c.published <= c.band_high


def test_a_failing_reproduction_gives_null_rows_and_the_others_run(monkeypatch, tmp_path):
    def boom(quick, out):
        raise RuntimeError("solver did not converge at step 7")

    ok = validate.Reproduction("ok", "ok", (validate.Check("x", "x", "–", 1.0, 0.5, 1.5, "cmd"),),
                               lambda quick, out: {"x": 1.2})
    bad = validate.Reproduction("bad", "bad", (validate.Check("y", "y", "–", 2.0, 1.0, 3.0, "cmd"),), boom)
    monkeypatch.setattr(validate, "REPRODUCTIONS", {"bad": bad, "ok": ok})
    rows = validate.run_validation()
    assert [r.seed for r in rows] == ["bad", "ok"]
    assert rows[0].inside is None and rows[0].rvflex is None and "did not converge at step 7" in rows[0].note
    assert rows[1].inside is True and rows[1].rvflex == 1.2
    doc = [r.as_json() for r in rows]
    assert KEYS <= set(doc[0]) and "note" in doc[0] and "note" not in doc[1]
    md = validate.write_markdown(rows, tmp_path / "validation.md", quick=True, wall_s=1.0)
    text = md.read_text()
    assert "| bad |" in text and validate.NOTES_MARKER in text
    md.write_text(text + "\nhand-written discussion\n")
    validate.write_markdown(rows, md, quick=True, wall_s=1.0)
    assert "hand-written discussion" in md.read_text()  # kept on regeneration


def test_quick_seed002_rows_are_physical(tmp_path):
    """Seed 002 at reduced resolution: the compensated profile has less backlash than the
    traditional one (the compensation, about 1.8 µm, takes clearance out of every flank) and the
    same-sign, plausible stiffness; the locked-input backlash is within 5 % of seed 002's ε
    formula (first order, and the cranks roll on the locked sun: factor 0.967)."""
    out = tmp_path / "v.json"
    assert main(["validate", "--quick", "--only", "seed002", "--json", str(out), "--out", str(tmp_path / "d")]) == 0
    rows = json.loads(out.read_text())
    assert all(KEYS <= set(r) for r in rows)
    assert all(r["seed"] == "seed002" and r["rvflex"] is not None and r["wall_s"] > 0 for r in rows)
    v = {r["quantity"]: r for r in rows}
    trad, comp = v["backlash, traditional modification"], v["backlash, deformation-compensated"]
    assert 0.5 < trad["rvflex"] < 3.0  # arcmin: 8–12 µm flank clearance on a 66 mm pin circle
    assert 0 < comp["rvflex"] < trad["rvflex"]
    k = v["torsional stiffness (secant over ±T_r), traditional"]["rvflex"]
    assert 50 < k < 300  # N·m/arcmin; rigid discs: stiffer than the catalogue's ~113, not by 3×
    eps = next(r for r in rows if r["quantity"].startswith("backlash: model"))
    assert eps["inside"] is True and eps["rvflex"] == pytest.approx(eps["published"], rel=0.05)
    assert (tmp_path / "d" / "validation.md").is_file() and (tmp_path / "d" / "seed002" / "comparison.png").is_file()

"""The flexibility notebook (scenarios/flexibility.ipynb) runs headless at coarse settings and
its figures are physical: nbclient executes it in the environment's own ``python3`` kernel
(ipykernel) with a cell injected after the one tagged ``parameters`` (papermill's scheme
without papermill), on the coarse disc reduction of tests/test_flexible.py (8 mm linear tets,
6 static + 12 fixed-interface modes), a few positions and a cold, private FE cache."""

from __future__ import annotations

import ast
import json
import math
import sys
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

pytestmark = pytest.mark.flexible

NOTEBOOK = Path(__file__).resolve().parents[1] / "scenarios" / "flexibility.ipynb"
COARSE = {"maxh_m": 8e-3, "n_modes": 12, "mesh_order": 1}  # test_flexible.COARSE (attach_per_tooth 0 is the default)
OVERRIDES = {
    **COARSE,
    "load_fraction": 1.0,
    "load_fractions": (0.5, 1.0),
    "n_positions": 8,
    "mode_counts": (12,),            # the studies rerun the base reduction only: each further
    "mesh_sizes_m": (8e-3,),         # setting is a cold reduction of ~15 s
    "hysteresis_steps": 80,          # 40 steps let the flexible cycle jump a pin pitch near zero torque
    "carrier_flexible": True,        # the carrier section, on a coarse carrier as tests/test_flexible_carrier.py
    "carrier_maxh_m": 8e-3,
    "carrier_mesh_order": 1,
    "carrier_n_modes": 6,
}
MARK = "NOTEBOOK-SUMMARY "


def _parameters_index(nb) -> int:
    tagged = [i for i, c in enumerate(nb.cells) if "parameters" in c.metadata.get("tags", [])]
    assert len(tagged) == 1, "the notebook needs exactly one cell tagged 'parameters'"
    return tagged[0]


def test_the_stored_notebook_is_clean():
    """No stored outputs or execution counts, one parameters cell that defines every name the
    CI run overrides, and the python3 kernel."""
    nb = nbformat.read(NOTEBOOK, as_version=4)
    nbformat.validate(nb)
    assert nb.metadata["kernelspec"]["name"] == "python3"
    for cell in nb.cells:
        if cell.cell_type == "code":
            assert cell.outputs == [] and cell.execution_count is None
    assigned = {t.id: node.value for node in ast.parse(nb.cells[_parameters_index(nb)].source).body
                if isinstance(node, ast.Assign) for t in node.targets if isinstance(t, ast.Name)}
    assert set(OVERRIDES) <= set(assigned)
    assert ast.literal_eval(assigned["carrier_flexible"]) is False


@pytest.fixture(scope="module")
def executed(tmp_path_factory):
    nb = nbformat.read(NOTEBOOK, as_version=4)
    injected = nbformat.v4.new_code_cell("# Injected parameters (tests/test_notebook.py)\n"
                                         + "\n".join(f"{k} = {v!r}" for k, v in OVERRIDES.items()))
    injected.metadata["tags"] = ["injected-parameters"]
    nb.cells.insert(_parameters_index(nb) + 1, injected)
    nb.cells.append(nbformat.v4.new_code_cell(
        f"import json, sys\nprint({MARK!r} + json.dumps({{'summary': summary, 'prefix': sys.prefix}}, default=float))"))
    mp = pytest.MonkeyPatch()
    mp.setenv("RVFLEX_CACHE_DIR", str(tmp_path_factory.mktemp("fe-cache")))  # the kernel inherits the environment
    mp.setenv("MPLBACKEND", "module://matplotlib_inline.backend_inline")
    try:
        NotebookClient(nb, kernel_name="python3", timeout=600,
                       resources={"metadata": {"path": str(tmp_path_factory.mktemp("nb-run"))}}).execute()
    finally:
        mp.undo()
    text = "".join(o.get("text", "") for o in nb.cells[-1].outputs if o.output_type == "stream")
    line = next(x for x in text.splitlines() if x.startswith(MARK))
    return nb, json.loads(line[len(MARK):])


def test_the_notebook_runs_in_this_environment_and_shows_its_plots(executed):
    """The kernel is this environment's Python, and every section drew its figure."""
    nb, out = executed
    assert Path(out["prefix"]).resolve() == Path(sys.prefix).resolve()
    pngs = sum("image/png" in o.get("data", {}) for c in nb.cells if c.cell_type == "code" for o in c.outputs)
    assert pngs >= 4  # TE, load study, mode/mesh study, hysteresis


def test_the_elastic_discs_add_wind_up_that_grows_with_the_load(executed):
    """At every load the flexible unit winds up more than the rigid one (TE is negative under
    a resisting torque); the added wind-up grows with the load, about in proportion (linear
    disc elasticity; the contact's load sharing bends it a little), and at rated torque it is
    a few arcseconds, as in tests/test_flexible.py; the elastic ripple dominates the TE."""
    s = executed[1]["summary"]
    loads = s["loads"]
    assert [r["load_Nm"] for r in loads] == pytest.approx([206.0, 412.0])
    for r in loads:
        assert r["windup_flexible"] < r["windup_rigid"] < 0.0
        assert 0.0 < r["share_windup"] < 0.5
    half, rated = (-r["elastic_windup"] for r in loads)
    assert 1.5 * half < rated < 2.5 * half
    assert -20.0 < s["windup_flexible_arcsec"] - s["windup_rigid_arcsec"] < -1.0
    assert s["te_pp_flexible_arcsec"] > 5 * s["te_pp_rigid_arcsec"]


def test_the_mode_and_mesh_study_rebuild_the_base_model(executed):
    """The study rows pass their settings through build_reducer: the base setting (12 modes,
    8 mm) reproduces section 2's flexible run, and the basis is 6 bore modes + 12 eigenmodes."""
    s = executed[1]["summary"]
    for row in (*s["mode_study"], *s["mesh_study"]):
        assert (row["n_modes"], row["maxh_m"], row["modes_total"]) == (12, 8e-3, 18)
        assert row["windup"] == pytest.approx(s["windup_flexible_arcsec"], abs=1e-6)
        assert row["te_pp"] == pytest.approx(s["te_pp_flexible_arcsec"], abs=1e-6)


def test_the_discs_lower_the_torsional_stiffness_not_the_lost_motion(executed):
    """The discs' compliance adds in series (a minor share of the unit's); the lost motion at
    ±3 % T_r is the modification's free play, which elastic discs barely change."""
    s = executed[1]["summary"]
    rigid, flexible = s["hysteresis"]["rigid"], s["hysteresis"]["flexible"]
    assert flexible["torsional_stiffness_Nm_per_arcmin"] < rigid["torsional_stiffness_Nm_per_arcmin"]
    assert 0.0 < s["discs_share_of_compliance"] < 0.5
    assert math.isfinite(flexible["lost_motion_arcmin"])  # no spurious jump in the cycle
    assert flexible["lost_motion_arcmin"] == pytest.approx(rigid["lost_motion_arcmin"], abs=0.05)


def test_the_flexible_carrier_adds_wind_up(executed):
    """carrier_flexible = True: the FE-reduced carrier (coarse) winds the output up further than
    flexible discs alone — its seats yield under the crank loads (tens of arcseconds at rated
    torque on the RV-40E, tests/test_flexible_carrier.py)."""
    s = executed[1]["summary"]
    carrier = s["carrier"]
    assert carrier["status"] == "run"
    assert -120.0 < carrier["windup"] - s["windup_flexible_arcsec"] < -10.0

"""The power-law bearing (``Bearing.load_exponent``, ``reference_load_N``): the law itself, its spec rules, the
compiled step against Exudyn's symbolic law (two implementations of one law), its load dependence in a unit, and
the ensemble's needle bearings drawn with it."""

import dataclasses as dc
from dataclasses import dataclass

import numpy as np
import pytest

from rvflex import catalog
from rvflex.bench_te import clearance_errors
from rvflex.contact.bearing import radial_force_N
from rvflex.diagnosis.ensemble import needle_reference_load
from rvflex.model import build_reducer
from rvflex.options import ModelOptions
from rvflex.spec import ErrorSpec, SpecError

ARCSEC_PER_RAD = 206264.806


def _power_needles(spec, exponent: float = 10.0 / 9.0, load_N: float | None = None):
    """``spec`` with its needle (eccentric) bearings on a power law of secant stiffness k at ``load_N`` (default the
    bearing's load at rated torque)."""
    b = spec.bearings
    ecc = dc.replace(b.eccentric, load_exponent=exponent,
                     reference_load_N=needle_reference_load(spec) if load_N is None else load_N)
    return dc.replace(spec, bearings=dc.replace(b, eccentric=ecc))


def test_the_power_law_carries_its_reference_load_at_its_secant_stiffness():
    k, f_r, e, eps = 5.1e8, 2000.0, 10.0 / 9.0, 3e-6
    x_r = f_r / k
    d = eps + np.array([0.5, 1.0, 2.0]) * x_r
    f = radial_force_N(d, stiffness_N_m=k, clearance_m=eps, load_exponent=e, reference_approach_m=x_r)
    assert f == pytest.approx(f_r * np.array([0.5, 1.0, 2.0]) ** e, rel=1e-12)  # beyond the 0.1 µm band: exact
    assert radial_force_N(eps - 0.2e-6, stiffness_N_m=k, clearance_m=eps, load_exponent=e,
                          reference_approach_m=x_r) == 0.0
    # softer than the linear law below the reference load, stiffer above
    lin = radial_force_N(d, stiffness_N_m=k, clearance_m=eps)
    assert f[0] < lin[0] and f[1] == pytest.approx(lin[1], rel=1e-12) and f[2] > lin[2]


def test_a_power_law_needs_both_fields_in_range():
    ecc = catalog.load("rv40e").bearings.eccentric
    with pytest.raises(SpecError, match=r"^reference_load_N = None: a power-law bearing needs both"):
        dc.replace(ecc, load_exponent=1.1)
    with pytest.raises(SpecError, match=r"^load_exponent = None: a power-law bearing needs both"):
        dc.replace(ecc, reference_load_N=2000.0)
    with pytest.raises(SpecError, match=r"^load_exponent = 0.9: expected 1 \(linear\) to 2"):
        dc.replace(ecc, load_exponent=0.9, reference_load_N=2000.0)
    with pytest.raises(SpecError, match=r"^reference_load_N = -5.0: expected N"):
        dc.replace(ecc, load_exponent=1.1, reference_load_N=-5.0)


@pytest.mark.parametrize("clearance", [True, False])
def test_the_compiled_power_law_is_exudyns(clearance):
    """At a loaded, perturbed state of the RV-40E with power-law needles (with seed 001's 12 µm clearances, and
    without any: the law from zero approach) the compiled force equals Exudyn's residual to rounding, as for the
    linear law (tests/test_engine.py). Its Jacobian equals central differences of that residual to 1e-6, and
    Exudyn's own Jacobian to 1e-4: Exudyn takes forward differences (relative step 1e-7), whose error grows with
    the law's curvature, d^(e−2) at a few µm of approach without clearance (measured 2.4e-5 there)."""
    from tests.test_engine import compiled_residual_is_exudyns

    spec = _power_needles(catalog.load("rv40e"))
    model = build_reducer(spec, clearance_errors(spec) if clearance else ErrorSpec(), "rigid")
    step, q, free, jc, jx = compiled_residual_is_exudyns(model, spec)
    central = np.empty_like(jc)
    h = 1e-11  # m or rad: 1e-5 of the approach, so the central difference's error (h²) stays below 1e-9
    for a, i in enumerate(free):
        up, down = q.copy(), q.copy()
        up[i] += h
        down[i] -= h
        central[:, a] = (step.residual(up)[0][free] - step.residual(down)[0][free]) / (2.0 * h)
    assert np.abs(jc - central).max() < 1e-6 * np.abs(jc).max()
    assert np.abs(jc - jx).max() < 1e-4 * np.abs(jx).max()


def test_power_law_needles_reach_exudyns_equilibria_and_soften_the_unit_at_part_load():
    """Over one crank turn (32 positions) the compiled run gives Exudyn's TE within 1e-4″. Against linear needles
    of the same secant stiffness at the reference load (2.1 kN, about two-thirds of the 3.2 kN mean the RV-40E's
    needles carry at rated torque), the power law (e = 10/9) is a little stiffer at rated torque, (3.2/2.1)^(1/9)
    ≈ 1.05 in secant stiffness, and softer at a fifth of it, ≈ 0.88: the unit winds up up to 2.5 % less at rated
    torque and more at a fifth (the needles are a fraction of the unit's compliance)."""
    from rvflex import solve

    lin = catalog.load("rv40e")
    spec = _power_needles(lin)
    theta = np.linspace(0.0, 2 * np.pi * lin.ratio / lin.cycloid.pin_count, 32, endpoint=False)
    fast = solve.quasi_static(build_reducer(spec, None, "rigid"), theta, spec.rated_torque_Nm)
    exudyn = solve.quasi_static(build_reducer(spec, None, "rigid"), theta, spec.rated_torque_Nm, chord_newton=False)
    assert fast.compiled is not None and exudyn.compiled is None
    assert np.abs(fast.te_rad - exudyn.te_rad).max() * ARCSEC_PER_RAD < 1e-4

    def windup(s, torque):
        return solve.quasi_static(build_reducer(s, None, "rigid"), theta, torque).te_rad.mean()

    rated = windup(spec, lin.rated_torque_Nm) / windup(lin, lin.rated_torque_Nm)
    fifth = windup(spec, 0.2 * lin.rated_torque_Nm) / windup(lin, 0.2 * lin.rated_torque_Nm)
    assert 0.975 < rated < 1.0, rated
    assert 1.003 < fifth < 1.05, fifth


def test_the_ensemble_draws_power_law_needles_for_the_share_asked():
    """``needle_power_share`` 0.5 (the default, the shipped null's ensemble): about half the units; 0: none, and
    every other drawn value the same (the needle law has a stream of its own)."""
    from rvflex.diagnosis.ensemble import NEEDLE_EXPONENT_RANGE, EnsembleMismatch, needle_reference_load

    gen, spec = EnsembleMismatch(), catalog.load("rv80e")
    assert gen.needle_power_share == 0.5
    drawn = [gen.draw(np.random.default_rng(s)) for s in range(200)]
    plain = [EnsembleMismatch(needle_power_share=0.0).draw(np.random.default_rng(s)) for s in range(200)]
    assert all(p["needle_exponent"] is None for p in plain)
    assert [{**d, "needle_exponent": None} for d in drawn] == plain
    power = [d for d in drawn if d["needle_exponent"] is not None]
    assert 70 <= len(power) <= 130  # share 0.5: ±4.2 standard deviations
    assert all(NEEDLE_EXPONENT_RANGE[0] <= d["needle_exponent"] <= NEEDLE_EXPONENT_RANGE[1] for d in power)
    ecc = gen.model(spec, power[0])[0].bearings.eccentric
    assert ecc.load_exponent == power[0]["needle_exponent"]
    assert ecc.reference_load_N == pytest.approx(needle_reference_load(spec))
    assert gen.model(spec, next(d for d in drawn if d["needle_exponent"] is None))[0].bearings.eccentric.load_exponent \
        is None


def test_a_spatial_model_with_power_law_needles_is_solved_by_exudyn():
    """The compiled step's 3D bushings carry the linear clearance law only: it declines the spatial model with
    power-law needles (Exudyn solves it), and takes the same model with linear ones."""
    from rvflex.engine import compiled_step
    from rvflex.options import ModelOptions

    spec = catalog.load("rv40e")
    assert compiled_step(build_reducer(spec, options=ModelOptions.spatial_rigid())) is not None
    assert compiled_step(build_reducer(_power_needles(spec), options=ModelOptions.spatial_rigid())) is None


@dataclass(frozen=True)
class _PowerNeedleUnit:
    """A healthy unit whose needle bearings follow F ∝ δ^e past no clearance (the interface of
    ``RealisticMismatch`` that ``generate_case`` reads), otherwise the catalogue's rigid model."""

    exponent: float
    samples_per_rev: int = 512
    name: str = "power-law needles"

    def draw(self, rng):
        return {"needle_exponent": self.exponent, "clearance_m": 0.0}

    def model(self, spec, drawn):
        return _power_needles(spec, drawn["needle_exponent"]), ErrorSpec(), None

    def options_for(self, drawn):
        return ModelOptions.rigid()

    def model_form(self, drawn):
        return ()


@pytest.mark.slow
def test_the_calibration_finds_the_needle_law_of_a_power_law_unit(tmp_path):
    """A healthy RV-40E whose needles follow F ∝ δ^1.2 at the spec's stiffness under rated torque: the nominal
    parameter ``needle_bearing_law`` recovers its exponent (measured 1.203; ± 0.03 asserted, as the needle stiffness
    and the clearance calibrated beside it could trade some of its load dependence), the calibration closes most of
    the gap (measured 85 %) and no effect is named."""
    from rvflex.diagnosis.bench import read_bench
    from rvflex.diagnosis.fit import diagnose
    from rvflex.diagnosis.selfcheck import GeneratorModel, generate_case
    from rvflex.diagnosis.settings import DiagnosisSettings

    spec = catalog.load("rv40e")
    generate_case(tmp_path / "bench", tmp_path / "truth.json", spec, [], np.random.default_rng(3),
                  gen=GeneratorModel(positions_per_rev=256, hysteresis_steps=48), realistic=_PowerNeedleUnit(1.2))
    settings = DiagnosisSettings(max_order=95, hysteresis_steps=24, refine_top=2, refine_iterations=3, workers=2,
                                 null_distribution=None)
    diag = diagnose(read_bench(tmp_path / "bench"), settings=settings, cache_dir=tmp_path / "cache",
                    nominal=("needle_bearing_stiffness", "needle_bearing_law", "crank_bearing_clearance"),
                    effects=("eccentric_bearing_clearance", "pin_ring_runout"))
    cal = diag.to_dataframe("calibration").set_index("name")
    assert 1.0 + cal.loc["needle_bearing_law", "value"] == pytest.approx(1.2, abs=0.03), cal
    assert diag.baseline.gap_shrink_pct >= 80.0, diag.verdict
    assert diag.chosen is None, diag.verdict
    assert "needle bearing law F ∝ δ^1.2" in diag.verdict

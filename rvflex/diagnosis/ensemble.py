"""Units of other model forms the self-check writes its benches from: :class:`RealisticMismatch` (another model
family, ``--mismatch realistic`` and ``far``) and :class:`EnsembleMismatch`, the ensemble of healthy units
the diagnosis's false alarms are held against (``--mismatch ensemble``, the null distribution).

A unit from another maker, or a real one, is never the rvflex model: its contact law, bearing laws, first
stage, carrier and thermal behaviour are of other forms, and a diagnosis that names a cause on such a healthy
unit is worse than one that names none. :class:`EnsembleMismatch` draws one such unit per case, without any
hidden effect, from the nominal spec of a built-in unit:

- contact law: the spec's line contact, or a power law F = k·x^e with e in [0.9, 1.5] matched to it over the
  pin forces of the tests, each scaled by the contact stiffness drawn; half the units with a compliance at each
  pin seat in series (0 … 1 times the line contact's own secant compliance at the most loaded pin's force at
  rated torque), and only they with a softening law (e below 1: the seat bounds its stiffness at zero approach);
- needle (eccentric) bearings: stiffness drawn, radial clearance 0 … 4 µm; past the clearance half the units
  (``needle_power_share``) linear, half a power law F ∝ x^e with e in [1, 1.25] (a roller's line contact is
  10/9, Palmgren), whose secant stiffness is the drawn one at the load the torque sets at rated torque
  (:func:`~rvflex.diagnosis.nominal.needle_reference_load`);
- crank-support and main bearings, first-stage mesh: stiffness drawn; the mesh with or without its backlash
  and its stiffness ripple;
- an overall stiffness scale ×0.5 … ×2 on every stiffness (a unit as far from its catalogue model as real ones
  are);
- a torsional compliance in series with the output flange: linear, stiffening with load, or both (up to
  :data:`SERIES_LINEAR_MAX_RAD` and :data:`SERIES_STIFFENING_MAX_RAD` of twist at rated torque);
- a housing-to-steel thermal mismatch within ±1 ppm/K;
- rigid or FE-reduced flexible discs, and with FE discs, half the time an FE-reduced carrier too (the nominal
  reduction: like the discs' modulus, the carrier's is not scaled, so every case shares one reduction).

Not drawn, because the model has no such form yet: anisotropic crank supports and crank seats that move in the
carrier (the crank supports are isotropic bushings in their seats). The two foreign benches' simulators differ
from the rvflex model in those ways too; the ensemble is not either of them.
"""

from __future__ import annotations

import dataclasses as dc
import math
from dataclasses import dataclass, field

import numpy as np

from rvflex.diagnosis.nominal import needle_reference_load
from rvflex.options import ModelOptions
from rvflex.spec import ErrorSpec, ReducerSpec
from rvflex.units import ARCSEC

__all__ = ["CLEARANCE_MAX_M", "EnsembleMismatch", "NEEDLE_EXPONENT_RANGE", "RealisticMismatch", "SERIES_LINEAR_MAX_RAD",
           "SERIES_STIFFENING_MAX_RAD", "THERMAL_MISMATCH_MAX_PER_K", "needle_reference_load", "secant_compliance"]

CLEARANCE_MAX_M = 4e-6  # a healthy unit's needle-bearing radial clearance: 0 … 4 µm
NEEDLE_EXPONENT_RANGE = (1.0, 1.25)  # a needle bearing's load exponent past its clearance (Palmgren's line: 10/9)
SERIES_LINEAR_MAX_RAD = 25 * ARCSEC  # a carrier flange or coupling: up to 25″ of linear twist at rated torque
SERIES_STIFFENING_MAX_RAD = 10 * ARCSEC  # and up to 10″ stiffening with load (∝ T^(2/3))
THERMAL_MISMATCH_MAX_PER_K = 1e-6  # a steel housing around steel parts: within ±1 ppm/K


@dataclass(frozen=True)
class RealisticMismatch:
    """A generator of another model family than the diagnosing one (``--mismatch realistic``), drawn
    per case: a power-law contact F = k·x^1.5 with k within ±``stiffness_spread`` of the line
    contact's equivalent, needle-bearing and mesh stiffness scaled within ±``stiffness_spread``, a
    nominal crank-bearing clearance up to ``clearance_max_m``, FE-reduced flexible discs, and TE
    encoders sampled ``samples_per_rev`` points per revolution over [0, 2π). ``global_range``: an overall
    stiffness scale g drawn log-uniformly in it multiplies the three drawn stiffnesses (``--mismatch far``:
    ×0.5 … ×2, a unit as far from its catalogue model as real ones are; the crank-support and main bearings
    are scaled by g too, so the rigid unit is g times stiffer at the drawn components' means; the FE discs keep
    their modulus, since an FE reduction per case would dominate the self-check's time)."""

    stiffness_spread: float = 0.4
    clearance_max_m: float = 5e-6
    global_range: tuple[float, float] = (1.0, 1.0)
    options: ModelOptions = field(default_factory=ModelOptions.flexible_discs)
    samples_per_rev: int = 1024
    fixed: tuple[tuple[str, float], ...] = ()  # (key, value) pairs taken instead of drawn (tests)

    def draw(self, rng: np.random.Generator) -> dict:
        """The case's drawn nominal parameters (scales of the diagnosing model's values; keys
        ``contact_scale``, ``needle_bearing_scale``, ``mesh_scale``, ``clearance_m``)."""
        if self.fixed:
            return dict(self.fixed)
        a, b = 1.0 - self.stiffness_spread, 1.0 + self.stiffness_spread
        lo, hi = self.global_range
        g = float(math.exp(rng.uniform(math.log(lo), math.log(hi)))) if hi > lo else float(lo)
        out = {"contact_scale": g * float(rng.uniform(a, b)), "needle_bearing_scale": g * float(rng.uniform(a, b)),
               "mesh_scale": g * float(rng.uniform(a, b)), "clearance_m": float(rng.uniform(0.0, self.clearance_max_m))}
        return out | ({"global_scale": g} if hi > lo else {})

    def model(self, spec: ReducerSpec, drawn: dict):
        """(spec, errors, law) of the generator for the drawn parameters."""
        from rvflex.contact.cycloid_pin import ContactLaw
        from rvflex.diagnosis.nominal import power_law_equivalent

        b, st = spec.bearings, spec.input_stage
        g = drawn.get("global_scale", 1.0)  # the other bearings follow the overall scale (far mismatch)
        b = dc.replace(b, crank_support=dc.replace(b.crank_support,
                                                   radial_stiffness_N_m=b.crank_support.radial_stiffness_N_m * g),
                       main=dc.replace(b.main, radial_stiffness_N_m=b.main.radial_stiffness_N_m * g))
        spec_g = dc.replace(spec, bearings=dc.replace(b, eccentric=dc.replace(
            b.eccentric, radial_stiffness_N_m=b.eccentric.radial_stiffness_N_m * drawn["needle_bearing_scale"])),
            input_stage=dc.replace(st, mesh_stiffness_mean_N_m=st.mesh_stiffness_mean_N_m * drawn["mesh_scale"],
                                   mesh_stiffness_amplitude_N_m=st.mesh_stiffness_amplitude_N_m * drawn["mesh_scale"]))
        n = spec.cranks.count * spec.cycloid.disc_count
        errors = ErrorSpec(eccentric_bearing_clearance_m=(drawn["clearance_m"],) * n)
        law = ContactLaw.hertz(power_law_equivalent(spec) * drawn["contact_scale"], 1.5, damping_Ns_m=500.0)
        return spec_g, errors, law

    def options_for(self, drawn: dict) -> ModelOptions:
        """The generator model's fidelity (the same for every case)."""
        return self.options

    def model_form(self, drawn: dict) -> tuple:
        """Registered effects the generator applies as its own model form: none."""
        return ()


@dataclass(frozen=True)
class EnsembleMismatch:
    """The generator of a healthy unit of another model form (``--mismatch ensemble``), drawn per case (see
    the module docstring). The interface is that of :class:`~rvflex.diagnosis.selfcheck.RealisticMismatch`:
    :meth:`draw`, :meth:`model`, :meth:`options_for` and :meth:`model_form`."""

    stiffness_spread: float = 0.4  # each component's stiffness ×(1 ± spread) around the overall scale
    global_range: tuple[float, float] = (0.5, 2.0)
    exponent_range: tuple[float, float] = (0.9, 1.5)  # below 1 only with a seat compliance (redrawn in 1 … 1.5)
    line_share: float = 1.0 / 3.0  # share of units with the spec's own (line) contact law
    seat_share: float = 0.5  # share of units with a compliance at each pin seat in series with the contact
    seat_range: tuple[float, float] = (0.0, 1.0)  # the seat's compliance over the line contact's secant compliance
    flexible_share: float = 0.5  # share of units with FE-reduced discs
    carrier_share: float = 0.5  # share of those with an FE-reduced carrier too
    clearance_max_m: float = CLEARANCE_MAX_M  # needle-bearing clearance drawn in [0, this], scaled into the class
    needle_power_share: float = 0.5  # share of units whose needle bearings follow a power law past the clearance
    samples_per_rev: int = 1024
    name: str = "ensemble"

    def draw(self, rng: np.random.Generator) -> dict:
        """The case's drawn model form (JSON-able): stiffness scales, law, clearance, needle-bearing law, mesh form,
        series compliance (rad at rated torque), thermal mismatch (1/K) and disc fidelity."""
        lo, hi = self.global_range
        g = float(math.exp(rng.uniform(math.log(lo), math.log(hi))))
        a, b = 1.0 - self.stiffness_spread, 1.0 + self.stiffness_spread
        law_line = bool(rng.uniform() < self.line_share)
        series = int(rng.integers(3))  # 0 linear, 1 stiffening, 2 both
        seat = float(rng.uniform(*self.seat_range)) if rng.uniform() < self.seat_share else 0.0
        e_lo = self.exponent_range[0] if seat > 0.0 else max(self.exponent_range[0], 1.0)
        flexible = bool(rng.uniform() < self.flexible_share)
        out = {"global_scale": g, "contact_scale": g * float(rng.uniform(a, b)),
               "needle_bearing_scale": g * float(rng.uniform(a, b)), "mesh_scale": g * float(rng.uniform(a, b)),
               "support_scale": g * float(rng.uniform(a, b)),
               "contact_law": "line" if law_line else "power",
               "contact_exponent": None if law_line else float(rng.uniform(e_lo, self.exponent_range[1])),
               "seat_share": seat,
               "clearance_m": float(rng.uniform(0.0, self.clearance_max_m)),
               "mesh_backlash": bool(rng.uniform() < 0.5), "mesh_ripple": bool(rng.uniform() < 0.5),
               "series_linear_rad": float(rng.uniform(0, SERIES_LINEAR_MAX_RAD)) if series != 1 else 0.0,
               "series_stiffening_rad": float(rng.uniform(0, SERIES_STIFFENING_MAX_RAD)) if series != 0 else 0.0,
               "thermal_per_K": float(rng.uniform(-THERMAL_MISMATCH_MAX_PER_K, THERMAL_MISMATCH_MAX_PER_K)),
               "flexible_discs": flexible, "flexible_carrier": flexible and bool(rng.uniform() < self.carrier_share)}
        # from a stream of its own (a spawned child leaves ``rng`` where it is): every case keeps the rest of its
        # draw and its bench (origin, offset, noise)
        own = rng.spawn(1)[0]
        out["needle_exponent"] = (float(own.uniform(*NEEDLE_EXPONENT_RANGE)) if own.uniform() < self.needle_power_share
                                  else None)
        return out

    def model(self, spec: ReducerSpec, drawn: dict):
        """(spec, errors, law) of the generator for the drawn model form."""
        from rvflex.contact.cycloid_pin import ContactLaw
        from rvflex.diagnosis.nominal import power_law_equivalent
        from rvflex.model import default_contact_law

        b, st = spec.bearings, spec.input_stage
        s_sup, s_ndl, s_msh = drawn["support_scale"], drawn["needle_bearing_scale"], drawn["mesh_scale"]
        b = dc.replace(b, crank_support=dc.replace(b.crank_support,
                                                   radial_stiffness_N_m=b.crank_support.radial_stiffness_N_m * s_sup),
                       main=dc.replace(b.main, radial_stiffness_N_m=b.main.radial_stiffness_N_m * drawn["global_scale"]),
                       eccentric=dc.replace(b.eccentric, radial_stiffness_N_m=b.eccentric.radial_stiffness_N_m * s_ndl))
        if drawn.get("needle_exponent") is not None:
            b = dc.replace(b, eccentric=dc.replace(b.eccentric, load_exponent=drawn["needle_exponent"],
                                                   reference_load_N=needle_reference_load(spec)))
        st = dc.replace(st, mesh_stiffness_mean_N_m=st.mesh_stiffness_mean_N_m * s_msh,
                        mesh_stiffness_amplitude_N_m=st.mesh_stiffness_amplitude_N_m * s_msh * drawn["mesh_ripple"],
                        backlash_m=st.backlash_m * drawn["mesh_backlash"])
        spec_g = dc.replace(spec, bearings=b, input_stage=st)
        n = spec.cranks.count * spec.cycloid.disc_count
        errors = ErrorSpec(eccentric_bearing_clearance_m=(drawn["clearance_m"],) * n)
        # a pin seat: a share of the line contact's secant compliance at its most loaded pin, at the drawn scale
        seat = drawn.get("seat_share", 0.0) * secant_compliance(spec) / drawn["contact_scale"]
        if drawn["contact_law"] == "line":
            law = default_contact_law(spec)
            law = dc.replace(law, disc_compliance_1_Pa=law.disc_compliance_1_Pa / drawn["contact_scale"],
                             pin_compliance_1_Pa=law.pin_compliance_1_Pa / drawn["contact_scale"], seat_compliance_m_N=seat)
        else:
            e = drawn["contact_exponent"]
            law = ContactLaw.hertz(power_law_equivalent(spec, e) * drawn["contact_scale"], e, damping_Ns_m=500.0,
                                   seat_compliance_m_N=seat)
        return spec_g, errors, law

    def options_for(self, drawn: dict) -> ModelOptions:
        """The generator model's fidelity for the drawn case."""
        if drawn.get("flexible_carrier"):
            return ModelOptions.flexible_discs_and_carrier()
        return ModelOptions.flexible_discs() if drawn["flexible_discs"] else ModelOptions.rigid()

    def model_form(self, drawn: dict) -> tuple:
        """The registered effects the drawn unit carries as its own model form (not hidden effects): the series
        compliance and the thermal mismatch, as (Effect, parameters)."""
        from rvflex.diagnosis.effects import EFFECTS

        return ((EFFECTS["output_series_compliance"],
                 np.array([drawn["series_linear_rad"], drawn["series_stiffening_rad"]])),
                (EFFECTS["thermal_expansion"], np.array([drawn["thermal_per_K"]])))


def secant_compliance(spec: ReducerSpec) -> float:
    """The secant compliance δ/F (m/N) of ``spec``'s line contact (seed 002) at the most loaded pin's force at rated
    torque, at the loaded-flank radius the power-law equivalence uses: the scale of a pin seat's compliance."""
    from rvflex.diagnosis.nominal import POWER_LAW_FLANK_RADIUS_M, max_pin_force
    from rvflex.geometry.formulas import hertz_line_deflection

    m, f = spec.materials, max_pin_force(spec, spec.rated_torque_Nm)
    return hertz_line_deflection(f, spec.cycloid.disc_thickness_m, POWER_LAW_FLANK_RADIUS_M, spec.cycloid.pin_radius_m,
                                 m.gears_cranks_discs.youngs_modulus_Pa, m.gears_cranks_discs.poisson_ratio,
                                 m.pins.youngs_modulus_Pa, m.pins.poisson_ratio) / f

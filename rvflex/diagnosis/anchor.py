"""The data anchor: start the calibration from the stiffness the bench measures.

A model's nominal stiffnesses are routinely a factor of two from the unit on the bench (seed 002
measures 72 N·m/arcmin where our model of its unit gives 117; an independent simulator's RV-40E
measures 275–290 N·m/arcmin against our catalogue model's 159). The calibration of the nominal
parameters (:mod:`rvflex.diagnosis.nominal`) is linearised about its start and regularised toward it,
with component scales of about ±30 %: started from the catalogue values, it stops at the bounds of its
prior ranges and what it cannot absorb swamps every effect. The bench itself states the unit's
stiffness, so the diagnosis measures it first and starts from there:

1. The unit's torsional compliance from the bench runs: the slope of the torque cycle beyond ±50 % of
   its amplitude (the catalogue's stiffness definition; both branches, both signs), or, without a torque
   cycle, the change of the mean wind-up between TE runs at two loads in the same direction (the
   common TE offset cancels in the difference).
2. The same figure of the nominal model (the rigid model plus the elastic discs' difference, the
   calibration's nominal point).
3. Their ratio is the *global stiffness scale*: every stiffness of the model (Young's moduli, so the
   contact law and the elastic discs alike, bearing and mesh stiffnesses) is multiplied by it, and the
   calibration's component scales, contact-law form and clearance are fitted around that anchored model.
   Applied when it lies outside ``[1/ANCHOR_MIN_RATIO, ANCHOR_MIN_RATIO]`` (inside, the component priors
   cover it, and the anchored model would only cost new FE reductions); quantised to ``2^(k/8)`` steps so
   that datasets of one unit share their FE reductions and model runs in the cache; clipped to
   ``[GLOBAL_SCALE_LOW, GLOBAL_SCALE_HIGH]`` (beyond it the spec describes another unit, and the report
   says so).
"""

from __future__ import annotations

import dataclasses as dc
import math
from dataclasses import dataclass

import numpy as np

from rvflex.diagnosis.plan import BRANCH_FRACTIONS, Layout, PlanRun
from rvflex.spec import AngularContactPair, ReducerSpec, TaperedRollerPair
from rvflex.units import ARCMIN, ARCSEC

__all__ = ["ANCHOR_MIN_RATIO", "GLOBAL_SCALE_HIGH", "GLOBAL_SCALE_LOW", "Anchor", "anchor", "compliance",
           "scale_stiffness"]

GLOBAL_SCALE_LOW, GLOBAL_SCALE_HIGH = 0.3, 3.0  # the unit's stiffness against the model's: beyond, another unit
ANCHOR_MIN_RATIO = 1.25  # inside [1/1.25, 1.25] the component priors (σ 0.35 in compliance) cover the mismatch
ANCHOR_STEPS_PER_OCTAVE = 8  # quantisation of the applied scale (9 % steps): datasets of one unit share the cache
STIFFNESS_FRACTION = 0.5  # the torque cycle's slope is read beyond this share of its amplitude (catalogue definition)


@dataclass(frozen=True)
class Anchor:
    """The global stiffness scale the diagnosis starts from.

    Attributes
    ----------
    source : str
        What measured the unit's stiffness: ``"torque cycle"``, ``"wind-up"`` (TE runs at two loads) or
        ``""`` (nothing could: not anchored).
    bench_Nm_per_arcmin, model_Nm_per_arcmin : float
        Torsional stiffness of the unit and of the nominal model by that measure (N·m/arcmin; NaN when
        not measured).
    ratio : float
        ``bench / model``: how many times stiffer the unit is than the model.
    scale : float
        The stiffness scale applied to the model (1.0: not applied).
    note : str
        Why the scale is what it is (not measured, inside the priors, quantised, clipped).
    """

    source: str = ""
    bench_Nm_per_arcmin: float = math.nan
    model_Nm_per_arcmin: float = math.nan
    ratio: float = math.nan
    scale: float = 1.0
    note: str = "not anchored"

    @property
    def applied(self) -> bool:
        """Whether the model's stiffnesses were scaled."""
        return self.scale != 1.0

    def sentence(self) -> str:
        """The report's first finding: the nominal mismatch in the user's terms."""
        if not self.source:
            return f"The runs do not measure the unit's torsional stiffness ({self.note})."
        k = self.ratio
        how = (f"{k:.2f}× stiffer than" if k >= 1.0 else f"{1 / k:.2f}× softer than")
        s = (f"On the {self.source} the unit is {how} the model ({self.bench_Nm_per_arcmin:.0f} against "
             f"{self.model_Nm_per_arcmin:.0f} N·m/arcmin).")
        if self.applied:
            s += (f" The diagnosis starts from the model with every stiffness ×{self.scale:.2f}"
                  f"{' (' + self.note + ')' if self.note else ''} and calibrates around it.")
        else:
            s += f" {self.note[0].upper() + self.note[1:]}." if self.note else ""
        return s

    def describe(self) -> dict:
        """JSON form."""
        return {"source": self.source, "bench_Nm_per_arcmin": _num(self.bench_Nm_per_arcmin),
                "model_Nm_per_arcmin": _num(self.model_Nm_per_arcmin), "ratio": _num(self.ratio),
                "scale": self.scale, "applied": self.applied, "note": self.note}


def _num(v: float):
    return float(v) if math.isfinite(v) else None


def compliance(f: np.ndarray, lay: Layout, plan: tuple[PlanRun, ...]) -> tuple[float, str]:
    """Torsional compliance (arcsec per N·m) of a feature vector ``f`` (measured or modelled) and its
    source: the mean slope of the torque cycles' branches beyond ±STIFFNESS_FRACTION of their amplitude,
    else the mean wind-up change between TE runs at different loads in one direction; (NaN, "") when
    neither exists."""
    slopes = []
    frac = BRANCH_FRACTIONS
    for r, sl in lay.hyst.items():
        a = f[sl].reshape(2, -1)  # descending, ascending branch at the torques frac·T_max
        t = frac * plan[r].torque_max_Nm
        for side in (frac <= -STIFFNESS_FRACTION, frac >= STIFFNESS_FRACTION):
            for branch in a:
                slopes.append(np.polyfit(t[side], branch[side], 1)[0])
    if slopes:
        return float(np.mean(slopes)), "torque cycle"
    for d in (1, -1):
        runs = sorted((plan[r].load_Nm, f[lay.dc[r]]) for r in lay.te_runs if plan[r].direction == d)
        if len(runs) >= 2 and runs[-1][0] - runs[0][0] > 0.2 * runs[-1][0]:
            (l0, m0), (l1, m1) = runs[0], runs[-1]
            slopes.append(d * (m1 - m0) / (l1 - l0))  # signed: bench and model must agree in sign
    if slopes:
        return float(np.mean(slopes)), "wind-up"
    return math.nan, ""


def anchor(measured: np.ndarray, model: np.ndarray, lay: Layout, plan: tuple[PlanRun, ...]) -> Anchor:
    """The global stiffness scale from the bench's features ``measured`` and the nominal model's
    ``model`` (same layout): see the module docstring."""
    cb, src = compliance(measured, lay, plan)
    cm, _ = compliance(model, lay, plan)
    if not src:
        return Anchor(note="no torque cycle and no TE runs at two loads in one direction; the calibration "
                           "starts from the nominal stiffnesses")
    to_arcmin = ARCMIN / ARCSEC  # N·m/arcsec → N·m/arcmin
    kb, km = to_arcmin / abs(cb) if cb else math.nan, to_arcmin / abs(cm) if cm else math.nan
    if cb == 0 or not cm / cb > 0:  # NaN fails too
        return Anchor(src, kb, km, note=f"the {src} gives a compliance of {cb:.3g} ″/N·m on the bench and {cm:.3g} on "
                                        "the model, not of one sign; the calibration starts from the nominal "
                                        "stiffnesses")
    ratio = cm / cb
    if 1.0 / ANCHOR_MIN_RATIO <= ratio <= ANCHOR_MIN_RATIO:
        return Anchor(src, kb, km, ratio, 1.0, f"within ×{ANCHOR_MIN_RATIO:g} the calibration's component priors "
                                               "cover it: it starts from the nominal stiffnesses")
    k = round(math.log2(ratio) * ANCHOR_STEPS_PER_OCTAVE)
    scale = 2.0 ** (k / ANCHOR_STEPS_PER_OCTAVE)
    note = ""
    if not GLOBAL_SCALE_LOW <= scale <= GLOBAL_SCALE_HIGH:
        scale = min(max(scale, GLOBAL_SCALE_LOW), GLOBAL_SCALE_HIGH)
        note = (f"clipped to the global range ×{GLOBAL_SCALE_LOW:g} … ×{GLOBAL_SCALE_HIGH:g}: the spec likely "
                "describes another unit")
    return Anchor(src, kb, km, ratio, scale, note)


def scale_stiffness(spec: ReducerSpec, s: float) -> ReducerSpec:
    """``spec`` with every stiffness multiplied by ``s``: the Young's moduli of all materials (the contact
    law and the elastic bodies), every bearing's radial, axial and tilt stiffness and the first-stage mesh
    stiffness. A linear model's compliance scales by exactly 1/s; clearances and geometry are unchanged."""
    if s == 1.0:
        return spec
    m = spec.materials
    mats = dc.replace(m, **{f.name: dc.replace(getattr(m, f.name), youngs_modulus_Pa=getattr(m, f.name).youngs_modulus_Pa * s)
                            for f in dc.fields(m)})

    def brg(b):
        # no pair given, or the crank support rows' geometry alone (their stiffness is crank_support's, scaled)
        if b is None or isinstance(b, TaperedRollerPair):
            return b
        if isinstance(b, AngularContactPair):  # its stiffness is its balls' Hertz contacts: their modulus
            return dc.replace(b, material=dc.replace(b.material, youngs_modulus_Pa=b.material.youngs_modulus_Pa * s))
        return dc.replace(b, radial_stiffness_N_m=b.radial_stiffness_N_m * s, axial_stiffness_N_m=b.axial_stiffness_N_m * s,
                          tilt_stiffness_Nm_rad=b.tilt_stiffness_Nm_rad * s)

    b = spec.bearings
    bearings = dc.replace(b, **{f.name: brg(getattr(b, f.name)) for f in dc.fields(b)})
    st = spec.input_stage
    stage = dc.replace(st, mesh_stiffness_mean_N_m=st.mesh_stiffness_mean_N_m * s,
                       mesh_stiffness_amplitude_N_m=st.mesh_stiffness_amplitude_N_m * s)
    return dc.replace(spec, materials=mats, bearings=bearings, input_stage=stage)

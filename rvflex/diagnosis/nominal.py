"""Uncertain nominal parameters: what the diagnosis calibrates before it attributes anything.

A bench unit is never the nominal model: its contact stiffness, its needle-bearing and mesh
stiffnesses, its needle bearings' law and its crank-bearing clearance are known only to tens of per cent (a catalogue
stiffness, a seed paper's table value carried over to another frame size, a nominal clearance
class). Left alone, these differences dominate the gap and every candidate effect competes to
absorb them. Each is calibrated from the same bench runs, within a stated prior, with a regulariser
toward its nominal value, and only what calibration leaves is attributed to unmodelled effects.

Each nominal parameter is an :class:`~rvflex.diagnosis.effects.Effect` with ``prior_sigma``; the
stiffnesses are parameterised by their *compliance change* u = 1/s − 1 (s the stiffness scale): a
series compliance enters the wind-up linearly, so the linearised fit is close to the model over
the whole prior range.

What separates them (``separating_runs``): the torque-cycle slope beyond ±50 % T_r and the load
dependence of the wind-up between TE runs (the stiffnesses; their TE signatures differ: the
contact stiffness shapes the pin-mesh orders, the bearing stiffness the crank orders), how the crank
orders grow with the load (the needle law), and the free-play region of the torque cycle (the clearance). The first-stage mesh stiffness is not
determined by output-side runs (reflected through the first-stage ratio its compliance moves the
output by ~0.05″ on the RV-40E; its sun-mesh orders lie near order 1400): the diagnosis finds that
from the sensitivities and holds it at nominal (:func:`rvflex.diagnosis.calibration.undetermined`).
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np

from rvflex.diagnosis.effects import Effect, Param
from rvflex.diagnosis.linear import Z95
from rvflex.options import ModelOptions
from rvflex.spec import ErrorSpec, ReducerSpec
from rvflex.units import ARCMIN, UM

__all__ = ["CUT_BY", "NOMINAL", "REPLACES", "SAME_QUANTITY", "clearance_class_top", "describe_calibration", "max_pin_force", "needle_reference_load", "nominal_parameters", "point_contact_law",
           "power_law_equivalent", "stiffness_scale", "within_spec_rules"]

COMPLIANCE_PRIOR = 0.35  # σ of the compliance change: a stiffness known to about ±30 %
COMPLIANCE_LOW, COMPLIANCE_HIGH = -0.7, 1.5  # component scale 3.3 … 0.4 around the data anchor (diagnose.anchor): a
# point-contact simulator's contact stiffness sat at the former ×2 bound in 3 of 3 foreign datasets
# Nominal crank-bearing clearance of a unit whose spec states no lost-motion class: 0 … 10 µm of total clearance.
# The runs determine only the total clearance of the crank bearings, so within the class calibration takes it: a
# total inside the class is the nominal parameter off, the effect eccentric_bearing_clearance is what lies beyond
# it (reported with the total). A spec with the maker's lost-motion class bounds it tighter (clearance_class_top).
CLEARANCE_HIGH = 10 * UM


def clearance_class_top(spec: ReducerSpec | None) -> float:
    """The most total radial clearance of the crank (needle) bearings a healthy unit of ``spec`` can have (m).

    A radial clearance c in every eccentric bearing lets the carrier turn c/r_c either way against discs the
    pins hold (r_c the crank circle radius): 2c/r_c of free play at the output, whatever the stiffnesses
    (the model's backlash grows by that to within 6 % on the built-in units; tests/test_diagnose_far.py). A unit
    that meets the maker's lost-motion class LM_max therefore has c ≤ LM_max·r_c/2, the clearance that alone
    would spend the whole class: beyond it the clearance is an unmodelled effect, not the nominal parameter off.
    Without a stated class (``spec.catalogue_lost_motion_arcmin`` None, or no spec): ``CLEARANCE_HIGH``."""
    lm = None if spec is None else spec.catalogue_lost_motion_arcmin
    if lm is None:
        return CLEARANCE_HIGH
    return lm * ARCMIN * spec.cranks.crank_circle_radius_m / 2.0


MODULUS_MAX_PA = 1e12  # a spec's rule for a Young's modulus (rvflex.spec_types), which the contact stiffness scales


CUT_BY = {"contact_stiffness": f"the spec's {MODULUS_MAX_PA / 1e9:.0f} GPa modulus rule leaves",
          "crank_bearing_clearance": "the clearance class (the clearance that alone spends the maker's lost-motion "
                                     "class) leaves above the spec's clearance"}
"""The rule that narrows a nominal parameter's stated range for a unit (:func:`within_spec_rules`,
:func:`nominal_parameters`), in the words the verdict uses for a value at the cut bound."""


def within_spec_rules(cal: tuple[Effect, ...], spec: ReducerSpec) -> tuple[Effect, ...]:
    """``cal`` with the contact stiffness's range cut where its scale of the disc and pin moduli of ``spec`` (the
    anchored model's) would break the spec's rule of at most ``MODULUS_MAX_PA``: a model the spec refuses cannot
    be evaluated (measured: on the foreign bench's H02, anchored ×1.68, the pin-ring runout's fit took the contact
    ×2.9 around the anchor, 1081 GPa, and its model evaluation failed, so no effect was accepted)."""
    out = []
    for e in cal:
        if e.name == "contact_stiffness":
            m = spec.materials
            s_max = 0.999 * MODULUS_MAX_PA / max(m.gears_cranks_discs.youngs_modulus_Pa, m.pins.youngs_modulus_Pa)
            p = e.params[0]
            low = 1.0 / s_max - 1.0
            if low > p.low:
                e = dc.replace(e, params=(dc.replace(p, low=low),))
        out.append(e)
    return tuple(out)


def stiffness_scale(u: float) -> float:
    """Stiffness scale s = 1/(1 + u) of a compliance change u."""
    return 1.0 / (1.0 + float(u))


def _contact(spec: ReducerSpec, errors: ErrorSpec, x):
    """Contact stiffness: Young's moduli of the discs and pins scaled (the line-contact law's
    compliance follows them; in the rigid model nothing else reads them)."""
    s = stiffness_scale(x[0])
    m = spec.materials
    mats = dc.replace(m, gears_cranks_discs=dc.replace(m.gears_cranks_discs,
                                                       youngs_modulus_Pa=m.gears_cranks_discs.youngs_modulus_Pa * s),
                      pins=dc.replace(m.pins, youngs_modulus_Pa=m.pins.youngs_modulus_Pa * s))
    return dc.replace(spec, materials=mats), errors


def _needle(spec: ReducerSpec, errors: ErrorSpec, x):
    s = stiffness_scale(x[0])
    b = spec.bearings
    ecc = dc.replace(b.eccentric, radial_stiffness_N_m=b.eccentric.radial_stiffness_N_m * s)
    return dc.replace(spec, bearings=dc.replace(b, eccentric=ecc)), errors


def _mesh(spec: ReducerSpec, errors: ErrorSpec, x):
    s = stiffness_scale(x[0])
    st = spec.input_stage
    return dc.replace(spec, input_stage=dc.replace(st, mesh_stiffness_mean_N_m=st.mesh_stiffness_mean_N_m * s,
                                                    mesh_stiffness_amplitude_N_m=st.mesh_stiffness_amplitude_N_m * s)), errors


def _needle_law(spec: ReducerSpec, errors: ErrorSpec, x):
    """Needle-bearing law: past its clearance the bearing follows F = F_r·(δ/δ_r)^e (Palmgren's line contact:
    e ≈ 10/9), e = 1 + x[0], with the same secant stiffness at the reference load F_r (the torque's share of a
    needle's load at rated torque), so e moves the bearing's load dependence, not its stiffness at rated torque;
    x[0] = 0 is the spec's linear law (the spec itself, so its model runs are the calibrated model's)."""
    e = 1.0 + float(x[0])
    if e <= 1.0 + 1e-12:
        return spec, errors
    b = spec.bearings
    ecc = dc.replace(b.eccentric, load_exponent=e, reference_load_N=needle_reference_load(spec))
    return dc.replace(spec, bearings=dc.replace(b, eccentric=ecc)), errors


def needle_reference_load(spec: ReducerSpec) -> float:
    """The power law's reference load for a needle (eccentric) bearing (N): each disc's torque over e·z_c, shared
    by the cranks, the share of the bearing's load at rated torque that the torque alone sets (the pins' radial
    push adds to it: the nominal RV-40E's needles carry 3.2 kN on average against this 2.1 kN). At it the power
    law's secant stiffness is the bearing's linear stiffness, so the two laws carry rated torque about alike and
    differ in their load dependence."""
    c = spec.cycloid
    per_disc = spec.rated_torque_Nm / c.disc_count / (c.eccentricity_m * c.disc_teeth)
    return per_disc / spec.cranks.count


def _clearance(spec: ReducerSpec, errors: ErrorSpec, x):
    n = spec.cranks.count * spec.cycloid.disc_count
    old = errors.eccentric_bearing_clearance_m or (0.0,) * n
    return spec, dc.replace(errors, eccentric_bearing_clearance_m=tuple(o + float(x[0]) for o in old))


STIFFNESS_RUNS = ("a torque cycle at half amplitude and a TE run at another load (a stiffness scales the "
                  "wind-up in proportion to the load; an effect does not)")


POWER_LAW_LOAD_RANGE = (0.1, 1.5)  # share of the most loaded pin's force at rated torque the equivalence covers
POWER_LAW_FLANK_RADIUS_M = 0.02  # loaded-flank radius at which the power law is matched to the line contact


def max_pin_force(spec: ReducerSpec, torque_Nm: float) -> float:
    """Force of the most loaded pin (N) at the output torque ``torque_Nm``: F_max = 4T/(n·z_c·K1·r_p)
    with n discs sharing the torque (seed 000's load sharing)."""
    c = spec.cycloid
    k1 = c.eccentricity_m * c.pin_count / c.pin_circle_radius_m
    return 4.0 * torque_Nm / (c.disc_count * c.disc_teeth * k1 * c.pin_circle_radius_m)


def power_law_equivalent(spec: ReducerSpec, exponent: float = 1.5) -> float:
    """k (N/m^e) of a power-law contact F = k·x^e (default e = 1.5, the point contact) matching ``spec``'s
    line contact (seed 002, materials and disc width of the spec) over the pin forces of the tests: least
    squares in log force over POWER_LAW_LOAD_RANGE of the most loaded pin's force at rated torque, at a
    loaded-flank radius of POWER_LAW_FLANK_RADIUS_M."""
    from rvflex.geometry.formulas import hertz_line_deflection

    m = spec.materials
    f = np.geomspace(*(np.asarray(POWER_LAW_LOAD_RANGE) * max_pin_force(spec, spec.rated_torque_Nm)), 16)
    d = np.array([hertz_line_deflection(x, spec.cycloid.disc_thickness_m, POWER_LAW_FLANK_RADIUS_M,
                                        spec.cycloid.pin_radius_m, m.gears_cranks_discs.youngs_modulus_Pa,
                                        m.gears_cranks_discs.poisson_ratio, m.pins.youngs_modulus_Pa,
                                        m.pins.poisson_ratio) for x in f])
    return float(np.exp(np.mean(np.log(f) - exponent * np.log(d))))


def point_contact_law(spec: ReducerSpec):
    """The power-law (F = k·x^1.5) contact equivalent to ``spec``'s line contact, same damping."""
    from rvflex.contact.cycloid_pin import ContactLaw

    return ContactLaw.hertz(power_law_equivalent(spec), 1.5, damping_Ns_m=500.0)


def _builtin() -> tuple[Effect, ...]:
    def u(name):
        return (Param(name, "1", COMPLIANCE_LOW, COMPLIANCE_HIGH, 0.25),)

    return (
        # the elastic discs' pin-mesh orders (5.7″ at 2·z_b) depend on the contact's compliance against the
        # teeth's: the stiffness acts through the flexible model too (coupled to the disc-flexibility share)
        Effect("contact_stiffness", "pin–disc contact stiffness (compliance change u = 1/s − 1 of the line-contact law)",
               u("compliance_change"), apply=_contact, prior_sigma=(COMPLIANCE_PRIOR,),
               separating_runs=STIFFNESS_RUNS, coupled_to="disc_flexibility"),
        Effect("needle_bearing_stiffness", "crank (needle) bearing radial stiffness (compliance change u = 1/s − 1)",
               u("compliance_change"), apply=_needle, prior_sigma=(COMPLIANCE_PRIOR,),
               separating_runs=STIFFNESS_RUNS),
        Effect("mesh_stiffness", "first-stage (involute) mesh stiffness (compliance change u = 1/s − 1)",
               u("compliance_change"), apply=_mesh, prior_sigma=(COMPLIANCE_PRIOR,),
               separating_runs="a torsional test of the first stage alone (input side, cranks held): output-side "
                               "runs see its compliance only through the first-stage ratio"),
        # the contact law's form: a line contact (F nearly ∝ x) or, with crowning, misalignment or edge
        # relief, closer to a point contact (F ∝ x^1.5, zero stiffness at first touch); blended linearly as
        # the difference the law makes to the flexible model (the elastic discs' pin-mesh orders, 5.7″ at
        # 2·z_b, depend on the law: its difference on the rigid model left a weighted RSS of 977 at a
        # power-law bench's own parameters, 90 % on the mesh orders)
        Effect("contact_law_form", "form of the pin–disc contact law: share of the equivalent point-contact law "
               "F = k·x^1.5 blended with the line contact (0 = line contact)",
               (Param("point_contact_share", "1", 0.0, 1.5, 1.0),), kind="fidelity",
               alt_law=point_contact_law, options=ModelOptions.flexible_discs(), prior_sigma=(0.7,),
               separating_runs="a torque cycle with fine steps through ±10 % of rated torque and TE runs at "
                               "two loads (the law's curvature shows as load-dependent stiffness)"),
        # the bench unit's discs (and carrier) are elastic: the rigid model's missing elastic wind-up and
        # TE enter as a share of the flexible model's, nominally all of it (1), calibrated like a stiffness
        Effect("disc_flexibility", "elastic discs and carrier (share of the FE-reduced flexible model's difference "
               "from the rigid one; nominal 1)", (Param("flexible_share", "1", 0.0, 2.0, 1.0),), kind="fidelity",
               options=ModelOptions.flexible_discs(), prior_sigma=(0.5,), prior_center=(1.0,),
               separating_runs="TE runs at two loads (the elastic TE at order 2·z_b grows with the load)"),
        # the needle bearings' law: linear (the spec) or a rolling line contact's power law past the clearance, which
        # changes how the crank orders (2·z_b on two-crank units) grow with the load
        Effect("needle_bearing_law", "load exponent of the crank (needle) bearings' law past their clearance, "
               "F ∝ δ^(1 + exponent_change) at the spec's stiffness at the rated torque's needle load (0 = the spec's "
               "linear law)",
               (Param("exponent_change", "1", 0.0, 0.5, 0.1),), apply=_needle_law, prior_sigma=(0.25,),
               separating_runs="TE runs at three or more loads (the exponent bends the crank orders' growth with "
                               "the load)"),
        # a nominal clearance class of a few µm: beyond its prior, clearance is an unmodelled effect
        Effect("crank_bearing_clearance", "nominal radial clearance of the crank (needle) bearings",
               (Param("clearance_m", "m", 0.0, CLEARANCE_HIGH, 2.5 * UM),), apply=_clearance, prior_sigma=(2.5 * UM,),
               separating_runs="a torque cycle with fine steps through ±5 % of rated torque (the free-play region)"),
    )


NOMINAL: dict[str, Effect] = {e.name: e for e in _builtin()}
"""The calibrated nominal parameters by name."""

SAME_QUANTITY = {"eccentric_bearing_clearance": "crank_bearing_clearance"}
"""Candidate effects acting on the same quantity as a nominal parameter: the effect is what lies beyond the
parameter's range (the runs see the total only)."""

REPLACES = {"disc_flexibility": "disc_carrier_flexibility"}
"""Candidate effects a nominal parameter stands for (not attributed separately when it is calibrated)."""


def describe_calibration(c, held: dict | None = None, anchor_scale: float = 1.0) -> list[dict]:
    """The calibrated nominal parameters of ``c``: value, 95 % interval, nominal value, shift, and
    for stiffnesses the stiffness scale against the spec, ``anchor_scale``·s with s = 1/(1 + u) the
    component scale around the data anchor (:mod:`rvflex.diagnosis.anchor`), with its interval
    (``determined``: True). The
    parameters in ``held`` (name → why; the runs do not determine them) follow at their nominal
    value with the prior's 95 % interval (``determined``: False, ``why``). ``prior_range`` is the range it was
    calibrated in (``at_prior_bound`` against it), ``stated_range`` the stated one before the unit's cuts, and
    ``cut_by`` the rule that cut it (:data:`CUT_BY`; None when uncut)."""
    out = []
    values = [(e, x, iv, True) for e, x, iv in c.calibrated]
    for name in held or {}:
        e = NOMINAL[name]
        iv = np.column_stack([np.maximum(e.center - Z95 * np.asarray(e.prior_sigma), e.lower),
                              np.minimum(e.center + Z95 * np.asarray(e.prior_sigma), e.upper)])
        values.append((e, e.center, iv, False))
    for e, x, iv, determined in values:
        # the range it was calibrated in: the stated one cut by the unit's clearance class and the spec's modulus
        # rule (nominal_parameters, within_spec_rules), so a value at a cut bound is flagged too
        stated = NOMINAL.get(e.name, e)
        for j, prm in enumerate(e.params):
            row = {"name": e.name, "param": prm.name, "unit": prm.unit, "value": float(x[j]),
                   "interval": [float(iv[j][0]), float(iv[j][1])], "nominal": float(e.center[j]),
                   "shift": float(x[j] - e.center[j]), "prior_sigma": float(e.prior_sigma[j]),
                   "prior_range": [prm.low, prm.high], "stated_range": [stated.params[j].low, stated.params[j].high],
                   "cut_by": (CUT_BY.get(e.name, "the unit leaves")
                              if (prm.low, prm.high) != (stated.params[j].low, stated.params[j].high) else None),
                   "determined": determined,
                   "at_prior_bound": bool(determined and min(x[j] - prm.low, prm.high - x[j]) < 1e-3 * (prm.high - prm.low)
                                          and not (prm.low == e.center[j] == 0.0 and x[j] - prm.low < 1e-12))}
            if prm.name == "compliance_change":
                row["stiffness_scale"] = anchor_scale * stiffness_scale(x[j])
                row["stiffness_scale_interval"] = sorted(anchor_scale * stiffness_scale(min(max(v, prm.low), prm.high))
                                                         for v in iv[j])
                row["anchor_scale"] = anchor_scale
            if not determined:
                row["why"] = held[e.name]
            out.append(row)
    return out


def nominal_parameters(names: tuple[str, ...] | None = None,
                       spec: ReducerSpec | None = None) -> tuple[tuple[Effect, ...], dict[str, str]]:
    """The nominal parameters to calibrate (all by default; ``()`` for none) for the unit ``spec``, and those
    the spec leaves nothing to calibrate (name → why).

    The crank-bearing clearance's class (0 … :func:`clearance_class_top`) bounds the unit's total clearance: the
    calibration adds to the spec's nominal clearance at most what the class has left above it."""
    if names is None:
        names = tuple(NOMINAL)
    bad = [n for n in names if n not in NOMINAL]
    if bad:
        raise ValueError(f"unknown nominal parameter {bad[0]!r}; known: {', '.join(NOMINAL)}")
    out, dropped = [], {}
    for n in names:
        e = NOMINAL[n]
        if n == "crank_bearing_clearance" and spec is not None:
            stated, top = spec.bearings.eccentric.clearance_m, clearance_class_top(spec)
            room = top - stated
            if room < 0.5 * UM:
                dropped[n] = (f"the spec's nominal crank-bearing clearance {stated / UM:.1f} µm leaves nothing of the "
                              f"class 0 … {top / UM:.1f} µm to calibrate")
                continue
            p = e.params[0]
            e = dc.replace(e, params=(dc.replace(p, high=room, step=min(p.step, room)),))
        out.append(e)
    return tuple(out), dropped

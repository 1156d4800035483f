"""Name TE orders by the parts of the reducer that turn at them.

A diagnosis may leave residual TE at some orders (harmonics per output revolution). This module
names each order by the parts of *this* unit that turn at it — from the unit's own tooth, pin and
crank counts, never from a hard-coded unit — by the library effects
(:data:`rvflex.diagnosis.effects.EFFECTS`) that act there, and by the part errors at that order
that no registered effect models.

Kinematics (housing and pin ring fixed, carrier = output; z1 sun teeth, z2 planet teeth, z_b pins,
z_c = z_b − 1 disc teeth, n_c cranks; ratio i = 1 + (z2/z1)·z_b), turns per output revolution:

====================================================  ==========================  ============
part                                                  order                       relative to
====================================================  ==========================  ============
output flange, carrier, output encoder                1                           housing
cycloid discs (their own rotation)                    1                           housing
crank-count pattern on the carrier                    n_c                         housing
carrier pillar pattern                                pillar count                housing
input shaft (sun)                                     i                           housing
input shaft (sun) against the planets                 i − 1                       carrier
first-stage (sun–planet) mesh                         z1·(i − 1) = z2·z_b         carrier
cranks (planet gears, eccentrics, crank bearings)     (i − 1)·z1/z2 = z_b         carrier
eccentric (needle) bearings                           (i − 1)·z1/z2               discs
eccentric-bearing cages (rolling without slip)        z_b·r_j/(r_j + r_bore)      discs
pin passing (pins past a point of the carrier)        z_b                         carrier
cranks, i.e. the load zone, against the pins          |(i − 1)·z1/z2 − 1| = z_c   housing
pin-ring lobing, L = 2, 3, 4 lobes                    L·z_c                       load zone
cycloid–pin tooth mesh (pin–tooth engagements)        z_c·z_b                     housing
====================================================  ==========================  ============

Orders are exact :class:`fractions.Fraction` values (i is not an integer when z1 does not divide
z2·z_b); the cage order is the only approximate one (its radii are floats). An error riding on a
part that turns at f shows at m·f (harmonic m).

Which harmonics each error shows at was measured on the rigid model's quasi-static TE at rated
load, one error at a time, minus the error-free unit's TE (RV-40E, RV-80E, RV-160N; 3120 or 4096
positions per output revolution; amplitudes per typical step of the effect):

- errors fixed in the housing and swept by the load zone (pins, pin-ring runout, the model's
  ``carrier_runout_m``, which offsets the main-bearing seat in the housing) show at n·z_c, and the
  discs' eccentric phases (0°, 180°) cancel odd n: pin-ring runout 5 µm → 78 (0.105″ RV-40E,
  0.059″ RV-160N), nothing at 39; 2-lobed pins 5 µm → 78 (9.9″), 156, 234; 3-lobed → 234 = 6·z_c
  (1.44″), nothing at 117; 4-lobed (``pin_position_h4``) → 156 = 4·z_c (2.54″ for 4 µm RV-40E, 0.47″ for
  2 µm RV-160N), 312;
- where the needle bearings' clearance is open (part load) a pin-ring runout on a two-crank unit also shows off
  the pin period: the discs float against the ring the carrier carries them past once per output revolution, an
  even response at 2 and at the crank harmonics' sidebands 2·z_b ± 2, 4·z_b − 2 (RV-80E, 2 µm clearance, 8 µm at
  240 N·m: 2 0.32″, 82 0.15″, 158 0.23″, beside 78 0.53″; ≤ 15 % of it at rated torque; nothing without
  clearance, nothing on the three-crank RV-160N): ``PartError.condition``, left out of :func:`lacking_lookalikes`;
- a pin ring tilted against the crank axis (``ErrorSpec.pin_ring_tilt_rad``: the discs see the ring offset
  oppositely) shows at z_c, where the runout's phases cancel: 2 µm at each disc plane → 39 (8.2″ RV-40E,
  5.1″ RV-160N; at 100, 800 and 1800 N·m alike on the RV-160N), 78 (0.15″, 0.08″), nothing at 117
  (4e-4″): the effect ``pin_ring_tilt``;
- errors on the discs swept by the load zone show at m·z_b: a once-per-disc pitch error
  (``cycloid_pitch_error``) → 40 (6.9″ on one disc, 0.56″ alike on both; 0.08″ at 80), nothing at
  order 1; one tooth's profile error → 40, 80, 120, …;
- a carrier runout that turns with the carrier (all crank bores offset alike) → 80 = 2·z_b (0.10″
  for 5 µm): z_b with the discs' phases cancelling odd harmonics;
- eccentric-bearing clearance alike on every bearing (8 µm) → the harmonics of z_b that are
  multiples of n_c and even: RV-40E 80 (5.4″), 160 (0.62″); RV-160N 240 (0.057″), nothing at 40,
  80, 120;
- planet runout on one crank (10 µm) → 40 (1.0″ RV-40E, 0.55″ RV-160N); the same runout on every planet
  → nothing at any order (≤ 1e-4″ RV-160N);
- one crank's eccentrics off its journal axis (``crank_runout``, 5 µm, turning with the crank) → z_b = 40
  (13.9″ RV-40E, 6.7″ RV-160N), ≤ 1e-4 of it at 80; the same runout on every crank moves the discs
  without a fight: the mean only (0.21″ RV-40E, 0.11″ RV-160N, < 0.004″ at any order);
- a planet base-pitch error → the first-stage mesh 1440 (RV-40E), 1760 (RV-160N);
- the sun's runout is second order (the sun is held on the axis and the planets' meshes cancel its
  first harmonic): 20 µm → 0.002″ at 2·(i − 1) = 240 on the RV-40E, ≤ 2e-4″ on the RV-160N;
  nothing at the input's own order i;
- an angle error a of the sun against the input as driven and read (``input_shaft_eccentricity``: the
  input shaft off-centre to the motor, or an off-centre input encoder) turns every planet alike: TE
  a/i at order i exactly (0.3 mrad → 0.511″ at 121 RV-40E, 0.764″ at 81 RV-160N; < 1e-3 of it at
  any other order);
- crank eccentricity errors, modification deviations, the pin-circle growth of
  ``thermal_expansion``, uniform pin radius errors: the mean (wind-up) and the amplitude of the
  tooth-mesh order z_c·z_b (0.07–0.15″ RV-40E) only, no crank-order TE (RV-160N alike: a common −3 µm
  crank eccentricity error ≤ 1e-4″ at any order, a differential 3 µm one 0.001″ at 80);
- ``crank_phase_error``, ``carrier_hole_position``, ``main_bearing_clearance``, friction (a load
  change) and ``output_series_compliance`` move the mean only (≤ 0.002″ at any order): they are
  named at no order (:data:`MEAN_ONLY`);
- nothing acts at the crank-count order n_c of a three-crank unit: on the RV-160N a 10 µm pin-ring runout, a
  10 µm main-bearing seat offset, 4 µm 2- and 3-lobed pin patterns give < 5e-4″ at orders 1 … 6 (1280 positions,
  rated load; the runout 0.24″ at 78). The rigid carrier turns the cranks' pattern past uniform pins, so TE at
  n_c needs a carrier-fixed pattern meeting a housing-fixed one (a housing or carrier whose stiffness varies
  around, the output's support): :data:`PART_ERRORS` lists it as lacking (``crank_pattern``,
  ``pillar_pattern``);
- ``output_encoder_eccentricity`` is a·cos θ + b·sin θ: order 1 exactly;
- ``disc_carrier_flexibility`` (a flexible-disc model) is placed at the tooth mesh, not measured
  here (an FE run).
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Literal, get_args

import numpy as np

from rvflex.diagnosis.effects import EFFECTS
from rvflex.geometry.pins import disc_planes
from rvflex.spec import ReducerSpec

__all__ = ["MEAN_ONLY", "PART_ERRORS", "NO_PART_NOTE", "HarmonicRule", "PartError", "PartRotation", "effects_at",
           "lacking_lookalikes", "name_orders", "parts_at", "rotations"]

HarmonicRule = Literal["any", "first", "two_cranks_even", "discs_housing", "discs_housing_tilt", "discs_carrier",
                       "cranks_carrier", "planets"]
"""At which harmonics of its part an error shows in the TE:

``"any"``: every harmonic m; ``"first"``: m = 1 only; ``"two_cranks_even"``: even m on a two-crank unit, none on others (the
discs floating in their bearings' free play against a runout: an even response; three cranks hold them); ``"discs_housing"``: an error fixed in the housing
and swept by the load zone, at TE order n·z_c where the discs' eccentric phases φ_d do not cancel
(Σ_d exp(i·n·φ_d) ≠ 0); ``"discs_housing_tilt"``: a once-round error that the discs see with opposite signs
(a tilted pin ring: disc d at axial position z_d sees it ∝ z_d), at z_c itself where Σ_d z_d·exp(i·φ_d) ≠ 0 (two
discs in antiphase: the order a runout's cancel; its higher harmonics are second order, measured
below); ``"discs_carrier"``: the same for an error fixed on the carrier, at n·z_b;
``"cranks_carrier"``: n·z_b with n a multiple of the crank count and not cancelled by the discs'
phases (an error alike on every crank's bearing); ``"planets"``: harmonics m of the sun's order against
the carrier that are multiples of the crank (planet) count."""

NO_PART_NOTE = "no part of this unit turns at this order (a multiple of none); measurement or dynamic origin"
"""The note of an order no part explains."""


@dataclass(frozen=True, slots=True)
class PartError:
    """A kind of part error, the effects of the library that model it and where it shows.

    Attributes
    ----------
    key : str
        Identifier (a key of :data:`PART_ERRORS`).
    description : str
        The error in words.
    effects : tuple of str
        Names of the effects in :data:`rvflex.diagnosis.effects.EFFECTS` that model it (empty: none).
    rule : HarmonicRule
        Which harmonics of its part's order it shows at in the TE (measured on the rigid model).
    condition : str
        When it shows only under a condition (the needle bearings' clearance open): the condition in words; ""
        always. :func:`lacking_lookalikes` leaves such signatures out.
    """

    key: str
    description: str
    effects: tuple[str, ...]
    rule: HarmonicRule = "any"
    condition: str = ""

    def __post_init__(self) -> None:
        if self.rule not in get_args(HarmonicRule):
            raise ValueError(f"part error {self.key}: rule {self.rule!r} is not one of {get_args(HarmonicRule)}")


@dataclass(frozen=True, slots=True)
class PartRotation:
    """One rotating element of the reducer and the rate it turns at.

    Attributes
    ----------
    key : str
        Identifier (``"crank_carrier"``, ``"pin_ring_lobing_3"``, …).
    name : str
        The part (or the kinematic event: a mesh, the pin passing) in words.
    order : fractions.Fraction
        Turns (or events) per output revolution, exact (per output revolution, ≥ 0).
    relative_to : str
        What it turns relative to (``"housing"``, ``"carrier"``, ``"discs"``, ``"load zone"``).
    errors : tuple of str
        Keys of :data:`PART_ERRORS`: the kinds of error that ride on it.
    """

    key: str
    name: str
    order: Fraction
    relative_to: str
    errors: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not isinstance(self.order, Fraction) or self.order < 0:
            raise ValueError(f"part rotation {self.key}: order must be a non-negative Fraction, got {self.order!r}")
        unknown = [e for e in self.errors if e not in PART_ERRORS]
        if unknown:
            raise ValueError(f"part rotation {self.key}: unknown part errors {unknown}")


# the tooth-mesh amplitude (order z_c·z_b) changes by ≥ 0.02″ with each of these at its typical step (measured on
# the RV-40E; thermal_expansion as a 2 µm pin-circle growth); disc_carrier_flexibility is placed here by its physics
# (contact and disc compliance), not measured
_TOOTH_MESH_EFFECTS = ("disc_modification_deviation", "thermal_expansion", "crank_eccentricity_error",
                       "pin_ring_runout", "pin_position_h2", "pin_position_h3", "pin_position_h4",
                       "eccentric_bearing_clearance", "cycloid_pitch_error", "disc_carrier_flexibility")

PART_ERRORS: dict[str, PartError] = {e.key: e for e in (
    PartError("output_encoder_eccentricity", "output encoder eccentricity (a measurement artefact)",
              ("output_encoder_eccentricity",), "first"),
    PartError("output_runout", "output flange, coupling or load runout (once per output revolution)", ()),
    PartError("main_bearing_race", "main-bearing race runout or waviness (turns with the carrier)", ()),
    PartError("crank_pattern", "a carrier or housing error with the cranks' pattern (load sharing between the "
              "cranks)", ()),
    PartError("pillar_pattern", "a carrier error with the pillars' pattern", ()),
    PartError("input_runout_housing", "input shaft runout relative to the housing at the ratio order (input encoder "
              "or motor-coupling eccentricity)", ("input_shaft_eccentricity",), "first"),
    PartError("sun_runout", "sun (input shaft) runout or eccentricity against the planets (second order: the "
              "planets' meshes cancel its first harmonic)", ("input_stage_runout",), "planets"),
    PartError("first_stage_mesh", "first-stage mesh error (sun/planet tooth pitch or profile errors, mesh-stiffness "
              "variation)", ()),
    PartError("planet_runout", "planet gear runout or eccentricity per crank", ()),
    PartError("crank_journal_runout", "crank eccentric runout per crank (the crank's journals off its axis)",
              ("crank_runout",), "first"),
    PartError("disc_tooth_errors", "disc tooth pitch or profile errors (the load zone sweeps the disc's teeth)",
              ("cycloid_pitch_error",)),
    PartError("carrier_runout_turning", "carrier runout turning with the carrier (the crank bores off the "
              "carrier's bearing axis)", (), "discs_carrier"),
    PartError("eccentric_bearing_clearance", "eccentric (needle) bearing clearance alike on every bearing",
              ("eccentric_bearing_clearance",), "cranks_carrier"),
    PartError("eccentric_bearing_race", "eccentric (needle) bearing race waviness or defect", ()),
    PartError("eccentric_bearing_cage", "eccentric (needle) bearing cage defect", ()),
    PartError("pin_errors", "individual pin position or radius errors (the load zone sweeps the fixed pins)", (),
              "discs_housing"),
    PartError("pin_ring_runout", "pin-ring runout (1 lobe) or a main-bearing seat offset in the housing",
              ("pin_ring_runout",), "discs_housing"),
    # measured (tests/test_orders.py): the rigid RV-80E with 2 µm of needle clearance, an 8 µm runout at 240 N·m →
    # 2 (0.32″), 82 (0.15″), 158 (0.23″) beside 78 (0.53″); ≤ 0.02″ there without clearance, ≤ 15 % at rated
    # torque; the RV-40E alike (0.25″ at 2, 0.21″ at 158 at 30 % load); the three-crank RV-160N nothing (< 0.005″)
    PartError("pin_ring_runout_free_play", "pin-ring runout the discs float against in their bearings' free play",
              ("pin_ring_runout",), "two_cranks_even", "with the needle bearings' clearance open (part load)"),
    PartError("pin_ring_runout_free_play_carrier", "pin-ring runout modulating the bearings' free play at the crank "
              "harmonics", ("pin_ring_runout",), "two_cranks_even",
              "with the needle bearings' clearance open (part load)"),
    PartError("pin_ring_tilt", "pin-ring tilt against the crank axis (pin bores not parallel to it, or a ring offset "
              "that differs between the disc planes): the discs see the ring offset oppositely", ("pin_ring_tilt",),
              "discs_housing_tilt"),
    PartError("pin_ring_lobing_2", "pin-ring lobing (2 lobes)", ("pin_position_h2",), "discs_housing"),
    PartError("pin_ring_lobing_3", "pin-ring lobing (3 lobes)", ("pin_position_h3",), "discs_housing"),
    PartError("pin_ring_lobing_4", "pin-ring lobing (4 lobes)", ("pin_position_h4",), "discs_housing"),
    PartError("tooth_mesh", "cycloid–pin mesh ripple (profile modification, pin-circle and pin-radius deviations, "
              "crank eccentricity, contact compliance)", _TOOTH_MESH_EFFECTS),
)}
"""The kinds of part error by key (see :class:`PartError`; measured signatures in the module docstring)."""

MEAN_ONLY: dict[str, str] = {
    "crank_phase_error": "moves the mean TE (wind-up) only: ≤ 0.002″ at any order for 0.5 mrad",
    "carrier_hole_position": "moves the mean TE only: < 1e-4″ at any order for 6 µm",
    "main_bearing_clearance": "no TE in the rigid model (pure torque loads no main bearing)",
    "pin_contact_friction": "a load change: moves the mean TE (0.001″ at the tooth mesh for 2 % load)",
    "output_friction": "a load change: moves the mean TE (0.001″ at the tooth mesh for 2 % load)",
    "output_series_compliance": "a twist with the output torque: the mean TE only",
}
"""Registered effects that act on the mean TE only (named at no order), with what the model showed."""

_LOBES = (2, 3, 4)


def _fraction(value: float) -> Fraction:
    return Fraction(value).limit_denominator(10_000)


def rotations(spec: ReducerSpec) -> tuple[PartRotation, ...]:
    """Every rotating element of ``spec``'s unit with its order per output revolution.

    Parameters
    ----------
    spec : ReducerSpec
        The reducer (any tooth, pin and crank counts).

    Returns
    -------
    tuple of PartRotation
        In the order of the module docstring's table; orders exact (per output revolution).
    """
    s, c = spec.input_stage, spec.cycloid
    z1, z2, zb, nc = s.sun_teeth, s.planet_teeth, c.pin_count, spec.cranks.count
    i = 1 + Fraction(z2 * zb, z1)
    crank_carrier = (i - 1) * Fraction(z1, z2)
    crank_housing = abs(crank_carrier - 1)
    rj, rb = spec.cranks.eccentric_journal_radius_m, spec.cranks.disc_bore_radius_m
    out = [
        PartRotation("output", "output flange, carrier and output encoder", Fraction(1), "housing",
                     ("output_encoder_eccentricity", "output_runout", "main_bearing_race", "pin_ring_runout_free_play")),
        PartRotation("discs", "cycloid discs (their own rotation)", Fraction(1), "housing"),
        PartRotation("crank_pattern", f"crank-count pattern ({nc} cranks on the carrier)", Fraction(nc), "housing",
                     ("crank_pattern",)),
    ]
    if spec.carrier.pillar_count:
        out.append(PartRotation("pillar_pattern", f"carrier pillar pattern ({spec.carrier.pillar_count} pillars)",
                                Fraction(spec.carrier.pillar_count), "housing", ("pillar_pattern",)))
    out += [
        PartRotation("input_housing", "input shaft (sun)", i, "housing", ("input_runout_housing",)),
        PartRotation("input_carrier", "input shaft (sun) against the planets", i - 1, "carrier", ("sun_runout",)),
        PartRotation("first_stage_mesh", "first-stage (sun–planet) mesh", z1 * (i - 1), "carrier",
                     ("first_stage_mesh",)),
        PartRotation("crank_carrier", "cranks (planet gears, eccentrics, crank bearings)", crank_carrier, "carrier",
                     ("planet_runout", "crank_journal_runout", "disc_tooth_errors", "carrier_runout_turning")),
        PartRotation("eccentric_bearings", "eccentric (needle) bearings", crank_carrier, "discs",
                     ("eccentric_bearing_clearance", "eccentric_bearing_race")),
        PartRotation("eccentric_bearing_cages", "eccentric (needle) bearing cages (rolling without slip)",
                     crank_carrier * _fraction(rj / (rj + rb)), "discs", ("eccentric_bearing_cage",)),
        PartRotation("pin_passing", "pin passing (the pins past a point of the carrier and discs)",
                     Fraction(zb), "carrier", ("pin_ring_runout_free_play_carrier",)),
        PartRotation("crank_housing", "cranks against the pin ring (the load zone sweeping the pins)", crank_housing,
                     "housing", ("pin_errors", "pin_ring_runout", "pin_ring_tilt")),
    ]
    out += [PartRotation(f"pin_ring_lobing_{n}", f"pin-ring lobing ({n} lobes)", n * crank_housing, "load zone",
                         (f"pin_ring_lobing_{n}",)) for n in _LOBES]
    out.append(PartRotation("tooth_mesh", "cycloid–pin tooth mesh (pin–tooth engagements)", crank_housing * zb,
                            "housing", ("tooth_mesh",)))
    return tuple(out)


def _as_order(order) -> Fraction:
    try:
        k = Fraction(order)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"order {order!r}: expected a whole number of harmonics per output revolution") from exc
    if k.denominator != 1 or k < 1:
        raise ValueError(f"order {order!r}: expected a positive integer (harmonics per output revolution)")
    return k


def _harmonic(order: Fraction, part_order: Fraction, max_harmonic: int) -> int | None:
    if part_order <= 0:
        return None
    m = order / part_order
    return int(m) if m.denominator == 1 and 1 <= m <= max_harmonic else None


def parts_at(spec: ReducerSpec, order, max_harmonic: int = 8) -> list[dict]:
    """Every part that turns at ``order`` or at a whole fraction of it.

    Parameters
    ----------
    spec : ReducerSpec
        The reducer.
    order : int
        TE order, harmonics per output revolution (a positive integer).
    max_harmonic : int, optional
        Largest harmonic m of a part's order considered.

    Returns
    -------
    list of dict
        One ``{"part", "harmonic", "relative_to", "key", "part_order"}`` per rotation with
        ``harmonic`` · ``part_order`` == ``order`` (``part_order`` a Fraction, per output revolution).

    Raises
    ------
    ValueError
        ``order`` is not a positive integer, or ``max_harmonic`` < 1.
    """
    if max_harmonic < 1:
        raise ValueError(f"max_harmonic = {max_harmonic}: must be at least 1")
    k = _as_order(order)
    out = []
    for rot in rotations(spec):
        m = _harmonic(k, rot.order, max_harmonic)
        if m is not None:
            out.append({"part": rot.name, "harmonic": m, "relative_to": rot.relative_to, "key": rot.key,
                        "part_order": float(rot.order)})
    return out


def _disc_sum(spec: ReducerSpec, n: int, tilted: bool = False) -> float:
    """|Σ_d w_d·exp(i·n·φ_d)| / Σ_d |w_d| over the discs' eccentric phases φ_d: w_d = 1, or (``tilted``) the disc's
    axial position from the discs' mid-plane."""
    phases = spec.cycloid.disc_phase_rad
    w = disc_planes(spec) if tilted else np.ones(len(phases))
    total = float(np.sum(np.abs(w)))
    return abs(sum(x * cmath.exp(1j * n * p) for x, p in zip(w, phases))) / total if total > 0 else 0.0


def _shows(err: PartError, spec: ReducerSpec, order: Fraction, m: int) -> tuple[bool, bool]:
    """(whether ``err`` shows at TE ``order`` = m·its part's order, whether only the discs' phases cancel it)."""
    zb, zc, nc = spec.cycloid.pin_count, spec.cycloid.disc_teeth, spec.cranks.count
    rule = err.rule
    if rule == "any":
        return True, False
    if rule == "first":
        return m == 1, False
    if rule == "two_cranks_even":
        return nc == 2 and m % 2 == 0, False
    if rule == "planets":
        return m % nc == 0, False
    n = order / (zc if rule in ("discs_housing", "discs_housing_tilt") else zb)
    if n.denominator != 1 or (rule == "discs_housing_tilt" and n != 1):
        return False, False
    if rule == "cranks_carrier" and int(n) % nc:
        return False, False
    if _disc_sum(spec, int(n), tilted=rule == "discs_housing_tilt") < 1e-6:
        return False, True
    return True, False


def _known(candidates) -> tuple[str, ...]:
    names = tuple(EFFECTS)
    if candidates is None:
        return names
    unknown = [c for c in candidates if c not in EFFECTS]
    if unknown:
        raise ValueError(f"candidates {unknown}: not registered effects (known: {', '.join(names)})")
    return tuple(c for c in names if c in set(candidates))


def _at(spec: ReducerSpec, order: Fraction, max_harmonic: int):
    """Per part at ``order``: (rotation, m, shown errors, errors the discs' phases cancel)."""
    for rot in rotations(spec):
        m = _harmonic(order, rot.order, max_harmonic)
        if m is None:
            continue
        shown, cancelled = [], []
        for key in rot.errors:
            ok, by_discs = _shows(PART_ERRORS[key], spec, order, m)
            (shown if ok else cancelled if by_discs else []).append(PART_ERRORS[key])
        yield rot, m, shown, cancelled


def effects_at(spec: ReducerSpec, order, max_harmonic: int = 8, candidates=None, conditional: bool = True) -> list[str]:
    """The registered effects that act at TE ``order`` in the model.

    Parameters
    ----------
    spec : ReducerSpec
        The reducer.
    order : int
        TE order, harmonics per output revolution.
    max_harmonic : int, optional
        Largest harmonic of a part's order considered.
    candidates : sequence of str, optional
        Restrict to these effect names (None: every registered effect).
    conditional : bool, optional
        Count signatures that show only under a condition (:attr:`PartError.condition`; default True).

    Returns
    -------
    list of str
        Effect names, in the order of :data:`~rvflex.diagnosis.effects.EFFECTS`.

    Raises
    ------
    ValueError
        A candidate that is not a registered effect, or a bad ``order``.
    """
    allowed = _known(candidates)
    k = _as_order(order)
    found = {name for _rot, _m, shown, _c in _at(spec, k, max_harmonic) for err in shown for name in err.effects
             if conditional or not err.condition}
    return [name for name in allowed if name in found]


def _effects_of(spec: ReducerSpec, key: str, m: int) -> set[str]:
    """Registered effects riding on rotation ``key`` that show at its harmonic ``m``."""
    rot = next(r for r in rotations(spec) if r.key == key)
    order = m * rot.order
    if order.denominator != 1:
        return set()
    return {name for err in (PART_ERRORS[e] for e in rot.errors) if _shows(err, spec, order, m)[0]
            for name in err.effects if name in EFFECTS}


# a ripple the carrier-frame pin passing makes in every unit is modulated by what turns slowly against it: a part
# fixed in the housing (a ring runout or lobing the load zone sweeps) or turning with the output (its flange); so
# its sidebands count, by parts turning at most this fraction of its order (slow modulations; a faster part would
# make nearly every order a sideband of some harmonic)
SLOW_MODULATION = Fraction(1, 8)


def _sidebands(spec: ReducerSpec, order: Fraction, max_harmonic: int, side_harmonic: int) -> list[dict]:
    rots = rotations(spec)
    meshes = [r for r in rots if r.key in ("tooth_mesh", "first_stage_mesh", "pin_passing")]
    out = []
    for mesh in meshes:
        limit = mesh.order * SLOW_MODULATION if mesh.key == "pin_passing" else mesh.order
        for p in range(1, max_harmonic + 1):
            offset = order - p * mesh.order
            if offset == 0:
                continue
            for rot in rots:
                if rot in meshes or rot.order >= limit:
                    continue
                m = _harmonic(abs(offset), rot.order, side_harmonic)
                if m is not None:
                    out.append({"mesh": mesh.name, "mesh_key": mesh.key, "mesh_harmonic": p,
                                "mesh_order": float(mesh.order), "part": rot.name,
                                "harmonic": m, "relative_to": rot.relative_to, "key": rot.key,
                                "sign": "+" if offset > 0 else "−"})
    return out


def _sideband_text(sidebands: list[dict], order: Fraction) -> str:
    """The sidebands of an order in words, grouped by mesh harmonic: "2× pin passing + 2 (output flange, …)"."""
    groups = {}
    for sb in sidebands:
        mesh = sb["mesh"].split(" (")[0]
        offset = order - sb["mesh_harmonic"] * _fraction(sb["mesh_order"])
        groups.setdefault((sb["mesh_harmonic"], mesh, offset), []).append(sb["part"].split(" (")[0])
    return "; ".join(f"{p}× {mesh} {'+' if off > 0 else '−'} {abs(off)}: {', '.join(dict.fromkeys(names))}"
                     for (p, mesh, off), names in groups.items())


def name_orders(spec: ReducerSpec, orders, candidates=None, max_harmonic: int = 8,
                side_harmonic: int = 2) -> list[dict]:
    """Name each TE order by the parts that turn at it, the effects that act there and what the library lacks.

    Parameters
    ----------
    spec : ReducerSpec
        The reducer.
    orders : iterable of int
        TE orders, harmonics per output revolution (positive integers).
    candidates : sequence of str, optional
        Effect names the ``candidates`` lists are restricted to (None: every registered effect).
    max_harmonic : int, optional
        Largest harmonic of a part's order (and of a mesh, for the sidebands) considered.
    side_harmonic : int, optional
        Largest harmonic of the modulating part in a sideband p·mesh ± m·part (the model's sidebands are
        those of the modulation's first harmonic: 1560 ± 78 for a pin-ring runout, 1560 ± 80 for an
        eccentric-bearing clearance on the RV-40E).

    Returns
    -------
    list of dict
        Per order: ``"order"`` (int), ``"parts"`` (:func:`parts_at`'s entries), ``"sidebands"`` (the order as
        p·mesh ± m·part: ``{"mesh", "mesh_key", "mesh_harmonic", "mesh_order", "part", "harmonic", "relative_to",
        "key", "sign"}``; a mesh is the tooth mesh, the first-stage mesh or the pin passing, whose ripple every unit
        shows, modulated by parts turning at most 1/8 as fast),
        ``"candidates"`` (effect names acting at a part there, or at both the mesh and the part of a sideband),
        ``"lacking"`` (descriptions of part errors that show there and that no registered effect models) and
        ``"note"`` (:data:`NO_PART_NOTE` when no part turns at the order; harmonics the discs' phases cancel).

    Raises
    ------
    ValueError
        A candidate that is not a registered effect, or an order that is not a positive integer.
    """
    allowed = _known(candidates)
    result = []
    for raw in orders:
        k = _as_order(raw)
        parts, found, lacking, cancelled = [], set(), [], []
        for rot, m, shown, gone in _at(spec, k, max_harmonic):
            parts.append({"part": rot.name, "harmonic": m, "relative_to": rot.relative_to, "key": rot.key,
                          "part_order": float(rot.order)})
            for err in shown:
                registered = [e for e in err.effects if e in EFFECTS]
                found.update(registered)
                if not registered and err.description not in lacking:
                    lacking.append(err.description)
            cancelled += [e.description for e in gone if e.description not in cancelled]
        sidebands = _sidebands(spec, k, max_harmonic, side_harmonic)
        for sb in sidebands:  # an effect acting at both the mesh harmonic and the modulating part's harmonic
            found.update(_effects_of(spec, sb["mesh_key"], sb["mesh_harmonic"])
                         & _effects_of(spec, sb["key"], sb["harmonic"]))
        notes = []
        if not parts and sidebands:
            notes.append("no part turns at this order itself: a sideband, the ripple of a mesh modulated by parts "
                         "turning slower (" + _sideband_text(sidebands, k) + ")")
        elif not parts:
            notes.append(NO_PART_NOTE)
        if cancelled:
            phases = ", ".join(f"{math.degrees(p):.0f}°" for p in spec.cycloid.disc_phase_rad)
            notes.append(f"the discs' eccentric phases ({phases}) cancel this harmonic of: " + "; ".join(cancelled))
        result.append({"order": int(k), "parts": parts, "sidebands": sidebands,
                       "candidates": [name for name in allowed if name in found], "lacking": lacking,
                       "note": "; ".join(notes)})
    return result


def lacking_lookalikes(spec: ReducerSpec, effect: str, max_order: int | None = None) -> dict:
    """The part errors no registered effect models that act at the lowest order where ``effect`` acts: what
    a finding of ``effect`` cannot be told from by TE alone (an encoder eccentricity at order 1 from a runout
    of the output flange, coupling or main-bearing race).

    Parameters
    ----------
    spec : ReducerSpec
        The reducer.
    effect : str
        A registered effect name.
    max_order : int, optional
        Highest order searched (default: 2·z_b).

    Returns
    -------
    dict
        ``{"order": k, "lacking": [descriptions]}`` at the effect's lowest order; ``{}`` when it acts at no order
        up to ``max_order`` (an effect on the mean only) or nothing is lacking there.
    """
    top = max_order or 2 * spec.cycloid.pin_count
    for k in range(1, top + 1):
        # the parts alone (cheaper than name_orders), where the effect always shows (not only under a condition)
        if effect not in effects_at(spec, k, candidates=(effect,), conditional=False):
            continue
        row = name_orders(spec, [k], candidates=(effect,))[0]
        return {"order": k, "lacking": row["lacking"]} if row["lacking"] else {}
    return {}

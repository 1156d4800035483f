"""The effect library: candidate unmodelled effects, each a named, bounded, physical
parameterisation.

An :class:`Effect` acts in one of four ways (``kind``):

``"model"``
    ``apply(spec, errors, x) -> (spec, errors)``: a spec/ErrorSpec variant (made with
    :func:`dataclasses.replace`) that the model is rebuilt with. With ``per_run=True`` the
    function also receives the run, ``apply(spec, errors, x, run)``, and the variant may differ
    from run to run (thermal expansion: each run at its own recorded temperature).
``"conditions"``
    ``conditions(plan_run, x, spec) -> plan_run``: changes what the model is loaded with
    (pin-contact friction: a Coulomb torque opposing the motion).
``"measurement"``
    ``measure(position_rad, te_rad, x) -> te_rad``: a measurement artefact applied to the
    model's TE as the bench would record it (output-encoder eccentricity); or
    ``series(torque_Nm, x, spec) -> rad``: the twist of a compliance in series with the output
    (between the reducer and the encoder or the load), added to every run at its output torque
    without a model run.
``"fidelity"``
    the model with other :class:`~rvflex.options.ModelOptions` (``options``, e.g. FE discs), or
    with another contact law (``alt_law(spec) -> ContactLaw``), blended with the model's run by the
    parameter (1 = the other model).

No effect carries a hand-written signature: the diagnosis finds each one's orders, load and
direction dependence by running the model with it (:mod:`rvflex.diagnosis.fit`).

Register a new effect by adding one object::

    from rvflex.diagnosis.effects import EFFECTS, Effect, Param, register
    register(Effect("my_effect", "what it is", (Param("size_m", "m", -1e-5, 1e-5, 3e-6),),
                    apply=my_apply))   # my_apply(spec, errors, x) -> (spec, errors), module-level

Effects must be picklable (module-level functions or :func:`functools.partial` of them) so
that process pools can evaluate them.
"""

from __future__ import annotations

import dataclasses as dc
import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np

from rvflex.choices import EffectKind, check_choice
from rvflex.options import ModelOptions
from rvflex.spec import ErrorSpec, ReducerSpec
from rvflex.units import ARCSEC, UM

__all__ = ["EFFECTS", "REFERENCE_TEMPERATURE_C", "THERMAL_ALPHA_MISMATCH_PER_K", "Effect", "Param",
           "available_effects", "register"]

# housing-to-steel expansion mismatch: an aluminium-alloy housing (23e-6/K) around steel pins
# and discs (11.5e-6/K); a nodular-iron housing (QT500-7, 10.5e-6/K) gives −1e-6/K.
THERMAL_ALPHA_MISMATCH_PER_K = 11.5e-6
# the temperature the reducer's dimensions refer to (ISO 1 reference temperature for dimensional
# specifications): the spec's pin circle and disc profile hold at 20 °C
REFERENCE_TEMPERATURE_C = 20.0


@dataclass(frozen=True)
class Param:
    """One effect parameter (SI).

    Attributes
    ----------
    name : str
        Parameter name with its unit suffix.
    unit : str
        SI unit.
    low, high : float
        Physical bounds.
    step : float
        Typical magnitude: the sensitivity step and the scale of the self-check draws.
    """

    name: str
    unit: str
    low: float
    high: float
    step: float

    def __post_init__(self) -> None:
        if not (self.low <= 0.0 <= self.high and self.low < self.high and 0 < self.step <= self.high - self.low):
            raise ValueError(f"parameter {self.name}: need low ≤ 0 ≤ high and 0 < step ≤ high − low")


@dataclass(frozen=True)
class Effect:
    """A candidate unmodelled effect (see the module docstring).

    ``polar`` marks a two-parameter effect whose parameters are the x and y components of one
    vector (a runout and its phase): its magnitude is their norm. ``central`` asks for central
    sensitivities (two model runs per parameter): for effects whose response is one-sided at the
    typical step (a pin pattern moves some pins into contact and others out of it), the secant
    of one side mis-states the signature. ``two_sided`` also runs the model at −step and keeps
    both secants: the fit uses the +step secant for a positive parameter value and the −step
    secant for a negative one (for responses whose slope differs on the two sides of zero, as
    a clearance that opens on one side and closes into preload on the other).
    ``corners`` (two-parameter ``two_sided`` effects): the model is also run at the four corners
    (±step, ±step), and the linearised fits may also use secants through a corner
    (:meth:`Sensitivities.orthants <rvflex.diagnosis.linear.Sensitivities.orthants>`): for parameters that
    nearly cancel each other along a diagonal, the response there is not the sum of the two axes' responses.
    ``same_as`` (name, map): this effect is the effect ``name`` with some of its parameters held at zero, the
    same model: per parameter of that effect, the index of this effect's parameter it equals (None: zero).
    A fit of either is restated as the other where the values allow (:func:`rvflex.diagnosis.fit.restated`).
    ``per_run`` (kind ``"model"``): ``apply`` receives the run as a fourth argument.
    ``run_fields``: run attributes (of :class:`~rvflex.diagnosis.plan.PlanRun`) that must be
    known (finite) for every run of a dataset for the effect to be evaluated, e.g.
    ``("temperature_C",)``.
    ``prior_sigma`` (one per parameter, parameter units) marks an *uncertain nominal parameter* of
    the model rather than an unmodelled effect (:mod:`rvflex.diagnosis.nominal`): it is calibrated
    before any effect is attributed, with a regulariser ‖(x − c)/σ‖² toward its nominal value c
    (``prior_center``, default 0);
    ``separating_runs`` names the bench runs that tell it from look-alike effects.
    ``unjudged_by`` names model forms that act where the effect acts and that the null distribution's
    ensemble (:mod:`rvflex.diagnosis.ensemble`) cannot draw yet: a healthy unit of such a form is fitted by
    the effect at sizes no control reached, so the effect is never established while its look-alikes are
    missing from the ensemble (:func:`rvflex.diagnosis.grade.grade`); it is still ranked and reported as
    consistent.
    ``relative_to_last_crank``: one parameter per crank but the last, relative to it (:meth:`for_unit` keeps as
    many as the unit has cranks less one).
    ``coupled_to`` (kind ``"model"``): the name of a fidelity effect whose model changes this
    effect's signature (the contact stiffness shapes the elastic discs' pin-mesh orders): the
    effect's secant is taken on that model too, and the difference from the rigid one enters in
    proportion to the fidelity effect's share (:mod:`rvflex.diagnosis.sensitivity`).
    """

    name: str
    description: str
    params: tuple[Param, ...]
    kind: EffectKind = "model"
    apply: Callable | None = None
    conditions: Callable | None = None
    measure: Callable | None = None
    options: ModelOptions | None = None  # kind "fidelity": the model it blends in (None: the diagnosing model's)
    polar: bool = False
    central: bool = False
    two_sided: bool = False
    corners: bool = False
    per_run: bool = False
    run_fields: tuple[str, ...] = ()
    alt_law: Callable | None = None
    prior_sigma: tuple[float, ...] = ()
    prior_center: tuple[float, ...] = ()
    separating_runs: str = ""
    unjudged_by: str = ""
    coupled_to: str | None = None
    series: Callable | None = None  # kind "measurement": output twist (rad) of a series compliance at a torque
    same_as: tuple[str, tuple[int | None, ...]] | None = None
    relative_to_last_crank: bool = False  # one parameter per crank but the last (:meth:`for_unit`)

    def __post_init__(self) -> None:
        check_choice(f"effect {self.name}: kind", self.kind, EffectKind)
        need = {"model": self.apply, "conditions": self.conditions, "measurement": self.measure or self.series,
                "fidelity": True}
        if need[self.kind] is None:
            raise ValueError(f"effect {self.name}: kind {self.kind!r} needs its function")
        if self.central and self.two_sided:
            raise ValueError(f"effect {self.name}: central and two_sided sensitivities exclude each other")
        if self.corners and not (self.two_sided and len(self.params) == 2):
            raise ValueError(f"effect {self.name}: corners applies to two-parameter two_sided effects only")
        if self.same_as and sorted(i for i in self.same_as[1] if i is not None) != list(range(len(self.params))):
            raise ValueError(f"effect {self.name}: same_as must map each of its parameters once")
        if self.per_run and self.kind != "model":
            raise ValueError(f"effect {self.name}: per_run applies to kind 'model' only")
        if self.prior_sigma and (len(self.prior_sigma) != len(self.params) or min(self.prior_sigma) <= 0):
            raise ValueError(f"effect {self.name}: prior_sigma needs one positive value per parameter")
        if self.prior_center and len(self.prior_center) != len(self.params):
            raise ValueError(f"effect {self.name}: prior_center needs one value per parameter")

    @property
    def center(self) -> np.ndarray:
        """Nominal value of each parameter (the prior's centre; 0 unless ``prior_center``)."""
        return np.asarray(self.prior_center, float) if self.prior_center else np.zeros(self.n)

    @property
    def nominal(self) -> bool:
        """Whether this is an uncertain nominal parameter (calibrated), not an unmodelled effect."""
        return bool(self.prior_sigma)

    @property
    def n(self) -> int:
        """Number of parameters."""
        return len(self.params)

    @property
    def units(self) -> tuple[str, ...]:
        return tuple(p.unit for p in self.params)

    @property
    def lower(self) -> np.ndarray:
        return np.array([p.low for p in self.params])

    @property
    def upper(self) -> np.ndarray:
        return np.array([p.high for p in self.params])

    @property
    def steps(self) -> np.ndarray:
        return np.array([p.step for p in self.params])

    def magnitude(self, x: np.ndarray) -> float:
        """One scalar size of the effect: the norm of its parameter vector (parameter unit)."""
        return float(np.linalg.norm(np.asarray(x, float)))

    def available(self) -> tuple[bool, str]:
        """Whether the model can evaluate this effect now, and why not (every registered effect can;
        kept for effects registered with a model that is not built yet)."""
        return True, ""

    def for_unit(self, spec: ReducerSpec) -> Effect:
        """This effect as the unit ``spec`` has it: an effect ``relative_to_last_crank`` keeps one parameter per
        crank but the last (at least one, at most its own count)."""
        if not self.relative_to_last_crank:
            return self
        k = min(max(spec.cranks.count - 1, 1), self.n)
        return self if k == self.n else dc.replace(self, params=self.params[:k])

    def available_for(self, plan) -> tuple[bool, str]:
        """Whether the runs ``plan`` (:class:`~rvflex.diagnosis.plan.PlanRun` sequence) carry what
        this effect needs (``run_fields``), and why not."""
        for fld in self.run_fields:
            missing = [p.label for p in plan if not math.isfinite(float(getattr(p, fld, math.nan)))]
            if missing:
                return False, (f"needs '{fld}' for every run in bench.toml; missing for "
                               f"{', '.join(missing[:3])}{' …' if len(missing) > 3 else ''}")
        return True, ""

    def apply_to(self, spec: ReducerSpec, errors: ErrorSpec, x, run=None) -> tuple[ReducerSpec, ErrorSpec]:
        """The spec/ErrorSpec variant of a ``"model"`` effect at parameters ``x`` (for ``run`` when
        the effect is ``per_run``)."""
        if self.per_run:
            return self.apply(spec, errors, x, run)
        return self.apply(spec, errors, x)


# ----------------------------------------------------------------------------- apply functions (module level: picklable)

def _errors_field(spec: ReducerSpec, errors: ErrorSpec, x, *, field: str, per: str = "") -> tuple:
    n = {"": 0, "crank": spec.cranks.count, "eccentric": spec.cranks.count * spec.cycloid.disc_count}[per]
    value = float(x[0]) if not n else (float(x[0]),) * n
    if per == "eccentric":  # clearances add to what the errors already have
        old = errors.eccentric_bearing_clearance_m or (0.0,) * n
        value = tuple(o + v for o, v in zip(old, value))
    elif field == "main_bearing_clearance_m":
        value += errors.main_bearing_clearance_m
    return spec, dc.replace(errors, **{field: value})


def _runout(spec, errors, x, *, field: str, angle_multiple: int = 1, phase_field: str = ""):
    """A runout of magnitude |x| (the field's unit) at the angle atan2(x[1], x[0]) / ``angle_multiple``, in
    ``phase_field`` (default: ``field`` with ``_m`` replaced by ``_phase_rad``)."""
    m = float(math.hypot(x[0], x[1]))
    phase = float(math.atan2(x[1], x[0])) / angle_multiple
    return spec, dc.replace(errors, **{field: m, (phase_field or field.replace("_m", "_phase_rad")): phase})


def _crank_runout(spec, errors, x):
    """A runout (x[0], x[1]) (m, in the crank's frame) of crank 0's eccentrics relative to its journal axis, added
    to the runouts the errors already have; the other cranks unchanged."""
    n = spec.cranks.count
    r = np.asarray(errors.crank_runout_m or (0.0,) * n, float)
    phase = np.asarray(errors.crank_runout_phase_rad or (0.0,) * n, float)
    z = r * np.exp(1j * phase)
    z[0] += complex(float(x[0]), float(x[1]))
    return spec, dc.replace(errors, crank_runout_m=tuple(float(v) for v in np.abs(z)),
                            crank_runout_phase_rad=tuple(float(v) for v in np.angle(z)))


def _pin_harmonic(spec, errors, x, *, harmonic: int, angle_multiple: int = 1):
    """Per-pin radial position error a·cos(h·θ_j − ψ) with a = |x| and ψ = atan2(x[1], x[0]) / angle_multiple
    (angle_multiple 1: the cos/sin amplitudes x[0], x[1])."""
    zb = spec.cycloid.pin_count
    ang = 2 * np.pi * np.arange(zb) / zb
    a, psi = math.hypot(x[0], x[1]), math.atan2(x[1], x[0]) / angle_multiple
    r = a * np.cos(harmonic * ang - psi)
    old = np.asarray(errors.pin_radial_m) if errors.pin_radial_m else np.zeros(zb)
    return spec, dc.replace(errors, pin_radial_m=tuple(float(v) for v in old + r))


def _per_crank(spec, errors, x, *, field: str):
    """``x`` added to cranks 0, 1, …; the cranks beyond ``x`` unchanged (a third crank's phase error is
    the other two's relative to it plus an input offset, so two parameters describe three cranks)."""
    n = spec.cranks.count
    old = getattr(errors, field) or (0.0,) * n
    add = tuple(float(v) for v in x)[:n] + (0.0,) * max(n - len(x), 0)
    return spec, dc.replace(errors, **{field: tuple(float(o + v) for o, v in zip(old, add))})


def _crank_modes(spec, errors, x):
    """Common part c on every crank, differential part d on cranks 0 (+d) and 1 (−d)."""
    c, d = float(x[0]), float(x[1])
    return _per_crank(spec, errors, (c + d, c - d) + (c,) * (spec.cranks.count - 2), field="crank_eccentricity_error_m")


def _modification(spec, errors, x):
    c = spec.cycloid
    mod = dc.replace(c.modification, moved_m=c.modification.moved_m + float(x[0]),
                     equidistant_m=c.modification.equidistant_m + float(x[1]))
    return dc.replace(spec, cycloid=dc.replace(c, modification=mod)), errors


def _pitch_harmonic(spec, errors, x):
    zc, nd = spec.cycloid.disc_teeth, spec.cycloid.disc_count
    j = 2 * np.pi * np.arange(zc) / zc
    row = x[0] * np.cos(j) + x[1] * np.sin(j)
    old = errors.disc_pitch_error_m or tuple((0.0,) * zc for _ in range(nd))
    return spec, dc.replace(errors, disc_pitch_error_m=tuple(tuple(float(a + b) for a, b in zip(o, row)) for o in old))


def _carrier_holes(spec, errors, x):
    d = float(x[0])
    return spec, dc.replace(errors, input_carrier_hole_distance_error_m=errors.input_carrier_hole_distance_error_m + d,
                            output_carrier_hole_distance_error_m=errors.output_carrier_hole_distance_error_m + d)


def _thermal(spec, errors, x, run):
    """Uniform temperature T of the run (``run.temperature_C``, °C) with a housing-to-steel
    expansion mismatch x[0] (1/K): the pin circle (in the housing) grows against the steel discs
    by Δα·r_b·(T − T_ref), T_ref = REFERENCE_TEMPERATURE_C, where the spec's dimensions hold."""
    dT = float(run.temperature_C) - REFERENCE_TEMPERATURE_C
    growth = float(x[0]) * spec.cycloid.pin_circle_radius_m * dT
    return spec, dc.replace(errors, pin_circle_radius_error_m=errors.pin_circle_radius_error_m + growth)


def _friction_conditions(run, x, spec):
    """Coulomb friction torque T_f = x·T_rated referred to the output, opposing the relative
    motion: a TE run (sliding all the time) sees its load grow by T_f; in a torque cycle the
    mesh sees the applied torque T through a Coulomb play of ±T_f — T − T_f·sgn(dT/dt) while
    it slides, held (stuck) while T changes by less than 2·T_f after a reversal and, from the
    unloaded start, until T first exceeds T_f. (The output friction's Coulomb part alone.)"""
    return _output_friction_conditions(run, (x[0], 0.0), spec)


def _output_friction_conditions(run, x, spec):
    """Friction torque referred to the output, T_f = x[0]·T_rated + x[1]·|T| (a Coulomb part from seals
    and bearing preload, and a part proportional to the transmitted torque), opposing the motion: a TE
    run (sliding all the time) sees its load grow by T_f; in a torque cycle the mesh sees the applied
    torque T through the play ±T_f(T): T − T_f·sgn(dT/dt) while it slides, held while T changes by less
    than 2·T_f after a reversal and, from the unloaded start, until T first exceeds T_f."""
    tc, mu = float(x[0]) * spec.rated_torque_Nm, float(x[1])
    if run.kind == "te":
        return dc.replace(run, load_Nm=run.load_Nm + tc + mu * run.load_Nm)
    eff, held = [], 0.0
    for t in run.torque_path_Nm:
        tf = tc + mu * abs(t)
        held = min(max(held, t - tf), t + tf)
        eff.append(float(held))
    return dc.replace(run, torque_eff_Nm=tuple(eff))


SERIES_STIFFENING_EXPONENT = 2.0 / 3.0  # twist ∝ T^(2/3): a Hertzian (point-contact) joint stiffening with load


def _series_twist(torque_Nm, x, spec):
    """Twist (rad) of a torsional compliance in series with the output at the torque ``torque_Nm``:
    x[0]·T/T_r (linear) + x[1]·sgn(T)·(|T|/T_r)^(2/3) (stiffening with load); x is the twist at rated
    torque (rad) of each part."""
    t = np.asarray(torque_Nm, float) / spec.rated_torque_Nm
    return x[0] * t + x[1] * np.sign(t) * np.abs(t) ** SERIES_STIFFENING_EXPONENT


def _encoder_eccentricity(position_rad, te_rad, x):
    """An output encoder mounted eccentrically reads θ + a·cos θ + b·sin θ (a, b in rad)."""
    return te_rad + x[0] * np.cos(position_rad) + x[1] * np.sin(position_rad)


def _builtin() -> tuple[Effect, ...]:
    um = UM
    xy = ("x_m", "y_m")

    def polar(lim, step, names=xy, unit="m"):
        return tuple(Param(n, unit, -lim, lim, step) for n in names)

    return (
        Effect("eccentric_bearing_clearance", "radial clearance of every crank (eccentric, needle) bearing",
               (Param("clearance_m", "m", 0.0, 30 * um, 8 * um),),
               apply=partial(_errors_field, field="eccentric_bearing_clearance_m", per="eccentric")),
        Effect("main_bearing_clearance", "radial clearance of the main (carrier) bearing",
               (Param("clearance_m", "m", 0.0, 30 * um, 8 * um),),
               apply=partial(_errors_field, field="main_bearing_clearance_m")),
        # the pin ring's runout relative to the carrier axis: a runout of the housing bore and one of
        # the carrier's main-bearing seat move the pins against the cranks alike, so TE and the
        # torque cycle cannot tell them apart (the planar model gives identical signatures); one
        # effect stands for both. Its response repeats every 180° of the runout's angle φ (the two discs'
        # load zones, 180° apart, sweep the fixed pins: TE at 2·z_c; measured: φ and φ + π give identical
        # TE and torque cycles, x and y runouts opposite order-78 TE), so it is parameterised by the
        # doubled angle, (r cos 2φ, r sin 2φ): in x/y components the two secants were antiparallel on
        # the TE and a linearised fit could not turn the runout (a hidden 6.6 µm runout refitted on the
        # TE runs alone moved 12 µm and predicted the torque cycle 237 % worse)
        Effect("pin_ring_runout", "pin-ring eccentricity r at angle φ relative to the carrier axis (housing-bore "
               "or carrier-seat runout), as (r cos 2φ, r sin 2φ): only 2φ is observable",
               polar(20 * um, 5 * um, ("cos2phi_m", "sin2phi_m")),
               apply=partial(_runout, field="pin_ring_runout_m", angle_multiple=2), polar=True),
        # pins leaning against the crank axis: the discs, on either side of their mid-plane, see the ring moved
        # oppositely, so their kinematic errors at the odd harmonics of the load zone's sweep add where a runout's
        # cancel (measured: 2 µm at each disc plane → 8.2″ at z_c on the RV-40E, its phase turning with φ)
        Effect("pin_ring_tilt", "pin-ring tilt t against the crank axis towards φ (pin bores not parallel to it, or a "
               "ring offset that differs between the disc planes: the disc at axial position z sees the ring moved "
               "t·z), as (t cos φ, t sin φ)",
               polar(1e-3, 2e-4, ("cos_rad", "sin_rad"), "rad"),
               apply=partial(_runout, field="pin_ring_tilt_rad", phase_field="pin_ring_tilt_phase_rad"), polar=True,
               separating_runs="a measurement of the pin bores' parallelism to the crank axis, or TE with the unit "
                               "turned end for end on the bench (a tilt keeps its order z_c)"),
        Effect("pin_position_h2", "per-pin radial position error, 2nd harmonic around the ring (cos/sin amplitudes)",
               polar(10 * um, 4 * um, ("cos_m", "sin_m")), apply=partial(_pin_harmonic, harmonic=2), polar=True,
               central=True),
        # a 3rd-harmonic pattern and its negative (the pattern turned by 60°) give identical TE and torque cycles
        # (measured at 412 N·m: 0.892″ at order 6·z_c = 234 and +2.41″ wind-up for both signs, and central secants
        # of exactly zero: the effect could never be found); a quarter turn of its phase ψ negates the order-234 TE.
        # So it is parameterised by the doubled phase, (a cos 2ψ, a sin 2ψ), as the pin-ring runout is
        Effect("pin_position_h3", "per-pin radial position error, 3rd harmonic around the ring: amplitude a at phase ψ "
               "as (a cos 2ψ, a sin 2ψ); a pattern and its negative look alike, so only 2ψ is observable",
               polar(10 * um, 4 * um, ("cos2psi_m", "sin2psi_m")),
               apply=partial(_pin_harmonic, harmonic=3, angle_multiple=2), polar=True),
        # a 4-lobed pin ring (a housing bore clamped out of round): 4·z_c = 156 is the lobing's first harmonic with
        # the discs' phases adding (4·π), so a pattern and its negative (turned 45°) give opposite order-156 TE
        # (measured to 1e-11; the mean alike), and cos/sin amplitudes serve as for 2 lobes. Bound as 2 and 3 lobes:
        # a pin pushed in by more than the profile's working clearance (equidistant − moved modification, 8 µm on
        # the catalogue units) preloads the mesh; step 2 µm: the RV-160N at rated load no longer converged at 4 µm
        Effect("pin_position_h4", "per-pin radial position error, 4th harmonic around the ring (cos/sin amplitudes)",
               polar(10 * um, 2 * um, ("cos_m", "sin_m")), apply=partial(_pin_harmonic, harmonic=4), polar=True,
               central=True),
        # common and differential parts: both cranks off alike change the drive's eccentricity (clearance
        # opens on one sign, preload on the other), which the sum of two one-crank secants missed (measured:
        # a −3.4/−3.2 µm pair fitted at the bounds, removing 4 % of a gap it had made)
        Effect("crank_eccentricity_error", "eccentricity error of the crankshafts: common part (all alike) and "
               "differential part (crank 0 = common + differential, crank 1 = common − differential, a third = common)",
               (Param("common_m", "m", -10 * um, 10 * um, 3 * um), Param("differential_m", "m", -10 * um, 10 * um, 3 * um)),
               apply=_crank_modes, two_sided=True),
        # relative to the last crank: the same phase error on every crank turns the eccentrics as the input would,
        # an output offset and no TE ripple, so a parameter for it would only drift to its bound unseen (measured,
        # RV-80E controls: both cranks' phases fitted at their bounds). Bound ±5 mrad: the eccentric's centre moved
        # e·φ along its path, 10 µm at the largest built-in eccentricity (2 mm), the crank eccentricity error's bound
        Effect("crank_phase_error", "eccentric phase error of each crank but the last, relative to the last (two "
               "cranks: crank 0 against crank 1; three: cranks 0 and 1 against crank 2)",
               tuple(Param(f"crank{k}_rad", "rad", -5e-3, 5e-3, 5e-4) for k in range(2)),
               apply=partial(_per_crank, field="crank_phase_error_rad"), relative_to_last_crank=True),
        # the eccentrics off the journal axis of one crank, turning with it: the cranks pull the discs apart once per
        # crank turn, TE at z_b (measured 5 µm: 13.9″ RV-40E, 6.7″ RV-160N; nothing at 2·z_b). The same runout on
        # every crank moves the discs without a fight and shows at no order (mean only), and to first order only the
        # cranks' runouts relative to each other act, through one resultant vector: one crank's runout (x/y in the
        # crank's frame) stands for any pattern. Bound 10 µm (28″ at z_b on an RV-40E, beyond any working unit)
        # a crank seat that moves in the carrier, or supports stiffer one way than the other, also shifts the cranks
        # once per crank turn: a healthy unit of that form is fitted with a runout of a tenth of a µm at an evidence
        # far above the ensemble's (which has isotropic, fixed seats)
        Effect("crank_runout", "runout of crank 0's eccentrics relative to its journal axis (x/y in the crank's frame), "
               "turning with the crank: it stands for the cranks' runouts relative to each other",
               polar(10 * um, 2 * um), apply=_crank_runout, polar=True,
               unjudged_by="crank seats that move in the carrier and anisotropic crank supports"),
        # two-sided: a negative deviation takes clearance away (towards preload), a positive one adds it.
        # A pin radius error +δ of all pins is the equidistant deviation −δ: the pin–profile gap depends
        # on the generating pin radius minus the pin radius only (features agree to 0.001″, test), so no run can tell
        # them apart and this one effect stands for both (as pin_ring_runout does for two runouts)
        Effect("disc_modification_deviation", "deviation of the moved (Δr_p) and equidistant (Δr_rp) modification; "
               "an equidistant deviation −δ is also a pin radius error +δ of all pins (the same pin–profile gap)",
               (Param("moved_m", "m", -10 * um, 10 * um, 4 * um), Param("equidistant_m", "m", -10 * um, 10 * um, 4 * um)),
               apply=_modification, two_sided=True, corners=True),
        Effect("cycloid_pitch_error", "cumulative pitch error of the discs, once-per-disc harmonic (cos/sin)",
               polar(15 * um, 5 * um, ("cos_m", "sin_m")), apply=_pitch_harmonic, polar=True),
        Effect("carrier_hole_position", "crank-hole distance error of both carrier plates",
               (Param("hole_distance_error_m", "m", -20 * um, 20 * um, 6 * um),), apply=_carrier_holes),
        # each run at its recorded temperature: the pin circle grows against the discs by
        # Δα·r_b·(T_run − 20 °C); typical Δα: an aluminium-alloy housing around steel (11.5e-6/K); the
        # lower bound covers iron housings and discs running warmer than the housing
        Effect("thermal_expansion", "housing-to-steel thermal expansion mismatch Δα: at each run's recorded "
               f"temperature T the pin circle grows against the discs by Δα·r_b·(T − {REFERENCE_TEMPERATURE_C:g} °C)",
               (Param("alpha_mismatch_per_K", "1/K", -5e-6, 25e-6, THERMAL_ALPHA_MISMATCH_PER_K),), apply=_thermal,
               per_run=True, run_fields=("temperature_C",), two_sided=True),
        Effect("input_stage_runout", "sun (input shaft) runout, x/y components",
               polar(20 * um, 5 * um), apply=partial(_runout, field="sun_runout_m"), polar=True),
        # a radial sun runout turns no output (its projections on the planets' lines of action sum to zero); an angle
        # error of the sun against the input as driven and read does: TE a/i at order i exactly (measured: 0.3 mrad →
        # 0.511″ at 121 on the RV-40E, 0.764″ at 81 on the RV-160N). Bound 3 mrad: a 30 µm parallel offset to the
        # motor at a 10 mm drive radius, or an input encoder 30 µm off-centre at a 10 mm read radius
        Effect("input_shaft_eccentricity", "input shaft off-centre to the motor or input encoder: the sun's angle "
               "error a·cos(θ_in − ψ) against the input angle θ_in, as (a cos ψ, a sin ψ)",
               polar(3e-3, 3e-4, ("cos_rad", "sin_rad"), "rad"),
               apply=partial(_runout, field="input_shaft_angle_error_rad",
                             phase_field="input_shaft_angle_error_phase_rad"), polar=True,
               separating_runs="the input angle read at the reducer's input shaft as well as at the motor (a coupling "
                               "offset turns the shaft against the motor) or the motor re-centred"),
        Effect("pin_contact_friction", "Coulomb friction at the pin contacts as a torque opposing the motion "
               "(fraction of rated torque)", (Param("friction_torque_fraction", "1", 0.0, 0.08, 0.02),),
               kind="conditions", conditions=_friction_conditions, same_as=("output_friction", (0, None))),
        # bench friction is mostly not at the pins: seals and preloaded main bearings give a Coulomb torque, the
        # loaded bearings and meshes a part proportional to the torque (seen on a foreign bench: a friction loop
        # no pin-friction candidate had the form of; the nearest predicted the withheld runs 123 % worse)
        Effect("output_friction", "friction torque referred to the output: Coulomb part (fraction of rated torque) "
               "plus a part proportional to the transmitted torque",
               (Param("coulomb_torque_fraction", "1", 0.0, 0.08, 0.01), Param("load_proportional_share", "1", 0.0, 0.1, 0.015)),
               kind="conditions", conditions=_output_friction_conditions),
        # a torsional compliance between the reducer's output and the encoder or load (a carrier flange, a
        # coupling, the output encoder's shaft): it twists with the output torque but carries no TE ripple, which
        # a uniform stiffness scale would scale too; linear, and stiffening with load
        Effect("output_series_compliance", "torsional compliance in series with the output: twist at rated torque of "
               "a linear part and of a part stiffening with load (∝ T^(2/3))",
               (Param("linear_twist_rad", "rad", 0.0, 600 * ARCSEC, 20 * ARCSEC),
                Param("stiffening_twist_rad", "rad", 0.0, 600 * ARCSEC, 20 * ARCSEC)),
               kind="measurement", series=_series_twist,
               separating_runs="the output angle read at the reducer's flange as well as past the coupling (the series "
                               "compliance lies between them), or TE runs at three or more loads (a series compliance "
                               "twists with the torque but adds no pin-mesh TE ripple; a softer bearing or contact "
                               "changes the ripple with the load)"),
        Effect("output_encoder_eccentricity", "eccentrically mounted output encoder (measurement artefact): "
               "angle error a·cos θ + b·sin θ", polar(250 * ARCSEC, 5 * ARCSEC, ("a_rad", "b_rad"), "rad"),
               kind="measurement", measure=_encoder_eccentricity, polar=True,
               separating_runs="the encoder re-mounted turned on the flange (its eccentricity turns with it, an "
                               "error of the output's parts does not), or a second read head 180° apart (an "
                               "eccentricity cancels in the mean of two opposite heads, a true angle error does "
                               "not)"),
        Effect("disc_carrier_flexibility", "disc and carrier flexibility (rigid → FE-reduced flexible model; "
               "1 = the flexible model)", (Param("flexible_share", "1", 0.0, 2.0, 1.0),),
               kind="fidelity", options=ModelOptions.flexible_discs()),
    )


EFFECTS: dict[str, Effect] = {e.name: e for e in _builtin()}
"""The registered effects by name (the default candidate set of a diagnosis)."""


def register(effect: Effect, *, replace: bool = False) -> Effect:
    """Add ``effect`` to :data:`EFFECTS` (``replace`` to overwrite a name)."""
    if effect.name in EFFECTS and not replace:
        raise ValueError(f"effect {effect.name!r} is already registered")
    EFFECTS[effect.name] = effect
    return effect


def available_effects(names: tuple[str, ...] | None = None) -> tuple[tuple[Effect, ...], dict[str, str]]:
    """The registered effects that the model can evaluate now, and the reasons of the others."""
    ok, why = [], {}
    for name, eff in EFFECTS.items():
        if names is not None and name not in names:
            continue
        avail, reason = eff.available()
        if avail:
            ok.append(eff)
        else:
            why[name] = reason
    return tuple(ok), why

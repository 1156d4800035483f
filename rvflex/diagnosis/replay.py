"""Run-condition replay: the model run under a plan (:func:`evaluate`) with candidate effects switched on,
and what the bench records of it (:func:`recorded`). The speed is recorded but the replay is quasi-static
(the bench speeds of TE tests, ~15 rpm at the output, are far below the first resonance)."""

from __future__ import annotations

import dataclasses as dc
import math
from dataclasses import dataclass

import numpy as np

from rvflex.diagnosis.plan import PlanRun
from rvflex.diagnosis.settings import DiagnosisSettings
from rvflex.options import ModelOptions
from rvflex.spec import ErrorSpec, ReducerSpec

__all__ = ["FIDELITY_TIME_FACTOR", "PERIODIC_ERRORS", "Evaluation", "EvaluationFailed", "ModelRun", "Response",
           "combine", "evaluate", "joined", "one_period", "plan_evaluation", "recorded", "run_model"]


@dataclass(frozen=True, eq=False)
class Response:
    """A model (or measured) response per plan run: TE on the position grid (rad, uniform
    positions 2πj/N, forward coordinate) or a torque path with its output angles (N·m, rad)."""

    te: tuple
    torque: tuple
    theta: tuple


class EvaluationFailed(RuntimeError):
    """A model evaluation did not converge (a failed candidate evaluation, not a crash)."""


FIDELITY_TIME_FACTOR = 4.0  # a flexible run may take this many times the rigid budget (FE reduction on first use)


def _run_model(variants: list[tuple[ReducerSpec, ErrorSpec]], plan: tuple[PlanRun, ...],
               settings: DiagnosisSettings, options: ModelOptions, law, parts: tuple[int, ...] | None = None,
               mesh_modification=None) -> Response:
    """Run every plan run (or those of ``parts``, the others None) with its own (spec, errors) variant
    (``variants[r]`` for run r), the model built with ``options`` (``law``, a ContactLaw or a callable
    spec → ContactLaw, replaces its contact law when given; ``mesh_modification``, the profile modification
    its FE discs are meshed with, ``build_reducer``'s ``disc_mesh_modification``)."""
    import time

    from rvflex.model import build_reducer
    from rvflex.solve import SolveError, quasi_static, torque_stepping

    n = settings.positions_per_rev
    te, tq, th = [], [], []
    limit = settings.eval_timeout_s * (FIDELITY_TIME_FACTOR if options != ModelOptions.rigid() else 1.0)
    t_end = [0.0]

    def budget(done: int, total: int) -> None:
        if time.perf_counter() > t_end[0]:
            raise EvaluationFailed(f"over the {limit:g} s budget of a run after {done}/{total} steps")

    # one build per distinct variant, shared by its runs: every run sets its own state (kinematic guess, load
    # continuation), so sharing changes its results only within the solver's tolerance (measured on foreign H04's
    # four runs: at most 1.4e-8″ with a 3 µm clearance, 3.5e-10″ flexible). A rigid build was a fifth of a rigid
    # run until the disc's checks were kept per curve (now 2 ms); an elastic one loads its reductions (~0.4 s)
    models = {}
    # a run under the same model and conditions as an earlier one (a map's runs at other speeds, or at other
    # temperatures where no effect reads the temperature: the model is quasi-static and temperature-free) is
    # that run's response
    solved = {}
    for r, (p, (spec, errors)) in enumerate(zip(plan, variants)):
        if parts is not None and r not in parts:
            te.append(None)
            tq.append(None)
            th.append(None)
            continue
        t_end[0] = time.perf_counter() + limit
        key = (repr(spec), repr(errors))  # an effect applied run by run gives equal, not identical, variants
        same = (key, p.kind, p.direction, p.load_Nm, p.torque_path_Nm, p.torque_eff_Nm)
        if same in solved:
            q = solved[same]
            te.append(te[q])
            tq.append(tq[q])
            th.append(th[q])
            continue
        solved[same] = r
        try:
            if key not in models:
                run_law = law(spec) if callable(law) else law
                models[key] = build_reducer(spec, errors,
                                            options if run_law is None else dc.replace(options, contact_law=run_law),
                                            disc_mesh_modification=mesh_modification)
            model = models[key]
            if p.kind == "te":
                phase = one_period(n, spec, errors, options) if settings.one_period else None
                if phase is None:
                    theta = p.direction * np.linspace(0.0, 2 * math.pi * model.ratio, n, endpoint=False)
                else:  # the distinct positions of the grid within one pin pitch of the output, in order
                    m = int(phase.max()) + 1
                    theta = p.direction * 2 * math.pi * model.ratio * np.arange(m) / (m * spec.cycloid.pin_count)
                res = quasi_static(model, theta, p.load_Nm, progress=budget, fail_fast=True, skip_unsolved=True,
                                   contact_states=False)
                grid = np.empty(n)
                grid[(p.direction * np.arange(n)) % n] = res.te_rad if phase is None else res.te_rad[phase]
                bad = np.isnan(grid)
                if bad.any():  # positions the solver left out (isolated): periodic interpolation
                    k = np.arange(n)
                    grid[bad] = np.interp(k[bad], k[~bad], grid[~bad], period=n)
                te.append(grid)
                tq.append(None)
                th.append(None)
            else:
                path = np.asarray(p.torque_eff_Nm or p.torque_path_Nm)
                te.append(None)
                tq.append(np.asarray(p.torque_path_Nm))
                steps = [0]

                def count(done: int, total: int) -> None:
                    steps[0] = done

                th.append(_over_skipped(path, torque_stepping(model, path, progress=count, skip_unsolved=True,
                                                              before_solve=lambda: budget(steps[0], len(path))
                                                              ).theta_out))
        except EvaluationFailed as err:
            raise EvaluationFailed(f"{p.label}: {err}") from None
        except (SolveError, RuntimeError, ValueError, ArithmeticError) as err:
            raise EvaluationFailed(f"{p.label}: {type(err).__name__}: {str(err)[:300]}") from None
    return Response(tuple(te), tuple(tq), tuple(th))


PERIODIC_ERRORS = frozenset({
    # what rides on the carrier, the cranks, their planet gears and the discs (back where it was after one crank
    # revolution), and what is the same at every pin or bearing
    "crank_support_clearance_m", "eccentric_bearing_clearance_m", "main_bearing_clearance_m",
    "pin_radius_error_m", "pin_circle_radius_error_m", "sun_pitch_radius_error_m",
    "crank_eccentricity_error_m", "crank_phase_error_rad", "crank_runout_m",
    "planet_base_eccentricity_m", "planet_runout_m",
    "planet_pitch_radius_error_m", "planet_base_pitch_error_m",
    "input_carrier_hole_distance_error_m", "output_carrier_hole_distance_error_m",
    "disc_pitch_error_m", "disc_profile_error_m", "disc_bore_distance_error_m", "disc_moved_error_m",
    "disc_equidistant_error_m",
})
"""ErrorSpec fields that keep the model periodic in one pin pitch of the output (:func:`one_period`; a ``*_phase_rad``
field goes with its magnitude's). The others
(the pins' individual positions and radii, the pin ring's runout, the sun's eccentricity and runout) turn with the
housing or the input, not with the crank, and break it; so does the model's carrier runout (measured: 0.06″ between
the TE and itself one pitch on for 5 µm, against ≤ 7e-8″ for each field here; the carrier-bore eccentricities, not
measured, are left out too)."""


def one_period(n: int, spec: ReducerSpec, errors: ErrorSpec, options: ModelOptions) -> np.ndarray | None:
    """Where each of the ``n`` grid positions of an output revolution lies within one pin pitch, for a model
    that repeats itself there; None for one that does not.

    One crank revolution relative to the carrier turns the output by one pin pitch 2π/z_b (the discs do not turn
    on the carrier), and the carrier, the cranks, their planet gears and the discs are back where they were while
    the pin ring, whose pins are alike, has turned by one pin. A model whose errors all ride on those parts or are
    the same at every pin (:data:`PERIODIC_ERRORS`) and whose housing is rigid therefore has the same state, and
    TE, one pin pitch on: its TE at the grid's positions is that at the m = n / gcd(n, z_b) distinct positions
    k·2π/(m·z_b) of one pitch, solved in order (in the run's direction, as the full revolution would pass them).

    Returns
    -------
    numpy.ndarray of int or None
        Per grid position j (output angle 2πj/n) the index k of the same position within the pitch.
    """
    if options.housing != "rigid":
        return None
    for f in dc.fields(errors):
        if f.name not in PERIODIC_ERRORS and not f.name.endswith("_phase_rad") and np.any(getattr(errors, f.name)):
            return None
    z_b = spec.cycloid.pin_count
    g = math.gcd(n, z_b)
    return (np.arange(n) * z_b % n) // g


def _over_skipped(torque: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """``theta`` with the steps the solver left out (NaN; isolated, never the first or the last, see
    :func:`rvflex.solve.torque_stepping`) interpolated in torque between their neighbours."""
    a = np.array(theta, float)
    for j in np.nonzero(np.isnan(a))[0]:
        span = torque[j + 1] - torque[j - 1]
        a[j] = a[j - 1] + ((torque[j] - torque[j - 1]) / span if span else 0.5) * (a[j + 1] - a[j - 1])
    return a


@dataclass(frozen=True, eq=False)
class ModelRun:
    """One model run of an evaluation: the model built with ``options`` (and ``alt_law`` for the
    diagnosing model's contact law when given) with the evaluation's model and condition effects
    ``active`` ((Effect, x) pairs, in the evaluation's order) applied, run under the plan.
    Evaluations that share a run (the elastic discs' model, as a contact-law form's reference and
    as the disc-flexibility share's alternative) need it once."""

    active: tuple
    options: ModelOptions
    alt_law: object = None

    @property
    def plain(self) -> bool:
        """True for the diagnosing model itself (rigid, its own law): the run is then the
        evaluation of ``active`` alone."""
        return self.options == ModelOptions.rigid() and self.alt_law is None

    def key(self) -> tuple:
        """What identifies the run (effects and values, options, law)."""
        return (tuple((e.name, tuple(np.round(np.asarray(x, float), 15))) for e, x in self.active),
                repr(self.options), getattr(self.alt_law, "__qualname__", None))


@dataclass(frozen=True, eq=False)
class Evaluation:
    """An evaluation (:func:`evaluate`) as the model runs it needs and how they combine:
    ``runs[0]`` is the model with the effects applied; each blend ``(w, alt, ref)`` adds ``w``
    times the difference of run ``alt`` from run ``ref`` (indices into ``runs``, each run once);
    ``measurement`` transforms what the bench records ((Effect, x) pairs)."""

    runs: tuple
    blends: tuple
    measurement: tuple


def plan_evaluation(active: tuple = (), options: ModelOptions | None = None) -> Evaluation:
    """The model runs an evaluation of ``active`` on the model of ``options`` (None: rigid)
    needs, and how they combine (see :func:`evaluate`)."""
    options = options or ModelOptions.rigid()
    applied = tuple((e, np.asarray(x, float)) for e, x in active if e.kind in ("model", "conditions"))
    runs = [ModelRun(applied, options)]
    index = {runs[0].key(): 0}

    def at(run: ModelRun) -> int:  # its index, each run once
        k = run.key()
        if k not in index:
            index[k] = len(runs)
            runs.append(run)
        return index[k]

    blends = []
    for eff, x in active:  # another fidelity or contact-law form, blended in by its share w
        w = float(np.asarray(x, float)[0]) if eff.kind == "fidelity" else 0.0
        if w == 0.0:
            continue
        opts = eff.options or options
        alt = at(ModelRun(applied, opts, eff.alt_law))
        # a contact-law form on a model of other options: the difference the law makes to that model
        ref = 0 if eff.alt_law is None or opts == options else at(ModelRun(applied, opts))
        blends.append((w, alt, ref))
    meas = tuple((e, np.asarray(x, float)) for e, x in active if e.kind == "measurement")
    return Evaluation(tuple(runs), tuple(blends), meas)


def run_model(spec: ReducerSpec, errors: ErrorSpec, plan: tuple[PlanRun, ...], settings: DiagnosisSettings,
              run: ModelRun, *, law=None, parts: tuple[int, ...] | None = None, mesh_as_spec: bool = False) -> Response:
    """The response of one model run (``law``: the diagnosing model's contact law, a ContactLaw or a
    callable spec → ContactLaw; None: the model's), before the measurement effects; with ``parts``
    (indices into ``plan``) of those plan runs only, the others None (:func:`joined` puts a run's
    parts together). ``mesh_as_spec``: the FE discs are meshed with ``spec``'s profile modification whatever
    the effects do to it (:func:`rvflex.model.disc_mesh_spec`; ``build_reducer``'s ``disc_mesh_modification``
    says why): the diagnosis's model runs; a bench's truth is meshed exactly.

    Raises
    ------
    EvaluationFailed
        The model did not converge (or an effect value broke a spec rule) for some run.
    """
    from rvflex.spec import SpecError

    if settings.positions_per_rev is None:
        settings = settings.for_spec(spec)
    variants = [(spec, errors)] * len(plan)
    plan_c = plan
    try:
        for eff, x in run.active:
            if eff.kind == "model":
                for fld in eff.run_fields:
                    bad = [p.label for p in plan if not math.isfinite(float(getattr(p, fld, math.nan)))]
                    if bad:
                        raise EvaluationFailed(f"effect {eff.name} needs '{fld}' of run {bad[0]}")
                variants = [eff.apply_to(s, e, x, p) for (s, e), p in zip(variants, plan)]
            elif eff.kind == "conditions":
                plan_c = tuple(eff.conditions(p, x, variants[0][0]) for p in plan_c)
    except SpecError as err:
        raise EvaluationFailed(f"effect value breaks a spec rule: {err}") from None
    return _run_model(variants, tuple(plan_c), settings, run.options, run.alt_law or law, parts,
                      spec.cycloid.modification if mesh_as_spec else None)


def joined(responses: list[Response]) -> Response:
    """One run's response from the responses of its parts (:func:`run_model` with ``parts``): each
    plan run's entry from the part that ran it."""
    def pick(field: str) -> tuple:
        cols = [getattr(r, field) for r in responses]
        return tuple(next((c[i] for c in cols if c[i] is not None), None) for i in range(len(cols[0])))

    return Response(pick("te"), pick("torque"), pick("theta"))


def combine(ev: Evaluation, responses: list[Response], plan: tuple[PlanRun, ...], settings: DiagnosisSettings,
            spec: ReducerSpec) -> Response:
    """The evaluation ``ev`` from the responses of its runs (``responses[i]`` of ``ev.runs[i]``), as the
    bench records it under ``plan`` (the bench's torques, before a condition effect changes what the
    mesh sees)."""
    if settings.positions_per_rev is None:
        settings = settings.for_spec(spec)
    resp = responses[0]
    for w, a, r in ev.blends:
        alt, ref = responses[a], responses[r]
        resp = Response(tuple(None if x is None else x + w * (b - x0) for x, x0, b in zip(resp.te, ref.te, alt.te)),
                        resp.torque,
                        tuple(None if x is None else x + w * (b - x0)
                              for x, x0, b in zip(resp.theta, ref.theta, alt.theta)))
    return recorded(resp, plan, settings, list(ev.measurement), spec)


def evaluate(spec: ReducerSpec, errors: ErrorSpec, plan: tuple[PlanRun, ...], settings: DiagnosisSettings,
             active: tuple = (), *, law=None, options: ModelOptions | None = None) -> Response:
    """Run the model under ``plan`` with the effects ``active`` ((Effect, x) pairs) switched on.

    Model effects change the spec/ErrorSpec the model is built with (``per_run`` ones per run,
    e.g. thermal expansion at each run's ``temperature_C``); condition effects change the plan;
    measurement effects transform the recorded TE; a fidelity effect blends in the model with its
    own ``options`` by its share, or with ``alt_law`` the difference that contact-law form makes to
    the model of its ``options`` (the diagnosing model's when None). The model runs this takes are
    :func:`plan_evaluation`'s, each made once (:func:`run_model`), combined by :func:`combine`.
    ``law``: a ContactLaw, or a callable spec → ContactLaw (per run variant); None: the model's.
    ``options``: the model's :class:`~rvflex.options.ModelOptions` (None: rigid).

    Raises
    ------
    EvaluationFailed
        From :func:`run_model`, for the first of the runs that fails.
    """
    ev = plan_evaluation(active, options)
    return combine(ev, [run_model(spec, errors, plan, settings, r, law=law) for r in ev.runs], plan, settings, spec)


def recorded(resp: Response, plan: tuple[PlanRun, ...], settings: DiagnosisSettings, meas, spec: ReducerSpec) -> Response:
    """``resp`` as the bench records it with the measurement effects ``meas`` ((Effect, x) pairs): each TE
    through ``measure``; the twist of each ``series`` compliance added at the output torque the bench applies
    (a TE run at load L in direction d lags by it, −d·series(L), as the model's own wind-up does; a torque
    cycle at each applied torque)."""
    if not meas:
        return resp
    pos = 2 * np.pi * np.arange(settings.positions_per_rev) / settings.positions_per_rev
    te, theta = [], []
    for p, a, t, b in zip(plan, resp.te, resp.torque, resp.theta):
        for eff, x in meas:
            if a is not None and eff.measure is not None:
                a = eff.measure(pos, a, x)
            if eff.series is not None:
                if a is not None:
                    a = a - p.direction * eff.series(p.load_Nm, x, spec)
                if b is not None:
                    b = b + eff.series(np.asarray(t, float), x, spec)
        te.append(a)
        theta.append(b)
    return dc.replace(resp, te=tuple(te), theta=tuple(theta))

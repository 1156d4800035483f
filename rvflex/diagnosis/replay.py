"""Run-condition replay and the feature vector the diagnosis compares.

Every bench run becomes a :class:`PlanRun` (direction, load, torque cycle) that the model is
run under (:func:`evaluate`); the speed is recorded but the replay is quasi-static (the
bench speeds of TE tests, ~15 rpm at the output, are far below the first resonance).
Measured runs and model runs are reduced to the same :class:`Features`:

- a TE run: its mean (the wind-up) and its Fourier coefficients a_k, b_k of orders 1 … K per
  output revolution (arcsec), TE(p) = mean + Σ a_k cos kp + b_k sin kp, p = θ_in/i the
  position in output revolutions (rad). Measured coefficients come from a least-squares fit
  to the samples (non-uniform sampling and speed ripple are harmless), model coefficients
  from the FFT of the uniform grid.
- a hysteresis run: the output angle (arcsec) on the descending and ascending branch at
  fixed fractions of the torque amplitude.

The unknown encoder origin enters as a position shift δ common to all TE runs
(:func:`shift_measured`), the unknown constant offset as a nuisance (one for all TE runs,
one per hysteresis run): both are estimated by the fit, never assumed.
"""

from __future__ import annotations

import dataclasses as dc
import math
from dataclasses import dataclass

import numpy as np

from rvflex.choices import RunKind
from rvflex.geometry.formulas import ARCSEC_PER_RAD
from rvflex.options import ModelOptions
from rvflex.spec import ErrorSpec, ReducerSpec

__all__ = [
    "BRANCH_FRACTIONS",
    "HYST_FRACTIONS",
    "DiagnosisSettings",
    "EvaluationFailed",
    "Layout",
    "PlanRun",
    "Response",
    "alias_free_positions",
    "aliasing_problem",
    "branch_angles",
    "evaluate",
    "features",
    "measured_features",
    "measured_runs",
    "orders_resolved",
    "plan_from_dataset",
    "recorded",
    "shift_measured",
]

HYST_FRACTIONS = np.array([0.02, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.97])
BRANCH_FRACTIONS = np.concatenate([-HYST_FRACTIONS[::-1], HYST_FRACTIONS])
"""The torques (shares of the amplitude, increasing) at which each torque-cycle branch is read."""


@dataclass(frozen=True)
class DiagnosisSettings:
    """Settings of a diagnosis (and of the model runs it makes).

    Parameters
    ----------
    positions_per_rev : int or None
        Model positions per output revolution (≥ 2·max_order + 2). None (default): the smallest
        grid that keeps the pin-mesh harmonics out of the analysed orders
        (:func:`alias_free_positions`, 320 for the RV-40E at 127 orders), set by :meth:`for_spec`.
    max_order : int or None
        Highest order analysed (per output revolution). None (default): every order the bench's TE runs
        resolve (:func:`orders_resolved`: their samples per revolution / 4, at most MAX_ORDER_CAP; 255 for
        1024 samples), set by :meth:`for_dataset`; DEFAULT_MAX_ORDER where no dataset is given.
    hysteresis_steps : int
        Equal torque steps of the replayed torque cycle (plus the fine ±0.5…4 % points).
    workers : int
        Process-pool size for the sensitivity and refinement runs (1: serial).
    refine_top : int
        Candidates refined with model-in-the-loop (Broyden) iterations.
    refine_iterations : int
        Most model evaluations per refined candidate; after the second, a candidate stops once
        an evaluation lowers its residual by less than ``refine_min_gain`` (or its step converges).
    refine_min_gain : float
        Relative residual decrease an evaluation must bring to go on refining (fraction).
    pair_top : int or None
        None: every pair of effects is fitted; an int: only pairs with one of the best
        ``pair_top`` single effects.
    bic_threshold : float
        Minimum BIC improvement over "no effect" for an effect to count (dimensionless; 10: very strong).
    min_shrink_pct : float
        Minimum share of the gap (weighted rms) an accepted effect removes (%).
    min_withheld_pct : float
        Minimum improvement of the withheld runs' prediction for acceptance (%).
    order_floor_arcsec : float
        Model-form floor of an order coefficient (arcsec): residuals below it are not signal.
    order_floor_rel : float
        Model-form floor of an order relative to its amplitude (fraction; the larger of measured and nominal):
        another program's contact law and stiffnesses move an order's amplitude by tens of per cent.
    mesh_order_floor_rel : float
        The same (fraction) for the pin-mesh orders (multiples of z_b) alone, where the contact-law form and the
        disc flexibility put several arcseconds of TE.
    eval_timeout_s : float
        Wall-time budget of one run of a model evaluation before the evaluation counts as failed (s).
    windup_floor_arcsec, windup_floor_rel : float
        Floor of wind-up and hysteresis-angle residuals: absolute (arcsec) plus a share of
        the modelled value (model-form mismatch of the contact stiffness).
    """

    positions_per_rev: int | None = None
    max_order: int | None = None
    hysteresis_steps: int = 40
    workers: int = 2
    refine_top: int = 3
    refine_iterations: int = 5
    refine_min_gain: float = 0.02
    pair_top: int | None = None
    bic_threshold: float = 10.0
    min_shrink_pct: float = 25.0
    min_withheld_pct: float = 10.0
    eval_timeout_s: float = 60.0  # a run takes ~1 s at 448 positions; a loose unit's bisections many more
    order_floor_arcsec: float = 0.03
    order_floor_rel: float = 0.0
    mesh_order_floor_rel: float = 0.0
    windup_floor_arcsec: float = 0.5
    windup_floor_rel: float = 0.02

    def __post_init__(self) -> None:
        k = DEFAULT_MAX_ORDER if self.max_order is None else self.max_order
        if self.positions_per_rev is not None and self.positions_per_rev < 2 * k + 2:
            raise ValueError(f"positions_per_rev = {self.positions_per_rev}: needs ≥ 2·max_order + 2 "
                             f"= {2 * k + 2}")
        if k < 1 or self.hysteresis_steps < 8 or self.workers < 1:
            raise ValueError("max_order ≥ 1, hysteresis_steps ≥ 8 and workers ≥ 1 are required")

    def for_dataset(self, dataset) -> DiagnosisSettings:
        """These settings for a bench dataset.

        Parameters
        ----------
        dataset : BenchDataset
            The bench: the analysed orders come from its sampling when ``max_order`` is None
            (:func:`orders_resolved`), then :meth:`for_spec` of its reducer.

        Returns
        -------
        DiagnosisSettings
            The settings with ``max_order`` and ``positions_per_rev`` set.
        """
        s = self if self.max_order is not None else dc.replace(self, max_order=orders_resolved(dataset))
        return s.for_spec(dataset.reducer)

    def for_spec(self, spec) -> DiagnosisSettings:
        """These settings for a reducer.

        Parameters
        ----------
        spec : ReducerSpec
            The reducer: the position grid is chosen by :func:`alias_free_positions` when None,
            else checked by :func:`aliasing_problem` (ValueError naming the folded harmonic); a
            ``max_order`` of None is DEFAULT_MAX_ORDER.

        Returns
        -------
        DiagnosisSettings
            The settings with ``max_order`` and ``positions_per_rev`` set.
        """
        if self.max_order is None:
            return dc.replace(self, max_order=DEFAULT_MAX_ORDER).for_spec(spec)
        z_b = spec.cycloid.pin_count
        if self.positions_per_rev is None:
            return dc.replace(self, positions_per_rev=alias_free_positions(z_b, self.max_order))
        why = aliasing_problem(self.positions_per_rev, z_b, self.max_order)
        if why:
            raise ValueError(f"positions_per_rev = {self.positions_per_rev}: {why}; use "
                             f"{alias_free_positions(z_b, self.max_order)} (or None to choose it)")
        return self


DEFAULT_MAX_ORDER = 127  # analysed orders where no bench data set the sampling
MAX_ORDER_CAP = 255  # the model grid grows with the orders (576 positions for the RV-40E at 255): capped for cost


def orders_resolved(dataset) -> int:
    """Highest order every TE run of ``dataset`` resolves: its samples per analysed revolution divided
    by MIN_SAMPLES_PER_ORDER (two coefficients per order, twice Nyquist), at most MAX_ORDER_CAP;
    DEFAULT_MAX_ORDER when the dataset has no TE run. 1024 samples per revolution resolve 255 orders
    (a 3rd-harmonic pin pattern's TE sits at order 6·z_c = 234 on the RV-40E)."""
    from rvflex.diagnosis.measured import MIN_SAMPLES_PER_ORDER

    per_rev = [r.window.samples // r.window.revolutions for r in dataset.runs
               if r.kind == "te" and r.window is not None]
    if not per_rev:
        return DEFAULT_MAX_ORDER
    return int(min(MAX_ORDER_CAP, min(per_rev) // MIN_SAMPLES_PER_ORDER))


# The model's TE is sampled at N positions per revolution, so its order k > N/2 folds to |k − jN|. The
# pin-mesh harmonics m·z_b are large (flexible RV-40E discs at 412 N·m, measured at 1024 positions:
# 5.7″ at 2·z_b, 0.93″ at 4·z_b, 0.22″ at 6·z_b, 0.11″ at 8·z_b): at 256 positions 4·z_b = 160 folded to
# order 96 and 6·z_b to 16, ~1″ of model-only signature on orders no bench shows. Folding onto a mesh
# order is no better: at 320 positions 6·z_b = 240 fell on 2·z_b = 80 and 7·z_b on z_b, and the
# generator's own model (power-law contact, flexible discs) left a weighted RSS of 584 on a control
# bench, 95 % of it on the mesh orders, against 21 at 512 positions; the calibration pushed the
# contact stiffness to its bound to absorb it.
ALIAS_HARMONICS = 8  # harmonics m·z_b, m ≤ this, must not fold into the analysed orders 0…max_order


def aliasing_problem(n: int, pin_count: int, max_order: int) -> str | None:
    """Why an N-position model grid folds a pin-mesh harmonic into the analysed orders (None: it
    does not). Harmonics m·z_b with m ≤ ALIAS_HARMONICS must be resolved (below N/2) or fold beyond
    ``max_order``."""
    for m in range(1, ALIAS_HARMONICS + 1):
        k = m * pin_count
        folded = abs(k - n * round(k / n))
        if folded == k or folded > max_order:
            continue
        return f"the pin-mesh harmonic {m}·z_b = {k} folds to order {folded} of the analysed 0…{max_order}"
    return None


def alias_free_positions(pin_count: int, max_order: int) -> int:
    """The smallest model grid (positions per revolution, ≥ 2·max_order + 2) that
    :func:`aliasing_problem` accepts."""
    n = 2 * max_order + 2
    while aliasing_problem(n, pin_count, max_order):
        n += 1
    return n


@dataclass(frozen=True)
class PlanRun:
    """What the model is run under for one bench run (SI).

    ``torque_path_Nm``: the replayed torque cycle (hysteresis); ``torque_eff_Nm``: the torque
    the model actually sees when an effect changes it (friction), else empty;
    ``temperature_C``: the run's recorded temperature (°C), NaN when the bench did not give it
    (the model itself is temperature-free; per-run effects such as thermal expansion use it).
    """

    kind: RunKind
    label: str
    direction: int = 1
    load_Nm: float = 0.0
    torque_max_Nm: float = 0.0
    torque_path_Nm: tuple[float, ...] = ()
    torque_eff_Nm: tuple[float, ...] = ()
    temperature_C: float = math.nan


@dataclass(frozen=True, eq=False)
class Response:
    """A model (or measured) response per plan run: TE on the position grid (rad, uniform
    positions 2πj/N, forward coordinate) or a torque path with its output angles (N·m, rad)."""

    te: tuple
    torque: tuple
    theta: tuple


@dataclass(frozen=True, eq=False)
class Layout:
    """Where each run's features sit in the feature vector.

    For TE run r: ``dc[r]`` the mean, ``cos[r]``/``sin[r]`` slices of a_1…a_K, b_1…b_K;
    for hysteresis run r: ``hyst[r]`` a slice of 4·len(HYST_FRACTIONS) angles.
    """

    n: int
    dc: dict
    cos: dict
    sin: dict
    hyst: dict
    max_order: int

    @property
    def te_runs(self) -> list[int]:
        return sorted(self.dc)

    def run_rows(self, r: int) -> np.ndarray:
        """Feature indices of run ``r``."""
        if r in self.dc:
            return np.r_[self.dc[r], np.arange(self.cos[r].start, self.cos[r].stop),
                         np.arange(self.sin[r].start, self.sin[r].stop)]
        return np.arange(self.hyst[r].start, self.hyst[r].stop)


class EvaluationFailed(RuntimeError):
    """A model evaluation did not converge (a failed candidate evaluation, not a crash)."""


def plan_from_dataset(dataset, settings: DiagnosisSettings) -> tuple[PlanRun, ...]:
    """One :class:`PlanRun` per bench run (same direction, load, torque amplitude)."""
    from rvflex.solve import hysteresis_cycle

    out = []
    for r in dataset.runs:
        temp = float(r.temperature_C)
        if r.kind == "te":
            out.append(PlanRun("te", r.label, 1 if r.direction == "forward" else -1, float(r.load_Nm),
                               temperature_C=temp))
        else:
            path = hysteresis_cycle(r.torque_max_Nm, settings.hysteresis_steps)
            out.append(PlanRun("hysteresis", r.label, torque_max_Nm=float(r.torque_max_Nm),
                               torque_path_Nm=tuple(float(t) for t in path), temperature_C=temp))
    return tuple(out)


def _layout(plan: tuple[PlanRun, ...], max_order: int) -> Layout:
    i = 0
    dcs, cos, sin, hyst = {}, {}, {}, {}
    for r, p in enumerate(plan):
        if p.kind == "te":
            dcs[r] = i
            cos[r] = slice(i + 1, i + 1 + max_order)
            sin[r] = slice(i + 1 + max_order, i + 1 + 2 * max_order)
            i += 1 + 2 * max_order
        else:
            hyst[r] = slice(i, i + 4 * len(HYST_FRACTIONS))
            i += 4 * len(HYST_FRACTIONS)
    return Layout(i, dcs, cos, sin, hyst, max_order)


FIDELITY_TIME_FACTOR = 4.0  # a flexible run may take this many times the rigid budget (FE reduction on first use)


def _run_model(variants: list[tuple[ReducerSpec, ErrorSpec]], plan: tuple[PlanRun, ...],
               settings: DiagnosisSettings, options: ModelOptions, law) -> Response:
    """Run every plan run with its own (spec, errors) variant (``variants[r]`` for run r), the model
    built with ``options`` (``law``, a ContactLaw or a callable spec → ContactLaw, replaces its
    contact law when given)."""
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

    for p, (spec, errors) in zip(plan, variants):
        t_end[0] = time.perf_counter() + limit
        try:
            run_law = law(spec) if callable(law) else law
            model = build_reducer(spec, errors, options if run_law is None else dc.replace(options, contact_law=run_law))
            if p.kind == "te":
                theta = p.direction * np.linspace(0.0, 2 * math.pi * model.ratio, n, endpoint=False)
                res = quasi_static(model, theta, p.load_Nm, progress=budget, fail_fast=True, skip_unsolved=True)
                grid = np.empty(n)
                grid[(p.direction * np.arange(n)) % n] = res.te_rad
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


def _over_skipped(torque: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """``theta`` with the steps the solver left out (NaN; isolated, never the first or the last, see
    :func:`rvflex.solve.torque_stepping`) interpolated in torque between their neighbours."""
    a = np.array(theta, float)
    for j in np.nonzero(np.isnan(a))[0]:
        span = torque[j + 1] - torque[j - 1]
        a[j] = a[j - 1] + ((torque[j] - torque[j - 1]) / span if span else 0.5) * (a[j + 1] - a[j - 1])
    return a


def evaluate(spec: ReducerSpec, errors: ErrorSpec, plan: tuple[PlanRun, ...], settings: DiagnosisSettings,
             active: tuple = (), *, law=None, options: ModelOptions | None = None) -> Response:
    """Run the model under ``plan`` with the effects ``active`` ((Effect, x) pairs) switched on.

    Model effects change the spec/ErrorSpec the model is built with (``per_run`` ones per run,
    e.g. thermal expansion at each run's ``temperature_C``); condition effects change the plan;
    measurement effects transform the recorded TE; a fidelity effect blends in the model with its
    own ``options`` by its share, or with ``alt_law`` the difference that contact-law form makes to
    the model of its ``options`` (the diagnosing model's when None).
    ``law``: a ContactLaw, or a callable spec → ContactLaw (per run variant); None: the model's.
    ``options``: the model's :class:`~rvflex.options.ModelOptions` (None: rigid).

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
    blends = []
    try:
        for eff, x in active:
            x = np.asarray(x, float)
            if eff.kind == "model":
                for fld in eff.run_fields:
                    bad = [p.label for p in plan if not math.isfinite(float(getattr(p, fld, math.nan)))]
                    if bad:
                        raise EvaluationFailed(f"effect {eff.name} needs '{fld}' of run {bad[0]}")
                variants = [eff.apply_to(s, e, x, p) for (s, e), p in zip(variants, plan)]
            elif eff.kind == "conditions":
                plan_c = tuple(eff.conditions(p, x, variants[0][0]) for p in plan_c)
            elif eff.kind == "fidelity":
                blends.append((eff, float(x[0])))
    except SpecError as err:
        raise EvaluationFailed(f"effect value breaks a spec rule: {err}") from None
    options = options or ModelOptions.rigid()
    applied = plan  # the bench's torques, before a condition effect changes what the mesh sees
    plan = tuple(plan_c)
    resp = base = _run_model(variants, plan, settings, options, law)
    for eff, w in blends:  # another fidelity or contact-law form, blended in by its share w
        if w == 0.0:
            continue
        opts = eff.options or options
        alt = _run_model(variants, plan, settings, opts, eff.alt_law or law)
        # a contact-law form on a model of other options: the difference the law makes to that model
        ref = base if eff.alt_law is None or opts == options else _run_model(variants, plan, settings, opts, law)
        resp = Response(tuple(None if a is None else a + w * (b - a0) for a, a0, b in zip(resp.te, ref.te, alt.te)),
                        resp.torque,
                        tuple(None if a is None else a + w * (b - a0)
                              for a, a0, b in zip(resp.theta, ref.theta, alt.theta)))
    meas = [(eff, np.asarray(x, float)) for eff, x in active if eff.kind == "measurement"]
    return recorded(resp, applied, settings, meas, spec)


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


def branch_angles(torque: np.ndarray, theta: np.ndarray, torque_max: float) -> np.ndarray:
    """Output angle (same unit as ``theta``) on the descending (+T → −T) and then the ascending
    branch, each at the torques ±HYST_FRACTIONS·torque_max in increasing order (4·12 values).
    """
    t = np.asarray(torque, float)
    a = np.asarray(theta, float)
    k_max, k_min = int(np.argmax(t)), int(np.argmin(t))
    if k_max > k_min:  # a cycle that goes negative first: read it mirrored
        t, a = -t, -a
        k_max, k_min = int(np.argmax(t)), int(np.argmin(t))
        flip = -1.0
    else:
        flip = 1.0
    desc = (t[k_max:k_min + 1], a[k_max:k_min + 1])
    asc = (np.concatenate([t[k_min:], t[:k_max + 1]]), np.concatenate([a[k_min:], a[:k_max + 1]]))
    at = BRANCH_FRACTIONS * torque_max
    out = []
    for bt, ba in (desc, asc):
        o = np.argsort(bt, kind="stable")
        bt, ba = bt[o], ba[o]
        keep = np.r_[True, np.diff(bt) > 0]
        out.append(np.interp(at, bt[keep], ba[keep]))
    if flip < 0:  # back to the true sign: the branches swap roles
        out = [-out[1][::-1], -out[0][::-1]]
    return np.concatenate(out)


def features(resp: Response, plan: tuple[PlanRun, ...], settings: DiagnosisSettings) -> tuple[np.ndarray, Layout]:
    """Feature vector (arcsec) of a model response and its layout."""
    lay = _layout(plan, settings.max_order)
    f = np.empty(lay.n)
    K = settings.max_order
    for r, p in enumerate(plan):
        if p.kind == "te":
            te = resp.te[r] * ARCSEC_PER_RAD
            c = np.fft.rfft(te) / len(te)
            f[lay.dc[r]] = c[0].real
            f[lay.cos[r]] = 2 * c[1:K + 1].real
            f[lay.sin[r]] = -2 * c[1:K + 1].imag
        else:
            f[lay.hyst[r]] = branch_angles(resp.torque[r], resp.theta[r] * ARCSEC_PER_RAD, p.torque_max_Nm)
    return f, lay


def measured_features(dataset, plan: tuple[PlanRun, ...], settings: DiagnosisSettings) -> tuple[np.ndarray, Layout]:
    """Feature vector (arcsec) of the bench runs, before the origin shift (see :func:`measured_runs`)."""
    f, lay, _ = measured_runs(dataset, plan, settings)
    return f, lay


def measured_runs(dataset, plan: tuple[PlanRun, ...], settings: DiagnosisSettings) -> tuple[np.ndarray, Layout, dict]:
    """Feature vector (arcsec) of the bench runs, before the origin shift, its layout, and per TE
    run what was analysed (``{run: {window and fit figures}}``).

    TE runs: a checked least-squares Fourier fit (orders 0 … K, :func:`rvflex.diagnosis.measured.fit_te`)
    of TE = θ_out − θ_in/i (or the TE column) against the position p over the run's analysed
    whole revolutions (:func:`rvflex.diagnosis.measured.te_window`).

    Raises
    ------
    BenchError
        A run whose samples cannot determine the orders (coverage, samples per order, conditioning,
        a reconstruction that disagrees with the measured peak-to-peak).
    """
    from rvflex.diagnosis.measured import fit_te, te_window

    lay = _layout(plan, settings.max_order)
    f = np.empty(lay.n)
    K = settings.max_order
    ratio = dataset.reducer.nominal_ratio
    info = {}
    for r, (run, p) in enumerate(zip(dataset.runs, plan)):
        if p.kind == "te":
            pos, te = run.te_samples(ratio)
            win = run.window or te_window(pos, run.file)
            fit = fit_te(pos[win.index], te[win.index] * ARCSEC_PER_RAD, K, run.file)
            f[lay.dc[r]] = fit.mean
            f[lay.cos[r]] = fit.cos
            f[lay.sin[r]] = fit.sin
            info[r] = {"file": run.file, "form": run.form, **win.describe(), **fit.describe()}
        else:
            f[lay.hyst[r]] = branch_angles(run.torque_Nm, run.theta_out_rad * ARCSEC_PER_RAD, p.torque_max_Nm)
    return f, lay, info


def shift_measured(f: np.ndarray, lay: Layout, delta: np.ndarray) -> np.ndarray:
    """Measured features with the position origin moved by ``delta`` (rad; scalar or array of G
    shifts → (n, G)): TE_shifted(p) = TE(p + δ), so a_k' = a_k cos kδ + b_k sin kδ,
    b_k' = −a_k sin kδ + b_k cos kδ. Means and hysteresis features do not change."""
    delta = np.atleast_1d(np.asarray(delta, float))
    out = np.repeat(f[:, None], len(delta), axis=1)
    k = np.arange(1, lay.max_order + 1)[:, None]
    c, s = np.cos(k * delta[None, :]), np.sin(k * delta[None, :])
    for r in lay.te_runs:
        a, b = f[lay.cos[r]][:, None], f[lay.sin[r]][:, None]
        out[lay.cos[r]] = a * c + b * s
        out[lay.sin[r]] = -a * s + b * c
    return out

"""Which effect: fitting every candidate with the model in the loop.

1. The baseline model (the reducer as specified, no errors) is run under every bench run's
   conditions; the measured and model features (:mod:`rvflex.diagnose.replay`) are weighted
   by their noise/model-form floors.
2. Sensitivities: one model run per effect parameter at its typical step (a secant, not an
   infinitesimal derivative, so clearances and other one-sided effects are linearised where
   they act; two-sided effects get a secant on each side of zero); cached by a content hash
   on disk, evaluated in a process pool.
3. Every candidate (each effect, and pairs of each of the best ones with every other effect)
   is fitted by bounded linear least squares together with the nuisances (common TE offset,
   hysteresis offsets) and the unknown encoder origin δ (a grid search over the position
   shift). A pair is kept only when its second effect removes at least ``min_shrink_pct`` of
   the weighted gap the better of its single effects leaves (and improves the BIC by at least
   ``bic_threshold``): the rule that admits an effect against "no effect", applied again.
4. The best ``refine_top`` candidates are refined with the model in the loop: Broyden
   (secant) updates of their Jacobian from real model runs at the fitted values; their
   score uses the real model's residual.
5. Model selection by BIC (n·ln(RSS/n) + k·ln n, k counting effect parameters, nuisances
   and δ); an interval per parameter from the linearised covariance (95 %).
6. Withheld check, two folds in which every run is predicted at most once by a fit that did not
   see it: refit on the forward TE run at the highest load and the torque cycles and predict
   the other TE runs (other directions, loads, temperatures); refit on the TE runs and predict
   the torque cycles. The improvement is pooled over the predicted runs.
"""

from __future__ import annotations

import dataclasses as dc
import hashlib
import itertools
import math
import pickle
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.optimize import lsq_linear

from rvflex.diagnose.effects import Effect, available_effects
from rvflex.diagnose.replay import (
    DiagnosisSettings,
    EvaluationFailed,
    Layout,
    PlanRun,
    Response,
    evaluate,
    features,
    measured_features,
    plan_from_dataset,
    shift_measured,
)
from rvflex.spec import ErrorSpec, ReducerSpec

__all__ = ["Candidate", "Diagnosis", "diagnose", "signature_sizes", "ties", "withheld_folds", "withheld_split"]

CACHE_VERSION = "diag-6"
DELTA_GRID = 2048  # origin shifts tried over one output revolution (0.18° apart), then refined locally
Z95 = 1.959964
REFINE_RETRY_STEP = 0.9  # a failed refinement point is tried again this share of the way from the last one


# ----------------------------------------------------------------------------- workers (module level: picklable)

def _eval_job(spec, errors, plan, settings, law, active):
    """Features and response of one model evaluation, or the failure message. Exudyn's console
    banners of retried static steps are silenced meanwhile (the retries are expected)."""
    import exudyn as exu

    before = exu.config.printToConsole
    exu.config.printToConsole = False
    try:
        resp = evaluate(spec, errors, plan, settings, active, law=law)
    except EvaluationFailed as err:
        return None, None, str(err)
    finally:
        exu.config.printToConsole = before
    f, _ = features(resp, plan, settings)
    return f, resp, ""


@dataclass(frozen=True)
class _Job:
    key: str
    active: tuple


class _Runner:
    """Evaluates model runs (serially or in a process pool), with an on-disk cache by content hash."""

    def __init__(self, spec, errors, plan, settings, law, cache_dir: Path | None, progress=None):
        self.spec, self.errors, self.plan, self.settings, self.law = spec, errors, plan, settings, law
        self.cache_dir = Path(cache_dir) if cache_dir else None
        self.progress = progress
        self.done = 0
        self.total = 0
        self.model_runs = 0
        from rvflex.spec import dumps_errors, dumps_spec

        self._base = hashlib.sha256(pickle.dumps((CACHE_VERSION, dumps_spec(spec), dumps_errors(errors), plan,
                                                  settings.positions_per_rev, settings.max_order,
                                                  settings.hysteresis_steps, repr(law)))).hexdigest()

    def key(self, active) -> str:
        desc = [(e.name, e.kind, tuple(p.name for p in e.params), tuple(np.round(np.asarray(x, float), 15)))
                for e, x in active]
        return hashlib.sha256((self._base + repr(desc)).encode()).hexdigest()[:24]

    def _load(self, key):
        if self.cache_dir is None:
            return None
        p = self.cache_dir / f"{key}.pkl"
        if p.is_file():
            try:
                return pickle.loads(p.read_bytes())
            except (OSError, pickle.UnpicklingError, EOFError, AttributeError):  # a damaged entry is recomputed
                return None
        return None

    def _store(self, key, value) -> None:
        if self.cache_dir is None:
            return
        self.cache_dir.mkdir(parents=True, exist_ok=True)
        tmp = self.cache_dir / f".{key}.{id(value)}.tmp"
        tmp.write_bytes(pickle.dumps(value))
        tmp.replace(self.cache_dir / f"{key}.pkl")

    def run(self, actives: list[tuple]) -> list[tuple]:
        """Evaluate each active set; returns (features | None, response | None, message) per set."""
        keys = [self.key(a) for a in actives]
        out: list = [self._load(k) for k in keys]
        todo = [i for i, o in enumerate(out) if o is None]
        self.total += len(actives)
        self.done += len(actives) - len(todo)
        if self.progress:
            self.progress(self.done, self.total)
        args = (self.spec, self.errors, self.plan, self.settings, self.law)
        if len(todo) > 1 and self.settings.workers > 1:
            with ProcessPoolExecutor(max_workers=min(self.settings.workers, len(todo))) as pool:
                futs = {i: pool.submit(_eval_job, *args, actives[i]) for i in todo}
                for i, fut in futs.items():
                    try:
                        out[i] = fut.result()
                    except Exception as err:  # noqa: BLE001 - a dying worker is a failed evaluation, not a crash
                        out[i] = (None, None, f"{type(err).__name__}: {err}")
                    self._finish(keys[i], out[i])
        else:
            for i in todo:
                out[i] = _eval_job(*args, actives[i])
                self._finish(keys[i], out[i])
        return out

    def _finish(self, key, value) -> None:
        self.model_runs += 1
        self._store(key, value)
        self.done += 1
        if self.progress:
            self.progress(self.done, self.total)


# ----------------------------------------------------------------------------- fitted candidates

@dataclass(frozen=True, eq=False)
class Candidate:
    """A fitted candidate (one effect or a pair).

    ``x`` are the effect parameters (SI, in the order of ``param_names``), ``interval`` their
    95 % intervals, ``delta`` the fitted encoder origin (rad), ``rss`` the weighted residual sum
    of squares (of the real model run when ``refined``, else of the linearised fit), ``bic``
    its Bayesian information criterion, ``score`` = BIC(no effect) − BIC(this). ``jacobian``:
    the sensitivity matrix (features per unit parameter) the fit used — the secants of the
    parameters' signs for two-sided effects, the Broyden-updated one when ``refined``;
    ``lower``/``upper`` the parameter bounds of that fit.
    """

    effects: tuple[Effect, ...]
    x: np.ndarray
    interval: np.ndarray
    magnitude: tuple[float, ...]
    magnitude_interval: tuple[tuple[float, float], ...]
    delta: float
    nuisance: np.ndarray
    rss: float
    k: int
    bic: float
    refined: bool
    at_bound: tuple[str, ...]
    model_features: np.ndarray
    response: Response | None = None
    score: float = 0.0
    gap_shrink_pct: float = 0.0
    withheld: dict = field(default_factory=dict)
    accepted: bool = False
    note: str = ""
    jacobian: np.ndarray | None = None
    lower: np.ndarray | None = None
    upper: np.ndarray | None = None

    @property
    def name(self) -> str:
        return " + ".join(e.name for e in self.effects) if self.effects else "none"

    @property
    def param_names(self) -> tuple[str, ...]:
        if len(self.effects) == 1:
            return tuple(p.name for p in self.effects[0].params)
        return tuple(f"{e.name}.{p.name}" for e in self.effects for p in e.params)

    @property
    def units(self) -> tuple[str, ...]:
        return tuple(u for e in self.effects for u in e.units)

    def split(self) -> list[tuple[Effect, np.ndarray]]:
        """(effect, its parameter values) pairs."""
        out, i = [], 0
        for e in self.effects:
            out.append((e, self.x[i:i + e.n]))
            i += e.n
        return out


def _nuisance_columns(lay: Layout, rows: np.ndarray | None = None) -> np.ndarray:
    """Offset columns: one for the means of all TE runs, one per hysteresis run."""
    cols = []
    if lay.te_runs:
        c = np.zeros(lay.n)
        c[[lay.dc[r] for r in lay.te_runs]] = 1.0
        cols.append(c)
    for r in sorted(lay.hyst):
        c = np.zeros(lay.n)
        c[lay.hyst[r]] = 1.0
        cols.append(c)
    return np.column_stack(cols) if cols else np.zeros((lay.n, 0))


@dataclass(frozen=True, eq=False)
class _Problem:
    y: np.ndarray  # measured features, unshifted
    lay: Layout
    w: np.ndarray  # weights (1/floor) per feature
    nuis: np.ndarray
    has_te: bool
    shifted: np.ndarray | None = None  # y shifted by every origin of the coarse δ grid (n × DELTA_GRID), shared by all fits

    @classmethod
    def build(cls, y, lay, w, nuis) -> _Problem:
        has_te = bool(lay.te_runs)
        grid = np.linspace(0.0, 2 * np.pi, DELTA_GRID, endpoint=False)
        return cls(y, lay, w, nuis, has_te, shift_measured(y, lay, grid) if has_te else None)


def _lin_fit(prob: _Problem, base: np.ndarray, J: np.ndarray, x_ref: np.ndarray, lo: np.ndarray, hi: np.ndarray,
             rows: np.ndarray | None = None, delta: float | None = None):
    """Bounded linear LS of y(δ) ≈ base + J·(x − x_ref) + nuisances, δ searched unless given.
    Returns x, nuisance, δ, weighted RSS, weighted design matrix at the solution."""
    rows = np.arange(prob.lay.n) if rows is None else rows
    w = prob.w[rows]
    nuis = prob.nuis[rows]
    nuis = nuis[:, np.abs(nuis).sum(axis=0) > 0]
    A = np.column_stack([J[rows] * w[:, None], nuis * w[:, None]])
    p = J.shape[1]
    if delta is None and prob.has_te:
        grid = np.linspace(0.0, 2 * np.pi, DELTA_GRID, endpoint=False)
        delta = _best_delta(prob, base, A, rows, w, grid, prob.shifted)
        step = 2 * np.pi / DELTA_GRID
        fine = delta + np.linspace(-step, step, 41)
        delta = _best_delta(prob, base, A, rows, w, fine)
    delta = 0.0 if delta is None else float(delta) % (2 * np.pi)
    r = (shift_measured(prob.y, prob.lay, delta)[:, 0] - base)[rows] * w
    lb = np.r_[lo - x_ref, np.full(A.shape[1] - p, -np.inf)]
    ub = np.r_[hi - x_ref, np.full(A.shape[1] - p, np.inf)]
    if A.shape[1] == 0:
        return x_ref.copy(), np.zeros(0), delta, float(r @ r), A
    sol = lsq_linear(A, r, bounds=(lb, ub), method="bvls" if A.shape[1] < 40 else "trf")
    res = r - A @ sol.x
    return x_ref + sol.x[:p], sol.x[p:], delta, float(res @ res), A


def _best_delta(prob, base, A, rows, w, grid, shifted=None) -> float:
    Y = ((shift_measured(prob.y, prob.lay, grid) if shifted is None else shifted) - base[:, None])[rows] * w[:, None]
    if A.shape[1]:
        Q, _ = np.linalg.qr(A)
        Y = Y - Q @ (Q.T @ Y)
    rss = np.einsum("ij,ij->j", Y, Y)
    return float(grid[int(np.argmin(rss))])


def _bic(rss: float, n: int, k: int) -> float:
    return n * math.log(max(rss, 1e-300) / n) + k * math.log(n)


def _intervals(A: np.ndarray, rss: float, p: int, x: np.ndarray):
    n, k = A.shape
    s2 = rss / max(n - k - 1, 1)
    try:
        cov = s2 * np.linalg.pinv(A.T @ A)
    except np.linalg.LinAlgError:
        cov = np.full((k, k), np.inf)
    return cov[:p, :p]


def _bounds(effects) -> tuple[np.ndarray, np.ndarray]:
    if not effects:
        return np.zeros(0), np.zeros(0)
    return np.concatenate([e.lower for e in effects]), np.concatenate([e.upper for e in effects])


def _candidate(effects, x, nu, d, rss, A, n, n_nuis, model_features, *, refined, response=None, note="",
               jacobian=None, bounds=None):
    p = len(x)
    k = p + n_nuis + 1
    cov = _intervals(A, rss, p, x)
    sd = np.sqrt(np.clip(np.diag(cov), 0, None)) if p else np.zeros(0)
    interval = np.column_stack([x - Z95 * sd, x + Z95 * sd]) if p else np.zeros((0, 2))
    mags, mag_iv, names_at_bound = [], [], []
    i = 0
    for e in effects:
        xe, ce = x[i:i + e.n], cov[i:i + e.n, i:i + e.n]
        m = e.magnitude(xe)
        g = xe / m if m > 0 else np.full(e.n, 1 / math.sqrt(e.n))
        sm = math.sqrt(max(float(g @ ce @ g), 0.0))
        mags.append(m)
        mag_iv.append((max(m - Z95 * sm, 0.0), m + Z95 * sm))
        for j, prm in enumerate(e.params):
            span = prm.high - prm.low
            if (prm.low != 0.0 and abs(xe[j] - prm.low) < 1e-3 * span) or abs(xe[j] - prm.high) < 1e-3 * span:
                names_at_bound.append(f"{e.name}.{prm.name}")
        i += e.n
    lo, hi = bounds if bounds is not None else _bounds(effects)
    return Candidate(tuple(effects), x, interval, tuple(mags), tuple(mag_iv), d, nu, rss, k, _bic(rss, n, k), refined,
                     tuple(names_at_bound), model_features, response, note=note, jacobian=jacobian, lower=lo,
                     upper=hi)


@dataclass(frozen=True, eq=False)
class _Sens:
    """Secant sensitivities (features per unit parameter) by effect name: ``plus`` from +step
    (central ones for ``central`` effects), ``minus`` from −step for ``two_sided`` effects."""

    plus: dict
    minus: dict

    def __contains__(self, name: str) -> bool:
        return name in self.plus

    def orthants(self, effects) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """(J, lower, upper) per sign pattern of the two-sided parameters of ``effects``: the +step
        secant with the bounds [0, high] and the −step secant with [low, 0]; one entry with the
        full bounds when no parameter is two-sided."""
        cols, los, his, choices = [], [], [], []
        for e in effects:
            for j, prm in enumerate(e.params):
                cols.append((self.plus[e.name][:, j], self.minus[e.name][:, j] if e.name in self.minus else None))
                los.append(prm.low)
                his.append(prm.high)
                choices.append((1.0, -1.0) if e.name in self.minus else (0.0,))
        out = []
        for signs in itertools.product(*choices):
            J = np.column_stack([c[1] if sg < 0 else c[0] for c, sg in zip(cols, signs)])
            lo = np.array([0.0 if sg > 0 else lw for sg, lw in zip(signs, los)])
            hi = np.array([0.0 if sg < 0 else h for sg, h in zip(signs, his)])
            if np.all(lo < hi) or not len(lo):
                out.append((J, lo, hi))
        return out


# ----------------------------------------------------------------------------- the diagnosis

@dataclass(frozen=True, eq=False)
class Diagnosis:
    """Everything a diagnosis found (see :func:`diagnose`); :mod:`rvflex.diagnose.report` turns it
    into the report and the JSON document."""

    dataset: object
    settings: DiagnosisSettings
    plan: tuple[PlanRun, ...]
    layout: Layout
    weights: np.ndarray
    measured: np.ndarray
    baseline: Candidate
    baseline_response: Response
    candidates: tuple[Candidate, ...]
    chosen: Candidate | None
    withheld_runs: tuple[tuple[tuple[int, ...], tuple[int, ...]], ...]  # the folds: (fitted, predicted) runs
    unavailable: dict
    failed: dict
    signature_size: dict
    verdict: str
    model_runs: int
    wall_s: float
    ties: tuple[str, ...] = ()


def withheld_split(plan: tuple[PlanRun, ...]) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """Runs fitted and runs predicted in the withheld check: fit on the forward TE runs at the
    highest load and on the torque cycles, predict every other run (other directions, other
    loads). With no TE run forward at the highest load the first TE run takes its place."""
    te = [r for r, p in enumerate(plan) if p.kind == "te"]
    hyst = [r for r, p in enumerate(plan) if p.kind != "te"]
    if not te:
        return tuple(hyst), ()
    fwd = [r for r in te if plan[r].direction > 0]
    pool = fwd or te
    top = max(plan[r].load_Nm for r in pool)
    fit_te = [r for r in pool if plan[r].load_Nm == top][:1]
    fitted = tuple(sorted(fit_te + hyst))
    return fitted, tuple(r for r in range(len(plan)) if r not in fitted)


def withheld_folds(plan: tuple[PlanRun, ...]) -> tuple[tuple[tuple[int, ...], tuple[int, ...]], ...]:
    """The folds of the withheld check, each (fitted runs, predicted runs); no run is predicted
    twice. Fold 1 is :func:`withheld_split` (the other TE runs predicted from the forward TE run at
    the highest load and the torque cycles); fold 2 predicts the torque cycles from the TE runs
    (an effect whose evidence lies mostly in the torque cycle, such as friction, is confirmed
    there). Folds with nothing to fit or to predict are left out."""
    folds = []
    fitted, predicted = withheld_split(plan)
    if fitted and predicted:
        folds.append((fitted, predicted))
    te = tuple(r for r, p in enumerate(plan) if p.kind == "te")
    hyst = tuple(r for r, p in enumerate(plan) if p.kind != "te")
    if te and hyst:
        folds.append((te, hyst))
    return tuple(folds)


def _weights(f0: np.ndarray, y: np.ndarray, lay: Layout, s: DiagnosisSettings) -> np.ndarray:
    w = np.empty(lay.n)
    for r in lay.te_runs:
        # the measurement's noise floor: median coefficient size over the upper half of the orders
        a, b = y[lay.cos[r]], y[lay.sin[r]]
        half = slice(len(a) // 2, None)
        noise = float(np.median(np.hypot(a[half], b[half]))) / 1.18  # Rayleigh median → σ
        floor = math.hypot(s.order_floor_arcsec, noise)
        w[lay.cos[r]] = w[lay.sin[r]] = 1.0 / floor
        w[lay.dc[r]] = 1.0 / (s.windup_floor_arcsec + s.windup_floor_rel * abs(f0[lay.dc[r]]))
    for r, sl in lay.hyst.items():
        w[sl] = 1.0 / (s.windup_floor_arcsec + s.windup_floor_rel * np.abs(f0[sl] - np.mean(f0[sl])))
    return w


def diagnose(dataset, *, settings: DiagnosisSettings | None = None, effects: tuple[str, ...] | None = None,
             law=None, cache_dir: str | Path | None = None, progress=None,
             errors: ErrorSpec | None = None) -> Diagnosis:
    """Diagnose the gap between the model of ``dataset.reducer`` and the bench runs.

    Parameters
    ----------
    dataset : BenchDataset
        From :func:`rvflex.diagnose.bench.read_bench`.
    settings : DiagnosisSettings
    effects : tuple of str, optional
        Names of the candidate effects (default: every registered, available effect).
    law : ContactLaw, optional
        Contact law of the model (default: the model's line contact).
    cache_dir : path, optional
        Disk cache of model runs (content-hashed; safe to share between datasets).
    progress : callable, optional
        ``progress(done, total)`` over model runs.
    errors : ErrorSpec, optional
        Known errors of the unit (default: none).
    """
    t0 = time.perf_counter()
    settings = settings or DiagnosisSettings()
    spec: ReducerSpec = dataset.reducer
    errors = errors or ErrorSpec()
    plan = plan_from_dataset(dataset, settings)
    cands, unavailable = _available(effects, plan)
    runner = _Runner(spec, errors, plan, settings, law, Path(cache_dir) if cache_dir else None, progress)

    base_out = runner.run([()])[0]
    if base_out[0] is None:
        raise EvaluationFailed(f"the baseline model does not converge under the bench conditions: {base_out[2]}")
    f0, resp0, _ = base_out
    y, lay = measured_features(dataset, plan, settings)
    w = _weights(f0, y, lay, settings)
    nuis = _nuisance_columns(lay)
    prob = _Problem.build(y, lay, w, nuis)
    n, n_nuis = lay.n, nuis.shape[1]

    sens, failed = _sensitivities(runner, cands, f0, resp0, plan, settings, n)
    size = {e.name: _signature_size(e, sens, w) for e in cands if e.name in sens}
    usable = [e for e in cands if e.name in sens and e.name not in failed]

    # --- no effect
    x, nu, d, rss, A = _lin_fit(prob, f0, np.zeros((n, 0)), np.zeros(0), np.zeros(0), np.zeros(0))
    none = _candidate((), x, nu, d, rss, A, n, n_nuis, f0, refined=True, response=resp0)

    def lin(effs):
        best = None
        for J, lo, hi in sens.orthants(effs):  # two-sided parameters: each sign with its own secant
            fit_ = _lin_fit(prob, f0, J, np.zeros(J.shape[1]), lo, hi)
            if best is None or fit_[3] < best[0][3]:
                best = (fit_, J, lo, hi)
        (x, nu, d, rss, A), J, lo, hi = best
        return _candidate(effs, x, nu, d, rss, A, n, n_nuis, f0 + J @ x, refined=False, note="linearised",
                          jacobian=J, bounds=(lo, hi))

    singles = sorted((lin((e,)) for e in usable), key=lambda c: c.bic)
    # pairs: every pair of effects (or those with one of the best pair_top singles) — a weak second
    # effect need not rank high alone while a strong one dominates the gap, and two effects can
    # act only together (a small crank-bearing clearance shows only with a modification deviation
    # that takes the flank clearance away); kept only when the second effect removes enough of
    # what the better single leaves
    lead = {c.effects[0].name for c in singles[: settings.pair_top]} if settings.pair_top else None
    by_name = {c.name: c for c in singles}
    pairs = []
    for a, b in itertools.combinations([c.effects[0] for c in singles], 2):
        if lead is not None and a.name not in lead and b.name not in lead:
            continue
        c = lin((a, b))
        if _second_effect_adds(c, by_name, settings):
            pairs.append(c)
    ranked = sorted(singles + pairs, key=lambda c: c.bic)

    # --- model in the loop: Broyden refinement of the best candidates (always including the best single)
    to_refine = ranked[: settings.refine_top]
    if singles and singles[0] not in to_refine:
        to_refine = to_refine[:-1] + [singles[0]]
    # per candidate: Jacobian, last evaluated point and features, next point to evaluate, best evaluation
    st = {c.name: {"J": c.jacobian.copy(), "x_prev": np.zeros(len(c.x)),
                   "f_prev": f0, "x_next": c.x.copy(), "best": None, "c": c} for c in to_refine}
    for it in range(settings.refine_iterations):
        live = [name for name in st if name not in failed and st[name]["x_next"] is not None]
        if not live:
            break
        xs = {name: st[name]["x_next"] for name in live}
        outs = dict(zip(live, runner.run([tuple(_split(st[nm]["c"].effects, xs[nm])) for nm in live])))
        # the solver fails at isolated parameter values (measured: a crank-bearing clearance of 7.0 µm
        # failed where 6.2 and 8.0 µm converged): a failed point is tried once more a little short of it
        retry = [name for name in live if outs[name][0] is None]
        for name in retry:
            xs[name] = st[name]["x_prev"] + REFINE_RETRY_STEP * (xs[name] - st[name]["x_prev"])
        for name, o in zip(retry, runner.run([tuple(_split(st[nm]["c"].effects, xs[nm])) for nm in retry])):
            outs[name] = o
        for name in live:
            fx, rx, msg = outs[name]
            s_ = st[name]
            if fx is None:
                if s_["best"] is None:
                    failed[name] = f"model evaluation failed at the fitted values: {msg}"
                s_["x_next"] = None  # keep the best evaluation so far
                continue
            x_eval = xs[name]
            dx = x_eval - s_["x_prev"]
            if dx @ dx > 0:
                s_["J"] = s_["J"] + np.outer((fx - s_["f_prev"]) - s_["J"] @ dx, dx) / (dx @ dx)
            _, _, _, rss_real, _ = _lin_fit(prob, fx, np.zeros((n, 0)), np.zeros(0), np.zeros(0), np.zeros(0))
            prev_best = s_["best"][0] if s_["best"] is not None else math.inf
            if rss_real < prev_best:
                s_["best"] = (rss_real, x_eval.copy(), fx, rx, s_["J"].copy())
            x_new, *_ = _lin_fit(prob, fx, s_["J"], x_eval, *_bounds(s_["c"].effects))
            s_["x_prev"], s_["f_prev"] = x_eval, fx
            converged = np.allclose(x_new, x_eval, rtol=1e-3, atol=0)
            # after two evaluations, go on only while each one still pays (a curved valley, as the
            # moved/equidistant deviations along their near-cancelling direction, needs several)
            stalled = it >= 1 and rss_real > (1.0 - settings.refine_min_gain) * prev_best
            s_["x_next"] = None if converged or stalled else x_new
    refined = []
    for name, s_ in st.items():
        if s_["best"] is None:
            continue
        _, x_r, fx, rx, J = s_["best"]
        effs = s_["c"].effects
        _, nu, d, rss, _ = _lin_fit(prob, fx, np.zeros((n, 0)), np.zeros(0), np.zeros(0), np.zeros(0))
        cols = prob.nuis[:, np.abs(prob.nuis).sum(0) > 0]
        A_full = np.column_stack([J * prob.w[:, None], cols * prob.w[:, None]])
        refined.append(_candidate(effs, x_r, nu, d, rss, A_full, n, n_nuis, fx, refined=True, response=rx,
                                  note="model in the loop", jacobian=J))
    refined_names = {c.name for c in refined}
    allc = refined + [c for c in ranked if c.name not in refined_names]
    # the pair rule again with the model-in-the-loop residuals where there are some
    best_single = {}
    for c in allc:
        if len(c.effects) == 1 and (c.name not in best_single or c.rss < best_single[c.name].rss):
            best_single[c.name] = c
    allc = [c for c in allc if len(c.effects) == 1 or _second_effect_adds(c, best_single, settings)]

    # --- scores, shrink, withheld check
    folds = withheld_folds(plan)
    out = []
    for c in allc:
        score = none.bic - c.bic
        shrink = 100.0 * (1.0 - math.sqrt(c.rss / none.rss)) if none.rss > 0 else 0.0
        wh = _withheld(prob, plan, c, f0, folds)
        out.append(dc.replace(c, score=score, gap_shrink_pct=shrink, withheld=wh))
    out.sort(key=lambda c: -c.score)
    chosen = None
    final = []
    blocked = None  # a candidate that fits better (linearised) but whose model evaluation failed
    for c in out:
        ok = (c.refined and c.score >= settings.bic_threshold and c.gap_shrink_pct >= settings.min_shrink_pct
              and c.withheld.get("improvement_pct") is not None
              and c.withheld["improvement_pct"] >= settings.min_withheld_pct)
        if ok and chosen is None and blocked is None:
            chosen = dc.replace(c, accepted=True)
            final.append(chosen)
            continue
        if chosen is None and blocked is None and c.name in failed and c.score >= settings.bic_threshold:
            blocked = c
        final.append(c)
    lead = chosen or (final[0] if final else None)
    # ties of a lead that explains nothing would be every candidate: only a significant lead has ties
    tied = (tuple(o.name for o in _equivalent(final, lead, sens, f0, w))
            if lead is not None and lead.score >= settings.bic_threshold else ())
    verdict = _verdict(final, chosen, none, bool(folds), settings, unavailable, failed, tied, blocked)
    return Diagnosis(dataset, settings, plan, lay, w, y, none, resp0, tuple(final), chosen,
                     folds, unavailable, failed, size, verdict, runner.model_runs,
                     time.perf_counter() - t0, tied)


def _available(effects, plan) -> tuple[tuple[Effect, ...], dict]:
    """The candidate effects the model can evaluate for ``plan``, and the reasons of the others."""
    cands, unavailable = available_effects(effects)
    ok = []
    for e in cands:
        avail, why = e.available_for(plan)
        if avail:
            ok.append(e)
        else:
            unavailable[e.name] = why
    return tuple(ok), unavailable


def _signature_size(e: Effect, sens: _Sens, w: np.ndarray) -> float:
    """||w·ΔF||/√(parameters) at the typical step (rms of the two sides for two-sided effects)."""
    size2 = float(np.sum(((sens.plus[e.name] * e.steps[None, :]) * w[:, None]) ** 2))
    if e.name in sens.minus:
        size2 = 0.5 * (size2 + float(np.sum(((sens.minus[e.name] * e.steps[None, :]) * w[:, None]) ** 2)))
    return math.sqrt(size2 / e.n)


def _second_effect_adds(pair: Candidate, singles: dict, settings: DiagnosisSettings) -> bool:
    """Whether the pair's second effect earns its place: against the better of its two single
    effects (by residual) the pair removes ≥ ``min_shrink_pct`` of the remaining weighted gap and
    improves the BIC by ≥ ``bic_threshold``."""
    subs = [singles[e.name] for e in pair.effects if e.name in singles]
    if not subs:
        return False
    sub = min(subs, key=lambda c: c.rss)
    if sub.rss <= 0:
        return False
    shrink = 100.0 * (1.0 - math.sqrt(pair.rss / sub.rss))
    return shrink >= settings.min_shrink_pct and sub.bic - pair.bic >= settings.bic_threshold


def _sensitivities(runner, cands, f0, resp0, plan, settings, n) -> tuple[_Sens, dict]:
    """Secant sensitivities (features per unit parameter) of every candidate, and the failures."""
    # --- sensitivities: one run per parameter (measurement effects need no model run)
    jobs, owners = [], []
    for e in cands:
        if e.kind == "measurement":
            continue
        for j, prm in enumerate(e.params):
            for sign in ((1.0, -1.0) if e.central or e.two_sided else (1.0,)):
                x = np.zeros(e.n)
                x[j] = sign * prm.step
                jobs.append(((e, x),))
                owners.append((e.name, j, sign))
    # other-fidelity (slow) jobs first, so that they run alongside the rigid ones
    order = sorted(range(len(jobs)), key=lambda i: next(c for c in cands if c.name == owners[i][0]).kind != "fidelity")
    outs: list = [None] * len(jobs)
    for i, o in zip(order, runner.run([jobs[i] for i in order])):
        outs[i] = o
    sens: dict[str, np.ndarray] = {}
    minus: dict[str, np.ndarray] = {}
    failed: dict[str, str] = {}
    pos = 2 * np.pi * np.arange(settings.positions_per_rev) / settings.positions_per_rev
    for e in cands:
        if e.kind == "measurement":
            cols = []
            for j, prm in enumerate(e.params):
                x = np.zeros(e.n)
                x[j] = prm.step
                te = tuple(None if a is None else e.measure(pos, a, x) for a in resp0.te)
                fj, _ = features(dc.replace(resp0, te=te), plan, settings)
                cols.append((fj - f0) / prm.step)
            sens[e.name] = np.column_stack(cols)
    for (name, j, sign), (fj, _, msg) in zip(owners, outs):
        if name in failed:
            continue
        if fj is None:
            failed[name] = f"model evaluation failed at the sensitivity step: {msg}"
            sens.pop(name, None)
            minus.pop(name, None)
            continue
        e = next(c for c in cands if c.name == name)
        if e.two_sided and sign < 0:  # the −step secant (f0 − f−)/h, kept apart
            minus.setdefault(name, np.zeros((n, e.n)))[:, j] = (f0 - fj) / e.params[j].step
            continue
        # one-sided: the secant (f+ − f0)/h; central: (f+ − f0)/(2h) + (f0 − f−)/(2h)
        scale = e.params[j].step * (2.0 if e.central else 1.0)
        sens.setdefault(name, np.zeros((n, e.n)))[:, j] += sign * (fj - f0) / scale
    return _Sens(sens, minus), failed


def signature_sizes(spec: ReducerSpec, plan, settings: DiagnosisSettings, effects: tuple[str, ...] | None = None,
                    *, law=None, cache_dir: str | Path | None = None, errors: ErrorSpec | None = None) -> dict:
    """Size of each effect's model signature at its typical magnitude, in units of the
    residual floors (measurement noise not included): ||w·ΔF||/√(parameters). Below ~3 an
    effect is not observable with these runs; NaN when its model evaluation failed."""
    cands, _ = _available(effects, plan)
    runner = _Runner(spec, errors or ErrorSpec(), plan, settings, law, Path(cache_dir) if cache_dir else None)
    f0, resp0, msg = runner.run([()])[0]
    if f0 is None:
        raise EvaluationFailed(f"the baseline model does not converge: {msg}")
    _, lay = features(resp0, plan, settings)
    y0 = f0.copy()
    for r in lay.te_runs:  # no measurement: the floors alone
        y0[lay.cos[r]] = y0[lay.sin[r]] = 0.0
    w = _weights(f0, y0, lay, settings)
    sens, _ = _sensitivities(runner, cands, f0, resp0, plan, settings, lay.n)
    return {e.name: (_signature_size(e, sens, w) if e.name in sens else math.nan) for e in cands}


def _split(effects, x) -> list[tuple[Effect, np.ndarray]]:
    out, i = [], 0
    for e in effects:
        out.append((e, np.asarray(x[i:i + e.n], float)))
        i += e.n
    return out


def _withheld(prob: _Problem, plan, c: Candidate, f0, folds) -> dict:
    """Refit ``c`` on each fold's fitted runs only and predict its other runs (linearised about
    the candidate's point with its Jacobian; origin δ as fitted on all runs). Improvement =
    1 − rms(prediction residual)/rms(baseline residual), per fold and pooled over every predicted
    run (weighted residual energy)."""
    label = [p.label for p in plan]
    doc = {"fitted_runs": sorted({label[r] for f, _ in folds for r in f}, key=label.index),
           "predicted_runs": [label[r] for _, pr in folds for r in pr], "improvement_pct": None, "folds": []}
    if not folds:
        doc["note"] = "no run usable for the withheld check"
        return doc
    lay = prob.lay
    J = c.jacobian
    if c.refined:
        base, x_ref = c.model_features, c.x
    else:
        base, x_ref = f0, np.zeros(len(c.x))
    lo, hi = (c.lower, c.upper) if c.lower is not None else _bounds(c.effects)
    d = c.delta

    def predict(base_, J_, x_ref_, lo_, hi_, fitted_runs, predicted_runs):
        rows_f = np.concatenate([lay.run_rows(r) for r in fitted_runs])
        rows_p = np.concatenate([lay.run_rows(r) for r in predicted_runs])
        x, nu, _, _, _ = _lin_fit(prob, base_, J_, x_ref_, lo_, hi_, rows=rows_f, delta=d)
        model = base_ + J_ @ (x - x_ref_)
        # nuisances: the common TE offset comes from the fitted runs; a predicted run's own
        # hysteresis offset is no prediction, so it is refitted
        cols = prob.nuis[:, np.abs(prob.nuis[rows_f]).sum(0) > 0]
        model = model + cols @ nu
        r = (shift_measured(prob.y, lay, d)[:, 0] - model)
        for run in predicted_runs:
            if run in lay.hyst:
                sl = lay.hyst[run]
                r[sl] -= np.average(r[sl], weights=prob.w[sl] ** 2)
        rw = r[rows_p] * prob.w[rows_p]
        return float(rw @ rw), x

    total_before = total_after = 0.0
    for fitted_runs, predicted_runs in folds:
        rss_before, _ = predict(f0, np.zeros((lay.n, 0)), np.zeros(0), np.zeros(0), np.zeros(0),
                                fitted_runs, predicted_runs)
        rss_after, x_f = predict(base, J, x_ref, lo, hi, fitted_runs, predicted_runs)
        total_before += rss_before
        total_after += rss_after
        doc["folds"].append({"fitted_runs": [label[r] for r in fitted_runs],
                             "predicted_runs": [label[r] for r in predicted_runs],
                             "improvement_pct": (100.0 * (1.0 - math.sqrt(rss_after / rss_before))
                                                 if rss_before > 0 else 0.0),
                             "fitted_params": [float(v) for v in x_f]})
    doc["improvement_pct"] = 100.0 * (1.0 - math.sqrt(total_after / total_before)) if total_before > 0 else 0.0
    return doc


TIE_RSS_RATIO = 1.15  # candidates whose residuals differ by less than this factor are not separated by the data


def ties(diag) -> tuple[str, ...]:
    """Names of the candidates tied with the diagnosis' lead (see :func:`_equivalent`)."""
    return diag.ties


SIGNATURE_TIE = 0.25  # another candidate reproduces the lead's fitted signature to within this (relative, weighted)


def _equivalent(cands, lead, sens, f0, w) -> list:
    """Candidates the data cannot tell from ``lead``: their residual is within TIE_RSS_RATIO of
    the lead's, or their own sensitivities, within their parameter bounds, reproduce the lead's
    fitted model change (weighted, origin shift ignored) to within SIGNATURE_TIE — both computed
    from model runs. When the two share an effect (two pairs), only the part of the lead's change
    that the shared effect does not make has to be reproduced."""
    names = {e.name for e in lead.effects}
    total = lead.model_features - f0
    parts, i = {}, 0
    for e, xe in lead.split():  # the lead's change per effect, from its Jacobian
        parts[e.name] = lead.jacobian[:, i:i + e.n] @ xe if lead.jacobian is not None else np.zeros_like(total)
        i += e.n
    out = []
    for o in cands:
        own = {e.name for e in o.effects}
        if o is lead or own <= names or names <= own or not all(e.name in sens for e in o.effects):
            continue
        if o.refined and o.rss <= TIE_RSS_RATIO * lead.rss:
            out.append(o)
            continue
        shared = names & own
        sig = (total - sum((parts[nm] for nm in shared), np.zeros_like(total))) * w
        norm = float(np.linalg.norm(sig))
        if norm <= 0:
            continue
        for J, lo, hi in sens.orthants(tuple(e for e in o.effects if e.name not in shared)):
            A = J * w[:, None]
            coef = lsq_linear(A, sig, bounds=(lo, hi), method="bvls").x
            if np.linalg.norm(sig - A @ coef) <= SIGNATURE_TIE * norm:
                out.append(o)
                break
    return out


def _verdict(cands, chosen, none, has_folds, settings, unavailable, failed, tied=(), blocked=None) -> str:
    if not cands:
        return "No candidate effect could be evaluated; the gap is unexplained."
    if chosen is not None:
        c = chosen
        tie = [o for o in cands if o.name in tied]
        mag = "; ".join(f"{e.name} {_fmt_mag(e, m)} (95 % {_fmt_mag(e, iv[0])} … {_fmt_mag(e, iv[1])})"
                        for e, m, iv in zip(c.effects, c.magnitude, c.magnitude_interval))
        s = (f"{c.name} explains the gap: {mag}; the weighted gap shrinks by {c.gap_shrink_pct:.0f} %, "
             f"{100 - c.gap_shrink_pct:.0f} % of it stays unexplained by any candidate; the withheld runs' "
             f"prediction improves by {c.withheld['improvement_pct']:.0f} %.")
        if c.at_bound:
            s += f" The fit hits a parameter bound ({', '.join(c.at_bound)}): the magnitude is a limit, not an estimate."
        if tie:
            s += (f" Tied with {', '.join(o.name for o in tie[:3])}: their model signatures reproduce this one "
                  "(or fit as well), so these runs cannot separate them.")
        return s
    if blocked is not None:
        return (f"No effect is confirmed: {blocked.name} fits best in the linearised model (score "
                f"{blocked.score:.1f}, gap shrink {blocked.gap_shrink_pct:.0f} %) but its model evaluation at the "
                f"fitted values failed ({failed.get(blocked.name, '')[:160]}), so no weaker candidate is accepted "
                f"in its place; the gap stays unexplained.")
    best = cands[0]
    significant = best.score >= settings.bic_threshold and best.gap_shrink_pct >= settings.min_shrink_pct
    if significant and not has_folds:
        return (f"{best.name} fits best (gap shrinks by {best.gap_shrink_pct:.0f} %) but cannot be confirmed: "
                f"no run is usable for the withheld check (add a reverse or another-load run).")
    if significant:
        why = []
        if not best.refined:
            why.append("its model-in-the-loop evaluation failed, so only its linearised fit is known")
        wh = best.withheld.get("improvement_pct")
        if wh is None or wh < settings.min_withheld_pct:
            why.append(f"refitted without them it predicts the withheld runs only {_fmt_pct(wh)} better "
                       f"(≥ {settings.min_withheld_pct:g} % needed)")
        return (f"No effect is confirmed: the best candidate, {best.name}, removes {best.gap_shrink_pct:.0f} % "
                f"of the gap (score {best.score:.1f}), but {' and '.join(why or ['it was not accepted'])}; "
                "the gap stays unexplained.")
    return (f"No significant unmodelled effect: the best candidate, {best.name}, removes only "
            f"{max(best.gap_shrink_pct, 0):.0f} % of the gap (score {best.score:.1f}, withheld "
            f"{_fmt_pct(best.withheld.get('improvement_pct'))}); the remaining gap is model-form "
            f"mismatch and noise.")


def _fmt_pct(v) -> str:
    return "n/a" if v is None else f"{v:+.0f} %"


def _fmt_mag(e: Effect, m: float) -> str:
    u = e.params[0].unit
    if u == "m":
        return f"{m * 1e6:.2f} µm"
    if u == "rad":
        return f"{m * 206264.806:.2f}″"
    if u == "1/K":
        return f"{m * 1e6:.2f} ppm/K"
    return f"{m:.3g} {u}"

"""Linearised fitting: candidates, the weighted bounded least squares with the encoder origin, priors
of the nominal parameters, BIC and intervals, and the secant sensitivities they use."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import lsq_linear

from rvflex.diagnosis.effects import Effect
from rvflex.diagnosis.features import shift_measured
from rvflex.diagnosis.plan import Layout
from rvflex.diagnosis.replay import Response
from rvflex.diagnosis.settings import DiagnosisSettings

__all__ = ["Candidate", "Problem", "Sensitivities", "bic", "bounds", "lin_fit", "make_candidate",
           "denoise_orders", "nuisance_columns", "prior_of", "prior_penalty", "split_params", "weights"]

DELTA_GRID = 2048  # origin shifts tried over one output revolution (0.18° apart), then refined locally
Z95 = 1.959964


@dataclass(frozen=True, eq=False)
class Candidate:
    """A fitted candidate (one effect or a pair).

    ``x`` are the effect parameters (SI, in the order of ``param_names``), ``interval`` their
    95 % intervals, ``delta`` the fitted encoder origin (rad), ``rss`` the weighted residual sum
    of squares (of the real model run when ``refined``, else of the linearised fit), ``bic``
    its Bayesian information criterion, ``score`` its evidence against the calibrated model (see
    :func:`rvflex.diagnosis.discrepancy.evidence`; ``bic_score`` = BIC(no effect) − BIC(this)). ``jacobian``:
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
    bic_score: float = 0.0  # BIC(no effect) − BIC(this) with one variance for all features (``score`` when evidence_model="bic")
    gap_shrink_pct: float = 0.0
    withheld: dict = field(default_factory=dict)
    accepted: bool = False
    note: str = ""
    jacobian: np.ndarray | None = None
    lower: np.ndarray | None = None
    upper: np.ndarray | None = None
    base_features: np.ndarray | None = None  # the linearisation point of an unrefined fit (None: the nominal model)
    base_x: np.ndarray | None = None  # its parameters (None: zeros)
    grade: dict = field(default_factory=dict)  # its grade (rvflex.diagnosis.grade.grade), once scored

    @property
    def name(self) -> str:
        """The attributed (unmodelled) effects; "none" for the calibrated nominal model alone."""
        return " + ".join(e.name for e in self.attributed) if self.attributed else "none"

    def magnitude_of(self, name: str) -> float:
        """Magnitude of the effect (or nominal parameter) ``name`` in this candidate."""
        return self.magnitude[[e.name for e in self.effects].index(name)]

    @property
    def attributed(self) -> tuple[Effect, ...]:
        """The unmodelled effects of this candidate (its nominal parameters left out)."""
        return tuple(e for e in self.effects if not e.nominal)

    @property
    def calibrated(self) -> list[tuple[Effect, np.ndarray, np.ndarray]]:
        """(nominal parameter, value, 95 % interval rows) of every calibrated nominal parameter."""
        out, i = [], 0
        for e in self.effects:
            if e.nominal:
                out.append((e, self.x[i:i + e.n], self.interval[i:i + e.n]))
            i += e.n
        return out

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


def nuisance_columns(lay: Layout, rows: np.ndarray | None = None) -> np.ndarray:
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
class Problem:
    y: np.ndarray  # measured features, unshifted
    lay: Layout
    w: np.ndarray  # weights (1/floor) per feature
    nuis: np.ndarray
    has_te: bool
    # the squared norms of the weighted measured features shifted by every origin of the coarse δ grid
    # (DELTA_GRID), shared by every δ search over all rows
    shifted_w_sq: np.ndarray | None = None
    memo: dict = field(default_factory=dict)  # δ of the offsets-only search by linearisation point

    @property
    def active_nuis(self) -> np.ndarray:
        """The nuisance columns in use (those not all zero: the offsets of the runs the layout has)."""
        return self.nuis[:, np.abs(self.nuis).sum(0) > 0]

    def weighted_design(self, J: np.ndarray) -> np.ndarray:
        """The weighted design matrix of a fit with parameter columns ``J``: those and :attr:`active_nuis`, each
        feature's row times its weight (what a candidate's intervals are computed from)."""
        return np.column_stack([J, self.active_nuis]) * self.w[:, None]

    @classmethod
    def build(cls, y, lay, w, nuis) -> Problem:
        has_te = bool(lay.te_runs)
        if not has_te:
            return cls(y, lay, w, nuis, has_te)
        grid = np.linspace(0.0, 2 * np.pi, DELTA_GRID, endpoint=False)
        yw = shift_measured(y, lay, grid) * w[:, None]
        return cls(y, lay, w, nuis, has_te, np.einsum("ij,ij->j", yw, yw))

    def shifted_products(self, V: np.ndarray) -> np.ndarray:
        """Vᵀ·(w ∘ y(δ)) for every origin δ of the coarse grid (m × DELTA_GRID, V: n × m): y(δ) is a trigonometric
        polynomial in δ of the TE orders (:func:`~rvflex.diagnosis.features.shift_measured`), so each product is
        one inverse FFT of its order coefficients instead of a pass over the n × G shifted matrix."""
        lay, y = self.lay, self.y
        Vw = V * self.w[:, None]
        K = lay.max_order
        Z = np.zeros((Vw.shape[1], DELTA_GRID // 2 + 1), complex)
        const = Vw.T @ y
        for r in lay.te_runs:
            cs, sn = lay.cos[r], lay.sin[r]
            vc, vs, a, b = Vw[cs], Vw[sn], y[cs][:, None], y[sn][:, None]
            const -= (vc * a + vs * b).sum(axis=0)  # the shifted rows enter through Z alone
            Z[:, 1:K + 1] += ((vc * a + vs * b) - 1j * (vc * b - vs * a)).T
        # Σ_k C_k cos kδ + S_k sin kδ = Re Σ_k (C_k − i S_k) e^{ikδ}; irfft halves the k ≥ 1 terms and divides by G
        return const[:, None] + np.fft.irfft(Z * (DELTA_GRID / 2.0), n=DELTA_GRID, axis=1)


def lin_fit(prob: Problem, base: np.ndarray, J: np.ndarray, x_ref: np.ndarray, lo: np.ndarray, hi: np.ndarray,
            rows: np.ndarray | None = None, delta: float | None = None, prior: tuple | None = None):
    """Bounded linear LS of y(δ) ≈ base + J·(x − x_ref) + nuisances, δ searched unless given, with
    the regulariser Σ ((x − c)/σ)² of ``prior`` = (1/σ per parameter, 0 where none; centres c).
    Returns x, nuisance, δ, weighted RSS (regulariser included), weighted design matrix (data rows)."""
    rows = np.arange(prob.lay.n) if rows is None else rows
    w = prob.w[rows]
    nuis = prob.nuis[rows]
    nuis = nuis[:, np.abs(nuis).sum(axis=0) > 0]
    A = np.column_stack([J[rows] * w[:, None], nuis * w[:, None]])
    p = J.shape[1]
    if delta is None and prob.has_te:
        # δ by the unbounded fit with every column, and by the offsets alone: a step the bounds cut
        # short can make the first one's δ poor for the bounded fit (measured: a crank-eccentricity
        # fit at its bounds, six times the calibrated model's residual); the better bounded fit wins
        key = (base.tobytes(), rows.tobytes())  # the offsets-only δ depends on the point alone: searched once
        if key not in prob.memo:
            prob.memo[key] = _search_delta(prob, base, A[:, p:], rows, w)
        deltas = [_search_delta(prob, base, A, rows, w), prob.memo[key]]
    else:
        deltas = [0.0 if delta is None else delta]
    best = None
    for d in deltas:
        fit = _bounded_fit(prob, base, A, rows, w, x_ref, lo, hi, prior, float(d) % (2 * np.pi))
        if best is None or fit[3] < best[3]:
            best = fit
    return best


def _search_delta(prob, base, A, rows, w) -> float:
    """The origin shift δ of the unbounded fit with the columns ``A``: grid, then refined locally."""
    grid = np.linspace(0.0, 2 * np.pi, DELTA_GRID, endpoint=False)
    Q = np.linalg.qr(A)[0] if A.shape[1] else np.zeros((A.shape[0], 0))  # (both searches project on A's span)
    if len(rows) == prob.lay.n:
        delta = _best_delta_all_rows(prob, base, Q, grid)
    else:
        delta = _best_delta(prob, base, Q, rows, w, grid)
    step = 2 * np.pi / DELTA_GRID
    return _best_delta(prob, base, Q, rows, w, delta + np.linspace(-step, step, 41))


def _bounded_fit(prob, base, A, rows, w, x_ref, lo, hi, prior, delta):
    """The bounded least squares of :func:`lin_fit` at the origin shift ``delta``."""
    p = len(x_ref)
    r = (shift_measured(prob.y, prob.lay, delta)[:, 0] - base)[rows] * w
    lb = np.r_[lo - x_ref, np.full(A.shape[1] - p, -np.inf)]
    ub = np.r_[hi - x_ref, np.full(A.shape[1] - p, np.inf)]
    if A.shape[1] == 0:
        return x_ref.copy(), np.zeros(0), delta, float(r @ r), A
    A_fit, r_fit = A, r
    if prior is not None and np.any(prior[0] > 0):
        pw, pc = prior
        keep = np.nonzero(pw > 0)[0]
        P = np.zeros((len(keep), A.shape[1]))
        P[np.arange(len(keep)), keep] = pw[keep]
        A_fit = np.vstack([A, P])
        r_fit = np.r_[r, -pw[keep] * (x_ref[keep] - pc[keep])]
    # the bounded solver on the triangular factor: ‖A·x − r‖² = ‖R·x − Qᵀr‖² + ‖r − QQᵀr‖² for A = QR, so
    # the same minimiser from k rows instead of thousands (each of the active-set solver's steps is a least
    # squares solve: 0.13 ms on 2100 × 12, a few µs on 12 × 12)
    q, rt = np.linalg.qr(A_fit)
    sol = lsq_linear(rt, q.T @ r_fit, bounds=(lb, ub), method="bvls" if A.shape[1] < 40 else "trf")
    res = r_fit - A_fit @ sol.x
    return x_ref + sol.x[:p], sol.x[p:], delta, float(res @ res), A


def prior_of(effects) -> tuple[np.ndarray, np.ndarray]:
    """(1/σ, centre) per parameter of ``effects``: the nominal parameters' regulariser (0 elsewhere)."""
    pw = [1.0 / s for e in effects for s in (e.prior_sigma or (math.inf,) * e.n)]
    pc = [c for e in effects for c in e.center]
    return np.asarray(pw, float), np.asarray(pc, float)


def prior_penalty(effects, x: np.ndarray) -> float:
    """Σ ((x − c)/σ)² of the nominal parameters among ``effects`` at ``x``."""
    pw, pc = prior_of(effects)
    return float(np.sum((pw * (np.asarray(x, float) - pc)) ** 2)) if len(pw) else 0.0


def _best_delta(prob, base, Q, rows, w, grid) -> float:
    """The shift of ``grid`` whose weighted residual off the span of ``Q`` (orthonormal columns, the fit's design
    matrix ``A`` on ``rows``) is least."""
    Y = (shift_measured(prob.y, prob.lay, grid) - base[:, None])[rows] * w[:, None]
    if Q.shape[1]:
        Y = Y - Q @ (Q.T @ Y)
    rss = np.einsum("ij,ij->j", Y, Y)
    return float(grid[int(np.argmin(rss))])


def _best_delta_all_rows(prob, base, Q, grid) -> float:
    """:func:`_best_delta` over all rows on the coarse grid: ‖P⊥(Y − b)‖² = ‖Y‖² − 2 bᵀY + ‖b‖² − ‖Qᵀ(Y − b)‖²,
    the products with the shifted features Y(δ) by FFT over δ (:meth:`Problem.shifted_products`)."""
    bw = base * prob.w
    F = prob.shifted_products(np.column_stack([bw, Q]))
    rss = prob.shifted_w_sq - 2.0 * F[0] + bw @ bw
    if Q.shape[1]:
        P = F[1:] - (Q.T @ bw)[:, None]
        rss = rss - np.einsum("ij,ij->j", P, P)
    return float(grid[int(np.argmin(rss))])


def bic(rss: float, n: int, k: int) -> float:
    return n * math.log(max(rss, 1e-300) / n) + k * math.log(n)


def _intervals(A: np.ndarray, rss: float, p: int, x: np.ndarray, pw: np.ndarray | None = None):
    n, k = A.shape
    s2 = rss / max(n - k - 1, 1)
    N = A.T @ A
    if pw is not None and p:
        N[np.arange(p), np.arange(p)] += np.where(np.isfinite(pw), pw, 0.0) ** 2
    try:
        cov = s2 * np.linalg.pinv(N)
    except np.linalg.LinAlgError:
        cov = np.full((k, k), np.inf)
    return cov[:p, :p]


def bounds(effects) -> tuple[np.ndarray, np.ndarray]:
    if not effects:
        return np.zeros(0), np.zeros(0)
    return np.concatenate([e.lower for e in effects]), np.concatenate([e.upper for e in effects])


def make_candidate(effects, x, nu, d, rss, A, n, n_nuis, model_features, *, refined, response=None, note="",
                   jacobian=None, box=None, base=None):
    """A :class:`Candidate` from a fit (intervals from the linearised covariance, the nominal
    parameters' regulariser included)."""
    p = len(x)
    k = p + n_nuis + 1
    cov = _intervals(A, rss, p, x, prior_of(effects)[0] if p else None)
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
    lo, hi = box if box is not None else bounds(effects)
    return Candidate(tuple(effects), x, interval, tuple(mags), tuple(mag_iv), d, nu, rss, k, bic(rss, n, k), refined,
                     tuple(names_at_bound), model_features, response, note=note, jacobian=jacobian, lower=lo,
                     upper=hi, base_features=None if base is None else base[1],
                     base_x=None if base is None else base[0])


@dataclass(frozen=True, eq=False)
class Sensitivities:
    """Secant sensitivities (features per unit parameter) by effect name: ``plus`` from +step
    (central ones for ``central`` effects), ``minus`` from −step for ``two_sided`` effects."""

    plus: dict
    minus: dict
    responses: dict = field(default_factory=dict)  # fidelity effects: the response at their step
    coupling: dict = field(default_factory=dict)  # coupled effects: (fidelity effect, n × k change per unit share·x)
    base: dict = field(default_factory=dict)  # the point (name → x) the fidelity effects were measured about; none: nominal
    corners: dict = field(default_factory=dict)  # ``corners`` effects: (sign, sign) → (corner x, feature change there)

    def __contains__(self, name: str) -> bool:
        return name in self.plus

    def change_at(self, name: str, x) -> np.ndarray:
        """The linearised feature change of effect ``name`` at its parameters ``x``: each parameter by the
        secant of its side (the −step secant for a negative value of a two-sided parameter)."""
        x = np.asarray(x, float)
        J = self.plus[name].copy()
        if name in self.minus:
            neg = x < 0
            J[:, neg] = self.minus[name][:, neg]
        return J @ x

    def orthants(self, effects, corners: bool = False) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """(J, lower, upper) per sign pattern of the two-sided parameters of ``effects``: the +step
        secant with the bounds [0, high] and the −step secant with [low, 0]; one entry with the
        full bounds when no parameter is two-sided.

        ``corners``: instead, the sign patterns of an effect with a model run at their corner (h₁, h₂)
        (signed steps, ``Effect.corners``), each with one column in turn replaced so that the secants pass
        through that corner (J₁h₁ + J₂h₂ = ΔF there, the other column kept): the response along a diagonal on
        which the two parameters nearly cancel (empty when no effect has corners)."""
        per_effect = [self._effect_orthants(e) for e in effects]
        out = []
        for combo in itertools.product(*per_effect):
            if corners != any(c for _, _, _, c in combo):
                continue
            out.append((np.column_stack([J for J, _, _, _ in combo]), np.concatenate([lo for _, lo, _, _ in combo]),
                        np.concatenate([hi for _, _, hi, _ in combo])))
        return out

    def _effect_orthants(self, e: Effect) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, bool]]:
        """(J, lower, upper, through a corner) of one effect (see :meth:`orthants`)."""
        plus, minus = self.plus[e.name], self.minus.get(e.name)
        lo_all = np.array([p.low for p in e.params])
        hi_all = np.array([p.high for p in e.params])
        if minus is None:
            return [(plus, lo_all, hi_all, False)]
        out = []
        at = self.corners.get(e.name, {})
        for signs in itertools.product((1.0, -1.0), repeat=e.n):
            neg = np.array(signs) < 0
            J = np.where(neg[None, :], minus, plus)
            lo, hi = np.where(neg, lo_all, 0.0), np.where(neg, 0.0, hi_all)
            if not np.all(lo < hi):
                continue
            out.append((J, lo, hi, False))
            if signs in at:
                h, df = at[signs]  # the corner (signed steps) and the feature change there
                for j in range(e.n):
                    Jc = J.copy()
                    Jc[:, j] = (df - np.delete(J, j, axis=1) @ np.delete(h, j)) / h[j]
                    out.append((Jc, lo, hi, True))
        return out


# ----------------------------------------------------------------------------- the diagnosis
def weights(f0: np.ndarray, y: np.ndarray, lay: Layout, s: DiagnosisSettings, pin_count: int = 0) -> np.ndarray:
    """1/floor per feature: TE orders by the measurement's noise, ``order_floor_arcsec`` and
    ``order_floor_rel`` of the amplitude, the pin-mesh orders (multiples of ``pin_count``) also by
    ``mesh_order_floor_rel`` of theirs; wind-ups and torque-cycle angles by the wind-up floors."""
    w = np.empty(lay.n)
    mesh = (np.arange(1, lay.max_order + 1) % pin_count == 0) if pin_count else np.zeros(lay.max_order, bool)
    for r in lay.te_runs:
        # the measurement's noise floor: median coefficient size over the upper half of the orders
        a, b = y[lay.cos[r]], y[lay.sin[r]]
        half = slice(len(a) // 2, None)
        noise = float(np.median(np.hypot(a[half], b[half]))) / 1.18  # Rayleigh median → σ
        # optional model-form share of an order's amplitude (the larger of measured and nominal; default 0:
        # measured on the self-checks, any share lost more effects than it saved)
        amp = np.maximum(np.hypot(a, b), np.hypot(f0[lay.cos[r]], f0[lay.sin[r]]))
        rel = np.where(mesh, np.hypot(s.order_floor_rel, s.mesh_order_floor_rel), s.order_floor_rel)
        floor = np.sqrt(s.order_floor_arcsec**2 + noise**2 + (rel * amp) ** 2)
        w[lay.cos[r]] = w[lay.sin[r]] = 1.0 / floor
        w[lay.dc[r]] = 1.0 / (s.windup_floor_arcsec + s.windup_floor_rel * abs(f0[lay.dc[r]]))
    for _r, sl in lay.hyst.items():
        w[sl] = 1.0 / (s.windup_floor_arcsec + s.windup_floor_rel * np.abs(f0[sl] - np.mean(f0[sl])))
    return w


MODEL_NOISE_K = 3.0  # an order's model change below this many times the run's numerical noise is not signature


def denoise_orders(df: np.ndarray, lay: Layout, k: float = MODEL_NOISE_K) -> np.ndarray:
    """A model feature change (or columns of changes) with its TE order coefficients below
    MODEL_NOISE_K times the model's own numerical noise set to zero. The noise of each TE run is
    estimated like the measurement's (median over the upper half of the orders): a clearance that lets
    a disc float in its bearing leaves ~0.1″ of solver noise on every order, which the tight order
    floors would otherwise read as a signature hundreds of floors strong."""
    out = np.array(df, float, copy=True)
    two = out.ndim == 2
    cols = out if two else out[:, None]
    for r in lay.te_runs:
        a, b = cols[lay.cos[r]], cols[lay.sin[r]]
        amp = np.hypot(a, b)
        half = amp[amp.shape[0] // 2:]
        noise = np.median(half, axis=0) / 1.18
        small = amp < k * noise[None, :]
        a[small] = 0.0
        b[small] = 0.0
        cols[lay.cos[r]], cols[lay.sin[r]] = a, b
    return out if two else cols[:, 0]


def split_params(effects, x) -> list[tuple[Effect, np.ndarray]]:
    out, i = [], 0
    for e in effects:
        out.append((e, np.asarray(x[i:i + e.n], float)))
        i += e.n
    return out

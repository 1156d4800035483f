"""Settings of a diagnosis (:class:`DiagnosisSettings`): the analysed orders, which follow the bench's
sampling, the alias-free model grid, the evidence model and the floors of the residuals."""

from __future__ import annotations

import dataclasses as dc
from dataclasses import dataclass

from rvflex.choices import EvidenceModel, check_choice

__all__ = ["DEFAULT_MAX_ORDER", "MAX_ORDER_CAP", "DiagnosisSettings", "alias_free_positions",
           "aliasing_problem", "orders_resolved"]


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
    one_period : bool
        A TE run of a model that repeats itself every pin pitch of the output (no error fixed to the pins, the pin
        ring or the input; :func:`~rvflex.diagnosis.replay.one_period`) is solved at the grid's distinct positions
        within one pitch and repeated (True, default: an eighth of the steps for the RV-40E at 576 positions, the same
        TE within the solver's tolerance). False: every run over the whole revolution.
    hysteresis_steps : int
        Equal torque steps of the replayed torque cycle (plus the fine ±0.5…4 % points).
    workers : int
        Process-pool size for the sensitivity and refinement runs (1: serial).
    refine_top : int
        Candidates refined with model-in-the-loop (Broyden) iterations.
    also_refine : tuple of str
        Candidates refined with the model in the loop whatever their rank, by name (a pair as
        ``"a + b"``; a name no candidate has is ignored). The null distribution's build sets it so that a
        control's fit that sets a threshold is measured as a finding is (:func:`rvflex.diagnosis.null.unrefined_setters`).
    refine_iterations : int
        Most model evaluations per refined candidate; after the second, a candidate stops once
        an evaluation lowers its residual by less than ``refine_min_gain`` (or its step converges).
    refine_min_gain : float
        Relative residual decrease an evaluation must bring to go on refining (fraction).
    pair_top : int or None
        None: every pair of effects is fitted; an int: only pairs with one of the best
        ``pair_top`` single effects.
    nominal_start : bool
        A candidate without evidence about the calibrated model is linearised also about the anchored
        nominal model, where that linearisation does not promise the calibration alone more than its model
        run gave; the fit is kept when it is better by ``bic_threshold`` and refined beside the other (True,
        default). False: about the calibrated model alone.
    evidence_model : {"discrepancy", "bic"}
        How an effect's evidence is measured against the calibrated model. "discrepancy" (default):
        against a model discrepancy with its own variance per order band and run, profiled
        (:mod:`rvflex.diagnosis.discrepancy`); "bic": one variance for every feature (the plain BIC)
        plus the ``min_shrink_pct`` rule (the rule before the discrepancy model, kept to compare).
    discrepancy_pooling : float or None
        Prior degrees of freedom ν that shrink each group's discrepancy variance toward the calibrated
        model's pooled one (0: each group's own, profiled). None (default): one pooled variance for all
        groups, ν → ∞ (measured, docs/diagnosis.md: on 35 benches 27 named against 25 with the groups'
        own variances and 25 with the former single-variance BIC and its 25 % shrink rule; with 7 far
        self-check benches 30 of 41 against the former rule's 27, one control of 10 missed).
    bic_threshold : float
        Minimum evidence over "no effect" (2 log Bayes factor in BIC's approximation) for an effect
        to count (dimensionless; 10: very strong).
    min_shrink_pct : float
        With ``evidence_model="bic"``: minimum share of the gap (weighted rms) an accepted effect
        removes (%). Both models: what a pair's second effect must remove of what the better single
        leaves, and the share that makes calibration alone "nominal parameters off".
    min_withheld_pct : float
        Minimum improvement of the withheld runs' prediction for acceptance (%).
    confirming_folds : int or None
        The other way the withheld runs confirm an effect: at least this many withheld folds each
        predicted better with evidence ≥ ``bic_threshold`` against the pooled discrepancy, no fold
        predicted worse by as much, and the pooled prediction better at all. The pooled improvement is
        dominated by the fold with the most model-form residual (the TE runs' ripple), so an effect
        whose signature lies in the torque cycle (friction, a series compliance) could not reach
        ``min_withheld_pct`` however well it predicts both halves of the cycle. None: only
        ``min_withheld_pct``.
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
    null_distribution : str or None
        The null distribution a finding must exceed to be established (:mod:`rvflex.diagnosis.null`):
        ``"builtin"`` (default) the one shipped with the package, a path to another, or None for none
        (``rvflex null-distribution`` builds it with none).
    """

    positions_per_rev: int | None = None
    max_order: int | None = None
    one_period: bool = True
    hysteresis_steps: int = 40
    workers: int = 2
    refine_top: int = 3
    also_refine: tuple[str, ...] = ()
    refine_iterations: int = 5
    refine_min_gain: float = 0.02
    pair_top: int | None = None
    nominal_start: bool = True
    evidence_model: EvidenceModel = "discrepancy"
    discrepancy_pooling: float | None = None
    bic_threshold: float = 10.0
    min_shrink_pct: float = 25.0
    min_withheld_pct: float = 10.0
    confirming_folds: int | None = 2
    eval_timeout_s: float = 60.0  # a run takes ~1 s at 448 positions; a loose unit's bisections many more
    order_floor_arcsec: float = 0.03
    order_floor_rel: float = 0.0
    mesh_order_floor_rel: float = 0.0
    windup_floor_arcsec: float = 0.5
    windup_floor_rel: float = 0.02
    null_distribution: str | None = "builtin"

    def __post_init__(self) -> None:
        k = DEFAULT_MAX_ORDER if self.max_order is None else self.max_order
        if self.positions_per_rev is not None and self.positions_per_rev < 2 * k + 2:
            raise ValueError(f"positions_per_rev = {self.positions_per_rev}: needs ≥ 2·max_order + 2 "
                             f"= {2 * k + 2}")
        check_choice("evidence_model", self.evidence_model, EvidenceModel)
        if k < 1 or self.hysteresis_steps < 8 or self.workers < 1:
            raise ValueError("max_order ≥ 1, hysteresis_steps ≥ 8 and workers ≥ 1 are required")
        if self.confirming_folds is not None and self.confirming_folds < 1:
            raise ValueError(f"confirming_folds = {self.confirming_folds}: needs ≥ 1 (None: the pooled rule alone)")

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

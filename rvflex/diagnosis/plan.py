"""The plan of a diagnosis: every bench run becomes a :class:`PlanRun` (direction, load, torque cycle,
temperature) that the model is run under, and the :class:`Layout` of the feature vector both sides are
reduced to (:mod:`rvflex.diagnosis.features`), and the folds of the withheld check (:func:`withheld_folds`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rvflex.choices import RunKind
from rvflex.diagnosis.settings import DiagnosisSettings

__all__ = ["BRANCH_FRACTIONS", "HYST_FRACTIONS", "Layout", "PlanRun", "feature_layout", "part_label", "plan_from_dataset",
           "withheld_folds", "withheld_split"]

HYST_FRACTIONS = np.array([0.02, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.97])
BRANCH_FRACTIONS = np.concatenate([-HYST_FRACTIONS[::-1], HYST_FRACTIONS])
"""The torques (shares of the amplitude, increasing) at which each torque-cycle branch is read."""


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

    def part_rows(self, part: tuple[int, int]) -> np.ndarray:
        """Feature indices of a run part (run, side): side 0 the whole run; +1 / −1 the positive- / negative-torque
        half of a torque cycle (both branches at the torques of that sign)."""
        r, side = part
        if side == 0:
            return self.run_rows(r)
        half = np.flatnonzero(np.sign(BRANCH_FRACTIONS) == side)
        return self.hyst[r].start + np.r_[half, half + len(BRANCH_FRACTIONS)]


def part_label(plan, part: tuple[int, int]) -> str:
    """The label of a run part (see :meth:`Layout.part_rows`)."""
    r, side = part
    return plan[r].label + {0: "", 1: " (T > 0)", -1: " (T < 0)"}[side]


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


def feature_layout(plan: tuple[PlanRun, ...], max_order: int) -> Layout:
    """Where each run's features sit (:class:`Layout`) for ``plan`` at orders 1 … ``max_order``."""
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


def withheld_folds(plan: tuple[PlanRun, ...]) -> tuple[tuple[tuple[tuple[int, int], ...], tuple[tuple[int, int], ...]], ...]:
    """The folds of the withheld check, each (fitted parts, predicted parts) of runs (run, side: 0 the whole
    run, ±1 a torque cycle's positive / negative-torque half, :meth:`Layout.part_rows`);
    nothing is predicted twice. Fold 1 is :func:`withheld_split` (the other TE runs predicted from the forward
    TE run at the highest load and the torque cycles); then each torque cycle's halves predict each other, with
    the TE runs fitted too: an effect whose evidence lies in the torque cycle (friction's loop, a clearance's
    free play, the curve's stiffening) is confirmed on the half it was not fitted on, and one read from the
    TE runs must predict both halves. Folds with nothing to fit or to predict are left out."""
    folds = []
    fitted, predicted = withheld_split(plan)
    if fitted and predicted:
        folds.append((tuple((r, 0) for r in fitted), tuple((r, 0) for r in predicted)))
    te = tuple((r, 0) for r, p in enumerate(plan) if p.kind == "te")
    for h in (r for r, p in enumerate(plan) if p.kind != "te"):
        for side in (1, -1):
            folds.append((te + ((h, side),), ((h, -side),)))
    return tuple(folds)

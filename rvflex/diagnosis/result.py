"""The result of a diagnosis (:class:`Diagnosis`): what :func:`rvflex.diagnosis.fit.diagnose` found, its
tables for pandas, its plot and its report."""

from __future__ import annotations

import dataclasses as dc
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rvflex.diagnosis.anchor import Anchor
from rvflex.diagnosis.calibration import (
    separable,
)
from rvflex.diagnosis.discrepancy import Discrepancy
from rvflex.diagnosis.linear import (
    Candidate,
    Sensitivities,
)
from rvflex.diagnosis.plan import Layout, PlanRun
from rvflex.diagnosis.replay import Response
from rvflex.diagnosis.settings import DiagnosisSettings

__all__ = ["Diagnosis"]


@dataclass(frozen=True, eq=False)
class Diagnosis:
    """Everything a diagnosis found (see :func:`diagnose`); :mod:`rvflex.diagnosis.report` turns it
    into the report and the JSON document. ``baseline`` is the *calibrated* nominal model (its
    ``calibrated`` parameters), the reference of every candidate's score; ``nominal_model`` the
    model as specified."""

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
    withheld_runs: tuple  # the folds: (fitted, predicted) run parts (run, side), see withheld_folds
    unavailable: dict
    failed: dict
    signature_size: dict
    verdict: str
    model_runs: int
    wall_s: float
    ties: tuple[str, ...] = ()
    nominal_model: Candidate | None = None  # the uncalibrated nominal model (the gap before calibration)
    windows: dict = dc.field(default_factory=dict)  # per TE run: the analysed window and its fit figures
    calibration_ties: tuple[str, ...] = ()  # nominal parameters that can mimic the accepted effect
    separating_runs: tuple[str, ...] = ()  # runs that would separate such a tie
    undetermined: dict = dc.field(default_factory=dict)  # nominal parameters the runs do not determine: why
    anchor: Anchor = dc.field(default_factory=Anchor)  # the global stiffness scale the calibration starts from
    discrepancy: Discrepancy | None = None  # what the calibrated model leaves, per order band and run
    lookalikes: dict = dc.field(default_factory=dict)  # effects the calibration can stand in for (see calibration_lookalikes)
    sensitivities: Sensitivities | None = None  # the secants the candidates were fitted with (about the anchored model)
    part_ties: tuple = ()  # part errors no candidate models that TE cannot tell from the accepted effect (grade.part_ties)

    def observability(self, name: str, x) -> tuple[float, float]:
        """How well these runs can see candidate effect ``name`` at parameters ``x``.

        Measured on the self-checks' misses: a hidden series compliance
        mostly leaves under 7 floor units separable, a modification deviation drawn along its
        near-cancelling direction 9 to 21.

        Parameters
        ----------
        name : str
            A candidate effect of this diagnosis.
        x : array_like
            Its parameters, in their units (m, rad, 1/K, …).

        Returns
        -------
        tuple of float
            Its linearised signature in floor units (the weighted norm of the feature change by its
            secants) and the part of it the calibrated nominal parameters cannot reproduce within their
            prior ranges (:func:`~rvflex.diagnosis.calibration.separable`): the part these runs can tell
            from a calibration. NaN, NaN for an effect without sensitivities here.

        Raises
        ------
        ValueError
            ``x`` does not have the effect's number of parameters.
        """
        if self.sensitivities is None or name not in self.sensitivities:
            return math.nan, math.nan
        x = np.asarray(x, float)
        k = self.sensitivities.plus[name].shape[1]
        if x.shape != (k,):
            raise ValueError(f"x = {x.tolist()}: {name} has {k} parameters")
        return separable(self.sensitivities.change_at(name, x), self.baseline, self.sensitivities, self.weights)

    def to_dataframe(self, table: str = "ranking"):
        """One of the diagnosis's tables as a tidy pandas DataFrame.

        Parameters
        ----------
        table : {"ranking", "gap", "calibration"}, optional
            ``"ranking"`` (default): one row per candidate effect, best first: name, score (BIC
            improvement), gap shrink (%), withheld improvement (%), accepted, refined, and each
            parameter in SI (unit in the column name). ``"gap"``: per run and metric, the measured
            value, the nominal model's, the calibrated model's and the model's with the accepted
            effect (unit in the ``unit`` column). ``"calibration"``: the calibrated nominal
            parameters with their intervals.

        Returns
        -------
        pandas.DataFrame
            The table.
        """
        import pandas as pd

        from rvflex.diagnosis.report import json_document

        if table == "ranking":
            rows = []
            for c in self.candidates:
                row = {"effect": c.name, "score": c.score, "gap_shrink_pct": c.gap_shrink_pct,
                       "withheld_improvement_pct": c.withheld.get("improvement_pct"), "accepted": c.accepted,
                       "refined": c.refined}
                row.update({f"{n} [{u}]": float(v) for n, u, v in zip(c.param_names, c.units, c.x)})
                rows.append(row)
            return pd.DataFrame(rows)
        doc = json_document(self)
        if table == "calibration":
            return pd.DataFrame(doc["calibration"])
        if table == "gap":
            rows = []
            for b, cal, a in zip(doc["gap_before"]["metrics"], doc["gap_calibrated"]["metrics"],
                                 doc["gap_after"]["metrics"]):
                rows.append({k: b[k] for k in ("run", "direction", "load_Nm", "temperature_C", "metric", "unit",
                                               "measured")}
                            | {"nominal_model": b["model"], "calibrated": cal["model"], "after": a["model"]})
            return pd.DataFrame(rows)
        raise ValueError(f"table = {table!r}: must be 'ranking', 'gap' or 'calibration'")

    def plot(self, ax=None, run: int | None = None):
        """Plot one bench run against the model, as the report's figures do.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw (default: a new :class:`matplotlib.figure.Figure`; pyplot is not used).
        run : int, optional
            Index of the bench run (``dataset.runs``; default: the first TE run, else the first
            torque cycle). A TE run is drawn as TE (arcsec) over the output position (°):
            measured, with the fitted offset and encoder origin removed, the calibrated model and
            the model with the accepted effect; a torque cycle as torque (N·m) over the output
            angle (arcmin).

        Returns
        -------
        matplotlib.axes.Axes
            The axes drawn on.
        """
        from rvflex.diagnosis.plots import draw_run

        if run is None:
            run = self.layout.te_runs[0] if self.layout.te_runs else min(self.layout.hyst)
        if not (isinstance(run, int) and 0 <= run < len(self.plan)):
            raise ValueError(f"run = {run!r}: must be a run index, 0 … {len(self.plan) - 1}")
        if ax is None:
            from matplotlib.figure import Figure

            ax = Figure(figsize=(8, 3.2), layout="constrained").subplots()
        draw_run(ax, self, run)
        ax.legend(fontsize=8)
        return ax

    def write(self, out: str | Path) -> list[Path]:
        """Write the report of ``rvflex diagnose --out``: report.md, diagnosis.json and the plots (PNG).

        Parameters
        ----------
        out : str or os.PathLike
            The folder (created when missing); every file is computed first and written
            through a temporary name.

        Returns
        -------
        list of pathlib.Path
            The files written.
        """
        from rvflex.diagnosis.report import write_report

        return write_report(self, out)

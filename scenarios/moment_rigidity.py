"""Moment rigidity: the output's tilt against a tilting moment, of the unit and of its main bearing pair alone.

The pair alone (``model="pair"``): the output carrier is a rigid body on the two preloaded angular-contact rows of
``spec.bearings.main_pair`` (:mod:`rvflex.contact.angular_contact`: Hertz ball contacts, loaded
contact angles, contact loss). A moment about an axis across the reducer axis is stepped from 0
to ±M (M: the allowable moment unless given) and the tilt solved at each step. The figure is
the secant over the whole range, 2M / (θ(+M) − θ(−M)) in N·m/arcmin, the slope of the straight
line through the curve's ends; the tangent at zero moment (the preloaded pair's small-moment
rigidity) is reported beside it. What the figure includes: the main bearing's ball contacts
only; rings, carrier and housing are rigid.

The unit (``model="unit"``, the default): the spatial rigid reducer (:meth:`rvflex.options.ModelOptions.spatial_rigid`,
:data:`rvflex.tilt.MOMENT_SLICES` face slices) is solved by :func:`rvflex.solve.quasi_static` at one crank position
under a torque (the rated torque unless given) with the moment on its carrier (:class:`rvflex.tilt.OutputLoad`),
stepped 0 → ±M in a few steps; the tilt is the solved carrier tilt. The gear train (pins, discs, cranks) resists
the tilt in parallel with the pair, so the unit's secant over the same ±M is the pair's or a little more. The
secant cancels the small tilt the gear train's own couple gives under torque at zero moment. Rings, carrier,
housing and gear parts are rigid here too.

    python -m rvflex.scenarios.moment_rigidity --table docs/results/moment_rigidity.md
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rvflex.contact.angular_contact import PairLoad, PairModel, PairState, pair_model, solve
from rvflex.io import save_figure, write_json, write_text
from rvflex.result import new_axes
from rvflex.spec import ReducerSpec, SpecError
from rvflex.units import ARCMIN

MODELS = ("unit", "pair")
"""What carries the moment: the spatial unit (gear train and pair) or the main bearing pair alone."""

__all__ = ["MomentRigidity", "MomentRigidityMetrics", "MomentRigidityResult", "register", "table", "main"]

PRELOAD_FACTORS = (0.5, 1.0, 2.0)
"""Preload multiples of the documented sensitivity table."""


@dataclass(frozen=True)
class MomentRigidity:
    """Moment rigidity of the unit's output, or of its main bearing pair alone (``rvflex moment-rigidity``).

    The default is the unit: a maker's catalogue states the moment rigidity of the whole reducer, the output's
    tilt with the gear train in place, so that is the figure to set beside it. The pair alone (the gear train
    left out) is computed in either case, costs 0.05 s against the unit's fraction of a second, and bounds the
    unit's figure from below.

    Parameters
    ----------
    spec : ReducerSpec
        The reducer; needs ``bearings.main_pair`` and ``allowable_moment_Nm``.
    moment_Nm : float, optional
        Largest moment of the sweep, N·m, in (0, allowable]; None: the allowable moment.
    steps : int, optional
        Moment steps on each side of zero (count, at least 4).
    phase_rad : float, optional
        Direction of the moment axis from the x axis, rad; the balls stand at multiples of
        2π/balls_per_row from it (0: a ball on the tilt axis).
    model : {"unit", "pair"}, optional
        What carries the moment and gives ``metrics.moment_rigidity_Nm_per_arcmin``: the spatial unit (the
        default) or the main bearing pair alone.
    torque_Nm : float, optional
        Output torque of the unit's solves, N·m (≥ 0); None: the rated torque. At zero torque the gear train
        carries no tilt where its backlash is open, and the unit's figure is the pair's.
    unit_steps : int, optional
        Moment steps of the unit on each side of zero (count, at least 1): each is one static solve.
    input_angle_rad : float, optional
        The crank position of the unit's solves (input angle, rad).

    Raises
    ------
    SpecError
        A spec without the pair or an allowable moment, a moment beyond the allowable or not
        positive, too few steps, an unknown model, a negative torque: one line naming the field.
    """

    spec: ReducerSpec
    moment_Nm: float | None = None
    steps: int = 40
    phase_rad: float = 0.0
    model: str = "unit"
    torque_Nm: float | None = None
    unit_steps: int = 4
    input_angle_rad: float = 0.0

    def __post_init__(self) -> None:
        if not isinstance(self.spec, ReducerSpec):
            raise TypeError(f"MomentRigidity.spec: expected a ReducerSpec, got {type(self.spec).__name__}")
        if self.spec.bearings.main_pair is None:
            raise SpecError("bearings.main_pair", None,
                            f"{self.spec.name} gives no main bearing pair geometry: add a [bearings.main_pair] "
                            "table (docs/spatial.md)")
        if self.moment_Nm is None and self.spec.allowable_moment_Nm is not None:
            object.__setattr__(self, "moment_Nm", self.spec.allowable_moment_Nm)
        self.spec.check_moment("moment_Nm", self.moment_Nm)  # also refuses a spec without an allowable moment
        if not (isinstance(self.steps, int) and self.steps >= 4):
            raise SpecError("steps", self.steps, "must be an integer of at least 4")
        if not math.isfinite(self.phase_rad):
            raise SpecError("phase_rad", self.phase_rad, "must be a finite angle in radians")
        if self.model not in MODELS:
            raise SpecError("model", self.model, f"must be one of {', '.join(MODELS)}")
        if self.torque_Nm is None:
            object.__setattr__(self, "torque_Nm", float(self.spec.rated_torque_Nm))
        if not (isinstance(self.torque_Nm, (int, float)) and math.isfinite(self.torque_Nm) and self.torque_Nm >= 0):
            raise SpecError("torque_Nm", self.torque_Nm, "must be a finite output torque of at least 0 N·m")
        if not (isinstance(self.unit_steps, int) and self.unit_steps >= 1):
            raise SpecError("unit_steps", self.unit_steps, "must be an integer of at least 1")
        if not math.isfinite(self.input_angle_rad):
            raise SpecError("input_angle_rad", self.input_angle_rad, "must be a finite angle in radians")
        if self.model == "unit":
            self.spec.check_spatial("model \"unit\"")

    def run(self) -> MomentRigidityResult:
        """Solve the tilt at every moment step.

        Returns
        -------
        MomentRigidityResult
            The curve and its figures.
        """
        t0 = time.perf_counter()
        model = pair_model(self.spec.bearings.main_pair)
        axis = np.array([math.cos(self.phase_rad), math.sin(self.phase_rad)])
        side = np.linspace(0.0, self.moment_Nm, self.steps + 1)
        moments = np.concatenate([-side[:0:-1], side])
        states: dict[int, PairState] = {}
        for direction in (1, -1):  # continuation outward from zero on each side
            start = None
            for k in range(self.steps + 1):
                i = self.steps + direction * k
                state = solve(model, PairLoad(moment_Nm=tuple(moments[i] * axis)), start=start)
                states[i] = state
                start = state.q
        ordered = [states[i] for i in range(len(moments))]
        tilt = np.array([s.q[3:5] @ axis for s in ordered])
        loss = _contact_loss_moment(model, axis, float(moments[-1]), ordered[-1])
        unit_moments = unit_tilt = None
        if self.model == "unit":
            unit_moments, unit_tilt = self._unit_curve(axis)
        metrics = _metrics(self, model, moments, tilt, ordered, loss, unit_tilt)
        return MomentRigidityResult(self, metrics, moments, tilt, np.array([s.peak_pressure_Pa.max() for s in ordered]),
                                    np.array([s.balls_in_contact for s in ordered]), model.n_balls,
                                    time.perf_counter() - t0, unit_moments, unit_tilt)

    def _unit_curve(self, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Moments −M … +M (N·m) and the spatial unit's solved carrier tilt about ``axis`` at each (rad)."""
        from rvflex.model import build_reducer
        from rvflex.options import ModelOptions
        from rvflex.solve import quasi_static
        from rvflex.tilt import MOMENT_SLICES, OutputLoad

        reducer = build_reducer(self.spec, options=ModelOptions.spatial_rigid(MOMENT_SLICES))
        side = np.linspace(0.0, self.moment_Nm, self.unit_steps + 1)
        moments = np.concatenate([-side[:0:-1], side])
        tilt = np.empty_like(moments)
        theta = np.array([self.input_angle_rad])
        for i, m in enumerate(moments):
            # each solve loads the unit afresh (torque and moment ramped together), so the steps are independent
            r = quasi_static(reducer, theta, self.torque_Nm,
                             output_load=OutputLoad(moment_Nm=float(m), moment_angle_rad=self.phase_rad))
            tilt[i] = r.carrier_tilt_rad[0] @ axis
        return moments, tilt


@dataclass(frozen=True)
class MomentRigidityMetrics:
    """The figures of a moment-rigidity run.

    Parameters
    ----------
    moment_rigidity_Nm_per_arcmin : float
        Secant over the sweep, 2M / (θ(+M) − θ(−M)), N·m/arcmin, of the scenario's model.
    model : str
        The model of that figure: "unit" or "pair".
    unit_moment_rigidity_Nm_per_arcmin : float or None
        The spatial unit's secant, N·m/arcmin (None: model "pair").
    pair_moment_rigidity_Nm_per_arcmin : float
        The main bearing pair's secant alone, N·m/arcmin.
    unit_torque_Nm : float or None
        Output torque of the unit's solves, N·m (None: model "pair").
    initial_moment_rigidity_Nm_per_arcmin : float
        Tangent at zero moment (the preloaded pair), N·m/arcmin.
    tilt_at_moment_arcmin : float
        Mean tilt magnitude at ±M of the pair alone, arcmin.
    moment_Nm : float
        M, the sweep's largest moment, N·m.
    peak_pressure_at_moment_Pa : float
        Largest ball contact pressure at ±M, Pa.
    contact_loss_moment_Nm : float or None
        Moment at which the first ball of the pair unloads, N·m (None: every ball stays loaded up to M).
    preload_N : float
        Axial preload of each row, N.
    catalogue_moment_rigidity_Nm_per_arcmin : float or None
        The maker's figure from the spec, N·m/arcmin (None: not sourced).
    """

    moment_rigidity_Nm_per_arcmin: float
    model: str
    unit_moment_rigidity_Nm_per_arcmin: float | None
    pair_moment_rigidity_Nm_per_arcmin: float
    unit_torque_Nm: float | None
    initial_moment_rigidity_Nm_per_arcmin: float
    tilt_at_moment_arcmin: float
    moment_Nm: float
    peak_pressure_at_moment_Pa: float
    contact_loss_moment_Nm: float | None
    preload_N: float
    catalogue_moment_rigidity_Nm_per_arcmin: float | None


def _contact_loss_moment(model: PairModel, axis: np.ndarray, m_end: float, end: PairState) -> float | None:
    """The moment (N·m) at which the first ball's squeeze reaches zero, by bisection on the
    smallest squeeze (continuous in the moment); None when every ball is loaded at ``m_end``."""
    from scipy import optimize

    if end.squeeze_m.min() > 0.0:
        return None

    def least(m: float) -> float:
        return float(solve(model, PairLoad(moment_Nm=tuple(m * axis))).squeeze_m.min())

    return float(optimize.brentq(least, 0.0, m_end, xtol=1e-4 * m_end))


def _metrics(sc: MomentRigidity, model: PairModel, moments, tilt, states, loss: float | None,
             unit_tilt) -> MomentRigidityMetrics:
    m_max, spec = float(moments[-1]), sc.spec
    pair = 2.0 * m_max / ((tilt[-1] - tilt[0]) / ARCMIN)
    unit = None if unit_tilt is None else 2.0 * m_max / ((unit_tilt[-1] - unit_tilt[0]) / ARCMIN)
    return MomentRigidityMetrics(
        moment_rigidity_Nm_per_arcmin=pair if unit is None else unit,
        model=sc.model,
        unit_moment_rigidity_Nm_per_arcmin=unit,
        pair_moment_rigidity_Nm_per_arcmin=pair,
        unit_torque_Nm=None if unit is None else float(sc.torque_Nm),
        initial_moment_rigidity_Nm_per_arcmin=states[len(moments) // 2].tilt_stiffness_Nm_rad() * ARCMIN,
        tilt_at_moment_arcmin=0.5 * (abs(tilt[-1]) + abs(tilt[0])) / ARCMIN,
        moment_Nm=m_max,
        peak_pressure_at_moment_Pa=float(max(states[0].peak_pressure_Pa.max(), states[-1].peak_pressure_Pa.max())),
        contact_loss_moment_Nm=loss,
        preload_N=model.pair.preload_N,
        catalogue_moment_rigidity_Nm_per_arcmin=spec.catalogue_moment_rigidity_Nm_per_arcmin,
    )


@dataclass(frozen=True, eq=False)
class MomentRigidityResult:
    """Tilt against moment of the output, on its main bearing pair and in the unit (:meth:`MomentRigidity.run`).

    Parameters
    ----------
    scenario : MomentRigidity
        What ran.
    metrics : MomentRigidityMetrics
        The figures.
    moment_Nm : numpy.ndarray
        Moments of the pair's sweep, −M … +M, N·m.
    tilt_rad : numpy.ndarray
        Tilt of the output on the pair alone about the moment's axis at each moment, rad.
    peak_pressure_Pa : numpy.ndarray
        Largest ball contact pressure at each moment, Pa.
    balls_in_contact : numpy.ndarray
        Balls carrying load at each moment (count).
    balls : int
        Balls of the pair (count).
    wall_s : float
        Wall time of the run, s.
    unit_moment_Nm : numpy.ndarray or None
        Moments of the unit's sweep, −M … +M, N·m (None: model "pair").
    unit_tilt_rad : numpy.ndarray or None
        The unit's solved carrier tilt about the moment's axis at each, rad (None: model "pair").
    """

    scenario: MomentRigidity
    metrics: MomentRigidityMetrics
    moment_Nm: np.ndarray
    tilt_rad: np.ndarray
    peak_pressure_Pa: np.ndarray
    balls_in_contact: np.ndarray
    balls: int
    wall_s: float
    unit_moment_Nm: np.ndarray | None = None
    unit_tilt_rad: np.ndarray | None = None

    def as_json(self) -> dict:
        """The JSON document of ``rvflex moment-rigidity --json``: figures, curve and inputs.

        Returns
        -------
        dict
            ``metrics`` (unit in each key; the unit's and the pair's figures), ``curve`` (the pair's:
            moment_Nm, tilt_arcmin, peak_pressure_Pa, balls_in_contact), ``unit_curve`` (moment_Nm,
            tilt_arcmin; None for model "pair"), ``inputs`` (reducer, main_pair with SI keys,
            allowable_moment_Nm, steps, phase_rad, model, torque_Nm, unit_steps, input_angle_rad,
            definition), ``wall_s``.
        """
        sc = self.scenario
        pair = dataclasses.asdict(sc.spec.bearings.main_pair)
        return {
            "reducer": sc.spec.name,
            "metrics": dataclasses.asdict(self.metrics),
            "curve": {"moment_Nm": self.moment_Nm.tolist(), "tilt_arcmin": (self.tilt_rad / ARCMIN).tolist(),
                      "peak_pressure_Pa": self.peak_pressure_Pa.tolist(),
                      "balls_in_contact": self.balls_in_contact.tolist(), "balls": self.balls},
            "unit_curve": None if self.unit_tilt_rad is None else
            {"moment_Nm": self.unit_moment_Nm.tolist(), "tilt_arcmin": (self.unit_tilt_rad / ARCMIN).tolist()},
            "inputs": {"main_pair": pair, "allowable_moment_Nm": sc.spec.allowable_moment_Nm,
                       "moment_Nm": sc.moment_Nm, "steps": sc.steps, "phase_rad": sc.phase_rad,
                       "model": sc.model, "torque_Nm": sc.torque_Nm, "unit_steps": sc.unit_steps,
                       "input_angle_rad": sc.input_angle_rad,
                       "definition": "secant 2M/(tilt(+M) - tilt(-M)); pair: ball contacts of the main bearing pair "
                                     "only (Hertz, preload, contact loss), rings, carrier and housing rigid; unit: "
                                     "the spatial rigid reducer at one crank position under torque_Nm, the solved "
                                     "carrier tilt (gear train and pair)"},
            "wall_s": self.wall_s,
        }

    def to_dataframe(self):
        """The curve as a table.

        Returns
        -------
        pandas.DataFrame
            Columns moment_Nm, tilt_arcmin, peak_pressure_Pa, balls_in_contact, one row per step.
        """
        import pandas as pd

        return pd.DataFrame({"moment_Nm": self.moment_Nm, "tilt_arcmin": self.tilt_rad / ARCMIN,
                             "peak_pressure_Pa": self.peak_pressure_Pa, "balls_in_contact": self.balls_in_contact})

    def plot(self, ax=None):
        """Tilt (arcmin) against moment (N·m) of the pair alone and, for model "unit", of the unit, with
        the secants and, where sourced, the maker's figure.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on; None draws on a new figure (pyplot is not touched).

        Returns
        -------
        matplotlib.axes.Axes
            The axes drawn on.
        """
        ax = new_axes(ax)
        met, name = self.metrics, self.scenario.spec.name
        tilt = self.tilt_rad / ARCMIN
        ends = np.array([self.moment_Nm[0], self.moment_Nm[-1]])
        ax.plot(self.moment_Nm, tilt, "o-", ms=2.5, lw=1.5, label=f"{name}: main bearing pair (Hertz, preload "
                                                                   f"{met.preload_N:g} N)")
        ax.plot(ends, ends / met.pair_moment_rigidity_Nm_per_arcmin, "--", lw=1,
                label=f"pair secant: {met.pair_moment_rigidity_Nm_per_arcmin:.0f} N·m/arcmin")
        if self.unit_tilt_rad is not None:
            ax.plot(self.unit_moment_Nm, self.unit_tilt_rad / ARCMIN, "s-", ms=4, lw=1.2, color="C3",
                    label=f"{name}: unit, gear train and pair (spatial, {met.unit_torque_Nm:g} N·m)")
            ax.plot(ends, ends / met.unit_moment_rigidity_Nm_per_arcmin, "--", lw=1, color="C3",
                    label=f"unit secant: {met.unit_moment_rigidity_Nm_per_arcmin:.0f} N·m/arcmin")
        if met.catalogue_moment_rigidity_Nm_per_arcmin:
            ax.plot(ends, ends / met.catalogue_moment_rigidity_Nm_per_arcmin, ":", color="k", lw=1.2,
                    label=f"maker's figure: {met.catalogue_moment_rigidity_Nm_per_arcmin:g} N·m/arcmin")
        if met.contact_loss_moment_Nm is not None:
            for sign in (-1, 1):
                ax.axvline(sign * met.contact_loss_moment_Nm, color="0.6", lw=0.8, ls="-.")
            ax.plot([], [], color="0.6", lw=0.8, ls="-.", label=f"first ball unloads: ±{met.contact_loss_moment_Nm:.0f} N·m")
        ax.axhline(0.0, color="0.85", lw=0.6)
        ax.axvline(0.0, color="0.85", lw=0.6)
        ax.set_xlabel("tilting moment on the output (N·m)")
        ax.set_ylabel("tilt of the output (arcmin)")
        ax.set_title(f"{name}: moment rigidity of the unit and its main bearing pair (parts rigid)")
        ax.legend(loc="upper left", fontsize=8)
        ax.grid(True, lw=0.3)
        return ax

    def write(self, out: str | Path) -> list[Path]:
        """Write ``moment_rigidity.png`` (the plot), ``moment_rigidity.csv`` (the curve) and
        ``moment_rigidity.json`` (:meth:`as_json`) into ``out``.

        Parameters
        ----------
        out : str or pathlib.Path
            Directory (created if missing).

        Returns
        -------
        list of pathlib.Path
            The files written.
        """
        out = Path(out)
        if out.exists() and not out.is_dir():
            raise SpecError("out", str(out), "exists and is not a directory")
        png = save_figure(self.plot().figure, out / "moment_rigidity.png", dpi=130)
        csv = write_text(out / "moment_rigidity.csv", self.to_dataframe().to_csv(index=False))
        js = write_json(out / "moment_rigidity.json", self.as_json())
        return [png, csv, js]

    def summary(self) -> str:
        """The one-paragraph report ``rvflex moment-rigidity`` prints.

        Returns
        -------
        str
            Figures with their units.
        """
        m = self.metrics
        maker = (f"maker's figure {m.catalogue_moment_rigidity_Nm_per_arcmin:g} N·m/arcmin"
                 if m.catalogue_moment_rigidity_Nm_per_arcmin else "no maker's figure in the spec")
        loss = (f"a ball unloads from {m.contact_loss_moment_Nm:.0f} N·m" if m.contact_loss_moment_Nm is not None
                else "every ball stays loaded")
        unit = ""
        if m.unit_moment_rigidity_Nm_per_arcmin is not None:
            unit = (f"moment rigidity of the unit {m.unit_moment_rigidity_Nm_per_arcmin:.0f} N·m/arcmin (secant over "
                    f"±{m.moment_Nm:g} N·m; spatial, {m.unit_torque_Nm:g} N·m, input angle "
                    f"{self.scenario.input_angle_rad:g} rad; {len(self.unit_moment_Nm)} solves), "
                    f"{m.unit_moment_rigidity_Nm_per_arcmin / m.pair_moment_rigidity_Nm_per_arcmin:.4f}× the pair's; ")
        pair = "the main bearing pair alone" if unit else "moment rigidity"
        return (f"{unit}{pair} {m.pair_moment_rigidity_Nm_per_arcmin:.0f} N·m/arcmin (secant over "
                f"±{m.moment_Nm:g} N·m), {m.initial_moment_rigidity_Nm_per_arcmin:.0f} N·m/arcmin at zero moment; "
                f"tilt {m.tilt_at_moment_arcmin:.3f}′ at {m.moment_Nm:g} N·m, peak ball pressure "
                f"{m.peak_pressure_at_moment_Pa / 1e9:.2f} GPa, {loss}; {maker} "
                f"({len(self.moment_Nm)} steps, {self.wall_s:.2f} s in all; pair: main bearing ball contacts only)")


# --------------------------------------------------------------------------- command and table


_FLAGS = {"moment_Nm": "--moment", "steps": "--steps", "model": "--model", "torque_Nm": "--torque"}


def register(sub) -> None:
    """Add ``rvflex moment-rigidity`` to the ``rvflex`` parser.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``rvflex`` sub-command parsers.
    """
    from rvflex import catalog

    p = sub.add_parser("moment-rigidity", help="tilt against tilting moment of the output, unit and main bearings",
                       description="The output carrier as a rigid body on the preloaded angular-contact main bearing "
                                   "pair of the spec ([bearings.main_pair]: Hertz ball contacts, loaded contact angles, "
                                   "contact loss); the moment is stepped 0 → ±M and the tilt solved. With --model unit "
                                   "(the default) the spatial rigid unit is also solved at one crank position under "
                                   "--torque with the moment on its carrier, in 4 steps each side, and its carrier "
                                   "tilt read (gear train in parallel with the pair). Prints the moment rigidity, the "
                                   "secant 2M/(θ(+M) − θ(−M)) in N·m/arcmin, of the unit and of the pair, and the "
                                   "pair's tangent at zero moment. Parts are rigid. JSON keys: reducer, metrics, curve, "
                                   "unit_curve, inputs, wall_s (docs/spatial.md).")
    p.add_argument("--reducer", required=True,
                   help=f"built-in reducer ({', '.join(catalog.names())}) or a spec TOML path with [bearings.main_pair] "
                        "and allowable_moment_Nm")
    p.add_argument("--moment", type=float, help="largest moment of the sweep, N·m (default: the allowable moment)")
    p.add_argument("--steps", type=int, default=40, help="the pair's moment steps on each side of zero (default 40)")
    p.add_argument("--model", choices=MODELS, default="unit",
                   help="the figure's model: the spatial unit (default; what a catalogue states) or the pair alone")
    p.add_argument("--torque", type=float, help="output torque of the unit's solves, N·m (default: the rated torque)")
    p.add_argument("--json", help="write the results as JSON to this path")
    p.add_argument("--out", help="directory for moment_rigidity.png, moment_rigidity.csv and moment_rigidity.json")
    p.set_defaults(func=_cmd, flags=_FLAGS)


def _cmd(args: argparse.Namespace) -> int:
    from rvflex import catalog
    from rvflex.io import emit

    spec = catalog.resolve(args.reducer)
    result = MomentRigidity(spec, args.moment, args.steps, model=args.model, torque_Nm=args.torque).run()
    print(result.summary())
    return emit(args, result.as_json(), result.write)


def table(names: list[str] | None = None) -> str:
    """The Markdown table of docs/spatial.md: each unit's moment rigidity, the spatial unit's (rated torque)
    beside its main bearing pair's, the pair's preload sensitivity and the maker's figure.

    Parameters
    ----------
    names : list of str, optional
        Built-in reducers (default all).

    Returns
    -------
    str
        The table, headed by the command that made it.
    """
    from rvflex import catalog

    rows = ["<!-- generated by `python -m rvflex.scenarios.moment_rigidity --table docs/results/moment_rigidity.md`; "
            "do not edit -->", "",
            "| unit | allowable moment | preload | unit at rated torque (secant ±M) | main bearing pair (secant ±M) | "
            "pair at zero moment | pair tilt at M | peak ball pressure at M | first ball unloads | "
            "pair secant at ½× / 2× preload | maker's figure |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    for name in names or catalog.names():
        spec = catalog.load(name)
        if spec.bearings.main_pair is None:
            continue
        figures = {}
        for factor in PRELOAD_FACTORS:
            pair = dataclasses.replace(spec.bearings.main_pair,
                                       preload_N=factor * spec.bearings.main_pair.preload_N)
            varied = dataclasses.replace(spec, bearings=dataclasses.replace(spec.bearings, main_pair=pair))
            figures[factor] = MomentRigidity(varied, model="unit" if factor == 1.0 else "pair").run().metrics
        m = figures[1.0]
        maker = (f"{m.catalogue_moment_rigidity_Nm_per_arcmin:g} N·m/arcmin"
                 if m.catalogue_moment_rigidity_Nm_per_arcmin else "not sourced")
        loss = "—" if m.contact_loss_moment_Nm is None else f"{m.contact_loss_moment_Nm:.0f} N·m"
        rows.append(f"| {name} | {m.moment_Nm:g} N·m | {m.preload_N:g} N | "
                    f"**{m.unit_moment_rigidity_Nm_per_arcmin:.0f} N·m/arcmin** | "
                    f"{m.pair_moment_rigidity_Nm_per_arcmin:.0f} N·m/arcmin | "
                    f"{m.initial_moment_rigidity_Nm_per_arcmin:.0f} N·m/arcmin | {m.tilt_at_moment_arcmin:.2f}′ | "
                    f"{m.peak_pressure_at_moment_Pa / 1e9:.2f} GPa | {loss} | "
                    f"{figures[0.5].pair_moment_rigidity_Nm_per_arcmin:.0f} / "
                    f"{figures[2.0].pair_moment_rigidity_Nm_per_arcmin:.0f} N·m/arcmin | {maker} |")
    return "\n".join(rows) + "\n"


def main(argv: list[str] | None = None) -> int:
    """``python -m rvflex.scenarios.moment_rigidity [--table PATH]``: print (or write) :func:`table`.

    Parameters
    ----------
    argv : list of str, optional
        Arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status 0.
    """
    p = argparse.ArgumentParser(prog="python -m rvflex.scenarios.moment_rigidity")
    p.add_argument("--table", help="write the Markdown table to this path (docs/results/moment_rigidity.md)")
    args = p.parse_args(argv)
    text = table()
    if args.table:
        write_text(args.table, text)
        print(f"wrote {args.table}")
    else:
        print(text, end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())

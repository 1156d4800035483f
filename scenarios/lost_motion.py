"""Torsional hysteresis test (input locked, output torque 0 → +T_r → −T_r → 0): lost motion,
hysteresis loss, torsional stiffness and backlash (the computation behind ``rvflex lost-motion``).

Run as a script for the catalogue RV-40E::

    python -m rvflex.scenarios.lost_motion out/
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rvflex.geometry.formulas import ARCSEC_PER_RAD
from rvflex.metrics import HysteresisMetrics, hysteresis_metrics
from rvflex.model import ReducerModel
from rvflex.options import ModelOptions
from rvflex.result import Result, new_axes, scenario_attrs, spatial_variables, variable
from rvflex.scenarios.common import OutputLoaded, check_model, check_scenario_inputs
from rvflex.solve import TorqueStepResult, hysteresis_cycle, torque_stepping
from rvflex.spec import ErrorSpec, ReducerSpec, SpecError
from rvflex.tilt import OutputLoad

__all__ = ["LostMotion", "LostMotionResult", "run_lost_motion", "write_lost_motion_outputs"]


@dataclass(frozen=True)
class LostMotion(OutputLoaded):
    """The catalogue torsional test (``rvflex lost-motion``): input locked, output torque
    0 → +T → −T → 0; lost motion, hysteresis loss, torsional stiffness and backlash.

    Parameters
    ----------
    spec : ReducerSpec
        The reducer (:func:`rvflex.load_reducer`).
    errors : ErrorSpec, optional
        Manufacturing and assembly errors (:func:`rvflex.load_errors`); None: none.
    torque_Nm : float, optional
        Torque amplitude T, N·m; None: the rated torque.
    steps : int, optional
        Torque steps over the whole cycle (at least 40).
    options : ModelOptions or str, optional
        Model fidelity per part: a :class:`~rvflex.options.ModelOptions` or a preset name
        (``"rigid"``, ``"flexible"``, ``"flexible-carrier"``).
    output_load : rvflex.tilt.OutputLoad, optional
        Tilting moment, axial and radial force on the output (None: none): the carrier tilts and moves on its main
        bearing pair and the discs with it against the pins (:mod:`rvflex.tilt`).

    Raises
    ------
    SpecError
        A value out of range, naming the parameter.
    """

    spec: ReducerSpec
    errors: ErrorSpec | None = None
    torque_Nm: float | None = None
    steps: int = 200
    options: ModelOptions | str = ModelOptions()
    output_load: OutputLoad | None = None

    def __post_init__(self) -> None:
        check_scenario_inputs(self)
        self._check_output_load()
        if self.torque_Nm is None:
            object.__setattr__(self, "torque_Nm", self.spec.rated_torque_Nm)
        self.spec.check_torque("torque_Nm", self.torque_Nm)
        if not self.steps >= 40:
            raise SpecError("steps", self.steps, "must be at least 40 torque steps")

    @property
    def torques_Nm(self) -> np.ndarray:
        """The torque path of the cycle (N·m)."""
        return hysteresis_cycle(self.torque_Nm, self.steps)

    def run(self, *, model: ReducerModel | None = None, progress=None) -> LostMotionResult:
        """Run the scenario (:func:`rvflex.run` calls this).

        Parameters
        ----------
        model : ReducerModel, optional
            A model from :func:`rvflex.build_reducer` with this scenario's spec, errors and
            options, reused instead of building one; None builds it.
        progress : callable, optional
            ``progress(done, total)``, called as the run advances (per torque step).

        Returns
        -------
        LostMotionResult
            The labelled result.
        """
        t0 = time.perf_counter()
        res, met = run_lost_motion(self, progress, model=model)
        return LostMotionResult(self, met, time.perf_counter() - t0, res)


def run_lost_motion(scenario: LostMotion, progress=None, *, model: ReducerModel | None = None
                    ) -> tuple[TorqueStepResult, HysteresisMetrics]:
    """Run the torque cycle on ``model`` (None: built here) and evaluate the catalogue metrics."""
    model = check_model(scenario, model)
    res = torque_stepping(model, scenario.torques_Nm, progress=progress, output_load=scenario.solver_load)
    return res, hysteresis_metrics(res.torque_Nm, res.theta_out, scenario.torque_Nm)


@dataclass(frozen=True, eq=False)
class LostMotionResult(Result):
    """Torsional hysteresis: per torque step the output torque and angle. ``raw`` is the solver's record.

    Parameters
    ----------
    scenario : LostMotion
        The scenario that ran.
    metrics : HysteresisMetrics
        Lost motion, hysteresis loss and backlash (arcmin), torsional stiffness (N·m/arcmin).
    wall_s : float
        Wall time of the run, s.
    raw : TorqueStepResult
        The solver's record (torque in N·m, angles in rad).
    """

    raw: TorqueStepResult

    name = "hysteresis"
    main_dim = "torque_step"

    def to_xarray(self):
        """Dataset over ``torque_step``: coordinate ``torque`` (N m), ``theta_out`` (rad) and
        ``output_angle`` (arcmin); the spatial model's ``carrier_tilt``, ``carrier_shift`` and ``disc_tilt``
        (:func:`rvflex.result.spatial_variables`); the metrics in ``attrs``.

        Returns
        -------
        xarray.Dataset
            Named dimensions, SI coordinates, ``units`` and ``long_name`` on every variable.
        """
        import xarray as xr

        r, dims = self.raw, ("torque_step",)
        coords = {"torque_step": variable(dims, np.arange(len(r.torque_Nm)), "1", "step of the torque cycle"),
                  "torque": variable(dims, r.torque_Nm, "N m", "output torque (positive forward)")}
        data = {"theta_out": variable(dims, r.theta_out, "rad", "output angle θ_out (input locked)"),
                "output_angle": variable(dims, r.theta_out * ARCSEC_PER_RAD / 60.0, "arcmin",
                                         "output angle θ_out (input locked)")}
        more, axes = spatial_variables(r, "torque_step")
        return xr.Dataset({**data, **more}, coords={**coords, **axes},
                          attrs=scenario_attrs(self.scenario, **self.metrics_dict()))

    def plot(self, ax=None):
        """The hysteresis loop (torque against output angle in arcmin) with the ±3 % band; returns the axes.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on; None draws on a new Figure's axes (pyplot and the backend untouched).

        Returns
        -------
        matplotlib.axes.Axes
            The axes drawn on.
        """
        ax = new_axes(ax, figsize=(8, 5.2))
        r, met, sc = self.raw, self.metrics, self.scenario
        ax.plot(r.theta_out * ARCSEC_PER_RAD / 60.0, r.torque_Nm, "-", lw=1.2, marker=".", ms=3)
        t3 = 0.03 * sc.torque_Nm
        ax.axhspan(-t3, t3, color="C1", alpha=0.15, label=f"±3 % T: lost motion {met.lost_motion_arcmin:.3f}′")
        ax.axhline(0.0, color="0.4", lw=0.6)
        ax.set_xlabel("output angle (arcmin)")
        ax.set_ylabel("output torque (N·m)")
        ax.set_title(f"{sc.spec.name}: torsional hysteresis, input locked — stiffness "
                     f"{met.torsional_stiffness_Nm_per_arcmin:.1f} N·m/arcmin, backlash {met.backlash_arcmin:.3f}′, "
                     f"hysteresis loss {met.hysteresis_loss_arcmin:.3f}′", fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(loc="upper left")
        return ax

    def files(self, out: Path) -> list[Path]:
        """hysteresis.csv and hysteresis.png.

        Parameters
        ----------
        out : pathlib.Path
            An existing directory.

        Returns
        -------
        list of pathlib.Path
            The files written.
        """
        return write_lost_motion_outputs(out, self.raw, self.metrics, self.scenario)


def write_lost_motion_outputs(out: Path, res: TorqueStepResult, met: HysteresisMetrics,
                              scenario: LostMotion) -> list[Path]:
    """Write hysteresis.csv and hysteresis.png (the loop with its metrics marked)."""
    out.mkdir(parents=True, exist_ok=True)
    arcmin = res.theta_out * ARCSEC_PER_RAD / 60.0
    csv = out / "hysteresis.csv"
    np.savetxt(csv, np.column_stack([res.torque_Nm, res.theta_out, arcmin]), delimiter=",",
               header="torque_Nm,theta_out_rad,theta_out_arcmin", comments="", fmt="%.12g")
    ax = LostMotionResult(scenario, met, res.wall_s, res).plot()
    png = out / "hysteresis.png"
    ax.figure.savefig(png, dpi=120)
    return [csv, png]


if __name__ == "__main__":
    import sys

    from rvflex import catalog

    result = LostMotion(catalog.load("rv40e")).run()
    print(result.metrics)
    print(result.write(sys.argv[1] if len(sys.argv) > 1 else "out"))

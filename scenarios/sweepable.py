"""The scenarios a sweep point can run, registered with the sweep engine (:mod:`rvflex.sweeps.registry`).

``te``: quasi-static loaded TE (:mod:`rvflex.scenarios.loaded_te`), metric ``te_pp_arcsec``;
``lost-motion``: the torsional hysteresis cycle (:mod:`rvflex.scenarios.lost_motion`, at
least 40 torque steps), metric ``lost_motion_arcmin``. Both build their model with the
design's :class:`~rvflex.options.ModelOptions`. Importing :mod:`rvflex.scenarios`
registers both. The scenario modules are imported when a point first runs (or a sweep warms
its process), so registering costs no Exudyn import.
"""

from __future__ import annotations

import dataclasses as dc

from rvflex.options import ModelOptions
from rvflex.spec import ErrorSpec, ReducerSpec
from rvflex.sweeps.registry import SweepScenario, register

__all__ = ["LOST_MOTION", "TE", "evaluate_lost_motion", "evaluate_te"]


def evaluate_te(spec: ReducerSpec, errors: ErrorSpec, load_Nm: float, positions_per_rev: int,
                revolutions: float, options: ModelOptions | None = None) -> dict[str, float]:
    """TE peak-to-peak and mean wind-up (arcsec) of one quasi-static loaded-TE run of the model
    built with ``options`` (None: rigid)."""
    from rvflex.scenarios.loaded_te import LoadedTE, run_loaded_te

    met = run_loaded_te(LoadedTE(spec, errors, load_Nm, revolutions, positions_per_rev,
                                 options=options or ModelOptions.rigid()))[1]
    return {"te_pp_arcsec": met.te_pp_arcsec, "mean_windup_arcsec": met.mean_windup_arcsec}


def evaluate_lost_motion(spec: ReducerSpec, errors: ErrorSpec, load_Nm: float, positions_per_rev: int,
                         revolutions: float, options: ModelOptions | None = None) -> dict[str, float]:
    """Every lost-motion metric of one hysteresis cycle at ±``load_Nm`` with
    max(positions_per_rev, 40) torque steps (``revolutions`` does not apply) of the model built
    with ``options`` (None: rigid)."""
    from rvflex.scenarios.lost_motion import LostMotion, run_lost_motion

    met = run_lost_motion(LostMotion(spec, errors, load_Nm, max(positions_per_rev, 40),
                                     options or ModelOptions.rigid()))[1]
    return dc.asdict(met)


def _warm_te() -> None:
    import rvflex.scenarios.loaded_te  # noqa: F401


def _warm_lost_motion() -> None:
    import rvflex.scenarios.lost_motion  # noqa: F401


TE = register(SweepScenario("te", evaluate_te, "te_pp_arcsec", "arcsec", _warm_te))
LOST_MOTION = register(SweepScenario("lost-motion", evaluate_lost_motion, "lost_motion_arcmin", "arcmin",
                                     _warm_lost_motion))

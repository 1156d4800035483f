"""Numerical settings shared by the part builders, the contact benches and the solvers, so that
none of them reaches into another for a constant.

- :data:`OUTPUT_REGULARISER_NM_RAD`: the weak spring from the output to its kinematic angle
  that keeps the floating output defined while clearances are open (DESIGN.md); the carrier
  builder installs it, the solvers stiffen it for continuation and reset it to this value.
- :func:`generalized_alpha_settings`: the fixed-step generalized-α settings of every dynamic run.
"""

from __future__ import annotations

__all__ = ["OUTPUT_REGULARISER_NM_RAD", "generalized_alpha_settings"]

OUTPUT_REGULARISER_NM_RAD = 1.0  # to the kinematic output angle: 1e-4 N·m per 1e-4 rad of TE


def generalized_alpha_settings(end_s: float, step_s: float, spectral_radius: float, *, relative_tolerance: float,
                               differentiation_epsilon: float | None = None):
    """Generalized-α settings shared by the dynamic runs: fixed step, dense solver, sensors
    stored every step, no solution file."""
    import exudyn as exu

    ss = exu.SimulationSettings()
    ss.timeIntegration.numberOfSteps = int(round(end_s / step_s))
    ss.timeIntegration.endTime = end_s
    ss.timeIntegration.verboseMode = 0
    ss.timeIntegration.generalizedAlpha.spectralRadius = spectral_radius
    ss.timeIntegration.newton.relativeTolerance = relative_tolerance
    if differentiation_epsilon is not None:
        ss.timeIntegration.newton.numericalDifferentiation.relativeEpsilon = differentiation_epsilon
    ss.solution.file.write = False
    ss.solution.sensors.writePeriod = step_s
    ss.linearSolver.solverType = exu.LinearSolverType.EXUdense
    return ss

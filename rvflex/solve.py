"""Solvers on an assembled :class:`~rvflex.model.ReducerModel`.

Quasi-static stepping: the input angle is prescribed step by step with the output torque
applied; each step is a static equilibrium started from the previous one advanced by the ideal
kinematics: by the compiled step of :mod:`rvflex.engine` (rigid models and FE discs, carrier and housing;
Exudyn's static solver where it fails), or with ``RVFLEX_SOLVER=exudyn`` by Exudyn's solvers: a chord
Newton on Exudyn's residual for FE parts. The first loaded step is reached by
continuation from a stiffly held output (DESIGN.md: clearances make the bodies float; weak
springs carry a negligible share — see :mod:`rvflex.parts.bearings` and
:data:`rvflex.numerics.OUTPUT_REGULARISER_NM_RAD`).

Over 600 lines on purpose: quasi-static stepping, torque stepping and the dynamic run share the
static-solve helpers (chord Newton, sub-stepping, regulariser continuation, the jump guard), and
their free-play fallbacks call each other (a failed first loading is redone by torque stepping);
split apart they would import each other's private helpers.
"""

from __future__ import annotations

import bisect
import time
from dataclasses import dataclass

import numpy as np

from rvflex.engine import compiled_step, pin_resultant, ring_torque
from rvflex.model import ReducerModel
from rvflex.numerics import OUTPUT_REGULARISER_NM_RAD, generalized_alpha_settings

__all__ = ["DynamicResult", "QuasiStaticResult", "SolveError", "TorqueStepResult", "dynamic", "hysteresis_cycle",
           "generalized_alpha_settings", "input_angle", "quasi_static", "solve_at", "static_settings", "torque_stepping"]

# the first loaded state is reached by a homotopy in the output regulariser: a stiff spring
# to the kinematic output angle (1e6 N·m/rad: 412 N·m turn the output ~85″) holds the
# floating output while the contacts close, then softens tenfold per step to its working value
REGULARISER_CONTINUATION_NM_RAD = (1e6, 1e5, 1e4, 1e3, 1e2, 1e1)
LOAD_CONTINUATION = (0.25, 0.5, 0.75, 1.0)  # of the torque above rated, applied at the first pose


class SolveError(RuntimeError):
    """A step did not converge; ``result`` holds the steps that did."""

    def __init__(self, message: str, result: "QuasiStaticResult"):
        super().__init__(message)
        self.result = result

    def __reduce__(self):  # picklable, so a failing point in a worker process stays an ordinary error
        return (type(self), (self.args[0], self.result))


@dataclass(frozen=True)
class QuasiStaticResult:
    """Quasi-static run: one row per converged step (SI: rad, N·m, N, m).

    theta_in, theta_out: input and output angles; te_rad = θ_out − θ_in/i;
    pin_force_N: (steps, discs, pins) normal forces; pin_gap_m likewise;
    torque_out_Nm: the output torque (resisting, positive); wall_s: solve time;
    compiled: the compiled step's counts over the run (:meth:`rvflex.engine.CompiledStep.counts`), None when
    Exudyn's solvers took it; disc_torque_Nm: (steps, discs) the torque of each disc's pin forces about the
    output axis (:func:`rvflex.engine.ring_torque`), None for a result made elsewhere.
    With the contact in slices along the face width (``ModelOptions.face_slices`` > 1) a pin's force is the sum
    over its slices, its gap the smallest, and pin_slice_force_N (steps, discs, slices, pins) holds each slice's
    force (slice 0 at the disc's face towards −z, :func:`rvflex.parts.cycloid_disc.slice_planes`) and
    slice_resultant_N (steps, discs, slices, 2) the resultant (x, y) of each slice's pin forces on the disc; None
    with one.
    The spatial model (``model.spatial``) records its out-of-plane motion per step, None for the planar one:
    carrier_tilt_rad (steps, 2) the carrier's tilt (ψx, ψy) about the housing's x and y axes, carrier_shift_m
    (steps, 3) its displacement (x, y, z) at the main bearing pair's centre, disc_tilt_rad (steps, discs, 2) each
    disc's tilt (ψx, ψy), crank_tilt_rad (steps, cranks) each crank's tilt: the slope of the chord between the
    points where its two support bearings carry (a rigid crank's axis; a beam crank's support stations).
    """

    theta_in: np.ndarray
    theta_out: np.ndarray
    te_rad: np.ndarray
    pin_force_N: np.ndarray
    pin_gap_m: np.ndarray
    torque_out_Nm: float
    ratio: float
    wall_s: float
    compiled: dict | None = None
    disc_torque_Nm: np.ndarray | None = None
    pin_slice_force_N: np.ndarray | None = None
    slice_resultant_N: np.ndarray | None = None
    carrier_tilt_rad: np.ndarray | None = None
    carrier_shift_m: np.ndarray | None = None
    disc_tilt_rad: np.ndarray | None = None
    crank_tilt_rad: np.ndarray | None = None


def _set_output_load(model: ReducerModel, load, fraction: float = 1.0) -> None:
    """Set ``fraction`` of the output load ``load`` (:class:`rvflex.tilt.OutputLoad` or None: none) on the spatial
    carrier's node (:attr:`rvflex.parts.carrier.CarrierHandles.output_loads`)."""
    if not model.carrier.output_loads:
        return
    values = np.zeros(5) if load is None else fraction * load.coordinate_loads()
    for item, v in zip(model.carrier.output_loads, values):
        model.mbs.SetLoadParameter(item, "load", float(v))


def _check_output_load(model: ReducerModel, load) -> None:
    """Refuse an output load the model cannot carry: the planar model takes it as moved pins
    (:func:`rvflex.tilt.tilted_errors` in the model's errors), not as a load."""
    from rvflex.tilt import OutputLoad

    if load is None:
        return
    if not isinstance(load, OutputLoad):
        raise TypeError(f"output_load: expected an rvflex.tilt.OutputLoad or None, got {type(load).__name__}")
    if not model.carrier.output_loads:
        raise ValueError("output_load: only the spatial model (options.spatial) carries it as a load; the planar "
                         "model takes it through its errors (rvflex.tilt.tilted_errors)")


class _SpatialRecord:
    """The spatial model's per-step out-of-plane state (carrier tilt and shift, disc and crank tilts), read from
    the absolute coordinates of each converged step; empty for the planar model."""

    def __init__(self, model: ReducerModel, n: int):
        self.on = model.spatial
        if not self.on:
            return
        idx = model.spatial_index()
        self.car = idx["carrier"]
        self.discs = np.array([idx[f"disc{d}"] for d in range(len(model.discs.nodes))])
        self.tilt = np.full((n, 2), np.nan)
        self.shift = np.full((n, 3), np.nan)
        self.disc_tilt = np.full((n, len(self.discs), 2), np.nan)
        # each crank's two support points: a rigid crank's node (its axis: ψx, ψy), a beam crank's support stations
        beam = model.cranks.beam
        self.rigid = beam is None
        self.cranks = np.array([idx[f"crank{k}"][3:5] for k in range(len(model.cranks.nodes))] if self.rigid else
                               [[model.mbs.GetNodeODE2Index(shaft[j]) for j in (beam.output_support,
                                                                                beam.input_support)]
                                for shaft in model.cranks.stations], dtype=np.int64)
        self.crank_tilt = np.full((n, len(self.cranks)), np.nan)

    def record(self, j: int, q: np.ndarray) -> None:
        if self.on:
            self.shift[j] = q[self.car[:3]]
            self.tilt[j] = q[self.car[3:5]]
            self.disc_tilt[j] = q[self.discs[:, 3:5]]
            if self.rigid:  # the axis R·e_z of Rxyz angles: (sin ψy, −sin ψx·cos ψy, cos ψx·cos ψy)
                px, py = q[self.cranks[:, 0]], q[self.cranks[:, 1]]
                self.crank_tilt[j] = np.hypot(np.sin(py), np.sin(px) * np.cos(py)) / (np.cos(px) * np.cos(py))
            else:
                a, b = self.cranks[:, 0], self.cranks[:, 1]
                chord = np.stack([q[a + i] - q[b + i] for i in range(3)], axis=1)
                self.crank_tilt[j] = np.hypot(chord[:, 0], chord[:, 1]) / chord[:, 2]

    def fields(self, m: int) -> dict:
        if not self.on:
            return {}
        return {"carrier_tilt_rad": self.tilt[:m], "carrier_shift_m": self.shift[:m],
                "disc_tilt_rad": self.disc_tilt[:m], "crank_tilt_rad": self.crank_tilt[:m]}


def static_settings():
    """Static-solver settings for the reducer: tight relative tolerance, no adaptive initial
    residual (a loose first residual would loosen the answer), dense solver (18–24 unknowns)."""
    import exudyn as exu

    ss = exu.SimulationSettings()
    ss.staticSolver.verboseMode = 0
    ss.staticSolver.newton.relativeTolerance = 1e-9
    ss.staticSolver.newton.absoluteTolerance = 1e-6
    ss.staticSolver.newton.maxIterations = 50
    ss.staticSolver.adaptiveStep = True
    ss.solution.file.write = False
    ss.linearSolver.solverType = exu.LinearSolverType.EXUdense
    # the connectors' Jacobians without the numerical derivative of the marker Jacobians:
    # the same equilibria (1e-10″ on the RV-40E), 1.2× faster rigid, 1.6× with FE discs
    ss.staticSolver.newton.numericalDifferentiation.jacobianConnectorDerivative = False
    return ss


def solve_at(model: ReducerModel, ss, theta_in: float, q_abs: np.ndarray) -> np.ndarray:
    """One static equilibrium with Exudyn's solver (settings ``ss``, e.g. :func:`static_settings`)
    at input angle ``theta_in`` (rad), the output regulariser centred on its kinematic angle,
    started from the absolute coordinates ``q_abs``; returns the absolute coordinates.

    Raises RuntimeError when the solver does not converge; the contacts' penetration guard
    raises on an overloaded contact."""
    import exudyn as exu

    mbs = model.mbs
    mbs.SetObjectParameter(model.sun.drive, "offset", theta_in)
    mbs.SetObjectParameter(model.carrier.regulariser, "offset", theta_in / model.ratio)
    mbs.systemData.SetODE2Coordinates(q_abs - model.reference, configuration=exu.ConfigurationType.Initial)
    if not mbs.SolveStatic(ss):
        raise RuntimeError("static solver did not converge")
    for c in model.discs.contacts:
        c.check_penetration()
    return np.asarray(mbs.systemData.GetODE2Coordinates()) + model.reference



SOLVER_ENV = "RVFLEX_SOLVER"
"""Environment variable choosing the static solver of the quasi-static and torque stepping: ``compiled``
(default: :mod:`rvflex.engine` where it replicates the system) or ``exudyn`` (Exudyn's own solver throughout,
the model of record: for comparisons, or a run to check against)."""


def _compiled(model: ReducerModel):
    """The compiled step of ``model`` unless :data:`SOLVER_ENV` asks for Exudyn's solver (None then, and for a
    system the compiled step does not replicate)."""
    import os

    from rvflex.spec import SpecError

    choice = os.environ.get(SOLVER_ENV, "compiled").strip().lower() or "compiled"
    if choice not in ("compiled", "exudyn"):
        raise SpecError(SOLVER_ENV, choice, "must be 'compiled' (default) or 'exudyn'")
    step = compiled_step(model) if choice == "compiled" else None
    if step is not None:
        step.backup = _Backup(model)
    return step


class _Backup:
    """The chord Newton on Exudyn's residual behind a compiled step, made when first needed: for a step
    that the compiled step's own retries (damped, a kept Jacobian, a growing load) cannot take either, before
    Exudyn's static solver. A full Newton can cycle where a contact sets in while the unit floats in its
    free play, where a kept Jacobian still contracts (measured: an RV-40E with stiff supports, 3 µm
    needle-bearing clearance and a 5 µm pitch error, torque cycle step 0 → 4.12 N·m: the full Newton cycled
    through its 60 iterations, and through 100, at residuals 7e-3 … 1e3 N; Exudyn's solver from the
    kinematic guess diverged to a 145 µm penetration; a chord Newton converged, tests/test_engine.py)."""

    def __init__(self, model: ReducerModel):
        self.model = model
        self.newton = None
        self.steps = 0  # steps it took

    def solve(self, q_abs: np.ndarray) -> np.ndarray:
        if self.newton is None:
            self.newton = _ChordNewton(self.model)
        q = self.newton.solve(q_abs)
        self.steps += 1
        return q

    def reset(self) -> None:
        if self.newton is not None:
            self.newton.reset()


SUBSTEP_LEVELS = 3  # a step that fails is retried in 2, 4, then 8 sub-steps from the last converged state

KEPT_FALLBACKS = 5
"""A rigid quasi-static run takes its steps by :class:`_KeptNewton` from the extrapolated guess until this
many of them have fallen back to Exudyn's static solver, then from the kinematic guess by that solver alone.
Where the steps are smooth (a loaded unit) the extrapolation saves a fifth of a run; where contacts open and
close from step to step (large clearances, a floating unloaded unit) it guesses worse than the kinematic
guess and Newton fails or crawls (measured, RV-40E with seed 001's errors and 12 µm eccentric-bearing
clearance, 576 positions: 0.71 s for the run at 412 N·m by Exudyn's solver, 1.02 s by the extrapolation
throughout, 0.73 s with this switch; the nominal unit 0.49, 0.39 and 0.39 s)."""

# Chord Newton of the quasi-static stepping (see _ChordNewton). Caps on one iteration's move:
# clearances are µm-scale, and a lightly loaded crank that sits at the edge of its mesh
# backlash makes the Jacobian soft in its spin, so an uncapped Newton step can throw it
# millimetres into the mesh (measured: a 0.02 rad crank step where the answer was 6e-4 rad away)
NEWTON_CAP_M = 1e-5  # largest translation of a body in one iteration, m
NEWTON_CAP_RADIUS_M = 0.03  # rotations are capped at NEWTON_CAP_M over this radius (a crank's eccentric/gear scale)
NEWTON_TOLERANCE = 1e-10  # converged when the last correction is below this (m, rad; 1e-10 rad = 2e-5″) ...
NEWTON_RESIDUAL = 1e-2  # ... and the residual norm below this (N, N·m): 1e-10 m against the contact stiffness
NEWTON_CONTRACTION = 0.25  # the Jacobian is re-evaluated when an iteration shrinks the residual by less than this
NEWTON_MAX_ITERATIONS = 100  # a unit crossing its free play needs ~60 capped iterations, still far cheaper than a fallback


class _NotConverged(RuntimeError):
    pass


def _static_solver(model: ReducerModel, ss, q_abs: np.ndarray):
    """A static solver of ``model``'s system with settings ``ss``, initialised at the absolute ODE2
    coordinates ``q_abs``, for Newton iterations driven step by step (the chord and the kept Newton)."""
    import exudyn as exu

    model.mbs.systemData.SetODE2Coordinates(q_abs - model.reference, configuration=exu.ConfigurationType.Initial)
    solver = exu.MainSolverStatic()
    solver.InitializeSolver(model.mbs, ss)
    return solver


class _ChordNewton:
    """Static equilibria by a chord Newton iteration on Exudyn's own static residual and
    Jacobian (``MainSolverStatic.ComputeNewtonResidual``/``ComputeNewtonJacobian``).

    The Jacobian is kept from step to step and re-evaluated only when an iteration contracts
    poorly; each iteration's move is capped (:data:`NEWTON_CAP_M`). With FE discs the
    Jacobian of the FFRF bodies and their superelement markers is ~6× the residual's cost,
    and Exudyn's own static solver evaluates it every iteration; the equilibria are the same
    (tests/test_model.py and tests/test_flexible.py compare both to 1e-4″). A step that does not converge raises
    :class:`_NotConverged` and is solved again by Exudyn's static solver.
    """

    def __init__(self, model: ReducerModel):
        self.model = model
        self.ss = static_settings()
        self.ss.staticSolver.useLoadFactor = False  # loads as set, no load-step ramp
        self.solver = None
        self.lu = None
        mbs = model.mbs
        self.n2, nae = mbs.systemData.ODE2Size(), mbs.systemData.AEsize()
        self.cap = np.full(self.n2 + nae, np.inf)  # modal coordinates and multipliers are not capped
        for idx in model.planar_index().values():
            self.cap[idx[:2]] = NEWTON_CAP_M
            self.cap[idx[2]] = NEWTON_CAP_M / NEWTON_CAP_RADIUS_M
        self.iterations = 0
        self.jacobians = 0
        self.fallbacks = 0
        from threadpoolctl import ThreadpoolController

        # one BLAS thread for the dense LU: a few hundred unknowns gain nothing from threads, and
        # OpenBLAS's threads on a busy 2-core machine made one LU of 193 unknowns 0.2 s instead of
        # 0.5 ms (measured: a flexible carrier and housing, 500 factorisations, 103 s of a 113 s run)
        self.blas = ThreadpoolController()

    def reset(self) -> None:
        """Drop the solver and its Jacobian (the next :meth:`solve` initialises a new one). Called
        whenever Exudyn's own static solver is about to run on the same system: a solver initialised
        before it does not see the state that run leaves behind. Measured: after a failed
        ``SolveStatic`` in a torque cycle's free play (RV-40E, pin circle 2.1 µm large, 9 nm
        crank-bearing clearance) the chord Newton "converged" on the descending branch with its residual
        at 4e-6 while a new solver's residual at the same state was the full output torque; the branch
        stayed at −60″ from −4 to −412 N·m (Exudyn's solver and a re-initialised chord Newton: −62 to
        −218″)."""
        self.solver = None
        self.lu = None

    def _set(self, x: np.ndarray) -> None:
        import exudyn as exu

        sd = self.model.mbs.systemData
        sd.SetODE2Coordinates(x[:self.n2], configuration=exu.ConfigurationType.Current)
        sd.SetAECoordinates(x[self.n2:], configuration=exu.ConfigurationType.Current)

    def _residual(self) -> np.ndarray:
        self.solver.ComputeNewtonResidual(self.model.mbs, self.ss)
        return np.asarray(self.solver.GetSystemResidual())

    def _factorize(self) -> None:
        from scipy.linalg import lu_factor

        self.solver.ComputeNewtonJacobian(self.model.mbs, self.ss)
        with self.blas.limit(limits=1, user_api="blas"):
            self.lu = lu_factor(self.solver.GetSystemJacobian(), check_finite=False)
        self.jacobians += 1

    def solve(self, q_abs: np.ndarray) -> np.ndarray:
        """Equilibrium from the guess ``q_abs`` (absolute ODE2 coordinates) with the loads and
        prescribed offsets as currently set in the system."""
        import exudyn as exu
        from scipy.linalg import lu_solve

        mbs, ref = self.model.mbs, self.model.reference
        if self.solver is None:
            self.solver = _static_solver(self.model, self.ss, q_abs)
        lam = np.asarray(mbs.systemData.GetAECoordinates(configuration=exu.ConfigurationType.Current))
        x = np.concatenate([q_abs - ref, lam])
        self._set(x)
        r = self._residual()
        if self.lu is None:
            self._factorize()
        last = np.linalg.norm(r)
        for _ in range(NEWTON_MAX_ITERATIONS):
            dx = lu_solve(self.lu, r, check_finite=False)
            excess = np.max(np.abs(dx) / self.cap)
            if excess > 1.0:
                dx /= excess
            x -= dx
            self._set(x)
            r = self._residual()
            norm = np.linalg.norm(r)
            self.iterations += 1
            if not np.isfinite(norm):
                break
            if np.max(np.abs(dx[:self.n2])) < NEWTON_TOLERANCE and norm < NEWTON_RESIDUAL:
                for c in self.model.discs.contacts:
                    c.check_penetration()
                return x[:self.n2] + ref
            if norm > NEWTON_CONTRACTION * last:
                self._factorize()
            last = norm
        raise _NotConverged(f"chord Newton stalled at residual {norm:.3e}")


class _KeptNewton:
    """Static equilibria by Exudyn's own (full) Newton of one static solver kept from step to step
    (``MainSolverStatic.Newton``), for the rigid model's quasi-static steps from
    :func:`_extrapolated_guess`: the same iteration and tolerances as ``SolveStatic`` with an iteration cap
    of its own, so a step the extrapolation guesses badly fails fast and is solved again by Exudyn's static
    solver from the kinematic guess (its load steps and the bisection take the free play). The saving is
    the guess's (measured, nominal RV-40E at 412 N·m, 576 positions: 0.39 s against 0.49 s per
    revolution, TE equal within 4e-9″); the kept solver alone, from the kinematic guess, saves nothing."""

    MAX_ITERATIONS = 6  # from an extrapolated guess a smooth step takes 4; a step needing more is the fallback's

    def __init__(self, model: ReducerModel):
        self.model = model
        self.ss = static_settings()
        self.ss.staticSolver.useLoadFactor = False  # loads as set, no load-step ramp
        self.ss.staticSolver.newton.maxIterations = self.MAX_ITERATIONS
        self.solver = None
        self.fallbacks = 0

    def reset(self) -> None:
        """Drop the solver (as :meth:`_ChordNewton.reset`: whenever Exudyn's own static solver is
        about to run on the same system)."""
        self.solver = None

    def solve(self, q_abs: np.ndarray) -> np.ndarray:
        """Equilibrium from the guess ``q_abs`` (absolute ODE2 coordinates) with the loads and
        prescribed offsets as currently set in the system."""
        import exudyn as exu

        mbs, ref = self.model.mbs, self.model.reference
        if self.solver is None:
            self.solver = _static_solver(self.model, self.ss, q_abs)
        mbs.systemData.SetODE2Coordinates(q_abs - ref, configuration=exu.ConfigurationType.Current)
        if not self.solver.Newton(mbs, self.ss):
            raise _NotConverged("Exudyn's Newton did not converge")
        for c in self.model.discs.contacts:
            c.check_penetration()
        return np.asarray(mbs.systemData.GetODE2Coordinates()) + ref


def _extrapolated_guess(kin: np.ndarray, history: list[tuple[float, np.ndarray]], theta: float) -> np.ndarray:
    """Guess at input angle ``theta``: its ideal kinematics ``kin`` plus the elastic part (the
    coordinates' deviation from the kinematics) extrapolated quadratically from the last
    three converged steps in ``history`` (linearly from two, held from one)."""
    ths = [h[0] for h in history]
    elastic = np.zeros_like(kin)
    for j, (tj, ej) in enumerate(history):  # Lagrange weights at theta
        w = 1.0
        for m, tm in enumerate(ths):
            if m != j:
                w *= (theta - tm) / (tj - tm)
        elastic += w * ej
    return kin + elastic


ORBIT_POINTS = 4  # converged steps of the last crank revolution the orbit guess interpolates between (cubic)
ORBIT_SPAN_RAD = 2 * np.pi / 3  # ... when they lie within this crank angle (beyond it the run is too coarse)


class _OrbitGuess:
    """Guess of an FE model's quasi-static step from the crank revolution before it.

    The elastic part of the state (coordinates less the ideal kinematics) repeats with each crank revolution
    relative to the carrier (the discs advance one pin, the crank gears mesh through whole teeth), while a
    step of a TE run turns the crank 7–28°: a polynomial extrapolation over the last steps misses the elastic
    part by ~1 µm there, and with the FE discs the chord Newton then needs a new Jacobian of Exudyn's FFRF
    bodies (ten residuals) in most steps. This guess interpolates the elastic part (cubic, in the crank
    angle) between the converged steps one revolution back, and adds what repeats not (errors of single
    pins, the carrier's slow turn): that part of the last three steps extrapolated as
    :func:`_extrapolated_guess` does. Until a revolution is behind it, it is :func:`_extrapolated_guess`'s.
    Measured, RV-40E FE discs at 512 positions: the guess's residual 1.1e3 N against 5.0e3 N (median of steps
    30-69); per step 6.7 residuals and 1.2 Jacobians against 8.2 and 1.4 (256 steps), with seed 001's errors
    11.0 and 4.2 against 14.1 and 7.0 (200 steps); the TE the same within 3e-6″.
    """

    def __init__(self, model: ReducerModel):
        idx = model.planar_index()
        self.crank, self.carrier = int(idx["crank0"][2]), int(idx["carrier"][2])
        self.reset()

    def reset(self) -> None:
        """Forget the run so far (the next step does not continue the last one)."""
        self.phase: list[float] = []  # crank angle relative to the carrier, increasing along the run (rad)
        self.elastic: list[np.ndarray] = []
        self.drift: list[tuple[float, np.ndarray]] = []  # (θ_in, elastic part less the periodic one)
        self.sign = 0.0

    def _phase(self, kin: np.ndarray) -> float:
        return float(kin[self.crank] - kin[self.carrier])

    def _periodic(self, phase: float) -> np.ndarray | None:
        """The elastic part one crank revolution before ``phase`` (signed as the run), or None."""
        target = phase - 2 * np.pi
        ph = self.phase
        j = bisect.bisect_left(ph, target)
        lo = j - ORBIT_POINTS // 2
        if lo < 0 or lo + ORBIT_POINTS > len(ph) or ph[lo + ORBIT_POINTS - 1] - ph[lo] > ORBIT_SPAN_RAD:
            return None
        return _extrapolated_guess(np.zeros_like(self.elastic[0]), list(zip(ph[lo:lo + ORBIT_POINTS],
                                                                              self.elastic[lo:lo + ORBIT_POINTS])),
                                   target)

    def guess(self, kin: np.ndarray, history: list[tuple[float, np.ndarray]], theta: float) -> np.ndarray:
        """Guess at input angle ``theta`` with ideal kinematics ``kin``; ``history`` as :func:`_extrapolated_guess`'s."""
        if self.sign and len(self.drift) == 3:
            p = self._periodic(self.sign * self._phase(kin))
            if p is not None:
                return _extrapolated_guess(kin + p, self.drift, theta)
        return _extrapolated_guess(kin, history, theta)

    def record(self, kin: np.ndarray, elastic: np.ndarray, theta: float) -> None:
        """A converged step of the run: its ideal kinematics ``kin``, elastic part and input angle."""
        raw = self._phase(kin)
        if not self.sign and self.phase:  # the second step sets the run's direction (the list holds sign·angle)
            self.sign = float(np.sign(raw - self.phase[0]))
            self.phase[0] *= self.sign
        phase = self.sign * raw
        if not self.sign or phase <= self.phase[-1]:  # the first step, or one that does not advance: start again
            self.reset()
            self.phase, self.elastic = [raw], [elastic]
            return
        p = self._periodic(phase)
        self.drift = (self.drift + [(theta, elastic - p)])[-3:] if p is not None else []
        self.phase.append(phase)
        self.elastic.append(elastic)


def _advance(model: ReducerModel, ss, q: np.ndarray, th0: float, th1: float, level: int = 0, *,
             newton: _ChordNewton | None = None, guess: np.ndarray | None = None, check=None,
             on_bisect=None) -> np.ndarray:
    """Static equilibrium at input angle ``th1`` from the converged state ``q`` at ``th0``
    (or from ``guess``), by ``newton`` if given and else, or when it fails, by Exudyn's static
    solver; on failure, bisect the step (contact sets that change within one step can stall Newton).
    ``check(q, th)`` may reject a converged state by raising (a jump to another tooth): it then
    counts as a failure. ``on_bisect()`` is called when the step has to be bisected."""
    def kinematic_guess() -> np.ndarray:  # the converged state moved by the ideal kinematics
        return q + model.kinematic_coordinates(th1) - model.kinematic_coordinates(th0)

    def accepted(q1: np.ndarray) -> np.ndarray:
        if check is not None:
            check(q1, th1)
        return q1

    if guess is None:
        guess = kinematic_guess()
    if newton is not None:
        mbs = model.mbs
        mbs.SetObjectParameter(model.sun.drive, "offset", th1)
        mbs.SetObjectParameter(model.carrier.regulariser, "offset", th1 / model.ratio)
        try:
            return accepted(newton.solve(guess))
        except Exception:  # stalled, or a contact guard tripped on a wild iterate: Exudyn's solver decides
            newton.fallbacks += 1
            newton.reset()  # Exudyn's solver runs next (and its Jacobian may belong to a wild iterate)
            backup = getattr(newton, "backup", None)  # a compiled step's chord Newton first
            if backup is not None:
                try:
                    return accepted(backup.solve(guess))
                except Exception:  # noqa: BLE001 - Exudyn raises its own error types
                    backup.reset()
            guess = kinematic_guess()
    try:
        return accepted(solve_at(model, ss, th1, guess))
    except Exception:
        if level >= SUBSTEP_LEVELS:
            raise
        if on_bisect is not None:
            on_bisect()
        mid = 0.5 * (th0 + th1)
        q_mid = _advance(model, ss, q, th0, mid, level + 1, check=check)
        return _advance(model, ss, q_mid, mid, th1, level + 1, check=check)


def quasi_static(model: ReducerModel, theta_in: np.ndarray, torque_out_Nm: float = 0.0, *,
                 progress=None, chord_newton: bool | None = None, fail_fast: bool = False,
                 skip_unsolved: bool = False, contact_states: bool = True, output_load=None) -> QuasiStaticResult:
    """Static equilibria at the input angles ``theta_in`` (rad; increasing runs forward,
    decreasing runs reverse) under the output torque ``torque_out_Nm`` (N·m, ≥ 0) resisting
    the motion. With ``chord_newton`` the steps are solved by :class:`_ChordNewton` from an
    extrapolated guess, else by Exudyn's static solver from the kinematic guess. The default
    (None) takes the compiled step (:func:`rvflex.engine.compiled_step`, the first pose's
    continuation included) for a model it replicates (rigid, FE discs, carrier and housing, spatial rigid), Exudyn's
    static solver for a step it cannot take; for a model it declines, or with ``RVFLEX_SOLVER=exudyn``, the
    chord Newton for FE parts, whose Exudyn Jacobian is dear (2.3× faster than Exudyn's solver), and for
    rigid ones Exudyn's Newton (:class:`_KeptNewton`, from the extrapolated guess, until
    :data:`KEPT_FALLBACKS` steps have fallen back to Exudyn's static solver from the kinematic guess;
    their Jacobian costs about a residual; with the chord Newton for every rigid run the realistic
    self-check took 975 s instead of 852 s) until a recorded step has to be bisected, then the chord
    Newton for the rest of the run (measured side by side,
    RV-40E, 448 positions: both crank eccentricities 3 µm too large at 103 N·m, Exudyn's solver
    bisecting step after step, 188 s against 0.4 s by the chord Newton; the TE agreed to 5e-6″
    in that run and in the nominal, clearance-and-runout and preloaded runs beside it).

    The loaded state at the first pose is reached by a stiff-to-working continuation of the output
    regulariser under the load; when that fails and the run starts at input angle 0, the unit is
    loaded step by step by :func:`torque_stepping` instead (without friction the equilibrium does
    not depend on the path; a run that loads this way the first time gives the same result).

    With ``skip_unsolved`` a recorded step that fails even in sub-steps is left out (NaN angles,
    forces and gaps) and the next one is solved from the last converged state; the first step and
    two steps in a row are never left out (see :func:`torque_stepping` for why a step can fail).
    Without ``contact_states`` the pin forces and gaps are not read (NaN): a caller that needs the
    TE alone saves a tenth of a rigid run.

    ``output_load`` (:class:`rvflex.tilt.OutputLoad`, spatial model only) loads the carrier with a tilting
    moment, an axial and a radial force at the main bearing pair's centre, ramped with the torque's
    continuation at the first pose and held over the run: the carrier's tilt and shift are then solved with the
    gear train (two-way), and recorded per step (:class:`QuasiStaticResult`). The planar model takes such a
    load through its errors instead (:func:`rvflex.tilt.tilted_errors`): a load given to it is refused
    (ValueError).

    Raises
    ------
    SolveError
        A step failed: the message names the step, the input angle and the largest
        residual; ``error.result`` holds the converged steps.
    """
    _check_output_load(model, output_load)
    mbs = model.mbs
    ss = static_settings()
    if fail_fast:  # a step Exudyn's solver cannot take in load increments down to 1e-3 fails (and is bisected)
        ss.staticSolver.minimumStepSize = CYCLE_MIN_LOAD_STEP
    car = model.output_index
    theta_in = np.asarray(theta_in, float)
    nd, ns = len(model.discs.nodes), model.discs.slices
    n, nc, npins = len(theta_in), len(model.discs.contacts), model.spec.cycloid.pin_count
    out = np.full(n, np.nan)
    forces = np.full((n, nc, npins), 0.0 if contact_states else np.nan)  # per contact: a disc's slice
    gaps = forces.copy()
    torques = np.full((n, nc), 0.0 if contact_states else np.nan)
    resultants = np.full((n, nc, 2), 0.0 if contact_states else np.nan)
    spatial = _SpatialRecord(model, n)
    t0 = time.perf_counter()
    q = model.kinematic_coordinates(theta_in[0])
    done = 0

    def result() -> QuasiStaticResult:
        m = done
        th_out = out[:m]
        f, g, tq, per_slice, res = forces[:m], gaps[:m], torques[:m], None, None
        if ns > 1:  # per disc: the slices' sum (the gap: the closest slice), each slice's force beside
            per_slice = f.reshape(m, nd, ns, npins)
            f, g, tq = per_slice.sum(axis=2), g.reshape(m, nd, ns, npins).min(axis=2), tq.reshape(m, nd, ns).sum(axis=2)
            res = resultants[:m].reshape(m, nd, ns, 2)
        return QuasiStaticResult(theta_in[:m], th_out, th_out - theta_in[:m] / model.ratio, f, g,
                                 torque_out_Nm, model.ratio, time.perf_counter() - t0,
                                 compiled.counts() if compiled is not None else None, tq, per_slice, res,
                                 **spatial.fields(m))

    direction = -1.0 if len(theta_in) > 1 and theta_in[-1] < theta_in[0] else 1.0
    k_work = OUTPUT_REGULARISER_NM_RAD
    # reach the loaded state by continuation at the first pose: at most rated torque against
    # a stiff output regulariser softened decade by decade (the backlash closes on the way),
    # then, above rated torque, the rest of the load in quarters against the engaged unit
    f0 = min(1.0, model.spec.rated_torque_Nm / torque_out_Nm) if torque_out_Nm else 1.0
    steps = [(theta_in[0], k, f0, False) for k in REGULARISER_CONTINUATION_NM_RAD] if torque_out_Nm else []
    if f0 < 1.0:
        steps += [(theta_in[0], k_work, f0 + (1.0 - f0) * f, False) for f in LOAD_CONTINUATION]
    steps += [(th, k_work, 1.0, True) for th in theta_in]
    prev_th = theta_in[0]
    fe = bool(model.modal_nodes)
    # default: the compiled step (rvflex.engine) where it replicates the system (rigid or FE), else the chord
    # Newton for FE parts and Exudyn's solver for rigid ones until it bisects
    compiled = _compiled(model) if chord_newton is None else None
    if compiled is not None:
        compiled.skip_open = not contact_states  # without pin states the surely open pins need no evaluation
    switch = chord_newton is None and not fe and compiled is None
    if chord_newton is None:
        chord_newton = fe or compiled is not None
    newton = compiled or (_ChordNewton(model) if chord_newton or switch else None)
    kept = _KeptNewton(model) if switch else None  # rigid: Exudyn's Newton from the extrapolation, see KEPT_FALLBACKS
    bisected = []  # recorded steps Exudyn's solver had to bisect (``switch``: the chord Newton takes over)
    history: list[tuple[float, np.ndarray]] = []  # (θ_in, elastic part) of the last converged recorded steps
    orbit = _OrbitGuess(model) if fe and compiled is None else None  # Exudyn's FE steps: the last crank turn's guess
    loaded_by_stepping = False
    skipped = -2  # the last recorded step left out
    last_te = 0.0  # TE of the last converged recorded step (rad)

    def jump_check(q1: np.ndarray, th: float) -> None:
        # a TE that moves by more than any deflection from one position to the next jumped across the
        # free play to another tooth (measured: 0.94 rad at quarter load with a 3 µm 2nd-harmonic pin
        # pattern and 2.2 µm crank-bearing clearance, the run then went on on the wrong tooth): a failure
        if abs(q1[car] - th / model.ratio - last_te) > MAX_CYCLE_ANGLE_RAD:
            raise RuntimeError(f"the TE jumped by {abs(q1[car] - th / model.ratio - last_te):.3g} rad from the last "
                               "converged step (across the free play to another tooth)")
    reached = 0  # recorded steps the loop has reached (a run of compiled steps takes several at once)
    stopped_at = -1  # the recorded step a run of compiled steps stopped at: the loop's own way takes it
    for th, k_reg, frac, record in steps:
        if loaded_by_stepping and not record:
            continue
        if record:
            reached += 1
            if reached <= done:
                continue
        mbs.SetLoadParameter(model.carrier.load, "load", -direction * frac * torque_out_Nm)
        _set_output_load(model, output_load, frac)  # ramped with the torque above rated, as far as it is
        mbs.SetObjectParameter(model.carrier.regulariser, "stiffness", k_reg)
        if record and compiled is not None and history and done > 0 and done != stopped_at:
            # the steps from here in compiled runs of COMPILED_RUN_STEPS (the same guess, Newton and checks as one
            # by one, without the loop's Python per step), up to the first it cannot take
            start = done
            while done < n:
                k, history, last_te, q_last = compiled.steps(theta_in[done:done + COMPILED_RUN_STEPS], history,
                                                             last_te, MAX_CYCLE_ANGLE_RAD, out[done:], forces[done:],
                                                             gaps[done:], torques[done:], resultants[done:],
                                                             contact_states)
                if k:
                    q, prev_th = q_last, float(theta_in[done + k - 1])
                    for j in range(k if spatial.on else 0):  # the run's steps' tilts and shifts
                        spatial.record(done + j, compiled.records[j])
                    done += k
                    if progress is not None:
                        progress(done, n)
                if k < min(COMPILED_RUN_STEPS, n - done + k):
                    stopped_at = done
                    break
            if done > start:
                continue  # the loop skips the steps taken and takes the one that stopped the run its own way
        # the compiled step takes the loading continuation too (Exudyn's solver when it fails): Exudyn's static
        # solves of the first pose were as dear as all the compiled steps of a diagnosis's runs (measured, FB1 H04:
        # 1968 solves, 23 s against 21 s for 50 429 compiled steps)
        chord_step = (record or compiled is not None) and newton is not None and (chord_newton or bool(bisected))
        kept_step = record and kept is not None and not chord_step and kept.fallbacks < KEPT_FALLBACKS
        # the extrapolated guess of a recorded step (a continuation step at the first pose starts from the last state)
        kin = model.kinematic_coordinates(th) if record and (chord_step or kept_step) else None
        if record and kin is None:
            history = []  # an extrapolation spans contiguous steps only
            if orbit is not None:
                orbit.reset()
        guess = None
        if kin is not None and history:
            guess = orbit.guess(kin, history, th) if orbit is not None else _extrapolated_guess(kin, history, th)
        try:
            check = jump_check if record and done > 0 else None
            if chord_step:
                q = _advance(model, ss, q, prev_th, th, newton=newton, check=check, guess=guess)
            else:
                q = _advance(model, ss, q, prev_th, th, check=check, newton=kept if kept_step else None, guess=guess,
                             on_bisect=(lambda: bisected.append(th)) if record and switch else None)
        except Exception as err:  # Exudyn raises its own error types; report the step
            if not record and theta_in[0] == 0.0:  # (after such a loading no unrecorded step is left)
                # the load continuation at the first pose failed (measured: 4.3 µm crank-bearing clearance
                # with a 6 µm pin-ring runout, stiff regulariser, full rated torque at once): load the unit
                # step by step with the torque-stepping engine instead (input locked at 0, its free-play
                # handling), then go on with the recorded steps
                q = _loaded_by_torque_stepping(model, -direction * torque_out_Nm, output_load)
                loaded_by_stepping = True
                mbs.SetObjectParameter(model.carrier.regulariser, "stiffness", k_work)
                for nw in (newton, kept):
                    if nw is not None:
                        nw.reset()  # Exudyn's solver and another chord Newton ran on the system
                continue
            if skip_unsolved and record and done > 0 and skipped != done - 1:
                for rec in (out, forces, gaps, torques, resultants):
                    rec[done] = np.nan
                spatial.record(done, np.full_like(q, np.nan))
                skipped = done
                done += 1
                if newton is not None:
                    newton.lu = None
                if progress is not None:
                    progress(done, n)
                continue  # the next step starts from the last converged state
            res = np.asarray(mbs.systemData.GetODE2Coordinates())
            guess = q + model.kinematic_coordinates(th) - model.kinematic_coordinates(prev_th)
            raise SolveError(f"quasi-static step {done} (input angle {th:.6f} rad, output regulariser {k_reg:g} N·m/rad) "
                             f"did not converge even in {2 ** SUBSTEP_LEVELS} sub-steps: {err}; largest coordinate "
                             f"change {np.abs(res + model.reference - guess).max():.3e}", result()) from None
        prev_th = th
        if record:
            if kin is not None:
                history = (history + [(th, q - kin)])[-3:]
                if orbit is not None:
                    orbit.record(kin, q - kin, th)
            last_te = q[car] - th / model.ratio
            out[done] = q[car]
            spatial.record(done, q)
            for d, c in enumerate(model.discs.contacts if contact_states else ()):
                if compiled is not None and compiled.solved:  # its last evaluation is the step's
                    forces[done, d], gaps[done, d], torques[done, d], resultants[done, d] = compiled.pin_outputs(d)
                    continue
                st = c.pin_state(mbs)
                forces[done, d] = st.force_N
                gaps[done, d] = st.gap_m
                pins = np.ascontiguousarray(c.pins_m, float)
                px, py = np.ascontiguousarray(st.point_m[:, 0]), np.ascontiguousarray(st.point_m[:, 1])
                torques[done, d] = ring_torque(np.ascontiguousarray(st.force_N, float), px, py, pins)
                resultants[done, d] = pin_resultant(st.force_N, px, py, pins)
            done += 1
            if progress is not None:
                progress(done, n)
    return result()


COMPILED_RUN_STEPS = 512  # recorded steps per compiled call (the progress bar moves between calls)

LOADING_FRACTIONS = (0.005, 0.01, 0.02, 0.04, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0)  # of the torque: the fallback loading path


def _loaded_by_torque_stepping(model: ReducerModel, torque_Nm: float, output_load=None) -> np.ndarray:
    """Absolute coordinates of the unit loaded by ``torque_Nm`` on the output (input locked at 0),
    reached along LOADING_FRACTIONS by :func:`torque_stepping`; the load stays applied. An intermediate
    step that fails is left out: the path is only a way there, and without friction the end state does
    not depend on it (measured: a 7.4 µm crank-bearing clearance with a 3.5 µm pin-ring runout fails the
    1 % step however it is started; the state agrees with the path without that step within 1e-3″, test)."""
    torque_stepping(model, torque_Nm * np.asarray(LOADING_FRACTIONS), skip_unsolved=True, output_load=output_load)
    return np.asarray(model.mbs.systemData.GetODE2Coordinates()) + model.reference


@dataclass(frozen=True)
class TorqueStepResult:
    """Input locked, output torque stepped: torque (N·m, on the output, positive in the forward
    direction), output angle (rad; NaN for a step left out by ``skip_unsolved``), one row per step
    taken; ``compiled`` as :class:`QuasiStaticResult`'s; the spatial model's carrier_tilt_rad (steps, 2),
    carrier_shift_m (steps, 3), disc_tilt_rad (steps, discs, 2) and crank_tilt_rad (steps, cranks) as
    :class:`QuasiStaticResult`'s (None for the planar model)."""

    torque_Nm: np.ndarray
    theta_out: np.ndarray
    wall_s: float
    compiled: dict | None = None
    carrier_tilt_rad: np.ndarray | None = None
    carrier_shift_m: np.ndarray | None = None
    disc_tilt_rad: np.ndarray | None = None
    crank_tilt_rad: np.ndarray | None = None


HYSTERESIS_FINE_FRACTIONS = (0.005, 0.01, 0.02, 0.03, 0.04)  # of T: the lost-motion points and the free play


def hysteresis_cycle(rated_Nm: float, steps: int = 200) -> np.ndarray:
    """Torque path 0 → +T → −T → 0 (N·m): ``steps`` equal increments, plus the torques
    ±HYSTERESIS_FINE_FRACTIONS·T on every passage, so the ±3 % points of the lost motion are
    solved, not interpolated across the free play."""
    quarter = max(steps // 4, 2)
    fine = np.concatenate([[0.0], np.array(HYSTERESIS_FINE_FRACTIONS), -np.array(HYSTERESIS_FINE_FRACTIONS)]) * rated_Nm

    def leg(a: float, b: float) -> np.ndarray:
        pts = np.linspace(a, b, quarter * round(abs(b - a) / rated_Nm) + 1)
        lo, hi = min(a, b), max(a, b)
        pts = np.union1d(pts, fine[(fine > lo) & (fine < hi)])
        return pts if b > a else pts[::-1]

    return np.concatenate([leg(0.0, rated_Nm), leg(rated_Nm, -rated_Nm)[1:], leg(-rated_Nm, 0.0)[1:]])


MAX_CYCLE_ANGLE_RAD = 0.02  # ≈ 69′: beyond any lost motion plus wind-up; a larger output angle is a jump to another tooth
ZERO_TORQUE_SHIFT = 2e-3  # an unloaded step that floats is taken at ±0.2 % of the amplitude (the side it comes from)
CYCLE_MIN_LOAD_STEP = 1e-3  # smallest load increment of Exudyn's solver within one torque step (share of the step)
TORQUE_BISECTIONS = 3  # a failing torque step is split in 2, 4, then 8 from the last converged state


def torque_stepping(model: ReducerModel, torques_Nm: np.ndarray, *, progress=None,
                    chord_newton: bool = True, before_solve=None, skip_unsolved: bool = False,
                    output_load=None) -> TorqueStepResult:
    """Input locked at angle 0, output torque stepped along ``torques_Nm``: the torsional
    hysteresis test of the catalogues, and the diagnosis's replay of a bench torque cycle (one
    engine, so both reach the same equilibria).

    Each step is a static equilibrium from the previous one, by the compiled step of a rigid model
    (:mod:`rvflex.engine`) or else :class:`_ChordNewton` unless ``chord_newton=False`` (Exudyn's static solver when it stalls, with a 1e-3 smallest load
    increment so a hopeless step fails fast). The free play needs more, in this order:

    1. a failing step is bisected (up to 3 levels) from the last converged state, through zero
       torque when it changes sign; a step out of zero torque is not (its smaller torques float as it does);
    2. a zero torque that floats (the clearances let the bodies drift) is taken at ±0.2 % of the
       amplitude on the side the path comes from (a cycle's first step, from the kinematic state, on
       the positive side), once the remedies of 3. and 4. fail at zero torque itself;
    3. a step that still fails is solved by a stiff-to-working continuation of the output
       regulariser, from the last state and then from the unloaded kinematic configuration: out
       of the free play the weak regulariser alone holds the output, and Newton's first step from
       a floating state can throw it across a tooth (measured: 0.3–1.8 N·m from the unloaded
       RV-40E landed 18° away). Without friction the equilibrium at a non-zero torque does not
       depend on the path that led to it, so the restart is exact. Once a step out of zero torque has
       needed it, the next step out of zero torque (the cycle's reversal) starts with it (measured: a rigid
       RV-40E with 3.3 µm crank-bearing clearance, 1.3–1.5 s → 0.35 s per cycle, the angles equal within 1e-8″);
    4. a step at a torque the path has converged at before (a cycle's unloading leg revisits its
       loading leg's torques) is solved from that state instead of the unloaded one (measured: 7.5 µm
       crank-bearing clearance with a 4.9 µm runout, the unloading leg's 16.5 and 12.4 N·m steps both
       failed from the last state and the unloaded one; the two legs then agree within 1e-4″, test).

    A solution whose output angle exceeds :data:`MAX_CYCLE_ANGLE_RAD` is a jump to another tooth
    and counts as a failure. ``before_solve()`` is called before every solve (a time budget may
    raise there; its exception propagates unchanged).

    With ``skip_unsolved`` a step that still fails is left out (its angle NaN) when the next step
    converges from the last converged state: inside the free play an equilibrium can sit on a
    contact's onset, where the residual has a kink and Newton cycles (measured: 2.9 µm crank-bearing
    clearance with a 3 µm pin-ring runout, 12.4 N·m, residual stuck at 2e-4 N along a direction of
    stiffness 7e-4). The first and last steps, and two steps in a row, are never skipped.

    ``output_load`` (:class:`rvflex.tilt.OutputLoad`, spatial model only; refused with the planar one as by
    :func:`quasi_static`) is held on the carrier over the whole cycle (a robot arm's moment does not change with
    the joint's torque); its first step reaches it by Exudyn's load steps from the unloaded state.

    Raises
    ------
    SolveError
        A step failed (message names the step and torque); ``error.result`` has the converged steps.
    """
    _check_output_load(model, output_load)
    mbs = model.mbs
    ss = static_settings()
    ss.staticSolver.minimumStepSize = CYCLE_MIN_LOAD_STEP
    car = model.output_index
    torques = np.asarray(torques_Nm, float)
    amplitude = float(np.max(np.abs(torques))) if len(torques) else 0.0
    out = np.full(len(torques), np.nan)
    spatial = _SpatialRecord(model, len(torques))
    t0 = time.perf_counter()
    q_kin = model.kinematic_coordinates(0.0)
    mbs.SetObjectParameter(model.carrier.regulariser, "stiffness", OUTPUT_REGULARISER_NM_RAD)
    _set_output_load(model, output_load)
    # the compiled step (rvflex.engine) where it replicates the system, else the chord Newton on Exudyn's residual
    compiled = _compiled(model) if chord_newton else None
    if compiled is not None:
        compiled.skip_open = True  # no pin state is recorded: the surely open pins need no evaluation
    newton = compiled or (_ChordNewton(model) if chord_newton else None)

    def result(m: int) -> TorqueStepResult:
        return TorqueStepResult(torques[:m], out[:m], time.perf_counter() - t0,
                                compiled.counts() if compiled is not None else None, **spatial.fields(m))

    class _Abort(Exception):
        pass

    def solve(q0, t, first=False):
        if before_solve is not None:
            try:
                before_solve()
            except Exception as err:  # noqa: BLE001 - the caller's abort, passed through unchanged
                raise _Abort() from err
        mbs.SetLoadParameter(model.carrier.load, "load", float(t))
        if first or newton is None:
            if newton is not None:
                newton.reset()  # Exudyn's solver runs on the system
            q1 = solve_at(model, ss, 0.0, q0)
        else:
            q1 = _advance(model, ss, q0, 0.0, 0.0, SUBSTEP_LEVELS, newton=newton)
        if abs(q1[car]) > MAX_CYCLE_ANGLE_RAD:
            raise RuntimeError(f"output angle {q1[car]:.4g} rad is not a deflection (jumped across the free play)")
        return q1

    def advance(q0, t0_, t1, level=0, first=False):
        if t0_ == 0.0 and t1 != 0.0 and by_continuation[0]:  # out of the free play as the last time (see below)
            try:
                return stiffened(q0, t1)
            except _Abort:
                raise
            except Exception:  # noqa: BLE001 - Exudyn raises its own error types
                pass
        try:
            return solve(q0, t1, first)
        except _Abort:
            raise
        except Exception:
            if t1 == 0.0:  # floating at zero torque: a small torque on the side the path comes from
                return solve(q0, (np.sign(t0_) or 1.0) * ZERO_TORQUE_SHIFT * amplitude)
            # a step out of zero torque is not bisected: its smaller torques float in the free play as it does
            # (measured: RV-40E with 3.3 µm crank-bearing clearance, every bisection of 0 → 2.06 N·m failed and
            # the continuation took it; 0.6 s of a 1.5 s cycle)
            if level >= TORQUE_BISECTIONS or t0_ == 0.0:
                raise
            mid = 0.0 if t0_ * t1 < 0 else 0.5 * (t0_ + t1)  # cross the free play through zero torque
            return advance(advance(q0, t0_, mid, level + 1), mid, t1, level + 1)

    def stiffened(q0, t):
        try:
            for k in REGULARISER_CONTINUATION_NM_RAD:
                mbs.SetObjectParameter(model.carrier.regulariser, "stiffness", k)
                q0 = solve(q0, t, first=True)
        finally:
            mbs.SetObjectParameter(model.carrier.regulariser, "stiffness", OUTPUT_REGULARISER_NM_RAD)
        return solve(q0, t, first=True)

    def again(t):
        # the state converged at this torque before (a cycle's second leg revisits its first leg's torques),
        # else the unloaded kinematic one: without friction both lead to the same equilibrium
        if t in solved:
            try:
                return solve(solved[t], t, first=True)
            except _Abort:
                raise
            except Exception:  # noqa: BLE001 - Exudyn raises its own error types
                pass
        return stiffened(q_kin, t)

    q, prev, done = q_kin.copy(), 0.0, 0
    by_continuation = [False]  # a step out of zero torque needed the continuation
    solved = {}  # torque → the state converged there
    skipped = -2  # the last step left out
    try:
        for j, torque in enumerate(torques):
            try:
                q = advance(q, prev, float(torque), first=(j == 0))
            except _Abort:
                raise
            except Exception as err:
                t = float(torque)
                # a zero torque that floats (even by the continuation) is taken at the small torque on the side
                # the path comes from (a cycle's first step, out of the kinematic state: the positive side)
                shifted = (np.sign(prev) or 1.0) * ZERO_TORQUE_SHIFT * amplitude
                attempts = [(from_last, at) for at in ((t, shifted) if t == 0.0 else (t,)) for from_last in (True, False)]
                for k, (from_last, at) in enumerate(attempts):
                    try:
                        q = stiffened(q, at) if from_last else again(at)
                    except _Abort:
                        raise
                    except Exception:  # noqa: BLE001 - Exudyn raises its own error types
                        continue
                    # a step out of zero torque that only the continuation took: the next one out of zero
                    # torque (the cycle's reversal) starts with it (the equilibrium at a non-zero torque does
                    # not depend on the path, see 3.)
                    by_continuation[0] = by_continuation[0] or (k == 0 and prev == 0.0)
                    break
                else:
                    if skip_unsolved and 0 < j < len(torques) - 1 and skipped != j - 1:
                        skipped = j
                        done = j + 1
                        if progress is not None:
                            progress(done, len(torques))
                        continue  # NaN; the next step starts from the last converged state
                    raise SolveError(f"torque step {j} ({torque:.3f} N·m) did not converge: {err}",
                                     result(done)) from None
            out[j] = q[car]
            spatial.record(j, q)
            solved[float(torque)] = q
            prev = float(torque)
            done = j + 1
            if progress is not None:
                progress(done, len(torques))
    except _Abort as abort:
        raise abort.__cause__ from None
    return result(len(torques))


@dataclass(frozen=True)
class DynamicResult:
    """Dynamic run sampled every step: time (s), input and output angles (rad), TE (rad)."""

    time_s: np.ndarray
    theta_in: np.ndarray
    theta_out: np.ndarray
    te_rad: np.ndarray
    ratio: float
    wall_s: float


def input_angle(t: float, omega_in: float, ramp_s: float) -> float:
    """Input angle of a smooth speed ramp ω(t) = ω·(3x² − 2x³), x = t/ramp, then constant (rad)."""
    if t >= ramp_s:
        return omega_in * (t - 0.5 * ramp_s)
    x = t / ramp_s
    return omega_in * ramp_s * (x**3 - 0.5 * x**4)


def dynamic(model: ReducerModel, speed_out_rpm: float, output_revolutions: float, torque_out_Nm: float = 0.0, *,
            step_s: float = 1e-4, ramp_s: float = 0.2, spectral_radius: float = 0.8) -> DynamicResult:
    """Generalized-α run: the input follows a smooth speed ramp to the speed giving
    ``speed_out_rpm`` at the output, against a constant resisting output torque; it starts
    from the static loaded state at input angle 0 and covers the ramp plus
    ``output_revolutions`` at constant speed.

    The input drive and the penetration guard are one Python call each per time step (not
    per contact).
    """
    import exudyn as exu

    if not speed_out_rpm > 0:
        raise ValueError(f"speed_out_rpm = {speed_out_rpm!r}: must be positive in dynamic mode")
    mbs = model.mbs
    quasi_static(model, np.array([0.0]), torque_out_Nm)  # leaves the system in the loaded static state
    q0 = np.asarray(mbs.systemData.GetODE2Coordinates())
    mbs.SetObjectParameter(model.carrier.regulariser, "stiffness", 0.0)  # dynamics: inertia regularises
    omega_in = speed_out_rpm * 2 * np.pi / 60.0 * model.ratio
    mbs.SetObjectParameter(model.sun.drive, "offsetUserFunction",
                           lambda mbs_, t, item, lOffset: input_angle(t, omega_in, ramp_s))
    # the angles are recorded by the post-Newton function (one Python call per step, which also
    # guards the contacts' penetration): no sensors are added, so the caller's model keeps its items
    contacts = list(model.discs.contacts)
    i_in, i_out = model.planar_index()["sun"][2], model.output_index
    ref_in, ref_out = model.reference[i_in], model.reference[i_out]
    rows = [(0.0, q0[i_in] + ref_in, q0[i_out] + ref_out)]
    sd = mbs.systemData

    def post_newton(mbs_, t):
        for c in contacts:
            c.check_penetration(t)
        q = sd.GetODE2Coordinates()
        rows.append((t, q[i_in] + ref_in, q[i_out] + ref_out))
        return [0.0, 0.0]

    mbs.SetPostNewtonUserFunction(post_newton)
    # a system changed since it was last assembled (the caller's sensors, the items' new parameters) is assembled
    # here, not by SolveDynamic: assembling sets the coordinates to the nodes' initial (unloaded) values, so done
    # after the loaded state is set it would start the run unloaded under the full torque (measured: a seed 000
    # run with sensors added, whose loaded state the compiled step had reached without Exudyn's solver, rang for
    # over a second: 26.7″ p-p in the window instead of 0.19″)
    if not mbs.systemIsConsistent:
        mbs.Assemble()
    mbs.systemData.SetODE2Coordinates(q0, configuration=exu.ConfigurationType.Initial)
    end = ramp_s + output_revolutions * 60.0 / speed_out_rpm
    # the residual's round-off floor is ~5e-9; angles reach 1e3 rad, so the Jacobian's
    # relative increments must stay ≪ the bearings' 0.1 µm smoothing band
    ss = generalized_alpha_settings(end, step_s, spectral_radius, relative_tolerance=1e-7,
                                    differentiation_epsilon=1e-10)
    t0 = time.perf_counter()
    try:
        mbs.SolveDynamic(ss)
    finally:
        mbs.SetPostNewtonUserFunction(0)
        mbs.SetObjectParameter(model.sun.drive, "offsetUserFunction", 0)
        mbs.SetObjectParameter(model.carrier.regulariser, "stiffness", OUTPUT_REGULARISER_NM_RAD)
    wall = time.perf_counter() - t0
    a = np.asarray(rows, float)
    th_in, th_out = a[:, 1], a[:, 2]
    return DynamicResult(a[:, 0], th_in, th_out, th_out - th_in / model.ratio, model.ratio, wall)

"""``rvflex bench te``: the cost of one quasi-static TE step, per fidelity and unit, in units of the contact
kernel's own evaluation measured in the same run.

For each built-in unit and each case (rigid; rigid with seed 001's errors and their 12 µm crank-bearing
clearances; rigid under half its allowable tilting moment with the pin contact in :data:`~rvflex.tilt.MOMENT_SLICES`
slices along the face width; the spatial rigid model (:meth:`~rvflex.options.ModelOptions.spatial_rigid`, its
slices on the tilting discs), without and with half the allowable moment on the output, and with beam cranks (one
element per segment); FE discs; FE discs and carrier; FE discs, carrier and housing) one loaded TE run over
one output revolution is timed after a warm-up (compiled kernels, FE reductions from the cache). Its wall time per
step is divided by the unit's contact evaluation: every disc's cycloid–pin kernel (every slice of it), force and
Jacobian, at a loaded state (the median of many calls); a sliced case's budget is thus per slice. A second, profiled run of the same case splits the step into
contact kernels, assembly of the residual and Jacobian outside Exudyn, linear solves, Exudyn's own calls and
the Python of the stepping; the compiled step's share (:mod:`rvflex.engine`, one numba call per step or per run
of steps) is split by its counted evaluations and solves and their measured unit costs, the rest of it (its
assembly, the guesses and kinematics of a run of steps) counted as assembly.
"""

from __future__ import annotations

import cProfile
import dataclasses as dc
import os
import platform
import pstats
import time

import numpy as np

__all__ = ["CASES", "bench_te", "clearance_errors", "contact_evaluation_us", "table_md"]

CASES = ("rigid", "rigid-clearance", "rigid-moment", "spatial", "spatial-moment", "spatial-beam", "flexible",
         "flexible-carrier", "flexible-all")
UNITS = ("rv40e", "rv80e", "rv160n")
CONTACT_CALLS = 400  # calls timed for the contact unit (median of 8 blocks)


def clearance_errors(spec):
    """Seed 001's errors (rv40e_seed001: 12 µm crank-bearing clearances, runouts, pin errors) sized for
    ``spec``: per-crank and per-bearing entries repeated to its crank count, per-pin ones to its pins."""
    from rvflex.api import load_errors, load_reducer
    from rvflex.spec import ErrorSpec

    base = load_errors("rv40e_seed001", load_reducer("rv40e"))
    n_c, n_d, n_p = spec.cranks.count, len(spec.cycloid.disc_phase_rad), spec.cycloid.pin_count
    changes = {}
    for f in dc.fields(ErrorSpec):
        v = getattr(base, f.name)
        if isinstance(v, tuple) and v:
            if len(v) == 2:  # one per crank of the RV-40E
                changes[f.name] = tuple(v[0] for _ in range(n_c))
            elif len(v) == 4:  # one per crank bearing (cranks × discs)
                changes[f.name] = tuple(v[0] for _ in range(n_c * n_d))
            elif len(v) == 40:  # one per pin
                changes[f.name] = tuple(v[k % 40] for k in range(n_p))
    return dc.replace(base, **changes)


def _options(case: str):
    from rvflex.options import ModelOptions, SpatialSettings
    from rvflex.tilt import MOMENT_SLICES

    return {"rigid": ModelOptions.rigid, "rigid-clearance": ModelOptions.rigid,
            "rigid-moment": lambda: ModelOptions(face_slices=MOMENT_SLICES), "spatial": ModelOptions.spatial_rigid,
            "spatial-moment": ModelOptions.spatial_rigid,
            "spatial-beam": lambda: ModelOptions.spatial_rigid(MOMENT_SLICES, SpatialSettings(crank="beam")),
            "flexible": ModelOptions.flexible_discs,
            "flexible-carrier": ModelOptions.flexible_discs_and_carrier,
            "flexible-all": ModelOptions.flexible_all}[case]()


def _errors(spec, case: str):
    """The case's errors: seed 001's for ``rigid-clearance``, the pins moved against the carrier tilted by half the
    allowable moment for ``rigid-moment``, none otherwise."""
    if case == "rigid-clearance":
        return clearance_errors(spec)
    if case == "rigid-moment":
        from rvflex.tilt import carrier_tilt, tilted_errors

        return tilted_errors(None, carrier_tilt(spec, 0.5 * spec.allowable_moment_Nm))
    return None


def _output_load(spec, case: str):
    """The output load of a ``spatial-moment`` case: half the allowable moment (two-way, on the spatial carrier)."""
    if case != "spatial-moment":
        return None
    from rvflex.tilt import OutputLoad

    return OutputLoad(moment_Nm=0.5 * spec.allowable_moment_Nm)


def contact_evaluation_us(model, q_abs: np.ndarray) -> float:
    """Median wall time (µs) of one evaluation of every disc's cycloid–pin contact, force and Jacobian, as
    Exudyn's user functions call it (the unit of ``rvflex bench contact``), at the absolute coordinates
    ``q_abs`` (a loaded state): the unit of the step's cost."""
    mbs = model.mbs
    x = np.asarray(q_abs, float) - model.reference
    calls = []
    for c in model.discs.contacts:
        parts = []
        for node in (int(c.node), int(c.modal_node), int(c.housing_node)):
            if node >= 0:
                i = mbs.GetNodeODE2Index(node)
                parts.append(x[i:i + len(mbs.GetNode(node)["referenceCoordinates"])])
        q = np.concatenate(parts)
        calls.append((c, q, np.zeros_like(q)))
    for c, q, qd in calls:  # compile and warm
        c._force_uf(mbs, 0.0, 0, q, qd)
    blocks = []
    per_block = CONTACT_CALLS // 8
    for _ in range(8):
        t = time.perf_counter()
        for _ in range(per_block):
            for c, q, qd in calls:
                c._force_uf(mbs, 0.0, 0, q, qd)
                c._jacobian_uf(mbs, 0.0, 0, q, qd, 1.0, 0.0)
        blocks.append((time.perf_counter() - t) / per_block * 1e6)
    return float(np.median(blocks))


_CONTACT_FUNCS = ("evaluate", "evaluate_housing", "_force_uf", "_force_housing", "_jacobian_uf", "evaluate_points")
_SOLVE_FUNCS = ("lu_factor", "lu_solve", "getrf", "getrs")


def _split(prof: cProfile.Profile, counts: dict | None, t_contact_us: float, t_solve_us: float) -> dict:
    """Shares of a profiled run: contact kernels, assembly outside Exudyn, linear solves, Exudyn, Python
    (``counts``: the run's compiled-step counts, :attr:`rvflex.solve.QuasiStaticResult.compiled`)."""
    st = pstats.Stats(prof)
    total = 0.0
    parts = dict(contact=0.0, assembly=0.0, linear_solve=0.0, exudyn=0.0, python=0.0)
    compiled = 0.0
    for (file, _line, name), (_cc, _nc, tt, _ct, _callers) in st.stats.items():
        total += tt
        if "_cycloid_kernel" in file or (name in _CONTACT_FUNCS and "cycloid_pin" in file):
            parts["contact"] += tt
        elif "gear_mesh" in file:
            parts["assembly"] += tt
        elif name in _SOLVE_FUNCS or "scipy/linalg" in file:
            parts["linear_solve"] += tt
        elif "exudyn" in file or "exudynCPP" in name or file == "~" and "exudyn" in name:
            parts["exudyn"] += tt
        elif "engine.py" in file and name in ("_newton", "_steps") and counts is not None:
            compiled += tt  # a step at a time or a run of steps: split below by the counted evaluations
        else:
            parts["python"] += tt
    if compiled:
        contact = counts["evaluations"] * t_contact_us * 1e-6
        solve = counts["solves"] * t_solve_us * 1e-6
        parts["contact"] += min(contact, compiled)
        parts["linear_solve"] += min(solve, max(compiled - contact, 0.0))
        parts["assembly"] += max(compiled - contact - solve, 0.0)
    return {k: v / total for k, v in parts.items()} if total else parts


def _solve_us(n: int) -> float:
    """Median µs of one compiled dense solve of n unknowns (the compiled step's linear solve)."""
    from rvflex.engine import solve_dense

    rng = np.random.default_rng(0)
    a0 = rng.normal(size=(n, n)) + n * np.eye(n)
    b0 = rng.normal(size=n)
    perm = np.zeros(n, dtype=np.int64)
    solve_dense(a0.copy(), b0.copy(), perm)
    t = time.perf_counter()
    reps = 2000
    for _ in range(reps):
        solve_dense(a0.copy(), b0.copy(), perm)
    return (time.perf_counter() - t) / reps * 1e6


def bench_case(unit: str, case: str, positions: int, progress=None) -> dict:
    """One unit and case: wall per step, in contact evaluations, and the split of a profiled run."""
    from rvflex import solve
    from rvflex.api import load_reducer
    from rvflex.model import build_reducer

    spec = load_reducer(unit)
    errors = _errors(spec, case)
    t = time.perf_counter()
    model = build_reducer(spec, errors, _options(case))
    build_s = time.perf_counter() - t
    theta = np.linspace(0.0, 2.0 * np.pi * model.ratio, positions, endpoint=False)
    torque = spec.rated_torque_Nm
    load = _output_load(spec, case)
    solve.quasi_static(model, theta[:6], torque, output_load=load)  # compile, warm the caches
    t = time.perf_counter()
    res = solve.quasi_static(model, theta, torque, output_load=load)
    wall = time.perf_counter() - t
    counts = res.compiled
    q = np.asarray(model.mbs.systemData.GetODE2Coordinates()) + model.reference
    t_contact = contact_evaluation_us(model, q)
    prof = cProfile.Profile()
    prof.enable()
    profiled = solve.quasi_static(model, theta, torque, output_load=load)
    prof.disable()
    t_solve = _solve_us(counts["free"]) if counts is not None and counts["free"] else 0.0
    per_step_us = wall / positions * 1e6
    row = {
        "unit": unit, "case": case, "positions": positions, "dof": int(model.mbs.systemData.ODE2Size()),
        "solver": "compiled" if counts is not None else ("chord Newton" if model.modal_nodes else "Exudyn"),
        "build_s": build_s, "wall_s": wall, "per_step_ms": per_step_us / 1e3,
        "contact_evaluation_us": t_contact, "per_step_contact_evaluations": per_step_us / t_contact,
        "newton_evaluations_per_step": (counts["evaluations"] / positions) if counts is not None else None,
        "fallbacks": counts["fallbacks"] if counts is not None else None,
        "te_peak_to_peak_arcsec": float(np.ptp(res.te_rad) * 206264.806),
        "split": _split(prof, profiled.compiled, t_contact, t_solve),
    }
    if progress is not None:
        progress(f"{unit:7s} {case:17s} {row['per_step_ms']:7.3f} ms/step = "
                 f"{row['per_step_contact_evaluations']:6.1f} contact evaluations ({row['solver']})")
    return row


TARGETS = {"rigid": 8, "rigid-clearance": 12, "rigid-moment": 8, "spatial": 8, "spatial-moment": 8, "spatial-beam": 8,
           "flexible": 40, "flexible-carrier": 80}


def bench_te(units=UNITS, cases=CASES, positions: int = 2048, flexible_positions: int = 512, progress=None) -> dict:
    """Every unit × case (see the module docstring); rows, the issue's per-step targets and the machine."""
    load = os.getloadavg()
    rows = []
    for unit in units:
        for case in cases:
            n = positions if case.startswith(("rigid", "spatial")) else flexible_positions
            rows.append(bench_case(unit, case, n, progress))
    for r in rows:
        goal = TARGETS.get(r["case"])
        r["target_contact_evaluations"] = goal
        r["target_met"] = None if goal is None else bool(r["per_step_contact_evaluations"] <= goal)
    return {"rows": rows, "machine": {"platform": platform.platform(), "processor": platform.processor(),
                                      "cpus": os.cpu_count(), "python": platform.python_version()},
            "load": load}


def table_md(doc: dict) -> str:
    """The rows of :func:`bench_te`'s document as a Markdown table (the machine and load stated)."""
    m = doc["machine"]
    lines = [f"{m['cpus']} cores, {m['platform']}, Python {m['python']}; load average {doc['load'][0]:.1f} when the "
             "run started (other jobs share the cores when it is above ~1).", "",
             "| unit | case | solver | ms/step | contact evaluations | target | Newton evaluations | contact | "
             "assembly | linear solve | Exudyn | Python |", "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in doc["rows"]:
        sp = r["split"]
        goal = "" if r["target_contact_evaluations"] is None else \
            f"≤ {r['target_contact_evaluations']} {'met' if r['target_met'] else 'not met'}"
        ne = "" if r["newton_evaluations_per_step"] is None else f"{r['newton_evaluations_per_step']:.2f}"
        lines.append(f"| {r['unit']} | {r['case']} | {r['solver']} | {r['per_step_ms']:.3f} | "
                     f"{r['per_step_contact_evaluations']:.1f} | {goal} | {ne} | "
                     + " | ".join(f"{100 * sp[k]:.0f} %" for k in ("contact", "assembly", "linear_solve", "exudyn",
                                                                    "python")) + " |")
    return "\n".join(lines) + "\n"

"""The ``rvflex`` command. Thin: parse arguments, call the library, write outputs.

Everything is computed before anything is written, and files are written through a
temporary name and renamed, so a failed run leaves no half-written output.
"""

from __future__ import annotations

import argparse
import dataclasses
import io
import math
import os
import sys
import traceback
from pathlib import Path

import rvflex.scenarios  # noqa: F401 -- registers the scenarios sweeps run (rvflex.scenarios.sweepable)
from rvflex import catalog
from rvflex.bench_te import CASES as BENCH_TE_CASES
from rvflex.choices import Executor, PlanarFidelity, RunCostKind, TEMode, choices
from rvflex.io import emit, write_json, write_text
from rvflex.spec import ErrorSpec, ReducerSpec, SpecError
from rvflex.tilt import MOMENT_SLICES

__all__ = ["main"]

# The flag of each Python parameter a command sets: the library's errors name the parameter
# (``load_Nm``), the command's errors the flag (``--load``), with the flag's own spelling of
# the value where it differs.
_LOAD_FLAGS = {"moment_Nm": "--moment", "moment_angle_rad": "--moment-angle-deg", "axial_force_N": "--axial-force",
               "radial_force_N": "--radial-force", "radial_angle_rad": "--radial-angle-deg", "face_slices": "--slices",
               "crank": "--crank", "crank_elements": "--crank-elements"}
_TE_FLAGS = {"load_Nm": "--load", "revolutions": "--revs", "positions_per_rev": "--positions", "mode": "--mode",
             "speed_out_rpm": "--speed-out", "direction": "--direction", "options": "--fidelity", **_LOAD_FLAGS}
_LOST_MOTION_FLAGS = {"torque_Nm": "--torque", "steps": "--steps", "options": "--fidelity", **_LOAD_FLAGS}
_BACKLASH_FLAGS = {"load_Nm": "--load", "options": "--fidelity", **_LOAD_FLAGS}
_SWEEP_FLAGS = {"executor": "--executor", "scheduler": "--scheduler", "workers": "--workers"}
_FLAG_VALUES = {"--direction": {1: "forward", -1: "reverse"}}


def _flag_error(err: SpecError, flags: dict[str, str]) -> SpecError:
    """``err`` naming the command's flag instead of the Python parameter it sets (unchanged when
    the field is not one of ``flags``)."""
    flag = flags.get(err.field)
    if flag is None:
        return err
    value = _FLAG_VALUES.get(flag, {}).get(err.value, err.value)
    return SpecError(flag, value, err.rule, err.source)


def _with_progress(total: int, desc: str, run):
    """Call ``run(progress)`` under a progress bar on stderr; returns its result and the wall time (s)."""
    import time

    from tqdm import tqdm

    t0 = time.perf_counter()
    with tqdm(total=total, desc=desc, unit="step", file=sys.stderr, mininterval=0.5) as bar:
        result = run(lambda done, n: bar.update(done - bar.n))
    return result, time.perf_counter() - t0


def _model_inputs(args: argparse.Namespace) -> tuple[ReducerSpec, ErrorSpec]:
    """Spec and errors of a model command (``--reducer``, ``--fidelity``, ``--errors``, ``--perfect``)."""
    from rvflex.scenarios.loaded_te import perfect_spec

    spec = catalog.resolve(args.reducer)
    if args.perfect:
        return perfect_spec(spec), ErrorSpec()
    return spec, catalog.resolve_errors(args.errors, spec) or ErrorSpec()


def _cmd_geometry(args: argparse.Namespace) -> int:
    from rvflex.geometry.report import geometry_report, plot_profile

    spec = catalog.resolve(args.reducer)
    errors = catalog.resolve_errors(args.errors, spec)
    report = geometry_report(spec, errors)
    print(report.text())
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        tmp = out / f".profile_{os.getpid()}.png"
        try:
            plot_profile(spec, tmp, errors)
            os.replace(tmp, out / "profile.png")
        finally:
            tmp.unlink(missing_ok=True)
        write_json(out / "geometry.json", report.as_json())
        print(f"wrote {out / 'profile.png'} and {out / 'geometry.json'}")
    if args.json:
        write_json(Path(args.json), report.as_json())
    return 0


def _output_load(args: argparse.Namespace):
    """The :class:`~rvflex.tilt.OutputLoad` of ``--moment``, ``--axial-force`` and ``--radial-force`` (None: none)."""
    from rvflex.tilt import OutputLoad

    load = OutputLoad(args.moment or 0.0, math.radians(args.moment_angle_deg), args.axial_force or 0.0,
                      args.radial_force or 0.0, math.radians(args.radial_angle_deg))
    return load if load.any else None


def _loaded_options(args: argparse.Namespace, load):
    """``_options(args)`` with ``--slices`` (default :data:`~rvflex.tilt.MOMENT_SLICES` under an output load or
    with ``--spatial``), the spatial rigid model with ``--spatial`` (refused with another ``--fidelity``), its
    cranks by ``--crank`` and ``--crank-elements`` (refused without ``--spatial``)."""
    from rvflex.options import ModelOptions, SpatialSettings

    spatial = getattr(args, "spatial", False)
    slices = args.slices if args.slices is not None else (MOMENT_SLICES if load is not None or spatial else 1)
    crank, elements = getattr(args, "crank", None), getattr(args, "crank_elements", None)
    if spatial:
        if args.fidelity != "rigid":
            raise SpecError("--spatial", True, f"takes rigid parts only (--fidelity rigid), got --fidelity "
                                               f"{args.fidelity}: FE bodies free out of their plane are not built yet")
        _options(args)  # the --fe-* flags are refused as with --fidelity rigid
        if elements is not None and crank != "beam":
            raise SpecError("--crank-elements", elements, "applies to --crank beam only")
        return ModelOptions.spatial_rigid(slices, SpatialSettings(crank=crank or "rigid",
                                                                  crank_elements=1 if elements is None else elements))
    for flag, value in (("--crank", crank), ("--crank-elements", elements)):
        if value is not None:
            raise SpecError(flag, value, "applies to the spatial model only (add --spatial): the planar model's "
                                         "cranks are rigid")
    return dataclasses.replace(_options(args), face_slices=slices)


def _tilt_report(scenario, doc: dict, raw=None) -> None:
    """Print how the output load moves the carrier and add it to ``doc`` (nothing without a load).

    The planar model (``raw`` None, before the run): the carrier's tilt and shift on its main bearing pair alone,
    which the model takes as moved pins. The spatial model (``raw`` the solver's record, after the run): the tilt,
    shift and disc tilts solved with the gear train (means over the run's steps) beside the pair-alone ones."""
    import numpy as np

    from rvflex.geometry.formulas import ARCMIN_PER_RAD
    from rvflex.geometry.pins import disc_planes

    tilt = scenario.tilt
    if tilt is None:
        return
    ld = tilt.load
    parts = [f"moment {ld.moment_Nm:g} N·m at {math.degrees(ld.moment_angle_rad):g}°"] if ld.moment_Nm else []
    parts += [f"axial force {ld.axial_force_N:g} N"] if ld.axial_force_N else []
    parts += [f"radial force {ld.radial_force_N:g} N at {math.degrees(ld.radial_angle_rad):g}°"] if ld.radial_force_N else []
    load = {k: float(v) for k, v in dataclasses.asdict(ld).items()}
    if raw is not None and getattr(raw, "carrier_tilt_rad", None) is not None:
        theta = np.nanmean(raw.carrier_tilt_rad, axis=0)
        shift = np.nanmean(raw.carrier_shift_m, axis=0)
        discs = np.nanmean(raw.disc_tilt_rad, axis=0)
        print(f"output load {', '.join(parts)}, solved with the gear train (spatial model, mean over the run): the "
              f"carrier tilts {np.hypot(*theta) * ARCMIN_PER_RAD:.3f}′ (on its main bearing pair alone "
              f"{tilt.tilt_arcmin:.3f}′) and moves {np.hypot(*shift[:2]) * 1e6:.2f} µm radially, "
              f"{shift[2] * 1e6:.2f} µm along the axis; the discs tilt "
              + ", ".join(f"{np.hypot(*t) * ARCMIN_PER_RAD:.3f}′" for t in discs)
              + f" ({tilt.balls_in_contact} balls loaded, {tilt.peak_pressure_Pa / 1e9:.2f} GPa at the most loaded, "
                f"pair alone)")
        doc["output_load"] = {**load, "carrier_tilt_rad": theta.tolist(),
                              "carrier_tilt_arcmin": float(np.hypot(*theta) * ARCMIN_PER_RAD),
                              "carrier_shift_m": shift.tolist(), "disc_tilt_rad": discs.tolist(),
                              "pair_carrier_tilt_rad": list(tilt.tilt_rad), "pair_carrier_tilt_arcmin": tilt.tilt_arcmin,
                              "pair_carrier_shift_m": list(tilt.shift_m), "peak_ball_pressure_Pa": tilt.peak_pressure_Pa}
        return
    shift = np.mean([np.hypot(*tilt.disc_shift_m(z)) for z in disc_planes(scenario.spec)])
    print(f"output load {', '.join(parts)}: the carrier tilts {tilt.tilt_arcmin:.3f}′ and moves "
          f"{np.hypot(*tilt.shift_m) * 1e6:.2f} µm on its main bearing pair ({tilt.balls_in_contact} balls loaded, "
          f"{tilt.peak_pressure_Pa / 1e9:.2f} GPa at the most loaded); the discs move {shift * 1e6:.2f} µm against "
          f"the pins at their mid-planes")
    doc["output_load"] = {**load, "carrier_tilt_rad": list(tilt.tilt_rad), "carrier_tilt_arcmin": tilt.tilt_arcmin,
                          "carrier_shift_m": list(tilt.shift_m), "peak_ball_pressure_Pa": tilt.peak_pressure_Pa}


def _cmd_te(args: argparse.Namespace) -> int:
    import numpy as np

    import rvflex

    spec, errors = _model_inputs(args)
    load = _output_load(args)
    options = _loaded_options(args, load)
    scenario = rvflex.LoadedTE(spec, errors, spec.rated_torque_Nm if args.load is None else args.load,
                               args.revs, args.positions, 1 if args.direction == "forward" else -1, args.mode,
                               spec.rated_output_speed_rpm if args.speed_out is None else args.speed_out,
                               options=options, output_load=load)
    doc = {}
    spatial = options.spatial is not None
    if not spatial:
        _tilt_report(scenario, doc)
    result, wall = _with_progress(scenario.n_positions, "loaded TE",
                                  lambda progress: rvflex.run(scenario, progress=progress))
    if spatial:
        _tilt_report(scenario, doc, result.raw)
    met, n = result.metrics, len(result.raw.te_rad)
    doc = {
        "te_pp_arcsec": met.te_pp_arcsec, "te_min_arcsec": met.te_min_arcsec, "te_max_arcsec": met.te_max_arcsec,
        "mean_windup_arcsec": met.mean_windup_arcsec,
        "orders": [{"order": o, "amplitude_arcsec": a} for o, a in met.orders],
        "n_positions": n, "wall_s": wall, "solve_s": result.raw.wall_s, "face_slices": options.face_slices, **doc,
    }
    print(f"TE peak-to-peak {met.te_pp_arcsec:.3f}″ (min {met.te_min_arcsec:.2f}″, max {met.te_max_arcsec:.2f}″), "
          f"mean wind-up {met.mean_windup_arcsec:.2f}″, {n} positions in {wall:.1f} s "
          f"(solver {result.raw.wall_s:.1f} s, the rest builds the model)")
    print("strongest orders: " + ", ".join(f"{o}: {a:.3f}″" for o, a in met.orders[:5]))
    loads = result.pin_end_loads()
    if loads is not None:
        doc["pin_loads"] = {k: np.asarray(v).tolist() for k, v in loads.items()}
        ends = loads["end_line_load_N_m"] / 1e3
        print("largest line load on the pins (N/mm) at the discs' faces −z / +z: " + "; ".join(
            f"disc {d + 1} {lo:.1f} / {hi:.1f}" for d, (lo, hi) in enumerate(ends))
              + f" (mean over the face width at most {loads['mid_line_load_N_m'].max() / 1e3:.1f}; "
                f"{options.face_slices} slices)")
    cranks = getattr(result.raw, "crank_tilt_rad", None)
    if cranks is not None:  # the spatial model: each crank's tilt in its support pair, largest over the run
        from rvflex.geometry.formulas import ARCSEC_PER_RAD

        most = np.nanmax(cranks, axis=0) * ARCSEC_PER_RAD
        doc["crank_tilt_max_arcsec"] = most.tolist()
        print("largest crank tilt in its support pair over the run: "
              + ", ".join(f"crank {k + 1} {t:.1f}″" for k, t in enumerate(most)))
    return emit(args, doc, result.write)


def _cmd_lost_motion(args: argparse.Namespace) -> int:
    import rvflex

    spec, errors = _model_inputs(args)
    load = _output_load(args)
    sc = rvflex.LostMotion(spec, errors, spec.rated_torque_Nm if args.torque is None else args.torque,
                           args.steps, _loaded_options(args, load), output_load=load)
    extra = {}
    spatial = sc.options.spatial is not None
    if not spatial:
        _tilt_report(sc, extra)
    result, wall = _with_progress(len(sc.torques_Nm), "hysteresis",
                                  lambda progress: rvflex.run(sc, progress=progress))
    if spatial:
        _tilt_report(sc, extra, result.raw)
    met = result.metrics
    doc = {**result.metrics_dict(), "wall_s": wall, **extra}
    print(f"lost motion {met.lost_motion_arcmin:.4f}′, hysteresis loss {met.hysteresis_loss_arcmin:.4f}′, "
          f"torsional stiffness {met.torsional_stiffness_Nm_per_arcmin:.2f} N·m/arcmin "
          f"(secant ±T {met.secant_stiffness_Nm_per_arcmin:.2f}), "
          f"backlash {met.backlash_arcmin:.4f}′ ({len(result.raw.torque_Nm)} steps in {wall:.1f} s)")
    return emit(args, doc, result.write)


def _cmd_backlash(args: argparse.Namespace) -> int:
    import rvflex

    spec, errors = _model_inputs(args)
    load = _output_load(args)
    sc = rvflex.ReversalBacklash(spec, errors, args.load, options=_loaded_options(args, load), output_load=load)
    extra = {}
    spatial = sc.options.spatial is not None
    if not spatial:
        _tilt_report(sc, extra)
    result = rvflex.run(sc)
    if spatial:
        _tilt_report(sc, extra, result.forward)
    doc = {**result.metrics_dict(), "wall_s": result.wall_s, **extra}
    print(f"reversal backlash {result.metrics.reversal_backlash_arcmin:.4f}′ at ±{sc.load_Nm:g} N·m "
          f"({doc['wall_s']:.1f} s)")
    return emit(args, doc, result.write)


def _cmd_sweep(args: argparse.Namespace) -> int:
    import csv

    from tqdm import tqdm

    from rvflex.studies import sweep
    from rvflex.sweeps import (
        SALIB_KINDS,
        classify,
        design_points,
        load_design,
        plot_indices,
        plot_main_effects,
        range_table,
        registry,
        sensitivity_indices,
        write_indices_csv,
    )

    design = load_design(args.design)
    out = Path(args.out or Path("out") / "sweeps" / design.name)
    n = len(design_points(design))
    with tqdm(total=n, desc=f"sweep {design.name}", unit="point", file=sys.stderr, mininterval=0.5) as bar:
        res = sweep(design, out / f"{design.name}.sqlite", executor=args.executor, workers=args.workers,
                    scheduler=args.scheduler, progress=lambda done, total: bar.update(done - bar.n))
    entry = registry.get(design.scenario)
    metric, unit = entry.metric, entry.unit
    keys = sorted({k for r in res.rows for k in r})
    fh = io.StringIO(newline="")
    w = csv.DictWriter(fh, fieldnames=keys)
    w.writeheader()
    w.writerows(res.rows)
    write_text(out / "table.csv", fh.getvalue())
    print(f"{res.finished} of {n} points finished, {res.failed} failed, {res.wall_s:.1f} s "
          f"(+ {res.startup_s:.1f} s start-up; {res.executor}, {res.workers} workers); table in {out / 'table.csv'}")
    print(f"model ({design.options.fidelity}): {design.options.describe()}")
    doc = {"points": n, "finished": res.finished, "failed": res.failed, "wall_s": res.wall_s,
           "startup_s": res.startup_s, "executor": res.executor, "workers": res.workers,
           "model": design.options.as_dict(), "ranking": []}
    if design.kind in SALIB_KINDS:
        try:
            indices = sensitivity_indices(design, res.rows, metric)
        except ValueError as err:
            raise SpecError("sweep", design.name, str(err)) from None
        classes = classify(indices, key="index")
        doc["ranking"] = [{**r, "class": classes.get(r["factor"], "")} for r in indices]
        print(f"indices in {write_indices_csv(indices, classes, out / 'indices.csv')}, "
              f"plot in {plot_indices(design, indices, metric, out / 'indices.png')}")
        for r in indices:
            conf = r["mu_star_conf"] if r["index_name"] == "mu_star" else r["ST_conf"]
            extra = (f"σ {r['sigma']:.4f} {unit}" if r["index_name"] == "mu_star"
                     else f"S1 {r['S1']:.3f} ± {r['S1_conf']:.3f}")
            print(f"  {r['factor']:32s} {r['index_name']} {r['index']:.4f} ± {conf:.4f}  {extra}  "
                  f"{classes.get(r['factor'], '')}")
        if args.json:
            write_json(Path(args.json), doc)
        return 0
    ranking = (range_table(design, res.rows, metric) if design.kind not in ("lhs", "sobol", "monte-carlo") else [])
    classes = classify(ranking)
    doc["ranking"] = [{"factor": r["factor"], f"range_{unit}": r["range"], "class": classes[r["factor"]]}
                      for r in ranking]
    if ranking:
        fh = io.StringIO(newline="")
        w = csv.writer(fh)
        k = max(len(r["K"]) for r in ranking)
        w.writerow(["factor"] + [f"K{j + 1}" for j in range(k)] + ["R", "class"])
        for r in ranking:
            w.writerow([r["factor"]] + r["K"] + [""] * (k - len(r["K"])) + [r["range"], classes[r["factor"]]])
        write_text(out / "range_table.csv", fh.getvalue())
        print(f"main effects in {plot_main_effects(design, ranking, metric, out / 'main_effects.png')}")
    for r in ranking:
        print(f"  {r['factor']:32s} range {r['range']:.4f} {unit}  {classes[r['factor']]}")
    if args.json:
        write_json(Path(args.json), doc)
    return 0


def _cmd_bench_sweep(args: argparse.Namespace) -> int:
    import tempfile as tf

    from rvflex.sweeps import bench_sweep

    with tf.TemporaryDirectory() as tmp:
        res = bench_sweep(Path(tmp) / "stores", args.points, args.speedup_points,
                          progress=lambda m: print(m, file=sys.stderr))
    for key, value in res.items():
        print(f"{key:20s} {value:.4g}" if isinstance(value, float) else f"{key:20s} {value}")
    mc = ("met" if res["mc_wall_s"] <= 600 else "NOT met") if res["mc_points"] >= 100 else \
        f"not measured ({res['mc_points']} points)"
    print(f"target 100-point MC ≤ 600 s: {mc}; "
          f"speed-up 1→2 workers ≥ 1.8: {'met' if res['speedup'] >= 1.8 else 'NOT met'} "
          f"(busy {res['busy_1_worker']:.2f} / {res['busy_2_workers']:.2f}: below ~0.95 other jobs share the cores; "
          f"CPU-makespan speed-up {res['speedup_cpu']:.2f})")
    if args.json:
        write_json(Path(args.json), res)
    return 0


def _cmd_bench_contact(args: argparse.Namespace) -> int:
    from rvflex.contact.bench import bench_contact

    if args.segments < 100:
        raise SpecError("--segments", args.segments, "the polygon contact needs at least 100 segments")
    result = bench_contact(args.segments, progress=lambda msg: print(msg, file=sys.stderr))
    targets = [
        ("eval_us_per_call", result["eval_us_per_call"] <= 50.0, "≤ 50 µs"),
        ("speedup", result["speedup"] >= 10.0, "≥ 10×"),
        ("geometric error ratio", result["curvecircles_geom_error_m"] >= 100 * result["ours_geom_error_m"], "≥ 100×"),
    ]
    for key, value in result.items():
        if key != "load_case":
            print(f"{key:32s} {value:.6g}" if isinstance(value, float) else f"{key:32s} {value}")
    for name, ok, goal in targets:
        print(f"target {name:24s} {goal:8s} {'met' if ok else 'NOT met'}")
    if args.json:
        write_json(Path(args.json), result)
    return 0


def _cmd_bench_te(args: argparse.Namespace) -> int:
    from rvflex.bench_te import bench_te

    if args.positions < 16 or args.flexible_positions < 16:
        raise SpecError("--positions", min(args.positions, args.flexible_positions), "needs at least 16 positions")
    res = bench_te(tuple(args.units), tuple(args.cases), args.positions, args.flexible_positions,
                   progress=lambda msg: print(msg, file=sys.stderr))
    print(f"{'unit':8s} {'case':17s} {'solver':12s} {'ms/step':>8s} {'contact evals':>13s} {'target':>7s} "
          f"{'Newton evals':>12s} {'contact':>8s} {'assembly':>8s} {'solve':>6s} {'Exudyn':>7s} {'Python':>7s}")
    for r in res["rows"]:
        sp = r["split"]
        goal = "" if r["target_contact_evaluations"] is None else \
            f"≤{r['target_contact_evaluations']}{'' if r['target_met'] else '!'}"
        ne = "" if r["newton_evaluations_per_step"] is None else f"{r['newton_evaluations_per_step']:.2f}"
        print(f"{r['unit']:8s} {r['case']:17s} {r['solver']:12s} {r['per_step_ms']:8.3f} "
              f"{r['per_step_contact_evaluations']:13.1f} {goal:>7s} {ne:>12s} "
              + " ".join(f"{100 * sp[k]:7.0f}%" for k in ("contact", "assembly", "linear_solve", "exudyn", "python")))
    print("contact evals: wall per step / one evaluation of every disc's contact kernel, measured in the same run; "
          "split: shares of a profiled run of the same case ('!' : target not met)")
    if args.json:
        write_json(Path(args.json), res)
    if args.md:
        from rvflex.bench_te import table_md
        from rvflex.io import write_atomic

        write_atomic(Path(args.md), table_md(res).encode())
    return 0


def _cmd_bench_diagnosis(args: argparse.Namespace) -> int:
    from rvflex.diagnosis.runcost import bench_model_runs

    if args.repeats < 1:
        raise SpecError("--repeats", args.repeats, "must be an integer ≥ 1")
    res = bench_model_runs(tuple(args.units), tuple(args.kinds), max_order=args.max_order, repeats=args.repeats,
                           progress=lambda msg: print(msg, file=sys.stderr))
    ref = res["reference"]
    print(f"{'unit':28s} {'run kind':12s} {'positions/rev':>13s} {'torque steps':>12s} {'CPU (s)':>8s} "
          f"{'wall (s)':>8s} {'× ' + ref:>10s}")
    for r in res["rows"]:
        print(f"{r['unit']:28s} {r['kind']:12s} {r['positions_per_rev']:13d} {r['torque_steps']:12d} {r['cpu_s']:8.2f} "
              f"{r['wall_s']:8.2f} {res['ratio'][r['unit']][r['kind']]:10.2f}")
    for unit, by in res["ratio"].items():
        if unit != ref:
            worst, kind = max((v, k) for k, v in by.items())
            print(f"target {unit}: model run ≤ {res['target_ratio']:g}× the {ref}'s (CPU): "
                  f"{'met' if worst <= res['target_ratio'] else 'NOT met'} (largest {worst:.2f}×, {kind})")
    if args.json:
        write_json(Path(args.json), res)
    return 0


def _model_arguments(p: argparse.ArgumentParser) -> None:
    """--reducer, --fidelity and --fe-* of the model commands (see :func:`_model_inputs`, :func:`_options`)."""
    from rvflex.options import CARRIER_FE, DISC_FE

    p.add_argument("--reducer", required=True, help=f"built-in reducer ({', '.join(catalog.names())}) or a spec TOML path")
    p.add_argument("--fidelity", default="rigid", choices=choices(PlanarFidelity),
                   help="rigid bodies (ModelOptions.rigid()); flexible: FE-reduced (Craig–Bampton, FFRF) cycloid "
                        "discs (ModelOptions.flexible_discs()); flexible-carrier: FE discs and carrier "
                        "(ModelOptions.flexible_discs_and_carrier(): output face = output frame, RBE3 seats, two "
                        "support bearings per crank); flexible-all: FE discs, carrier and pin housing "
                        "(ModelOptions.flexible_all(): the pins ride on the housing's seats). Reductions are cached under $RVFLEX_CACHE_DIR or "
                        "~/.cache/rvflex (default rigid)")
    fe = p.add_argument_group(
        "FE disc reduction (with --fidelity flexible, flexible-carrier or flexible-all; each flag overrides one field of the "
        f"preset's disc settings: {DISC_FE.maxh_m:g} m, order {DISC_FE.mesh_order}, {DISC_FE.n_modes} modes, "
        f"{DISC_FE.attach_per_tooth} attachment patches/tooth; carrier: {CARRIER_FE.maxh_m:g} m, order "
        f"{CARRIER_FE.mesh_order}, {CARRIER_FE.n_modes} modes, {CARRIER_FE.seat_coupling} seats)")
    fe.add_argument("--fe-maxh", type=float, dest="fe_maxh_m", help=f"mesh size, m (default {DISC_FE.maxh_m:g})")
    fe.add_argument("--fe-modes", type=int, dest="fe_n_modes",
                    help=f"fixed-interface eigenmodes (default {DISC_FE.n_modes})")
    fe.add_argument("--fe-attach", type=int, dest="fe_attach_per_tooth",
                    help=f"flank attachment modes per tooth (default {DISC_FE.attach_per_tooth})")
    fe.add_argument("--fe-order", type=int, dest="fe_mesh_order", choices=(1, 2),
                    help=f"tet order (default {DISC_FE.mesh_order})")


def _options(args: argparse.Namespace):
    """The :class:`~rvflex.options.ModelOptions` of ``--fidelity`` with the ``--fe-*`` disc overrides."""
    from rvflex.options import ModelOptions

    flags = {"fe_maxh_m": "--fe-maxh", "fe_n_modes": "--fe-modes", "fe_attach_per_tooth": "--fe-attach",
             "fe_mesh_order": "--fe-order"}
    given = {k: getattr(args, k) for k in flags if getattr(args, k) is not None}
    options = ModelOptions.preset(args.fidelity)
    if not given:
        return options
    if not options.flexible_discs_on:
        k = next(iter(given))
        raise SpecError(flags[k], given[k], "applies to --fidelity flexible, flexible-carrier or flexible-all only")
    return options.with_fe("discs", **{k[3:]: v for k, v in given.items()})


def _load_arguments(p: argparse.ArgumentParser) -> None:
    """--moment, --axial-force, --radial-force (with their directions) and --slices of the model commands."""
    p.add_argument("--moment", type=float,
                   help="tilting moment on the output, N·m, up to the spec's allowable moment: the carrier tilts on "
                        "its main bearing pair and the discs with it against the pins (default: none)")
    p.add_argument("--moment-angle-deg", type=float, default=0.0,
                   help="direction of the moment vector in the housing frame, degrees from +x (default 0)")
    p.add_argument("--axial-force", type=float, help="axial force on the output, N, positive along +z (default 0)")
    p.add_argument("--radial-force", type=float, help="radial force on the output at the main bearing pair's centre, "
                                                      "N ≥ 0 (default 0)")
    p.add_argument("--radial-angle-deg", type=float, default=0.0,
                   help="direction of the radial force in the housing frame, degrees from +x (default 0)")
    p.add_argument("--slices", type=int,
                   help=f"slices of the pin contact along the face width (default {MOMENT_SLICES} under an output "
                        f"load or with --spatial, else 1; at least 2 with --spatial; docs/spatial.md: convergence)")
    p.add_argument("--spatial", action="store_true",
                   help="the spatial rigid model: carrier, cranks and discs free out of their plane, the output load "
                        "on the carrier and its tilt solved with the gear train (with --fidelity rigid only; "
                        "docs/spatial.md)")
    p.add_argument("--crank", choices=("rigid", "beam"),
                   help="the spatial model's cranks: rigid bodies, or flexible (Timoshenko) shafts carrying the "
                        "eccentrics and the planet gear at their planes (with --spatial only; default rigid)")
    p.add_argument("--crank-elements", type=int,
                   help="beam elements per crank segment, 1 to 64 (with --crank beam only; default 1, exact in "
                        "statics for the prismatic segments; more add mass stations)")


def _output_arguments(p: argparse.ArgumentParser, files: str) -> None:
    """--errors, --perfect, --json and --out of the model commands."""
    p.add_argument("--errors", help="ErrorSpec TOML file (omitted keys are zero) or a built-in set (rv40e_seed001); "
                                    "default: no errors")
    p.add_argument("--perfect", action="store_true",
                   help="theoretical geometry: no modification, backlash, clearances or errors")
    p.add_argument("--json", help="write the results as JSON to this path")
    p.add_argument("--out", help=f"directory for {files}")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``rvflex`` command."""
    p = argparse.ArgumentParser(prog="rvflex", description="Rigid–flexible RV reducer models: geometry, TE, lost motion.",
                                epilog="SI inside; reports TE in arcsec, lost motion and backlash in arcmin, "
                                       "stiffness in N·m/arcmin. Each command's --help states its defaults. "
                                       "FE reductions are cached under $RVFLEX_CACHE_DIR or ~/.cache/rvflex.")
    p.add_argument("--debug", action="store_true",
                   help="on a failure, print the Python traceback as well as the one-line message, and let Exudyn "
                        "write its console messages (may also follow the command)")
    sub = p.add_subparsers(dest="command", required=True)
    g = sub.add_parser("geometry", help="cycloid-stage geometry report and profile plot")
    g.add_argument("--reducer", required=True, help=f"built-in reducer ({', '.join(catalog.names())}) or a spec TOML path")
    g.add_argument("--errors", help="ErrorSpec TOML file (omitted keys are zero) or a built-in set (rv40e_seed001); "
                                    "default: no errors")
    g.add_argument("--json", help="write the report as JSON to this path")
    g.add_argument("--out", help="directory for profile.png and geometry.json")
    g.set_defaults(func=_cmd_geometry)
    t = sub.add_parser("te", help="loaded transmission error (quasi-static)")
    _model_arguments(t)
    t.add_argument("--mode", default="quasi-static", choices=choices(TEMode),
                   help="quasi-static stepping or a generalized-α run (default quasi-static)")
    t.add_argument("--speed-out", type=float, help="output speed in dynamic mode, rpm (default: rated)")
    t.add_argument("--load", type=float, help="output torque resisting the motion, N·m (default: rated)")
    t.add_argument("--revs", type=float, default=1.0, help="output revolutions (default 1)")
    t.add_argument("--positions", type=int, default=2048, help="positions per output revolution (default 2048)")
    t.add_argument("--direction", choices=("forward", "reverse"), default="forward",
                   help="direction of the input rotation (default forward)")
    _load_arguments(t)
    _output_arguments(t, "te.csv, te.png, load_sharing.png, pin_loads.png (with --slices ≥ 2) and te.nc "
                         "(the labelled result, netCDF)")
    t.set_defaults(func=_cmd_te, flags=_TE_FLAGS)
    lm = sub.add_parser("lost-motion", help="torsional hysteresis: lost motion, stiffness, backlash")
    _model_arguments(lm)
    lm.add_argument("--torque", type=float, help="torque amplitude, N·m (default: rated)")
    lm.add_argument("--steps", type=int, default=200, help="torque steps over the cycle (default 200)")
    _load_arguments(lm)
    _output_arguments(lm, "hysteresis.csv, hysteresis.png and hysteresis.nc")
    lm.set_defaults(func=_cmd_lost_motion, flags=_LOST_MOTION_FLAGS)
    bl = sub.add_parser("backlash", help="reversal backlash: output angle lost when the input reverses")
    _model_arguments(bl)
    bl.add_argument("--load", type=float, help="load resisting the motion, N·m (default: 3 %% of rated)")
    _load_arguments(bl)
    _output_arguments(bl, "backlash.csv, backlash.png and backlash.nc")
    bl.set_defaults(func=_cmd_backlash, flags=_BACKLASH_FLAGS)
    sw = sub.add_parser("sweep", help="parameter sweep / tolerance design from a design TOML",
                        description="Evaluate every point of a design TOML: [sweep] (reducer, scenario, kind, load, "
                                    "resolution), [[factor]] tables, and an optional [model] table with the model "
                                    "options of every point: fidelity = \"rigid\" (default) | \"flexible\" | "
                                    "\"flexible-carrier\" (the ModelOptions presets), [model.discs] / [model.carrier] "
                                    "overriding fields of that preset's reduction (e.g. n_modes = 24).")
    sw.add_argument("design", help="design TOML (see scenarios/designs/smoke.toml, smoke_flexible.toml)")
    sw.add_argument("--executor", default="process", choices=choices(Executor),
                    help="serial: this process; process: a local pool of workers forked warm from this process "
                         "(a killed worker's points are retried); dask: a Dask cluster (default process)")
    sw.add_argument("--scheduler", help="with --executor dask: scheduler address tcp://HOST:PORT (default: a "
                                        "LocalCluster of --workers single-threaded worker processes)")
    sw.add_argument("--workers", type=int,
                    help=f"workers of the process pool or the LocalCluster (default: the CPU count, {os.cpu_count()} "
                         f"here; serial uses 1)")
    sw.add_argument("--json", help="write the summary as JSON to this path")
    sw.add_argument("--out", help="directory for the store and table.csv (default out/sweeps/NAME)")
    sw.set_defaults(func=_cmd_sweep, flags=_SWEEP_FLAGS)
    b = sub.add_parser("bench", help="benchmarks")
    bsub = b.add_subparsers(dest="bench", required=True)
    bc = bsub.add_parser("contact", help="cycloid–pin contact: rvflex element vs ObjectContactCurveCircles",
                         description="One rigid RV-40E disc (catalogue modification) on its pin ring, 50 N·m resisting, "
                                     "crank at 1 rev/s for a quarter revolution, generalized-α with a 0.2 ms step "
                                     "(rvflex.contact.bench): evaluation "
                                     "time of the rvflex contact element, steps per second against Exudyn's "
                                     "polygon contact, and both contacts' geometric error.")
    bc.add_argument("--json", help="write the results as JSON to this path")
    bc.add_argument("--segments", type=int, default=8000, help="polygon segments of the Exudyn contact (default 8000)")
    bc.set_defaults(func=_cmd_bench_contact)
    bt = bsub.add_parser("te", help="cost of one quasi-static TE step per unit and fidelity, in contact evaluations",
                         description="Each built-in unit and case (rigid; rigid with seed 001's errors and 12 µm "
                                     "crank-bearing clearances; rigid under half the allowable moment, the pin contact "
                                     "in 4 slices; the spatial rigid model, without and with half the allowable "
                                     "moment on the output; FE discs; FE discs and carrier; FE discs, carrier and "
                                     "housing): one loaded TE run over one output revolution, its wall time per step "
                                     "and the same divided by one evaluation of every disc's contact kernel (every "
                                     "slice) measured in the same run, with the split of a profiled run "
                                     "(rvflex.bench_te).")
    bt.add_argument("--units", nargs="+", default=["rv40e", "rv80e", "rv160n"], metavar="NAME",
                    help="built-in reducers (default all three)")
    bt.add_argument("--cases", nargs="+", default=list(BENCH_TE_CASES), choices=BENCH_TE_CASES, help="cases (default all)")
    bt.add_argument("--positions", type=int, default=2048, help="positions per output revolution, rigid (default 2048)")
    bt.add_argument("--flexible-positions", type=int, default=512,
                    help="positions per output revolution with FE parts (default 512)")
    bt.add_argument("--json", help="write the results as JSON to this path")
    bt.add_argument("--md", help="write the table as Markdown to this path (docs/results/bench_te.md)")
    bt.set_defaults(func=_cmd_bench_te)
    bd = bsub.add_parser("diagnosis", help="one model run of a diagnosis on each unit, side by side",
                         description="One diagnosis model run of each kind (rigid; rigid + flexible: the disc-"
                                     "flexibility share; rigid + two flexible: the contact-law form) on each unit, "
                                     "under the self-check campaign's four runs at the diagnosis's default "
                                     "resolution (255 orders), in one process, FE reductions from the cache; CPU "
                                     "time and its ratio to the first unit's (rvflex.diagnosis.runcost; issue 24's "
                                     "target: ≤ 1.5× the RV-40E's).")
    bd.add_argument("--units", nargs="+", default=["rv40e", "rv80e"], metavar="NAME|SPEC",
                    help="built-in reducers or spec TOML files; the first is the reference (default rv40e rv80e)")
    bd.add_argument("--kinds", nargs="+", default=list(choices(RunCostKind)), choices=choices(RunCostKind),
                    help="run kinds (default all)")
    bd.add_argument("--max-order", type=int, default=255, help="analysed orders (default 255)")
    bd.add_argument("--repeats", type=int, default=1, help="runs of each kind per unit, the least CPU kept (default 1)")
    bd.add_argument("--json", help="write the results as JSON to this path")
    bd.set_defaults(func=_cmd_bench_diagnosis)
    bs = bsub.add_parser("sweep", help="Monte Carlo sweep time and the 1→2 worker speed-up",
                         description="Rigid RV-40E, quasi-static loaded TE at 412 N·m over one output revolution "
                                     "(2048 positions), five tolerances uniform in their bands "
                                     "(rvflex.sweeps.monte_carlo_design); process executor with 2 workers for the "
                                     "Monte Carlo (seed 1), 1 and 2 workers on the same speed-up points (seed 2).")
    bs.add_argument("--points", type=int, default=100, help="Monte Carlo points (default 100)")
    bs.add_argument("--speedup-points", type=int, default=32,
                    help="points for the speed-up measurement (default 32: 16 per worker keeps the idle tail small)")
    bs.add_argument("--json", help="write the results as JSON to this path")
    bs.set_defaults(func=_cmd_bench_sweep)
    from rvflex.diagnosis import cli as diagnose_cli
    from rvflex.fe import cli as fe_cli

    fe_cli.register(sub)
    diagnose_cli.register(sub)
    from rvflex import validate

    validate.register(sub)
    from rvflex.scenarios import moment_rigidity

    moment_rigidity.register(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``rvflex`` console script.

    Exit codes: 0 done; 1 a run or build failed (one line on stderr naming the unit, the run or
    part and what failed); 2 bad input (one line naming the field, the value and the rule). No
    traceback unless ``--debug`` is given (anywhere on the command line).
    """
    from rvflex.api import RunError, one_line

    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    argv = [a for a in argv if a != "--debug"]  # accepted before or after the command
    args = build_parser().parse_args(argv)
    quiet = not debug  # Exudyn's own console banners ("STATIC SOLVER FAILED", hints) are for --debug
    if quiet:
        import exudyn

        was = exudyn.config.printToConsole
        exudyn.config.printToConsole = False
    try:
        return args.func(args)
    except SpecError as err:
        if debug:
            traceback.print_exc()
        print(f"rvflex: error: {_flag_error(err, getattr(args, 'flags', {}))}", file=sys.stderr)
        return 2
    except Exception as err:  # noqa: BLE001 -- the one place a failure becomes a message
        if debug:
            traceback.print_exc()
        if isinstance(err, RunError):
            msg = str(err)
        else:
            what = " ".join(str(getattr(args, k)) for k in ("command", "bench") if getattr(args, k, None))
            unit = getattr(args, "reducer", None)
            msg = f"{unit + ', ' if unit else ''}rvflex {what}: {one_line(err)}"
        print(f"rvflex: error: {msg}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("rvflex: interrupted", file=sys.stderr)
        return 130
    finally:
        if quiet:  # as it was, for a caller that goes on in this process (tests)
            exudyn.config.printToConsole = was


if __name__ == "__main__":
    sys.exit(main())

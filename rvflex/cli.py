"""The ``rvflex`` command. Thin: parse arguments, call the library, write outputs.

Everything is computed before anything is written, and files are written through a
temporary name and renamed, so a failed run leaves no half-written output.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

from rvflex import catalog
from rvflex.spec import ErrorSpec, ReducerSpec, SpecError, load_errors, load_spec

__all__ = ["main", "resolve_reducer"]


def resolve_reducer(name: str) -> ReducerSpec:
    """A built-in catalogue name (``rv40e``) or the path of a reducer spec TOML file."""
    if name.endswith(".toml") or os.sep in name:
        path = Path(name)
        if not path.is_file():
            raise SpecError("--reducer", name, "file not found")
        return load_spec(path)
    return catalog.load(name)


def _errors(path: str | None, spec: ReducerSpec) -> ErrorSpec | None:
    """An ErrorSpec TOML file, or a built-in error set name (``rv40e_seed001``)."""
    if path is None:
        return None
    if Path(path).is_file():
        return load_errors(path, spec)
    if not path.endswith(".toml") and os.sep not in path:
        return catalog.load_error_set(path, spec)
    raise SpecError("--errors", path, "file not found")


def _with_progress(total: int, desc: str, run):
    """Call ``run(progress)`` under a progress bar on stderr; returns its result and the wall time (s)."""
    import time

    from tqdm import tqdm

    t0 = time.perf_counter()
    with tqdm(total=total, desc=desc, unit="step", file=sys.stderr, mininterval=0.5) as bar:
        result = run(lambda done, n: bar.update(done - bar.n))
    return result, time.perf_counter() - t0


def _emit(args: argparse.Namespace, doc: dict, write_outputs) -> int:
    """Write ``--out`` files (``write_outputs(dir) -> paths``) and the ``--json`` document."""
    if args.out:
        for path in write_outputs(Path(args.out)):
            print(f"wrote {path}")
    if args.json:
        _write_atomic(Path(args.json), json.dumps(doc, indent=2).encode())
    return 0


def _model_inputs(args: argparse.Namespace) -> tuple[ReducerSpec, ErrorSpec]:
    """Spec and errors of a model command (``--reducer``, ``--fidelity``, ``--errors``, ``--perfect``)."""
    from rvflex.scenarios.loaded_te import perfect_spec

    spec = resolve_reducer(args.reducer)
    if args.perfect:
        return perfect_spec(spec), ErrorSpec()
    return spec, _errors(args.errors, spec) or ErrorSpec()


def _write_atomic(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.chmod(tmp, 0o644)  # mkstemp creates 0600; results are ordinary files
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _cmd_geometry(args: argparse.Namespace) -> int:
    from rvflex.geometry.report import geometry_report, plot_profile

    spec = resolve_reducer(args.reducer)
    errors = _errors(args.errors, spec)
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
        _write_atomic(out / "geometry.json", json.dumps(report.as_json(), indent=2).encode())
        print(f"wrote {out / 'profile.png'} and {out / 'geometry.json'}")
    if args.json:
        _write_atomic(Path(args.json), json.dumps(report.as_json(), indent=2).encode())
    return 0


def _cmd_te(args: argparse.Namespace) -> int:
    from rvflex.scenarios.loaded_te import LoadedTE, run_loaded_te, write_te_outputs

    spec, errors = _model_inputs(args)
    scenario = LoadedTE(spec, errors, spec.rated_torque_Nm if args.load is None else args.load,
                        args.revs, args.positions, 1 if args.direction == "forward" else -1, args.mode,
                        spec.rated_output_speed_rpm if args.speed_out is None else args.speed_out,
                        fidelity=args.fidelity, fe=_fe(args))
    (res, met), wall = _with_progress(int(round(args.positions * args.revs)), "loaded TE",
                                      lambda progress: run_loaded_te(scenario, progress=progress))
    doc = {
        "te_pp_arcsec": met.te_pp_arcsec, "te_min_arcsec": met.te_min_arcsec, "te_max_arcsec": met.te_max_arcsec,
        "mean_windup_arcsec": met.mean_windup_arcsec,
        "orders": [{"order": o, "amplitude_arcsec": a} for o, a in met.orders],
        "n_positions": len(res.te_rad), "wall_s": wall, "solve_s": res.wall_s,
    }
    print(f"TE peak-to-peak {met.te_pp_arcsec:.3f}″ (min {met.te_min_arcsec:.2f}″, max {met.te_max_arcsec:.2f}″), "
          f"mean wind-up {met.mean_windup_arcsec:.2f}″, {len(res.te_rad)} positions in {wall:.1f} s "
          f"(solver {res.wall_s:.1f} s, the rest builds the model)")
    print("strongest orders: " + ", ".join(f"{o}: {a:.3f}″" for o, a in met.orders[:5]))
    return _emit(args, doc, lambda out: write_te_outputs(out, res, met, scenario))


def _cmd_lost_motion(args: argparse.Namespace) -> int:
    from rvflex.scenarios.lost_motion import LostMotion, run_lost_motion, write_lost_motion_outputs
    from rvflex.solve import hysteresis_cycle

    spec, errors = _model_inputs(args)
    sc = LostMotion(spec, errors, spec.rated_torque_Nm if args.torque is None else args.torque,
                    args.steps, args.fidelity, _fe(args))
    (res, met), wall = _with_progress(len(hysteresis_cycle(sc.torque_Nm, sc.steps)), "hysteresis",
                                      lambda progress: run_lost_motion(sc, progress=progress))
    doc = {"lost_motion_arcmin": met.lost_motion_arcmin, "hysteresis_loss_arcmin": met.hysteresis_loss_arcmin,
           "torsional_stiffness_Nm_per_arcmin": met.torsional_stiffness_Nm_per_arcmin,
           "backlash_arcmin": met.backlash_arcmin,
           "secant_stiffness_Nm_per_arcmin": met.secant_stiffness_Nm_per_arcmin, "wall_s": wall}
    print(f"lost motion {met.lost_motion_arcmin:.4f}′, hysteresis loss {met.hysteresis_loss_arcmin:.4f}′, "
          f"torsional stiffness {met.torsional_stiffness_Nm_per_arcmin:.2f} N·m/arcmin "
          f"(secant ±T {met.secant_stiffness_Nm_per_arcmin:.2f}), "
          f"backlash {met.backlash_arcmin:.4f}′ ({len(res.torque_Nm)} steps in {wall:.1f} s)")
    return _emit(args, doc, lambda out: write_lost_motion_outputs(out, res, met, sc))


def _cmd_backlash(args: argparse.Namespace) -> int:
    import time

    from rvflex.scenarios.reversal_backlash import (DEFAULT_LOAD_FRACTION, ReversalBacklash, run_reversal_backlash,
                                                    write_backlash_outputs)

    spec, errors = _model_inputs(args)
    sc = ReversalBacklash(spec, errors, DEFAULT_LOAD_FRACTION * spec.rated_torque_Nm if args.load is None else args.load,
                          fidelity=args.fidelity, fe=_fe(args))
    t0 = time.perf_counter()
    lost, fwd, rev = run_reversal_backlash(sc)
    doc = {"reversal_backlash_arcmin": lost, "wall_s": time.perf_counter() - t0}
    print(f"reversal backlash {lost:.4f}′ at ±{sc.load_Nm:g} N·m ({doc['wall_s']:.1f} s)")
    return _emit(args, doc, lambda out: write_backlash_outputs(out, lost, fwd, rev, sc))


def _cmd_sweep(args: argparse.Namespace) -> int:
    import csv

    from tqdm import tqdm

    from rvflex.sweep import (
        SALIB_KINDS,
        classify,
        design_points,
        load_design,
        plot_indices,
        plot_main_effects,
        range_table,
        sensitivity_indices,
        sweep,
        write_indices_csv,
    )

    design = load_design(args.design)
    out = Path(args.out or Path("out") / "sweeps" / design.name)
    n = len(design_points(design))
    with tqdm(total=n, desc=f"sweep {design.name}", unit="point", file=sys.stderr, mininterval=0.5) as bar:
        res = sweep(design, out / f"{design.name}.sqlite", executor=args.executor, workers=args.workers,
                    scheduler=args.scheduler, progress=lambda: bar.update(1))
    metric = "te_pp_arcsec" if design.scenario == "te" else "lost_motion_arcmin"
    keys = sorted({k for r in res.rows for k in r})
    with open(out / "table.csv", "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(res.rows)
    unit = "arcsec" if design.scenario == "te" else "arcmin"
    print(f"{res.finished} of {n} points finished, {res.failed} failed, {res.wall_s:.1f} s "
          f"(+ {res.startup_s:.1f} s start-up; {res.executor}, {res.workers} workers); table in {out / 'table.csv'}")
    doc = {"points": n, "finished": res.finished, "failed": res.failed, "wall_s": res.wall_s,
           "startup_s": res.startup_s, "executor": res.executor, "workers": res.workers, "ranking": []}
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
            _write_atomic(Path(args.json), json.dumps(doc, indent=2).encode())
        return 0
    ranking = (range_table(design, res.rows, metric) if design.kind not in ("lhs", "sobol", "monte-carlo") else [])
    classes = classify(ranking)
    doc["ranking"] = [{"factor": r["factor"], f"range_{unit}": r["range"], "class": classes[r["factor"]]}
                      for r in ranking]
    if ranking:
        with open(out / "range_table.csv", "w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh)
            k = max(len(r["K"]) for r in ranking)
            w.writerow(["factor"] + [f"K{j + 1}" for j in range(k)] + ["R", "class"])
            for r in ranking:
                w.writerow([r["factor"]] + r["K"] + [""] * (k - len(r["K"])) + [r["range"], classes[r["factor"]]])
        print(f"main effects in {plot_main_effects(design, ranking, metric, out / 'main_effects.png')}")
    for r in ranking:
        print(f"  {r['factor']:32s} range {r['range']:.4f} {unit}  {classes[r['factor']]}")
    if args.json:
        _write_atomic(Path(args.json), json.dumps(doc, indent=2).encode())
    return 0


def _cmd_bench_sweep(args: argparse.Namespace) -> int:
    import tempfile as tf

    from rvflex.sweep import bench_sweep

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
        _write_atomic(Path(args.json), json.dumps(res, indent=2).encode())
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
        _write_atomic(Path(args.json), json.dumps(result, indent=2).encode())
    return 0


def _model_arguments(p: argparse.ArgumentParser) -> None:
    """--reducer and --fidelity of the model commands (see :func:`_model_inputs`)."""
    p.add_argument("--reducer", required=True, help=f"built-in reducer ({', '.join(catalog.names())}) or a spec TOML path")
    p.add_argument("--fidelity", default="rigid", choices=("rigid", "flexible"),
                   help="rigid bodies, or FE-reduced (Craig–Bampton, FFRF) cycloid discs; the reduction is "
                        "cached under $RVFLEX_CACHE_DIR or ~/.cache/rvflex (default rigid)")
    p.add_argument("--flexible-carrier", action="store_true",
                   help="with --fidelity flexible: the carrier is an FE-reduced body too (rvflex reduce --part "
                        "carrier; output face = output frame, two support bearings per crank)")
    fe = p.add_argument_group("flexible discs (FE reduction settings; defaults: rvflex reduce's)")
    fe.add_argument("--fe-maxh", type=float, dest="fe_maxh_m", help="mesh size, m")
    fe.add_argument("--fe-modes", type=int, dest="fe_n_modes", help="fixed-interface eigenmodes")
    fe.add_argument("--fe-attach", type=int, dest="fe_attach_per_tooth", help="flank attachment modes per tooth")
    fe.add_argument("--fe-order", type=int, dest="fe_mesh_order", choices=(1, 2), help="tet order")


def _fe(args: argparse.Namespace) -> tuple[tuple[str, float], ...]:
    """The FE reduction settings given on the command line (``--fe-*``)."""
    options = {"fe_maxh_m": "--fe-maxh", "fe_n_modes": "--fe-modes", "fe_attach_per_tooth": "--fe-attach",
               "fe_mesh_order": "--fe-order"}
    given = [k for k in options if getattr(args, k) is not None]
    if given and args.fidelity != "flexible":
        raise SpecError(options[given[0]], getattr(args, given[0]), "applies to --fidelity flexible only")
    carrier = getattr(args, "flexible_carrier", False)
    if carrier and args.fidelity != "flexible":
        raise SpecError("--flexible-carrier", True, "applies to --fidelity flexible only")
    # the scenarios pass these settings to build_reducer(fe=...), which takes the carrier switch out of them
    return tuple((k[3:], getattr(args, k)) for k in given) + ((("flexible_carrier", True),) if carrier else ())


def _output_arguments(p: argparse.ArgumentParser, files: str) -> None:
    """--errors, --perfect, --json and --out of the model commands."""
    p.add_argument("--errors", help="ErrorSpec TOML file (omitted keys are zero) or a built-in set (rv40e_seed001)")
    p.add_argument("--perfect", action="store_true",
                   help="theoretical geometry: no modification, backlash, clearances or errors")
    p.add_argument("--json", help="write the results as JSON to this path")
    p.add_argument("--out", help=f"directory for {files}")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``rvflex`` command."""
    p = argparse.ArgumentParser(prog="rvflex", description="Rigid–flexible RV reducer models: geometry, TE, lost motion.")
    sub = p.add_subparsers(dest="command", required=True)
    g = sub.add_parser("geometry", help="cycloid-stage geometry report and profile plot")
    g.add_argument("--reducer", required=True, help=f"built-in reducer ({', '.join(catalog.names())}) or a spec TOML path")
    g.add_argument("--errors", help="ErrorSpec TOML file (omitted keys are zero) or a built-in set (rv40e_seed001)")
    g.add_argument("--json", help="write the report as JSON to this path")
    g.add_argument("--out", help="directory for profile.png and geometry.json")
    g.set_defaults(func=_cmd_geometry)
    t = sub.add_parser("te", help="loaded transmission error (quasi-static)")
    _model_arguments(t)
    t.add_argument("--mode", default="quasi-static", choices=("quasi-static", "dynamic"),
                   help="quasi-static stepping or a generalized-α run (default quasi-static)")
    t.add_argument("--speed-out", type=float, help="output speed in dynamic mode, rpm (default: rated)")
    t.add_argument("--load", type=float, help="output torque resisting the motion, N·m (default: rated)")
    t.add_argument("--revs", type=float, default=1.0, help="output revolutions (default 1)")
    t.add_argument("--positions", type=int, default=2048, help="positions per output revolution (default 2048)")
    t.add_argument("--direction", choices=("forward", "reverse"), default="forward")
    _output_arguments(t, "te.csv, te.png and load_sharing.png")
    t.set_defaults(func=_cmd_te)
    lm = sub.add_parser("lost-motion", help="torsional hysteresis: lost motion, stiffness, backlash")
    _model_arguments(lm)
    lm.add_argument("--torque", type=float, help="torque amplitude, N·m (default: rated)")
    lm.add_argument("--steps", type=int, default=200, help="torque steps over the cycle (default 200)")
    _output_arguments(lm, "hysteresis.csv and hysteresis.png")
    lm.set_defaults(func=_cmd_lost_motion)
    bl = sub.add_parser("backlash", help="reversal backlash: output angle lost when the input reverses")
    _model_arguments(bl)
    bl.add_argument("--load", type=float, help="load resisting the motion, N·m (default: 3 %% of rated)")
    _output_arguments(bl, "backlash.csv and backlash.png")
    bl.set_defaults(func=_cmd_backlash)
    sw = sub.add_parser("sweep", help="parameter sweep / tolerance design from a design TOML")
    sw.add_argument("design", help="design TOML (see scenarios/designs/smoke.toml)")
    sw.add_argument("--executor", default="process", choices=("serial", "process", "dask"), help="default: process")
    sw.add_argument("--scheduler", help="Dask scheduler address tcp://HOST:PORT (default: a LocalCluster)")
    sw.add_argument("--workers", type=int, help="process workers (default: CPU count)")
    sw.add_argument("--json", help="write the summary as JSON to this path")
    sw.add_argument("--out", help="directory for the store and table.csv (default out/sweeps/NAME)")
    sw.set_defaults(func=_cmd_sweep)
    b = sub.add_parser("bench", help="benchmarks")
    bsub = b.add_subparsers(dest="bench", required=True)
    bc = bsub.add_parser("contact", help="cycloid–pin contact: rvflex element vs ObjectContactCurveCircles")
    bc.add_argument("--json", help="write the results as JSON to this path")
    bc.add_argument("--segments", type=int, default=8000, help="polygon segments of the Exudyn contact (default 8000)")
    bc.set_defaults(func=_cmd_bench_contact)
    bs = bsub.add_parser("sweep", help="Monte Carlo sweep time and the 1→2 worker speed-up")
    bs.add_argument("--points", type=int, default=100, help="Monte Carlo points (default 100)")
    bs.add_argument("--speedup-points", type=int, default=32,
                    help="points for the speed-up measurement (default 32: 16 per worker keeps the idle tail small)")
    bs.add_argument("--json", help="write the results as JSON to this path")
    bs.set_defaults(func=_cmd_bench_sweep)
    from rvflex.diagnose import cli as diagnose_cli
    from rvflex.fe import cli as fe_cli

    fe_cli.register(sub)
    diagnose_cli.register(sub)
    from rvflex import validate

    validate.register(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``rvflex`` console script."""
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except SpecError as err:
        print(f"rvflex: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

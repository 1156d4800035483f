"""The diagnosis commands of ``rvflex`` (``rvflex diagnose``, ``rvflex selfcheck``, ``rvflex null-distribution``)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rvflex.choices import Mismatch, choices


def register(sub: argparse._SubParsersAction) -> None:
    """Add the diagnosis sub-commands to the ``rvflex`` parser."""
    d = sub.add_parser("diagnose", help="sim-to-real gap diagnosis of a bench dataset (Markdown report + JSON)")
    d.add_argument("bench_dir", metavar="BENCH_DIR", help="bench dataset folder (bench.toml + one CSV per run)")
    d.add_argument("--json", help="write the JSON document here")
    d.add_argument("--out", help="write report.md, diagnosis.json and the plots to this folder")
    d.add_argument("--workers", type=int, default=2, help="processes for the model runs (default 2)")
    d.add_argument("--cache", help="model-run cache folder (default: OUT/.cache when --out is given)")
    d.add_argument("--effects", help="comma-separated candidate effects (default: all registered)")
    d.set_defaults(func=_guarded(_cmd_diagnose), flags={"effects": "--effects"})
    s = sub.add_parser("selfcheck", help="diagnose synthetic bench datasets with hidden effects and score the result")
    s.add_argument("--cases", type=int, default=20, help="number of datasets (default 20)")
    s.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
    s.add_argument("--json", help="write the score document here")
    s.add_argument("--out", help="folder for the datasets, truths, cache and per-case reports "
                                 "(default: a temporary folder)")
    s.add_argument("--workers", type=int, default=2,
                   help="processes: the benches are generated and the cases diagnosed that many at a time (default 2)")
    s.add_argument("--mismatch", choices=choices(Mismatch), default="none",
                   help="generator: 'none' (default) the diagnosing model at a finer resolution, contact 2 %% stiffer; "
                        "'realistic' another model family per case (power-law contact, needle-bearing and mesh "
                        "stiffness ±40 %%, nominal crank-bearing clearance 0–5 µm, flexible discs, TE sampled over "
                        "[0, 2π)) with a control every 4th case; 'far' the realistic generator with the overall "
                        "stiffness also drawn ×0.5 … ×2 and a nominal clearance 0–8 µm; 'ensemble' a unit of another "
                        "model form per case (contact, bearing, mesh, series-compliance, thermal and disc forms drawn, "
                        "see rvflex.diagnosis.ensemble)")
    s.add_argument("--reducer", default="rv40e", metavar="NAME|SPEC",
                   help="the unit: a built-in reducer name or a spec TOML file (default rv40e)")
    s.add_argument("--reuse-benches", action="store_true",
                   help="diagnose again the benches --out already holds from the same draws and generator (others are "
                        "generated): after a change to the diagnosis, the same benches")
    s.add_argument("--told", action="store_true",
                   help="also diagnose each effect case told its hidden effects (the candidates only those): "
                        "top1_rate_told, what the runs confirm when the ranking has nothing else to choose")
    s.set_defaults(func=_guarded(_cmd_selfcheck), flags={"cases": "--cases", "mismatch": "--mismatch",
                                                        "reducer": "--reducer"})
    n = sub.add_parser("null-distribution",
                       help="diagnose healthy units of other model forms (the ensemble) and write the null distribution "
                            "a finding must exceed to be established")
    n.add_argument("--cases", type=int, default=56, help="ensemble controls per unit (default 56)")
    n.add_argument("--reducers", default="rv40e,rv80e,rv160n",
                   help="comma-separated built-in units (default rv40e,rv80e,rv160n)")
    n.add_argument("--seed", type=int, default=1, help="random seed of the first unit (the next units: seed + 1, …)")
    n.add_argument("--out", required=True, help="folder for the controls' benches, reports and cache")
    n.add_argument("--json", help="write the null distribution here (the package's own: "
                                  "rvflex/diagnosis/null_distribution.json)")
    n.set_defaults(func=_guarded(_cmd_null), flags={"cases": "--cases"})


def _guarded(cmd):
    """Report bad bench input and a non-converging baseline as one ``rvflex: error:`` line (exit 2)."""
    def run(args: argparse.Namespace) -> int:
        from rvflex.diagnosis.bench import BenchError
        from rvflex.diagnosis.replay import EvaluationFailed

        try:
            return cmd(args)
        except (BenchError, EvaluationFailed) as err:
            print(f"rvflex: error: {err}", file=sys.stderr)
            return 2
    return run


def _cmd_diagnose(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from rvflex.diagnosis.bench import read_bench
    from rvflex.diagnosis.report import json_document
    from rvflex.diagnosis.settings import DiagnosisSettings
    from rvflex.io import emit
    from rvflex.spec import SpecError
    from rvflex.studies import diagnose

    dataset = read_bench(args.bench_dir)  # every bad input is refused here, before anything runs or is written
    if args.workers < 1:
        raise SpecError("--workers", args.workers, "must be at least 1")
    effects = tuple(x.strip() for x in args.effects.split(",") if x.strip()) if args.effects else None
    cache = args.cache or (str(Path(args.out) / ".cache") if args.out else None)
    with tqdm(total=1, desc="diagnosis: model runs", unit="run", file=sys.stderr, mininterval=0.5) as bar:
        def progress(done: int, total: int) -> None:
            bar.total = total
            bar.update(done - bar.n)

        diag = diagnose(dataset, effects=effects, settings=DiagnosisSettings(workers=args.workers), cache_dir=cache,
                        progress=progress)
    print(diag.verdict)
    for c in diag.candidates[:5]:
        print(f"  {c.name:48s} score {c.score:10.1f}  shrink {c.gap_shrink_pct:5.0f} %  "
              f"{'accepted' if c.accepted else ''}")
    print(f"{diag.model_runs} model runs, {diag.wall_s:.0f} s")
    return emit(args, json_document(diag) if args.json else {}, diag.write)


def _cmd_selfcheck(args: argparse.Namespace) -> int:
    import json
    import tempfile

    from rvflex.diagnosis.settings import DiagnosisSettings
    from rvflex.io import write_atomic
    from rvflex.spec import SpecError
    from rvflex.studies import selfcheck

    if args.workers < 1:
        raise SpecError("--workers", args.workers, "must be at least 1")
    if args.reuse_benches and not args.out:
        raise SpecError("--reuse-benches", True, "needs --out, the folder that holds the benches")
    with tempfile.TemporaryDirectory(prefix="rvflex-selfcheck-") as tmp:
        out = Path(args.out) if args.out else Path(tmp)
        doc = selfcheck(out, cases=args.cases, seed=args.seed, mismatch=args.mismatch, reducer=args.reducer,
                        settings=DiagnosisSettings(workers=args.workers), reuse_benches=args.reuse_benches,
                        told=args.told, log=lambda s: print(s, file=sys.stderr, flush=True))
        summary = {k: doc[k] for k in ("cases", "mismatch", "top1_rate", "top2_rate", "magnitude_within_25pct_rate",
                                       "median_gap_shrink_pct", "control_correct_rate", "calibration_rate",
                                       "calibration_rate_all_scales", "top1_rate_told", "false_names",
                                       "false_names_per_20_cases", "wall_s") if k in doc}
        print(json.dumps(summary, indent=2))
        if args.out:
            write_atomic(out / "selfcheck.json", json.dumps(doc, indent=2).encode())
            print(f"wrote {out / 'selfcheck.json'}")
        if args.json:
            write_atomic(Path(args.json), json.dumps(doc, indent=2).encode())
    return 0


def _cmd_null(args: argparse.Namespace) -> int:
    import json

    from rvflex.diagnosis.null_build import build_null
    from rvflex.spec import SpecError

    if args.cases < 1:
        raise SpecError("--cases", args.cases, "must be at least 1")
    reducers = tuple(x.strip() for x in args.reducers.split(",") if x.strip())
    if not reducers:
        raise SpecError("--reducers", args.reducers, "names no unit")
    out = Path(args.out)
    doc = build_null(out, reducers, args.cases, args.seed, json_path=args.json, cache_dir=out / "cache",
                     log=lambda s: print(s, file=sys.stderr, flush=True))
    rows = {k: {"relative_threshold": round(v["relative_threshold"], 3), "false_alarm_rate": round(v["false_alarm_rate"], 3)}
            for k, v in doc["effects"].items()}
    held = {u: {k: h[k] for k in ("controls", "named")} for u, h in doc["leave_one_out"].items()}
    print(json.dumps({"controls": doc["source"]["controls"], "wall_s": doc["wall_s"], "effects": rows,
                      "leave_one_out": held}, indent=2))
    if args.json:
        print(f"wrote {args.json}")
    return 0

"""The diagnosis commands of ``rvflex`` (``rvflex diagnose``, ``rvflex selfcheck``)."""

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
    d.set_defaults(func=_guarded(_cmd_diagnose))
    s = sub.add_parser("selfcheck", help="diagnose synthetic bench datasets with hidden effects and score the result")
    s.add_argument("--cases", type=int, default=20, help="number of datasets (default 20)")
    s.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
    s.add_argument("--json", help="write the score document here")
    s.add_argument("--out", help="folder for the datasets, truths, cache and per-case reports "
                                 "(default: a temporary folder)")
    s.add_argument("--workers", type=int, default=2, help="processes for the model runs (default 2)")
    s.add_argument("--mismatch", choices=choices(Mismatch), default="none",
                   help="generator: 'none' (default) the diagnosing model at a finer resolution, contact 2 %% stiffer; "
                        "'realistic' another model family per case (power-law contact, needle-bearing and mesh "
                        "stiffness ±40 %%, nominal crank-bearing clearance 0–5 µm, flexible discs, TE sampled over "
                        "[0, 2π)) with a control every 4th case; 'far' the realistic generator with the overall "
                        "stiffness also drawn ×0.5 … ×2 and a nominal clearance 0–8 µm")
    s.add_argument("--reducer", default="rv40e", metavar="NAME|SPEC",
                   help="the unit: a built-in reducer name or a spec TOML file (default rv40e)")
    s.set_defaults(func=_guarded(_cmd_selfcheck))


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
    import time

    from tqdm import tqdm

    from rvflex.diagnosis.bench import read_bench
    from rvflex.diagnosis.effects import EFFECTS
    from rvflex.diagnosis.fit import diagnose
    from rvflex.diagnosis.report import json_document, write_report
    from rvflex.diagnosis.settings import DiagnosisSettings
    from rvflex.io import emit
    from rvflex.spec import SpecError

    dataset = read_bench(args.bench_dir)  # every bad input is refused here, before anything runs or is written
    if args.workers < 1:
        raise SpecError("--workers", args.workers, "must be at least 1")
    effects = None
    if args.effects:
        effects = tuple(x.strip() for x in args.effects.split(",") if x.strip())
        bad = [x for x in effects if x not in EFFECTS]
        if bad:
            raise SpecError("--effects", bad[0], f"unknown effect; registered: {', '.join(EFFECTS)}")
    cache = args.cache or (str(Path(args.out) / ".cache") if args.out else None)
    settings = DiagnosisSettings(workers=args.workers)
    t0 = time.perf_counter()
    with tqdm(total=1, desc="diagnosis: model runs", unit="run", file=sys.stderr, mininterval=0.5) as bar:
        def progress(done: int, total: int) -> None:
            bar.total = total
            bar.update(done - bar.n)

        diag = diagnose(dataset, settings=settings, effects=effects, cache_dir=cache, progress=progress)
    doc = json_document(diag)
    doc["wall_s"] = time.perf_counter() - t0
    print(diag.verdict)
    for c in diag.candidates[:5]:
        print(f"  {c.name:48s} score {c.score:10.1f}  shrink {c.gap_shrink_pct:5.0f} %  "
              f"{'accepted' if c.accepted else ''}")
    print(f"{diag.model_runs} model runs, {doc['wall_s']:.0f} s")
    return emit(args, doc, lambda out: write_report(diag, out, doc))


def _cmd_selfcheck(args: argparse.Namespace) -> int:
    import dataclasses as dc
    import json
    import tempfile

    from rvflex.api import load_reducer
    from rvflex.diagnosis.selfcheck import SelfCheckSettings, selfcheck
    from rvflex.diagnosis.settings import DiagnosisSettings
    from rvflex.io import write_atomic
    from rvflex.spec import SpecError

    if args.cases < 1:
        raise SpecError("--cases", args.cases, "must be at least 1")
    if args.workers < 1:
        raise SpecError("--workers", args.workers, "must be at least 1")
    reducer = str(Path(args.reducer).resolve()) if args.reducer.endswith(".toml") else args.reducer
    load_reducer(reducer, field="--reducer")  # one clear message for an unknown name or a bad spec, before any run
    settings = SelfCheckSettings(cases=args.cases, seed=args.seed, diagnosis=DiagnosisSettings(workers=args.workers),
                                 mismatch=args.mismatch, control_every=5 if args.mismatch == "none" else 4,
                                 reducer=reducer)
    with tempfile.TemporaryDirectory(prefix="rvflex-selfcheck-") as tmp:
        out = Path(args.out) if args.out else Path(tmp)
        doc = selfcheck(out, settings, log=lambda s: print(s, file=sys.stderr, flush=True))
        doc["settings"] = {"cases": settings.cases, "seed": settings.seed, "reducer": settings.reducer,
                           "diagnosis": dc.asdict(settings.diagnosis), "generator": dc.asdict(settings.generator),
                           "realism": dc.asdict(settings.realism), "mismatch": settings.mismatch,
                           "realistic": dc.asdict(settings.realistic), "far": dc.asdict(settings.far)}
        summary = {k: doc[k] for k in ("cases", "mismatch", "top1_rate", "top2_rate", "magnitude_within_25pct_rate",
                                       "median_gap_shrink_pct", "control_correct_rate", "calibration_rate",
                                       "calibration_rate_all_scales", "wall_s")}
        print(json.dumps(summary, indent=2))
        if args.out:
            write_atomic(out / "selfcheck.json", json.dumps(doc, indent=2).encode())
            print(f"wrote {out / 'selfcheck.json'}")
        if args.json:
            write_atomic(Path(args.json), json.dumps(doc, indent=2).encode())
    return 0

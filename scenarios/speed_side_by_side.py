"""Studies timed side by side with a reference revision of rvflex: the same commands, alternately run by this
installation and by another Python environment holding the reference (e.g. a clone checked out at the
revision, installed in its own virtual environment), on the same machine in one run.

The commands: the 256-point tolerance design of the rigid RV-40E (``rvflex sweep
scenarios/designs/tolerance_lhs256.toml``, serial, so each point's cost is what is timed) and a cold diagnosis
of a four-run foreign-bench dataset (``rvflex diagnose DATASET --cache EMPTY``)::

    python -m rvflex.scenarios.speed_side_by_side --reference-python ../ref/.venv/bin/python \\
        --dataset ../shared/foreign-bench/data/H04

writes ``docs/results/speed_side_by_side.json`` and the table ``docs/results/speed_side_by_side.md`` (wall time
of each command under both, and their ratio), replacing the previous run's files.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rvflex.io import write_atomic

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results"
DESIGN = ROOT / "scenarios" / "designs" / "tolerance_lhs256.toml"


def _revision(python: str) -> str:
    """The git revision of the rvflex that ``python`` imports (its source tree's HEAD), or "unknown"."""
    code = "import rvflex, pathlib; print(pathlib.Path(rvflex.__file__).resolve().parents[1])"
    try:
        src = subprocess.run([python, "-c", code], capture_output=True, text=True, check=True,
                             cwd=tempfile.gettempdir()).stdout.strip()
        rev = subprocess.run(["git", "-C", src, "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                             check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", src, "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, check=True).stdout.strip()
        return rev + (" with uncommitted changes" if dirty else "")
    except (subprocess.CalledProcessError, OSError):
        return "unknown"


def _timed(python: str, args: list[str], log: Path) -> float:
    """Wall time (s) of ``python -m rvflex.cli ARGS``; its output goes to ``log``; a failure stops the run."""
    t = time.perf_counter()
    with log.open("w", encoding="utf-8") as out:
        # run from the log's folder: ``-m`` puts the working directory first on the path, and a checkout there
        # would shadow the environment's rvflex
        rc = subprocess.run([python, "-m", "rvflex.cli", *args], stdout=out, stderr=subprocess.STDOUT,
                            cwd=log.parent).returncode
    if rc:
        sys.exit(f"{' '.join(args[:2])} failed under {python} (exit {rc}); its output is in {log}")
    return time.perf_counter() - t


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--reference-python", required=True, help="python of the environment holding the reference rvflex")
    ap.add_argument("--dataset", required=True, help="a four-run bench dataset directory (foreign bench)")
    ap.add_argument("--out", default=None, help="folder for the commands' outputs and logs (default: a temporary one)")
    ap.add_argument("--results", default=str(RESULTS), help="where the JSON and the table go (default docs/results)")
    args = ap.parse_args(argv)
    if not Path(args.reference_python).is_file():
        ap.error(f"--reference-python {args.reference_python}: no such file")
    if not (Path(args.dataset) / "bench.toml").is_file():
        ap.error(f"--dataset {args.dataset}: no bench.toml there (a bench dataset directory is needed)")
    pythons = {"reference": args.reference_python, "this": sys.executable}
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(args.out or tmp)
        out.mkdir(parents=True, exist_ok=True)
        jobs = {"sweep": lambda d: ["sweep", str(DESIGN), "--executor", "serial", "--out", str(d / "sweep")],
                "diagnosis": lambda d: ["diagnose", str(args.dataset), "--out", str(d / "diagnosis"),
                                        "--cache", str(d / "cache")]}
        for job, make in jobs.items():
            wall = {}
            for who in ("reference", "this"):  # alternately, so a change in the machine's load hits both alike
                d = out / f"{job}-{who}"
                d.mkdir(parents=True, exist_ok=True)
                print(f"{job}: {who} ...", file=sys.stderr)
                wall[who] = _timed(pythons[who], make(d), d / "log.txt")
            shown = [a.replace(str(ROOT) + "/", "") for a in make(Path("OUT"))]
            rows.append({"job": job, "command": "rvflex " + " ".join(shown),
                         "reference_s": wall["reference"], "this_s": wall["this"],
                         "speedup": wall["reference"] / wall["this"]})
            print(f"{job}: {wall['reference']:.1f} s → {wall['this']:.1f} s ({rows[-1]['speedup']:.2f}×)",
                  file=sys.stderr)
    doc = {"rows": rows, "reference_revision": _revision(args.reference_python), "this_revision": _revision(sys.executable),
           "dataset": Path(args.dataset).name, "machine": {"platform": platform.platform(), "cpus": os.cpu_count()},
           "load_average": os.getloadavg()}
    res = Path(args.results)
    write_atomic(res / "speed_side_by_side.json", (json.dumps(doc, indent=2) + "\n").encode())
    lines = [f"Reference {doc['reference_revision']}, this {doc['this_revision']}; {doc['machine']['cpus']} cores, "
             f"load average {doc['load_average'][0]:.1f} at the end; dataset {doc['dataset']}.", "",
             "| study | command | reference (s) | this (s) | speed-up |", "|---|---|---:|---:|---:|"]
    lines += [f"| {r['job']} | `{r['command']}` | {r['reference_s']:.1f} | {r['this_s']:.1f} | {r['speedup']:.2f}× |"
              for r in rows]
    write_atomic(res / "speed_side_by_side.md", ("\n".join(lines) + "\n").encode())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""The diagnosis's measured figures: each self-check run by its command into one current result file,
and the tables docs/diagnosis.md includes (docs/results/table.md; docs/results/null_table.md, the null
distribution's per-effect false-alarm rates).

Every check is a ``rvflex selfcheck`` command (:data:`CHECKS`); ``--run`` runs the named ones (or
``all``) and writes each score document to ``docs/results/<name>.json``, replacing the file of the
previous run of that check, with the command and the code revision it ran on added (``command``,
``code_revision``). The table is regenerated from every JSON in the results folder each time, with
or without ``--run``, so the page and the files cannot drift apart::

    python -m rvflex.scenarios.diagnosis_results                       # the table only, no check run
    python -m rvflex.scenarios.diagnosis_results --list                # the checks and their commands
    python -m rvflex.scenarios.diagnosis_results --run selfcheck_far_seed1 selfcheck_none_seed1
    python -m rvflex.scenarios.diagnosis_results --run all --out out/results

The benches, truths, model-run caches and per-case reports of a check go to ``OUT/<name>/`` (default
``out/results``; each result file's ``wall_s`` says how long its check took),
so ``--reuse-benches`` can diagnose the same benches again after a change to the diagnosis.
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from rvflex.io import write_atomic

__all__ = ["CHECKS", "RESULTS", "check_command", "null_table", "run_check", "table", "write_null_table", "write_table"]

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results"
"""Where the result files and the table live (the repository's docs/results/)."""

CHECKS: dict[str, tuple[str, ...]] = {
    **{f"selfcheck_far_seed{s}": ("--cases", "20", "--mismatch", "far", "--seed", str(s), "--told") for s in (1, 2, 3)},
    **{f"selfcheck_realistic_seed{s}": ("--cases", "20", "--mismatch", "realistic", "--seed", str(s), "--told")
       for s in (3, 5)},
    "selfcheck_none_seed1": ("--cases", "20", "--mismatch", "none", "--seed", "1", "--told"),
    **{f"selfcheck_ensemble_seed{s}": ("--cases", "20", "--mismatch", "ensemble", "--seed", str(s), "--told")
       for s in (1, 2, 3)},
    "selfcheck_rv80e_seed1": ("--cases", "8", "--mismatch", "realistic", "--reducer", "rv80e", "--seed", "1", "--told"),
}
"""The checks by result name: the arguments of ``rvflex selfcheck`` (without ``--json`` and ``--out``)."""


def check_command(name: str, reuse_benches: bool = False) -> str:
    """The command line of check ``name`` as it is run (without its ``--json`` and ``--out`` paths)."""
    args = CHECKS[name] + (("--reuse-benches",) if reuse_benches else ())
    return shlex.join(("rvflex", "selfcheck") + args)


def _rvflex() -> str:
    """The ``rvflex`` command of this interpreter's environment (else the one on PATH)."""
    here = Path(sys.executable).with_name("rvflex")
    found = str(here) if here.exists() else shutil.which("rvflex")
    if not found:
        raise SystemExit("the rvflex command is not installed (pip install -e .)")
    return found


def _revision() -> str | None:
    """The commit the code runs on (``+dirty`` when rvflex/ or scenarios/ have uncommitted changes), or None."""
    try:
        head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short=12", "HEAD"], capture_output=True,
                              text=True, check=True).stdout.strip()
        # tracked files only: untracked files (caches, scratch output) are not the code
        dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--untracked-files=no", "--",
                                "rvflex", "scenarios"],
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return None
    return head + ("+dirty" if dirty else "")


def run_check(name: str, out_dir: str | Path = "out/results", results: str | Path = RESULTS, *,
              reuse_benches: bool = False, workers: int = 2) -> Path:
    """Run check ``name`` and write its score document to ``results/<name>.json``.

    Parameters
    ----------
    name : str
        A key of :data:`CHECKS`.
    out_dir : str or os.PathLike
        Parent of the check's working folder ``out_dir/<name>`` (benches, truths, caches, per-case reports).
    results : str or os.PathLike
        The results folder.
    reuse_benches : bool
        Pass ``--reuse-benches``: diagnose again the benches the working folder holds from the same draws.
    workers : int
        ``--workers`` of the self-check.

    Returns
    -------
    pathlib.Path
        The result file, written only when the command succeeded (the previous one stays otherwise).

    Raises
    ------
    RuntimeError
        The command failed (its exit status named).
    """
    work = Path(out_dir) / name
    work.mkdir(parents=True, exist_ok=True)
    revision = _revision()
    with tempfile.TemporaryDirectory(prefix="rvflex-results-") as tmp:
        score = Path(tmp) / f"{name}.json"
        args = list(CHECKS[name]) + (["--reuse-benches"] if reuse_benches else [])
        cmd = [_rvflex(), "selfcheck", *args, "--workers", str(workers), "--json", str(score), "--out", str(work)]
        print("$", shlex.join(cmd), flush=True)
        done = subprocess.run(cmd)
        if done.returncode != 0:
            raise RuntimeError(f"{name}: rvflex selfcheck exited with status {done.returncode}")
        doc = json.loads(score.read_text(encoding="utf-8"))
    doc = {"command": check_command(name, reuse_benches), "code_revision": revision} | doc
    return write_atomic(Path(results) / f"{name}.json", (json.dumps(doc, indent=2) + "\n").encode())


# ----------------------------------------------------------------------------- the table

def _command_of(doc: dict) -> str:
    """The command a result file was made by: its ``command``, else as its settings state it."""
    if doc.get("command"):
        return doc["command"]
    s = doc.get("settings", {})
    args = ["--cases", str(s.get("cases", doc.get("cases"))), "--mismatch", str(s.get("mismatch", doc.get("mismatch")))]
    if s.get("reducer", "rv40e") != "rv40e":
        args += ["--reducer", str(s["reducer"])]
    args += ["--seed", str(s.get("seed"))]
    args += ["--reuse-benches"] if s.get("reuse_benches") else []
    args += ["--told"] if s.get("told") else []
    return shlex.join(["rvflex", "selfcheck", *args])


def _rate(rate, hits: int | None = None, cases: int | None = None) -> str:
    if rate is None or (isinstance(rate, float) and math.isnan(rate)):
        return "—"
    return f"{rate:.2f}" + (f" ({hits}/{cases})" if cases else "")


def _false_names(doc: dict) -> str | None:
    """The false names a result file records (a top-level key ``false_name…``), or None when it has none."""
    keys = sorted(k for k in doc if k.startswith("false_name"))
    if not keys:
        return None
    v = doc[keys[0]]
    if isinstance(v, (list, tuple, dict)):
        return str(len(v))
    if isinstance(v, float) and not v.is_integer():
        return f"{v:.2f}"
    return "—" if v is None else str(int(v))


def _row(name: str, doc: dict) -> dict[str, str]:
    cases = doc.get("per_case", [])
    eff = [r for r in cases if r.get("hidden")]
    ctl = [r for r in cases if not r.get("hidden") and "correct" in r]
    reused = doc.get("benches_reused") or 0
    wall = doc.get("wall_s")
    wall_text = "—" if wall is None else f"{wall:.0f} s"
    if reused:
        wall_text += f" ({reused}/{doc.get('cases', len(cases))} benches reused)"
    return {
        "check": f"`{name}`",
        "command": f"`{_command_of(doc)}`",
        "top-1": _rate(doc.get("top1_rate"), sum(bool(r.get("top1")) for r in eff), len(eff)),
        "told": (_rate(doc["top1_rate_told"], sum(bool(r.get("told_top1")) for r in eff), len(eff))
                 if "top1_rate_told" in doc else "—"),
        "controls": _rate(doc.get("control_correct_rate"), sum(bool(r["correct"]) for r in ctl), len(ctl)),
        "top-2": _rate(doc.get("top2_rate")),
        "false names": _false_names(doc) or "—",
        "wall time": wall_text,
        "revision": f"`{doc['code_revision']}`" if doc.get("code_revision") else "not recorded",
    }


def table(results: str | Path = RESULTS) -> str:
    """The Markdown table of every self-check result file (``selfcheck_*.json``) in ``results``, sorted by name
    (the folder holds other checks' files too: ``rvflex bench te``'s, the side-by-side timings). The column
    "false names" appears when some file records them."""
    docs = {p.stem: json.loads(p.read_text(encoding="utf-8")) for p in sorted(Path(results).glob("selfcheck_*.json"))}
    rows = [_row(n, d) for n, d in docs.items()]
    cols = ["check", "command", "top-1", "told", "controls", "top-2", "false names", "wall time", "revision"]
    if not any(_false_names(d) is not None for d in docs.values()):
        cols.remove("false names")
    lines = ["<!-- generated by `python -m rvflex.scenarios.diagnosis_results` from docs/results/selfcheck_*.json; "
             "do not edit -->", "",
             "| " + " | ".join(cols) + " |",
             "|" + "|".join("---" if c in ("check", "command", "revision") else "---:" for c in cols) + "|"]
    lines += ["| " + " | ".join(r[c] for c in cols) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def write_table(results: str | Path = RESULTS) -> Path:
    """Write :func:`table` to ``results/table.md``; returns the path."""
    return write_atomic(Path(results) / "table.md", table(results).encode())


def null_table(path: str | Path | None = None) -> str:
    """The Markdown table of the null distribution (``rvflex null-distribution``; default: the package's): per
    candidate effect, the share of the ensemble's controls in which the tests alone accepted it (its false-alarm
    rate before the null's thresholds), and per unit the thresholds a diagnosis of that unit uses (the second
    largest relative evidence, the largest determined size and the largest off-period evidence its healthy controls
    reach), the pooled ones for any other unit; below
    it, how many controls held out one at a time the thresholds of the others hold, and a second table: each
    unit's thresholds from the first and the second half of its controls."""
    from rvflex.diagnosis.effects import EFFECTS
    from rvflex.diagnosis.null import NULL_PATH, relative_threshold_of
    from rvflex.diagnosis.verdict import fmt_mag

    p = Path(path) if path is not None else NULL_PATH
    if not p.is_file():
        return "No null distribution has been made (`rvflex null-distribution`).\n"
    doc = json.loads(p.read_text(encoding="utf-8"))
    src = doc.get("source", {})
    units = list(doc.get("per_unit", {}))
    lines = ["<!-- generated by `python -m rvflex.scenarios.diagnosis_results` from "
             "rvflex/diagnosis/null_distribution.json; do not edit -->", "",
             (f"{src.get('controls', '?')} ensemble controls over {', '.join(src.get('reducers', []))} "
              f"({src.get('cases_per_unit', '?')} per unit, seed {src.get('seed', '?')}; "
              f"`rvflex null-distribution --cases {src.get('cases_per_unit', '?')} --seed {src.get('seed', '?')}`). "
              "Thresholds as relative evidence / size / off-period evidence (the second largest relative evidence "
              "the controls reach, the largest size, and the largest own evidence any control's candidate earns at "
              "the orders that are not multiples of z_b, twice which frees a finding from the size; "
              "the eccentric-bearing clearance's size is its total with the calibrated clearance; for a one-parameter effect "
              "whose range spans both signs, the size on each side, + above zero, − below; for the modification "
              "deviation, + with its moved and equidistant parts of opposite signs, the clearance side, − of one "
              "sign, the shape side)."), "",
             "| effect | false alarms (tests alone) | " + " | ".join(units + ["pooled"]) + " |",
             "|---|---:|" + "---:|" * (len(units) + 1)]

    def cell(v, e) -> str:
        if v is None:
            return "—"
        plain = e is None or e.params[0].unit == "1"  # a share or fraction: no unit to print
        def size(m):
            return f"{m:.3g}" if plain else fmt_mag(e, m)

        off = f" / {v['off_period_max']:.0f}" if "off_period_max" in v else ""
        if "magnitude_max_positive" in v:  # kept per side (rvflex.diagnosis.null.side): + side, then − side
            return (f"{relative_threshold_of(v):.2f} / +{size(v['magnitude_max_positive'])}, "
                    f"−{size(v['magnitude_max_negative'])}{off}")
        return f"{relative_threshold_of(v):.2f} / {size(v['magnitude_max'])}{off}"

    for name, v in sorted(doc["effects"].items(), key=lambda kv: (-kv[1]["false_alarm_rate"], kv[0])):
        e = EFFECTS.get(name)
        n = v["controls"]
        per = [cell(doc["per_unit"][u].get(name), e) for u in units]
        lines.append(f"| {name} | {v['false_alarm_rate']:.2f} ({round(v['false_alarm_rate'] * n)}/{n}) | "
                     + " | ".join(per + [cell(v, e)]) + " |")
    held = doc.get("leave_one_out")
    if held:
        n = sum(h["controls"] for h in held.values())
        named = sum(h["named"] for h in held.values())
        which = "; ".join(f"{u}: {', '.join(h['names'].values())}" for u, h in held.items() if h["names"])
        lines += ["", f"Held out one at a time, each control judged by the thresholds of its unit's other controls: "
                      f"{named} of {n} name an effect ({which or 'none'})."]
    halves = doc.get("halves")
    if halves:
        lines += ["", "Each unit's thresholds from the first and from the second half of its controls (relative "
                      "evidence, size; the plain evidence, which is not a threshold, for comparison):", "",
                  "| unit | effect | relative evidence | size | evidence |", "|---|---|---:|---:|---:|"]
        for u, per in halves.items():
            for name, v in per.items():
                e = EFFECTS.get(name)
                plain = e is None or e.params[0].unit == "1"
                sz = [f"{m:.3g}" if plain else fmt_mag(e, m) for m in v["magnitude"]]
                lines.append(f"| {u} | {name} | {v['relative'][0]:.2f} · {v['relative'][1]:.2f} | {sz[0]} · {sz[1]} | "
                             f"{v['evidence'][0]:.0f} · {v['evidence'][1]:.0f} |")
    return "\n".join(lines) + "\n"


def write_null_table(results: str | Path = RESULTS) -> Path:
    """Write :func:`null_table` to ``results/null_table.md``; returns the path."""
    return write_atomic(Path(results) / "null_table.md", null_table().encode())


def main(argv: list[str] | None = None) -> int:
    """The command (see the module docstring); returns the exit status."""
    ap = argparse.ArgumentParser(prog="python -m rvflex.scenarios.diagnosis_results",
                                 description="Run the diagnosis's checks into docs/results/ and regenerate "
                                             "docs/results/table.md (without --run: the table only).")
    ap.add_argument("--run", nargs="+", metavar="NAME", default=[],
                    help=f"checks to run, or 'all' ({', '.join(CHECKS)})")
    ap.add_argument("--list", action="store_true", help="print the checks and their commands, run nothing")
    ap.add_argument("--out", default="out/results", help="parent of each check's working folder (default out/results)")
    ap.add_argument("--results", default=str(RESULTS), help="results folder (default the repository's docs/results)")
    ap.add_argument("--reuse-benches", action="store_true", help="pass --reuse-benches to every check")
    ap.add_argument("--workers", type=int, default=2, help="--workers of every check (default 2)")
    a = ap.parse_args(argv)
    if a.list:
        for name in CHECKS:
            print(f"{name}: {check_command(name)}")
        return 0
    names = list(CHECKS) if a.run == ["all"] else a.run
    unknown = [n for n in names if n not in CHECKS]
    if unknown:
        ap.error(f"unknown check {unknown[0]!r}; known: all, {', '.join(CHECKS)}")
    failed = []
    for name in names:
        try:
            print("wrote", run_check(name, a.out, a.results, reuse_benches=a.reuse_benches, workers=a.workers))
        except RuntimeError as err:
            print(err, file=sys.stderr)
            failed.append(name)
    print("wrote", write_table(a.results))
    print("wrote", write_null_table(a.results))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

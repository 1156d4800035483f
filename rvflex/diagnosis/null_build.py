"""Build the null distribution (:mod:`rvflex.diagnosis.null`): ensemble controls of every unit, diagnosed."""

from __future__ import annotations

import json
import time
from pathlib import Path

from rvflex.diagnosis.null import halves, leave_one_out, null_from_reports, unrefined_setters

__all__ = ["build_null"]


def build_null(out_dir: str | Path, reducers=("rv40e", "rv80e", "rv160n"), cases: int = 56, seed: int = 1,
               json_path: str | Path | None = None, cache_dir: str | Path | None = None, rounds: int = 4,
               log=print) -> dict:
    """Diagnose ``cases`` ensemble controls of each unit in ``reducers`` (self-checks with ``--mismatch
    ensemble`` and every case a control) and write their null distribution to ``json_path`` (default: none
    written). Each control whose linearised fit sets a threshold is diagnosed again with that candidate refined
    (:func:`~rvflex.diagnosis.null.unrefined_setters`), for at most ``rounds`` rounds. Returns the document: ``effects`` (see :func:`null_from_reports`), ``per_unit`` (the same per
    unit), ``controls`` (verdict per control), ``leave_one_out`` (per unit, :func:`~rvflex.diagnosis.null.leave_one_out`),
    ``halves`` (per unit, :func:`~rvflex.diagnosis.null.halves`) and ``source``."""
    from rvflex.diagnosis.selfcheck import SelfCheckSettings, selfcheck
    from rvflex.diagnosis.settings import DiagnosisSettings
    from rvflex.io import write_atomic

    t0 = time.perf_counter()
    out = Path(out_dir)
    reports, per_unit, controls, held_out, split = [], {}, [], {}, {}
    for i, unit in enumerate(reducers):
        s = SelfCheckSettings(cases=cases, seed=seed + i, control_every=1, mismatch="ensemble", reducer=unit,
                              reuse_benches=True, diagnosis=DiagnosisSettings(null_distribution=None))
        doc = selfcheck(out / unit, s, cache_dir=cache_dir, log=log)
        rows = [row for row in doc["per_case"]
                if "error" not in row and (out / unit / "reports" / f"case_{row['case']:02d}.json").is_file()]
        rows = _setters_refined(out / unit, rows, s, cache_dir, rounds, log)
        mine = [json.loads((out / unit / "reports" / f"case_{row['case']:02d}.json").read_text(encoding="utf-8"))
                for row in rows]
        controls += [{"unit": unit, "case": row["case"], "chosen": row.get("chosen"), "ranked": row.get("ranked"),
                      "wall_s": row.get("wall_s"), "also_refined": row.get("also_refined", [])} for row in rows]
        reports += mine
        per_unit[unit] = null_from_reports(mine)
        held_out[unit] = leave_one_out(mine)
        split[unit] = halves(mine)
    doc = {"effects": null_from_reports(reports), "per_unit": per_unit, "controls": controls,
           "leave_one_out": held_out, "halves": split,
           "source": {"reducers": list(reducers), "cases_per_unit": cases, "seed": seed, "mismatch": "ensemble",
                      "controls": len(reports), "setter_rounds": rounds},
           "wall_s": time.perf_counter() - t0}
    if json_path is not None:
        write_atomic(json_path, json.dumps(doc, indent=2, default=float).encode())
    return doc


def _setters_refined(folder: Path, rows: list[dict], s, cache_dir, rounds: int, log) -> list[dict]:
    """The self-check rows of one unit's controls (in ``folder``, made with self-check settings ``s``) after up to
    ``rounds`` rounds in which each control whose linearised fit sets a threshold is diagnosed again with it refined
    (and those of earlier rounds); its report is rewritten and its row gains ``also_refined``. A fit still linearised
    after its control was diagnosed again with it (a refinement that failed) is not asked for again."""
    import dataclasses as dc

    from rvflex.diagnosis.selfcheck import diagnose_case
    from rvflex.parallel import map_warm

    def report(row):
        return folder / "reports" / f"case_{row['case']:02d}.json"

    asked: dict[int, set] = {}
    tried: set = set()
    for r in range(rounds):
        docs = [json.loads(report(row).read_text(encoding="utf-8")) for row in rows]
        todo = unrefined_setters(docs, tried=tried)
        if not todo:
            break
        for i, names in todo.items():
            asked.setdefault(i, set()).update(names)
            tried.update((i, n) for n in names)
        log(f"{folder.name}: round {r + 1}: {sum(map(len, todo.values()))} threshold-setting fits in "
            f"{len(todo)} controls refined")
        jobs = []
        for i in sorted(todo):
            row = rows[i]
            ds = dc.replace(s.diagnosis, workers=1 if len(todo) > 1 else s.diagnosis.workers,
                            also_refine=tuple(sorted(asked[i])))
            jobs.append((row["case"], folder / "datasets" / f"case_{row['case']:02d}",
                         folder / "truth" / f"case_{row['case']:02d}.json", report(row), s, ds, cache_dir))
        for i, o in zip(sorted(todo), map_warm(diagnose_case, jobs, s.diagnosis.workers if len(jobs) > 1 else 0)):
            if not o.ok:
                raise RuntimeError(f"control {rows[i]['case']} of {folder.name}: the diagnosis failed: {o.error}")
            rows[i] = {**o.value[0], "also_refined": sorted(asked[i])}
    return rows

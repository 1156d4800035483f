"""Build the null distribution (:mod:`rvflex.diagnosis.null`): ensemble controls of every unit, diagnosed."""

from __future__ import annotations

import json
import time
from pathlib import Path

from rvflex.diagnosis.null import halves, leave_one_out, null_from_reports

__all__ = ["build_null"]


def build_null(out_dir: str | Path, reducers=("rv40e", "rv80e", "rv160n"), cases: int = 56, seed: int = 1,
               json_path: str | Path | None = None, cache_dir: str | Path | None = None, log=print) -> dict:
    """Diagnose ``cases`` ensemble controls of each unit in ``reducers`` (self-checks with ``--mismatch
    ensemble`` and every case a control) and write their null distribution to ``json_path`` (default: none
    written). Returns the document: ``effects`` (see :func:`null_from_reports`), ``per_unit`` (the same per
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
        mine = []
        for row in doc["per_case"]:
            p = out / unit / "reports" / f"case_{row['case']:02d}.json"
            if "error" in row or not p.is_file():
                continue
            d = json.loads(p.read_text(encoding="utf-8"))
            mine.append(d)
            controls.append({"unit": unit, "case": row["case"], "chosen": row.get("chosen"),
                             "ranked": row.get("ranked"), "wall_s": row.get("wall_s")})
        reports += mine
        per_unit[unit] = null_from_reports(mine)
        held_out[unit] = leave_one_out(mine)
        split[unit] = halves(mine)
    doc = {"effects": null_from_reports(reports), "per_unit": per_unit, "controls": controls,
           "leave_one_out": held_out, "halves": split,
           "source": {"reducers": list(reducers), "cases_per_unit": cases, "seed": seed, "mismatch": "ensemble",
                      "controls": len(reports)},
           "wall_s": time.perf_counter() - t0}
    if json_path is not None:
        write_atomic(json_path, json.dumps(doc, indent=2, default=float).encode())
    return doc

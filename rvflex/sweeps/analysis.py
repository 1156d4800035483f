"""Analysis of a finished sweep: level means and ranges of orthogonal and single-factor designs,
the sensitive/insensitive split, and SALib's global sensitivity indices (Morris μ*/σ, Sobol S1/ST)."""

from __future__ import annotations

import csv
import io
import itertools
import math
from pathlib import Path

import numpy as np

from rvflex.io import write_text
from rvflex.sweeps.designs import SALIB_KINDS, Design, salib_problem, salib_samples

__all__ = ["classify", "range_table", "sensitivity_indices", "write_indices_csv"]


def range_table(design: Design, rows: list[dict], metric: str) -> list[dict]:
    """Level means K1…Kn and range R per factor (seed 004 Table 8 style) for an orthogonal or
    single-factor design."""
    out = []
    for f in design.factors:
        means = []
        for level in f.levels:
            vals = [r[metric] for r in rows if metric in r and r[f.name] == level]
            means.append(float(np.mean(vals)) if vals else math.nan)
        finite = [m for m in means if not math.isnan(m)]
        out.append({"factor": f.name, "K": means, "range": (max(finite) - min(finite)) if finite else math.nan})
    return sorted(out, key=lambda r: -r["range"])


def classify(ranking: list[dict], key: str = "range") -> dict[str, str]:
    """Sensitive / insensitive per factor: the ranges (or another non-negative measure ``key``,
    e.g. ``index`` of :func:`sensitivity_indices`), sorted, split where two consecutive ones
    differ by the largest ratio (the natural break on a log scale); the upper group is
    sensitive. A single factor is sensitive; a factor without a finite measure is left out."""
    ranked = sorted((r for r in ranking if math.isfinite(r[key])), key=lambda r: -r[key])
    if len(ranked) < 2:
        return {r["factor"]: "sensitive" for r in ranked}
    ratios = [max(a[key], 1e-300) / max(b[key], 1e-300) for a, b in itertools.pairwise(ranked)]
    cut = int(np.argmax(ratios)) + 1
    return {r["factor"]: ("sensitive" if k < cut else "insensitive") for k, r in enumerate(ranked)}


def sensitivity_indices(design: Design, rows: list[dict], metric: str, *, num_resamples: int = 1000,
                        conf_level: float = 0.95) -> list[dict]:
    """Global sensitivity of ``metric`` from a finished ``morris`` or ``sobol-indices`` sweep,
    analysed with SALib (bootstrap seeded by ``design.seed``), most influential factor first.

    Each entry has ``factor``, ``index`` (the ranking measure) and ``index_name``, plus:

    - ``morris``: ``index`` = μ* (mean |elementary effect|, in the metric's unit per full
      ``low``…``high`` range, so comparable with a single-factor range R of a linear
      response), ``mu``, ``sigma`` (spread of the effects: interaction or non-linearity)
      and ``mu_star_conf``;
    - ``sobol-indices``: ``index`` = ST (total-order index, share of the variance including
      interactions), ``S1``, ``S1_conf`` and ``ST_conf`` (half-widths at ``conf_level``).

    Every entry also has ``groups_used``: a trajectory (Morris) or a Saltelli block with a failed
    point is dropped whole, since both estimators need complete groups; raises ``ValueError``
    when fewer than two groups are complete.
    """
    if design.kind not in SALIB_KINDS:
        raise ValueError(f"sensitivity indices need a {' or '.join(SALIB_KINDS)} design, not {design.kind!r}")
    problem = salib_problem(design)
    x = salib_samples(design)
    y = np.full(len(x), np.nan)
    for r in rows:
        if metric in r and r[metric] is not None:
            y[r["point"]] = float(r[metric])
    d = len(design.factors)
    size = d + 1 if design.kind == "morris" else d + 2
    ok = np.isfinite(y.reshape(-1, size)).all(axis=1)
    if ok.sum() < 2:
        raise ValueError(f"only {int(ok.sum())} complete {'trajectories' if size == d + 1 else 'blocks'} of "
                         f"{len(ok)}: too few for {design.kind}")
    keep = np.repeat(ok, size)
    out = []
    if design.kind == "morris":
        from SALib.analyze import morris

        res = morris.analyze(problem, x[keep], y[keep], num_resamples=num_resamples, conf_level=conf_level,
                             num_levels=design.morris_levels, seed=design.seed)
        for j, name in enumerate(problem["names"]):
            out.append({"factor": name, "index_name": "mu_star", "index": float(res["mu_star"][j]),
                        "mu": float(res["mu"][j]), "sigma": float(res["sigma"][j]),
                        "mu_star_conf": float(res["mu_star_conf"][j]), "groups_used": int(ok.sum())})
    else:
        from SALib.analyze import sobol

        res = sobol.analyze(problem, y[keep], calc_second_order=False, num_resamples=num_resamples,
                            conf_level=conf_level, seed=design.seed)
        for j, name in enumerate(problem["names"]):
            out.append({"factor": name, "index_name": "ST", "index": float(res["ST"][j]),
                        "S1": float(res["S1"][j]), "S1_conf": float(res["S1_conf"][j]),
                        "ST_conf": float(res["ST_conf"][j]), "groups_used": int(ok.sum())})
    return sorted(out, key=lambda r: -r["index"])


def write_indices_csv(ranking: list[dict], classes: dict[str, str], path: Path) -> Path:
    """Write the :func:`sensitivity_indices` table (one row per factor, with its class) as CSV."""
    keys = ["factor", "index_name", "index"] + [k for k in ranking[0] if k not in ("factor", "index_name", "index")]
    fh = io.StringIO(newline="")
    w = csv.writer(fh)
    w.writerow(keys + ["class"])
    for r in ranking:
        w.writerow([r[k] for k in keys] + [classes.get(r["factor"], "")])
    write_text(path, fh.getvalue())
    return path

"""Plots of a finished sweep, written to PNG files (``matplotlib.figure.Figure``: no pyplot state,
no backend switch)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from rvflex.io import save_figure
from rvflex.sweeps.analysis import classify
from rvflex.sweeps.designs import Design

__all__ = ["plot_indices", "plot_main_effects"]


def plot_indices(design: Design, ranking: list[dict], metric: str, path: Path) -> Path:
    """Bar plot of the sensitivity indices with their confidence intervals; for Morris also the
    μ*–σ plane (σ ≫ μ* flags interaction or non-linearity)."""
    from matplotlib.figure import Figure

    names = [r["factor"] for r in ranking][::-1]
    y = np.arange(len(names))
    morris = ranking[0]["index_name"] == "mu_star"
    fig = Figure(figsize=(11 if morris else 7, 0.5 * len(names) + 2), layout="constrained")
    axes = fig.subplots(1, 2 if morris else 1, squeeze=False)
    ax = axes[0, 0]
    rev = ranking[::-1]
    if morris:
        ax.barh(y, [r["index"] for r in rev], xerr=[r["mu_star_conf"] for r in rev], capsize=3)
        ax.set_xlabel(f"μ* of {metric} (per full range)")
        ax2 = axes[0, 1]
        ax2.scatter([r["index"] for r in ranking], [r["sigma"] for r in ranking])
        for r in ranking:
            ax2.annotate(r["factor"], (r["index"], r["sigma"]), fontsize=7)
        ax2.set_xlabel("μ*")
        ax2.set_ylabel("σ")
        ax2.grid(alpha=0.3)
    else:
        ax.barh(y - 0.2, [r["S1"] for r in rev], 0.4, xerr=[r["S1_conf"] for r in rev], capsize=3, label="S1")
        ax.barh(y + 0.2, [r["index"] for r in rev], 0.4, xerr=[r["ST_conf"] for r in rev], capsize=3, label="ST")
        ax.set_xlabel(f"Sobol index of {metric}")
        ax.legend()
    ax.set_yticks(y, names, fontsize=8)
    ax.grid(alpha=0.3, axis="x")
    fig.suptitle(f"{design.name}: {design.kind} ({design.samples} {'trajectories' if morris else 'base samples'}, "
                 f"{ranking[0]['groups_used']} complete)")
    save_figure(fig, path, dpi=110)
    return path


def plot_main_effects(design: Design, ranking: list[dict], metric: str, path: Path) -> Path:
    """Main-effect plot: level means of ``metric`` against each factor's deviation (µm)."""
    from matplotlib.figure import Figure

    n = len(ranking)
    cols = min(n, 5)
    rows_ = math.ceil(n / cols)
    fig = Figure(figsize=(3.0 * cols, 2.6 * rows_), layout="constrained")
    axes = fig.subplots(rows_, cols, squeeze=False, sharey=True)
    levels = {f.name: f.levels for f in design.factors}
    cls = classify(ranking)
    for ax, r in zip(axes.flat, ranking):
        ax.plot(np.asarray(levels[r["factor"]]) * 1e6, r["K"], "o-")
        ax.set_title(f"{r['factor']}\nR = {r['range']:.4g} ({cls[r['factor']]})", fontsize=8)
        ax.set_xlabel("deviation (µm)", fontsize=8)
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    axes[0, 0].set_ylabel(metric)
    fig.suptitle(f"{design.name}: main effects ({design.kind}, {design.reducer})")
    save_figure(fig, path, dpi=110)
    return path

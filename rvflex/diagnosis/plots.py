"""The diagnosis report's plots: measured, model and corrected TE, the residual order spectra, the torque
cycles and the effect ranking (:data:`PLOTS`), drawn into PNG files side by side (:func:`draw_plots`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rvflex.diagnosis.features import shift_measured
from rvflex.diagnosis.linear import nuisance_columns
from rvflex.geometry.formulas import ARCSEC_PER_RAD

__all__ = ["PLOTS", "PLOT_DPI", "draw_plots", "draw_run", "mag_text", "offset_columns", "png_of", "te_on_grid"]


def offset_columns(diag) -> np.ndarray:
    """The offset (nuisance) columns of ``diag``'s features that are in use."""
    cols = nuisance_columns(diag.layout)
    return cols[:, np.abs(cols).sum(0) > 0]


def te_on_grid(diag, feats: np.ndarray, run: int, n: int = 512) -> np.ndarray:
    """TE run ``run`` of the features ``feats`` (arcsec) at ``n`` uniform positions of an output revolution."""
    lay = diag.layout
    p = 2 * np.pi * np.arange(n) / n
    k = np.arange(1, lay.max_order + 1)
    return feats[lay.dc[run]] + np.cos(np.outer(p, k)) @ feats[lay.cos[run]] + np.sin(np.outer(p, k)) @ feats[lay.sin[run]]


def _fig_te(diag):
    """Measured, model and corrected TE of every TE run (None without TE runs)."""
    from matplotlib.figure import Figure  # no pyplot: the caller's backend and figures stay untouched

    te_runs = diag.layout.te_runs
    if not te_runs:
        return None
    fig = Figure(figsize=(11, 3.0 * len(te_runs)), layout="constrained")
    axes = fig.subplots(len(te_runs), 1, squeeze=False)
    for ax, r in zip(axes[:, 0], te_runs):
        draw_run(ax, diag, r)
        if r != te_runs[-1]:
            ax.set_xlabel("")
    axes[0, 0].legend(fontsize=8, loc="best")
    return fig


def _fig_orders(diag):
    """The residual order spectrum of every TE run before and after the accepted effect."""
    from matplotlib.figure import Figure

    lay = diag.layout
    base, ch = diag.baseline, diag.chosen
    te_runs = lay.te_runs
    if not te_runs:
        return None
    fig = Figure(figsize=(11, 2.6 * len(te_runs)), layout="constrained")
    axes = fig.subplots(len(te_runs), 1, squeeze=False)
    k = np.arange(1, lay.max_order + 1)
    for ax, r in zip(axes[:, 0], te_runs):
        for c, col, lab in ((base, "C0", "before (model)"), (ch, "C3", "after (corrected)")):
            if c is None:
                continue
            y = shift_measured(diag.measured, lay, c.delta)[:, 0]
            amp = np.hypot(y[lay.cos[r]] - c.model_features[lay.cos[r]], y[lay.sin[r]] - c.model_features[lay.sin[r]])
            # one line collection per run, not 255 bar patches (a third of the report's plotting time)
            ax.vlines(k + (0.2 if c is ch else -0.2), 1e-3, np.maximum(amp, 1e-3), color=col, lw=1.0, label=lab)
        ax.set_yscale("log")
        ax.set_ylim(bottom=1e-3)
        ax.set_title(f"residual order spectrum — {diag.plan[r].label}", fontsize=9)
        ax.set_ylabel("|residual| (arcsec)")
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("order (per output revolution)")
    axes[0, 0].legend(fontsize=8)
    return fig


def _fig_hysteresis(diag):
    """Measured, model and corrected torque cycles (None without torque cycles)."""
    from matplotlib.figure import Figure

    hyst = sorted(diag.layout.hyst)
    if not hyst:
        return None
    fig = Figure(figsize=(7 * len(hyst), 4.8), layout="constrained")
    axes = fig.subplots(1, len(hyst), squeeze=False)
    for ax, r in zip(axes[0], hyst):
        draw_run(ax, diag, r)
    return fig


def _fig_ranking(diag):
    """The first ten candidates' scores and fitted magnitudes against their bounds."""
    from matplotlib.figure import Figure

    cands = list(diag.candidates[:10])
    if not cands:
        return None
    fig = Figure(figsize=(13, 0.45 * len(cands) + 1.6), layout="constrained")
    a0, a1 = fig.subplots(1, 2, width_ratios=(1, 1.2))
    yy = np.arange(len(cands))[::-1]
    a0.barh(yy, [max(c.score, 0.0) for c in cands],
            color=["C3" if c.accepted else ("C0" if c.refined else "0.7") for c in cands])
    a0.set_yticks(yy, [c.name for c in cands], fontsize=8)
    a0.set_xlabel("score = BIC(calibrated model) − BIC(candidate)")
    a0.set_xscale("symlog")
    a0.grid(alpha=0.3)
    for y_, c in zip(yy, cands):
        if not c.attributed:
            continue
        e = c.attributed[0]
        i = list(c.effects).index(e)
        m, (lo, hi) = c.magnitude[i], c.magnitude_interval[i]
        hi_b = float(np.linalg.norm(np.maximum(np.abs(e.lower), np.abs(e.upper))))
        a1.errorbar([m / hi_b], [y_], xerr=[[max(m - lo, 0) / hi_b], [max(hi - m, 0) / hi_b]], fmt="o",
                    color="C3" if c.accepted else "C0", capsize=3)
        a1.text(1.02, y_, f"{e.name}: {mag_text(e, m, lo, hi)}", fontsize=7, va="center",
                transform=a1.get_yaxis_transform())
    a1.set_yticks(yy, [""] * len(yy))
    a1.set_xlim(0, 1)
    a1.set_xlabel("fitted magnitude / bound (first effect), 95 % interval")
    a1.grid(alpha=0.3)
    return fig


PLOTS = {"te_measured_model_corrected.png": _fig_te, "residual_orders.png": _fig_orders,
         "hysteresis_loops.png": _fig_hysteresis, "effect_ranking.png": _fig_ranking}
"""The report's plots: file name → the function drawing its figure from a diagnosis (None: nothing to show)."""
PLOT_DPI = 110


def png_of(item) -> bytes | None:
    """The PNG of plot ``name`` of ``diag`` (item = (diag, name)), None when it shows nothing."""
    import io

    diag, name = item
    fig = PLOTS[name](diag)
    if fig is None:
        return None
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=PLOT_DPI)
    return buf.getvalue()


def draw_plots(diag, out: Path) -> list[Path]:
    """Draw the report's plots into ``out``; returns the files written. With more than one worker
    (``diag.settings.workers``) they are drawn side by side, forked from this process once it has drawn a
    line of text (the backend and the fonts then loaded here once, not in each worker: measured, four plots
    of a four-run diagnosis 0.36 + 0.9 s against 1.6 s one after the other); a plot whose worker fails is
    drawn here."""
    import io

    from matplotlib.figure import Figure

    from rvflex.parallel import map_warm

    names = list(PLOTS)
    workers = min(diag.settings.workers, len(names)) if diag.settings.workers > 1 else 0
    if workers:
        warm = Figure(figsize=(1, 1))
        warm.text(0.5, 0.5, "0″")
        warm.savefig(io.BytesIO(), format="png")
    done = map_warm(png_of, [(diag, n) for n in names], workers)
    paths = []
    for name, o in zip(names, done):
        png = o.value if o.ok else png_of((diag, name))
        if png is not None:
            p = out / name
            p.write_bytes(png)
            paths.append(p)
    return paths


def draw_run(ax, diag, run: int) -> None:
    """Draw bench run ``run`` (its index in ``diag.plan``) on ``ax`` as the report's plots do: a TE
    run's TE over one output revolution (arcsec against degrees; measured with the fitted offset and
    origin removed, the calibrated model, the model with the accepted effect), a torque cycle's
    torque against the output angle (N·m against arcmin)."""
    lay = diag.layout
    base, ch = diag.baseline, diag.chosen
    ref = ch or base
    if run in lay.hyst:
        data = diag.dataset.runs[run]
        nu = (offset_columns(diag) @ ref.nuisance)[lay.hyst[run]][0]
        ax.plot(data.theta_out_rad * ARCSEC_PER_RAD / 60 - nu / 60, data.torque_Nm, ".", ms=2, color="k",
                label="measured")
        for c, col, lab in ((base, "C0", "model"), (ch, "C3", "corrected")):
            if c is None or c.response is None:
                continue
            off = (offset_columns(diag) @ c.nuisance)[lay.hyst[run]][0] - nu
            ax.plot(c.response.theta[run] * ARCSEC_PER_RAD / 60 + off / 60, c.response.torque[run], "-", color=col,
                    lw=1.0, label=lab)
        ax.set_xlabel("output angle (arcmin)")
        ax.set_ylabel("output torque (N·m)")
    else:
        deg = np.arange(512) * 360 / 512
        y = shift_measured(diag.measured, lay, ref.delta)[:, 0] - offset_columns(diag) @ ref.nuisance
        ax.plot(deg, te_on_grid(diag, y, run), color="k", lw=1.0, label="measured (offset, origin removed)")
        ax.plot(deg, te_on_grid(diag, base.model_features, run), color="C0", lw=1.0, ls="--", label="model")
        if ch is not None:
            ax.plot(deg, te_on_grid(diag, ch.model_features, run), color="C3", lw=1.0, label=f"corrected: {ch.name}")
        ax.set_xlabel("output position (°)")
        ax.set_ylabel("TE (arcsec)")
    ax.set_title(diag.plan[run].label, fontsize=9)
    ax.grid(alpha=0.3)
    if run in lay.hyst:
        ax.legend(fontsize=8)


def mag_text(e, m, lo, hi) -> str:
    """A magnitude with its 95 % interval in the effect's display unit (µm, ″, ppm/K)."""
    u = e.params[0].unit
    f, unit = {"m": (1e6, "µm"), "rad": (ARCSEC_PER_RAD, "″"), "1/K": (1e6, "ppm/K")}.get(u, (1.0, u))
    return f"{m * f:.3g} [{lo * f:.3g}, {hi * f:.3g}] {unit}"

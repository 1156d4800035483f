"""The diagnosis report: where the gap lies, the effect ranking, the gap before/after, the
JSON document of ``rvflex diagnose`` and the Markdown report (its plots: :mod:`rvflex.diagnosis.plots`)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from rvflex.diagnosis.features import shift_measured
from rvflex.diagnosis.linear import Candidate
from rvflex.diagnosis.nominal import describe_calibration
from rvflex.diagnosis.plan import BRANCH_FRACTIONS, part_label
from rvflex.diagnosis.plots import draw_plots, mag_text, offset_columns, te_on_grid

__all__ = ["dependence", "gap_table", "json_document", "repeatability", "residual_orders", "verdict_grade", "where_list", "write_report"]


def _run_meta(diag, r: int) -> tuple[str, float]:
    p = diag.plan[r]
    if p.kind == "te":
        return ("forward" if p.direction > 0 else "reverse"), p.load_Nm
    return "cycle", p.torque_max_Nm


def _run_keys(diag, r: int) -> dict:
    """The keys that name run ``r`` in the JSON rows: its index, direction, load and temperature
    (°C, None when the bench did not record it); runs may share direction and load."""
    direction, load = _run_meta(diag, r)
    t = diag.plan[r].temperature_C
    speed = getattr(diag.dataset.runs[r], "speed_out_rpm", math.nan) if diag.dataset is not None else math.nan
    return {"run": r, "direction": direction, "load_Nm": load, "temperature_C": float(t) if math.isfinite(t) else None,
            "speed_out_rpm": float(speed) if speed is not None and math.isfinite(speed) and speed > 0 else None}


def _run_text(row: dict) -> str:
    at = f" at {row['temperature_C']:g} °C" if row.get("temperature_C") is not None else ""
    return f"{row['direction']} {row['load_Nm']:g} N·m{at}"


def _residual(diag, c: Candidate) -> np.ndarray:
    """Measured − model features (arcsec) with the candidate's origin and offsets applied."""
    y = shift_measured(diag.measured, diag.layout, c.delta)[:, 0]
    cols = diag.layout and offset_columns(diag)
    return y - c.model_features - cols @ c.nuisance


def where_list(diag, min_share: float = 0.01) -> list[dict]:
    """The gap's location: weighted residual energy of the baseline per run and order, mean
    wind-up and hysteresis region, as shares of the total, largest first."""
    lay = diag.layout
    r = _residual(diag, diag.nominal_model or diag.baseline) * diag.weights
    total = float(r @ r) or 1.0
    out = []
    for run in range(len(diag.plan)):
        keys = _run_keys(diag, run)
        if run in lay.dc:
            out.append({"metric": "mean wind-up", **keys, "share": float(r[lay.dc[run]] ** 2 / total)})
            e = r[lay.cos[run]] ** 2 + r[lay.sin[run]] ** 2
            rest = 0.0
            for k, v in enumerate(e, start=1):
                if v / total >= min_share:
                    out.append({"order": k, **keys, "share": float(v / total)})
                else:
                    rest += v
            out.append({"metric": "other orders", **keys, "share": float(rest / total)})
        else:
            sl = r[lay.hyst[run]]
            frac = np.abs(np.tile(BRANCH_FRACTIONS, 2))
            low = frac <= 0.05
            out.append({"metric": "lost motion (hysteresis loop, torque within ±5 %)", **keys,
                        "share": float(np.sum(sl[low] ** 2) / total)})
            out.append({"metric": "torsional stiffness (hysteresis loop, torque beyond ±5 %)", **keys,
                        "share": float(np.sum(sl[~low] ** 2) / total)})
    return sorted((w for w in out if w["share"] > 0), key=lambda w: -w["share"])


def _hyst_metrics(torque, theta_rad, tmax):
    from rvflex.metrics import hysteresis_metrics

    try:
        m = hysteresis_metrics(np.asarray(torque), np.asarray(theta_rad), tmax)
    except (ValueError, np.linalg.LinAlgError, IndexError):
        return None
    return m


def gap_table(diag, c: Candidate, n_orders: int = 8) -> dict:
    """Gap between the bench and the model ``c`` (the baseline or a corrected one): per run and
    metric (TE peak-to-peak, mean wind-up, lost motion, hysteresis loss, torsional stiffness)
    and per order (the ``n_orders`` largest residual orders of each TE run)."""
    lay = diag.layout
    y = shift_measured(diag.measured, lay, c.delta)[:, 0]
    nu = offset_columns(diag) @ c.nuisance
    metrics, orders = [], []
    for run, p in enumerate(diag.plan):
        keys = _run_keys(diag, run)
        if p.kind == "te":
            meas = te_on_grid(diag, y - nu, run)
            mod = te_on_grid(diag, c.model_features, run)
            for name, fm in (("TE peak-to-peak", np.ptp), ("mean wind-up", np.mean)):
                a, b = float(fm(meas)), float(fm(mod))
                metrics.append({"metric": name, **keys, "unit": "arcsec",
                                "measured": a, "model": b, "gap": b - a,
                                "gap_pct": 100 * (b - a) / a if abs(a) > 1e-12 else None})
            ra = y[lay.cos[run]] - c.model_features[lay.cos[run]]
            rb = y[lay.sin[run]] - c.model_features[lay.sin[run]]
            amp = np.hypot(ra, rb)
            for k in np.argsort(amp)[::-1][:n_orders]:
                orders.append({"order": int(k + 1), **keys, "residual_arcsec": float(amp[k])})
        else:
            run_data = diag.dataset.runs[run]
            mm = _hyst_metrics(run_data.torque_Nm, run_data.theta_out_rad, p.torque_max_Nm)
            resp = c.response
            md = (_hyst_metrics(resp.torque[run], resp.theta[run], p.torque_max_Nm)
                  if resp is not None else None)
            for name, attr, unit in (("lost motion", "lost_motion_arcmin", "arcmin"),
                                     ("hysteresis loss", "hysteresis_loss_arcmin", "arcmin"),
                                     ("torsional stiffness", "torsional_stiffness_Nm_per_arcmin", "N·m/arcmin")):
                a = getattr(mm, attr) if mm else math.nan
                b = getattr(md, attr) if md else math.nan
                metrics.append({"metric": name, **keys, "unit": unit,
                                "measured": a, "model": b, "gap": b - a,
                                "gap_pct": 100 * (b - a) / a if abs(a) > 1e-12 else None})
    r = (y - c.model_features - nu) * diag.weights
    return {"metrics": metrics, "orders": orders, "weighted_rms": float(math.sqrt(np.mean(r**2)))}


def _after_with_shrink(before: dict, after: dict) -> dict:
    out = dict(after)
    ms = []
    for b, a in zip(before["metrics"], after["metrics"]):
        m = dict(a)
        gb, ga = abs(b["gap"]), abs(a["gap"])
        m["shrink_abs"] = gb - ga if np.isfinite(gb) and np.isfinite(ga) else None
        m["shrink_pct"] = 100 * (gb - ga) / gb if gb > 1e-12 and np.isfinite(ga) else None
        ms.append(m)
    out["metrics"] = ms
    bo = {(o["order"], o["run"]): o["residual_arcsec"] for o in before["orders"]}
    os_ = []
    for o in after["orders"]:
        key = (o["order"], o["run"])
        m = dict(o)
        if key in bo and bo[key] > 0:
            m["shrink_pct"] = 100 * (bo[key] - o["residual_arcsec"]) / bo[key]
        os_.append(m)
    out["orders"] = os_
    out["weighted_rms_shrink_pct"] = 100 * (1 - after["weighted_rms"] / before["weighted_rms"]) \
        if before["weighted_rms"] > 0 else 0.0
    return out


def _orders_of(diag, c: Candidate, keys) -> list[dict]:
    lay = diag.layout
    y = shift_measured(diag.measured, lay, c.delta)[:, 0]
    out = []
    for order, r in keys:
        a = y[lay.cos[r]][order - 1] - c.model_features[lay.cos[r]][order - 1]
        b = y[lay.sin[r]][order - 1] - c.model_features[lay.sin[r]][order - 1]
        out.append({"order": order, **_run_keys(diag, r), "residual_arcsec": float(math.hypot(a, b))})
    return out


RESIDUAL_ORDER_FLOORS = 3.0  # a residual order is significant at this many floors (noise and model-form floor)
RESIDUAL_ORDERS_SHOWN = 12  # at most this many residual orders are named, largest first


def residual_orders(diag, c: Candidate | None = None) -> list[dict]:
    """The significant residual TE orders of model ``c`` (default: the accepted one, else the calibrated model),
    each named by the parts of the unit that turn at it (:func:`rvflex.diagnosis.orders.name_orders`).

    An order is significant in a run when its residual amplitude reaches :data:`RESIDUAL_ORDER_FLOORS` times its
    floor (the weight's inverse: measurement noise and the model-form floor). Per order: its largest residual
    (arcsec) and floors, the residual in every TE run with the run's conditions (load, direction, temperature),
    so its load and temperature dependence can be read, the parts, the candidate effects acting there and the
    part errors at that order the library lacks. Largest first, at most :data:`RESIDUAL_ORDERS_SHOWN`."""
    from rvflex.diagnosis.effects import EFFECTS
    from rvflex.diagnosis.orders import name_orders

    lay = diag.layout
    c = c or diag.chosen or diag.baseline
    y = shift_measured(diag.measured, lay, c.delta)[:, 0]
    amp, floors = {}, {}
    for r in lay.te_runs:
        a = np.hypot(y[lay.cos[r]] - c.model_features[lay.cos[r]], y[lay.sin[r]] - c.model_features[lay.sin[r]])
        f = 1.0 / diag.weights[lay.cos[r]]
        amp[r], floors[r] = a, a / f
    peak = {}
    for r in lay.te_runs:
        for k in np.flatnonzero(floors[r] >= RESIDUAL_ORDER_FLOORS):
            if floors[r][k] > peak.get(int(k) + 1, (0.0, None))[0]:
                peak[int(k) + 1] = (float(floors[r][k]), r)
    top = sorted(peak, key=lambda k: -amp[peak[k][1]][k - 1])[:RESIDUAL_ORDERS_SHOWN]
    named = {row["order"]: row for row in name_orders(diag.dataset.reducer, top, candidates=tuple(EFFECTS))}
    out = []
    for k in top:
        fl, r = peak[k]
        row = named[k]
        per_run = [{**_run_keys(diag, q), "residual_arcsec": float(amp[q][k - 1]), "floors": float(floors[q][k - 1])}
                   for q in lay.te_runs]
        out.append({"order": k, "residual_arcsec": float(amp[r][k - 1]), "floors": fl, **_run_keys(diag, r),
                    "dependence": dependence(per_run),
                    "per_run": per_run,
                    "parts": row["parts"], "sidebands": row["sidebands"], "candidates": row["candidates"],
                    "lacking": row["lacking"], "note": row["note"]})
    return out


def repeatability(diag) -> list[dict]:
    """TE runs under the same conditions (direction, load, temperature, speed): how far the bench repeats itself.
    Per group of two or more such runs, the rms over orders 1 … K of each run's Fourier coefficients from the
    group's mean (arcsec; the origin and offset are common to all TE runs) and the largest order difference: the
    repeatability floor, below which no model difference is seen."""
    lay = diag.layout
    y = np.asarray(diag.measured, float)
    groups = {}
    for r in lay.te_runs:
        k = _run_keys(diag, r)
        groups.setdefault((k["direction"], k["load_Nm"], k["temperature_C"], k["speed_out_rpm"]), []).append(r)
    out = []
    for (d, load, t, v), runs in groups.items():
        if len(runs) < 2:
            continue
        c = np.array([np.r_[y[lay.cos[r]], y[lay.sin[r]]] for r in runs])
        dev = c - c.mean(axis=0)
        amp = np.hypot(dev[:, :lay.max_order], dev[:, lay.max_order:])
        worst = np.unravel_index(np.argmax(amp), amp.shape)
        out.append({"runs": runs, "direction": d, "load_Nm": load, "temperature_C": t, "speed_out_rpm": v,
                    "rms_arcsec": float(np.sqrt(np.mean(dev ** 2))), "largest_arcsec": float(amp[worst]),
                    "largest_order": int(worst[1]) + 1})
    return out


DEPENDENCE_RATIO = 1.5  # a residual order "grows with" a condition when it is this much larger at its top value


def dependence(per_run: list[dict]) -> dict:
    """How a residual order's amplitude depends on the runs' conditions: per condition (``load_Nm``,
    ``temperature_C``, ``speed_out_rpm``) that takes two or more values, the mean amplitude (arcsec) of the runs at
    its lowest and at its highest value and their ratio, and ``"grows"`` when the amplitude there is at least
    :data:`DEPENDENCE_RATIO` times larger and 2 floors above; a component that grows with speed is ``"dynamic"``:
    outside a quasi-static replay."""
    out = {}
    for cond in ("load_Nm", "temperature_C", "speed_out_rpm"):
        vals = sorted({p[cond] for p in per_run if p.get(cond) is not None})
        if len(vals) < 2:
            continue
        lo = [p for p in per_run if p.get(cond) == vals[0]]
        hi = [p for p in per_run if p.get(cond) == vals[-1]]
        a_lo = float(np.mean([p["residual_arcsec"] for p in lo]))
        a_hi = float(np.mean([p["residual_arcsec"] for p in hi]))
        f_lo = float(np.mean([p["floors"] for p in lo]))
        f_hi = float(np.mean([p["floors"] for p in hi]))
        grows = a_hi >= DEPENDENCE_RATIO * a_lo and f_hi - f_lo >= 2.0
        out[cond] = {"low": vals[0], "high": vals[-1], "residual_low_arcsec": a_lo, "residual_high_arcsec": a_hi,
                     "ratio": a_hi / a_lo if a_lo > 0 else math.inf, "grows": bool(grows)}
    if out.get("speed_out_rpm", {}).get("grows"):
        out["dynamic"] = True
    return out


def _dependence_text(dep: dict) -> str:
    words = {"load_Nm": "load", "temperature_C": "temperature", "speed_out_rpm": "speed"}
    parts = [f"grows with {words[k]} ×{v['ratio']:.1f}" for k, v in dep.items() if k in words and v["grows"]]
    if dep.get("dynamic"):
        parts.append("dynamic: outside the quasi-static replay")
    return "; ".join(parts) or "—"


def _parts_text(row: dict) -> str:
    """The parts of a residual order in words (harmonic m of a part as "m× …")."""
    parts = [(f"{p['harmonic']}× " if p["harmonic"] > 1 else "") + f"{p['part']} (vs {p['relative_to']})"
             for p in row["parts"]]
    return "; ".join(parts) or row["note"] or "—"


def _second_effect_withheld(wh: dict) -> dict:
    """A pair's withheld check against its better single as the JSON's ``second_effect_withheld`` ({} for a
    single effect)."""
    alone = wh.get("against_single")
    if alone is None:
        return {}
    return {"second_effect_withheld": {"against": alone["single"], "improvement_pct": alone["improvement_pct"],
                                       "evidence": alone.get("evidence"),
                                       "fold_evidence": [f.get("evidence") for f in alone["folds"]]}}


def json_document(diag) -> dict:
    """The JSON document of ``rvflex diagnose`` (keys of issue 6)."""
    before = gap_table(diag, diag.nominal_model or diag.baseline)
    chosen = diag.chosen
    keys = [(o["order"], o["run"]) for o in before["orders"]]
    calibrated = gap_table(diag, diag.baseline)
    calibrated["orders"] = _orders_of(diag, diag.baseline, keys)
    calibrated = _after_with_shrink(before, calibrated)
    if chosen is not None:
        after = gap_table(diag, chosen)
        after["orders"] = _orders_of(diag, chosen, keys)
        after = _after_with_shrink(before, after)
    else:
        after = calibrated
    effects = []
    for c in diag.candidates:
        effects.append({
            "name": c.name,
            "params": dict(zip(c.param_names, map(float, c.x))),
            "units": dict(zip(c.param_names, c.units)),
            "interval": {**{n: [float(a), float(b)] for n, (a, b) in zip(c.param_names, c.interval)},
                         **{f"{e.name}.magnitude": [float(a), float(b)]
                            for e, (a, b) in zip(c.effects, c.magnitude_interval)}},
            "magnitude": {e.name: float(m) for e, m in zip(c.effects, c.magnitude)},
            "score": float(c.score),
            "bic_score": float(c.bic_score),
            "accepted": bool(c.accepted),
            "gap_shrink_pct": float(c.gap_shrink_pct),
            "refined": bool(c.refined),
            "at_bound": list(c.at_bound),
            "withheld_improvement_pct": c.withheld.get("improvement_pct"),
            "withheld_evidence": c.withheld.get("evidence"),
            "withheld_fold_evidence": [f.get("evidence") for f in c.withheld.get("folds", ())],
            **_second_effect_withheld(c.withheld),
            "grade": c.grade.get("grade"), "grade_fails": list(c.grade.get("fails", [])),
            "explained_where_pct": c.grade.get("explained_where_pct"),
            "signature_groups": list(c.grade.get("signature_groups", [])),
            "own_evidence": c.grade.get("own_evidence") or {},
            "leftover": c.grade.get("leftover"),
            "off_period_evidence": c.grade.get("off_period_evidence"),
            "relative_evidence": c.grade.get("relative_evidence") or {},
            "null_relative_thresholds": c.grade.get("relative_thresholds") or {},
            "null_magnitude_thresholds": c.grade.get("magnitude_thresholds") or {},
            "own_off_period_evidence": c.grade.get("own_off_period_evidence") or {},
            "null_off_period_thresholds": c.grade.get("off_period_thresholds") or {},
            "off_period_beyond": list(c.grade.get("off_period_beyond", [])),
            "null_unit": c.grade.get("null_unit"),
        })
    ref = chosen or (diag.candidates[0] if diag.candidates else None)
    wh = dict(ref.withheld) if ref is not None else {}
    folds = wh.get("folds") or [{"fitted_runs": [part_label(diag.plan, p) for p in f],
                                 "predicted_runs": [part_label(diag.plan, p) for p in pr],
                                 "improvement_pct": None} for f, pr in diag.withheld_runs]
    withheld = {"fitted_runs": list(dict.fromkeys(x for f in folds for x in f["fitted_runs"])),
                "predicted_runs": [x for f in folds for x in f["predicted_runs"]],
                "improvement_pct": wh.get("improvement_pct"),
                "folds": [{k: f.get(k) for k in ("fitted_runs", "predicted_runs", "improvement_pct", "evidence")}
                          for f in folds],
                "evidence": wh.get("evidence"),
                "effect": ref.name if ref is not None else None}
    if not diag.withheld_runs:
        withheld["note"] = "no run usable for the withheld check"
    return {"where": where_list(diag), "effects": effects, "gap_before": before, "gap_after": after,
            "gap_calibrated": calibrated, "calibration": describe_calibration(diag.baseline, diag.undetermined, diag.anchor.scale),
            "anchor": diag.anchor.describe(),
            "discrepancy": diag.discrepancy.describe() if diag.discrepancy is not None else [],
            "calibration_lookalikes": [{"effect": k, "nominal_parameters": list(v[0]), "separating_runs": list(v[1]),
                                        "reproduced_pct": 100.0 * (1.0 - v[2]), "parameters": list(v[3]) or None}
                                       for k, v in diag.lookalikes.items()],
            "calibration_shrink_pct": float(diag.baseline.gap_shrink_pct),
            "calibration_withheld_improvement_pct": diag.baseline.withheld.get("improvement_pct"),
            "calibration_ties": list(diag.calibration_ties), "separating_runs": list(diag.separating_runs),
            "analysed_windows": [diag.windows[r] | {"run": r} for r in sorted(diag.windows)],
            "withheld_check": withheld, "verdict": diag.verdict, "wall_s": diag.wall_s,
            "origin_rad": float((chosen or diag.baseline).delta), "model_runs": diag.model_runs,
            "unavailable_effects": diag.unavailable, "failed_effects": diag.failed,
            "signature_size": diag.signature_size, "ties": list(diag.ties), "grade": verdict_grade(diag),
            "residual_orders": residual_orders(diag), "part_ties": list(diag.part_ties),
            "repeatability": repeatability(diag)}


def verdict_grade(diag) -> str:
    """The verdict's grade: "established" (an accepted finding), "consistent but not established" (a candidate
    passes the tests but is not established), or "unexplained model-form gap" (see :mod:`rvflex.diagnosis.grade`)."""
    from rvflex.diagnosis.grade import CONSISTENT, ESTABLISHED

    if diag.chosen is not None:
        return ESTABLISHED
    if any(c.grade.get("grade") == CONSISTENT for c in diag.candidates):
        return CONSISTENT
    return "unexplained model-form gap"


# ----------------------------------------------------------------------------- plots and Markdown

def write_report(diag, out: str | Path, doc: dict | None = None) -> list[Path]:
    """Write report.md with its plots (PNG) and diagnosis.json to ``out``; every file is
    computed first and written through a temporary name."""
    import json

    from rvflex.io import write_atomic

    out = Path(out)
    doc = doc or json_document(diag)
    tmpdir = out / f".report_{id(diag)}"
    tmpdir.mkdir(parents=True, exist_ok=True)
    try:
        pngs = draw_plots(diag, tmpdir)
        md = markdown(diag, doc, [p.name for p in pngs])
        final = []
        for p in pngs:
            p.replace(out / p.name)
            final.append(out / p.name)
    finally:
        for p in tmpdir.glob("*"):
            p.unlink()
        tmpdir.rmdir()
    write_atomic(out / "report.md", md.encode())
    write_atomic(out / "diagnosis.json", json.dumps(doc, indent=2, default=_json_default).encode())
    return [out / "report.md", out / "diagnosis.json", *final]


def _json_default(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    raise TypeError(type(o))


def markdown(diag, doc: dict, pngs: list[str]) -> str:
    """The Markdown report."""
    ds = diag.dataset
    lines = [f"# Sim-to-real gap diagnosis — {ds.reducer.name}", "",
             (f"Dataset `{ds.path}`: {len(ds.runs)} runs ({', '.join(r.label for r in ds.runs)}). Model: rigid, "
             f"quasi-static replay at {diag.settings.positions_per_rev} positions per output revolution, orders "
             f"1…{diag.settings.max_order}; {diag.model_runs} model runs (each run of the model under the plan; cached ones not counted) in {diag.wall_s:.0f} s."), "",
             f"**Verdict.** {diag.verdict}", "", "## Analysed data", "",
             "| run | form | samples (window / run) | revolutions | coverage | TE pp measured (″) | Fourier fit pp (″) | fit rms (″) |",
             "|---|---|---:|---:|---:|---:|---:|---:|"]
    for w in doc["analysed_windows"]:
        lines.append(f"| {diag.plan[w['run']].label} | {w['form']} | {w['samples']} / {w['samples_in_run']} | "
                     f"{w['revolutions']} | {w['coverage']:.3f} | {w['te_pp_measured_arcsec']:.2f} | "
                     f"{w['te_pp_fit_arcsec']:.2f} | {w['fit_rms_residual_arcsec']:.3f} |")
    lines += ["", "## Calibrated nominal parameters", "", f"**Anchor.** {diag.anchor.sentence()}", "",
              ("Uncertain nominal parameters of the model, fitted before any effect with a regulariser toward the "
               "nominal value (prior σ, around the anchored model); stiffnesses as compliance change u = 1/s − 1 and "
               "stiffness scale against the spec (anchor × component). "
               f"Calibration closes {doc['calibration_shrink_pct']:.0f} % of the nominal model's weighted gap."), "",
              "| parameter | value [95 %] | nominal | prior σ | stiffness scale [95 %] | at prior bound |",
              "|---|---|---:|---:|---|:---:|"]
    for c in doc["calibration"]:
        unit = c["unit"]
        f = (lambda v: f"{v * 1e6:.2f} µm") if unit == "m" else (lambda v: f"{v:.3f}")
        sc = (f"×{c['stiffness_scale']:.3f} [{c['stiffness_scale_interval'][0]:.2f} … "
              f"{c['stiffness_scale_interval'][1]:.2f}]") if "stiffness_scale" in c else "—"
        value = (f"{f(c['value'])} [{f(c['interval'][0])} … {f(c['interval'][1])}]" if c["determined"] else
                 "held at nominal: not determined by these runs")
        lines.append(f"| {c['name']}.{c['param']} | {value} | "
                     f"{f(c['nominal'])} | {f(c['prior_sigma'])} | {sc if c['determined'] else '—'} | "
                     f"{'yes' if c['at_prior_bound'] else ''} |")
    lines += ["", "## Where the gap lies (nominal model)", "",
             "| where | direction | load (N·m) | temperature (°C) | share of the weighted gap |",
             "|---|---|---:|---:|---:|"]
    for w in doc["where"][:15]:
        what = f"order {w['order']}" if "order" in w else w["metric"]
        temp = "—" if w.get("temperature_C") is None else f"{w['temperature_C']:g}"
        lines.append(f"| {what} | {w['direction']} | {w['load_Nm']:g} | {temp} | {100 * w['share']:.1f} % |")
    lines += ["", "## Effect ranking", "",
              ("Score = BIC(calibrated model) − BIC(candidate) (> 10: very strong evidence); each candidate is fitted "
               "together with the nominal parameters; gap shrink of what calibration left; 95 % intervals from the "
              "linearised covariance; *refined* candidates were re-fitted with the model in the loop."), "",
              "| rank | effect | magnitude [95 %] | score | gap shrink | withheld | explained where it lies | grade | note |",
              "|---:|---|---|---:|---:|---:|---:|---|---|"]
    for i, c in enumerate(diag.candidates[:12], start=1):
        mags = "; ".join(mag_text(e, m, lo, hi) for e, m, (lo, hi) in zip(c.effects, c.magnitude,
                                                                             c.magnitude_interval) if not e.nominal)
        wh = c.withheld.get("improvement_pct")
        note = ("bound hit: " + ", ".join(c.at_bound) + "; " if c.at_bound else "") + c.note
        ew = c.grade.get("explained_where_pct")
        lines.append(f"| {i} | {c.name} | {mags} | {c.score:.1f} | {c.gap_shrink_pct:.0f} % | "
                     f"{'n/a' if wh is None else f'{wh:+.0f} %'} | {'—' if ew is None else f'{ew:.0f} %'} | "
                     f"{('**accepted**, ' if c.accepted else '') + c.grade.get('grade', '')} | {note} |")
    weak = sorted(k for k, v in diag.signature_size.items() if v < 3.0)
    if weak:
        lines += ["", "Not observable with these runs (model signature at typical size below 3 residual floors): "
                  + ", ".join(weak) + "."]
    if diag.unavailable:
        lines += ["", "Not evaluated (unavailable): " + "; ".join(f"{k} — {v}" for k, v in diag.unavailable.items())]
    if diag.failed:
        lines += ["", "Failed model evaluations (treated as failed candidates): "
                  + "; ".join(f"{k} — {v[:160]}" for k, v in diag.failed.items())]
    wc = doc["withheld_check"]
    imp = "n/a" if wc["improvement_pct"] is None else f"{wc['improvement_pct']:.0f} %"
    lines += ["", "## Withheld check", ""]
    if wc.get("note"):
        lines.append(f"{wc['note'].capitalize()}.")
    for k, f in enumerate(wc["folds"], start=1):
        fi = "n/a" if f["improvement_pct"] is None else f"{f['improvement_pct']:+.0f} %"
        ev = "" if f.get("evidence") is None else f", evidence {f['evidence']:.1f}"
        lines.append(f"- Fold {k}: fitted on {', '.join(f['fitted_runs'])}; predicted {', '.join(f['predicted_runs'])}: "
                     f"improvement {fi}{ev}.")
    lines += ["", (f"Improvement of the prediction of every withheld run ({wc['effect'] or '—'}, pooled over the "
                   f"folds): {imp}."), "",
              "## Gap before and after", "",
              "| run | metric | measured | model | gap before | gap after | shrink |", "|---|---|---:|---:|---:|---:|---:|"]
    for b, a in zip(doc["gap_before"]["metrics"], doc["gap_after"]["metrics"]):
        run = _run_text(b)
        sp = a.get("shrink_pct")
        lines.append(f"| {run} | {b['metric']} ({b['unit']}) | {b['measured']:.3f} | {b['model']:.3f} | "
                     f"{b['gap']:+.3f} | {a['gap']:+.3f} | {'—' if sp is None else f'{sp:.0f} %'} |")
    lines += ["", "| run | order | residual before (″) | after (″) | shrink |", "|---|---:|---:|---:|---:|"]
    for b, a in zip(doc["gap_before"]["orders"], doc["gap_after"]["orders"]):
        sp = a.get("shrink_pct")
        lines.append(f"| {_run_text(b)} | {b['order']} | {b['residual_arcsec']:.3f} | "
                     f"{a['residual_arcsec']:.3f} | {'—' if sp is None else f'{sp:.0f} %'} |")
    lines += ["", "## Residual orders and the parts that turn at them", "",
              (f"Orders whose residual reaches {RESIDUAL_ORDER_FLOORS:g} floors in a TE run "
               f"({'after ' + diag.chosen.name if diag.chosen else 'after calibration'}), largest first, named by the "
               "unit's kinematics: the parts that turn at the order (harmonic × part, relative to what), the candidate "
               "effects acting there and the part errors at that order no candidate models."), ""]
    if doc["residual_orders"]:
        lines += ["| order | residual (″) | floors | run | residual per TE run (″) | conditions | parts that turn at it | "
                  "candidates | lacking |", "|---:|---:|---:|---|---|---|---|---|---|"]
        for o in doc["residual_orders"]:
            per = ", ".join(f"{p['residual_arcsec']:.2f}" for p in o["per_run"])
            lines.append(f"| {o['order']} | {o['residual_arcsec']:.2f} | {o['floors']:.1f} | {_run_text(o)} | {per} | "
                         f"{_dependence_text(o['dependence'])} | {_parts_text(o)} | {', '.join(o['candidates']) or '—'} | {'; '.join(o['lacking']) or '—'} |")
    else:
        lines.append("No residual order reaches that.")
    for g in doc["repeatability"]:
        lines += ["", (f"Repeatability floor: runs {', '.join(str(r) for r in g['runs'])} ({g['direction']} "
                       f"{g['load_Nm']:g} N·m, same temperature and speed) differ by {g['rms_arcsec']:.3f}″ rms over "
                       f"the orders, most at order {g['largest_order']} ({g['largest_arcsec']:.3f}″): the bench repeats "
                       "itself no better than that.")]
    lines += ["", (f"Weighted rms gap: {doc['gap_before']['weighted_rms']:.3f} before (nominal model), "
              f"{doc['gap_calibrated']['weighted_rms']:.3f} calibrated, "
              f"{doc['gap_after']['weighted_rms']:.3f} after ({doc['gap_after']['weighted_rms_shrink_pct']:.0f} % "
              "shrink)."), "", "## Plots", ""]
    for p in pngs:
        lines.append(f"![{p}]({p})")
        lines.append("")
    return "\n".join(lines)

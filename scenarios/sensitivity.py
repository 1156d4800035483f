"""Seed 002's backlash sensitivity table recomputed with the model.

For each error of seed 002's table the matching spec or :class:`~rvflex.spec.ErrorSpec` field
is perturbed by ±h (a few µm) from the catalogue RV-40E and the model's zero-load backlash is
measured as seed 002's locked-input test defines it: input locked, output torque stepped to
+T and −T with T = ``load_fraction``·T_r (default 0.01 %, 0.04 N·m, where the elastic turn is
< 0.5 % of the free play); backlash = θ_out(+T) − θ_out(−T). The sensitivity is the central
difference (b(+h) − b(−h))/2h in arcmin/µm; the one-sided slopes (b(+h) − b(0))/h and
(b(0) − b(−h))/h show whether the response is linear. A clearance cannot be negative: its
slopes are one-sided from zero, (b(h) − b(0))/h and (b(2h) − b(h))/h.

Beside the model: seed 002's printed value and the partial derivative of its ε formula
(:func:`rvflex.geometry.formulas.backlash_formula_arcmin`) where the error maps onto one of
ε's terms, and the same derivative times the kinematic coupling ``k·z_c/i`` (k = z2/z1) that
ε leaves out: with the input locked, turning the output turns the cranks too (they roll on the
locked sun), so a free play u of the disc–pin mesh, measured as a disc turn at lever e·z_c,
frees the output by only u·k·z_c/i (0.967 on the RV-40E) — see :func:`kinematic_coupling`.

    python -m rvflex.scenarios.sensitivity out/sensitivity

What it finds on the RV-40E (h = 2 µm, nominal zero-load backlash 1.811′; ε gives 1.874′,
1.817′ with the coupling):

- Every error that maps onto a term of ε agrees with ∂ε × k·z_c/i: equidistant modification
  and pin radius within 0.3 %, centre distance exactly, crank-support clearance 0.5 %,
  alternating pin position 2.5 %, pin-circle radius and moved modification 2 % (their
  one-sided slopes differ by 3 %: the first-contact pin moves with them), eccentric-bearing
  clearance 4 %. ε itself needs two corrections: the coupling (without it ε is 3.4 % high
  on the cycloid stage) and a radial clearance c counting as a play 2c (Δφ3 = 2c).
- Errors that add no uniform gap — base pitch error alike on both planets (none at all: it
  turns the locked position), sun runout, disc runout and pitch error, alternating pin
  position, crank eccentricity — are even in h: either sign makes one tooth or pin touch
  earlier and takes backlash away, so their central difference is zero and the table gives
  the one-sided magnitude. The eccentricity error, zero in ε to first order (it moves the disc
  normal to the first-contact line of action), takes 0.046′/µm through the discrete pins.
- Seed 002's column is in arcmin per mm, not per µm: its Δ3 = 95.49 is (180·60/π)/36 mm (a0 =
  36 mm, Δφ3 = c) and its Δr_rp = 135.61 is 2·(180·60/π)/(1.3 mm·39) (e = 1.3 mm, not
  1.25). Divided by 1000 it matches the model within 1 % for the pin radius and equidistant
  modification and within 7 % for the pin position; it is half the model for the pin-circle
  radius / moved modification and for Δ3 (radial clearance counted once), ≈ 0 where the model
  has 0.046′/µm for the eccentricity, and its F_p, F_rc, Δ_hole are halvings of other rows.
  Rankings agree on the split: first stage ≈ 1/100 of the cycloid stage and bearings. The
  pin-hole clearance Δ_hole has no ErrorSpec field (pins sit in exact holes): not modelled.
"""

from __future__ import annotations

import dataclasses as dc
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rvflex.model import build_reducer
from rvflex.parallel import map_warm
from rvflex.solve import SolveError, torque_stepping
from rvflex.spec import ErrorSpec, ReducerSpec
from rvflex.units import ARCMIN_PER_RAD, UM

__all__ = ["ERRORS", "PAPER", "SensitivityRow", "backlash_arcmin", "formula_sensitivity", "kinematic_coupling",
           "markdown_table", "nominal_backlash", "perturb", "run_sensitivity", "write_sensitivity_outputs"]


PAPER = {  # seed 002's table as printed ("arc-min/µm"; read as relative weights, tables.md)
    "E_bp": 1.12, "E_a": 0.77, "F_r": 0.77, "dr_p": 46.09, "dr_rp": 135.61, "hole": 67.81, "F_rc": 33.90,
    "t_pos": 110.18, "F_p": 55.09, "da": 1.65, "d3": 95.49, "d3_eccentric": 95.49, "mod_equidistant": 135.61,
    "mod_moved": 46.09,
}

ERRORS = {
    # key: (seed 002 name, our field and the perturbation pattern, is a clearance)
    "E_bp": ("planet base pitch error E_bp", "ErrorSpec.planet_base_pitch_error_m = h on every planet", False),
    "E_a": ("centre distance error E_a", "ReducerSpec.cranks.crank_circle_radius_m + h (sun–planet distance)", False),
    "F_r": ("gear runout F_r", "ErrorSpec.sun_runout_m = h (radius of the sun's runout, phase 0)", False),
    "dr_p": ("pin centre-circle radius error Δr_p", "ErrorSpec.pin_circle_radius_error_m = h", False),
    "dr_rp": ("pin radius error Δr_rp", "ErrorSpec.pin_radius_error_m = h", False),
    "hole": ("pin-hole clearance Δ_hole", "none: the model's pins sit in exact holes", False),
    "F_rc": ("cycloid gear runout F_rc", "ErrorSpec.disc_profile_error_m = (h/2)·cos(2πk/z_c) on both discs", False),
    "t_pos": ("pin-hole position error t_pos", "ErrorSpec.pin_tangential_m = ±h alternating pin by pin", False),
    "F_p": ("cycloid pitch error F_p", "ErrorSpec.disc_pitch_error_m = (h/2)·sin(2πk/z_c) on both discs", False),
    "da": ("eccentricity error Δa", "ErrorSpec.crank_eccentricity_error_m = h on both cranks", False),
    "d3": ("crank bearing clearance Δ3", "ErrorSpec.crank_support_clearance_m = h on both cranks", True),
    "d3_eccentric": ("crank bearing clearance Δ3 (eccentric needle bearings)",
                     "ErrorSpec.eccentric_bearing_clearance_m = h on every eccentric", True),
    "mod_equidistant": ("equidistant modification Δr_rp", "ReducerSpec.cycloid.modification.equidistant_m + h", False),
    "mod_moved": ("moved modification Δr_p", "ReducerSpec.cycloid.modification.moved_m + h", False),
}
"""The errors of seed 002's table and how each is applied to the model."""


def perturb(spec: ReducerSpec, key: str, h: float) -> tuple[ReducerSpec, ErrorSpec]:
    """The catalogue ``spec`` with error ``key`` of :data:`ERRORS` set to ``h`` (m); no other errors."""
    c, e = spec.cycloid, ErrorSpec()
    nc, nd, zb, zc = spec.cranks.count, c.disc_count, c.pin_count, c.disc_teeth
    k = np.arange(zc)
    if key == "E_bp":
        return spec, dc.replace(e, planet_base_pitch_error_m=(h,) * nc)
    if key == "E_a":
        return dc.replace(spec, cranks=dc.replace(spec.cranks,
                                                  crank_circle_radius_m=spec.cranks.crank_circle_radius_m + h)), e
    if key == "F_r":
        return spec, dc.replace(e, sun_runout_m=h)
    if key == "dr_p":
        return spec, dc.replace(e, pin_circle_radius_error_m=h)
    if key == "dr_rp":
        return spec, dc.replace(e, pin_radius_error_m=h)
    if key == "F_rc":
        row = tuple(float(x) for x in 0.5 * h * np.cos(2 * np.pi * k / zc))
        return spec, dc.replace(e, disc_profile_error_m=(row,) * nd)
    if key == "t_pos":
        return spec, dc.replace(e, pin_tangential_m=tuple(h if j % 2 == 0 else -h for j in range(zb)))
    if key == "F_p":
        row = tuple(float(x) for x in 0.5 * h * np.sin(2 * np.pi * k / zc))
        return spec, dc.replace(e, disc_pitch_error_m=(row,) * nd)
    if key == "da":
        return spec, dc.replace(e, crank_eccentricity_error_m=(h,) * nc)
    if key == "d3":
        return spec, dc.replace(e, crank_support_clearance_m=(h,) * nc)
    if key == "d3_eccentric":
        return spec, dc.replace(e, eccentric_bearing_clearance_m=(h,) * (nc * nd))
    if key in ("mod_equidistant", "mod_moved"):
        field = "equidistant_m" if key == "mod_equidistant" else "moved_m"
        m = dc.replace(c.modification, **{field: getattr(c.modification, field) + h})
        return dc.replace(spec, cycloid=dc.replace(c, modification=m)), e
    raise KeyError(f"{key!r} has no perturbation; modelled errors: {', '.join(k_ for k_ in ERRORS if k_ != 'hole')}")


def backlash_arcmin(spec: ReducerSpec, errors: ErrorSpec, load_fraction: float = 1e-4) -> float:
    """Zero-load backlash (arcmin): input locked, output torque 0 → +T → 0 → −T with
    T = ``load_fraction``·T_r, backlash θ_out(+T) − θ_out(−T) (seed 002's locked-input test
    taken to a vanishing load; rigid bodies, Hertz line contacts)."""
    t = load_fraction * spec.rated_torque_Nm
    res = torque_stepping(build_reducer(spec, errors), np.array([0.0, t, 0.0, -t]))
    return float(res.theta_out[1] - res.theta_out[3]) * ARCMIN_PER_RAD


def kinematic_coupling(spec: ReducerSpec) -> float:
    """Output free play per unit of disc–pin free play with the input locked, k·z_c/i (–).

    Angles: sun θ_s, output (carrier) α, crank θ_p (absolute), k = z2/z1. The first stage is
    free of strain while w = θ_s − α + k·(θ_p − α) = 0 (external mesh, relative to the
    carrier); the disc–pin mesh while u = α + θ_p/z_c = 0 (the disc turns with the carrier,
    the eccentric with the crank). With θ_s = 0 locked, eliminating θ_p gives
    α = (k·z_c·u − w)/i, i = 1 + k·(z_c + 1): a free play u of the disc–pin mesh (as a disc
    turn at lever e·z_c, ε's Δφ2/(e·z_c) and Δφ4/(e·z_c)) frees the output by k·z_c/i·u, not
    u, because the cranks roll on the locked sun while the output turns; the first stage's
    play w (a sun turn) frees it by w/i, as ε has it.
    """
    s = spec.input_stage
    return s.planet_teeth / s.sun_teeth * spec.cycloid.disc_teeth / spec.ratio


def formula_sensitivity(spec: ReducerSpec, key: str) -> float:
    """∂ε/∂h (arcmin/µm) of seed 002's ε for error ``key``, NaN where ε has no term for it.

    Cycloid stage (lever e·z_c): the modification play Δφ4 = 2·(Δr_rp − Δr_p·√(1 − K1²))
    (:func:`~rvflex.geometry.formulas.modification_free_play`); a pin radius error +h closes
    both flanks like an equidistant modification −h, a pin-circle radius error +h opens them
    like a moved modification −h; the eccentricity error moves the disc along the eccentric,
    normal to the first-contact pins' line of action (cos φ = K1) to first order: 0. A
    tangential shift t of a first-contact pin closes its flank by t·e·z_c/r_p, i.e. t/r_p of
    output turn; the alternating ±h pattern puts a pin shifted toward its flank in each
    flank's first contact, whichever the sign: the backlash falls by 2|h|/r_p. First stage:
    circumferential play Δφ1 through the sun (lever i·r1): a centre distance change h opens it
    by 2h·tan α; a sun runout (radius) h by up to 2h·tan α at the worst phase; a base pitch
    error f_pb by f_pb/cos α at most. Crank
    bearings: Δφ3/a0 with a0 the crank-circle radius and Δφ3 the whole play, 2c for a radial
    clearance c (the bearing can shift ±c: the factor 2 of Δφ4 too).
    """
    c, st = spec.cycloid, spec.input_stage
    ez = c.eccentricity_m * c.disc_teeth
    root = math.sqrt(1.0 - c.k1 ** 2)
    first = 1.0 / (spec.ratio * st.module_m * st.sun_teeth / 2.0)
    alpha = st.pressure_angle_rad
    per_m = {
        "mod_equidistant": 2.0 / ez, "mod_moved": -2.0 * root / ez, "dr_rp": -2.0 / ez, "dr_p": 2.0 * root / ez,
        "da": 0.0, "t_pos": 2.0 / c.pin_circle_radius_m,
        "E_a": 2.0 * math.tan(alpha) * first, "F_r": 2.0 * math.tan(alpha) * first, "E_bp": first / math.cos(alpha),
        "d3": 2.0 / spec.cranks.crank_circle_radius_m, "d3_eccentric": 2.0 / spec.cranks.crank_circle_radius_m,
    }
    return per_m.get(key, math.nan) * ARCMIN_PER_RAD * UM


@dataclass(frozen=True)
class SensitivityRow:
    """One error: the model's slopes (arcmin/µm), the paper's value and the formula's derivative."""

    key: str
    name: str
    field: str
    h_m: float
    backlash_arcmin: tuple[float, float, float]  # b(−h), b(0), b(+h); clearances b(0), b(h), b(2h)
    central: float  # central difference (clearances: the first one-sided slope)
    slope_minus: float  # (b(0) − b(−h))/h; clearances (b(h) − b(0))/h
    slope_plus: float  # (b(h) − b(0))/h; clearances (b(2h) − b(h))/h
    paper: float
    formula: float
    formula_coupled: float
    note: str = ""

    @property
    def linear(self) -> bool:
        """Both one-sided slopes agree within 10 % of the larger (or both below 1e-4 arcmin/µm)."""
        a, b = self.slope_minus, self.slope_plus
        return bool(max(abs(a), abs(b)) < 1e-4 or abs(a - b) <= 0.1 * max(abs(a), abs(b)))


def _evaluate(args: tuple[ReducerSpec, str, float, float]) -> float:
    spec, key, h, load_fraction = args
    try:
        return backlash_arcmin(*perturb(spec, key, h), load_fraction)
    except SolveError:  # recorded as NaN (a stalled Newton is a solver bug being fixed, not a result)
        return math.nan


def run_sensitivity(spec: ReducerSpec, *, h_m: float = 2 * UM, keys: tuple[str, ...] | None = None,
                    load_fraction: float = 1e-4, workers: int = 1) -> list[SensitivityRow]:
    """Perturb each error of ``keys`` (default: all of :data:`ERRORS`) by ±``h_m`` and return
    one row per error, in :data:`ERRORS` order. ``workers`` > 1 evaluates in a process pool
    (same numbers: every evaluation builds its own model)."""
    keys = tuple(ERRORS) if keys is None else keys
    modelled = [k for k in keys if k != "hole"]
    jobs = [(spec, "mod_equidistant", 0.0, load_fraction)]  # the nominal: every error at zero
    for k in modelled:
        steps = (h_m, 2 * h_m) if ERRORS[k][2] else (-h_m, h_m)
        jobs += [(spec, k, s, load_fraction) for s in steps]
    # workers fork from this process, warm: the model, solver and Exudyn are imported above
    outcomes = map_warm(_evaluate, jobs, workers if workers > 1 else 0)
    for out in outcomes:
        if out.died:
            raise RuntimeError(f"sensitivity job {jobs[out.index][1:3]}: its worker process died")
        if out.error is not None:
            raise out.error
    values = [out.value for out in outcomes]
    b0, it = values[0], iter(values[1:])
    coupling = kinematic_coupling(spec)
    rows = []
    for k in keys:
        name, field, clearance = ERRORS[k]
        f = formula_sensitivity(spec, k)
        cycloid_stage = k in ("mod_equidistant", "mod_moved", "dr_rp", "dr_p", "da", "t_pos", "d3", "d3_eccentric")
        fc = f * coupling if cycloid_stage else f
        if k == "hole":
            rows.append(SensitivityRow(k, name, field, h_m, (math.nan,) * 3, math.nan, math.nan, math.nan,
                                       PAPER[k], f, fc, "not modelled"))  # linear is vacuous here
            continue
        lo, hi = next(it), next(it)
        s = h_m / UM
        if clearance:
            trip = (b0, lo, hi)
            sm, sp = (lo - b0) / s, (hi - lo) / s
            central = sm
        else:
            trip = (lo, b0, hi)
            sm, sp = (b0 - lo) / s, (hi - b0) / s
            central = (hi - lo) / (2 * s)
        even = (not clearance and sm * sp < 0 and max(abs(sm), abs(sp)) >= 1e-4
                and abs(sm + sp) < 0.1 * max(abs(sm), abs(sp)))
        note = f"even in h: backlash falls by {abs(sm):.4f} arcmin/µm whichever the sign" if even else ""
        rows.append(SensitivityRow(k, name, field, h_m, trip, central, sm, sp, PAPER[k], f, fc, note))
    return rows


def nominal_backlash(rows: list[SensitivityRow]) -> float:
    """The unperturbed model's zero-load backlash (arcmin) recorded in ``rows``."""
    for r in rows:
        if r.note != "not modelled":
            return r.backlash_arcmin[0 if ERRORS[r.key][2] else 1]
    return math.nan


def _fmt(x: float, digits: int = 4) -> str:
    return "—" if not math.isfinite(x) else f"{x:.{digits}f}"


def markdown_table(rows: list[SensitivityRow], b0: float) -> str:
    """The rows as a Markdown table (arcmin/µm)."""
    lines = [(f"Zero-load backlash of the nominal RV-40E: {b0:.4f}′ (model). Sensitivities in arcmin/µm; "
              "the paper's column as printed and divided by 1000 (its values read as arcmin/mm)."), "",
             ("| error | model central | model −h / +h slopes | linear | ε formula | ε × coupling | paper | "
              "paper ÷ 1000 | perturbation | note |"), "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r.name} | {_fmt(r.central)} | {_fmt(r.slope_minus)} / {_fmt(r.slope_plus)} | "
                     f"{'—' if r.note == 'not modelled' else ('yes' if r.linear else 'no')} | {_fmt(r.formula)} | "
                     f"{_fmt(r.formula_coupled)} | {r.paper:g} | {r.paper / 1000:.4f} | {r.field} | {r.note} |")
    return "\n".join(lines) + "\n"


def write_sensitivity_outputs(out: Path, rows: list[SensitivityRow]) -> list[Path]:
    """Write sensitivity.csv, sensitivity.md and sensitivity.png (model and formula in arcmin/µm
    on the left; every column normalised to its own equidistant-modification value on the right,
    which is how the paper's column can be compared)."""
    import csv

    from matplotlib.figure import Figure

    out.mkdir(parents=True, exist_ok=True)
    b0 = nominal_backlash(rows)
    path_csv = out / "sensitivity.csv"
    with open(path_csv, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["key", "error", "field", "h_m", "b_first_arcmin", "b_mid_arcmin", "b_last_arcmin",
                    "model_central_arcmin_per_um", "slope_minus", "slope_plus", "linear", "formula_arcmin_per_um",
                    "formula_coupled_arcmin_per_um", "paper_as_printed", "note"])
        for r in rows:
            w.writerow([r.key, r.name, r.field, r.h_m, *r.backlash_arcmin, r.central, r.slope_minus, r.slope_plus,
                        r.linear if r.note != "not modelled" else "", r.formula, r.formula_coupled, r.paper, r.note])
    path_md = out / "sensitivity.md"
    path_md.write_text(markdown_table(rows, b0), encoding="utf-8")

    def mag(r: SensitivityRow) -> float:  # an even response has no central slope: its one-sided magnitude
        return max(abs(r.slope_minus), abs(r.slope_plus)) if r.note.startswith("even") else abs(r.central)

    ref = {r.key: r for r in rows}.get("mod_equidistant")
    names = [r.name.replace(" (eccentric needle bearings)", " (eccentric)") for r in rows]
    y = np.arange(len(rows))[::-1]
    fig = Figure(figsize=(14, 0.42 * len(rows) + 2), layout="constrained")
    a1, a2 = fig.subplots(1, 2, sharey=True)
    modelled = [r.note != "not modelled" for r in rows]
    a1.barh(y + 0.27, [mag(r) if m else 0 for r, m in zip(rows, modelled)], 0.27, label="model |slope|")
    a1.barh(y, [abs(r.formula_coupled) if math.isfinite(r.formula_coupled) else 0 for r in rows], 0.27,
            label="ε formula × coupling")
    a1.barh(y - 0.27, [r.paper / 1000 for r in rows], 0.27, label="seed 002 ÷ 1000 (read as arcmin/mm)")
    a1.set_xscale("symlog", linthresh=1e-3)
    a1.set_xlabel("backlash sensitivity (arcmin/µm)")
    a1.set_yticks(y, names, fontsize=8)
    a1.legend(fontsize=8)
    a1.grid(alpha=0.3, axis="x")
    if ref is not None:
        a2.barh(y + 0.27, [mag(r) / abs(ref.central) if m else 0 for r, m in zip(rows, modelled)], 0.27,
                label="model")
        a2.barh(y, [abs(r.formula_coupled) / abs(ref.formula_coupled) if math.isfinite(r.formula_coupled) else 0
                    for r in rows], 0.27, label="ε formula")
        a2.barh(y - 0.27, [r.paper / ref.paper for r in rows], 0.27, label="seed 002 (as printed)")
        a2.set_xlabel("relative to the equidistant modification")
        a2.legend(fontsize=8)
        a2.grid(alpha=0.3, axis="x")
    fig.suptitle(f"Backlash sensitivity per error, RV-40E (zero-load backlash {b0:.3f}′, h = "
                 f"{rows[0].h_m / UM:g} µm)")
    path_png = out / "sensitivity.png"
    fig.savefig(path_png, dpi=110)
    return [path_csv, path_md, path_png]


if __name__ == "__main__":
    import sys
    import time

    from rvflex import catalog

    t0 = time.perf_counter()
    spec = catalog.load("rv40e")
    result = run_sensitivity(spec, workers=2)
    out_dir = Path(sys.argv[1] if len(sys.argv) > 1 else "out/sensitivity")
    paths = write_sensitivity_outputs(out_dir, result)
    print(markdown_table(result, nominal_backlash(result)))
    print(f"kinematic coupling k·z_c/i = {kinematic_coupling(spec):.4f}; {time.perf_counter() - t0:.0f} s")
    print("wrote " + ", ".join(map(str, paths)))

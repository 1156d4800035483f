"""The `rvflex geometry` report: ratio, K1, clearances, pressure angle, backlash formula,
closest-point accuracy and speed, and the profile figure."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rvflex.geometry import formulas as F
from rvflex.geometry.clearance import Clearance, initial_clearance_numeric
from rvflex.geometry.pins import nominal_disc_pose, pin_centres, pin_radii, to_disc_frame
from rvflex.geometry.profile import CycloidProfile, build_profile
from rvflex.spec_types import ErrorSpec, ReducerSpec

__all__ = ["GeometryReport", "geometry_report", "working_zone", "plot_profile", "ACCURACY_ECCENTRIC_ANGLE_RAD"]

WORKING_ZONE_LEVER_FRACTION = 0.5
ACCURACY_ECCENTRIC_ANGLE_RAD = 0.3  # a generic crank position (no pin on a symmetry line)
TIMING_REPEATS = 2000


@dataclass(frozen=True)
class GeometryReport:
    """Numbers printed by ``rvflex geometry`` (see :meth:`as_json` for the JSON keys)."""

    name: str
    ratio: float
    catalogue_ratio: float
    k1: float
    zc: int
    zb: int
    modification_kinds: tuple[str, ...]
    min_initial_clearance_um: float
    max_pressure_angle_deg: float
    working_zone_deg: tuple[float, float]
    backlash_terms_arcmin: dict[str, float]
    free_play_numeric_arcmin: float
    gap_max_error_m: float
    gap_eval_us_80_pins: float
    gap_eval_us_80_pins_warm: float

    def as_json(self) -> dict:
        """The JSON document of ``rvflex geometry --json`` (keys are a stable interface)."""
        return {
            "reducer": self.name,
            "ratio": self.ratio,
            "catalogue_ratio": self.catalogue_ratio,
            "K1": self.k1,
            "zc": self.zc,
            "zb": self.zb,
            "modification_kinds": list(self.modification_kinds),
            "min_initial_clearance_um": self.min_initial_clearance_um,
            "max_pressure_angle_deg": self.max_pressure_angle_deg,
            "working_zone_deg": list(self.working_zone_deg),
            "backlash_formula_arcmin": self.backlash_terms_arcmin["total"],
            "backlash_formula_terms_arcmin": self.backlash_terms_arcmin,
            "free_play_numeric_arcmin": self.free_play_numeric_arcmin,
            "gap_max_error_m": self.gap_max_error_m,
            "gap_eval_us_80_pins": self.gap_eval_us_80_pins,
            "gap_eval_us_80_pins_warm": self.gap_eval_us_80_pins_warm,
        }

    def text(self) -> str:
        """Human-readable summary."""
        b = self.backlash_terms_arcmin
        kinds = ", ".join(self.modification_kinds) or "none"
        return "\n".join([
            f"reducer                     {self.name}",
            f"ratio                       {self.ratio:g} (catalogue {self.catalogue_ratio:g})",
            f"K1 = e·zb/r_p               {self.k1:.6f}",
            f"teeth zc / zb               {self.zc} / {self.zb}",
            f"modification                {kinds}",
            f"min initial clearance       {self.min_initial_clearance_um:.3f} µm (nominal pose, all pins"
            + ("; negative: the profile overlaps a pin, a preloaded mesh)" if self.min_initial_clearance_um < 0 else ")"),
            f"max pressure angle          {self.max_pressure_angle_deg:.2f}° over the working zone "
            f"φ = {self.working_zone_deg[0]:.1f}°…{self.working_zone_deg[1]:.1f}°",
            f"backlash formula (seed 002) {b['total']:.4f}′ = first stage {b['first_stage']:.4f}′ + crank bearings "
            f"{b['crank_bearings']:.4f}′ + modification {b['modification']:.4f}′",
            f"free play, exact geometry   {self.free_play_numeric_arcmin:.4f}′ (modification only, disc 1)",
            f"closest-point accuracy      {self.gap_max_error_m:.2e} m max |Newton − brute force| over 80 pins",
            f"closest-point speed         {self.gap_eval_us_80_pins:.1f} µs per call for 80 pins "
            f"(cold start), {self.gap_eval_us_80_pins_warm:.1f} µs warm-started from the previous step",
        ])


def working_zone(spec: ReducerSpec) -> tuple[float, float]:
    """Pin angles φ (rad) where the lever arm is at least half its maximum: the flank that
    carries load (sinφ/S ≥ 0.5; seed 000's load-sharing law)."""
    k1 = spec.cycloid.k1
    phi = np.linspace(1e-6, np.pi - 1e-6, 200001)
    share = np.sin(phi) / np.sqrt(1 + k1 * k1 - 2 * k1 * np.cos(phi))
    inside = phi[share >= WORKING_ZONE_LEVER_FRACTION]
    return float(inside[0]), float(inside[-1])


def _accuracy_case(spec: ReducerSpec, errors: ErrorSpec | None) -> tuple[list[CycloidProfile], list[np.ndarray], np.ndarray]:
    c = spec.cycloid
    pins, radii = pin_centres(c, errors), pin_radii(c, errors)
    profiles = [build_profile(c, errors, k) for k in range(c.disc_count)]
    centres = [to_disc_frame(pins, *nominal_disc_pose(c, ACCURACY_ECCENTRIC_ANGLE_RAD, k)) for k in range(c.disc_count)]
    return profiles, centres, radii


def geometry_report(spec: ReducerSpec, errors: ErrorSpec | None = None, *, brute_samples: int = 1 << 22) -> GeometryReport:
    """Compute the geometry report of ``spec`` (optionally with ``errors``)."""
    c = spec.cycloid
    profiles, centres, radii = _accuracy_case(spec, errors)
    # accuracy: every pin of every disc (80 for the RV-40E) against a dense brute force
    err = 0.0
    for prof, x in zip(profiles, centres):
        err = max(err, float(np.abs(prof.gap(x, radii).gap_m - prof.brute_force_gap(x, radii, brute_samples)).max()))
    # speed: one call evaluating 80 pins (two discs' worth for a 40-pin ring)
    x80 = np.concatenate(centres)[:80] if sum(len(x) for x in centres) >= 80 else np.resize(np.concatenate(centres), (80, 2))
    r80 = np.resize(radii, 80)
    prof = profiles[0]
    t_prev = prof.gap(x80, r80).t  # also the JIT warm-up
    # the next quasi-static step: eccentric 0.01° further on
    x80_next = to_disc_frame(x80, np.zeros(2), 1e-4 / c.disc_teeth)
    us = _best_us(lambda: prof.gap(x80, r80))
    us_warm = _best_us(lambda: prof.gap(x80_next, r80, t_prev))
    # clearance and free play from the exact geometry
    cl = initial_clearance_numeric(c, errors, 0, profile=profiles[0], allow_interference=True)
    zone = working_zone(spec)
    u = np.linspace(zone[0], zone[1], 2001)
    alpha = profiles[0].pressure_angle(u / c.disc_teeth)
    return GeometryReport(
        name=spec.name,
        ratio=spec.nominal_ratio,
        catalogue_ratio=spec.ratio,
        k1=c.k1,
        zc=c.disc_teeth,
        zb=c.pin_count,
        modification_kinds=c.modification.kinds,
        min_initial_clearance_um=float(cl.nominal_gap_m.min() * 1e6),
        max_pressure_angle_deg=float(np.degrees(alpha.max())),
        working_zone_deg=(math.degrees(zone[0]), math.degrees(zone[1])),
        backlash_terms_arcmin=F.reducer_backlash_arcmin(spec),
        free_play_numeric_arcmin=cl.free_play_rad * F.ARCMIN_PER_RAD,
        gap_max_error_m=err,
        gap_eval_us_80_pins=us,
        gap_eval_us_80_pins_warm=us_warm,
    )


def _best_us(call) -> float:
    """Best of five batches of TIMING_REPEATS/5 calls, in µs per call."""
    best = math.inf
    for _ in range(5):
        t0 = time.perf_counter()
        for _ in range(TIMING_REPEATS // 5):
            call()
        best = min(best, (time.perf_counter() - t0) / (TIMING_REPEATS // 5))
    return 1e6 * best


def plot_profile(spec: ReducerSpec, path: str | Path, errors: ErrorSpec | None = None,
                 exaggeration: float | None = None) -> Path:
    """Write the profile figure: theoretical vs modified disc with the clearance exaggerated,
    a close-up of the teeth around the root, and the clearance along the flank.

    Returns the path of the PNG written.
    """
    from matplotlib.figure import Figure

    c = spec.cycloid
    theo = build_profile(c, modified=False)
    mod = build_profile(c, errors, 0)
    cl: Clearance = initial_clearance_numeric(c, errors, 0, profile=mod, allow_interference=True)
    n = c.disc_teeth * 256
    t = np.linspace(0, 2 * np.pi, n + 1)
    qt, _, _ = theo.evaluate(t)
    qm, _, _ = mod.evaluate(t)
    dev = qm - qt
    peak = float(np.abs(dev).max()) or 1e-6
    k = exaggeration or 10 ** math.floor(math.log10(0.5 * c.pin_radius_m / peak))  # deviation ~ a fifth of a pin radius
    qe = qt + k * dev
    pins = pin_centres(c, errors)
    radii = pin_radii(c, errors)
    centre, angle = nominal_disc_pose(c, 0.0, 0)
    xp = to_disc_frame(pins, centre, angle)

    fig = Figure(figsize=(15, 5.4), layout="constrained")
    gs = fig.add_gridspec(1, 3)
    ax0, ax1, ax2 = fig.add_subplot(gs[0]), fig.add_subplot(gs[1]), fig.add_subplot(gs[2])
    ring = np.linspace(0, 2 * np.pi, 97)
    for ax in (ax0, ax1):
        ax.plot(qt.real * 1e3, qt.imag * 1e3, color="0.55", lw=1.0, label="theoretical profile")
        ax.plot(qe.real * 1e3, qe.imag * 1e3, color="C3", lw=1.3, label=f"modified, deviation ×{k:g}")
        for (x, y), r in zip(xp, radii):
            ax.plot((x + r * np.cos(ring)) * 1e3, (y + r * np.sin(ring)) * 1e3, color="C0", lw=0.8)
        ax.set_aspect("equal")
        ax.set_xlabel("x in disc frame (mm)")
        ax.set_ylabel("y in disc frame (mm)")
    ax0.plot([], [], color="C0", lw=0.8, label="pins (nominal pose, θ = 0)")
    ax0.set_title(f"{spec.name}: disc 1, zc = {c.disc_teeth}, zb = {c.pin_count}, K1 = {c.k1:.4f}")
    ax0.legend(loc="center", fontsize=9)
    r0 = c.pin_circle_radius_m * 1e3
    ax1.set_xlim(r0 - c.eccentricity_m * 1e3 - 2.5 * c.pin_radius_m * 1e3, r0 + 1.5 * c.pin_radius_m * 1e3)
    half = 2.2 * np.pi * r0 / c.pin_count
    ax1.set_ylim(-half, half)
    ax1.set_title(f"close-up at the tooth root (deviation ×{k:g})")
    phi_deg = np.degrees(cl.phi)
    order = np.argsort(phi_deg)
    ax2.plot(phi_deg[order], cl.nominal_gap_m[order] * 1e6, "o-", ms=3, label="gap, disc centred (exact)")
    gap_turn = np.where(cl.closing_pos, cl.gap_after_pos_m, np.nan)
    ax2.plot(phi_deg[order], gap_turn[order] * 1e6, "s-", ms=3,
             label=f"Δ_i after turning {cl.turn_pos_rad * F.ARCMIN_PER_RAD:.3f}′ to first contact")
    fine = np.linspace(1e-3, np.pi - 1e-3, 400)
    ax2.plot(np.degrees(fine), F.nominal_clearance(c, fine) * 1e6, "k:", lw=1, label="first-order closed form")
    ax2.plot(np.degrees(fine), F.initial_clearance(c, fine) * 1e6, "k--", lw=1, label="Δ_i closed form (seed 000)")
    ax2.set_xlim(0, 360)
    ax2.set_xlabel("pin angle φ from the eccentricity direction (°)")
    ax2.set_ylabel("normal clearance (µm)")
    ax2.set_title("clearance along the pin ring")
    ax2.grid(alpha=0.3)
    ax2.legend(fontsize=8)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=130)
    return path

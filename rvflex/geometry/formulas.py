"""Closed forms from the seed papers. They are checks for the exact geometry and the
model, never substitutes for them (DESIGN.md, accuracy rules).

φ is a pin's angle from the eccentricity direction (φ = 0: the pin deepest in a tooth
root), K1 = e·z_b/r_p, S(φ) = √(1 + K1² − 2K1·cos φ).
"""

from __future__ import annotations

import math

import numpy as np

from rvflex.spec_types import CycloidStage, ReducerSpec
from rvflex.units import ARCMIN_PER_RAD, ARCSEC_PER_RAD  # re-exported: older code imports them from here

__all__ = [
    "ARCMIN_PER_RAD",
    "ARCSEC_PER_RAD",
    "lever_arm",
    "load_sharing",
    "initial_clearance",
    "nominal_clearance",
    "modification_free_play",
    "backlash_formula_arcmin",
    "reducer_backlash_arcmin",
    "hertz_line_deflection",
]



def _s(k1: float, phi: np.ndarray) -> np.ndarray:
    return np.sqrt(1.0 + k1 * k1 - 2.0 * k1 * np.cos(phi))


def lever_arm(stage: CycloidStage, phi: np.ndarray) -> np.ndarray:
    """Moment arm of the contact normal at pin angle φ about the disc centre, e·z_c·sinφ/S (m)."""
    return stage.eccentricity_m * stage.disc_teeth * np.sin(phi) / _s(stage.k1, np.asarray(phi, float))


def load_sharing(stage: CycloidStage, phi: np.ndarray) -> np.ndarray:
    """Deflection share δ_i/δ_max = sinφ/S of a rigid disc turned about its centre (seeds 000, 002)."""
    phi = np.asarray(phi, float)
    return np.sin(phi) / _s(stage.k1, phi)


def nominal_clearance(stage: CycloidStage, phi: np.ndarray) -> np.ndarray:
    """First-order normal clearance of the modified profile at pin angle φ with the disc in its
    nominal (centred) position: Δr_rp − Δr_p·(1 − K1·cosφ)/S (m)."""
    m, k1 = stage.modification, stage.k1
    phi = np.asarray(phi, float)
    return m.equidistant_m - m.moved_m * (1.0 - k1 * np.cos(phi)) / _s(k1, phi)


def initial_clearance(stage: CycloidStage, phi: np.ndarray) -> np.ndarray:
    """Initial clearance Δ_i (m) of the pin at φ ∈ (0, π) once the disc has turned until its
    first pin touches (seed 000's Δ_i, in the dimensionally consistent form of Li Lixing):

        Δ(φ) = Δr_rp·(1 − sinφ/S) − Δr_p·(1 − K1·cosφ − √(1 − K1²)·sinφ)/S

    Seed 000 prints this without the square root and divided by r_p (dimensionless), a
    transcription slip; this form is the one the exact geometry reproduces (tests).
    """
    m, k1 = stage.modification, stage.k1
    phi = np.asarray(phi, float)
    s = _s(k1, phi)
    return (m.equidistant_m * (1.0 - np.sin(phi) / s)
            - m.moved_m * (1.0 - k1 * np.cos(phi) - math.sqrt(1.0 - k1 * k1) * np.sin(phi)) / s)


def modification_free_play(stage: CycloidStage) -> float:
    """Total (both flanks) circumferential clearance of the modification at the lever arm
    e·z_c, 2·(Δr_rp − Δr_p·√(1 − K1²)) (m): the Δφ4 of seed 002's backlash formula.

    One flank closes after the disc turns (Δr_rp − Δr_p√(1 − K1²))/(e·z_c), the first
    contact falling at cos φ = K1; reversing closes the other flank, hence the factor 2.
    """
    m, k1 = stage.modification, stage.k1
    return 2.0 * (m.equidistant_m - m.moved_m * math.sqrt(1.0 - k1 * k1))


def backlash_formula_arcmin(*, ratio: float, sun_pitch_radius_m: float, eccentricity_m: float, disc_teeth: int,
                            crank_circle_radius_m: float, dphi1_m: float, dphi2_m: float, dphi3_m: float,
                            dphi4_m: float) -> float:
    """Seed 002's backlash ε (arcmin) from the clearances along the torque path:

        ε = (180·60/π)·(Δφ1/(i·r1) + Δφ2/(e·z_c) + Δφ3/a0 + Δφ4/(e·z_c))

    Parameters
    ----------
    ratio : float
        Total ratio i of the reducer (–).
    sun_pitch_radius_m : float
        r1, pitch radius of the sun (m): first-stage play j turns the output by j/(i·r1).
    eccentricity_m, disc_teeth : float, int
        e (m) and z_c; e·z_c is the cycloid stage's lever arm at the pitch point.
    crank_circle_radius_m : float
        a0, crank-axis radius = sun–planet centre distance (m).
    dphi1_m, dphi2_m, dphi3_m, dphi4_m : float
        Free plays (m): first-stage circumferential backlash; cycloid-stage play from errors
        (excluding the modification); crank bearing radial clearance; modification play.
    """
    ez = eccentricity_m * disc_teeth
    return ARCMIN_PER_RAD * (dphi1_m / (ratio * sun_pitch_radius_m) + dphi2_m / ez
                             + dphi3_m / crank_circle_radius_m + dphi4_m / ez)


def reducer_backlash_arcmin(spec: ReducerSpec) -> dict[str, float]:
    """ε of seed 002 for a nominal reducer (no manufacturing errors), term by term (arcmin).

    Δφ1 = input-stage backlash, Δφ2 = 0, Δφ3 = nominal crank-support plus eccentric-bearing
    clearance (in series on the torque path), Δφ4 = :func:`modification_free_play`.
    """
    st, c = spec.input_stage, spec.cycloid
    common = dict(ratio=spec.ratio, sun_pitch_radius_m=st.module_m * st.sun_teeth / 2,
                  eccentricity_m=c.eccentricity_m, disc_teeth=c.disc_teeth,
                  crank_circle_radius_m=spec.cranks.crank_circle_radius_m)
    zero = dict(dphi1_m=0.0, dphi2_m=0.0, dphi3_m=0.0, dphi4_m=0.0)
    terms = {
        "first_stage": dict(zero, dphi1_m=st.backlash_m),
        "crank_bearings": dict(zero, dphi3_m=spec.bearings.crank_support.clearance_m
                               + spec.bearings.eccentric.clearance_m),
        "modification": dict(zero, dphi4_m=modification_free_play(c)),
    }
    out = {k: backlash_formula_arcmin(**common, **v) for k, v in terms.items()}
    out["total"] = sum(out.values())
    return out


def hertz_line_deflection(force_N: float, width_m: float, rho_m: float, pin_radius_m: float,
                          e1_Pa: float, nu1: float, e2_Pa: float, nu2: float) -> float:
    """Approach δ (m) of a cycloid flank (1) and a pin (2) in line contact (seed 002):

        δ = 2F/(π·b)·[k1·(ln(4|ρ|/c) − 0.5) + k2·(ln(4·r_rp/c) − 0.5)],  k = (1 − ν²)/E

    with c the Hertz half-width, c² = 4F·(k1 + k2)/(π·b·(1/ρ + 1/r_rp)). ρ is the flank's
    signed radius of curvature (negative where the flank is concave). Seed 002 prints
    c = 4.0606e-3·(k1 + k2)·(F/b)·(1/ρ + 1/r_rp), which is dimensionless as printed; the
    Hertz half-width is the quantity the logarithms need.
    """
    if force_N <= 0.0:
        return 0.0
    k1 = (1.0 - nu1 * nu1) / e1_Pa
    k2 = (1.0 - nu2 * nu2) / e2_Pa
    curv = 1.0 / rho_m + 1.0 / pin_radius_m
    if curv <= 0.0:
        raise ValueError(f"conformal contact: flank radius {rho_m} m is concave and tighter than the pin")
    c = math.sqrt(4.0 * force_N * (k1 + k2) / (math.pi * width_m * curv))
    return 2.0 * force_N / (math.pi * width_m) * (k1 * (math.log(4.0 * abs(rho_m) / c) - 0.5)
                                                  + k2 * (math.log(4.0 * pin_radius_m / c) - 0.5))

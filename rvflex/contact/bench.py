"""``rvflex bench contact``: our cycloid–pin element against Exudyn's ObjectContactCurveCircles.

One load case for both: the RV-40E disc (catalogue modification) on the dynamic
single-disc bench, 50 N·m resisting, crank at 1 rev/s, generalized-α with a 0.2 ms step,
a quarter crank revolution; our element with the "strip" law, which is the fine-segment
limit of the polygon contact's law, at the same per-length stiffness.
"""

from __future__ import annotations

import math
import time

import numpy as np

from rvflex import catalog
from rvflex.contact.cycloid_pin import ContactLaw, add_cycloid_pin_contact
from rvflex.contact.single_disc import (
    arc_length_segments,
    build_dynamic_disc,
    build_single_disc,
    quasi_static_te,
    run_dynamic,
)
from rvflex.geometry.clearance import initial_clearance_numeric
from rvflex.geometry.pins import nominal_disc_pose, pin_centres, pin_radii, to_disc_frame
from rvflex.geometry.profile import build_profile
from rvflex.units import ARCSEC_PER_RAD

__all__ = ["CROSSCHECK", "bench_contact", "crosscheck_te", "polygon_interference_m", "relieved_rv80e_stage"]

CROSSCHECK = dict(stiffness_N_m2=1e11, damping_Ns_m2=2e6, damping_Ns_m=300.0, torque_Nm=50.0,
                  crank_speed_rad_s=2 * math.pi, step_s=2e-4, revolutions=0.25)
"""The shared load case. 1e11 N/m² per unit length gives ~10 µm approaches at 50 N·m: the
polygon contact converges with it (1e12 diverges at a 0.2 ms step); the damping values give
a similar dissipation per contact (c ≈ d_c × overlap chord)."""


def crosscheck_te(segments: int = 0, **overrides) -> tuple[np.ndarray, np.ndarray, float, int]:
    """Run the shared load case with our element (``segments`` = 0) or the polygon contact.

    Returns crank angle (rad), TE (arcsec), wall time (s) and steps.
    """
    p = dict(CROSSCHECK, **overrides)
    stage = catalog.load("rv40e").cycloid
    start = -initial_clearance_numeric(stage).turn_pos_rad
    common = dict(resisting_torque_Nm=p["torque_Nm"], start_te_rad=start, crank_speed_rad_s=p["crank_speed_rad_s"])
    if segments:
        bench = build_dynamic_disc(stage, curve_circles_segments=segments,
                                   curve_circles_stiffness_N_m2=p["stiffness_N_m2"],
                                   curve_circles_damping_Ns_m2=p["damping_Ns_m2"], **common)
    else:
        bench = build_dynamic_disc(stage, law=ContactLaw.strip(p["stiffness_N_m2"], damping_Ns_m=p["damping_Ns_m"]),
                                   **common)
    theta, te, wall = run_dynamic(bench, p["revolutions"], p["step_s"])
    return theta, te * ARCSEC_PER_RAD, wall, len(theta) - 1


def polygon_interference_m(segments: int, n_positions: int = 64) -> float:
    """Worst interference of exactly touching pins with the arc-length polygon of the
    theoretical RV-40E profile over one crank revolution (m): the polygon's geometric error."""
    stage = catalog.load("rv40e").cycloid
    import dataclasses as dc

    theo = dc.replace(stage, modification=dc.replace(stage.modification, moved_m=0.0, equidistant_m=0.0))
    seg = arc_length_segments(theo, segments)
    a, b = seg[:, :2], seg[:, 2:]
    ab = b - a
    worst = 0.0
    for theta in np.linspace(0.0, 2 * np.pi, n_positions, endpoint=False):
        x = to_disc_frame(pin_centres(theo), *nominal_disc_pose(theo, theta))
        for c, r in zip(x, pin_radii(theo)):
            s = np.clip(np.einsum("ij,ij->i", c - a, ab) / np.einsum("ij,ij->i", ab, ab), 0.0, 1.0)
            dist = np.sqrt(np.min(np.sum((a + s[:, None] * ab - c) ** 2, axis=1)))
            worst = max(worst, r - dist)
    return worst


def relieved_rv80e_stage():
    """The RV-80E cycloid stage with seed 003's pressure-angle profile (Table 2: theoretical
    working zone, 45 µm tip relief beyond 65°, 15 µm root relief beyond 75°; the root is
    sharper than the pin, so root pins have two contact points)."""
    import dataclasses as dc

    stage = catalog.load("rv80e").cycloid
    mod = dc.replace(stage.modification, moved_m=0.0, equidistant_m=0.0, tip_amount_m=45e-6, root_amount_m=15e-6)
    return dc.replace(stage, modification=mod)


def _eval_us_per_call(repeats: int = 2000, stage=None) -> float:
    """Force + Jacobian user functions of both discs (2 × 40 pins) as Exudyn calls them, on
    a sequence of nearby loaded states (so warm starts work as in a run), µs per call;
    ``stage`` defaults to the RV-40E catalogue stage."""
    import exudyn as exu
    from exudyn.itemInterface import NodeRigidBody2D

    stage = stage or catalog.load("rv40e").cycloid
    law = ContactLaw.hertz(2e10, 1.5, damping_Ns_m=300.0)
    mbs = exu.SystemContainer().AddSystem()
    contacts, states = [], []
    for disc in range(2):
        centre, angle = nominal_disc_pose(stage, 0.0, disc)
        body = angle + stage.disc_phase_rad[disc] / stage.disc_teeth
        node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[centre[0], centre[1], body]))
        contacts.append(add_cycloid_pin_contact(mbs, node, stage, law, disc=disc))
        # a profile that touches at the nominal pose (theoretical working zone) needs no closing turn
        clear = initial_clearance_numeric(stage, None, disc, allow_interference=True)
        close = clear.turn_pos_rad if clear.nominal_gap_m.min() > 0.0 else 0.0
        path = []
        for k in range(repeats):
            theta = 1e-3 * k
            c, a = nominal_disc_pose(stage, theta, disc)
            b = a + stage.disc_phase_rad[disc] / stage.disc_teeth
            path.append((np.array([c[0] - centre[0], c[1] - centre[1], b + close + 2e-5 - body]),
                         np.array([0.0, 0.0, -2 * np.pi / stage.disc_teeth])))
        states.append(path)
    for c, path in zip(contacts, states):  # compile and warm the caches
        c._force_uf(mbs, 0.0, 0, *path[0])
    t0 = time.perf_counter()
    for k in range(repeats):
        for c, path in zip(contacts, states):
            q, qd = path[k]
            c._force_uf(mbs, 0.0, 0, q, qd)
            c._jacobian_uf(mbs, 0.0, 0, q, qd, 1.0, 0.0)
    return 1e6 * (time.perf_counter() - t0) / repeats


def _noise_floor_arcsec() -> float:
    """TE peak-to-peak of perfect geometry without load over one disc revolution (″)."""
    import dataclasses as dc

    stage = catalog.load("rv40e").cycloid
    perfect = dc.replace(stage, modification=dc.replace(stage.modification, moved_m=0.0, equidistant_m=0.0))
    bench = build_single_disc(perfect, ContactLaw.linear(1e8))
    theta = np.linspace(0.0, 2 * np.pi * perfect.disc_teeth, 16 * perfect.disc_teeth + 1)
    return float(np.ptp(quasi_static_te(bench, theta, predictor_offset_rad=1e-5)) * ARCSEC_PER_RAD)


def _our_geometry_error_m() -> float:
    stage = catalog.load("rv40e").cycloid
    worst = 0.0
    for disc in range(stage.disc_count):
        prof = build_profile(stage, None, disc)
        x = to_disc_frame(pin_centres(stage), *nominal_disc_pose(stage, 0.3, disc))
        r = pin_radii(stage)
        worst = max(worst, float(np.abs(prof.gap(x, r).gap_m - prof.brute_force_gap(x, r)).max()))
    return worst


def bench_contact(segments: int = 8000, progress=print) -> dict:
    """Run the contact benchmark and return its JSON document."""
    t_start = time.perf_counter()
    progress("evaluation cost (2 × 40 pins, force + Jacobian) ...")
    eval_us = _eval_us_per_call()
    progress("evaluation cost, RV-80E with seed 003's relieved roots (multi-point contact) ...")
    eval_relieved_us = _eval_us_per_call(stage=relieved_rv80e_stage())
    progress("noise floor (perfect geometry, no load, one disc revolution) ...")
    floor = _noise_floor_arcsec()
    progress("dynamic load case, rvflex element ...")
    th_o, te_o, wall_o, n_o = crosscheck_te(0)
    progress(f"dynamic load case, ObjectContactCurveCircles with {segments} segments (slow) ...")
    th_c, te_c, wall_c, n_c = crosscheck_te(segments)
    half = len(te_o) // 3  # after the start transient
    ours_sps, cc_sps = n_o / wall_o, n_c / wall_c
    ours_geom, cc_geom = _our_geometry_error_m(), polygon_interference_m(segments)
    return {
        "eval_us_per_call": eval_us,
        "eval_us_per_call_relieved_rv80e": eval_relieved_us,
        "noise_floor_te_pp_arcsec": floor,
        "ours_steps_per_s": ours_sps,
        "curvecircles_steps_per_s": cc_sps,
        "speedup": ours_sps / cc_sps,
        "ours_geom_error_m": ours_geom,
        "curvecircles_geom_error_m": cc_geom,
        "curvecircles_segments": segments,
        "te_mean_ours_arcsec": float(te_o[half:].mean()),
        "te_mean_curvecircles_arcsec": float(te_c[half:].mean()),
        "te_max_difference_arcsec": float(np.abs(te_o[half:] - te_c[half:]).max()),
        "load_case": {k: v for k, v in CROSSCHECK.items()},
        "wall_s": time.perf_counter() - t_start,
    }

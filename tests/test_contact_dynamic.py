"""Contact element in dynamics: cross-check against Exudyn's ObjectContactCurveCircles, and
stability through seed 001's bearing clearance with a modified profile."""

from __future__ import annotations

import numpy as np
import pytest

from rvflex import catalog
from rvflex.contact.bench import crosscheck_te
from rvflex.contact.cycloid_pin import ContactLaw, install_penetration_guard
from rvflex.contact.single_disc import build_dynamic_disc, run_dynamic
from rvflex.geometry.clearance import initial_clearance_numeric
from rvflex.geometry.formulas import ARCSEC_PER_RAD


@pytest.mark.slow
def test_curve_circles_converges_to_our_loaded_te():
    """Same disc, load (50 N·m), speed and law: Exudyn's polygon contact at 4000 and 8000
    arc-length segments against our exact element ("strip" law = the polygon law's
    fine-segment limit). The polygon curve moves toward ours as the segments double, and
    ours lies within the polygon's own discretisation error at 8000 segments, estimated as
    2 × |TE₈₀₀₀ − TE₄₀₀₀| (the error falls like h^p with p ≈ 0.7 here; p ≥ 0.5 keeps
    the remaining error of TE₈₀₀₀ below 2.4 × that change)."""
    _, ours, _, _ = crosscheck_te(0)
    _, cc4, _, _ = crosscheck_te(4000)
    _, cc8, _, _ = crosscheck_te(8000)
    tail = slice(len(ours) // 3, None)  # after the start transient
    ours, cc4, cc8 = ours[tail], cc4[tail], cc8[tail]
    assert np.abs(ours - cc8).mean() < np.abs(ours - cc4).mean()
    assert np.max(np.abs(ours - cc8)) <= 2.0 * np.max(np.abs(cc8 - cc4))


def test_stable_through_bearing_clearance_with_modified_profile():
    """RV-40E disc with its 12 µm / 20 µm modification on the eccentric through the clearance
    bearing (catalogue stiffness + seed 001's 12 µm clearance), half the rated torque on one
    disc, crank at 1 rev/s, generalized-α (ρ∞ 0.8) at h = 0.1 ms: the run completes, no
    contact penetrates beyond 50 µm, and the disc settles to a steady lag."""
    spec = catalog.load("rv40e")
    stage = spec.cycloid
    start = -initial_clearance_numeric(stage).turn_pos_rad
    bench = build_dynamic_disc(stage, law=ContactLaw.hertz(2e10, 1.5, damping_Ns_m=300.0), resisting_torque_Nm=206.0,
                               start_te_rad=start, eccentric_bearing=spec.bearings.eccentric,
                               eccentric_clearance_m=12e-6)
    install_penetration_guard(bench.mbs, [bench.contact])
    theta, te, _ = run_dynamic(bench, 0.5, 1e-4)
    te = te[len(te) // 3:] * ARCSEC_PER_RAD
    assert np.all(np.isfinite(te))
    # lag = modification free play + bearing clearance + contact approach: tens of arcsec,
    # and steady within 1″ once the start transient has gone
    assert -400.0 < te.mean() < -50.0
    assert np.ptp(te) < 1.0

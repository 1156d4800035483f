"""The main bearing pair's numba kernel and its Exudyn element: the kernel against the numpy evaluation it
replaced (loaded and partly unloaded rows), its Jacobian against central differences and the symmetry a
frictionless potential and the pair's mirror symmetry demand, and Exudyn's static solve on the element against
:func:`rvflex.contact.angular_contact.solve`."""

from __future__ import annotations

import numpy as np
import pytest

from rvflex import catalog
from rvflex.contact.angular_contact import PairLoad, PairModel, pair_kernel, pair_model, solve

COMBINED = PairLoad(force_N=(800.0, -500.0, 1500.0), moment_Nm=(1500.0, -900.0))
"""Radial, axial and tilting load on the RV-40E pair that lifts about half its balls off (43 of 80 loaded)."""


@pytest.fixture(scope="module")
def pair():
    return catalog.load("rv40e").bearings.main_pair


def _numpy_reference(model: PairModel, q: np.ndarray):
    """The pair's numpy evaluation as it was before the kernel (all balls at once with einsum): contact
    potential (J), generalized force (N, N·m), stiffness, ball loads (N) and the per-component scale of the
    force, Σ_j Q_j·|J_jᵀ v̂_j| (what cancels in the sum)."""
    jac = model.jacobians()
    v = model.outer_centres_m - model.inner_centres_m - jac @ q
    length = np.linalg.norm(v, axis=1)
    unit = v / length[:, None]
    x = np.maximum(length - model.centre_distance_m, 0.0)
    if model.law == "hertz":
        load, kt, energy = model.stiffness * x * np.sqrt(x), 1.5 * model.stiffness * np.sqrt(x), \
            0.4 * model.stiffness * x**2 * np.sqrt(x)
    else:
        load, kt, energy = model.stiffness * x, np.where(x > 0, model.stiffness, 0.0), 0.5 * model.stiffness * x**2
    ju = np.einsum("nk,nkd->nd", unit, jac)
    geo = load / length
    hess = np.einsum("n,nd,ne->de", kt - geo, ju, ju) + np.einsum("n,nkd,nke->de", geo, jac, jac)
    return energy.sum(), (load[:, None] * ju).sum(axis=0), hess, load, np.abs(load[:, None] * ju).sum(axis=0)


def _kernel(model: PairModel, q: np.ndarray):
    n = model.n_balls
    f, k, load, unit, squeeze = np.empty(5), np.empty((5, 5)), np.empty(n), np.empty((n, 3)), np.empty(n)
    energy = pair_kernel(np.asarray(q, float), model.inner_centres_m, model.outer_centres_m, model.centre_distance_m,
                         model.stiffness, model.law_code, f, k, load, unit, squeeze)
    return energy, f, k, load, squeeze


def _states(pair):
    """(model, q, label): preloaded at rest (every ball loaded), under the combined load (about half the balls
    free), and without preload under an axial force and a moment (one row off, part of the other)."""
    import dataclasses

    hertz, linear = pair_model(pair), pair_model(pair, law="linear", linear_stiffness_N_m=2e8)
    free = pair_model(dataclasses.replace(pair, preload_N=0.0))
    lifting = PairLoad(force_N=(0.0, 0.0, 3000.0), moment_Nm=(200.0, 0.0))
    return [(hertz, solve(hertz, PairLoad()).q, "hertz preloaded"),
            (hertz, solve(hertz, COMBINED).q, "hertz combined"),
            (linear, solve(linear, COMBINED).q, "linear combined"),
            (free, solve(free, lifting).q, "hertz no preload")]


def test_the_kernel_is_the_numpy_evaluation_it_replaced(pair):
    loss = 0
    for model, q, label in _states(pair):
        energy, f, k, load, _ = _kernel(model, q)
        e_ref, f_ref, k_ref, load_ref, scale = _numpy_reference(model, q)
        # ball loads come from squeezes of µm taken from groove-centre gaps of 0.4 mm at 64 mm radius:
        # round-off ~1e-17 m in the gap is ~1e-12 of the largest squeeze, so 1e-12 of the largest load
        assert np.abs(load - load_ref).max() <= 1e-12 * load_ref.max(), label
        assert energy == pytest.approx(e_ref, rel=1e-12), label
        # the balls' forces cancel (preload): compare with what cancels, component by component
        assert np.all(np.abs(f - f_ref) <= 1e-12 * scale), label
        assert np.abs(k - k_ref).max() <= 1e-12 * np.abs(k_ref).max(), label
        loss += 0 < np.count_nonzero(load) < model.n_balls
    assert loss == 3  # the states with contact loss are among them


def test_the_kernel_balances_the_load_at_the_solved_equilibrium(pair):
    model = pair_model(pair)
    state = solve(model, COMBINED)
    _, f, _, load, _ = _kernel(model, state.q)
    assert 0 < np.count_nonzero(load) < model.n_balls
    # the balls carry the external load: contact force + load = 0 (to the solver's 1e-12 m at the balls)
    assert np.abs(f + COMBINED.vector()).max() <= 1e-6 * np.abs(COMBINED.vector()).max()
    np.testing.assert_array_equal(load, state.ball_load_N)


def test_the_jacobian_is_central_differences_of_the_force(pair):
    reach = 0.5 * pair.pitch_diameter_m
    h = np.array([1e-10, 1e-10, 1e-10, 1e-10 / reach, 1e-10 / reach])  # 0.1 nm at the balls
    for model, q, label in _states(pair):
        _, _, k, _, squeeze = _kernel(model, q)
        # no ball within the step of its first touch, where the law has a kink (Hertz: dQ/dδ → ∞ slope)
        assert np.abs(squeeze).min() > 100 * h[0], label
        fd = np.empty((5, 5))
        for j in range(5):
            dq = np.zeros(5)
            dq[j] = h[j]
            fd[:, j] = -(_kernel(model, q + dq)[1] - _kernel(model, q - dq)[1]) / (2 * h[j])
        # truncation (h/δ)² and round-off 1e-16·ΣQ/h are both far below 1e-6 of the stiffness
        assert np.abs(fd - k).max() <= 1e-6 * np.abs(k).max(), label


def test_the_jacobian_is_symmetric_and_the_preloaded_pair_decoupled(pair):
    for model, q, label in _states(pair):
        k = _kernel(model, q)[2]
        # no friction: the stiffness is the Hessian of the contact potential
        assert np.abs(k - k.T).max() <= 1e-14 * np.abs(k).max(), label
        assert np.all(np.linalg.eigvalsh(k) >= -1e-12 * np.abs(k).max()), label  # convex potential
    model = pair_model(pair)
    k = _kernel(model, np.zeros(5))[2]
    # at rest the pair is axisymmetric and mirror-symmetric about its middle plane: radial, axial and tilt
    # stiffness are uncoupled, alike in x and y
    assert np.abs(k - np.diag(np.diag(k))).max() <= 1e-9 * np.abs(k).max()
    assert k[0, 0] == pytest.approx(k[1, 1], rel=1e-12) and k[3, 3] == pytest.approx(k[4, 4], rel=1e-12)


def test_exudyn_static_solve_on_the_pair_element_is_the_pair_solution(pair):
    from rvflex.parts.main_bearing import static_displacement

    model = pair_model(pair)
    for load in (COMBINED, PairLoad(force_N=(-300.0, 200.0, -400.0), moment_Nm=(-100.0, 250.0))):
        expected = solve(model, load)
        got = static_displacement(model, load, contacts="element")
        # one law and one set of kinematics: equal to both solvers' tolerances (1e-12 m at the balls)
        assert np.abs(got - expected.q).max() <= 1e-9 * np.abs(expected.q).max()
    assert 0 < solve(model, COMBINED).balls_in_contact < model.n_balls  # contact loss inside Exudyn's Newton


def test_the_element_evaluates_the_kernel_on_the_carrier_node(pair):
    import exudyn as exu
    from exudyn.itemInterface import NodeRigidBody2D, NodeRigidBodyRxyz

    from rvflex.parts.main_bearing import add_pair_element

    model = pair_model(pair)
    mbs = exu.SystemContainer().AddSystem()
    node = mbs.AddNode(NodeRigidBodyRxyz(referenceCoordinates=[0.0] * 6))
    element = add_pair_element(mbs, node, model)
    q = np.array([1e-6, -2e-6, 3e-6, 1e-5, -2e-5, 0.7])  # the turn ψz loads no ball
    f, k, load = element.evaluate(q)
    _, f5, k5, load5, _ = _kernel(model, q[:5])
    np.testing.assert_array_equal(f[:5], f5)
    np.testing.assert_array_equal(k[:5, :5], k5)
    np.testing.assert_array_equal(load, load5)
    assert f[5] == 0.0 and not k[5].any() and not k[:, 5].any()
    with pytest.raises(ValueError, match=r"not RigidBodyRxyz"):
        add_pair_element(mbs, mbs.AddNode(NodeRigidBody2D()), model)
    with pytest.raises(ValueError, match=r"reference tilt .* must be zero"):
        add_pair_element(mbs, mbs.AddNode(NodeRigidBodyRxyz(referenceCoordinates=[0, 0, 0, 0.01, 0, 0])), model)


def test_a_seat_offset_moves_the_outer_rings(pair):
    """With the outer rings' seat off the axis by (s_x, s_y) (a carrier runout), the element at q evaluates the
    centred pair at q − (s_x, s_y, 0, 0, 0): a carrier sitting on the seat's axis carries the preload alone."""
    import exudyn as exu
    from exudyn.itemInterface import NodeRigidBodyRxyz

    from rvflex.parts.main_bearing import add_pair_element

    model = pair_model(pair)
    mbs = exu.SystemContainer().AddSystem()
    seat = (4e-6, -3e-6)
    element = add_pair_element(mbs, mbs.AddNode(NodeRigidBodyRxyz(referenceCoordinates=[0.0] * 6)), model,
                               seat_offset_m=seat)
    q = np.array([1e-6, -2e-6, 3e-6, 1e-5, -2e-5, 0.0])
    f, k, load = element.evaluate(q)
    _, f5, k5, load5, _ = _kernel(model, q[:5] - np.array([*seat, 0.0, 0.0, 0.0]))
    np.testing.assert_allclose(f[:5], f5, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(load, load5, rtol=1e-12, atol=1e-9)
    f0, _, _ = element.evaluate(np.array([*seat, 0.0, 0.0, 0.0, 0.0]))
    assert np.abs(f0).max() < 1e-6 * model.n_balls * pair.preload_N  # the preload balances itself
    with pytest.raises(ValueError, match=r"seat_offset_m = .* must be two finite lengths"):
        add_pair_element(mbs, mbs.AddNode(NodeRigidBodyRxyz(referenceCoordinates=[0.0] * 6)), model,
                         seat_offset_m=(1e-6,))

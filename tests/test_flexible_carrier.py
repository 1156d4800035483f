"""The flexible carrier: an FE-reduced (FFRF) output flange with distributing (RBE3) crank
seats in the full reducer, on coarse reductions (8 mm linear tets) so CI stays quick; the
default (6 mm quadratic) carrier is exercised by the slow tests of test_fe.py and the
flexibility_effect scenario."""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np
import pytest
from conftest import COARSE_DISC

from rvflex.geometry.formulas import ARCSEC_PER_RAD
from rvflex.model import build_reducer
from rvflex.options import CARRIER_FE, DISC_FE, ModelOptions
from rvflex.solve import quasi_static

pytestmark = pytest.mark.flexible

COARSE_CARRIER = {"maxh_m": 8e-3, "n_modes": 6, "mesh_order": 1}


@pytest.fixture(scope="module")
def setup(coarse_disc):
    from rvflex.fe.reduce import reduce_part

    spec, disc = coarse_disc
    carrier = reduce_part(spec, "carrier", **COARSE_CARRIER)
    # one crank turn relative to the carrier at 6 positions
    theta = np.linspace(0.0, 2 * np.pi * spec.nominal_ratio / spec.cycloid.pin_count, 6, endpoint=False)
    discs_only = quasi_static(build_reducer(spec, None, "flexible", reduced_disc=disc), theta,
                              spec.rated_torque_Nm).te_rad * ARCSEC_PER_RAD
    return spec, disc, carrier, theta, discs_only


def _te(spec, disc, carrier, theta, monkeypatch=None, scale=1.0, seat_marker="virtual"):
    if scale != 1.0:
        import rvflex.fe.ffrf as ffrf

        orig = ffrf.ffrf_interface

        def stiffer(r, **kw):
            o = orig(r, **kw)
            if r.part == "carrier":
                o.stiffnessMatrixReduced = o.stiffnessMatrixReduced * scale
            return o

        monkeypatch.setattr(ffrf, "ffrf_interface", stiffer)
    model = build_reducer(spec, None, ModelOptions(carrier_seat_marker=seat_marker), reduced_disc=disc,
                          reduced_carrier=carrier)
    return quasi_static(model, theta, spec.rated_torque_Nm).te_rad * ARCSEC_PER_RAD


def test_model_layout_of_the_flexible_carrier(setup):
    """The carrier's reference node is a NodeRigidBodyRxyz: planar_index gives (x, y, ψz), the
    output angle is its 6th coordinate, node_slices leaves it out (no contiguous x, y, θ),
    the kinematic guess sets θ_out and zero modal coordinates; two support bearings per crank."""
    spec, disc, carrier, _, _ = setup
    m = build_reducer(spec, None, "flexible", reduced_disc=disc, reduced_carrier=carrier)
    i = m.mbs.GetNodeODE2Index(m.carrier.node)
    assert m.flexible_carrier and "carrier" not in m.node_slices()
    assert m.planar_index()["carrier"].tolist() == [i, i + 1, i + 5] and m.output_index == i + 5
    assert m.carrier.angle_coordinate == 5
    th = 0.3
    q = m.kinematic_coordinates(th)
    assert q[i + 5] == pytest.approx(th / m.ratio)
    j = m.mbs.GetNodeODE2Index(m.carrier.modal_node)
    assert np.all(q[j:j + carrier.n_modes] == 0.0) and np.all(q[i + 2:i + 5] == 0.0)
    assert len(m.input_seat_supports) == len(m.cranks.supports) == spec.cranks.count
    rigid = build_reducer(spec, None, "rigid")
    assert not rigid.flexible_carrier and rigid.output_index == rigid.node_slices()["carrier"].start + 2


def test_seat_attachment_modes_make_the_reduction_exact_for_the_coupling_loads(setup):
    """The reduction's own error: for loads distributed by the seats' RBE3 couplings (what the
    model's seat markers apply), the reduced response equals the full FE solve (output face
    held) to round-off, everywhere — the static check's remaining few % are the load
    distribution (uniform vs bearing pressure), not the reduction (docs/fe.md)."""
    import scipy.sparse.linalg as sla

    from rvflex.fe.reduce import rbe3_loads

    _, _, carrier, _, _ = setup
    nn = carrier.n_nodes
    K = carrier.fem.GetStiffnessMatrix(sparse=True).tocsc()
    free = np.ones(3 * nn, bool)
    for c in range(3):
        free[3 * carrier.interfaces[0].nodes + c] = False
    F = np.hstack([rbe3_loads(carrier.node_positions_m, itf, nn) for itf in carrier.interfaces[1:]])
    U = np.zeros_like(F)
    U[free] = sla.splu(K[free][:, free]).solve(F[free])
    P = carrier.mode_basis
    Ur = P @ np.linalg.solve(P.T @ (K @ P), P.T @ F)
    assert np.abs(Ur - U).max() <= 1e-8 * np.abs(U).max()
    assert carrier.check.flank_pct < 1.0  # pillar mid-span under the bearing pressure


def _seat_marker_outputs(model, q_modal, frame):
    """Position and rotation matrix of every seat marker at the carrier's modal coordinates
    ``q_modal`` and reference-node coordinates ``frame`` (x, y, z, ψx, ψy, ψz)."""
    import exudyn as exu

    mbs = model.mbs
    mbs.Assemble()
    q = np.array(mbs.systemData.GetODE2Coordinates())
    i, j = mbs.GetNodeODE2Index(model.carrier.node), mbs.GetNodeODE2Index(model.carrier.modal_node)
    q[i:i + 6] = frame
    q[j:j + len(q_modal)] = q_modal
    mbs.systemData.SetODE2Coordinates(q)
    return np.array([np.concatenate([mbs.GetMarkerOutput(mk, exu.OutputVariableType.Position),
                                     mbs.GetMarkerOutput(mk, exu.OutputVariableType.RotationMatrix)])
                     for mk in model.carrier.bore_markers + model.carrier.input_seat_markers])


def _mass_matrix(model) -> np.ndarray:
    """The system mass matrix at the current state (FFRF terms included)."""
    import exudyn as exu

    ss = exu.SimulationSettings()
    ss.solution.file.write = False  # InitializeSolver would open coordinatesSolution.txt in the cwd
    solver = exu.MainSolverImplicitSecondOrder()
    solver.InitializeSolver(model.mbs, ss)
    solver.ComputeMassMatrix(model.mbs)
    return np.array(solver.GetSystemMassMatrix())


def test_virtual_seat_nodes_move_like_the_all_node_seat_markers(setup):
    """The default seat markers sit on 4 massless virtual nodes per seat whose mode rows are the
    seat's RBE3 motion: for any carrier state their positions and rotations equal those of the
    markers on all seat nodes (Exudyn's weighted mean translation and its rotation
    W⁻¹ Σ w_i p_i × u_i, W = Σ w_i (|p_i|²1 − p_i p_iᵀ)) to round-off — also with a large
    elastic deformation (exponential rotation map) and a turned, shifted frame. The nodes are
    massless: the system mass matrix (FFRF inertia terms) is the same, bit for bit."""
    spec, disc, carrier, _, _ = setup
    q_modal = np.random.default_rng(1).normal(size=carrier.n_modes) * 1e-5
    frame = [1e-5, -2e-5, 0.0, 0.0, 0.0, 0.3]
    outs, masses = {}, {}
    for mode in ("all_nodes", "virtual"):
        m = build_reducer(spec, None, ModelOptions(carrier_seat_marker=mode), reduced_disc=disc,
                          reduced_carrier=carrier)
        deformed = _seat_marker_outputs(m, q_modal, frame)
        masses[mode] = _mass_matrix(m)  # at the deformed, turned state just set
        outs[mode] = (deformed, _seat_marker_outputs(m, 0 * q_modal, frame))
        nodes = [len(m.mbs.GetMarker(mk)["meshNodeNumbers"]) for mk in m.carrier.bore_markers]
        assert (max(nodes) == 4) == (mode == "virtual")
    elastic = outs["virtual"][0] - outs["virtual"][1]
    assert np.abs(elastic[:, :3]).max() > 1e-5 and np.abs(elastic[:, 3:]).max() > 1e-3  # a real deformation
    d = outs["virtual"][0] - outs["all_nodes"][0]
    assert np.abs(d[:, :3]).max() < 1e-15 and np.abs(d[:, 3:]).max() < 1e-13
    assert np.array_equal(masses["virtual"], masses["all_nodes"])  # the virtual nodes are massless


def test_virtual_seat_nodes_apply_the_rbe3_loads(setup):
    """Virtual work: a unit force or moment on a virtual-node seat marker (weights ¼: force rows
    Σ ¼ Φ_v, moment rows the RBE3 rotation map) gives the same generalised forces as the RBE3
    nodal loads the seat attachment modes were computed for (``rbe3_loads``): Ψᵀ F."""
    from rvflex.fe.reduce import rbe3_loads, rbe3_virtual_nodes

    _, _, carrier, _, _ = setup
    pos, P = carrier.node_positions_m, carrier.mode_basis
    seats = carrier.interfaces[1:]
    vn = rbe3_virtual_nodes(P, pos, seats)
    for itf in seats:
        g = np.asarray(vn.group(itf.name))
        rows = vn.rows.reshape(-1, 3, P.shape[1])[g]  # (4, 3, m)
        s = vn.positions_m[g] - vn.positions_m[g].mean(axis=0)
        assert np.allclose(vn.positions_m[g].mean(axis=0), itf.weights @ pos[itf.nodes], atol=1e-15)
        # Exudyn's rotation map of a marker on these 4 nodes (weights ¼, centroid reference)
        W = sum(0.25 * ((v @ v) * np.eye(3) - np.outer(v, v)) for v in s)
        rot = np.linalg.solve(W, sum(0.25 * np.cross(v[:, None], r, axis=0) for v, r in zip(s, rows)))
        Q = P.T @ rbe3_loads(pos, itf, carrier.n_nodes)  # (m, 6)
        scale = np.abs(Q).max(axis=0)
        assert np.abs(rows.mean(axis=0).T - Q[:, :3]).max(axis=0) / scale[:3] == pytest.approx(0, abs=1e-10)
        assert np.abs(rot.T - Q[:, 3:]).max(axis=0) / scale[3:] == pytest.approx(0, abs=1e-10)


def test_virtual_seat_nodes_give_the_all_node_te(setup):
    """Loaded TE at rated torque with the virtual-node seat markers equals the all-node seat
    markers' (the same coupling, exactly) to 1e-3″ — measured 1e-10″."""
    spec, disc, carrier, theta, _ = setup
    virtual = _te(spec, disc, carrier, theta[:3])
    all_nodes = _te(spec, disc, carrier, theta[:3], seat_marker="all_nodes")
    assert np.abs(virtual - all_nodes).max() < 1e-3


def test_flexible_carrier_adds_wind_up(setup):
    """Rated torque: the elastic carrier (plates twisting against each other on two 7 mm
    pillars, seats ovalising) adds wind-up of the same sign as the elastic discs — tens of
    arcseconds on the ~220″ of the flexible-disc model (the full FE input-plate seats move
    ≈ 19 µm ≈ 1.8′ at the 36 mm crank circle on this coarse mesh under the bearing loads,
    most of which the crank bypasses to the stiff output-plate seat) — and leaves the
    crank-angle pattern of the TE nearly as it was (the seat loads do not turn with the crank)."""
    spec, disc, carrier, theta, discs_only = setup
    flex = _te(spec, disc, carrier, theta)
    extra = flex.mean() - discs_only.mean()
    assert -120.0 < extra < -10.0
    assert abs(np.ptp(flex) - np.ptp(discs_only)) < 0.2 * np.ptp(discs_only) + 0.5


def test_stiff_carrier_recovers_the_flexible_disc_model(setup, monkeypatch):
    """Reduced carrier stiffness × 1e5: the model is the flexible-disc (rigid-carrier) model
    to 0.01″ — the FFRF carrier, its seat markers, the split support bearings (two halves in
    parallel = the lumped pair) and the output frame add nothing but elasticity."""
    spec, disc, carrier, theta, discs_only = setup
    stiff = _te(spec, disc, carrier, theta, monkeypatch, 1e5)
    assert np.abs(stiff - discs_only).max() < 0.01


def test_cli_fidelity_maps_to_the_presets():
    """--fidelity names a ModelOptions preset, --fe-* override the disc settings of a flexible one
    and are refused with the rigid one (naming the flag); a reduced carrier makes the carrier
    flexible with the reduction's own settings."""
    from rvflex.cli import _options
    from rvflex.spec import SpecError

    ns = dict(fe_maxh_m=None, fe_n_modes=None, fe_attach_per_tooth=None, fe_mesh_order=None)
    assert _options(argparse.Namespace(fidelity="rigid", **ns)) == ModelOptions.rigid()
    assert _options(argparse.Namespace(fidelity="flexible", **ns)) == ModelOptions.flexible_discs()
    both = _options(argparse.Namespace(fidelity="flexible-carrier", **{**ns, "fe_n_modes": 24}))
    assert both.carrier == CARRIER_FE and both.discs == dataclasses.replace(DISC_FE, n_modes=24)
    with pytest.raises(SpecError, match="--fe-modes"):
        _options(argparse.Namespace(fidelity="rigid", **{**ns, "fe_n_modes": 24}))


def test_flexibility_effect_scenario_has_the_carrier_row(setup, tmp_path):
    """Smoke run of the scenario with the flexible+carrier row (coarse reductions): the
    carrier's share of the wind-up and of the compliance is positive, and the table says so."""
    from rvflex.scenarios.flexibility_effect import FlexibilityEffect, run_flexibility_effect, write_flexibility_outputs
    from rvflex.spec import ErrorSpec

    spec = setup[0]
    sc = FlexibilityEffect(spec, ErrorSpec(), load_fractions=(0.0, 1.0), positions_per_rev=16, steps=40,
                           discs=dataclasses.replace(DISC_FE, **COARSE_DISC),
                           carrier=dataclasses.replace(CARRIER_FE, **COARSE_CARRIER))
    rows = run_flexibility_effect(sc, progress=lambda done, total: None)
    rated = next(r for r in rows if r["fidelity"] == "flexible+carrier" and r["load_fraction"] == 1.0)
    assert 0.0 < rated["carrier_share_windup"] < rated["elastic_share_windup"] < 1.0
    assert 0.0 < rated["carrier_share_compliance"] < 1.0
    paths = write_flexibility_outputs(tmp_path, rows, sc)
    assert "flexible+carrier" in (tmp_path / "flexibility.md").read_text()
    assert all(p.stat().st_size > 0 for p in paths)

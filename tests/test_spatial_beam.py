"""Beam cranks of the spatial model (``SpatialSettings(crank="beam")``, rvflex.parts.crankshaft): the station chain
is the closed-form Timoshenko shaft, a very stiff beam is the rigid crank, the wind-up the beam adds is the one its
bending and twist under the eccentric loads predict, more elements leave the statics alone, and what the beam needs
is refused in one line when missing. Solved by Exudyn (the compiled step declines the model)."""

from __future__ import annotations

import dataclasses
import json
import math

import exudyn as exu
import numpy as np
import pytest

from rvflex import catalog
from rvflex.cli import main
from rvflex.contact.tapered_roller import support_rows
from rvflex.engine import compiled_step
from rvflex.geometry.formulas import ARCSEC_PER_RAD
from rvflex.model import build_reducer
from rvflex.options import ModelOptions, SpatialSettings
from rvflex.parts.crankshaft import add_shaft, beam_layout, segment_stiffness, shaft_inertia, shear_coefficient
from rvflex.solve import quasi_static, solve_at, static_settings
from rvflex.spec import SpecError
from rvflex.tilt import MOMENT_SLICES

UNITS = ("rv40e", "rv80e", "rv160n")


def _crank_turn(spec, n: int) -> np.ndarray:
    """``n`` input angles over one crank revolution against the carrier (rad)."""
    return np.linspace(0.0, 2 * math.pi * spec.ratio / spec.cycloid.pin_count, n + 1)[:-1]


def _beam(elements: int = 1) -> ModelOptions:
    return ModelOptions.spatial_rigid(MOMENT_SLICES, SpatialSettings(crank="beam", crank_elements=elements))


@pytest.fixture(scope="module")
def rv40e():
    return catalog.load("rv40e")


# -- the shaft alone against the closed form ------------------------------------------------------------------------

def _solve_shaft(elements: int, held: dict[int, tuple[int, ...]], load_station: int, load: np.ndarray,
                 spin_rad: float = 0.0) -> np.ndarray:
    """A uniform shaft (radius 8 mm, 30 mm, rv40e's crank steel) of ``elements`` equal segments on the axis at
    (36, 0) mm, the coordinates ``held[station]`` of some stations held (ψz at ``spin_rad``: the whole shaft turned),
    the force and moment ``load`` (6,) on one station; Exudyn's static solution of that station's six coordinates."""
    from exudyn.itemInterface import (
        CoordinateConstraint,
        LoadForceVector,
        LoadTorqueVector,
        MarkerNodeCoordinate,
        MarkerNodeRigid,
        NodePointGround,
    )

    material = catalog.load("rv40e").materials.gears_cranks_discs
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()), coordinate=0))
    z = np.linspace(0.0, 0.03, elements + 1)
    shaft = add_shaft(mbs, (0.036, 0.0), z, np.full(elements, 0.008), material)
    for station, coords in held.items():
        for c in coords:
            m = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=shaft.nodes[station], coordinate=c))
            mbs.AddObject(CoordinateConstraint(markerNumbers=[ground, m], offset=spin_rad if c == 5 else 0.0))
    tip = mbs.AddMarker(MarkerNodeRigid(nodeNumber=shaft.nodes[load_station]))
    mbs.AddLoad(LoadForceVector(markerNumber=tip, loadVector=list(load[:3])))
    mbs.AddLoad(LoadTorqueVector(markerNumber=tip, loadVector=list(load[3:])))
    mbs.Assemble()
    start = np.zeros(mbs.systemData.ODE2Size())
    start[5::6] = spin_rad  # every station turned alike
    mbs.systemData.SetODE2Coordinates(start, configuration=exu.ConfigurationType.Initial)
    ss = exu.SimulationSettings()
    ss.staticSolver.verboseMode = 0
    ss.staticSolver.newton.relativeTolerance = 1e-12
    ss.staticSolver.newton.absoluteTolerance = 1e-7  # above the round-off of 1e10 N/m springs at 36 mm (~1e-8 N)
    ss.linearSolver.solverType = exu.LinearSolverType.EXUdense
    ss.solution.file.write = False
    mbs.SolveStatic(ss)
    i = mbs.GetNodeODE2Index(shaft.nodes[load_station])
    q = np.asarray(mbs.systemData.GetODE2Coordinates())[i:i + 6].copy()
    q[5] -= spin_rad
    return q


@pytest.mark.parametrize("elements", [1, 3])
@pytest.mark.parametrize("spin_rad", [0.0, 1.3])
def test_the_station_chain_is_the_timoshenko_cantilever(elements, spin_rad):
    """A uniform shaft clamped at one end, loaded at the other: tip deflection PL³/(3EI) + PL/(κGA) and slope
    PL²/(2EI) under a lateral force (x and y), ML/(EI) and ML²/(2EI) under a bending moment, TL/(GJ) under a torque,
    NL/(EA) under an axial force, each to 1e-9 relative, in one segment or three (prismatic: the mid-point springs
    are the element's exact static stiffness, so subdividing changes nothing), and with the shaft turned by
    1.3 rad about its axis (the section is axisymmetric; the springs see the stations' relative motion). Loads of
    10 N and 0.1 N·m keep the geometric nonlinearity (the slope squared, ~1e-11) below the tolerance."""
    e, nu = 2.07e11, 0.254
    g = e / (2 * (1 + nu))
    r, length = 0.008, 0.03
    area, inertia = math.pi * r**2, math.pi * r**4 / 4
    kga = shear_coefficient(nu) * g * area
    clamp = {0: (0, 1, 2, 3, 4, 5)}
    p, m = 10.0, 0.1
    cases = [  # load (6,), the tip's expected (6,) coordinates (m, rad)
        ([p, 0, 0, 0, 0, 0], [p * length**3 / (3 * e * inertia) + p * length / kga, 0, 0, 0,
                              p * length**2 / (2 * e * inertia), 0]),
        ([0, p, 0, 0, 0, 0], [0, p * length**3 / (3 * e * inertia) + p * length / kga, 0,
                              -p * length**2 / (2 * e * inertia), 0, 0]),
        ([0, 0, 0, 0, m, 0], [m * length**2 / (2 * e * inertia), 0, 0, 0, m * length / (e * inertia), 0]),
        ([0, 0, 0, 0, 0, m], [0, 0, 0, 0, 0, m * length / (g * 2 * inertia)]),
        ([0, 0, p, 0, 0, 0], [0, 0, p * length / (e * area), 0, 0, 0]),
    ]
    for load, expected in cases:
        q = _solve_shaft(elements, clamp, elements, np.array(load, float), spin_rad)
        expected = np.array(expected)
        scale = np.abs(expected).max()
        for c in np.flatnonzero(expected):
            assert q[c] == pytest.approx(expected[c], rel=1e-9), (load, c)
        assert np.abs(q[expected == 0.0]).max() < 1e-6 * scale, load  # second order: the slope (7e-6) times it


@pytest.mark.parametrize("elements", [2, 4])
def test_the_station_chain_is_the_simply_supported_timoshenko_shaft(elements):
    """Pinned at both ends (the ends' slopes free), a force at mid-span: deflection PL³/(48EI) + PL/(4κGA) there
    to 1e-9 relative and no slope (symmetry)."""
    e, nu = 2.07e11, 0.254
    g = e / (2 * (1 + nu))
    r, length, p = 0.008, 0.03, 10.0
    area, inertia = math.pi * r**2, math.pi * r**4 / 4
    q = _solve_shaft(elements, {0: (0, 1, 2, 5), elements: (0, 1)}, elements // 2, np.array([p, 0, 0, 0, 0, 0]))
    expected = p * length**3 / (48 * e * inertia) + p * length / (4 * shear_coefficient(nu) * g * area)
    assert q[0] == pytest.approx(expected, rel=1e-9)
    assert abs(q[4]) < 1e-9 * expected / length


def test_segment_stiffness_and_station_masses():
    """The spring is the series of bending and shear lateral compliance, L³/(12EI) + L/(κGA); a shaft's stations
    carry its whole mass, and its transverse inertia about the stations sums to the cylinders' about their own ends
    (the halves of each segment)."""
    material = catalog.load("rv40e").materials.gears_cranks_discs
    e, nu = material.youngs_modulus_Pa, material.poisson_ratio
    g = e / (2 * (1 + nu))
    r, length = 0.0095, 0.011
    k = segment_stiffness(material, r, length)
    lateral = 1.0 / (length**3 / (12 * e * math.pi * r**4 / 4) + length / (shear_coefficient(nu) * g * math.pi * r**2))
    assert k[0] == k[1] == pytest.approx(lateral, rel=1e-12)
    assert k[3] == k[4] and k[5] == pytest.approx(k[3] / (1 + nu), rel=1e-12)  # GJ = EI/(1 + ν)
    z, radius = [0.0, 0.004, 0.011], [0.008, 0.0095]
    mass, ixx, izz = shaft_inertia(z, radius, material.density_kg_m3)
    total = material.density_kg_m3 * math.pi * (0.008**2 * 0.004 + 0.0095**2 * 0.007)
    assert mass.sum() == pytest.approx(total, rel=1e-12) and np.all(ixx > 0) and np.all(izz > 0)


# -- the crank's layout ----------------------------------------------------------------------------------------------

def test_the_beam_layout_of_the_rv40e(rv40e):
    """Stations at the gear (−29.5 mm), the input support's pressure centre, the disc stack's faces (∓10.5), the
    eccentrics (∓5.5) and the output support's pressure centre; the stack at the eccentric journal's 9.5 mm, the
    rest at the support journal's 8 mm; two elements halve every segment, the key stations keep their planes.

    The pressure centres: the rows' mid-planes at ±16.5 mm, each centre r_c·tan α outboard, r_c = (16 + 35)/4 mm
    + 2.5 mm·cos 15° the cup's radius at mid-roller (the spec's 16/35 mm bearing, 5 mm rollers, 15°)."""
    alpha = math.radians(15.0)
    h = 0.0165 + (0.01275 + 0.0025 * math.cos(alpha)) * math.tan(alpha)
    one = beam_layout(rv40e)
    assert np.allclose(one.station_z_m, [-0.0295, -h, -0.0105, -0.0055, 0.0055, 0.0105, h], rtol=0.0, atol=1e-12)
    assert one.segment_radius_m == (0.008, 0.008, 0.0095, 0.0095, 0.0095, 0.008)
    assert (one.gear, one.input_support, one.eccentrics, one.output_support) == (0, 1, (3, 4), 6)
    two = beam_layout(rv40e, 2)
    assert len(two.station_z_m) == 13 and two.segment_radius_m[::2] == one.segment_radius_m
    for key in ("gear", "input_support", "output_support"):
        assert two.station_z_m[getattr(two, key)] == pytest.approx(one.station_z_m[getattr(one, key)], abs=1e-15)
    assert [two.station_z_m[j] for j in two.eccentrics] == pytest.approx([-0.0055, 0.0055], abs=1e-15)


def test_a_beam_model_is_a_station_chain_per_crank(rv40e):
    """Every crank a chain of station bodies; its node (``crank{k}`` of the spatial index, the gear mesh's planet)
    the gear's station; the ideal kinematics place and turn every station with it; the compiled step takes the
    model (tests/test_engine_spatial.py); held out of plane, every station's z, ψx, ψy are held."""
    model = build_reducer(rv40e, options=_beam(2), hold_out_of_plane=True)
    layout = model.cranks.beam
    assert layout == beam_layout(rv40e, 2) and compiled_step(model) is not None
    idx = model.spatial_index()
    for k, shaft in enumerate(model.cranks.stations):
        assert len(shaft) == 13 and len(model.cranks.segments[k]) == 12
        assert model.cranks.nodes[k] == shaft[layout.gear] == model.cranks.meshes[k].planet_node
        assert idx[f"crank{k}"][0] == model.mbs.GetNodeODE2Index(shaft[layout.gear])
        q = model.kinematic_coordinates(0.7)
        for node in shaft:
            i = model.mbs.GetNodeODE2Index(node)
            assert np.array_equal(q[[i, i + 1, i + 5]], q[idx[f"crank{k}"][[0, 1, 5]]])
    quasi_static(model, np.zeros(1), rv40e.rated_torque_Nm)
    q = np.asarray(model.mbs.systemData.GetODE2Coordinates())
    for node in (n for shaft in model.cranks.stations for n in shaft):
        i = model.mbs.GetNodeODE2Index(node)
        assert np.abs(q[i + 2:i + 5]).max() < 1e-18  # held, to the constraints' round-off (free: ~1e-5)


# -- the beam crank in the reducer -----------------------------------------------------------------------------------

def _shaft_energy(spec, loads: list[tuple[float, np.ndarray]], torques: list[tuple[float, float]]) -> float:
    """Complementary energy (J) of one crank as a simply supported Timoshenko shaft on its two support bearings'
    pressure centres (the beam layout's radii) under in-plane forces (z, (Fx, Fy)) at the eccentrics and the gear,
    and its twist under the torques (z, T) that leave it there, carried from the gear's plane."""
    mat = spec.materials.gears_cranks_discs
    e, nu = mat.youngs_modulus_Pa, mat.poisson_ratio
    g = e / (2 * (1 + nu))
    layout = beam_layout(spec)
    z_st, r_seg = np.array(layout.station_z_m), np.array(layout.segment_radius_m)
    half = support_rows(spec).half_span_m  # the supports where they carry: the rows' pressure centres
    edges = np.linspace(z_st[0], z_st[-1], 40001)
    z = 0.5 * (edges[1:] + edges[:-1])
    dz = edges[1] - edges[0]
    r = r_seg[np.clip(np.searchsorted(z_st, z) - 1, 0, len(r_seg) - 1)]
    inertia, area = math.pi * r**4 / 4, math.pi * r**2
    energy = 0.0
    for c in range(2):
        right = -sum(f[c] * (zi + half) for zi, f in loads) / (2 * half)  # the supports' reactions
        pts = [(zi, f[c]) for zi, f in loads] + [(-half, -sum(f[c] for _, f in loads) - right), (half, right)]
        shear = sum(np.where(z > zi, f, 0.0) for zi, f in pts)
        moment = sum(np.where(z > zi, f * (z - zi), 0.0) for zi, f in pts)
        energy += np.sum(moment**2 / (2 * e * inertia) + shear**2 / (2 * shear_coefficient(nu) * g * area)) * dz
    gear = spec.cranks.gear_axial_position_m
    twist = sum(np.where((z > min(gear, zi)) & (z < max(gear, zi)), t, 0.0) for zi, t in torques)
    return energy + np.sum(twist**2 / (2 * g * 2 * inertia)) * dz


def _windup_estimate(model) -> float:
    """The wind-up (rad) a flexible shaft adds to a rigid crank's solved state, to first order in its compliance:
    with the loads held, the work of the output torque on the added wind-up equals twice the shafts' complementary
    energy (Castigliano), Δθ = 2 Σ U / T."""
    from exudyn.rigidBodyUtilities import RotXYZ2RotationMatrix

    mbs, spec = model.mbs, model.spec
    q = np.asarray(mbs.systemData.GetODE2Coordinates()) + model.reference
    carrier = mbs.GetNodeODE2Index(model.carrier.node)
    total = 0.0
    for k in range(spec.cranks.count):
        loads, torques = [], []
        for d in range(len(model.discs.nodes)):
            force = np.asarray(mbs.GetObjectOutput(model.discs.eccentric_bearings[d][k].bearing.connector,
                                                   exu.OutputVariableType.ForceLocal))
            marker = mbs.GetMarker(model.cranks.eccentric_markers[k][d])
            i = mbs.GetNodeODE2Index(mbs.GetObject(marker["bodyNumber"])["nodeNumber"])
            rot = RotXYZ2RotationMatrix(q[i + 3:i + 6])
            f = (rot @ force)[:2]  # on the crank, in the housing frame
            arm = (rot @ np.r_[np.asarray(marker["localPosition"])[:2], 0.0])[:2]
            z = float(marker["localPosition"][2])
            loads.append((z, f))
            torques.append((z, arm[0] * f[1] - arm[1] * f[0]))
        # the gear's mesh force closes the crank's balance with the support bearings' (on the crank: minus the
        # connector's force, whose marker 0 is the carrier's seat)
        support = sum(-(RotXYZ2RotationMatrix(q[carrier + 3:carrier + 6])
                        @ np.asarray(mbs.GetObjectOutput(pair.bearing.connector,
                                                         exu.OutputVariableType.ForceLocal)))[:2]
                      for pair in (model.cranks.supports[k], model.cranks.input_supports[k]))
        loads.append((spec.cranks.gear_axial_position_m, -(sum(f for _, f in loads) + support)))
        total += _shaft_energy(spec, loads, torques)
    return 2.0 * total / spec.rated_torque_Nm


def _stiffened(model, factor: float) -> None:
    """Scale every beam segment's stiffness of ``model`` by ``factor`` (a test hook on the built system)."""
    for seg in (s for row in model.cranks.segments for s in row):
        model.mbs.SetObjectParameter(seg, "stiffness", factor * np.asarray(model.mbs.GetObjectParameter(seg,
                                                                                                      "stiffness")))


def _stiff_te(model, th: np.ndarray, torque: float, factor: float) -> np.ndarray:
    """TE (rad) of a beam model with its segments ``factor`` times stiffer, each position solved by Exudyn's static
    solver from the unstiffened model's loaded first pose. Its absolute residual tolerance is 0.1 N instead of 1e-6 N:
    springs of 1e15 N/m leave ~1e-3 N of round-off in the residual (position round-off 7e-18 m at 50 mm), forces
    internal to each crank that move its stations apart by 1e-18 m, not the output."""
    quasi_static(model, th[:1], torque)
    q = np.asarray(model.mbs.systemData.GetODE2Coordinates()) + model.reference
    _stiffened(model, factor)
    ss = static_settings()
    ss.staticSolver.newton.absoluteTolerance = 0.1
    ss.staticSolver.useLoadFactor = False
    te, prev = [], th[0]
    for t in th:
        q = solve_at(model, ss, t, q + model.kinematic_coordinates(t) - model.kinematic_coordinates(prev))
        te.append(q[model.output_index] - t / model.ratio)
        prev = t
    return np.array(te)


@pytest.mark.parametrize("unit", UNITS)
def test_the_beam_adds_the_windup_its_bending_and_twist_predict(unit):
    """At rated torque (8 positions over a crank revolution) every built-in unit builds and solves with beam cranks,
    and winds up more than with rigid ones by what the shafts' compliance predicts.

    The estimate: each crank a simply supported Timoshenko shaft on its support journals (the beam layout's radii)
    under the rigid model's solved eccentric loads, twisted by their torques from the gear's plane; the work of the
    output torque on the added wind-up is twice the shafts' complementary energy, Δθ = 2ΣU/T. RV-40E: the eccentric
    loads 4.8 and 0.7 kN (the heavily loaded disc's on one crank, the other's on the other) bend its 8–9.5 mm shaft
    between its support rows' pressure centres 41 mm apart: 47.9″ of wind-up; 50.9″ RV-80E (its 7.5 mm support
    journals), 29.0″ RV-160N.

    Asserted: (1) to first order in the compliance the model is that estimate: with the shafts 1e5 times stiffer the
    added wind-up times 1e5 is the estimate within 1 % (measured 0.13 %, 0.48 % below and 0.36 % above it: the
    support rows' own tilt stiffness and the eccentric bearings', which the estimate leaves out). The gear's mesh
    force belongs in it: it is 4 % of the eccentric loads (0.2 of 5.5 kN on the RV-40E), but overhung outboard of
    the input support it bends the whole span, and without it the estimate is 3–5 % high. (2) At the real stiffness
    the model adds 0.9 to 1.0 times the estimate (measured 46.8″, 50.2″, 28.8″: 0.977, 0.987, 0.993): with fixed
    loads the estimate bounds the added compliance from above (the minimum of complementary energy, for a linear
    train), and the model moves load away from the softened path."""
    spec = catalog.load(unit)
    th = _crank_turn(spec, 8)
    torque = spec.rated_torque_Nm
    rigid_model = build_reducer(spec, options=ModelOptions.spatial_rigid(MOMENT_SLICES))
    rigid, estimate = np.empty(len(th)), np.empty(len(th))
    for j, t in enumerate(th):  # each pose solved from its own continuation: the loads of that pose
        rigid[j] = quasi_static(rigid_model, np.array([t]), torque).te_rad[0]
        estimate[j] = _windup_estimate(rigid_model)
    beam = quasi_static(build_reducer(spec, options=_beam()), th, torque).te_rad
    added = -(beam - rigid)  # the TE is negative: wind-up against the torque
    assert np.all(np.isfinite(beam))
    factor = 1e5
    first_order = -(_stiff_te(build_reducer(spec, options=_beam()), th, torque, factor) - rigid) * factor
    assert first_order.mean() == pytest.approx(estimate.mean(), rel=0.01), (first_order.mean(), estimate.mean())
    ratio = added.mean() / estimate.mean()
    assert 0.9 < ratio < 1.0, (ratio, added.mean() * ARCSEC_PER_RAD, estimate.mean() * ARCSEC_PER_RAD)


def test_a_very_stiff_beam_is_the_rigid_crank(rv40e):
    """The RV-40E's beam cranks with every segment 1e5 times stiffer give the rigid cranks' TE within 1e-3″ over
    32 positions of a crank revolution at rated torque (what is left, 4.8e-4″ measured, is the 47″ the real shafts'
    compliance adds, over 1e5)."""
    th = _crank_turn(rv40e, 32)
    rigid = quasi_static(build_reducer(rv40e, options=ModelOptions.spatial_rigid(MOMENT_SLICES)), th,
                         rv40e.rated_torque_Nm).te_rad
    stiff = _stiff_te(build_reducer(rv40e, options=_beam()), th, rv40e.rated_torque_Nm, 1e5)
    assert np.abs(stiff - rigid).max() * ARCSEC_PER_RAD < 1e-3


def test_more_elements_leave_the_static_te_alone(rv40e):
    """1, 2 and 4 elements per segment: the same TE within 3e-4″ over 32 positions at rated torque (measured 1.2e-4″).
    The segments are prismatic, so their linear laws are the same stiffness cut anywhere; what differs is the
    chain's geometry to second order in the stations' slopes (4e-4 rad): without the rows' geometry (the supports at
    the bearings' mid-planes, 33 mm apart), which bends the shafts half as far, it is 3e-5″, a quarter."""
    th = _crank_turn(rv40e, 32)
    te = [quasi_static(build_reducer(rv40e, options=_beam(n)), th, rv40e.rated_torque_Nm).te_rad for n in (1, 2, 4)]
    for other in te[1:]:
        assert np.abs(other - te[0]).max() * ARCSEC_PER_RAD < 3e-4


# -- bad input -------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("field", ["support_journal_radius_m", "gear_axial_position_m", "support_span_m"])
def test_a_spec_without_what_the_beam_needs_is_refused_in_one_line(rv40e, field):
    spec = dataclasses.replace(rv40e, cranks=dataclasses.replace(rv40e.cranks, **{field: None}))
    with pytest.raises(SpecError) as info:
        build_reducer(spec, options=_beam())
    assert info.value.field == f"cranks.{field}" and "\n" not in str(info.value)
    if field != "support_span_m":  # (the span: the spatial model's own check names it first)
        assert "which options.spatial.crank = 'beam' needs" in str(info.value)
    build_reducer(spec if field != "support_span_m" else rv40e, options=ModelOptions.spatial_rigid())  # rigid: fine


@pytest.mark.parametrize("elements", [0, 65, True, 2.0])
def test_crank_elements_outside_1_to_64_are_refused(rv40e, elements):
    with pytest.raises(SpecError, match="crank_elements = .*: must be an integer from 1 to 64"):
        SpatialSettings(crank="beam", crank_elements=elements)
    with pytest.raises(SpecError, match="crank_elements = .*: must be an integer from 1 to 64"):
        beam_layout(rv40e, elements)


# -- the command line ------------------------------------------------------------------------------------------------

def test_te_with_beam_cranks_from_the_command_line(tmp_path, capsys):
    """``--spatial --crank beam`` winds the RV-40E up ~47″ more than ``--spatial`` alone (32 positions)."""
    runs = {}
    for name, extra in (("rigid", []), ("beam", ["--crank", "beam", "--crank-elements", "2"])):
        code = main(["te", "--reducer", "rv40e", "--spatial", "--positions", "32", "--json",
                     str(tmp_path / f"{name}.json"), *extra])
        assert code == 0
        runs[name] = json.loads((tmp_path / f"{name}.json").read_text())
    added = runs["beam"]["mean_windup_arcsec"] - runs["rigid"]["mean_windup_arcsec"]
    assert -50.0 < added < -43.0, added


@pytest.mark.parametrize("command", [["lost-motion", "--steps", "40"], ["backlash"]])
def test_lost_motion_and_backlash_take_beam_cranks(tmp_path, command):
    assert main([*command, "--reducer", "rv40e", "--spatial", "--crank", "beam", "--json",
                 str(tmp_path / "r.json")]) == 0


@pytest.mark.parametrize("argv, message", [
    (["--crank", "beam"], "--crank = 'beam': applies to the spatial model only (add --spatial)"),
    (["--crank", "rigid", "--crank-elements", "2"], "--crank = 'rigid': applies to the spatial model only"),
    (["--spatial", "--crank-elements", "2"], "--crank-elements = 2: applies to --crank beam only"),
    (["--spatial", "--crank", "beam", "--crank-elements", "0"], "--crank-elements = 0: must be an integer from 1 "
                                                                "to 64"),
])
def test_crank_flags_without_their_model_are_a_one_line_error(tmp_path, capsys, argv, message):
    code = main(["te", "--reducer", "rv40e", "--positions", "32", "--out", str(tmp_path / "o"), *argv])
    assert code == 2
    err = capsys.readouterr().err
    assert message in " ".join(err.split()) and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_the_convergence_scenario_runs_and_writes_its_table():
    """``python -m rvflex.scenarios.spatial_convergence`` at a short duration (16 positions, a few rows): every row
    solves (the rigid crank row run for it: no 4-slice row), the beam adds its wind-up and more elements none, the
    segments are listed."""
    from rvflex.scenarios.spatial_convergence import convergence_study, table

    study = convergence_study("rv40e", 16, slices=(2,), elements=(1, 2))
    rows = study["slices"] + study["cranks"]
    assert len(rows) == 4 and all("error" not in r for r in rows)
    rigid, one, two = study["cranks"]
    assert one["mean_windup_arcsec"] - rigid["mean_windup_arcsec"] > 15.0
    assert abs(two["mean_windup_arcsec"] - one["mean_windup_arcsec"]) < 1e-4
    assert 10.0 < rigid["crank_tilt_arcsec"] < 100.0
    text = table([study])
    assert "| beam cranks, 2 element(s)/segment, 4 slices |" in text and "| gear – input support |" in text

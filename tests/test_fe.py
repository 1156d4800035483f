"""FE reduction of the flexible parts: geometry, Craig–Bampton basis, static accuracy, cache.

The fast tier reduces one coarse RV-40E disc (linear tets, maxh 8 mm) once per module; the
full-size default reductions (quadratic tets) and the CLI run are also marked ``slow``.
"""

from __future__ import annotations

import dataclasses
import json
import math
import multiprocessing as mp
import time

import numpy as np
import pytest

from rvflex.catalog import load as load_reducer
from rvflex.spec import ErrorSpec, SpecError

pytestmark = pytest.mark.flexible

COARSE = {"maxh_m": 8e-3, "n_modes": 6, "mesh_order": 1, "attach_per_tooth": 2, "patch_half_width_m": 3e-3,
          "curvature_safety": 1.0, "attach_tangential": True}


@pytest.fixture(scope="module")
def spec():
    return load_reducer("rv40e")


@pytest.fixture(scope="module")
def cache_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("fe-cache")


@pytest.fixture(scope="module")
def disc(spec, cache_dir):
    from rvflex.fe.reduce import reduce_part

    return reduce_part(spec, "disc", cache_dir=cache_dir, **COARSE)


# --------------------------------------------------------------------------- geometry


def test_outline_spline_within_1um_of_exact_profile(spec):
    """The OCC outline (spline through 96 exact points per tooth) stays within 1 µm of the
    exact modified profile; 16 points per tooth would not (the check can fail)."""
    from rvflex.fe.geometry import SAMPLES_PER_TOOTH, spline_deviation_m
    from rvflex.geometry.profile import build_profile

    prof = build_profile(spec.cycloid)
    assert spline_deviation_m(prof, SAMPLES_PER_TOOTH) < 1e-6
    assert spline_deviation_m(prof, 16) > 1e-6


def test_flank_nodes_lie_on_exact_profile(disc, spec):
    """Every flank mesh node is on the exact profile to < 1 µm (same body frame, same angular
    origin as the contact element's profile)."""
    from rvflex.fe.reduce import _nodeset
    from rvflex.geometry.profile import build_profile

    nodes = _nodeset(disc.fem, "flank")
    xy = disc.node_positions_m[nodes, :2]
    g = build_profile(spec.cycloid).gap(xy, np.zeros(len(xy)))
    assert np.abs(g.gap_m).max() < 1e-6
    z = disc.node_positions_m[nodes, 2]
    assert z.min() == pytest.approx(-spec.cycloid.disc_thickness_m / 2, abs=1e-9)
    assert z.max() == pytest.approx(spec.cycloid.disc_thickness_m / 2, abs=1e-9)


def test_rv80e_default_disc_mesh_flank_nodes_all_solve():
    """The mesh of issue 24: the RV-80E disc at the flexible preset's maxh 6 mm, quadratic tets
    (2936 flank nodes). Its flank nodes within 37 µm of a tooth tip defeated the closest-point
    cold start (7 did not converge: "Craig–Bampton reduction of the disc ... failed"); every one
    solves now, on the exact profile to < 1 µm (docs/fe.md, "Flank nodes and the closest-point solve")."""
    import ngsolve as ngs
    from exudyn.FEM import FEMinterface
    from netgen.occ import OCCGeometry

    from rvflex.fe.couplings import boundary_node_sets
    from rvflex.fe.geometry import disc_geometry
    from rvflex.fe.loads import flank_of
    from rvflex.fe.reduce import DEFAULTS
    from rvflex.geometry.profile import build_profile

    rv80 = load_reducer("rv80e")
    s = DEFAULTS["disc"]
    mesh = ngs.Mesh(OCCGeometry(disc_geometry(rv80).shape).GenerateMesh(maxh=s.maxh_m, curvaturesafety=s.curvature_safety))
    fem = FEMinterface()
    m = rv80.materials.gears_cranks_discs
    fem.ImportMeshFromNGsolve(mesh, density=m.density_kg_m3, youngsModulus=m.youngs_modulus_Pa,
                              poissonsRatio=m.poisson_ratio, meshOrder=s.mesh_order, createBoundaryNodeSets=False)
    fem.nodeSets = boundary_node_sets(mesh, fem)
    profile = build_profile(rv80.cycloid)
    flank = flank_of(mesh, fem, profile, s.mesh_order)  # raised "did not converge for 7 of 2936" before the fix
    assert flank.nodes.size > 2000
    g = profile.gap(fem.GetNodePositionsAsArray()[flank.nodes, :2], np.zeros(flank.nodes.size), t_init=flank.t)
    assert np.abs(g.gap_m).max() < 1e-6


def test_bore_interfaces_where_the_model_puts_the_bores(disc, spec):
    """Bore interfaces sit where parts/cycloid_disc.bore_positions puts the rigid model's
    bore markers: the mesh nodes of each bore lie on the nominal cylinder (radius to 1 µm)
    and the RBE weights' centroid is the nominal centre (to 1 nm)."""
    from rvflex.parts.cycloid_disc import bore_positions

    bores = bore_positions(spec, ErrorSpec(), 0)
    for k in range(spec.cranks.count):
        itf = disc.interface(f"bore{k}")
        x = disc.node_positions_m[itf.nodes]
        r = np.linalg.norm(x[:, :2] - bores[k], axis=1)
        np.testing.assert_allclose(r, spec.cranks.disc_bore_radius_m, atol=1e-6)
        np.testing.assert_allclose(itf.weights @ x, [bores[k, 0], bores[k, 1], 0.0], atol=1e-9)
        assert itf.weights.min() > 0 and itf.weights.sum() == pytest.approx(1.0)


def test_bore_breaking_the_outline_is_refused_before_meshing(spec):
    from rvflex.fe.reduce import reduce_part

    bad = dataclasses.replace(spec, cranks=dataclasses.replace(spec.cranks, disc_bore_radius_m=0.027))
    t0 = time.perf_counter()
    with pytest.raises(SpecError, match="breaks the disc outline"):
        reduce_part(bad, "disc", use_cache=False, **COARSE)
    assert time.perf_counter() - t0 < 10.0


def test_oversized_mesh_and_mode_count_refused_with_estimate(spec):
    from rvflex.fe.reduce import reduce_part

    with pytest.raises(SpecError, match=r"GiB"):
        reduce_part(spec, "carrier", maxh_m=0.4e-3, use_cache=False)
    with pytest.raises(SpecError, match="resolve"):
        reduce_part(spec, "carrier", maxh_m=8e-3, n_modes=1500, mesh_order=1, use_cache=False)


def test_netgen_failure_names_part_and_settings(spec, netgen_fails):
    """A meshing failure comes back as FEError naming the part, maxh, order and modes."""
    from rvflex.fe.reduce import FEError, reduce_part

    with pytest.raises(FEError, match=r"carrier \(maxh 8 mm, order 1, 6 modes\).*surface meshing failed"):
        reduce_part(spec, "carrier", maxh_m=8e-3, n_modes=6, mesh_order=1, use_cache=False)


def test_a_reduction_failing_in_its_own_process_is_one_line_without_traceback(spec, tmp_path):
    """A pool worker builds in a fresh interpreter (rvflex.fe.isolated); when that build fails, the
    FEError carries the child's one-line error, not its traceback (the report of an RV-80E diagnosis
    used to list 'File "…", line …' fragments of it). A real failure: more modes than the mesh resolves."""
    from rvflex.fe.isolated import build_isolated
    from rvflex.fe.reduce import FEError, settings_for

    s = settings_for("carrier", maxh_m=8e-3, n_modes=1500, mesh_order=1)
    with pytest.raises(FEError) as info:
        build_isolated(spec, "carrier", s, "isolated-failure-test", tmp_path, use_cache=False)
    msg = str(info.value)
    assert "\n" not in msg and "Traceback" not in msg and 'File "' not in msg, msg
    assert "SpecError: n_modes = 1500" in msg and "internal modes exceed what a mesh" in msg, msg


# --------------------------------------------------------------------------- reduction


def test_reduced_flank_response_within_5pct_of_full_fe(disc):
    """Rated torque on ~half the pins, bores held, worst of four disc angles: reduced vs full
    NGSolve static solution at the loaded flank patches < 5 %; bore reactions exact
    (Craig–Bampton statics)."""
    assert disc.n_attach == 2 * 2 * 39 and disc.n_static == 6
    assert disc.check.flank_pct < 5.0
    assert disc.check.interface_pct < 1e-6
    # physical scale: ~1 µm flank displacement for ~400 N pin loads on a 10 mm disc
    assert 0.2e-6 < disc.check.flank_full_m < 5e-6


def test_flank_rows_reproduce_the_full_flank_response(disc, spec):
    """The contact element's path: generalised forces Σ rows(t)ᵀF, internal modes (bores
    held), displacement rows(t)·q along each load — against the full FE maximum."""
    from rvflex.fe.reduce import CHECK_ANGLES_PITCH, disc_rated_load_case
    from rvflex.geometry.profile import build_profile

    t, _pts, forces = disc_rated_load_case(spec, build_profile(spec.cycloid))  # one of the checked angles
    R = disc.flank.rows_at(t)[:, :, disc.n_static:]  # (pins, 2, internal modes)
    Q = np.einsum("pim,pi->m", R, forces)
    Kr = disc.stiffness_reduced[disc.n_static:, disc.n_static:]
    q = np.linalg.solve(Kr, Q)
    d = np.einsum("pim,m,pi->p", R, q, forces / np.linalg.norm(forces, axis=1, keepdims=True))
    i = CHECK_ANGLES_PITCH.index(0.37)  # disc_rated_load_case's default angle
    assert np.max(np.abs(d)) == pytest.approx(disc.check.flank_full_by_angle_m[i], rel=0.05)


def test_internal_block_is_diagonal_and_positive(disc):
    """The Ritz step leaves the internal block of the reduced matrices diagonal."""
    k = disc.stiffness_reduced[disc.n_static:, disc.n_static:]
    m = disc.mass_reduced[disc.n_static:, disc.n_static:]
    off = k - np.diag(np.diag(k))
    assert np.abs(off).max() < 1e-8 * np.abs(np.diag(k)).max()
    assert np.all(np.diag(k) > 0)
    np.testing.assert_allclose(np.diag(m), 1.0, rtol=1e-8)


def test_linear_tets_are_stiffer_than_quadratic_physics(disc, spec):
    """Coarse linear tets lock: the fast tier's first fixed-interface mode lies above the
    quadratic-tet value (3.40 kHz, docs/fe.md) — by less than 2× at maxh 8 mm."""
    assert 3.4e3 < disc.freqs_hz[0] < 6.8e3


# --------------------------------------------------------------------------- cache


def test_cache_hit_returns_the_same_reduction(disc, spec, cache_dir):
    from rvflex.fe.reduce import reduce_part

    t0 = time.perf_counter()
    again = reduce_part(spec, "disc", cache_dir=cache_dir, **COARSE)
    assert time.perf_counter() - t0 < 2.0
    assert again.meta["cached"] is True
    np.testing.assert_array_equal(again.mode_basis, disc.mode_basis)
    np.testing.assert_array_equal(again.stiffness_reduced, disc.stiffness_reduced)
    assert (again.fem.GetStiffnessMatrix(sparse=True) != disc.fem.GetStiffnessMatrix(sparse=True)).nnz == 0
    np.testing.assert_array_equal(again.flank.rows, disc.flank.rows)
    assert [i.name for i in again.interfaces] == ["bore0", "bore1"]
    np.testing.assert_array_equal(again.interface("bore1").nodes, disc.interface("bore1").nodes)


def test_a_cache_file_read_again_is_kept_in_memory_but_never_shared(disc, tmp_path):
    """Every elastic build loads its reduction; the arrays of the file read last are kept (``cache._READ``), each
    load gets its own copies, and a file written again (another size or time) is read again, never the old
    arrays."""
    import os

    from rvflex.fe import cache

    path = cache.store(disc, tmp_path)
    a, b = cache.load(disc.key, tmp_path), cache.load(disc.key, tmp_path)
    assert any(tag[0] == str(path) for tag in cache._READ)
    np.testing.assert_array_equal(a.mode_basis, b.mode_basis)
    a.mode_basis[:] = 0.0  # a caller writing into its arrays changes nobody else's
    np.testing.assert_array_equal(b.mode_basis, disc.mode_basis)
    np.testing.assert_array_equal(cache.load(disc.key, tmp_path).mode_basis, disc.mode_basis)
    st = path.stat()
    raw = bytearray(path.read_bytes())
    raw[len(raw) // 2] ^= 0xFF  # the same size, another time: read again, found damaged, not served from memory
    path.write_bytes(bytes(raw))
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000))
    assert cache.load(disc.key, tmp_path) is None


def test_the_same_disc_at_another_modulus_is_the_cached_one_scaled_not_a_new_mesh(disc, spec, cache_dir):
    """Linear elasticity at a fixed Poisson ratio: K ∝ E while M and the Craig–Bampton basis do not depend
    on E. The disc at 1.7 E is made from the cached one (nothing meshed, nothing written) and agrees with
    one built afresh: frequencies and the flank response under the rated load case within 1e-6 (the
    eigensolver's and the Cholesky's round-off; 1e-6 of a 1 µm flank displacement is 1e-12 m)."""
    from rvflex.fe.reduce import disc_rated_load_case, reduce_part
    from rvflex.geometry.profile import build_profile

    m = spec.materials
    stiffer = dataclasses.replace(spec, materials=dataclasses.replace(m, gears_cranks_discs=dataclasses.replace(
        m.gears_cranks_discs, youngs_modulus_Pa=1.7 * m.gears_cranks_discs.youngs_modulus_Pa)))
    files = sorted(p.name for p in cache_dir.iterdir() if p.suffix == ".rvfe")
    scaled = reduce_part(stiffer, "disc", cache_dir=cache_dir, **COARSE)
    assert scaled.meta["scaled_from"]["key"] == disc.key
    assert scaled.meta["scaled_from"]["modulus_factor"] == pytest.approx(1.7, rel=1e-12)
    assert sorted(p.name for p in cache_dir.iterdir() if p.suffix == ".rvfe") == files
    fresh = reduce_part(stiffer, "disc", use_cache=False, **COARSE)
    assert scaled.key == fresh.key != disc.key
    np.testing.assert_allclose(scaled.freqs_hz, fresh.freqs_hz, rtol=1e-6)
    # the internal modes' signs are the eigensolver's choice: the reduced mass agrees up to them
    np.testing.assert_allclose(np.abs(scaled.mass_reduced), np.abs(fresh.mass_reduced), rtol=1e-6, atol=1e-9)
    k_s, k_f = scaled.fem.GetStiffnessMatrix(sparse=True), fresh.fem.GetStiffnessMatrix(sparse=True)
    assert abs(k_s - k_f).max() < 1e-6 * abs(k_f).max()
    t, _pts, forces = disc_rated_load_case(spec, build_profile(spec.cycloid))
    unit = forces / np.linalg.norm(forces, axis=1, keepdims=True)

    def flank(rp):  # displacement along each pin load (the contact element's path; mode signs cancel)
        R = rp.flank.rows_at(t)[:, :, rp.n_static:]
        q = np.linalg.solve(rp.stiffness_reduced[rp.n_static:, rp.n_static:], np.einsum("pim,pi->m", R, forces))
        return np.einsum("pim,m,pi->p", R, q, unit)

    np.testing.assert_allclose(flank(scaled), flank(fresh), rtol=1e-6, atol=1e-6 * np.abs(flank(fresh)).max())
    np.testing.assert_allclose(flank(scaled), flank(disc) / 1.7, rtol=1e-9, atol=1e-9 * np.abs(flank(disc)).max())


def test_the_same_disc_at_other_moduli_shares_one_ffrf_file(disc, spec, cache_dir):
    """The floating-frame tensors come from the mode basis and the mass matrix, which the modulus leaves
    alone: a part scaled from the cached one uses that one's file (one file for all its moduli, built by
    whichever comes first), with only the reduced stiffness scaled."""
    from rvflex.fe.ffrf import _path, ffrf_interface
    from rvflex.fe.reduce import reduce_part

    def at(factor):
        m = spec.materials
        return reduce_part(dataclasses.replace(spec, materials=dataclasses.replace(m, gears_cranks_discs=dataclasses.replace(
            m.gears_cranks_discs, youngs_modulus_Pa=factor * m.gears_cranks_discs.youngs_modulus_Pa))),
            "disc", cache_dir=cache_dir, **COARSE)

    softer, stiffer = at(0.6), at(2.5)
    assert _path(softer, cache_dir) == _path(stiffer, cache_dir) == _path(disc, cache_dir)
    _path(disc, cache_dir).unlink(missing_ok=True)
    a = ffrf_interface(softer, cache_dir=cache_dir)  # built from the scaled part, stored as the reference's
    files = sorted(p.name for p in cache_dir.iterdir() if p.name.startswith("ffrf-"))
    assert files == [_path(disc, cache_dir).name]
    b, ref = ffrf_interface(stiffer, cache_dir=cache_dir), ffrf_interface(disc, cache_dir=cache_dir)
    assert sorted(p.name for p in cache_dir.iterdir() if p.name.startswith("ffrf-")) == files
    np.testing.assert_allclose(a.stiffnessMatrixReduced, 0.6 * ref.stiffnessMatrixReduced, rtol=1e-12,
                               atol=1e-12 * np.abs(ref.stiffnessMatrixReduced).max())
    np.testing.assert_allclose(b.stiffnessMatrixReduced, 2.5 * ref.stiffnessMatrixReduced, rtol=1e-12,
                               atol=1e-12 * np.abs(ref.stiffnessMatrixReduced).max())
    assert np.array_equal(a.mPsiTildePsi, b.mPsiTildePsi) and np.array_equal(a.massMatrixReduced, ref.massMatrixReduced)


def test_a_modulus_note_whose_reduction_is_gone_is_dropped(spec, tmp_path):
    """A note naming a reduction no longer in the cache scales nothing and is removed, so the next
    reduction built becomes the reference."""
    from rvflex.fe import cache
    from rvflex.fe.reduce import CODE_VERSION, settings_for

    free = cache.modulus_free_key(spec, "disc", settings_for("disc", **COARSE), CODE_VERSION)
    cache.note_modulus(free, "0" * 24, 2.0e11, tmp_path)
    assert [p.name for p in tmp_path.iterdir()] == [f"fe-E-{free}.json"]
    assert cache.load_at_modulus(free, "1" * 24, 3.0e11, "disc", tmp_path) is None
    assert not any(tmp_path.iterdir())


def test_key_depends_on_geometry_material_settings_only(spec):
    from rvflex.fe import cache
    from rvflex.fe.reduce import CODE_VERSION, settings_for

    s = settings_for("disc", **COARSE)
    k = cache.key_for(spec, "disc", s, CODE_VERSION)
    stiffer = dataclasses.replace(spec, bearings=dataclasses.replace(
        spec.bearings, eccentric=dataclasses.replace(spec.bearings.eccentric, radial_stiffness_N_m=1e9)))
    assert cache.key_for(stiffer, "disc", s, CODE_VERSION) == k  # bearing data: same body
    thicker = dataclasses.replace(spec, cycloid=dataclasses.replace(spec.cycloid, disc_thickness_m=0.012))
    assert cache.key_for(thicker, "disc", s, CODE_VERSION) != k
    assert cache.key_for(spec, "disc", dataclasses.replace(s, n_modes=7), CODE_VERSION) != k
    assert cache.key_for(spec, "disc", s, CODE_VERSION + "x") != k


@pytest.mark.parametrize("damage", ["flip", "truncate", "header"])
def test_corrupt_or_partial_file_is_rebuilt_never_loaded(disc, tmp_path, damage, monkeypatch):
    from rvflex.fe import cache, reduce

    path = cache.store(disc, tmp_path)
    raw = bytearray(path.read_bytes())
    if damage == "flip":
        raw[len(raw) // 2] ^= 0xFF
    elif damage == "truncate":
        raw = raw[: len(raw) * 2 // 3]
    else:
        raw[:10] = b"garbage!!!"
    path.write_bytes(bytes(raw))
    assert cache.load(disc.key, tmp_path) is None
    assert not path.exists()  # removed, so the next call rebuilds it
    # reduce_part rebuilds (the builder is called) and stores a good file again
    calls = []

    def builder(spec, part, s, key, progress=None):
        calls.append(key)
        return disc

    monkeypatch.setattr(reduce, "_build", builder)
    path.write_bytes(bytes(raw))
    spec = load_reducer("rv40e")
    reduce.reduce_part(spec, "disc", cache_dir=tmp_path, **COARSE)
    assert calls == [disc.key]
    assert cache.load(disc.key, tmp_path) is not None


def _writer(src_dir: str, dst_dir: str, key: str, n: int) -> None:
    from rvflex.fe import cache

    rp = cache.load(key, src_dir)
    for _ in range(n):
        cache.store(rp, dst_dir)


def test_two_processes_writing_the_same_key(disc, cache_dir, tmp_path):
    """Concurrent writers of one key never leave a corrupt file or temporary files."""
    from rvflex.fe import cache

    ctx = mp.get_context("spawn")
    procs = [ctx.Process(target=_writer, args=(str(cache_dir), str(tmp_path), disc.key, 4)) for _ in range(2)]
    for p in procs:
        p.start()
    seen_valid = 0
    while any(p.is_alive() for p in procs):  # a reader during the writes sees a complete file or none
        if cache.path_for(disc.key, tmp_path).exists():
            rp = cache.load(disc.key, tmp_path)
            if rp is not None:
                seen_valid += 1
                np.testing.assert_array_equal(rp.mode_basis[:, :3], disc.mode_basis[:, :3])
        time.sleep(0.2)
    for p in procs:
        p.join()
        assert p.exitcode == 0
    assert cache.load(disc.key, tmp_path) is not None
    assert not list(tmp_path.glob(".*.tmp"))


# --------------------------------------------------------------------------- full size


@pytest.fixture(scope="module")
def flank_basis_disc(spec, tmp_path_factory):
    """The quadratic-tet disc with flank attachment modes (DISC_FLANK_BASIS: the basis the static
    flank check is about; the model's default disc, DEFAULTS["disc"], has none)."""
    from rvflex.fe.reduce import DISC_FLANK_BASIS, reduce_part

    return reduce_part(spec, "disc", cache_dir=tmp_path_factory.mktemp("fe-default"),
                       **dataclasses.asdict(DISC_FLANK_BASIS))


@pytest.mark.slow
def test_free_free_frequency_near_plate_estimate(flank_basis_disc, spec):
    """First elastic free–free mode of the flank-basis (quadratic-tet) disc vs a free Kirchhoff
    plate with 2 nodal diameters (λ² = 5.25, Leissa): f = λ²/(2πa²)·√(D/ρh), a = r_p − r_rp
    ≈ 3.2 kHz. The holes (−15 % of the area, at the crank circle) and the teeth move it:
    accepted 0.75–1.25 × the estimate."""
    from rvflex.fe.reduce import free_free_frequencies_hz

    cy, m = spec.cycloid, spec.materials.gears_cranks_discs
    h, a = cy.disc_thickness_m, cy.pin_circle_radius_m - cy.pin_radius_m
    D = m.youngs_modulus_Pa * h**3 / (12 * (1 - m.poisson_ratio**2))
    f_plate = 5.25 / (2 * math.pi * a**2) * math.sqrt(D / (m.density_kg_m3 * h))
    f = free_free_frequencies_hz(flank_basis_disc, 4)
    assert 0.75 * f_plate < f[0] < 1.25 * f_plate


@pytest.mark.slow
def test_flank_basis_disc_mass_and_flank_error(flank_basis_disc, spec):
    """Quadratic (curved) tets: FE mass = ρ·(exact profile area − holes)·T to 0.1 %; flank error ≤ 5 %."""
    from rvflex.fe.geometry import disc_geometry

    M = flank_basis_disc.fem.GetMassMatrix(sparse=True)
    ones = np.zeros(M.shape[0])
    ones[0::3] = 1.0
    vol = disc_geometry(spec).volume_m3
    assert ones @ (M @ ones) == pytest.approx(spec.materials.gears_cranks_discs.density_kg_m3 * vol, rel=1e-3)
    assert flank_basis_disc.check.flank_pct <= 5.0


@pytest.mark.slow
@pytest.mark.parametrize("part", ["disc", "carrier"])
def test_cli_reduce_quadratic_settings(part, tmp_path, capsys):
    """The quadratic-tet reductions through ``rvflex reduce`` (carrier: its default; disc: the
    flank basis, ``--modes 10 --attach 2``, as the default disc has no flank attachment modes):
    JSON keys, flank (pillar) error ≤ 5 % (carrier: seats too), first fixed-interface mode in the
    kHz range (carrier: above 300 Hz); the warm run is a cache hit within 2 s."""
    from rvflex.cli import main

    out = tmp_path / "r.json"
    args = ["reduce", "--reducer", "rv40e", "--part", part, "--json", str(out), "--cache-dir", str(tmp_path)]
    if part == "disc":
        args += ["--modes", "10", "--attach", "2"]
    assert main(args) == 0
    doc = json.loads(out.read_text())
    assert set(doc) == {"n_nodes", "n_modes", "freqs_hz", "static_error_pct", "wall_s", "cached"}
    assert doc["cached"] is False
    assert doc["static_error_pct"]["flank"] <= 5.0
    # carrier: only the output face is held (distributing seats), so its first mode is the input plate
    # twisting on the pillars (≈ 760 Hz); the seat error (model's RBE3 seats vs bearing pressure) ≤ 5 %
    assert (3e2 if part == "carrier" else 1e3) < doc["freqs_hz"][0] < 2e4
    if part == "carrier":
        assert doc["static_error_pct"]["max"] <= 5.0
    assert main(args) == 0
    warm = json.loads(out.read_text())
    assert warm["cached"] is True and warm["wall_s"] < 2.0
    assert warm["freqs_hz"] == doc["freqs_hz"]


def _reduce_in_worker(spec, cache_dir: str) -> None:
    from rvflex.fe.reduce import reduce_part

    reduce_part(spec, "disc", cache_dir=cache_dir, **COARSE)


def test_a_forked_worker_builds_a_reduction_after_its_parent_meshed(disc, spec, cache_dir, tmp_path):
    """A process forked after its parent meshed a disc reduces another disc (built in a separate
    process, rvflex.fe.isolated): meshing in the forked process itself waits forever on the OCC
    thread pool the fork copied without its threads (the self-check's generator hung so). The
    child gets 240 s, about ten times what the coarse build takes."""
    import dataclasses as dc
    import multiprocessing as mp

    from rvflex.fe import cache
    from rvflex.fe.reduce import CODE_VERSION, settings_for

    assert disc.n_modes > 0  # the parent has meshed
    mod = spec.cycloid.modification
    other = dc.replace(spec, cycloid=dc.replace(spec.cycloid, modification=dc.replace(mod, moved_m=mod.moved_m + 3e-6)))
    proc = mp.get_context("fork").Process(target=_reduce_in_worker, args=(other, str(tmp_path)))
    proc.start()
    proc.join(240)
    hung = proc.is_alive()
    if hung:
        proc.kill()
        proc.join()
    assert not hung and proc.exitcode == 0
    assert cache.load(cache.key_for(other, "disc", settings_for("disc", **COARSE), CODE_VERSION), tmp_path) is not None

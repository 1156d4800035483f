"""The Hurty–Craig–Bampton build of one part: mesh, assemble, static interface modes,
fixed-interface eigenmodes, attachment modes, Rayleigh–Ritz, static check; with the memory and
resolution estimates that refuse a hopeless mesh before the long steps.

See :mod:`rvflex.fe.reduce` for the basis and the patch loads; :func:`build` is the uncached
step that :func:`rvflex.fe.reduce.reduce_part` caches."""

from __future__ import annotations

import time

import numpy as np

from rvflex.choices import FEPart
from rvflex.fe.checks import carrier_check, disc_check, housing_check
from rvflex.fe.couplings import boundary_node_sets, interfaces_of, rbe3_loads, rigid_map
from rvflex.fe.geometry import part_geometry
from rvflex.fe.loads import flank_of
from rvflex.fe.solver import Solver, free_mask
from rvflex.fe.types import FEError, FlankRows, PartSettings, ReducedPart
from rvflex.geometry.profile import build_profile
from rvflex.spec import ReducerSpec, SpecError

__all__ = ["BYTES_PER_TET", "MAX_MODE_FRACTION", "ROWS_PER_TOOTH", "STEPS", "build", "estimate_memory_bytes", "estimate_tets"]


BYTES_PER_TET = {1: 10_000, 2: 60_000}  # measured peak RSS per tet of mesh + import + HCB (docs/fe.md)


MAX_MODE_FRACTION = 0.05  # at most one internal mode per 20 free DOFs: beyond, the mesh cannot resolve them


ROWS_PER_TOOTH = 64


STEPS = ("mesh", "assemble", "factorise", "static modes", "eigenmodes", "attachment modes", "Ritz", "static check")  # grid of the flank mode rows (patch-smoothed, so linear interpolation is accurate)


def _available_bytes() -> int:
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 8 << 30


def estimate_tets(volume_m3: float, maxh_m: float, part: FEPart, curvature_safety: float = 2.0) -> int:
    """Tet count estimate: 4·V/maxh³ (fitted to netgen's graded meshes, docs/fe.md) plus the
    floor that the curvature of the tooth profile forces on the disc (RV-40E: ≈ 6 000 tets
    at curvaturesafety 1, 23 000 at 2, whatever maxh) and the pin seats on the housing."""
    # the housing's pin seats (3 mm radius) force ≈ 12 000 tets at curvaturesafety 1 (RV-40E: 14 300 at 8 mm)
    floor = {"disc": 6_000 * curvature_safety**2, "housing": 12_000 * curvature_safety**2}.get(part, 3_000)
    return int(4.0 * volume_m3 / maxh_m**3 + floor)


def estimate_memory_bytes(n_tets: int, settings: PartSettings, n_extra_modes: int = 0) -> int:
    """Peak memory estimate of a reduction (bytes): measured bytes per tet plus the dense
    mode basis (nodes ≈ 1.45·tets for quadratic, 0.25·tets for linear tets) kept ~4×."""
    nodes = n_tets * (1.45 if settings.mesh_order == 2 else 0.25)
    basis = 4 * 8 * 3 * nodes * (settings.n_modes + n_extra_modes + 30)
    return int(n_tets * BYTES_PER_TET[settings.mesh_order] + basis + (300 << 20))


def _mass_orthonormal(B: np.ndarray, M) -> np.ndarray:
    """An M-orthonormal basis of span(B), dropping directions below 1e-10 of the largest."""
    B = B / np.sqrt(np.einsum("ij,ij->j", B, M @ B))  # unit M-norm first: attachment modes are ~1e-9 m/N
    G = B.T @ (M @ B)
    lam, V = np.linalg.eigh(0.5 * (G + G.T))
    keep = lam > 1e-10 * lam.max()
    return B @ (V[:, keep] / np.sqrt(lam[keep]))


def _progress(progress, msg: str) -> None:
    if progress is not None:
        progress(msg)


def build(spec: ReducerSpec, part: FEPart, s: PartSettings, key: str, progress=None) -> ReducedPart:
    import ngsolve as ngs
    from exudyn.FEM import FEMinterface
    from netgen.occ import OCCGeometry

    t_start = time.perf_counter()
    what = f"{part} (maxh {s.maxh_m * 1e3:g} mm, order {s.mesh_order}, {s.n_modes} modes)"
    geom = part_geometry(spec, part)
    n_att_planned = (s.attach_per_tooth * spec.cycloid.disc_teeth * (2 if s.attach_tangential else 1)
                     if part == "disc" else 2 * spec.cycloid.pin_count if part == "housing" else 0)
    tets_est = estimate_tets(geom.volume_m3, s.maxh_m, part, s.curvature_safety)
    need = estimate_memory_bytes(tets_est, s, n_att_planned)
    avail = _available_bytes()
    if need > 0.8 * avail:
        raise SpecError("maxh_m", s.maxh_m, f"the {part} mesh would have ≈{tets_est:,} tets and need ≈{need / 2**30:.1f} "
                                            f"GiB, more than 80 % of the {avail / 2**30:.1f} GiB available; use a "
                                            f"larger maxh")
    dof_est = 3 * tets_est * (1.45 if s.mesh_order == 2 else 0.25)
    if s.n_modes + n_att_planned > MAX_MODE_FRACTION * dof_est:
        raise SpecError("n_modes", s.n_modes, f"{s.n_modes + n_att_planned} internal modes exceed what a mesh of "
                                              f"≈{int(dof_est):,} DOFs resolves ({MAX_MODE_FRACTION:.0%} of them)")
    mat = {"disc": spec.materials.gears_cranks_discs, "carrier": spec.materials.carriers,
           "housing": spec.materials.pin_housing}[part]
    _progress(progress, "mesh")
    try:
        ngmesh = OCCGeometry(geom.shape).GenerateMesh(maxh=s.maxh_m, curvaturesafety=s.curvature_safety)
        mesh = ngs.Mesh(ngmesh)
        _progress(progress, "assemble")
        fem = FEMinterface()
        with ngs.TaskManager():
            _bfM, bfK, _fes = fem.ImportMeshFromNGsolve(mesh, density=mat.density_kg_m3,
                                                      youngsModulus=mat.youngs_modulus_Pa,
                                                      poissonsRatio=mat.poisson_ratio, meshOrder=s.mesh_order,
                                                      createBoundaryNodeSets=False)
        fem.nodeSets = boundary_node_sets(mesh, fem)  # vectorised: Exudyn's loops take ~10 s here
    except SpecError:
        raise
    except Exception as exc:  # netgen/NGSolve raise plain exceptions: say which part and settings
        raise FEError(f"meshing/assembly of the {what} failed: {exc}") from exc
    nn = fem.NumberOfNodes()
    pos = fem.GetNodePositionsAsArray()
    M = fem.GetMassMatrix(sparse=True).tocsr()
    K = fem.GetStiffnessMatrix(sparse=True).tocsr()
    itfs = interfaces_of(fem, geom, centred=part != "housing")
    # carrier with distributing (RBE3) seats: only the output face is held; the seats are
    # elastic and get attachment modes for the loads their couplings distribute. The housing
    # likewise: mount face held, each pin seat elastic with two in-plane force attachment modes
    rbe3 = (part == "carrier" and s.seat_coupling == "rbe3") or part == "housing"
    held = itfs[0].nodes if rbe3 else np.concatenate([i.nodes for i in itfs])
    n_free = 3 * (nn - held.size)
    n_int_req = s.n_modes + n_att_planned
    if n_int_req > MAX_MODE_FRACTION * n_free:
        raise SpecError("n_modes", s.n_modes, f"{n_int_req} internal modes exceed what this mesh resolves: "
                                              f"{n_free:,} free DOFs allow {int(MAX_MODE_FRACTION * n_free)}")
    try:
        _progress(progress, "factorise")
        solver = Solver(bfK, held, nn)
        # 1. static interface modes (interior relaxed); the first interface stays clamped
        _progress(progress, "static modes")
        T_all = [rigid_map(pos, i.nodes, i.centre_m, nn) for i in itfs]
        static = []
        for T in ([] if rbe3 else T_all[1:]):
            Ub = T.toarray()
            static.append(Ub - solver.solve(K @ Ub) * free_mask(held, nn)[:, None])
        S = np.hstack(static) if static else np.zeros((3 * nn, 0))
        # 2. fixed-interface eigenmodes: shift-invert Lanczos on the interior, the Cholesky as (K_ii)⁻¹
        _progress(progress, "eigenmodes")
        E = np.zeros((3 * nn, 0))
        lam_eig = np.zeros(0)
        if s.n_modes:
            lam_eig, E = _fixed_interface_modes(K, M, solver, held, nn, s.n_modes)
        # 3. attachment modes: unit normal patch loads around the flank (disc)
        profile = flank = None
        A = np.zeros((3 * nn, 0))
        if part == "disc":
            profile = build_profile(spec.cycloid)
            flank = flank_of(mesh, fem, profile, s.mesh_order)
        _progress(progress, "attachment modes")
        if part == "housing":  # unit x and y forces per pin seat, distributed by its area weights
            A = solver.solve(np.hstack([rbe3_loads(pos, i, nn)[:, :2] for i in itfs[1:]]))
        elif rbe3:  # 6 unit loads per seat, distributed as its RBE3 coupling does (forces, then moments)
            A = solver.solve(np.hstack([rbe3_loads(pos, i, nn) for i in itfs[1:]]))
        if n_att_planned and part == "disc":
            n_c = s.attach_per_tooth * spec.cycloid.disc_teeth
            tc = (np.arange(n_c) + 0.5) * 2 * np.pi / n_c
            Wd = flank.weights(tc, s.patch_half_width_m, s.patch_shape).toarray()
            nrm = profile.normal(tc)
            dirs = [nrm, np.column_stack([-nrm[:, 1], nrm[:, 0]])] if s.attach_tangential else [nrm]
            F = np.zeros((3 * nn, n_c * len(dirs)))
            for k, d in enumerate(dirs):  # normal (and tangential) unit patch loads
                for c in range(2):
                    F[3 * flank.nodes + c, k * n_c:(k + 1) * n_c] = -(Wd * d[:, c][:, None]).T
            A = solver.solve(F)
        # Rayleigh–Ritz on the internal span: diagonal internal mass and stiffness
        _progress(progress, "Ritz")
        B = _mass_orthonormal(np.hstack([E, A]), M) if E.shape[1] + A.shape[1] else np.zeros((3 * nn, 0))
        Kr = B.T @ (K @ B)
        lam_r, V = np.linalg.eigh(0.5 * (Kr + Kr.T))
        Psi_int = B @ V
        Psi = np.hstack([S, Psi_int])
    except SpecError:
        raise
    except Exception as exc:
        raise FEError(f"Craig–Bampton reduction of the {what} failed: {exc}") from exc
    fem.modeBasis = {"matrix": Psi, "type": "HCBmodes"}
    fem.eigenValues = lam_eig
    mass_r = Psi.T @ (M @ Psi)
    stiff_r = Psi.T @ (K @ Psi)
    rows = None
    if flank is not None:
        tg = np.arange(spec.cycloid.disc_teeth * ROWS_PER_TOOTH) * 2 * np.pi / (spec.cycloid.disc_teeth * ROWS_PER_TOOTH)
        W = flank.weights(tg, s.patch_half_width_m, s.patch_shape)
        Pf = Psi.reshape(nn, 3, -1)[flank.nodes, :2, :]  # (n_flank, 2, modes)
        rows = FlankRows(tg, np.stack([W @ Pf[:, 0, :], W @ Pf[:, 1, :]], axis=1), s.patch_half_width_m)
    _progress(progress, "static check")
    if part == "disc":
        chk = disc_check(spec, profile, flank, s, solver, K, Psi, S.shape[1], T_all, nn)
    elif part == "housing":
        chk = housing_check(spec, solver, fem, itfs, K, Psi, nn)
    else:
        chk = carrier_check(spec, bfK, fem, itfs, K, Psi, nn, geom, s.seat_coupling)
    wall = time.perf_counter() - t_start
    return ReducedPart(part, s, key, fem, pos, itfs, S.shape[1], E.shape[1], A.shape[1],
                       np.sqrt(lam_eig) / (2 * np.pi), mass_r, stiff_r, rows, chk, wall,
                       {"n_tets": int(mesh.ne), "ritz_freqs_hz": (np.sqrt(np.abs(lam_r)) / (2 * np.pi)).tolist()})


def _fixed_interface_modes(K, M, solver: Solver, held: np.ndarray, nn: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``n`` lowest eigenpairs (ω², Exudyn-ordered modes) with all interface nodes held."""
    from scipy.sparse.linalg import LinearOperator, eigsh

    free = np.flatnonzero(free_mask(held, nn))
    Kii, Mii = K[free][:, free], M[free][:, free]

    def apply_inv(x):
        full = np.zeros(3 * nn)
        full[free] = np.ravel(x)
        return solver.solve(full[:, None])[free, 0]

    op = LinearOperator(Kii.shape, matvec=apply_inv, dtype=float)
    lam, vec = eigsh(Kii, k=n, M=Mii, sigma=0.0, which="LM", OPinv=op, v0=np.ones(free.size))  # fixed v0: repeatable
    order = np.argsort(lam)
    E = np.zeros((3 * nn, n))
    E[free] = vec[:, order]
    return np.abs(lam[order]), E

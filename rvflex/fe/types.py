"""The data types of FE reduction, shared by the reduction (:mod:`rvflex.fe.reduce`), its
disk cache (:mod:`rvflex.fe.cache`) and the part builders: settings, the reduced part and its
interfaces, flank rows, static check and virtual nodes."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from rvflex.choices import FEPart, PatchShape, SeatCoupling, check_choice
from rvflex.spec import SpecError

__all__ = ["CHECK_ANGLES_PITCH", "CODE_VERSION", "DEFAULTS", "DISC_FLANK_BASIS", "FEError", "FlankRows", "Interface", "PartSettings", "ReducedPart", "StaticCheck", "VirtualNodes", "settings_for"]


CODE_VERSION = "fe-2"  # bump when the reduction's numbers change for the same inputs (part of the cache key)


CHECK_ANGLES_PITCH = (0.12, 0.37, 0.62, 0.87)  # disc angles of the static check, in pin pitches


class FEError(RuntimeError):
    """A netgen/NGSolve/Exudyn failure, re-raised with the part and the settings that caused it."""


@dataclass(frozen=True, slots=True)
class PartSettings:
    """Mesh and reduction settings of one part (lengths in m).

    ``n_modes`` counts the fixed-interface eigenmodes; the disc adds
    ``attach_per_tooth × disc_teeth`` attachment modes (twice that with ``attach_tangential``)
    and every part ``6 × (interfaces − 1)`` static modes, so the reduced body has more
    coordinates than ``n_modes``.
    """

    maxh_m: float
    n_modes: int
    mesh_order: int = 2
    patch_half_width_m: float = 2.5e-3
    attach_per_tooth: int = 0
    curvature_safety: float = 2.0
    patch_shape: PatchShape = "hat"
    attach_tangential: bool = False
    seat_coupling: SeatCoupling = "rbe3"  # carrier crank seats: "rbe3" distributing coupling (default) or "rbe2" rigid rings

    def __post_init__(self) -> None:
        if not (isinstance(self.maxh_m, (int, float)) and 0.3e-3 <= self.maxh_m <= 0.05):
            raise SpecError("maxh_m", self.maxh_m, "expected metres, 0.3 mm to 50 mm")
        if not (isinstance(self.n_modes, int) and 0 <= self.n_modes <= 2000):
            raise SpecError("n_modes", self.n_modes, "must be an integer from 0 to 2000")
        if self.mesh_order not in (1, 2):
            raise SpecError("mesh_order", self.mesh_order, "must be 1 (linear tets) or 2 (quadratic tets)")
        if not 0.2e-3 <= self.patch_half_width_m <= 20e-3:
            raise SpecError("patch_half_width_m", self.patch_half_width_m, "expected metres, 0.2 mm to 20 mm")
        check_choice("patch_shape", self.patch_shape, PatchShape)
        if not 0.5 <= self.curvature_safety <= 5.0:
            raise SpecError("curvature_safety", self.curvature_safety, "netgen's curvaturesafety, 0.5 to 5 (2 is its default)")
        if not (isinstance(self.attach_per_tooth, int) and 0 <= self.attach_per_tooth <= 16):
            raise SpecError("attach_per_tooth", self.attach_per_tooth, "must be an integer from 0 to 16")
        check_choice("seat_coupling", self.seat_coupling, SeatCoupling)


DEFAULTS: dict[str, PartSettings] = {
    "disc": PartSettings(maxh_m=6e-3, n_modes=12, mesh_order=2, patch_half_width_m=3e-3, attach_per_tooth=0,
                         curvature_safety=1.0, attach_tangential=True),
    "carrier": PartSettings(maxh_m=6e-3, n_modes=10, mesh_order=2, curvature_safety=1.0, seat_coupling="rbe3"),
    "housing": PartSettings(maxh_m=8e-3, n_modes=8, mesh_order=2, curvature_safety=1.0),
}
"""The one default reduction of each part: what :func:`rvflex.fe.reduce.reduce_part` and ``rvflex
reduce`` use when no setting is given, and what the flexible presets of
:class:`rvflex.options.ModelOptions` hold (``DISC_FE``, ``CARRIER_FE`` are these objects).

Disc: global deformation only — 6 bore (RBE2) static modes and 12 fixed-interface modes on 6 mm
quadratic tets, no flank attachment modes (the line-contact law carries the patch-local
compliance; docs/flexible.md). Carrier: output face the reference, 4 distributing (RBE3) seats
with 6 attachment modes each, 10 fixed-interface modes, 6 mm quadratic tets. Both chosen by the
convergence studies of docs/fe.md and docs/flexible.md."""

DISC_FLANK_BASIS = dataclasses.replace(DEFAULTS["disc"], n_modes=10, attach_per_tooth=2)
"""The disc basis the static flank check is about: :data:`DEFAULTS` with 10 fixed-interface modes
and 2 flank attachment patches per tooth (normal and tangential; 172 modes on the RV-40E, flank
error 4.4 %: docs/fe.md). ``rvflex reduce --part disc --modes 10 --attach 2``; in a model,
``ModelOptions.flexible_discs().with_fe("discs", n_modes=10, attach_per_tooth=2)`` (``--fe-modes
10 --fe-attach 2``)."""


def settings_for(part: FEPart, *, maxh_m: float | None = None, n_modes: int | None = None, **over) -> PartSettings:
    """The default settings of ``part`` (:data:`DEFAULTS`) with the given overrides."""
    check_choice("part", part, FEPart)
    base = DEFAULTS[part]
    kw = dict(over)
    if maxh_m is not None:
        kw["maxh_m"] = maxh_m
    if n_modes is not None:
        kw["n_modes"] = n_modes
    return dataclasses.replace(base, **kw)


@dataclass(frozen=True, eq=False)
class Interface:
    """A rigid (RBE2) interface: mesh nodes, their surface-area weights (sum 1) and centre (m)."""

    name: str
    nodes: np.ndarray
    weights: np.ndarray
    centre_m: np.ndarray


@dataclass(frozen=True, eq=False)
class FlankRows:
    """In-plane modal displacement rows of the disc flank (body frame).

    ``rows[i]`` (2 × n_modes) maps modal coordinates q to the (x, y) displacement (m) of the
    flank patch centred at profile parameter ``t_grid[i]`` (rad, the parameter of
    :class:`rvflex.geometry.profile.CycloidProfile`, e.g. ``GapResult.t``): the average over
    the patch (hat of half-width ``patch_half_width_m`` in arc length) and through the
    thickness. Transposed, it gives the generalised force of a pin force F applied there:
    Q = rows(t)ᵀ F.
    """

    t_grid: np.ndarray
    rows: np.ndarray
    patch_half_width_m: float

    def rows_at(self, t: np.ndarray | float) -> np.ndarray:
        """Rows at parameters ``t`` (rad, any real; periodic in 2π), shape (len(t), 2, n_modes),
        by linear interpolation on the grid."""
        t = np.atleast_1d(np.asarray(t, float)) % (2 * np.pi)
        n = self.t_grid.size
        h = 2 * np.pi / n
        x = t / h
        i0 = np.floor(x).astype(int) % n
        a = (x - np.floor(x))[:, None, None]
        return (1 - a) * self.rows[i0] + a * self.rows[(i0 + 1) % n]


@dataclass(frozen=True, eq=False)
class StaticCheck:
    """Reduced vs full NGSolve static solution of the part's rated-load case.

    ``flank_pct``: largest error of the loaded patch displacements along their loads
    (disc: loaded pins; carrier: pillar mid-span), in % of the largest full one.
    ``interface_pct``: disc — error of the bore reaction forces (% of the largest);
    carrier — error of the seat displacements (RBE2 seats vs elastic seats) in % of the
    largest; housing — ``flank_pct`` the reduction's error under the model's seat loads,
    ``interface_pct`` the seat displacements against a cosine seat pressure. ``case``: words describing the load case. ``flank_full_m``: the largest full
    flank (pillar) displacement (m); ``interface_full``: the largest full bore reaction (N,
    disc) or seat displacement (m, carrier) — the figures of the convergence study;
    ``flank_full_by_angle_m``: disc, the largest full flank displacement at each angle of
    :data:`CHECK_ANGLES_PITCH`.
    """

    flank_pct: float
    interface_pct: float
    case: str
    flank_full_m: float = float("nan")
    interface_full: float = float("nan")
    flank_full_by_angle_m: tuple = ()

    @property
    def max_pct(self) -> float:
        return max(self.flank_pct, self.interface_pct)


@dataclass(frozen=True, eq=False)
class ReducedPart:
    """A Craig–Bampton-reduced part, ready for Exudyn.

    Attributes
    ----------
    part : FEPart
        ``"disc"``, ``"carrier"`` or ``"housing"``.
    settings : PartSettings
    key : str
        Cache key (content hash of geometry, material, settings, code version).
    fem : exudyn.FEM.FEMinterface
        Nodes, tets, surface, mass and stiffness (SI) and ``modeBasis``: pass it to
        ``ObjectFFRFreducedOrderInterface(fem).AddObjectFFRFreducedOrder(mbs, ...)``.
        Treat as read-only.
    node_positions_m : ndarray (n_nodes, 3)
        Reference node positions in the body frame (m).
    interfaces : tuple of Interface
        In basis order; the first is the floating-frame reference (clamped in all modes).
    n_static, n_eigen, n_attach : int
        Column counts of the basis blocks (static interface modes first).
    freqs_hz : ndarray
        Fixed-interface eigenfrequencies of the ``n_eigen`` eigenmodes (Hz).
    mass_reduced, stiffness_reduced : ndarray (n_modes, n_modes)
        Ψᵀ M Ψ (kg·m²-consistent) and Ψᵀ K Ψ (N/m) of the basis.
    flank : FlankRows or None
        Disc only: the flank mode rows.
    check : StaticCheck
        The reduced-vs-full static check done when the part was reduced.
    wall_s : float
        Wall time of the cold reduction (s).
    """

    part: FEPart
    settings: PartSettings
    key: str
    fem: object
    node_positions_m: np.ndarray
    interfaces: tuple[Interface, ...]
    n_static: int
    n_eigen: int
    n_attach: int
    freqs_hz: np.ndarray
    mass_reduced: np.ndarray
    stiffness_reduced: np.ndarray
    flank: FlankRows | None
    check: StaticCheck
    wall_s: float
    meta: dict = field(default_factory=dict)

    @property
    def mode_basis(self) -> np.ndarray:
        """Ψ, (3·n_nodes, n_modes), Exudyn ordering (x0, y0, z0, x1, ...), m per modal unit."""
        return self.fem.modeBasis["matrix"]

    @property
    def n_modes(self) -> int:
        return int(self.mode_basis.shape[1])

    @property
    def n_nodes(self) -> int:
        return int(self.node_positions_m.shape[0])

    def interface(self, name: str) -> Interface:
        """The interface called ``name``."""
        for itf in self.interfaces:
            if itf.name == name:
                return itf
        raise KeyError(f"{self.part} has no interface {name!r}; it has {[i.name for i in self.interfaces]}")


@dataclass(frozen=True, eq=False)
class VirtualNodes:
    """Massless nodes that carry the distributing (RBE3) motion of interfaces (body frame).

    ``positions_m`` (n, 3) and mode rows ``rows`` (3·n × n_modes, Exudyn ordering x0, y0, z0, x1, …);
    ``groups[k]`` are the indices (into ``positions_m``) of the nodes of ``names[k]``.
    """

    names: tuple[str, ...]
    positions_m: np.ndarray
    rows: np.ndarray
    groups: tuple[tuple[int, ...], ...]

    def group(self, name: str) -> tuple[int, ...]:
        return self.groups[self.names.index(name)]

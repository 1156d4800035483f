"""Cycloid–pin contact: one Exudyn object per disc acting on all pins at once.

The element is an ``ObjectGenericODE2`` on the disc's planar rigid node with a force and
an analytic Jacobian user function; both call one numba kernel
(:mod:`rvflex.contact._cycloid_kernel`) that evaluates every pin with the exact
closest-point gap of :mod:`rvflex.geometry` — no polygon, no Python loop over pins. The
force call stores the Jacobian it computes alongside, so Newton's Jacobian request at the
same state costs nothing.

A pin has one contact point per separate local minimum of its distance to the profile
within the contact range (``CONTACT_RANGE_M`` of the kernel), each with its own force: a
relieved root whose radius of curvature is smaller than the pin is touched on both rims
(:func:`concave_zones` finds where the profile allows that).

Which deformation it carries: the local contact compliance only (the normal law). Global
deformation of the disc belongs to the flexible body (Craig–Bampton modes), not here; a
flexible pin housing moves the pins by its modal seat displacement (``housing_node``, ``seat``:
:func:`rvflex.contact._cycloid_kernel.evaluate_housing`).

On a spatial rigid disc (``NodeRigidBodyRxyz``, ``lever_m`` given) the element is one face slice: the kernel sees
the in-plane pose of the disc's section at that axial lever, which the disc's tilt moves, and its force and
Jacobians map back onto the node's six coordinates with the exact Jacobian of that pose
(:mod:`rvflex.contact.tilt_map`).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass, field

import numpy as np

from rvflex.choices import ContactLawKind, check_choice
from rvflex.contact import _cycloid_kernel as K
from rvflex.contact.tilt_map import NODE, map_to_body, section_pose
from rvflex.geometry.pins import pin_centres, pin_radii
from rvflex.geometry.profile import CurveKey, CycloidProfile, build_profile
from rvflex.spec import CycloidStage, ErrorSpec, Material

__all__ = ["ContactError", "ContactLaw", "CycloidPinContact", "PinState", "add_cycloid_pin_contact",
           "concave_zones", "install_penetration_guard", "DEFAULT_MAX_PENETRATION_M", "MAX_POINTS", "N_OUT", "O_FORCE",
           "O_GAP", "empty_points", "evaluate_kernel", "evaluate_tracked_kernel"]

DEFAULT_MAX_PENETRATION_M = 50e-6  # beyond any elastic approach of steel pins (a few µm): a run gone wrong
DEFAULT_INITIAL_INTERFERENCE_M = 1e-6
MAX_POINTS = K.MAX_POINTS
# the kernel, for compiled callers that evaluate a disc without its Exudyn element (rvflex.engine), and the
# layout of its per-pin outputs
evaluate_kernel = K.evaluate
evaluate_tracked_kernel = K.evaluate_tracked
evaluate_housing_kernel = K.evaluate_housing
empty_points = K.empty_points
N_OUT, O_GAP, O_FORCE, O_PX, O_PY = K.N_OUT, K.O_GAP, K.O_FORCE, K.O_PX, K.O_PY
ZONE_SAMPLES_PER_TOOTH = 4096  # curvature samples of the concave-zone search: 0.09° of tooth phase
ZONE_PAD_SAMPLES = 2  # each zone widened by this many samples per side, so sampling cannot clip it
ZONE_FINE_SAMPLES = 1025  # curvature samples across one zone when placing its slope samples


class ContactError(RuntimeError):
    """A contact penetrates deeper than is physically possible: the run is stopped."""


@dataclass(frozen=True)
class ContactLaw:
    """Normal force law of a pin contact, damping and optional regularised Coulomb friction.

    Use the constructors :meth:`linear`, :meth:`hertz` and :meth:`line`.

    Attributes
    ----------
    kind : {"linear", "power", "line", "strip"}
        Linear penalty F = k·x; power law F = k·x^e (Hertz-type, seed 000); line contact of
        seed 002 (stiffness from materials, width and local flank curvature); "strip", a
        penalty per unit flank length (the law ObjectContactCurveCircles converges to).
    stiffness : float
        k in N/m (linear), N/m^e (power) or N/m² (strip); unused for "line".
    exponent : float
        e of the power law (–).
    damping_Ns_m : float
        c of the damping force c·ẋ, active only while in contact (N·s/m).
    friction_coefficient : float
        μ of the regularised Coulomb friction μ·F_n·tanh(v_t/v_reg); 0 switches it off.
    friction_velocity_m_s : float
        v_reg, sliding speed over which friction builds up (m/s).
    width_m : float
        Contact width b (the disc thickness) for "line" (m).
    disc_compliance_1_Pa, pin_compliance_1_Pa : float
        (1 − ν²)/E of disc and pin for "line" (1/Pa).
    seat_compliance_m_N : float
        s, a compliance of each pin's seat in series with the contact (m/N; 0: none): the penetration x
        splits into the contact's approach x_c and the seat's s·F, F = f(x_c), so the force-approach law
        softens with load and its stiffness never exceeds 1/s. With it a power law may soften
        (exponent from 0.9): the seat bounds the stiffness a sub-linear law has at zero approach.
    body_radius_m : float
        For "line": bound on the flank radius in seed 002's ln(4ρ/c) term (m). The term is the
        approach of a cylinder of radius ρ measured to its centre; where the flank is nearly
        straight (around its inflection point ρ → ∞) the disc body itself, not the flank
        curvature, bounds that distance. The law uses 1/ρ_eff = √(κ² + 1/R_b²), smooth in
        the curvature κ; without it the force has a logarithmic cusp at the inflection point
        and Newton cycles there. ``default_contact_law`` takes R_b = the pin-circle radius.
    """

    kind: ContactLawKind
    stiffness: float = 0.0
    exponent: float = 1.0
    damping_Ns_m: float = 0.0
    friction_coefficient: float = 0.0
    friction_velocity_m_s: float = 1e-4
    width_m: float = 0.0
    disc_compliance_1_Pa: float = 0.0
    pin_compliance_1_Pa: float = 0.0
    body_radius_m: float = math.inf
    seat_compliance_m_N: float = 0.0

    def __post_init__(self) -> None:
        check_choice("contact law kind", self.kind, ContactLawKind)
        if self.kind != "line" and not self.stiffness > 0:
            raise ValueError(f"contact law stiffness = {self.stiffness!r}: must be positive")
        if not (math.isfinite(self.seat_compliance_m_N) and self.seat_compliance_m_N >= 0.0):
            raise ValueError(f"contact law seat_compliance_m_N = {self.seat_compliance_m_N!r}: must be a finite "
                             "compliance ≥ 0 (m/N)")
        low = 0.9 if self.seat_compliance_m_N > 0.0 else 1.0
        if self.kind == "power" and not low <= self.exponent <= 3.0:
            raise ValueError(f"contact law exponent = {self.exponent!r}: must lie in [{low:g}, 3]"
                             + ("" if low == 0.9 else " (from 0.9 with a seat compliance in series, which bounds "
                                "the stiffness a softening law has at zero approach)"))
        if self.kind == "line" and not (self.width_m > 0 and self.disc_compliance_1_Pa > 0
                                        and self.pin_compliance_1_Pa > 0):
            raise ValueError("line contact law: width_m and both compliances must be positive")
        if not self.body_radius_m > 0:
            raise ValueError(f"contact law body_radius_m = {self.body_radius_m!r}: must be positive (m)")
        for name in ("damping_Ns_m", "friction_coefficient"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"contact law {name} = {getattr(self, name)!r}: must not be negative")
        if not self.friction_velocity_m_s > 0:
            raise ValueError(f"contact law friction_velocity_m_s = {self.friction_velocity_m_s!r}: must be positive")

    @classmethod
    def linear(cls, stiffness_N_m: float, damping_Ns_m: float = 0.0, **friction: float) -> "ContactLaw":
        """Linear penalty F = k·x (+ c·ẋ)."""
        return cls("linear", stiffness_N_m, 1.0, damping_Ns_m, **friction)

    @classmethod
    def hertz(cls, stiffness: float, exponent: float = 1.5, damping_Ns_m: float = 0.0,
              **friction: float) -> "ContactLaw":
        """Power law F = k·x^e (+ c·ẋ), e = 1.5 as in seed 000; k in N/m^e."""
        return cls("power", stiffness, exponent, damping_Ns_m, **friction)

    @classmethod
    def strip(cls, stiffness_N_m2: float, damping_Ns_m: float = 0.0, **friction: float) -> "ContactLaw":
        """A penalty k (N/m²) per unit length of flank, integrated over the overlap chord:
        F = (4√2/3)·k·√R·x^1.5 with 1/R = 1/r_pin + κ_flank. It is the fine-segment limit of
        Exudyn's ``ObjectContactCurveCircles`` (contact model 0) and serves the cross-check."""
        return cls("strip", stiffness_N_m2, 1.5, damping_Ns_m, **friction)

    @classmethod
    def line(cls, width_m: float, disc: Material, pin: Material, damping_Ns_m: float = 0.0, *,
             body_radius_m: float, **friction: float) -> "ContactLaw":
        """Seed 002's line contact: the approach δ(F) of :func:`rvflex.geometry.formulas.hertz_line_deflection`
        inverted, with the flank curvature at each contact point; ``body_radius_m`` bounds the
        flank radius in the logarithm (see the class docstring)."""
        return cls("line", 0.0, 1.0, damping_Ns_m, width_m=width_m,
                   disc_compliance_1_Pa=(1 - disc.poisson_ratio**2) / disc.youngs_modulus_Pa,
                   pin_compliance_1_Pa=(1 - pin.poisson_ratio**2) / pin.youngs_modulus_Pa,
                   body_radius_m=body_radius_m, **friction)

    def sliced(self, slices: int) -> "ContactLaw":
        """The law of one of ``slices`` equal slices of the contact along the face width: each carries its share
        of the load at the same approach, so ``slices`` of them side by side at one gap give this law's force
        (a line law's width, another law's stiffness and every law's damping divided by ``slices``; the seed 002
        approach depends on the force per unit width alone)."""
        if not (isinstance(slices, int) and slices >= 1):
            raise ValueError(f"slices = {slices!r}: must be an integer ≥ 1")
        if slices == 1:
            return self
        seat = self.seat_compliance_m_N * slices  # each slice's share of the seat carries its share of the load
        if self.kind == "line":
            return dataclasses.replace(self, width_m=self.width_m / slices, damping_Ns_m=self.damping_Ns_m / slices,
                                       seat_compliance_m_N=seat)
        return dataclasses.replace(self, stiffness=self.stiffness / slices, damping_Ns_m=self.damping_Ns_m / slices,
                                   seat_compliance_m_N=seat)

    def vector(self) -> np.ndarray:
        """Parameter vector of the kernel."""
        v = np.zeros(K.N_LAW)
        v[K.L_KIND] = {"linear": K.LAW_LINEAR, "power": K.LAW_POWER, "line": K.LAW_LINE, "strip": K.LAW_STRIP}[self.kind]
        v[K.L_K], v[K.L_EXP], v[K.L_C] = self.stiffness, self.exponent, self.damping_Ns_m
        v[K.L_MU], v[K.L_VREG] = self.friction_coefficient, self.friction_velocity_m_s
        v[K.L_WIDTH], v[K.L_COMPL1], v[K.L_COMPL2] = self.width_m, self.disc_compliance_1_Pa, self.pin_compliance_1_Pa
        v[K.L_INV_RB] = 1.0 / self.body_radius_m
        v[K.L_SEAT] = self.seat_compliance_m_N
        return v


@dataclass(frozen=True)
class PinState:
    """Per-pin contact state (arrays of one row per pin, pin order).

    gap_m: signed gap (m, negative = penetration) of the pin's deepest point; force_N: normal
    force (N), summed over the pin's contact points; tangential_force_N: friction force along
    the flank (N), summed likewise; point_m: deepest contact point on the disc in the ring
    frame (n, 2) (m); t: its profile parameter. ``points_*`` hold every contact point
    (n, MAX_POINTS) (gap in m, normal force in N, profile parameter), NaN gap and t where a
    pin has fewer points; ``point_count`` (n,) how many it has (1 on an unrelieved profile).
    """

    gap_m: np.ndarray
    force_N: np.ndarray
    tangential_force_N: np.ndarray
    point_m: np.ndarray
    t: np.ndarray
    points_gap_m: np.ndarray | None = None
    points_force_N: np.ndarray | None = None
    points_t: np.ndarray | None = None
    point_count: np.ndarray | None = None

    @property
    def in_contact(self) -> np.ndarray:
        """Pins carrying load."""
        return self.force_N > 0.0


@dataclass(frozen=True, eq=False)
class CycloidPinContact:
    """Handle of one disc–pin-ring contact element.

    Attributes
    ----------
    object_index : int
        Exudyn index of the ``ObjectGenericODE2``.
    node : int
        The disc's NodeRigidBody2D.
    profile : CycloidProfile
        Exact profile of this disc (with its errors).
    pins_m, radii_m : ndarray
        Pin centres in the ring frame (n, 2) and radii (n,), errors included (m).
    offset_rad : float
        Profile frame angle relative to the node's rotation (disc phase).
    modal_node : int
        NodeGenericODE2 of the disc's modal coordinates (flexible disc), −1 for a rigid disc.
    phi : ndarray
        (n_grid, 2, m) modal flank displacement in the profile frame on the uniform grid of
        the profile parameter, see :func:`rvflex.contact._cycloid_kernel.evaluate` (m = 0: rigid).
    zones : ndarray
        (n_zones, N_ZONE) concave zones of the profile where a pin can touch at several points
        (:func:`concave_zones`); empty for a profile where it cannot.
    zone_window_rad : float
        Zones are searched within this profile-parameter distance of a pin's closest point (rad).
    """

    object_index: int
    node: int
    profile: CycloidProfile
    pins_m: np.ndarray
    radii_m: np.ndarray
    law: ContactLaw
    offset_rad: float
    reference: np.ndarray
    max_penetration_m: float
    _law_vec: np.ndarray = field(repr=False)
    _t_cache: np.ndarray = field(repr=False)
    _work: "_Workspace" = field(repr=False)
    zones: np.ndarray = field(default_factory=lambda: np.zeros((0, K.N_ZONE)), repr=False)
    zone_window_rad: float = 0.0
    modal_node: int = -1
    phi: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 0)), repr=False)
    rigid_index: tuple[int, int, int] = (0, 1, 2)  # (x, y, θ) within the node's coordinates
    housing_node: int = -1  # NodeGenericODE2 of a flexible housing's modal coordinates, −1: pins fixed
    seat: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 0)), repr=False)  # (n_pins, 2, h) seat rows
    lever_m: float | None = None  # a slice of a tilting (Rxyz) disc: its axial lever from the node (m); None: planar

    @property
    def tilted(self) -> bool:
        """True when the element is a slice of a spatial disc whose tilt moves it (:mod:`rvflex.contact.tilt_map`)."""
        return self.lever_m is not None

    def section(self, q_node: np.ndarray, qd_node: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """In-plane pose (x, y, θ) (m, rad) and its rates of the disc section this element acts on, from the disc
        node's absolute coordinates ``q_node`` and rates ``qd_node`` (zero if None)."""
        q_node = np.asarray(q_node, float)
        qd_node = np.zeros(len(q_node)) if qd_node is None else np.asarray(qd_node, float)
        if self.lever_m is None:
            ri = list(self.rigid_index)
            return q_node[ri].copy(), qd_node[ri].copy()
        s, jac = np.empty(3), np.empty((3, NODE))
        section_pose(q_node, self.lever_m, s, jac)
        return s, jac @ qd_node

    @property
    def n_modes(self) -> int:
        """Modal coordinates of the disc (0 for a rigid disc)."""
        return self.phi.shape[2]

    @property
    def n_housing_modes(self) -> int:
        """Modal coordinates of the pin housing (0 for fixed pins)."""
        return self.seat.shape[2]

    def evaluate(self, q: np.ndarray, qd: np.ndarray | None = None, eta: np.ndarray | None = None,
                 eta_d: np.ndarray | None = None, xi: np.ndarray | None = None, xi_d: np.ndarray | None = None):
        """Force (3 + m + h,), LHS Jacobians K and D ((3 + m + h)²), per-pin outputs and max
        penetration at absolute rigid coordinates ``q = (x, y, θ)``, velocities ``qd``, the
        disc's modal coordinates ``eta`` (m,) with rates ``eta_d`` and the housing's ``xi`` (h,)
        with rates ``xi_d``."""
        f, k, d, out, _, _, pen = self.evaluate_points(q, qd, eta, eta_d, xi, xi_d)
        return f, k, d, out, pen

    def evaluate_points(self, q: np.ndarray, qd: np.ndarray | None = None, eta: np.ndarray | None = None,
                        eta_d: np.ndarray | None = None, xi: np.ndarray | None = None,
                        xi_d: np.ndarray | None = None):
        """As :meth:`evaluate`, with every contact point: force, K, D, per-pin outputs (n, N_OUT),
        per-point outputs (n, MAX_POINTS, N_OUT), point counts (n,) and max penetration."""
        m, h = self.n_modes, self.n_housing_modes
        qd = np.zeros(3) if qd is None else np.asarray(qd, float)
        eta = np.zeros(m) if eta is None else np.asarray(eta, float)
        eta_d = np.zeros(m) if eta_d is None else np.asarray(eta_d, float)
        n, npin = 3 + m + h, len(self.radii_m)
        f, k, d, out = np.empty(n), np.empty((n, n)), np.empty((n, n)), np.empty((npin, K.N_OUT))
        pout, count = K.empty_points(npin)
        if h:
            xi = np.zeros(h) if xi is None else np.asarray(xi, float)
            xi_d = np.zeros(h) if xi_d is None else np.asarray(xi_d, float)
            pen, bad = K.evaluate_housing(np.asarray(q, float), qd, self.offset_rad, self.pins_m, self.radii_m,
                                          self.profile.par, self.profile.herr, self.profile.hpsi, self._law_vec,
                                          self._t_cache, self.phi, eta, eta_d, self.seat, xi, xi_d, f, k, d, out,
                                          self.zones, self.zone_window_rad, pout, count, np.empty(3 + m),
                                          np.empty((3 + m, 3 + m)), np.empty((3 + m, 3 + m)))
        else:
            pen, bad = K.evaluate(np.asarray(q, float), qd, self.offset_rad, self.pins_m, self.radii_m,
                                  self.profile.par, self.profile.herr, self.profile.hpsi, self._law_vec,
                                  self._t_cache, self.phi, eta, eta_d, f, k, d, out, self.zones, self.zone_window_rad,
                                  pout, count)
        if bad:
            raise RuntimeError(f"cycloid–pin contact on node {self.node}: closest-point solve failed for {bad} pins "
                               f"(or a pin has more than {K.MAX_POINTS} contact points)")
        return f, k, d, out, pout, count, pen

    def pin_state(self, mbs) -> PinState:
        """Per-pin gap, force and contact point at the system's current state."""
        q, qd = self.section(self.reference + np.asarray(mbs.GetNodeOutput(self.node, _exu().OutputVariableType.Coordinates)),
                             np.asarray(mbs.GetNodeOutput(self.node, _exu().OutputVariableType.Coordinates_t)))
        eta = eta_d = xi = xi_d = None
        if self.modal_node >= 0:
            eta = np.asarray(mbs.GetNodeOutput(self.modal_node, _exu().OutputVariableType.Coordinates))
            eta_d = np.asarray(mbs.GetNodeOutput(self.modal_node, _exu().OutputVariableType.Coordinates_t))
        if self.housing_node >= 0:
            xi = np.asarray(mbs.GetNodeOutput(self.housing_node, _exu().OutputVariableType.Coordinates))
            xi_d = np.asarray(mbs.GetNodeOutput(self.housing_node, _exu().OutputVariableType.Coordinates_t))
        return self.pin_state_at(q, qd, eta, eta_d, xi, xi_d)

    def pin_state_at(self, q: np.ndarray, qd: np.ndarray | None = None, eta: np.ndarray | None = None,
                     eta_d: np.ndarray | None = None, xi: np.ndarray | None = None,
                     xi_d: np.ndarray | None = None) -> PinState:
        """Per-pin state at absolute rigid coordinates ``q = (x, y, θ)`` and rates ``qd`` (and
        the disc's and housing's modal coordinates): e.g. replayed from a dynamic run's recorded
        disc states."""
        _, _, _, out, pout, count, _ = self.evaluate_points(q, qd, eta, eta_d, xi, xi_d)
        return PinState(out[:, K.O_GAP].copy(), out[:, K.O_FORCE].copy(), out[:, K.O_FT].copy(),
                        out[:, [K.O_PX, K.O_PY]].copy(), out[:, K.O_T].copy(), pout[:, :, K.O_GAP].copy(),
                        pout[:, :, K.O_FORCE].copy(), pout[:, :, K.O_T].copy(), count)

    # ------------------------------------------------------------------ user functions
    def _force_uf(self, mbs, t, item, q, q_t):
        w = self._work
        q = np.asarray(q, float)
        q_t = np.asarray(q_t, float)
        w.key = q.tobytes() + q_t.tobytes()  # the Jacobian call checks it is asked at this state
        if self.housing_node >= 0:
            return self._force_housing(q, q_t)
        if self.lever_m is not None:
            return self._force_tilted(q, q_t)
        if w.scatter is None:  # a rigid disc: the object's coordinates are (x, y, θ)
            np.add(self.reference, q, out=w.q)
            w.qd[:] = q_t
            eta = eta_d = w.no_modes
        else:
            ri, nn = w.rigid, len(self.reference)
            np.add(self.reference[ri], q[ri], out=w.q)
            w.qd[:] = q_t[ri]
            eta, eta_d = q[nn:], q_t[nn:]
        w.penetration, w.bad = K.evaluate(w.q, w.qd, self.offset_rad, self.pins_m, self.radii_m, self.profile.par,
                                          self.profile.herr, self.profile.hpsi, self._law_vec, self._t_cache,
                                          self.phi, eta, eta_d, w.f, w.k, w.d, w.out, self.zones,
                                          self.zone_window_rad, w.pout, w.count)
        if w.scatter is None:
            return w.f
        w.f_obj[w.scatter] = w.f
        return w.f_obj

    def _force_tilted(self, q: np.ndarray, q_t: np.ndarray) -> np.ndarray:
        """Force user function of a slice of a spatial disc: the kernel on the section's in-plane pose, mapped
        back onto the node's coordinates (x, y, z, ψx, ψy, ψz)."""
        w = self._work
        qa, jac, f6, k6, d6 = w.tilt
        np.add(self.reference, q, out=qa)
        section_pose(qa, self.lever_m, w.q, jac)
        np.dot(jac, q_t, out=w.qd)
        w.penetration, w.bad = K.evaluate(w.q, w.qd, self.offset_rad, self.pins_m, self.radii_m, self.profile.par,
                                          self.profile.herr, self.profile.hpsi, self._law_vec, self._t_cache,
                                          self.phi, w.no_modes, w.no_modes, w.f, w.k, w.d, w.out, self.zones,
                                          self.zone_window_rad, w.pout, w.count)
        map_to_body(qa, self.lever_m, jac, w.f, w.k, w.d, f6, k6, d6)
        return f6

    def _force_housing(self, q: np.ndarray, q_t: np.ndarray) -> np.ndarray:
        """Force user function with the pins on a flexible housing: the object's coordinates are
        the disc node's, the disc's modes (if any), then the housing's modes."""
        w = self._work
        ri, nn, m = w.rigid, len(self.reference), self.n_modes
        np.add(self.reference[ri], q[ri], out=w.q)
        w.qd[:] = q_t[ri]
        w.penetration, w.bad = K.evaluate_housing(
            w.q, w.qd, self.offset_rad, self.pins_m, self.radii_m, self.profile.par, self.profile.herr,
            self.profile.hpsi, self._law_vec, self._t_cache, self.phi, q[nn:nn + m], q_t[nn:nn + m], self.seat,
            q[nn + m:], q_t[nn + m:], w.f, w.k, w.d, w.out, self.zones, self.zone_window_rad, w.pout, w.count,
            *w.pin_buffers)
        if w.scatter is None:
            return w.f
        w.f_obj[w.scatter] = w.f
        return w.f_obj

    def check_penetration(self, t: float = math.nan) -> None:
        """Raise :class:`ContactError` if the last evaluated state penetrates deeper than
        ``max_penetration_m``. Call it at converged states (see :func:`install_penetration_guard`):
        Newton's intermediate iterates may overshoot harmlessly."""
        pen = self._work.penetration
        if pen > self.max_penetration_m:
            raise ContactError(f"cycloid–pin contact on node {self.node}: penetration {pen * 1e6:.1f} µm exceeds "
                               f"{self.max_penetration_m * 1e6:.0f} µm at t = {t:g} s (diverged or overloaded run)")

    def _jacobian_uf(self, mbs, t, item, q, q_t, f_ode2, f_ode2_t):
        w = self._work
        # bitwise compare with the last evaluated state (tobytes: ~0.2 µs, (a == b).all(): ~3 µs)
        if w.key != np.asarray(q, float).tobytes() + np.asarray(q_t, float).tobytes():
            self._force_uf(mbs, t, item, q, q_t)  # Newton asks at a state the force was not evaluated at (rare)
        if w.tilt:
            _, _, _, k6, d6 = w.tilt
            return (k6 if f_ode2 == 1.0 else f_ode2 * k6) if f_ode2_t == 0.0 else f_ode2 * k6 + f_ode2_t * d6
        if w.scatter is None:
            if f_ode2_t == 0.0:  # statics: no damping term, no temporary
                return w.k if f_ode2 == 1.0 else f_ode2 * w.k
            return f_ode2 * w.k + f_ode2_t * w.d
        ix = np.ix_(w.scatter, w.scatter)
        w.k_obj[ix] = f_ode2 * w.k + f_ode2_t * w.d
        return w.k_obj


@dataclass(eq=False)
class _Workspace:
    """Buffers of the user functions: the last evaluated state and its force and Jacobians."""

    q: np.ndarray
    qd: np.ndarray
    f: np.ndarray
    k: np.ndarray
    d: np.ndarray
    out: np.ndarray
    pout: np.ndarray  # per contact point (n, MAX_POINTS, N_OUT)
    count: np.ndarray  # contact points per pin (n,)
    key: bytes  # the object's coordinates and velocities at the last evaluation
    no_modes: np.ndarray  # empty modal coordinates of a rigid disc
    scatter: np.ndarray | None  # positions of (x, y, θ, η…) in the object's coordinates; None: identity
    rigid: np.ndarray  # positions of (x, y, θ) in the object's coordinates
    f_obj: np.ndarray
    k_obj: np.ndarray
    penetration: float = -math.inf
    bad: int = 0
    pin_buffers: tuple = ()  # flexible housing: one pin's force and Jacobians, (3 + m,), ((3 + m)²) ×2
    tilt: tuple = ()  # a tilting slice: the node's absolute coordinates, ∂s/∂q (3, 6), force (6,), K, D (6, 6)

    @classmethod
    def for_pins(cls, n: int, rigid_index: tuple[int, int, int] = (0, 1, 2), node_coords: int = 3,
                 modes: int = 0, housing_modes: int = 0, tilted: bool = False) -> "_Workspace":
        k = 3 + modes + housing_modes
        nobj = node_coords + modes + housing_modes
        scatter = None
        if tuple(rigid_index) != (0, 1, 2) or node_coords != 3:
            scatter = np.array(list(rigid_index) + list(range(node_coords, nobj)), dtype=np.intp)
        kp = 3 + modes
        pins = (np.zeros(kp), np.zeros((kp, kp)), np.zeros((kp, kp))) if housing_modes else ()
        tilt = (np.zeros(NODE), np.zeros((3, NODE)), np.zeros(NODE), np.zeros((NODE, NODE)),
                np.zeros((NODE, NODE))) if tilted else ()
        return cls(np.full(3, np.nan), np.full(3, np.nan), np.zeros(k), np.zeros((k, k)), np.zeros((k, k)),
                   np.zeros((n, K.N_OUT)), *K.empty_points(n), b"",
                   np.zeros(0), scatter,
                   np.asarray(rigid_index, dtype=np.intp), np.zeros(nobj), np.zeros((nobj, nobj)), pin_buffers=pins,
                   tilt=tilt)


def install_penetration_guard(mbs, contacts: list[CycloidPinContact]) -> None:
    """Stop a dynamic run whose converged state penetrates any contact too deeply.

    Installs the system's post-Newton user function (one Python call per time step for
    all contacts, not per contact); it checks the state Newton converged to.
    """

    def post_newton(mbs, t):
        for c in contacts:
            c.check_penetration(t)
        return [0.0, 0.0]

    mbs.SetPostNewtonUserFunction(post_newton)


def concave_zones(profile: CycloidProfile, max_pin_radius_m: float, min_pin_radius_m: float | None = None) -> np.ndarray:
    """Stretches of ``profile`` where a pin of radius up to ``max_pin_radius_m`` can touch at
    more than one point.

    Two local minima of the distance from a pin centre need a maximum between them, and a
    maximum at distance d needs a concave stretch with radius of curvature below d
    (1 + κ·d < 0). Within the contact range d ≤ r + CONTACT_RANGE_M, so the zones are where
    κ < −1/(r_max + CONTACT_RANGE_M), sampled ``ZONE_SAMPLES_PER_TOOTH`` per tooth and
    widened by ``ZONE_PAD_SAMPLES`` samples each side.

    ``min_pin_radius_m`` (default: ``max_pin_radius_m``) places the slope samples the
    contact evaluates across a zone (``_slope_samples``).

    Returns
    -------
    ndarray (n_zones, N_ZONE)
        Rows with the columns ``Z_*`` of :mod:`rvflex.contact._cycloid_kernel`: parameter
        range (t_a, t_b) (rad, t_a in [0, 2π) ascending, t_b > t_a, possibly past 2π), the
        slope samples, and the bounding circles of ZONE_ARCS equal parameter pieces of the
        zone in the profile frame (m). Empty for every unrelieved cycloid (its root radius
        exceeds the pin's).
    """
    min_pin_radius_m = max_pin_radius_m if min_pin_radius_m is None else min_pin_radius_m
    return _zones(CurveKey(profile), float(max_pin_radius_m), float(min_pin_radius_m)).copy()


@functools.lru_cache(maxsize=64)
def _zones(curve: CurveKey, max_pin_radius_m: float, min_pin_radius_m: float) -> np.ndarray:
    # a pure function of the curve and the radii, kept per process: a third of a rigid model build, and a
    # diagnosis builds the same discs some 70 times (the caller gets a copy: the kernel's input stays as made)
    profile = curve.profile
    n = profile.stage.disc_teeth * ZONE_SAMPLES_PER_TOOTH
    h = 2 * np.pi / n
    ts = np.arange(n) * h
    tight = profile.curvature(ts) < -1.0 / (max_pin_radius_m + K.CONTACT_RANGE_M)
    if not tight.any():
        return np.zeros((0, K.N_ZONE))
    if tight.all():
        raise ValueError("profile: concave everywhere with a radius below the pin's (not a cycloid disc)")
    # widen on the circle, then find the runs starting after a non-tight sample
    idx = np.flatnonzero(tight)
    wide = np.zeros(n, bool)
    for k in range(-ZONE_PAD_SAMPLES, ZONE_PAD_SAMPLES + 1):
        wide[(idx + k) % n] = True
    start = np.flatnonzero(wide & ~np.roll(wide, 1))
    rows = []
    for a in start:
        b = a
        while wide[(b + 1) % n]:
            b += 1
        ta, tb = a * h, b * h
        row = np.zeros(K.N_ZONE)
        row[K.Z_TA], row[K.Z_TB] = ta, tb
        offsets = _slope_samples(profile, ta, tb, min_pin_radius_m)
        row[K.Z_NS] = len(offsets)
        row[K.Z_S0:K.Z_S0 + len(offsets)] = offsets
        edges = np.linspace(ta, tb, K.ZONE_ARCS + 1)
        for k, (lo, hi) in enumerate(zip(edges[:-1], edges[1:])):
            qz, _, _ = profile.evaluate(np.linspace(lo, hi, 64))
            centre = 0.5 * (complex(qz.real.min(), qz.imag.min()) + complex(qz.real.max(), qz.imag.max()))
            # chords between the samples sag far less than their length: the circle covers the arc
            row[K.Z_CX + 3 * k:K.Z_CX + 3 * k + 3] = (centre.real, centre.imag,
                                                      float(np.abs(qz - centre).max() + np.abs(np.diff(qz)).max()))
        rows.append(row)
    return np.array(sorted(rows, key=lambda r: r[K.Z_TA]))


def _slope_samples(profile: CycloidProfile, ta: float, tb: float, min_pin_radius_m: float) -> np.ndarray:
    """Offsets from ``ta`` of the slope samples of the zone [ta, tb] (rad, ascending, 0 and
    tb − ta included): both ends of every stretch whose radius of curvature is below
    r_min − CONTACT_RANGE_M (at most one critical point of the distance there, a maximum)
    and the quarter points of the stretches between them; uniform if that needs more than
    ZONE_SLOPE_MAX samples."""
    t = np.linspace(ta, tb, ZONE_FINE_SAMPLES)
    strict = profile.curvature(t) < -1.0 / (min_pin_radius_m - K.CONTACT_RANGE_M)
    cuts = [0]
    for k in range(1, len(t) - 1):
        if strict[k] and not (strict[k - 1] and strict[k + 1]):  # first or last sample of a strict stretch
            cuts.append(k)
    cuts.append(len(t) - 1)
    out = [t[cuts[0]]]
    for lo, hi in zip(cuts[:-1], cuts[1:]):
        if not (strict[lo] and strict[hi] and strict[lo:hi + 1].all()):
            out += list(np.linspace(t[lo], t[hi], 5)[1:-1])
        out.append(t[hi])
    out = np.unique(np.array(out) - ta)
    if len(out) > K.ZONE_SLOPE_MAX:
        out = np.linspace(0.0, tb - ta, K.ZONE_SLOPE_MAX)
    return out


def _exu():
    import exudyn

    return exudyn


def add_cycloid_pin_contact(mbs, disc_node: int, stage: CycloidStage, law: ContactLaw, *, disc: int = 0,
                            errors: ErrorSpec | None = None, max_penetration_m: float = DEFAULT_MAX_PENETRATION_M,
                            initial_interference_m: float = DEFAULT_INITIAL_INTERFERENCE_M,
                            profile: CycloidProfile | None = None, modal_node: int = -1,
                            phi: np.ndarray | None = None, offset_rad: float | None = None,
                            housing_node: int = -1, seat: np.ndarray | None = None,
                            axial_m: float = 0.0, lever_m: float | None = None) -> CycloidPinContact:
    """Add the contact between disc ``disc`` of ``stage`` (on ``disc_node``) and the fixed pin ring.

    Parameters
    ----------
    mbs : exudyn.MainSystem
        System to add to.
    disc_node : int
        A NodeRigidBody2D carrying the disc body; its rotation coordinate is the disc angle
        (the profile frame is turned by −ϕ_k/z_c for a disc with eccentric phase ϕ_k).
    stage : CycloidStage
        Geometry and modification.
    law : ContactLaw
        Normal law, damping and friction.
    disc : int
        Disc index (selects the disc phase and the disc errors).
    errors : ErrorSpec, optional
        Pin and disc errors (validated against the stage's counts by the caller's spec check).
    max_penetration_m : float
        A run whose deepest penetration exceeds this stops with :class:`ContactError`.
    initial_interference_m : float
        The initial configuration may interfere by at most this much (m).
    modal_node, phi : int, ndarray, optional
        A flexible disc: ``disc_node`` is the reference node (NodeRigidBodyRxyz, planar: its
        z, ψx, ψy held by the caller) of an FFRF body whose modal coordinates are the
        NodeGenericODE2 ``modal_node``; ``phi`` (n_grid, 2, m) is the modal flank
        displacement in the profile frame on the uniform profile-parameter grid.
    offset_rad : float, optional
        Profile frame against the node's rotation (rad); default −φ_d/z_c (disc phase).
    housing_node, seat : int, ndarray, optional
        A flexible pin housing: its modal coordinates are the NodeGenericODE2 ``housing_node``
        (h coordinates) and pin i sits at its nominal centre plus ``seat[i] @ ξ`` (``seat``
        (n_pins, 2, h), m per modal unit, ring frame): the in-plane motion of its seat.
    axial_m : float, optional
        The disc's axial position from the discs' mid-plane (m): where a tilted pin ring
        (``errors.pin_ring_tilt_rad``) is cut.
    lever_m : float, optional
        A spatial rigid disc: ``disc_node`` is its ``NodeRigidBodyRxyz`` and the element acts on the disc's
        section at this axial distance from the node (m; the slice's plane less the node's), whose in-plane pose
        the disc's tilt moves (:mod:`rvflex.contact.tilt_map`). None (default): a planar or FE disc.

    Raises
    ------
    ValueError
        Wrong node type, a pin or disc error set that does not match the stage (SpecError),
        bad tolerances, or initial interference beyond the tolerance (naming the pin).
    """
    node = mbs.GetNode(disc_node)
    flexible = modal_node >= 0
    tilted = lever_m is not None
    if tilted and (flexible or housing_node >= 0 or not math.isfinite(lever_m)):
        raise ValueError(f"lever_m = {lever_m!r}: a tilting slice needs a finite lever on a rigid disc with fixed "
                         "pins (no modal_node, no housing_node)")
    if node.get("nodeType") != ("RigidBodyRxyz" if flexible or tilted else "RigidBody2D"):
        need = ("a NodeRigidBodyRxyz (flexible disc)" if flexible else "a NodeRigidBodyRxyz (spatial disc)" if tilted
                else "a NodeRigidBody2D")
        raise ValueError(f"disc_node = {disc_node}: must be {need}, not {node.get('nodeType')}")
    phi = np.zeros((0, 2, 0)) if phi is None else np.ascontiguousarray(phi, dtype=float)
    m = phi.shape[2]
    if flexible and (phi.ndim != 3 or phi.shape[1] != 2 or phi.shape[0] < 8
                     or mbs.GetNode(modal_node).get("numberOfODE2Coordinates") != m):
        raise ValueError(f"phi {phi.shape}: must be (n_grid ≥ 8, 2, m) with m the modal node's coordinates")
    rigid_index = (0, 1, 5) if flexible or tilted else (0, 1, 2)
    seat = np.zeros((0, 2, 0)) if seat is None else np.ascontiguousarray(seat, dtype=float)
    h = seat.shape[2]
    if housing_node >= 0 and (seat.shape[:2] != (stage.pin_count, 2) or h == 0
                              or mbs.GetNode(housing_node).get("numberOfODE2Coordinates") != h):
        raise ValueError(f"seat {seat.shape}: must be (pin_count = {stage.pin_count}, 2, h) with h the housing "
                         f"node's coordinates")
    if housing_node < 0:
        seat = np.zeros((0, 2, 0))
        h = 0
    if not 0 <= disc < stage.disc_count:
        raise ValueError(f"disc = {disc}: the stage has {stage.disc_count} discs")
    for name, v in (("max_penetration_m", max_penetration_m), ("initial_interference_m", initial_interference_m)):
        if not v > 0:
            raise ValueError(f"{name} = {v!r}: must be positive")
    if errors is not None:
        errors.check_cycloid(stage)
    prof = profile or build_profile(stage, errors, disc)
    pins = np.ascontiguousarray(pin_centres(stage, errors, axial_m))
    radii = np.ascontiguousarray(pin_radii(stage, errors))
    ref = np.asarray(node["referenceCoordinates"], float)
    init = ref + np.asarray(node.get("initialCoordinates", np.zeros(len(ref))), float)
    contact = CycloidPinContact(
        object_index=-1, node=disc_node, profile=prof, pins_m=pins, radii_m=radii, law=law,
        offset_rad=-stage.disc_phase_rad[disc] / stage.disc_teeth if offset_rad is None else offset_rad,
        reference=ref,
        max_penetration_m=max_penetration_m, _law_vec=law.vector(),
        _t_cache=np.full(len(radii), np.nan),
        _work=_Workspace.for_pins(len(radii), rigid_index, len(ref), m, h, tilted),
        zones=concave_zones(prof, float(radii.max()), float(radii.min())), zone_window_rad=math.pi / stage.disc_teeth,
        modal_node=modal_node, phi=phi, rigid_index=rigid_index, housing_node=int(housing_node), seat=seat,
        lever_m=float(lever_m) if tilted else None)
    _, _, _, out, _ = contact.evaluate(contact.section(init)[0])
    worst = int(np.argmin(out[:, K.O_GAP]))
    if -out[worst, K.O_GAP] > initial_interference_m:
        raise ValueError(f"initial configuration: pin {worst} interferes with disc {disc} by "
                         f"{-out[worst, K.O_GAP] * 1e6:.3f} µm (tolerance {initial_interference_m * 1e6:g} µm)")
    from exudyn.itemInterface import ObjectGenericODE2

    nobj = len(ref) + m + h
    nodes = [disc_node] + ([modal_node] if flexible else []) + ([housing_node] if h else [])
    idx = mbs.AddObject(ObjectGenericODE2(
        nodeNumbers=nodes, massMatrix=np.zeros((nobj, nobj)),
        stiffnessMatrix=np.zeros((nobj, nobj)), dampingMatrix=np.zeros((nobj, nobj)),
        forceUserFunction=contact._force_uf,
        jacobianUserFunction=contact._jacobian_uf))
    object.__setattr__(contact, "object_index", int(idx))
    return contact

"""Frozen, validated specifications of an RV reducer, its errors and its tooth modification.

Everything is SI (m, rad, N, N·m, kg, Pa, s). Every dataclass validates itself in
``__post_init__`` with closed-form rules and raises :class:`SpecError` naming the field, its
value and the rule it breaks; variants are made with :func:`dataclasses.replace`, which
re-validates. The geometric profile check (the modified cycloid profile must be a simple
closed curve) needs the exact profile evaluation of :mod:`rvflex.geometry.profile`, which is
built from these types; it runs where specs enter: :func:`rvflex.spec.loads_spec`, the
catalogue and ``build_reducer``.

Import these types from :mod:`rvflex.spec`, which re-exports them with the TOML I/O; this
module sits below :mod:`rvflex.geometry` so that the geometry can be built from a spec while
loading a spec can check its geometry.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from rvflex.units import MM

__all__ = [
    "SpecError",
    "Material",
    "Materials",
    "InputStage",
    "Modification",
    "CycloidStage",
    "Cranks",
    "Bearing",
    "AngularContactPair",
    "Bearings",
    "Carrier",
    "ReducerSpec",
    "ErrorSpec",
    "BEARING_KINDS",
    "PAIR_ARRANGEMENTS",
]

BEARING_KINDS = (
    "needle",
    "cylindrical_roller",
    "tapered_roller",
    "angular_contact_ball",
    "deep_groove_ball",
    "crossed_roller",
)

PAIR_ARRANGEMENTS = ("back_to_back", "face_to_face")
"""Arrangements of an angular-contact pair: back-to-back (O: the contact lines spread apart away
from the rows, as in RV-E main bearings) and face-to-face (X: they meet between the rows)."""


class SpecError(ValueError):
    """A specification value breaks a rule.

    Parameters
    ----------
    field : str
        Dotted name of the offending field (``cycloid.pin_circle_radius_m``).
    value : object
        The value found.
    rule : str
        The rule it breaks, in words.
    source : str, optional
        File (or other origin) the value came from.
    """

    def __init__(self, field: str, value: object, rule: str, source: str | None = None):
        self.field, self.value, self.rule, self.source = field, value, rule, source
        where = f"{source}: " if source else ""
        super().__init__(f"{where}{field} = {value!r}: {rule}")

    def __reduce__(self):  # picklable across worker processes
        return (type(self), (self.field, self.value, self.rule, self.source))

    def within(self, prefix: str = "", source: str | None = None) -> "SpecError":
        """Return the same error with a table prefix and/or a source file attached.

        Parameters
        ----------
        prefix : str, optional
            Table name put before the field (``cycloid`` → ``cycloid.pin_radius_m``).
        source : str, optional
            File the value came from (kept from this error when None).

        Returns
        -------
        SpecError
            The new error.
        """
        name = f"{prefix}.{self.field}" if prefix and not self.field.startswith(prefix + ".") else self.field
        return SpecError(name, self.value, self.rule, source or self.source)


def _range(name: str, value: float, lo: float, hi: float, rule: str) -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and lo <= value <= hi):
        raise SpecError(name, value, rule)


def _positive(name: str, value: float, unit: str) -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        raise SpecError(name, value, f"must be a positive number in {unit}")


def _int_range(name: str, value: int, lo: int, hi: int) -> None:
    if not (isinstance(value, int) and not isinstance(value, bool) and lo <= value <= hi):
        raise SpecError(name, value, f"must be an integer from {lo} to {hi}")


def _one_of(name: str, value: str, options: tuple[str, ...]) -> None:
    if value not in options:
        raise SpecError(name, value, f"must be one of {', '.join(options)}")


# --------------------------------------------------------------------------- materials


@dataclass(frozen=True, slots=True)
class Material:
    """Isotropic linear-elastic material."""

    name: str
    density_kg_m3: float
    youngs_modulus_Pa: float
    poisson_ratio: float

    def __post_init__(self) -> None:
        _range("density_kg_m3", self.density_kg_m3, 500.0, 25_000.0, "expected kg/m³ (steel is 7850)")
        _range("youngs_modulus_Pa", self.youngs_modulus_Pa, 1e9, 1e12,
               "expected Pa, 1 GPa to 1000 GPa (steel is 2.07e11, not 207)")
        _range("poisson_ratio", self.poisson_ratio, 0.0, 0.5, "must lie in [0, 0.5]")


@dataclass(frozen=True, slots=True)
class Materials:
    """Materials of the reducer's parts (seed 004 Table 2)."""

    gears_cranks_discs: Material
    pins: Material
    pin_housing: Material
    carriers: Material


# --------------------------------------------------------------------------- input stage


@dataclass(frozen=True, slots=True)
class InputStage:
    """Involute first stage: sun on the input shaft, one planet per crank.

    ``mesh_stiffness_*`` describe the time-varying mesh stiffness
    k(t) = mean + amplitude·cos(mesh phase) (seed 003 Table 3). ``backlash_m`` is the
    circumferential backlash at the pitch circle (the normal backlash is that times cos α).
    """

    sun_teeth: int
    planet_teeth: int
    module_m: float
    pressure_angle_rad: float
    face_width_m: float
    mesh_stiffness_mean_N_m: float
    mesh_stiffness_amplitude_N_m: float
    mesh_damping_Ns_m: float
    backlash_m: float

    def __post_init__(self) -> None:
        _int_range("sun_teeth", self.sun_teeth, 6, 400)
        _int_range("planet_teeth", self.planet_teeth, 6, 400)
        _range("module_m", self.module_m, 0.1 * MM, 20 * MM, "expected metres, 0.1 mm to 20 mm")
        _range("pressure_angle_rad", self.pressure_angle_rad, math.radians(10), math.radians(35),
               "expected radians, 10° to 35° (20° is 0.349)")
        _range("face_width_m", self.face_width_m, 1 * MM, 0.2, "expected metres, 1 mm to 200 mm")
        _range("mesh_stiffness_mean_N_m", self.mesh_stiffness_mean_N_m, 1e6, 1e12, "expected N/m, 1e6 to 1e12")
        _range("mesh_stiffness_amplitude_N_m", self.mesh_stiffness_amplitude_N_m, 0.0,
               self.mesh_stiffness_mean_N_m, "expected N/m, from 0 to the mean stiffness")
        _range("mesh_damping_Ns_m", self.mesh_damping_Ns_m, 0.0, 1e7, "expected N·s/m, 0 to 1e7")
        _range("backlash_m", self.backlash_m, 0.0, 1 * MM, "expected metres, 0 to 1 mm")

    @property
    def centre_distance_m(self) -> float:
        """Sun–planet centre distance of the unshifted gears, m(z1 + z2)/2 (m)."""
        return self.module_m * (self.sun_teeth + self.planet_teeth) / 2.0


# --------------------------------------------------------------------------- cycloid stage


@dataclass(frozen=True, slots=True)
class Modification:
    """Cycloid tooth-profile modification; all four kinds may be combined.

    Sign convention (seeds 002 and 004): the modified profile is generated by pins of
    radius ``r_rp + equidistant_m`` on a pin circle of radius ``r_p + moved_m``.
    A positive ``equidistant_m`` (Δr_rp) removes material evenly and opens clearance;
    a positive ``moved_m`` (Δr_p) moves the flank outward and closes clearance. To first
    order the normal clearance at the pin at angle φ is
    Δr_rp − Δr_p·(1 − K1·cosφ)/√(1 + K1² − 2K1·cosφ).

    Pressure-angle segmented modification (seed 003 eqs. 26–29): where the pressure angle
    exceeds ``tip_pressure_angle_rad`` on the tooth-tip side (``root_pressure_angle_rad``
    on the root side) the generating pin radius grows by up to ``tip_amount_m``
    (``root_amount_m``) at the tip (root) apex, blended in with a C² quintic so that the
    profile and its curvature stay continuous. An amount of 0 switches a zone off.

    Deformation-compensated modification (seed 002): the generating pin radius grows
    by δ(τ) = ``compensation_m``·|sin τ|/√(1 + K1² − 2K1·cosτ) (τ: tooth phase, 0 at the
    root); |sin τ| is smoothed within ~0.01 rad of root and tip so the profile stays C².
    """

    moved_m: float = 0.0
    equidistant_m: float = 0.0
    tip_pressure_angle_rad: float = math.radians(65.0)
    tip_amount_m: float = 0.0
    root_pressure_angle_rad: float = math.radians(75.0)
    root_amount_m: float = 0.0
    compensation_m: float = 0.0

    def __post_init__(self) -> None:
        for name in ("moved_m", "equidistant_m"):
            _range(name, getattr(self, name), -0.5 * MM, 0.5 * MM,
                   "expected metres; modifications are tens of µm, at most ±0.5 mm")
        for name in ("tip_pressure_angle_rad", "root_pressure_angle_rad"):
            _range(name, getattr(self, name), math.radians(5), math.radians(89.5),
                   "expected radians between 5° and 89.5°")
        for name in ("tip_amount_m", "root_amount_m"):
            _range(name, getattr(self, name), 0.0, 0.5 * MM, "expected metres, 0 to 0.5 mm")
        _range("compensation_m", self.compensation_m, -0.1 * MM, 0.1 * MM,
               "expected metres; elastic compensation is a few µm, at most ±0.1 mm")

    @property
    def kinds(self) -> tuple[str, ...]:
        """Names of the modification kinds that are switched on."""
        out = []
        if self.equidistant_m:
            out.append("equidistant")
        if self.moved_m:
            out.append("moved")
        if self.tip_amount_m or self.root_amount_m:
            out.append("pressure_angle")
        if self.compensation_m:
            out.append("compensated")
        return tuple(out)


@dataclass(frozen=True, slots=True)
class CycloidStage:
    """Cycloid–pin stage: ``disc_count`` discs of ``disc_teeth`` teeth in a ring of ``pin_count`` pins.

    The short-width coefficient is K1 = e·z_b/r_p (seed 003; seed 002 writes a·z_c/r_p);
    the pin-centre curve is regular only for K1 < 1.
    """

    disc_teeth: int
    pin_count: int
    pin_circle_radius_m: float
    pin_radius_m: float
    eccentricity_m: float
    disc_thickness_m: float
    disc_center_hole_radius_m: float
    disc_count: int
    disc_phase_rad: tuple[float, ...]
    modification: Modification

    def __post_init__(self) -> None:
        _int_range("disc_teeth", self.disc_teeth, 5, 200)
        if self.pin_count != self.disc_teeth + 1:
            raise SpecError("pin_count", self.pin_count,
                            f"must equal disc_teeth + 1 = {self.disc_teeth + 1} (z_b = z_c + 1)")
        _range("pin_circle_radius_m", self.pin_circle_radius_m, 5 * MM, 1.0, "expected metres, 5 mm to 1 m")
        _range("pin_radius_m", self.pin_radius_m, 0.3 * MM, 0.05, "expected metres, 0.3 mm to 50 mm")
        _range("eccentricity_m", self.eccentricity_m, 0.05 * MM, 0.05, "expected metres, 0.05 mm to 50 mm")
        _range("disc_thickness_m", self.disc_thickness_m, 1 * MM, 0.2, "expected metres, 1 mm to 200 mm")
        _range("disc_center_hole_radius_m", self.disc_center_hole_radius_m, 0.0,
               self.pin_circle_radius_m - self.eccentricity_m - self.pin_radius_m,
               "expected metres, from 0 to the profile's root radius r_p − e − r_rp")
        if self.k1 >= 1.0:
            raise SpecError("eccentricity_m", self.eccentricity_m,
                            f"K1 = e·z_b/r_p = {self.k1:.4f} must be < 1 (the pin-centre curve loops)")
        gap = 2 * self.pin_circle_radius_m * math.sin(math.pi / self.pin_count)
        if 2 * self.pin_radius_m >= gap:
            raise SpecError("pin_radius_m", self.pin_radius_m,
                            f"pin cannot fit: neighbouring pins {gap * 1e3:.3f} mm apart overlap")
        _int_range("disc_count", self.disc_count, 1, 4)
        if len(self.disc_phase_rad) != self.disc_count:
            raise SpecError("disc_phase_rad", self.disc_phase_rad, f"needs one phase per disc ({self.disc_count})")
        for k, ph in enumerate(self.disc_phase_rad):
            _range(f"disc_phase_rad[{k}]", ph, 0.0, 2 * math.pi, "expected radians in [0, 2π]")
        # the profile's geometric check (no self-intersection) runs where specs enter (rvflex.spec)

    @property
    def k1(self) -> float:
        """Short-width coefficient K1 = e·z_b/r_p (–)."""
        return self.eccentricity_m * self.pin_count / self.pin_circle_radius_m


# --------------------------------------------------------------------------- cranks, bearings, carrier


@dataclass(frozen=True, slots=True)
class Cranks:
    """Crankshafts: ``count`` cranks on a circle, each with one eccentric per disc.

    Axial positions are along the reducer axis from the discs' mid-plane (m). The last three fields
    place the crank in space (the spatial model); a planar model reads none of them.

    Parameters
    ----------
    count : int
        Cranks (2 or 3).
    crank_circle_radius_m : float
        Radius of the circle of crank axes, m.
    angles_rad : tuple of float
        Angle of each crank axis, rad.
    eccentric_axial_positions_m : tuple of float
        Axial position of each eccentric (one per disc), m.
    eccentric_journal_radius_m : float
        Radius of the eccentric journals, m.
    disc_bore_radius_m : float
        Radius of the crank bores in the discs, m.
    support_span_m : float or None, optional
        Axial distance between a crank's two support bearings in the carrier's end plates, m, symmetric
        about the discs' mid-plane; the eccentrics lie between them (None: not stated).
    support_journal_radius_m : float or None, optional
        Radius of the crank's journals in its support bearings, m (None: not stated).
    gear_axial_position_m : float or None, optional
        Axial position of the mid-plane of the crank's spur gear (the planet of the input stage), m
        (None: not stated).
    """

    count: int
    crank_circle_radius_m: float
    angles_rad: tuple[float, ...]
    eccentric_axial_positions_m: tuple[float, ...]
    eccentric_journal_radius_m: float
    disc_bore_radius_m: float
    support_span_m: float | None = None
    support_journal_radius_m: float | None = None
    gear_axial_position_m: float | None = None

    def __post_init__(self) -> None:
        if self.count not in (2, 3):
            raise SpecError("count", self.count, "an RV reducer has 2 or 3 cranks")
        _range("crank_circle_radius_m", self.crank_circle_radius_m, 5 * MM, 1.0, "expected metres, 5 mm to 1 m")
        if len(self.angles_rad) != self.count:
            raise SpecError("angles_rad", self.angles_rad, f"needs one angle per crank ({self.count})")
        for k, a in enumerate(self.angles_rad):
            _range(f"angles_rad[{k}]", a, 0.0, 2 * math.pi, "expected radians in [0, 2π]")
        for k, z in enumerate(self.eccentric_axial_positions_m):
            _range(f"eccentric_axial_positions_m[{k}]", z, -0.5, 0.5, "expected metres within ±0.5 m")
        _range("eccentric_journal_radius_m", self.eccentric_journal_radius_m, 1 * MM, 0.2,
               "expected metres, 1 mm to 200 mm")
        if not self.eccentric_journal_radius_m < self.disc_bore_radius_m < self.crank_circle_radius_m:
            raise SpecError("disc_bore_radius_m", self.disc_bore_radius_m,
                            "must lie between the eccentric journal radius and the crank circle radius")
        if self.support_span_m is not None:
            _range("support_span_m", self.support_span_m, 1 * MM, 1.0,
                   "expected a positive length in metres, 1 mm to 1 m")
            outer = max((abs(z) for z in self.eccentric_axial_positions_m), default=0.0)
            if not outer < self.support_span_m / 2:
                raise SpecError("support_span_m", self.support_span_m,
                                f"must exceed twice the outermost eccentric's axial position ({2 * outer:g} m): "
                                "the eccentrics lie between the two support bearings")
        if self.support_journal_radius_m is not None:
            _range("support_journal_radius_m", self.support_journal_radius_m, 1 * MM, 0.2,
                   "expected a positive length in metres, 1 mm to 200 mm")
        if self.gear_axial_position_m is not None:
            _range("gear_axial_position_m", self.gear_axial_position_m, -0.5, 0.5, "expected metres within ±0.5 m")


@dataclass(frozen=True, slots=True)
class Bearing:
    """A rolling bearing as a bushing: radial stiffness beyond a radial clearance.

    Beyond the clearance the radial force is linear, k·x (x the approach past the clearance), unless
    ``load_exponent`` e and ``reference_load_N`` F_r are given (both or neither): then it is the rolling
    contact's power law F = F_r·(x/x_r)^e, x_r = F_r/k, so ``radial_stiffness_N_m`` k is the secant stiffness at
    F_r, the law softer below it and stiffer above (e = 10/9 a roller's line contact, Palmgren; 1.5 a ball's
    point contact)."""

    kind: str
    radial_stiffness_N_m: float
    axial_stiffness_N_m: float
    tilt_stiffness_Nm_rad: float
    radial_damping_Ns_m: float
    clearance_m: float
    load_exponent: float | None = None
    reference_load_N: float | None = None

    def __post_init__(self) -> None:
        _one_of("kind", self.kind, BEARING_KINDS)
        _range("radial_stiffness_N_m", self.radial_stiffness_N_m, 1e5, 1e12, "expected N/m, 1e5 to 1e12")
        _range("axial_stiffness_N_m", self.axial_stiffness_N_m, 1e5, 1e12, "expected N/m, 1e5 to 1e12")
        _range("tilt_stiffness_Nm_rad", self.tilt_stiffness_Nm_rad, 1e2, 1e10, "expected N·m/rad, 1e2 to 1e10")
        _range("radial_damping_Ns_m", self.radial_damping_Ns_m, 0.0, 1e7, "expected N·s/m, 0 to 1e7")
        _range("clearance_m", self.clearance_m, 0.0, 0.2 * MM, "expected metres, 0 to 0.2 mm (µm-scale)")
        if (self.load_exponent is None) != (self.reference_load_N is None):
            missing = "reference_load_N" if self.reference_load_N is None else "load_exponent"
            raise SpecError(missing, None, "a power-law bearing needs both load_exponent and reference_load_N "
                                           "(neither: the linear law)")
        if self.load_exponent is not None:
            _range("load_exponent", self.load_exponent, 1.0, 2.0,
                   "expected 1 (linear) to 2; a roller's line contact is 10/9, a ball's point contact 1.5")
            _range("reference_load_N", self.reference_load_N, 1.0, 1e7, "expected N, 1 to 1e7")

    @property
    def reference_approach_m(self) -> float:
        """x_r = F_r/k: the approach past the clearance at which the power law carries its reference load (m);
        0 for the linear law."""
        return 0.0 if self.reference_load_N is None else self.reference_load_N / self.radial_stiffness_N_m


@dataclass(frozen=True, slots=True)
class AngularContactPair:
    """Geometry and preload of a pair of angular-contact ball rows (the main bearing pair).

    The two rows are coaxial with the reducer axis, ``row_spacing_m`` apart (ball centre to ball
    centre), symmetric about the middle plane; the outer rings sit in the housing, the inner
    raceways on the output carrier. Groove radii are ``inner_conformity`` and
    ``outer_conformity`` times the ball diameter (f = r_groove / D, > 0.5). ``preload_N`` is the
    axial force each row carries when no external load acts (0: the balls just touch).

    Parameters
    ----------
    kind : str
        ``"angular_contact_ball"`` (the only kind modelled).
    arrangement : str
        ``"back_to_back"`` (O) or ``"face_to_face"`` (X), :data:`PAIR_ARRANGEMENTS`.
    pitch_diameter_m : float
        Diameter of the circle of ball centres, m.
    row_spacing_m : float
        Axial distance between the two rows' ball-centre planes, m.
    contact_angle_rad : float
        Nominal (unloaded) contact angle from the radial plane, rad, in (0, π/2).
    balls_per_row : int
        Rolling elements in each row (count).
    ball_diameter_m : float
        Ball diameter, m.
    inner_conformity, outer_conformity : float
        Groove radius over ball diameter of the inner and outer raceway (–), in (0.5, 0.6].
    preload_N : float
        Axial preload of each row, N (≥ 0).
    material : Material
        Elastic constants of balls and raceways (both taken alike).
    """

    kind: str
    arrangement: str
    pitch_diameter_m: float
    row_spacing_m: float
    contact_angle_rad: float
    balls_per_row: int
    ball_diameter_m: float
    inner_conformity: float
    outer_conformity: float
    preload_N: float
    material: Material

    def __post_init__(self) -> None:
        if self.kind != "angular_contact_ball":
            raise SpecError("kind", self.kind, "must be 'angular_contact_ball' (the only pair kind modelled)")
        _one_of("arrangement", self.arrangement, PAIR_ARRANGEMENTS)
        _range("pitch_diameter_m", self.pitch_diameter_m, 10 * MM, 2.0, "expected metres, 10 mm to 2 m")
        _range("ball_diameter_m", self.ball_diameter_m, 0.5 * MM, 0.1, "expected metres, 0.5 mm to 100 mm")
        if not self.ball_diameter_m < 0.25 * self.pitch_diameter_m:
            raise SpecError("ball_diameter_m", self.ball_diameter_m,
                            f"must be below a quarter of the pitch diameter ({self.pitch_diameter_m:g} m)")
        _range("row_spacing_m", self.row_spacing_m, self.ball_diameter_m, 1.0,
               "expected metres, from one ball diameter (rows side by side) to 1 m")
        if not (isinstance(self.contact_angle_rad, (int, float)) and 0.0 < self.contact_angle_rad < math.pi / 2):
            raise SpecError("contact_angle_rad", self.contact_angle_rad,
                            "must lie in (0, π/2) rad, open (40° is 0.698)")
        _int_range("balls_per_row", self.balls_per_row, 3, 1000)
        pitch = math.pi * self.pitch_diameter_m / self.balls_per_row
        if not pitch > self.ball_diameter_m:
            raise SpecError("balls_per_row", self.balls_per_row,
                            f"{self.balls_per_row} balls of {self.ball_diameter_m * 1e3:g} mm do not fit on a "
                            f"{self.pitch_diameter_m * 1e3:g} mm pitch circle (ball pitch {pitch * 1e3:.3f} mm)")
        for name in ("inner_conformity", "outer_conformity"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and 0.5 < value <= 0.6):
                raise SpecError(name, value, "groove radius over ball diameter must lie in (0.5, 0.6] (0.52 is usual)")
        _range("preload_N", self.preload_N, 0.0, 1e7, "expected an axial force in N, from 0 to 1e7 (not negative)")


@dataclass(frozen=True, slots=True)
class TaperedRollerPair:
    """Geometry of a crank's two support bearings as preloaded tapered roller rows (the spatial model).

    Each row has ``rollers`` rollers of ``roller_diameter_m`` and effective length ``roller_length_m``
    between a cone of ``bore_diameter_m`` and a cup of ``outer_diameter_m``; the cup raceway meets the
    axis at ``cup_angle_rad`` (the bearing's contact angle). The rows sit at ±``cranks.support_span_m``/2
    (their roller mid-planes). Where and how stiff each carries: :mod:`rvflex.contact.tapered_roller`.

    Parameters
    ----------
    kind : str
        ``"tapered_roller"`` (the only kind modelled).
    arrangement : str
        ``"back_to_back"`` (O: pressure centres outboard) or ``"face_to_face"`` (X), :data:`PAIR_ARRANGEMENTS`.
    bore_diameter_m, outer_diameter_m : float
        Bore (the crank's journal) and outside diameter of each bearing, m.
    roller_diameter_m : float
        Mean roller diameter, m.
    roller_length_m : float
        Effective roller length (its line contact), m.
    rollers : int
        Rollers in each row (count).
    cup_angle_rad : float
        Angle of the cup raceway to the axis, rad, in (0, π/4].
    """

    kind: str
    arrangement: str
    bore_diameter_m: float
    outer_diameter_m: float
    roller_diameter_m: float
    roller_length_m: float
    rollers: int
    cup_angle_rad: float

    def __post_init__(self) -> None:
        if self.kind != "tapered_roller":
            raise SpecError("kind", self.kind, "must be 'tapered_roller' (the only crank support pair kind modelled)")
        _one_of("arrangement", self.arrangement, PAIR_ARRANGEMENTS)
        _range("bore_diameter_m", self.bore_diameter_m, 2 * MM, 0.5, "expected metres, 2 mm to 500 mm")
        _range("outer_diameter_m", self.outer_diameter_m, self.bore_diameter_m, 1.0,
               "expected metres, above the bore, up to 1 m")
        ring = 0.5 * (self.outer_diameter_m - self.bore_diameter_m)
        _range("roller_diameter_m", self.roller_diameter_m, 0.2 * MM, ring,
               f"expected metres, 0.2 mm up to the rings' radial section {ring * 1e3:g} mm")
        _range("roller_length_m", self.roller_length_m, 0.5 * MM, 0.2, "expected metres, 0.5 mm to 200 mm")
        _int_range("rollers", self.rollers, 3, 200)
        pitch = math.pi * self.pitch_diameter_m / self.rollers
        if not pitch > self.roller_diameter_m:
            raise SpecError("rollers", self.rollers,
                            f"{self.rollers} rollers of {self.roller_diameter_m * 1e3:g} mm do not fit on the "
                            f"{self.pitch_diameter_m * 1e3:g} mm pitch circle (roller pitch {pitch * 1e3:.3f} mm)")
        if not (isinstance(self.cup_angle_rad, (int, float)) and 0.0 < self.cup_angle_rad <= math.pi / 4):
            raise SpecError("cup_angle_rad", self.cup_angle_rad,
                            "must lie in (0, π/4] rad (tapered roller bearings: 10° to 30°, 15° is 0.2618)")

    @property
    def pitch_diameter_m(self) -> float:
        """Diameter of the circle of roller centres, d_m = (d + D)/2 of bore d and outside diameter D, m."""
        return 0.5 * (self.bore_diameter_m + self.outer_diameter_m)

    @property
    def pressure_centre_offset_m(self) -> float:
        """Axial distance of a row's pressure centre from its roller mid-plane, m: r_c·tan α, r_c the cup
        raceway's radius at mid-roller, (d_m + D_w·cos α)/2 with the pitch diameter d_m; positive outboard
        (back to back), negative inboard (face to face)."""
        alpha = self.cup_angle_rad
        r_cup = 0.5 * (self.pitch_diameter_m + self.roller_diameter_m * math.cos(alpha))
        a = r_cup * math.tan(alpha)
        return a if self.arrangement == "back_to_back" else -a


@dataclass(frozen=True, slots=True)
class Bearings:
    """The reducer's bearings: crank supports in the carrier, eccentric (disc) bearings, main bearing.

    ``main`` is the main bearing lumped as one bushing (the planar model); ``main_pair``, when
    given, is its geometry as a pair of angular-contact rows (the spatial output support:
    ``rvflex moment-rigidity``). A spec without it runs every planar command. ``crank_support_pair``,
    when given, is the geometry of a crank's two support bearings as tapered roller rows (the spatial
    model's crank supports; without it each is half of ``crank_support`` at ±``cranks.support_span_m``/2).
    """

    crank_support: Bearing
    eccentric: Bearing
    main: Bearing
    main_pair: AngularContactPair | None = None
    crank_support_pair: TaperedRollerPair | None = None


@dataclass(frozen=True, slots=True)
class Carrier:
    """Output carrier (input-end and output-end plates joined by pillars through the discs)."""

    hole_distance_m: float
    pillar_count: int
    pillar_circle_radius_m: float
    pillar_radius_m: float
    disc_pillar_hole_radius_m: float
    plate_thickness_m: float
    outer_radius_m: float

    def __post_init__(self) -> None:
        _range("hole_distance_m", self.hole_distance_m, 5 * MM, 1.0, "expected metres, 5 mm to 1 m")
        _int_range("pillar_count", self.pillar_count, 0, 6)
        _range("pillar_circle_radius_m", self.pillar_circle_radius_m, 0.0, 1.0, "expected metres, 0 to 1 m")
        _range("pillar_radius_m", self.pillar_radius_m, 0.0, 0.2, "expected metres, 0 to 200 mm")
        if self.pillar_count and not self.disc_pillar_hole_radius_m > self.pillar_radius_m:
            raise SpecError("disc_pillar_hole_radius_m", self.disc_pillar_hole_radius_m,
                            "must exceed pillar_radius_m (the pillars pass through the discs with clearance)")
        _range("plate_thickness_m", self.plate_thickness_m, 1 * MM, 0.2, "expected metres, 1 mm to 200 mm")
        _range("outer_radius_m", self.outer_radius_m, 5 * MM, 1.0, "expected metres, 5 mm to 1 m")


# --------------------------------------------------------------------------- reducer


@dataclass(frozen=True, slots=True)
class ReducerSpec:
    """A whole RV reducer (housing and pins fixed, carrier is the output).

    ``ratio`` is the catalogue ratio; it must equal 1 + (z2/z1)·z_b.

    Parameters
    ----------
    name : str
        Identifier (letters, digits, ``-``, ``_``).
    description : str
        One line for people.
    ratio : float
        Catalogue ratio input/output (dimensionless).
    rated_torque_Nm, momentary_max_torque_Nm : float
        Rated and momentary maximum output torque, N·m.
    rated_output_speed_rpm : float
        Rated output speed, rpm.
    input_stage : InputStage
        The involute sun–planet stage.
    cycloid : CycloidStage
        Pins, discs and profile modification.
    cranks : Cranks
        The crankshafts.
    bearings : Bearings
        Stiffness and clearance of every bearing.
    carrier : Carrier
        The output carrier.
    materials : Materials
        Elastic constants of the parts.
    allowable_moment_Nm : float or None, optional
        Allowable tilting moment on the output, N·m (None: not stated; commands that load the
        output with a moment then need it).
    catalogue_moment_rigidity_Nm_per_arcmin : float or None, optional
        The maker's moment rigidity, N·m/arcmin, where a source gives one (a reference, never
        an input of the model).
    catalogue_lost_motion_arcmin : float or None, optional
        The maker's lost-motion class, arcmin: the most lost motion a unit of this size may show
        (None: not stated). Never an input of the model; the diagnosis takes from it the most
        crank-bearing clearance a healthy unit can have (:func:`rvflex.diagnosis.nominal.clearance_class_top`).
    """

    name: str
    description: str
    ratio: float
    rated_torque_Nm: float
    momentary_max_torque_Nm: float
    rated_output_speed_rpm: float
    input_stage: InputStage
    cycloid: CycloidStage
    cranks: Cranks
    bearings: Bearings
    carrier: Carrier
    materials: Materials
    allowable_moment_Nm: float | None = None
    catalogue_moment_rigidity_Nm_per_arcmin: float | None = None
    catalogue_lost_motion_arcmin: float | None = None

    def __post_init__(self) -> None:
        for name, unit in (("allowable_moment_Nm", "N·m"), ("catalogue_moment_rigidity_Nm_per_arcmin", "N·m/arcmin"),
                           ("catalogue_lost_motion_arcmin", "arcmin")):
            value = getattr(self, name)
            if value is not None:
                _positive(name, value, unit)
        if not self.name or not self.name.replace("_", "").replace("-", "").isalnum():
            raise SpecError("name", self.name, "must be a non-empty identifier (letters, digits, - or _)")
        _positive("rated_torque_Nm", self.rated_torque_Nm, "N·m")
        _positive("rated_output_speed_rpm", self.rated_output_speed_rpm, "rpm")
        if not self.momentary_max_torque_Nm >= self.rated_torque_Nm:
            raise SpecError("momentary_max_torque_Nm", self.momentary_max_torque_Nm,
                            f"must be at least the rated torque {self.rated_torque_Nm:g} N·m")
        if abs(self.ratio - self.nominal_ratio) > 1e-9 * self.nominal_ratio:
            s = self.input_stage
            raise SpecError("ratio", self.ratio,
                            f"must equal 1 + (z2/z1)·z_b = 1 + ({s.planet_teeth}/{s.sun_teeth})·"
                            f"{self.cycloid.pin_count} = {self.nominal_ratio:g}")
        a0 = self.input_stage.centre_distance_m
        if abs(self.cranks.crank_circle_radius_m - a0) > self.input_stage.module_m:
            raise SpecError("cranks.crank_circle_radius_m", self.cranks.crank_circle_radius_m,
                            f"must be within one module of the sun–planet centre distance {a0 * 1e3:.3f} mm")
        chord = 2 * self.cranks.crank_circle_radius_m * math.sin(
            math.pi / self.cranks.count if self.cranks.count > 2 else math.pi / 2)
        if abs(self.carrier.hole_distance_m - chord) > 1 * MM:
            raise SpecError("carrier.hole_distance_m", self.carrier.hole_distance_m,
                            f"must match the crank-bore spacing {chord * 1e3:.3f} mm of the crank circle")
        if len(self.cranks.eccentric_axial_positions_m) != self.cycloid.disc_count:
            raise SpecError("cranks.eccentric_axial_positions_m", self.cranks.eccentric_axial_positions_m,
                            f"needs one eccentric per disc ({self.cycloid.disc_count})")
        pair, cr = self.bearings.crank_support_pair, self.cranks
        if pair is not None:  # without a support span the spatial model is refused (check_spatial)
            if cr.support_journal_radius_m is not None and abs(pair.bore_diameter_m
                                                               - 2 * cr.support_journal_radius_m) > 1e-6:
                raise SpecError("bearings.crank_support_pair.bore_diameter_m", pair.bore_diameter_m,
                                f"must equal twice cranks.support_journal_radius_m ({2 * cr.support_journal_radius_m:g} "
                                "m): the bearings sit on the crank's support journals")
            inner = None if cr.support_span_m is None else 0.5 * cr.support_span_m + pair.pressure_centre_offset_m
            outer = max(abs(z) for z in cr.eccentric_axial_positions_m)
            if inner is not None and not inner > outer:
                raise SpecError("bearings.crank_support_pair.arrangement", pair.arrangement,
                                f"puts the rows' pressure centres at ±{inner * 1e3:.2f} mm, not outside the "
                                f"eccentrics (±{outer * 1e3:g} mm): the crank would not be held in tilt")

    def check_torque(self, field_name: str, value: float, *, allow_zero: bool = False) -> None:
        """Refuse an output torque outside (0, momentary maximum] N·m ([0, …] with ``allow_zero``).

        Parameters
        ----------
        field_name : str
            The name the error gives the value (the caller's parameter or flag).
        value : float
            The torque, N·m.
        allow_zero : bool, optional
            Accept zero torque.

        Raises
        ------
        SpecError
            Naming ``field_name``, the value and the allowed range.
        """
        lo_ok = value >= 0.0 if allow_zero else value > 0.0
        if not (lo_ok and value <= self.momentary_max_torque_Nm):
            bracket = "[0" if allow_zero else "(0"
            raise SpecError(field_name, value, f"must lie in {bracket}, {self.momentary_max_torque_Nm:g}] N·m "
                                               f"(the momentary maximum torque of {self.name})")

    def check_moment(self, field_name: str, value: float) -> None:
        """Refuse a tilting moment outside (0, allowable moment] N·m.

        Parameters
        ----------
        field_name : str
            The name the error gives the value (the caller's parameter or flag).
        value : float
            The moment, N·m.

        Raises
        ------
        SpecError
            Naming ``field_name``, the value and the allowed range; or naming
            ``allowable_moment_Nm`` when the spec states none.
        """
        if self.allowable_moment_Nm is None:
            raise SpecError("allowable_moment_Nm", None, f"{self.name} states no allowable moment; add "
                                                         "allowable_moment_Nm (N·m) to the spec's top level")
        if not (isinstance(value, (int, float)) and math.isfinite(value)
                and 0.0 < value <= self.allowable_moment_Nm):
            raise SpecError(field_name, value, f"must lie in (0, {self.allowable_moment_Nm:g}] N·m "
                                               f"(the allowable moment of {self.name})")

    def check_spatial(self, field: str = "--spatial") -> None:
        """Refuse a spec the spatial model cannot be built from: it needs the main bearing pair's
        geometry (the output's support in tilt and along the axis) and the cranks' support span (their
        support in tilt).

        Parameters
        ----------
        field : str, optional
            The option that asked for the spatial model, named in the message.

        Raises
        ------
        SpecError
            Naming ``bearings.main_pair`` or ``cranks.support_span_m``, whichever is absent first.
        """
        if self.bearings.main_pair is None:
            raise SpecError("bearings.main_pair", None, f"{self.name} gives no main bearing pair geometry, which "
                                                        f"{field} needs: add a [bearings.main_pair] table "
                                                        "(docs/spatial.md)")
        if self.cranks.support_span_m is None:
            raise SpecError("cranks.support_span_m", None, f"{self.name} gives no crank support span, which {field} "
                                                           "needs: add support_span_m (m, between a crank's two "
                                                           "support bearings) to [cranks]")

    @property
    def nominal_ratio(self) -> float:
        """Ratio input/output of the kinematic chain, 1 + (z2/z1)·z_b (–)."""
        s = self.input_stage
        return 1.0 + s.planet_teeth / s.sun_teeth * self.cycloid.pin_count


# --------------------------------------------------------------------------- errors


@dataclass(frozen=True, slots=True)
class ErrorSpec:
    """Manufacturing and assembly errors (seed 001 Table 2, seed 004 Table 1), all in m or rad.

    A tuple field is either empty (no error) or has one entry per item: per pin
    (``pin_count``), per crank (``count``), per disc (``disc_count``), or per disc and
    tooth (``disc_count`` tuples of ``disc_teeth`` values). Pin radial errors are positive
    outward; tangential errors positive counter-clockwise (arc length at the pin circle);
    disc profile errors positive where material is added (the flank moves toward the pin);
    disc pitch errors are cumulative, arc length at the pin circle, positive CCW.
    ``eccentric_bearing_clearance_m`` is ordered crank-major: entry k·disc_count + d is the
    bearing of crank k in disc d.

    Parameters
    ----------
    sun_base_eccentricity_m, sun_base_eccentricity_phase_rad : float
        Eccentricity of the sun's base circle (m) and its phase (rad).
    sun_runout_m, sun_runout_phase_rad : float
        Radial runout of the sun (m) and its phase (rad).
    sun_pitch_radius_error_m : float
        Pitch-radius error of the sun, m.
    input_shaft_angle_error_rad, input_shaft_angle_error_phase_rad : float
        Once-per-revolution angle error of the sun against the input angle θ_in at which the input is
        driven and read: the sun's teeth stand at θ_in + a·cos(θ_in − ψ), amplitude a (rad, 0 to 10 mrad)
        and phase ψ (rad). An input shaft driven off-centre (a parallel offset e to the motor at a drive
        radius R gives a ≈ e/R) or an input encoder mounted off-centre.
    planet_base_eccentricity_m, planet_base_eccentricity_phase_rad : tuple of float
        Per planet: base-circle eccentricity (m) and its phase (rad).
    planet_runout_m, planet_pitch_radius_error_m, planet_base_pitch_error_m : tuple of float
        Per planet: radial runout, pitch-radius error and base-pitch error, m.
    pin_radial_m, pin_tangential_m : tuple of float
        Per pin: position errors, radial (outward) and tangential (CCW, at the pin circle), m.
    pin_radius_error_m : float
        Radius error common to all pins, m.
    pin_radius_individual_m : tuple of float
        Per pin: radius error, m.
    pin_circle_radius_error_m : float
        Error of the pin-circle radius, m.
    pin_ring_runout_m, pin_ring_runout_phase_rad : float
        Runout of the pin ring (m) and its phase (rad).
    pin_ring_tilt_rad, pin_ring_tilt_phase_rad : float
        Tilt of the pins (their housing bores) against the crank axis (rad, at most 10 mrad) and the
        direction the ring leans towards (rad): the disc at axial position z (the crank's eccentric, from the
        discs' mid-plane) sees the pin ring shifted by tilt·z in that direction, the discs on either side
        oppositely.
    carrier_bore_eccentricity_m, carrier_bore_eccentricity_phase_rad : tuple of float
        Per crank: eccentricity of its carrier bore (m) and its phase (rad).
    carrier_runout_m, carrier_runout_phase_rad : float
        Runout of the carrier (m) and its phase (rad).
    input_carrier_hole_distance_error_m, output_carrier_hole_distance_error_m : float
        Crank-hole distance errors of the input and output carrier plates, m.
    crank_eccentricity_error_m, crank_phase_error_rad : tuple of float
        Per crank: eccentricity error (m) and phase error (rad).
    crank_runout_m, crank_runout_phase_rad : tuple of float
        Per crank: runout of its eccentrics (both alike) relative to its journal axis, turning with the
        crank (m), and its phase in the crank's frame from the first disc's eccentric (rad).
    crank_support_clearance_m, eccentric_bearing_clearance_m : tuple of float
        Radial clearance added to the nominal one of each crank support bearing (per crank) and
        each eccentric (needle) bearing (per crank and disc, crank-major), m.
    main_bearing_clearance_m : float
        Radial clearance added to the main bearing's, m.
    disc_pitch_error_m, disc_profile_error_m : tuple of tuple of float
        Per disc and tooth: cumulative pitch error (arc length at the pin circle, CCW) and
        profile error (material added), m.
    disc_bore_distance_error_m, disc_moved_error_m, disc_equidistant_error_m : tuple of float
        Per disc: crank-bore distance error and errors of the moved and equidistant
        modification, m.
    """

    # first stage
    sun_base_eccentricity_m: float = 0.0
    sun_base_eccentricity_phase_rad: float = 0.0
    sun_runout_m: float = 0.0
    sun_runout_phase_rad: float = 0.0
    sun_pitch_radius_error_m: float = 0.0
    input_shaft_angle_error_rad: float = 0.0
    input_shaft_angle_error_phase_rad: float = 0.0
    planet_base_eccentricity_m: tuple[float, ...] = ()
    planet_base_eccentricity_phase_rad: tuple[float, ...] = ()
    planet_runout_m: tuple[float, ...] = ()
    planet_pitch_radius_error_m: tuple[float, ...] = ()
    planet_base_pitch_error_m: tuple[float, ...] = ()
    # pin ring
    pin_radial_m: tuple[float, ...] = ()
    pin_tangential_m: tuple[float, ...] = ()
    pin_radius_error_m: float = 0.0
    pin_radius_individual_m: tuple[float, ...] = ()
    pin_circle_radius_error_m: float = 0.0
    pin_ring_runout_m: float = 0.0
    pin_ring_runout_phase_rad: float = 0.0
    pin_ring_tilt_rad: float = 0.0
    pin_ring_tilt_phase_rad: float = 0.0
    # carrier
    carrier_bore_eccentricity_m: tuple[float, ...] = ()
    carrier_bore_eccentricity_phase_rad: tuple[float, ...] = ()
    carrier_runout_m: float = 0.0
    carrier_runout_phase_rad: float = 0.0
    input_carrier_hole_distance_error_m: float = 0.0
    output_carrier_hole_distance_error_m: float = 0.0
    # cranks
    crank_eccentricity_error_m: tuple[float, ...] = ()
    crank_phase_error_rad: tuple[float, ...] = ()
    crank_runout_m: tuple[float, ...] = ()
    crank_runout_phase_rad: tuple[float, ...] = ()
    # bearings (radial clearance added to the nominal clearance of each bearing)
    crank_support_clearance_m: tuple[float, ...] = ()
    eccentric_bearing_clearance_m: tuple[float, ...] = ()
    main_bearing_clearance_m: float = 0.0
    # discs
    disc_pitch_error_m: tuple[tuple[float, ...], ...] = ()
    disc_profile_error_m: tuple[tuple[float, ...], ...] = ()
    disc_bore_distance_error_m: tuple[float, ...] = ()
    disc_moved_error_m: tuple[float, ...] = ()
    disc_equidistant_error_m: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            is_angle = f.name.endswith("_rad")
            limit = 2 * math.pi if is_angle else 1 * MM
            rule = ("expected radians within ±2π" if is_angle
                    else "expected metres; manufacturing errors are µm-scale, at most ±1 mm")
            if not isinstance(v, tuple):
                items = [(f.name, v)]
            elif v and isinstance(v[0], tuple):  # per disc and tooth
                items = [(f"{f.name}[{i}][{j}]", x) for i, row in enumerate(v) for j, x in enumerate(row)]
            else:
                items = [(f"{f.name}[{i}]", x) for i, x in enumerate(v)]
            for name, x in items:
                _range(name, x, -limit, limit, rule)
                if f.name.endswith("_clearance_m"):
                    _range(name, x, 0.0, limit, "a clearance cannot be negative")
        # an angle error of µrad–mrad scale; the sun's angle θ + a·cos(θ − ψ) must still rise with θ (a < 1)
        _range("input_shaft_angle_error_rad", self.input_shaft_angle_error_rad, 0.0, 0.01,
               "expected an amplitude in radians, 0 to 10 mrad (the phase goes in input_shaft_angle_error_phase_rad)")
        _range("pin_ring_tilt_rad", self.pin_ring_tilt_rad, -0.01, 0.01,
               "expected a tilt in radians, at most ±10 mrad (the direction goes in pin_ring_tilt_phase_rad)")

    def check_against(self, spec: ReducerSpec) -> None:
        """Raise :class:`SpecError` if a per-item tuple does not match ``spec``'s item counts.

        Parameters
        ----------
        spec : ReducerSpec
            The reducer these errors belong to.
        """
        nc, nd = spec.cranks.count, spec.cycloid.disc_count
        self.check_cycloid(spec.cycloid, spec.name)
        self._check_counts({
            "planet_base_eccentricity_m": (nc, "crank"), "planet_base_eccentricity_phase_rad": (nc, "crank"),
            "planet_runout_m": (nc, "crank"), "planet_pitch_radius_error_m": (nc, "crank"),
            "planet_base_pitch_error_m": (nc, "crank"),
            "carrier_bore_eccentricity_m": (nc, "crank"), "carrier_bore_eccentricity_phase_rad": (nc, "crank"),
            "crank_eccentricity_error_m": (nc, "crank"), "crank_phase_error_rad": (nc, "crank"),
            "crank_runout_m": (nc, "crank"), "crank_runout_phase_rad": (nc, "crank"),
            "crank_support_clearance_m": (nc, "crank"), "eccentric_bearing_clearance_m": (nc * nd, "crank×disc"),
            "disc_bore_distance_error_m": (nd, "disc"),
        }, spec.name)

    def check_cycloid(self, stage: CycloidStage, name: str = "the stage") -> None:
        """Raise :class:`SpecError` if the pin and disc errors do not match ``stage``'s pins,
        discs and teeth.

        Parameters
        ----------
        stage : CycloidStage
            The cycloid stage.
        name : str, optional
            The reducer's name, for the message.
        """
        zb, zc, nd = stage.pin_count, stage.disc_teeth, stage.disc_count
        self._check_counts({
            "pin_radial_m": (zb, "pin"), "pin_tangential_m": (zb, "pin"), "pin_radius_individual_m": (zb, "pin"),
            "disc_moved_error_m": (nd, "disc"), "disc_equidistant_error_m": (nd, "disc"),
            "disc_pitch_error_m": (nd, "disc"), "disc_profile_error_m": (nd, "disc"),
        }, name)
        for field_name in ("disc_pitch_error_m", "disc_profile_error_m"):
            for k, row in enumerate(getattr(self, field_name)):
                if len(row) != zc:
                    raise SpecError(f"{field_name}[{k}]", row, f"needs {zc} values, one per tooth of the disc")

    def _check_counts(self, expect: dict[str, tuple[int, str]], name: str) -> None:
        for field_name, (n, what) in expect.items():
            v = getattr(self, field_name)
            if v and len(v) != n:
                raise SpecError(field_name, v, f"needs {n} values (one per {what} of {name}) or none")

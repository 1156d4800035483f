"""``ModelOptions``: what fidelity each part of the reducer model has, in one typed object.

One frozen options object selects how :func:`rvflex.model.build_reducer` builds every part:
the cycloid discs, the carrier and the pin housing are each ``"rigid"`` or an FE reduction
(:class:`rvflex.fe.reduce.PartSettings`: Craig–Bampton, floating frame), the flexible
carrier's seat markers are a :data:`SeatMarker`, and the pin contact law is the spec's
default line contact unless one is given. The presets hold the one default reduction per
part that every entry point (scripts, the CLI's ``--fidelity``, sweeps, the notebook) uses:

=================================================  ===============  ==================  ==================
preset                                             discs            carrier             housing
=================================================  ===============  ==================  ==================
:meth:`ModelOptions.rigid`                         rigid            rigid               rigid
:meth:`ModelOptions.flexible_discs`                :data:`DISC_FE`  rigid               rigid
:meth:`ModelOptions.flexible_discs_and_carrier`    :data:`DISC_FE`  :data:`CARRIER_FE`  rigid
:meth:`ModelOptions.flexible_all`                  :data:`DISC_FE`  :data:`CARRIER_FE`  :data:`HOUSING_FE`
:meth:`ModelOptions.spatial_rigid`                 rigid            rigid               rigid
=================================================  ===============  ==================  ==================

The spatial preset (``"spatial"``) keeps every part rigid but lets each body move out of its plane
(:class:`SpatialSettings`): the carrier on its main bearing pair, the cranks on their support pairs, the discs
tilting against the pins, whose contact is then sliced along the face width. :func:`rvflex.model.build_reducer`
builds it with rigid or beam cranks (``SpatialSettings.crank``); the compiled step of :mod:`rvflex.engine`
solves it either way (:mod:`rvflex.engine3d`), Exudyn's solvers behind it.

Variants by :func:`dataclasses.replace` (e.g. more disc modes:
``replace(opts, discs=replace(opts.discs, n_modes=24))``) or :meth:`ModelOptions.with_fe`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

from rvflex.choices import CrankModel, Fidelity, SeatCoupling, SeatMarker, check_choice, choices, did_you_mean
from rvflex.fe.reduce import DEFAULTS, PartSettings
from rvflex.spec import SpecError
from rvflex.tilt import MOMENT_SLICES

if TYPE_CHECKING:
    from rvflex.contact.cycloid_pin import ContactLaw

__all__ = ["CARRIER_FE", "DISC_FE", "FIDELITIES", "HOUSING_FE", "Fidelity", "ModelOptions", "PartFidelity", "SeatCoupling",
           "SeatMarker", "SpatialSettings", "as_options"]

FIDELITIES: tuple[str, ...] = choices(Fidelity)
"""The preset names: ``"rigid"``, ``"flexible"`` (FE discs), ``"flexible-carrier"`` (FE discs and carrier),
``"flexible-all"`` (FE discs, carrier and pin housing), ``"spatial"`` (rigid parts free out of their plane)."""

PartFidelity = Literal["rigid"]
"""A part that is not FE-reduced (the alternative to a :class:`PartSettings`)."""

DISC_FE: PartSettings = DEFAULTS["disc"]
"""Disc reduction of the flexible presets, the one default disc reduction
(:data:`rvflex.fe.reduce.DEFAULTS` ``["disc"]``, also ``rvflex reduce --part disc``'s default):
global deformation only — 6 bore (RBE2) modes and 12 fixed-interface modes on 6 mm
quadratic tets, no flank attachment modes, whose patch-local compliance the line-contact law
already carries (docs/flexible.md: convergence study). The basis with flank attachment modes
that the static flank check is about (:data:`rvflex.fe.reduce.DISC_FLANK_BASIS`: 10 modes, 2
attachment patches per tooth) is ``with_fe("discs", n_modes=10, attach_per_tooth=2)``, on the
command line ``--fe-modes 10 --fe-attach 2``."""

CARRIER_FE: PartSettings = DEFAULTS["carrier"]
"""Carrier reduction of :meth:`ModelOptions.flexible_discs_and_carrier`, the one default carrier
reduction (:data:`rvflex.fe.reduce.DEFAULTS` ``["carrier"]``, also ``rvflex reduce --part
carrier``'s default): output face the reference, 4 distributing (RBE3) seats with 6 attachment
modes each, 10 fixed-interface modes, 6 mm quadratic tets (static check 3.3 % at the seats,
0.1 % at the pillars: docs/fe.md)."""

HOUSING_FE: PartSettings = DEFAULTS["housing"]
"""Pin-housing reduction of :meth:`ModelOptions.flexible_all`, the one default housing reduction
(:data:`rvflex.fe.reduce.DEFAULTS` ``["housing"]``, also ``rvflex reduce --part housing``'s
default): mount face clamped to ground, two in-plane attachment modes per pin seat, 8
fixed-interface modes, 8 mm quadratic tets (docs/flexible.md: convergence)."""

MODEL_TABLE_KEYS = ("fidelity", "discs", "carrier", "housing", "carrier_seat_marker", "face_slices", "spatial")
"""Keys of a TOML ``[model]`` table (:meth:`ModelOptions.from_table`)."""


@dataclass(frozen=True)
class SpatialSettings:
    """What the spatial fidelity models beyond rigid bodies free out of their plane.

    Parameters
    ----------
    crank : {"rigid", "beam"}
        The crankshafts: rigid bodies, or flexible (Timoshenko) shafts between their support bearings
        carrying the eccentrics and the gear at their axial positions (:func:`rvflex.parts.crankshaft.beam_layout`).
    crank_elements : int
        Beam elements per crank segment (1 to 64; read with ``crank="beam"`` only). The segments are prismatic,
        so one element is exact in statics; more add mass stations along the shaft.
    pin_bending : bool
        Let each pin bend between its housing seats where the spec gives their span (no span: the pins
        stay rigid whatever this says).
    """

    crank: CrankModel = "rigid"
    crank_elements: int = 1
    pin_bending: bool = True

    def __post_init__(self) -> None:
        check_choice("crank", self.crank, CrankModel)
        if isinstance(self.crank_elements, bool) or not isinstance(self.crank_elements, int) \
                or not 1 <= self.crank_elements <= 64:
            raise SpecError("crank_elements", self.crank_elements, "must be an integer from 1 to 64 (beam elements "
                                                                   "per crank segment)")
        if not isinstance(self.pin_bending, bool):
            raise SpecError("pin_bending", self.pin_bending, "must be true or false")

    def describe(self) -> str:
        """A few words: the crank model and the pins, e.g. ``rigid cranks, pins bending where seated``."""
        crank = "rigid cranks" if self.crank == "rigid" else f"beam cranks ({self.crank_elements} elements/segment)"
        return f"{crank}, {'pins bending where seated' if self.pin_bending else 'rigid pins'}"


@dataclass(frozen=True)
class ModelOptions:
    """Fidelity of each part of the reducer model.

    Parameters
    ----------
    discs, carrier : ``"rigid"`` or :class:`PartSettings`
        Rigid planar bodies, or Craig–Bampton FFRF bodies reduced with these settings
        (cached on disk). The sun and the cranks are rigid in every preset.
    housing : ``"rigid"`` or :class:`PartSettings`
        The pin housing: ground, or its Craig–Bampton reduction (mount face clamped to ground)
        whose pin seats carry the pins (:mod:`rvflex.parts.pin_ring`).
    carrier_seat_marker : SeatMarker
        Marker kind of the flexible carrier's crank seats (ignored for a rigid carrier).
    contact_law : ContactLaw or None
        The cycloid–pin law; None: the spec's line contact
        (:func:`rvflex.model.default_contact_law`).
    face_slices : int
        Slices of each disc's pin contact along the face width (≥ 1): each slice a contact element at its own
        axial position carrying its share of the width (:meth:`ContactLaw.sliced`), so a disc moved against the
        pins differently at its two faces (a tilted output, :mod:`rvflex.tilt`) loads its pins' ends unequally.
        1, the default: one contact at each disc's mid-plane. At least 2 with ``spatial``.
    spatial : SpatialSettings or None
        None (the default): the planar model. Settings: the spatial model, every part a rigid body free out of
        its plane (FE parts refused), the cranks rigid or beams (:attr:`SpatialSettings.crank`).
    """

    discs: PartSettings | PartFidelity = "rigid"
    carrier: PartSettings | PartFidelity = "rigid"
    housing: PartSettings | PartFidelity = "rigid"
    carrier_seat_marker: SeatMarker = "virtual"
    contact_law: ContactLaw | None = None
    face_slices: int = 1
    spatial: SpatialSettings | None = None

    def __post_init__(self) -> None:
        for name in ("discs", "carrier", "housing"):
            value = getattr(self, name)
            if value != "rigid" and not isinstance(value, PartSettings):
                raise SpecError(name, value, "must be 'rigid' or an rvflex.fe.reduce.PartSettings")
        if isinstance(self.carrier, PartSettings):
            check_choice("carrier.seat_coupling", self.carrier.seat_coupling, SeatCoupling)
        check_choice("carrier_seat_marker", self.carrier_seat_marker, SeatMarker)
        if isinstance(self.face_slices, bool) or not isinstance(self.face_slices, int) or not 1 <= self.face_slices <= 64:
            raise SpecError("face_slices", self.face_slices, "must be an integer from 1 to 64 (slices of the pin "
                                                             "contact along the face width)")
        if self.contact_law is not None:
            from rvflex.contact.cycloid_pin import ContactLaw

            if not isinstance(self.contact_law, ContactLaw):
                raise SpecError("contact_law", self.contact_law, "must be an rvflex.contact.cycloid_pin.ContactLaw")
        if self.spatial is not None:
            if not isinstance(self.spatial, SpatialSettings):
                raise SpecError("spatial", self.spatial, "must be None or an rvflex.options.SpatialSettings")
            fe = [name for name in ("discs", "carrier", "housing") if isinstance(getattr(self, name), PartSettings)]
            if fe:
                raise SpecError("spatial", self.spatial, f"needs rigid parts, got FE {', '.join(fe)}: FE bodies "
                                                         "free out of their plane are not modelled")
            if self.face_slices < 2:
                raise SpecError("face_slices", self.face_slices, "must be at least 2 with spatial (a tilted disc "
                                                                 "loads its pins' ends through the slices)")

    # -- presets ------------------------------------------------------------------------------
    @classmethod
    def rigid(cls) -> ModelOptions:
        """Every part rigid (planar rigid bodies)."""
        return cls()

    @classmethod
    def flexible_discs(cls) -> ModelOptions:
        """FE-reduced cycloid discs (:data:`DISC_FE`), the other parts rigid."""
        return cls(discs=DISC_FE)

    @classmethod
    def flexible_discs_and_carrier(cls) -> ModelOptions:
        """FE-reduced discs (:data:`DISC_FE`) and carrier (:data:`CARRIER_FE`, RBE3 seats)."""
        return cls(discs=DISC_FE, carrier=CARRIER_FE)

    @classmethod
    def flexible_all(cls) -> ModelOptions:
        """FE-reduced discs, carrier and pin housing (:data:`DISC_FE`, :data:`CARRIER_FE`,
        :data:`HOUSING_FE`): the system as seed 001's virtual prototype built it."""
        return cls(discs=DISC_FE, carrier=CARRIER_FE, housing=HOUSING_FE)

    @classmethod
    def spatial_rigid(cls, slices: int = MOMENT_SLICES, settings: SpatialSettings | None = None) -> ModelOptions:
        """Every part a rigid body free out of its plane, the pin contact in ``slices`` slices along the face width.

        Parameters
        ----------
        slices : int, optional
            Slices of each disc's pin contact (≥ 2); default :data:`rvflex.tilt.MOMENT_SLICES`, the converged
            count of a run under a moment.
        settings : SpatialSettings, optional
            Crank and pin models; default rigid cranks, pins bending where the spec gives their seat span.

        Returns
        -------
        ModelOptions
            The options (:func:`rvflex.model.build_reducer` builds them, beam cranks included).
        """
        return cls(face_slices=slices, spatial=SpatialSettings() if settings is None else settings)

    @classmethod
    def preset(cls, fidelity: Fidelity) -> ModelOptions:
        """The preset of a fidelity name.

        Parameters
        ----------
        fidelity : {"rigid", "flexible", "flexible-carrier", "flexible-all", "spatial"}
            Rigid parts; FE-reduced discs; FE-reduced discs and carrier; FE-reduced discs,
            carrier and pin housing; rigid parts free out of their plane.

        Returns
        -------
        ModelOptions
            The preset.
        """
        check_choice("fidelity", fidelity, Fidelity)
        presets = {"rigid": cls.rigid, "flexible": cls.flexible_discs,
                   "flexible-carrier": cls.flexible_discs_and_carrier, "flexible-all": cls.flexible_all,
                   "spatial": cls.spatial_rigid}
        return presets[fidelity]()

    @classmethod
    def from_table(cls, table: Mapping, where: str = "[model]", source: str | None = None) -> ModelOptions:
        """Options from a TOML table (a sweep design's ``[model]``), checked key by key.

        ``fidelity`` names the preset (``"rigid"``, the default, ``"flexible"``,
        ``"flexible-carrier"``, ``"flexible-all"`` or ``"spatial"``); the sub-tables ``discs``, ``carrier`` and
        ``housing`` override fields of that
        preset's reduction of the part (:class:`PartSettings` field names, SI: ``maxh_m``,
        ``n_modes``, ``attach_per_tooth`` …; the part must be flexible in the preset);
        ``carrier_seat_marker`` is a :data:`SeatMarker`; ``face_slices`` the pin contact's slices along the face
        width; the sub-table ``spatial`` overrides :class:`SpatialSettings` fields (``crank``, ``crank_elements``,
        ``pin_bending``; with ``fidelity = "spatial"`` only). No other key is accepted.

        Parameters
        ----------
        table : Mapping
            The parsed TOML table.
        where : str, optional
            The table's name in messages.
        source : str, optional
            The file it came from, in messages.

        Returns
        -------
        ModelOptions
            The options.

        Raises
        ------
        SpecError
            Naming the key as ``{where}.key`` (e.g. ``[model].discs.n_modes``), the value and the
            rule, and ``source`` (the file).
        """
        if not isinstance(table, Mapping):
            raise SpecError(where, table, "must be a table", source)
        extra = sorted(set(table) - set(MODEL_TABLE_KEYS))
        if extra:
            raise SpecError(f"{where}.{extra[0]}", table[extra[0]],
                            f"unknown key; valid: {', '.join(MODEL_TABLE_KEYS)}", source)
        fidelity = table.get("fidelity", "rigid")
        check_choice(f"{where}.fidelity", fidelity, Fidelity, source)
        options = cls.preset(fidelity)
        if "carrier_seat_marker" in table:
            check_choice(f"{where}.carrier_seat_marker", table["carrier_seat_marker"], SeatMarker, source)
            options = dataclasses.replace(options, carrier_seat_marker=table["carrier_seat_marker"])
        if "face_slices" in table:
            try:
                options = dataclasses.replace(options, face_slices=table["face_slices"])
            except SpecError as err:
                raise err.within(where, source) from None
        if "spatial" in table:
            options = _spatial_from_table(options, table["spatial"], f"{where}.spatial", fidelity, source)
        fields = tuple(f.name for f in dataclasses.fields(PartSettings))
        for part in ("discs", "carrier", "housing"):
            if part not in table:
                continue
            over = table[part]
            if not isinstance(over, Mapping):
                raise SpecError(f"{where}.{part}", over, "must be a table of PartSettings fields", source)
            if not isinstance(getattr(options, part), PartSettings):
                raise SpecError(f"{where}.{part}", dict(over), f"the {part} {'are' if part == 'discs' else 'is'} rigid with "
                                                               f"fidelity = {fidelity!r}: "
                                                               f"reduction settings apply to a flexible part only",
                                source)
            unknown = sorted(set(over) - set(fields))
            if unknown:
                raise SpecError(f"{where}.{part}.{unknown[0]}", over[unknown[0]],
                                f"unknown key; valid: {', '.join(fields)}", source)
            try:
                options = options.with_fe(part, **over)
            except SpecError as err:
                raise err.within(f"{where}.{part}", source) from None
        return options

    # -- reading ------------------------------------------------------------------------------
    @property
    def flexible_discs_on(self) -> bool:
        """True when the discs are FE-reduced."""
        return isinstance(self.discs, PartSettings)

    @property
    def flexible_carrier_on(self) -> bool:
        """True when the carrier is FE-reduced."""
        return isinstance(self.carrier, PartSettings)

    @property
    def flexible_housing_on(self) -> bool:
        """True when the pin housing is FE-reduced."""
        return isinstance(self.housing, PartSettings)

    @property
    def fidelity(self) -> str:
        """The preset name these options extend: ``"rigid"``, ``"flexible"``, ``"flexible-carrier"``,
        ``"flexible-all"`` or ``"spatial"`` (reductions other than the presets' keep their preset's name; see
        :meth:`describe`; a flexible housing on another combination adds ``"+housing"``)."""
        if self.spatial is not None:
            return "spatial"
        if self.flexible_housing_on:
            if self.flexible_carrier_on and self.flexible_discs_on:
                return "flexible-all"
            return dataclasses.replace(self, housing="rigid").fidelity + "+housing"
        if self.flexible_carrier_on:
            return "flexible-carrier" if self.flexible_discs_on else "rigid+carrier"
        return "flexible" if self.flexible_discs_on else "rigid"

    def with_fe(self, part: Literal["discs", "carrier", "housing"], **settings) -> ModelOptions:
        """These options with the reduction of one flexible part changed.

        Parameters
        ----------
        part : {"discs", "carrier", "housing"}
            The part; it must be flexible in these options.
        **settings
            :class:`PartSettings` fields to change (SI: ``maxh_m``; ``n_modes=24`` …).

        Returns
        -------
        ModelOptions
            New options.

        Raises
        ------
        SpecError
            The part is rigid, or a name is not a PartSettings field.
        """
        current = getattr(self, part, None)
        if not isinstance(current, PartSettings):
            raise SpecError(part, current, "is rigid in these options: FE settings apply to a flexible part only")
        try:
            return dataclasses.replace(self, **{part: dataclasses.replace(current, **settings)})
        except TypeError as err:
            raise SpecError(part, settings, f"not PartSettings fields ({err})") from None

    def describe(self) -> str:
        """One line naming each part's fidelity and reduction.

        Returns
        -------
        str
            E.g. ``discs FE 6 mm order 2, 12 modes, 0 attachment patches/tooth; carrier rigid;
            housing rigid``.
        """

        def part(p) -> str:
            if not isinstance(p, PartSettings):
                return "rigid"
            s = (f"FE {p.maxh_m * 1e3:g} mm order {p.mesh_order}, {p.n_modes} modes, "
                 f"{p.attach_per_tooth} attachment patches/tooth")
            return s
        car = part(self.carrier)
        if self.flexible_carrier_on:
            car += f", {self.carrier.seat_coupling} seats ({self.carrier_seat_marker} markers)"
        hou = "rigid" if not self.flexible_housing_on else (
            f"FE {self.housing.maxh_m * 1e3:g} mm order {self.housing.mesh_order}, {self.housing.n_modes} modes, "
            f"2 attachment modes/pin seat")
        sliced = f"; pin contact in {self.face_slices} slices along the face width" if self.face_slices > 1 else ""
        spatial = "" if self.spatial is None else f"; spatial: {self.spatial.describe()}"
        return f"discs {part(self.discs)}; carrier {car}; housing {hou}{sliced}{spatial}"

    def as_dict(self) -> dict:
        """Plain values (for result attributes and JSON).

        Returns
        -------
        dict
            Part settings as dicts, the contact law by kind; ``spatial`` (its settings as a dict) only when set,
            so a planar model's record, and a stored sweep's digest made from it, stay what they were.
        """
        def part(p):
            return dataclasses.asdict(p) if isinstance(p, PartSettings) else p
        out = {"discs": part(self.discs), "carrier": part(self.carrier), "housing": part(self.housing),
               "carrier_seat_marker": self.carrier_seat_marker,
               "contact_law": "default (line)" if self.contact_law is None else self.contact_law.kind,
               "face_slices": self.face_slices}
        if self.spatial is not None:
            out["spatial"] = dataclasses.asdict(self.spatial)
        return out


def _spatial_from_table(options: ModelOptions, over: object, where: str, fidelity: Fidelity,
                        source: str | None) -> ModelOptions:
    """``options`` with the :class:`SpatialSettings` fields of a ``[model.spatial]`` table, checked key by key."""
    if not isinstance(over, Mapping):
        raise SpecError(where, over, "must be a table of SpatialSettings fields", source)
    if options.spatial is None:
        raise SpecError(where, dict(over), f"the model is planar with fidelity = {fidelity!r}: spatial settings "
                                           "apply with fidelity = 'spatial' only", source)
    fields = tuple(f.name for f in dataclasses.fields(SpatialSettings))
    unknown = sorted(set(over) - set(fields))
    if unknown:
        raise SpecError(f"{where}.{unknown[0]}", over[unknown[0]], f"unknown key; valid: {', '.join(fields)}", source)
    try:
        return dataclasses.replace(options, spatial=dataclasses.replace(options.spatial, **over))
    except SpecError as err:
        raise err.within(where, source) from None


def as_options(value: ModelOptions | Fidelity | None, field: str = "options") -> ModelOptions:
    """``value`` as :class:`ModelOptions`: options pass through, a preset name maps to its preset
    (``"rigid"``, ``"flexible"``, ``"flexible-carrier"``, ``"flexible-all"``, ``"spatial"``), None is rigid; anything
    else is refused naming ``field``."""
    if value is None:
        return ModelOptions.rigid()
    if isinstance(value, ModelOptions):
        return value
    if isinstance(value, str):
        if value not in FIDELITIES:
            raise SpecError(field, value, f"must be ModelOptions or one of {', '.join(map(repr, FIDELITIES))}"
                                          f"{did_you_mean(value, FIDELITIES)}")
        return ModelOptions.preset(value)
    raise SpecError(field, value, f"must be ModelOptions or one of {', '.join(map(repr, FIDELITIES))} "
                                  f"(got a {type(value).__name__})")

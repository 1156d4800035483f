"""``build_reducer``: one Exudyn system of the whole RV reducer, then only read.

Planar rigid fidelity: every part is a ``NodeRigidBody2D`` in the xy plane (z the reducer
axis); the housing and pin ring are ground. The sun's angle is prescribed; the carrier is the
output, on its main bearing, loaded by the output torque. Cranks sit in the carrier on
clearance bearings, mesh with the sun and carry the discs on clearance (needle) bearings; the
discs mesh with the pins through the exact contact element. Every ErrorSpec field reaches the
geometry or connector it belongs to (see the part modules).

Spatial rigid fidelity (``options.spatial``): carrier, cranks and discs are rigid bodies free in
space (``NodeRigidBodyRxyz``; z the axis, z = 0 the discs' mid-plane): the carrier on the main bearing pair
element, each crank on two support bearings at ±``support_span_m``/2, each disc on its eccentric (needle)
bearings with their axial and tilt springs, the pin contact in face slices that see the disc's tilt, and each
planet gear's mesh at its own plane on the tilting crank. The sun stays a planar body (held on the axis). Beam
cranks (``options.spatial.crank = "beam"``) are each a chain of rigid stations on the crank's axis joined by the
static stiffness of the shaft's Timoshenko segments (:func:`rvflex.parts.crankshaft.build_spatial`); a crank's
node is then the station at its planet gear.

Reference configuration: input and output angles 0, every crank at relative angle 0, each
disc where its eccentrics put it.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from rvflex.choices import Fidelity
from rvflex.contact.cycloid_pin import ContactLaw
from rvflex.engine import ideal_kinematics
from rvflex.options import FIDELITIES, ModelOptions, as_options
from rvflex.parts import carrier as carrier_part
from rvflex.parts import crankshaft, cycloid_disc, input_stage, pin_ring
from rvflex.spec import ErrorSpec, ReducerSpec, check_geometry

__all__ = ["ReducerModel", "build_reducer", "check_fidelity", "default_contact_law", "disc_mesh_spec", "FIDELITIES"]
# FIDELITIES (rvflex.options): the preset names build_reducer maps to ModelOptions, re-exported here


def check_fidelity(fidelity: Fidelity, field: str = "fidelity") -> None:
    """Refuse a fidelity name that is not a preset (SpecError naming ``field``)."""
    as_options(fidelity, field)


def default_contact_law(spec: ReducerSpec) -> ContactLaw:
    """Seed 002's line contact: disc and pin materials, disc thickness as the width, the
    pin-circle radius bounding the flank radius in the law's logarithm; 500 N·s/m damping in
    contact (seed 003 Table 3)."""
    m = spec.materials
    return ContactLaw.line(spec.cycloid.disc_thickness_m, m.gears_cranks_discs, m.pins, damping_Ns_m=500.0,
                           body_radius_m=spec.cycloid.pin_circle_radius_m)


@dataclass(frozen=True, eq=False)
class ReducerModel:
    """An assembled reducer: the Exudyn system and the handles of every part.

    Built by :func:`build_reducer` (not by hand) and then only read; the fields are its inputs
    and the Exudyn item handles of its parts.

    Parameters
    ----------
    spec : ReducerSpec
        The reducer.
    errors : ErrorSpec
        Its errors.
    options : ModelOptions
        The fidelity of each part.
    system_container, mbs : exudyn.SystemContainer, exudyn.MainSystem
        The Exudyn system.
    sun, carrier, cranks, discs, pins : part handles
        Item indices of each part (:mod:`rvflex.parts`).
    reference : numpy.ndarray
        Absolute reference coordinates of all ODE2 coordinates (m, rad, modal).
    crank_axes, disc_centres : numpy.ndarray
        Nominal crank axes and disc centres in the carrier frame (m).
    input_seat_supports : tuple, optional
        Flexible carrier: each crank's second support bearing (input-plate seat).
    reduced_disc, reduced_carrier : ReducedPart, optional
        The FE reductions of the discs and the carrier (flexible parts), else None.
    reduced_discs : tuple of ReducedPart
        FE discs: every disc's reduction (the same object where discs share one); empty when rigid.
    reduced_housing : ReducedPart, optional
        The FE reduction of the pin housing (flexible housing), else None.
    out_of_plane_held : bool
        Spatial model built with ``hold_out_of_plane``: every body's z, ψx, ψy held (a test hook).
    """

    spec: ReducerSpec
    errors: ErrorSpec
    options: ModelOptions
    system_container: object
    mbs: object
    sun: input_stage.InputHandles
    carrier: carrier_part.CarrierHandles
    cranks: crankshaft.CrankHandles
    discs: cycloid_disc.DiscHandles
    pins: pin_ring.PinRingHandles
    reference: np.ndarray  # absolute reference coordinates of all ODE2 coordinates
    crank_axes: np.ndarray
    disc_centres: np.ndarray
    input_seat_supports: tuple = ()  # flexible carrier: each crank's second support bearing (input-plate seat)
    reduced_disc: object = None  # disc 0's rvflex.fe.reduce.ReducedPart (FE discs), else None
    reduced_carrier: object = None  # the carrier's ReducedPart (FE carrier), else None
    reduced_discs: tuple = ()  # FE discs: every disc's ReducedPart (the same object where discs share one)
    reduced_housing: object = None  # the pin housing's ReducedPart (FE housing), else None
    out_of_plane_held: bool = False  # spatial model with every body's z, ψx, ψy held (build_reducer's test hook)

    @property
    def spatial(self) -> bool:
        """True for the spatial model (bodies free out of their plane)."""
        return self.options.spatial is not None

    @property
    def fidelity(self) -> str:
        """Preset name of :attr:`options` (``"rigid"``, ``"flexible"``, ``"flexible-carrier"``)."""
        return self.options.fidelity

    @property
    def item_count(self) -> int:
        """Number of Exudyn items (nodes, objects, markers, loads, sensors) in the system: a run
        leaves it unchanged."""
        m = self.mbs
        return m.systemData.NumberOfNodes() + m.systemData.NumberOfObjects() + m.systemData.NumberOfMarkers() \
            + m.systemData.NumberOfLoads() + m.systemData.NumberOfSensors()

    @property
    def flexible_carrier(self) -> bool:
        """True when the carrier is the FE-reduced (FFRF) body."""
        return self.carrier.modal_node >= 0

    @property
    def modal_nodes(self) -> tuple[int, ...]:
        """The NodeGenericODE2 of every FE part's modal coordinates (discs, carrier, housing)."""
        return (self.discs.modal_nodes + ((self.carrier.modal_node,) if self.flexible_carrier else ())
                + ((self.pins.modal_node,) if self.pins.modal_node >= 0 else ()))

    @property
    def output_index(self) -> int:
        """ODE2 index of the output angle θ_out (the carrier's reference-frame rotation)."""
        return int(self.planar_index()["carrier"][2])

    @property
    def ratio(self) -> float:
        """Kinematic ratio i = θ_in/θ_out (–)."""
        return self.spec.nominal_ratio

    def _body_nodes(self) -> dict[str, int]:
        """The node of every body by name, in order: sun, carrier, crank0…, disc0…"""
        out = {"sun": self.sun.node, "carrier": self.carrier.node}
        out.update({f"crank{k}": n for k, n in enumerate(self.cranks.nodes)})
        out.update({f"disc{d}": n for d, n in enumerate(self.discs.nodes)})
        return out

    def node_slices(self) -> dict[str, slice]:
        """ODE2 coordinate ranges of the planar (x, y, θ) nodes.

        Returns
        -------
        dict of str to slice
            The bodies on a ``NodeRigidBody2D``: the sun, and the carrier, cranks and discs of the planar rigid
            model (an FFRF frame's or a spatial body's ``NodeRigidBodyRxyz`` has no contiguous (x, y, θ): use
            :meth:`planar_index`).
        """
        out = {}
        for name, node in self._body_nodes().items():
            if self.mbs.GetNode(node)["nodeType"] == "RigidBody2D":
                i = self.mbs.GetNodeODE2Index(node)
                out[name] = slice(i, i + 3)
        return out

    def planar_index(self) -> dict[str, np.ndarray]:
        """ODE2 indices of (x, y, θ) of every body, discs and carrier included.

        Returns
        -------
        dict of str to numpy.ndarray
            Three indices per body (a flexible or spatial body's node is a NodeRigidBodyRxyz: x, y, ψz).
        """
        return dict(self._planar_index)

    def spatial_index(self) -> dict[str, np.ndarray]:
        """ODE2 indices of (x, y, z, ψx, ψy, ψz) of every body on a ``NodeRigidBodyRxyz`` (the spatial model's
        carrier, cranks and discs; the FE bodies' frames), by name as :meth:`planar_index`.

        Returns
        -------
        dict of str to numpy.ndarray
            Six indices per body (m, m, m, rad, rad, rad; R = Rx(ψx)·Ry(ψy)·Rz(ψz)); the planar bodies are absent.
        """
        return dict(self._spatial_index)

    @functools.cached_property
    def _planar_index(self) -> dict[str, np.ndarray]:
        # computed once: the system is assembled before the model exists and a run adds no item, and every
        # quasi-static step asks for it (Exudyn's index look-ups were 8 % of a rigid run, measured)
        out = {}
        for name, node in self._body_nodes().items():
            i = self.mbs.GetNodeODE2Index(node)
            out[name] = np.array([i, i + 1, i + 5] if self.mbs.GetNode(node)["nodeType"] == "RigidBodyRxyz"
                                 else [i, i + 1, i + 2])
            out[name].flags.writeable = False  # shared by every call
        return out

    @functools.cached_property
    def _spatial_index(self) -> dict[str, np.ndarray]:
        out = {}
        for name, node in self._body_nodes().items():
            if self.mbs.GetNode(node)["nodeType"] == "RigidBodyRxyz":
                i = self.mbs.GetNodeODE2Index(node)
                out[name] = np.arange(i, i + 6)
                out[name].flags.writeable = False
        return out

    def kinematic_coordinates(self, theta_in: float) -> np.ndarray:
        """Absolute ODE2 coordinates of the ideal (rigid, error-free kinematics) reducer.

        Parameters
        ----------
        theta_in : float
            Input angle θ_in, rad.

        Returns
        -------
        numpy.ndarray
            The coordinates (m, rad; modal coordinates zero).
        """
        k = self._kinematics
        q = self.reference.copy()
        ideal_kinematics(q, float(theta_in), self.ratio, float(self.spec.cycloid.pin_count), *k)
        return q

    @functools.cached_property
    def _crank_stations(self) -> tuple[np.ndarray, np.ndarray]:
        # (x, y, ψz) of each beam crank's node, repeated for each of its other stations, and those stations' (x, y,
        # ψz): empty for rigid cranks
        src, dst = [], []
        for node, shaft in zip(self.cranks.nodes, self.cranks.stations):
            i = self.mbs.GetNodeODE2Index(node)
            for s in shaft:
                if s != node:
                    j = self.mbs.GetNodeODE2Index(s)
                    src += [i, i + 1, i + 5]
                    dst += [j, j + 1, j + 5]
        return np.array(src, dtype=np.int64), np.array(dst, dtype=np.int64)

    @functools.cached_property
    def _kinematics(self) -> tuple:
        # index arrays and constants of kinematic_coordinates, computed once (it runs every quasi-static step)
        sl = self.planar_index()
        cy = self.spec.cycloid
        nk, nd = len(self.cranks.nodes), len(self.discs.nodes)
        phase = np.asarray(cy.disc_phase_rad[:nd], float)
        base = np.asarray(self.disc_centres, float)[:nd] - cy.eccentricity_m * np.stack([np.cos(phase), np.sin(phase)],
                                                                                       axis=1)
        modal = [np.arange(self.mbs.GetNodeODE2Index(n), self.mbs.GetNodeODE2Index(n)
                           + self.mbs.GetNode(n)["numberOfODE2Coordinates"]) for n in self.modal_nodes]

        def idx(name, j, n):
            return np.array([sl[f"{name}{i}"][j] for i in range(n)], dtype=np.int64)

        # in the argument order of rvflex.engine.ideal_kinematics
        return (int(sl["sun"][2]), int(sl["carrier"][2]), np.ascontiguousarray(np.asarray(self.crank_axes, float)[:nk]),
                idx("crank", 0, nk), idx("crank", 1, nk), idx("crank", 2, nk), np.ascontiguousarray(base),
                float(cy.eccentricity_m), phase, idx("disc", 0, nd), idx("disc", 1, nd), idx("disc", 2, nd),
                (np.concatenate(modal) if modal else np.zeros(0)).astype(np.int64), *self._crank_stations)


def disc_mesh_spec(spec: ReducerSpec, modification=None) -> ReducerSpec:
    """The spec whose FE discs :func:`build_reducer` meshes and reduces for ``spec`` with
    ``disc_mesh_modification=modification``: ``spec`` with that profile modification (``spec`` itself for
    None or the same one)."""
    if modification is None or modification == spec.cycloid.modification:
        return spec
    import dataclasses

    return dataclasses.replace(spec, cycloid=dataclasses.replace(spec.cycloid, modification=modification))


def build_reducer(spec: ReducerSpec, errors: ErrorSpec | None = None,
                  options: ModelOptions | str | None = None, *, law: ContactLaw | None = None,
                  reduced_disc=None, reduced_carrier=None, reduced_housing=None,
                  disc_mesh_modification=None, hold_out_of_plane: bool = False) -> ReducerModel:
    """Assemble the Exudyn model of a reducer.

    Rigid parts are planar rigid bodies. FE discs (``options.discs`` a ``PartSettings``) are
    Craig–Bampton-reduced FFRF bodies reduced from ``spec`` with those settings (cached on
    disk); an FE carrier likewise (output face the reference frame, distributing seat
    couplings): each crank then has two support bearings (one per plate seat, half the lumped
    pair each); output angle, load, regulariser and main bearing act on the output face's frame
    (docs/flexible.md). ``reduced_disc`` / ``reduced_carrier`` (:class:`rvflex.fe.reduce.ReducedPart`)
    inject an existing reduction (``reduced_disc``: disc 0's, or a tuple with one per disc): that
    part is then flexible with the reduction's own settings,
    which the model's ``options`` record. ``law`` overrides ``options.contact_law``. An FE pin
    housing (``options.housing``, or ``reduced_housing`` injected) carries the pins on its seats
    (:mod:`rvflex.parts.pin_ring`; mount face clamped to ground).

    Spatial options (``options.spatial``) build the spatial rigid model (module docstring;
    ``spec.check_spatial`` first), its cranks rigid or beams (``options.spatial.crank``); the compiled step of
    :mod:`rvflex.engine` solves it either way (a beam crank's segment springs are its 3D bushings with torsion),
    Exudyn's solvers behind it as for the planar model.

    Every layout takes FE discs: a disc that is disc 0 turned by a symmetry of the crank and
    pillar layout (to a whole number of teeth) shares disc 0's reduction; any other disc (three
    cranks with discs 180° apart, a phase that is not a half turn) gets its own, the exact disc
    geometry (:func:`rvflex.parts.cycloid_disc.fe_disc_placements`; cached like disc 0's).

    Parameters
    ----------
    spec : ReducerSpec
        The reducer.
    errors : ErrorSpec, optional
        Its errors; None: none.
    options : ModelOptions or str, optional
        A :class:`~rvflex.options.ModelOptions`, or a preset name ``"rigid"``, ``"flexible"`` or
        ``"flexible-carrier"``; None is rigid.
    law : ContactLaw, optional
        Overrides ``options.contact_law``.
    reduced_disc, reduced_carrier, reduced_housing : ReducedPart, optional
        An existing reduction of the disc (disc 0's, or a tuple with one per disc), the carrier or
        the pin housing to use.
    disc_mesh_modification : Modification, optional
        The profile modification the FE discs are meshed and reduced with; None: the spec's. The
        contact always takes the spec's exact profile: the FE disc carries the global deformation,
        which a profile change of a few µm leaves alike (measured on the RV-40E, flexible discs,
        a modification deviation of −8/+6 µm meshed as the nominal disc: TE within 0.025″,
        torque cycle within 0.0014″, against 16.3″ of TE ripple), while each new mesh and
        reduction costs about 15 s and 90 MB of cache.
    hold_out_of_plane : bool, optional
        Spatial model only, a test hook: hold z, ψx and ψy of the carrier, every crank and every disc by
        coordinate constraints, which reduces the spatial model to the planar one with the same face slices
        (tests/test_spatial_model.py). Default False.

    Returns
    -------
    ReducerModel
        The assembled model (run it with :func:`rvflex.run` and a scenario).

    Raises
    ------
    SpecError
        Options that are not ModelOptions or a preset name; error counts that do not match the spec.
        A spec without what the spatial model needs (``check_spatial``; beam cranks: the crank fields
        :func:`rvflex.parts.crankshaft.beam_layout` names); a main-bearing clearance error under spatial options.
    ValueError
        ``hold_out_of_plane`` with planar options.
    """
    import dataclasses

    import exudyn as exu
    from exudyn.itemInterface import MarkerNodeCoordinate, NodePointGround, ObjectGround

    options = as_options(options, "options")
    if hold_out_of_plane and options.spatial is None:
        raise ValueError("hold_out_of_plane: applies to the spatial model only (options.spatial is None)")
    if reduced_disc is not None:
        first = reduced_disc[0] if isinstance(reduced_disc, (tuple, list)) else reduced_disc
        options = dataclasses.replace(options, discs=first.settings)
    if reduced_carrier is not None:
        options = dataclasses.replace(options, carrier=reduced_carrier.settings)
    if reduced_housing is not None:
        options = dataclasses.replace(options, housing=reduced_housing.settings)
    check_geometry(spec)  # the profile check of every spec entering a model (variants made by replace)
    errors = errors or ErrorSpec()
    errors.check_against(spec)
    law = law or options.contact_law or default_contact_law(spec)
    if options.spatial is not None:
        return _build_spatial(spec, errors, options, law, hold_out_of_plane)
    flexible_carrier = options.flexible_carrier_on
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    ground_body = mbs.AddObject(ObjectGround())
    ground_coord = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()), coordinate=0))
    if options.flexible_housing_on and reduced_housing is None:
        from rvflex.fe.reduce import reduce_part

        reduced_housing = reduce_part(spec, "housing", **dataclasses.asdict(options.housing))
    pins = pin_ring.build(mbs, spec, errors, fidelity="flexible" if options.flexible_housing_on else "rigid",
                          reduced=reduced_housing)
    sun = input_stage.build(mbs, spec, ground_coord, fidelity="rigid")
    if flexible_carrier and reduced_carrier is None:
        from rvflex.fe.reduce import reduce_part

        reduced_carrier = reduce_part(spec, "carrier", **dataclasses.asdict(options.carrier))
    carrier = carrier_part.build(mbs, spec, errors, ground_body, ground_coord,
                                 fidelity="flexible" if flexible_carrier else "rigid", reduced=reduced_carrier,
                                 seat_marker=options.carrier_seat_marker)
    axes = carrier_part.crank_axis_positions(spec, errors)
    # flexible carrier: the lumped support pair splits into one bearing per plate seat
    cranks = crankshaft.build(mbs, carrier_part.split_support_bearing(spec) if flexible_carrier else spec, errors,
                              carrier, sun.node, axes, fidelity="rigid")
    seat_in = carrier_part.add_input_seat_bearings(mbs, spec, errors, carrier, cranks) if flexible_carrier else ()
    ecc = crankshaft.eccentric_offsets(spec, errors)
    reduced_discs = ()
    if options.flexible_discs_on:
        from rvflex.fe.reduce import reduce_part

        # a disc that is not disc 0 turned (fe_disc_placements) is reduced as the exact disc it is
        fe_spec = disc_mesh_spec(spec, disc_mesh_modification)
        if isinstance(reduced_disc, (tuple, list)):  # one given per disc
            reduced_discs = tuple(reduced_disc)
        else:
            from rvflex.fe.types import FEError

            by_turn = {} if reduced_disc is None else {0.0: reduced_disc}
            for d, place in enumerate(cycloid_disc.fe_disc_placements(spec)):
                h = place.holes_turn_rad
                if h not in by_turn:
                    try:
                        by_turn[h] = reduce_part(cycloid_disc.fe_disc_spec(fe_spec, h), "disc",
                                                 **dataclasses.asdict(options.discs))
                    except FEError as err:
                        if h == 0.0:
                            raise
                        raise FEError(f"disc {d}'s own FE body (cranks and pillars turned by {h:.6f} rad against "
                                      f"the teeth): {err}") from err
                reduced_discs += (by_turn[h],)
        reduced_disc = reduced_discs[0]
    discs = cycloid_disc.build(mbs, spec, errors, cranks, law, ecc, axes,
                               fidelity="flexible" if options.flexible_discs_on else "rigid",
                               reduced=reduced_discs or None, ground_coordinate=ground_coord, housing=pins,
                               face_slices=options.face_slices)
    mbs.Assemble()
    ref = np.asarray(mbs.systemData.GetODE2Coordinates(configuration=exu.ConfigurationType.Reference))
    centres = np.array([np.asarray(mbs.GetNode(n)["referenceCoordinates"])[:2] for n in discs.nodes])
    return ReducerModel(spec, errors, options, sc, mbs, sun, carrier, cranks, discs, pins, ref, axes, centres, seat_in,
                        reduced_disc, reduced_carrier, reduced_discs, reduced_housing)


def _build_spatial(spec: ReducerSpec, errors: ErrorSpec, options: ModelOptions, law: ContactLaw,
                   hold_out_of_plane: bool) -> ReducerModel:
    """The spatial rigid model (module docstring) of :func:`build_reducer`.

    Pin bending (``options.spatial.pin_bending``) needs a pin seat span, which no spec gives yet: the pins
    are rigid, as :class:`~rvflex.options.SpatialSettings` states for a spec without one.
    """
    import exudyn as exu
    from exudyn.itemInterface import CoordinateConstraint, MarkerNodeCoordinate, NodePointGround

    spec.check_spatial("options.spatial")
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    ground_coord = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()), coordinate=0))
    pins = pin_ring.build(mbs, spec, errors, fidelity="rigid")
    sun = input_stage.build(mbs, spec, ground_coord, fidelity="rigid")
    carrier = carrier_part.build_spatial(mbs, spec, errors, ground_coord)
    axes = carrier_part.crank_axis_positions(spec, errors)
    # each crank's two support bearings are the two the planar model lumps into spec.bearings.crank_support
    beam = options.spatial.crank_elements if options.spatial.crank == "beam" else None
    cranks = crankshaft.build_spatial(mbs, spec, errors, carrier, sun.node, axes, beam_elements=beam)
    discs = cycloid_disc.build_spatial(mbs, spec, errors, cranks, law, crankshaft.eccentric_offsets(spec, errors), axes,
                                       face_slices=options.face_slices)
    if hold_out_of_plane:
        crank_nodes = [n for shaft in cranks.stations for n in shaft] or cranks.nodes
        for node in (carrier.node, *crank_nodes, *discs.nodes):
            for coord in (2, 3, 4):  # z, ψx, ψy
                m = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=coord))
                mbs.AddObject(CoordinateConstraint(markerNumbers=[ground_coord, m]))
    mbs.Assemble()
    ref = np.asarray(mbs.systemData.GetODE2Coordinates(configuration=exu.ConfigurationType.Reference))
    centres = np.array([np.asarray(mbs.GetNode(n)["referenceCoordinates"])[:2] for n in discs.nodes])
    return ReducerModel(spec, errors, options, sc, mbs, sun, carrier, cranks, discs, pins, ref, axes, centres,
                        cranks.input_supports, out_of_plane_held=bool(hold_out_of_plane))

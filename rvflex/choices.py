"""The string options that select behaviour, as ``Literal`` types, and the one check they share.

Every option whose value picks a code path (a fidelity, a coupling, a design kind, an
executor …) is typed by one of the ``Literal`` aliases below and checked where it enters
(a dataclass's ``__post_init__``, a loader, a command) by :func:`check_choice`, which refuses
any other value with a :class:`~rvflex.spec_types.SpecError` naming the field and listing the
allowed values. ``typing.get_args(T)`` gives the allowed values of a type ``T``.

Names that are an open set, not a choice, stay ``str``: a sweep's scenario is any name
registered with :mod:`rvflex.sweeps.registry`, checked there.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from typing import Literal, get_args

from rvflex.spec_types import SpecError

__all__ = ["BodyFidelity", "ContactLawKind", "ConvergencePart", "CrankModel", "DesignKind", "Distribution", "EffectKind", "Executor", "FEPart",
           "DiscrepancyKind", "EvidenceModel", "Fidelity", "Mismatch", "PairContacts", "PatchShape", "PlanarFidelity", "RunCostKind", "RunKind", "SeatCoupling", "SeatMarker", "TEMode", "check_choice",
           "choices", "did_you_mean"]

PlanarFidelity = Literal["rigid", "flexible", "flexible-carrier", "flexible-all"]
"""The planar presets (the CLI's ``--fidelity``): rigid parts; FE discs; FE discs and carrier; FE discs,
carrier and pin housing."""

Fidelity = Literal[PlanarFidelity, "spatial"]
"""Names of the :class:`~rvflex.options.ModelOptions` presets: the planar ones (:data:`PlanarFidelity`) and
``"spatial"`` (rigid bodies free out of their plane, :meth:`~rvflex.options.ModelOptions.spatial_rigid`)."""

PairContacts = Literal["springs", "element"]
"""The main bearing pair's balls in an Exudyn carrier model (:mod:`rvflex.parts.main_bearing`): one linearised
spring per ball (the cross-check), or the pair element on the pair's own kernel."""

CrankModel = Literal["rigid", "beam"]
"""The cranks of the spatial model (:class:`~rvflex.options.SpatialSettings`): rigid bodies, or flexible
(Timoshenko) shafts."""

BodyFidelity = Literal["rigid", "flexible"]
"""How a part builder (:mod:`rvflex.parts`) builds its part: a planar rigid body or a
Craig–Bampton FFRF body."""

FEPart = Literal["disc", "carrier", "housing"]
"""The parts :func:`rvflex.fe.reduce.reduce_part` can reduce (``"housing"``: the pin housing)."""

SeatMarker = Literal["virtual", "all_nodes"]
"""Flexible carrier seat markers: on four massless nodes carrying each seat's RBE3 motion
(``"virtual"``) or on all seat nodes (``"all_nodes"``: the same coupling, slow — for comparison)."""

SeatCoupling = Literal["rbe3", "rbe2"]
"""Carrier crank-seat coupling of a reduction: distributing (RBE3) or rigid rings (RBE2)."""

PatchShape = Literal["hat", "cos2"]
"""Weight of a flank patch load along the arc length: linear hat or cos²."""

ContactLawKind = Literal["linear", "power", "line", "strip"]
"""Normal law of the cycloid–pin contact (:class:`rvflex.contact.cycloid_pin.ContactLaw`)."""

TEMode = Literal["quasi-static", "dynamic"]
"""Loaded-TE solution: quasi-static stepping or a generalized-α time integration."""

Executor = Literal["serial", "process", "dask"]
"""Where a sweep evaluates its points: this process, a local process pool, a Dask cluster."""

DesignKind = Literal["single-factor", "L9", "L16", "L27", "lhs", "sobol", "monte-carlo", "morris", "sobol-indices"]
"""Kinds of sweep design (:mod:`rvflex.sweeps.designs`)."""

Distribution = Literal["uniform", "normal"]
"""Monte Carlo sampling of a tolerance: uniform in [low, high] or normal with ``sigma``."""

EffectKind = Literal["model", "conditions", "measurement", "fidelity"]
"""How a diagnosis effect acts (:class:`rvflex.diagnosis.effects.Effect`): on the spec and errors the
model is built with, on the run conditions, on the recorded TE, or as another model blended in."""

RunKind = Literal["te", "hysteresis"]
"""Kinds of bench run (:mod:`rvflex.diagnosis.bench`): a loaded-TE run or a torque cycle."""

RunCostKind = Literal["rigid", "flexible", "contact-law"]
"""Kinds of diagnosis model run ``rvflex bench diagnosis`` times (:mod:`rvflex.diagnosis.runcost`): the
rigid model; the rigid and the flexible model (the disc-flexibility share); the rigid and two flexible
models (the contact-law form)."""

ConvergencePart = Literal["discs", "housing"]
"""Parts whose FE reduction the convergence study refines (the ``ModelOptions`` field it sets)."""

EvidenceModel = Literal["discrepancy", "bic"]
"""How a diagnosis weighs an effect's evidence: against a model discrepancy per order band and run, or with
one variance for all features (the plain BIC, with the fixed gap-shrink rule)."""

DiscrepancyKind = Literal["orders", "mesh orders", "wind-up", "loading curve", "hysteresis"]
"""Kinds of the diagnosis' discrepancy groups: a TE run's octave band of orders, its pin-mesh orders, the
wind-ups of the TE runs, a torque cycle's loading curve (its branches' midline) and hysteresis (their
half-width)."""

Mismatch = Literal["none", "realistic", "far", "ensemble"]
"""Self-check generators: the diagnosing model's family, another one per case, or another one whose
overall stiffness is also drawn far from the model's (×0.5 … ×2)."""


def choices(kind) -> tuple[str, ...]:
    """The allowed values of a ``Literal`` type, in their order."""
    return get_args(kind)


def did_you_mean(value: object, known: Iterable[str]) -> str:
    """``"; did you mean 'x'?"`` for the known name closest to ``value`` (difflib ratio ≥ 0.6;
    a case-only difference always matches), else ``""``: the tail of an unknown-name message."""
    if not isinstance(value, str):
        return ""
    known = list(known)
    folded = [k for k in known if k.casefold() == value.casefold()]
    close = folded or difflib.get_close_matches(value, known, n=1, cutoff=0.6)
    return f"; did you mean {close[0]!r}?" if close else ""


def check_choice(field: str, value: object, kind, source: str | None = None) -> None:
    """Refuse ``value`` unless it is one of the values of the ``Literal`` type ``kind``.

    Raises
    ------
    SpecError
        Naming ``field`` (and ``source``, the file it came from), listing the allowed values and
        suggesting the closest one.
    """
    allowed = get_args(kind)
    if not (isinstance(value, str) and value in allowed):
        raise SpecError(field, value, f"must be one of {', '.join(map(repr, allowed))}{did_you_mean(value, allowed)}",
                        source)

"""Reducer specifications: the validated dataclasses (from :mod:`rvflex.spec_types`), their
TOML load/dump, and the geometric check every spec passes where it enters rvflex.

Everything is SI (m, rad, N, N·m, kg, Pa, s). Every dataclass validates itself in
``__post_init__`` (closed-form rules) and raises :class:`SpecError` naming the field, its
value and the rule it breaks; variants are made with :func:`dataclasses.replace`, which
re-validates. The cycloid profile's geometric check (:func:`check_geometry`: theoretical and
modified profiles are simple counter-clockwise closed curves) needs the exact profile, so it
runs where specs enter: :func:`loads_spec`/:func:`load_spec` (and so the catalogue) and
``build_reducer``, not on every ``replace``.

TOML mirrors the dataclasses one table per nested dataclass. :func:`loads_spec` is
strict: an unknown (e.g. misspelled) or a missing key is refused, except the optional ones, the
fields typed ``X | None`` whose default is None (``[bearings.main_pair]``, ``[bearings.crank_support_pair]``,
``allowable_moment_Nm``, ``catalogue_moment_rigidity_Nm_per_arcmin``, ``catalogue_lost_motion_arcmin``,
``cranks.support_span_m``, ``cranks.support_journal_radius_m``, ``cranks.gear_axial_position_m``, a bearing's
``load_exponent`` and ``reference_load_N``): omitted, they are
None, and a None is not written. Error files (:func:`loads_errors`) may omit keys: an omitted error
source is zero.
"""

from __future__ import annotations

import dataclasses
import difflib
import tomllib
import types
import typing
from dataclasses import fields
from pathlib import Path

import tomli_w

from rvflex.geometry.profile import check_stage
from rvflex.io import write_text
from rvflex.spec_types import (
    AngularContactPair,
    Bearing,
    Bearings,
    Carrier,
    Cranks,
    CycloidStage,
    ErrorSpec,
    InputStage,
    Material,
    Materials,
    Modification,
    ReducerSpec,
    SpecError,
    TaperedRollerPair,
)

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
    "TaperedRollerPair",
    "Bearings",
    "Carrier",
    "ReducerSpec",
    "ErrorSpec",
    "check_geometry",
    "loads_spec",
    "load_spec",
    "dumps_spec",
    "dump_spec",
    "loads_errors",
    "load_errors",
    "dumps_errors",
    "dump_errors",
]


def check_geometry(spec: ReducerSpec) -> None:
    """Refuse a spec whose theoretical or modified cycloid profile is not a simple closed
    counter-clockwise curve (undercut, swallowtail); raises :class:`SpecError` naming
    ``cycloid.pin_radius_m`` or ``cycloid.modification``."""
    check_stage(spec.cycloid)


# --------------------------------------------------------------------------- TOML


def _is_dataclass_type(tp: object) -> bool:
    return isinstance(tp, type) and dataclasses.is_dataclass(tp)


def _optional_inner(tp: object) -> object | None:
    """``X`` of an annotation ``X | None`` (None for any other annotation)."""
    if typing.get_origin(tp) in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if len(args) == 1 and len(typing.get_args(tp)) == 2:
            return args[0]
    return None


def _convert(tp: object, value: object, name: str) -> object:
    """Convert a TOML value to the annotated type, refusing type mismatches."""
    inner = _optional_inner(tp)
    if inner is not None:  # TOML has no null: a present value is the inner type
        return _convert(inner, value, name)
    origin = typing.get_origin(tp)
    if _is_dataclass_type(tp):
        if not isinstance(value, dict):
            raise SpecError(name, value, "must be a table")
        return _from_dict(tp, value, name)
    if origin is tuple:
        inner = typing.get_args(tp)[0]
        if not isinstance(value, list):
            raise SpecError(name, value, "must be an array")
        return tuple(_convert(inner, v, f"{name}[{k}]") for k, v in enumerate(value))
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise SpecError(name, value, "must be a number")
        return float(value)
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise SpecError(name, value, "must be an integer")
        return value
    if tp is str:
        if not isinstance(value, str):
            raise SpecError(name, value, "must be a string")
        return value
    raise TypeError(f"unsupported annotation {tp!r} for {name}")  # programming error, not input


def _from_dict(cls: type, data: dict, prefix: str = "", *, partial: bool = False) -> object:
    hints = typing.get_type_hints(cls)
    names = [f.name for f in fields(cls)]
    optional = {f.name for f in fields(cls) if f.default is None and _optional_inner(hints[f.name]) is not None}
    for key in data:
        if key not in names:
            close = difflib.get_close_matches(key, names, n=1)
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            where = f"[{prefix}]" if prefix else "top level"
            raise SpecError(f"{prefix}.{key}" if prefix else key, data[key],
                            f"unknown key in {where}{hint}")
    kwargs = {}
    for n in names:
        full = f"{prefix}.{n}" if prefix else n
        if n not in data:
            if partial or n in optional:
                continue
            raise SpecError(full, None, "missing key")
        kwargs[n] = _convert(hints[n], data[n], full)
    try:
        return cls(**kwargs)
    except SpecError as err:
        raise err.within(prefix) from None


def _to_dict(obj: object) -> dict:
    def conv(v: object) -> object:
        if dataclasses.is_dataclass(v):  # None is an omitted optional field (TOML has no null)
            return {f.name: conv(getattr(v, f.name)) for f in fields(v) if getattr(v, f.name) is not None}
        if isinstance(v, tuple):
            return [conv(x) for x in v]
        return v

    return conv(obj)  # type: ignore[return-value]


def _parse(text: str, source: str) -> dict:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise SpecError("<file>", source, f"is not valid TOML: {err}", source) from None


def loads_spec(text: str, source: str = "<string>") -> ReducerSpec:
    """Parse a reducer spec from TOML text; every key is required, none may be unknown; the
    profile geometry is checked (:func:`check_geometry`)."""
    try:
        spec = _from_dict(ReducerSpec, _parse(text, source))
        check_geometry(spec)  # type: ignore[arg-type]
        return spec  # type: ignore[return-value]
    except SpecError as err:
        raise err.within(source=source) from None


def load_spec(path: str | Path) -> ReducerSpec:
    """Read a reducer spec TOML file (see :func:`loads_spec`)."""
    path = Path(path)
    return loads_spec(path.read_text(encoding="utf-8"), str(path))


def dumps_spec(spec: ReducerSpec) -> str:
    """TOML text of ``spec``; ``loads_spec(dumps_spec(s)) == s`` exactly."""
    return tomli_w.dumps(_to_dict(spec))


def dump_spec(spec: ReducerSpec, path: str | Path) -> None:
    """Write ``spec`` as TOML to ``path``."""
    write_text(path, dumps_spec(spec))


def loads_errors(text: str, source: str = "<string>", spec: ReducerSpec | None = None) -> ErrorSpec:
    """Parse an :class:`ErrorSpec` from TOML (omitted keys are zero); check counts against ``spec``."""
    try:
        errors = _from_dict(ErrorSpec, _parse(text, source), partial=True)
        if spec is not None:
            errors.check_against(spec)  # type: ignore[union-attr]
        return errors  # type: ignore[return-value]
    except SpecError as err:
        raise err.within(source=source) from None


def load_errors(path: str | Path, spec: ReducerSpec | None = None) -> ErrorSpec:
    """Read an error TOML file (see :func:`loads_errors`)."""
    path = Path(path)
    return loads_errors(path.read_text(encoding="utf-8"), str(path), spec)


def dumps_errors(errors: ErrorSpec) -> str:
    """TOML text of ``errors`` (every field written); round-trips exactly."""
    return tomli_w.dumps(_to_dict(errors))


def dump_errors(errors: ErrorSpec, path: str | Path) -> None:
    """Write ``errors`` as TOML to ``path``."""
    write_text(path, dumps_errors(errors))

"""Built-in reducer catalogue: one TOML file per reducer, every value with its source."""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

from rvflex.choices import did_you_mean
from rvflex.spec import ErrorSpec, ReducerSpec, SpecError, load_errors, load_spec, loads_errors, loads_spec

__all__ = ["names", "error_set_names", "load", "load_error_set", "resolve", "resolve_errors", "text"]

ERRORS_SUFFIX = ".errors.toml"


def names() -> list[str]:
    """Names of the built-in reducers (file stems), sorted."""
    return sorted(p.name[:-5] for p in resources.files(__package__).iterdir()
                  if p.name.endswith(".toml") and not p.name.endswith(ERRORS_SUFFIX))


def error_set_names() -> list[str]:
    """Names of the built-in error sets (``rv40e_seed001``), sorted."""
    return sorted(p.name[:-len(ERRORS_SUFFIX)] for p in resources.files(__package__).iterdir()
                  if p.name.endswith(ERRORS_SUFFIX))


def load_error_set(name: str, spec: ReducerSpec, *, field: str = "errors"):
    """Load the built-in error set ``name``, checked against ``spec``; an unknown name is refused
    naming ``field`` and suggesting the closest built-in one."""
    known = error_set_names()
    if name not in known:
        raise SpecError(field, name, f"neither a file nor a built-in error set ({', '.join(known)})"
                                     f"{did_you_mean(name, known)}")
    text = resources.files(__package__).joinpath(name + ERRORS_SUFFIX).read_text(encoding="utf-8")
    return loads_errors(text, f"catalog/{name}{ERRORS_SUFFIX}", spec)


def text(name: str, *, field: str = "reducer") -> str:
    """TOML source of the built-in reducer ``name``; an unknown name is refused naming ``field``
    and suggesting the closest built-in one."""
    known = names()
    if name not in known:
        raise SpecError(field, name, f"unknown reducer; built-in: {', '.join(known)}{did_you_mean(name, known)}")
    return resources.files(__package__).joinpath(f"{name}.toml").read_text(encoding="utf-8")


def load(name: str, *, field: str = "reducer") -> ReducerSpec:
    """Load the built-in reducer ``name`` (e.g. ``"rv40e"``); errors name ``field``."""
    return loads_spec(text(name, field=field), f"catalog/{name}.toml")


def resolve(name_or_path: str, field: str = "--reducer") -> ReducerSpec:
    """A built-in reducer name (``rv40e``) or the path of a reducer spec TOML file; errors name
    ``field`` (the commands' flag by default).

    A value ending in ``.toml`` or containing a path separator is a path; anything else a
    catalogue name. Both routes validate the spec, its profile geometry included."""
    if name_or_path.endswith(".toml") or os.sep in name_or_path:
        path = Path(name_or_path)
        if not path.is_file():
            raise SpecError(field, name_or_path, "file not found")
        return load_spec(path)
    return load(name_or_path, field=field)


def resolve_errors(name_or_path: str | None, spec: ReducerSpec, field: str = "--errors") -> ErrorSpec | None:
    """An ErrorSpec TOML file or a built-in error set name (``rv40e_seed001``), checked against
    ``spec``; None gives None. Errors name ``field`` (the commands' flag by default)."""
    if name_or_path is None:
        return None
    if Path(name_or_path).is_file():
        return load_errors(name_or_path, spec)
    if not name_or_path.endswith(".toml") and os.sep not in name_or_path:
        return load_error_set(name_or_path, spec, field=field)
    raise SpecError(field, name_or_path, "file not found")

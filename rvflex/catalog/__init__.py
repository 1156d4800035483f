"""Built-in reducer catalogue: one TOML file per reducer, every value with its source."""

from __future__ import annotations

from importlib import resources

from rvflex.spec import ReducerSpec, SpecError, loads_spec

__all__ = ["names", "error_set_names", "load", "load_error_set", "text"]

ERRORS_SUFFIX = ".errors.toml"


def names() -> list[str]:
    """Names of the built-in reducers (file stems), sorted."""
    return sorted(p.name[:-5] for p in resources.files(__package__).iterdir()
                  if p.name.endswith(".toml") and not p.name.endswith(ERRORS_SUFFIX))


def error_set_names() -> list[str]:
    """Names of the built-in error sets (``rv40e_seed001``), sorted."""
    return sorted(p.name[:-len(ERRORS_SUFFIX)] for p in resources.files(__package__).iterdir()
                  if p.name.endswith(ERRORS_SUFFIX))


def load_error_set(name: str, spec: ReducerSpec):
    """Load the built-in error set ``name``, checked against ``spec``."""
    from rvflex.spec import loads_errors

    if name not in error_set_names():
        raise SpecError("--errors", name, f"neither a file nor a built-in error set ({', '.join(error_set_names())})")
    text = resources.files(__package__).joinpath(name + ERRORS_SUFFIX).read_text(encoding="utf-8")
    return loads_errors(text, f"catalog/{name}{ERRORS_SUFFIX}", spec)


def text(name: str) -> str:
    """TOML source of the built-in reducer ``name``."""
    if name not in names():
        raise SpecError("--reducer", name, f"unknown reducer; built-in: {', '.join(names())}")
    return resources.files(__package__).joinpath(f"{name}.toml").read_text(encoding="utf-8")


def load(name: str) -> ReducerSpec:
    """Load the built-in reducer ``name`` (e.g. ``"rv40e"``)."""
    return loads_spec(text(name), f"catalog/{name}.toml")

"""Built-in reducer catalogue: one TOML file per reducer, every value with its source."""

from __future__ import annotations

from importlib import resources

from rvflex.spec import ReducerSpec, SpecError, loads_spec

__all__ = ["names", "load", "text"]


def names() -> list[str]:
    """Names of the built-in reducers (file stems), sorted."""
    return sorted(p.name[:-5] for p in resources.files(__package__).iterdir() if p.name.endswith(".toml"))


def text(name: str) -> str:
    """TOML source of the built-in reducer ``name``."""
    if name not in names():
        raise SpecError("--reducer", name, f"unknown reducer; built-in: {', '.join(names())}")
    return resources.files(__package__).joinpath(f"{name}.toml").read_text(encoding="utf-8")


def load(name: str) -> ReducerSpec:
    """Load the built-in reducer ``name`` (e.g. ``"rv40e"``)."""
    return loads_spec(text(name), f"catalog/{name}.toml")

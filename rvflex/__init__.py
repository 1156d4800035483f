"""rvflex: rigid–flexible Exudyn models of RV reducers for loaded transmission error,
lost motion and backlash. SI units throughout; see README.md for conventions.

The top-level names load on first use (PEP 562), so ``import rvflex`` stays fast::

    import rvflex
    spec = rvflex.load_reducer("rv40e")
    r = rvflex.run(rvflex.LoadedTE(spec, load_Nm=412.0, options="flexible"))
    r.metrics.te_pp_arcsec; r.to_dataframe(); r.to_xarray(); r.plot(); r.write("out/te")
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

__version__ = "0.1.0"

_LAZY = {
    "load_reducer": "rvflex.api",
    "load_errors": "rvflex.api",
    "run": "rvflex.api",
    "RunError": "rvflex.api",
    "build_reducer": "rvflex.model",
    "ReducerModel": "rvflex.model",
    "ModelOptions": "rvflex.options",
    "PartSettings": "rvflex.fe.reduce",
    "Result": "rvflex.result",
    "SpecError": "rvflex.spec",
    "ReducerSpec": "rvflex.spec",
    "ErrorSpec": "rvflex.spec",
    "LoadedTE": "rvflex.scenarios.loaded_te",
    "LostMotion": "rvflex.scenarios.lost_motion",
    "ReversalBacklash": "rvflex.scenarios.reversal_backlash",
    "FlexibilityEffect": "rvflex.scenarios.flexibility_effect",
}

__all__ = ["__version__", *_LAZY]

if TYPE_CHECKING:  # for type checkers and IDEs; at run time the names load lazily
    from rvflex.api import RunError, load_errors, load_reducer, run
    from rvflex.fe.reduce import PartSettings
    from rvflex.model import ReducerModel, build_reducer
    from rvflex.options import ModelOptions
    from rvflex.result import Result
    from rvflex.scenarios.flexibility_effect import FlexibilityEffect
    from rvflex.scenarios.loaded_te import LoadedTE
    from rvflex.scenarios.lost_motion import LostMotion
    from rvflex.scenarios.reversal_backlash import ReversalBacklash
    from rvflex.spec import ErrorSpec, ReducerSpec, SpecError


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'rvflex' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later look-ups skip __getattr__
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))

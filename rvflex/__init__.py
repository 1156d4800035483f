"""rvflex: rigid–flexible Exudyn models of RV reducers for loaded transmission error,
lost motion and backlash. SI units throughout; conventions in docs/conventions.md.

The top-level names load on first use (PEP 562), so ``import rvflex`` stays fast::

    import rvflex
    spec = rvflex.load_reducer("rv40e")
    r = rvflex.run(rvflex.LoadedTE(spec, load_Nm=412.0, options="flexible"))
    r.metrics.te_pp_arcsec; r.to_dataframe(); r.to_xarray(); r.plot(); r.write("out/te")
    rvflex.sweep("design.toml").to_dataframe()        # a tolerance sweep
    rvflex.diagnose("bench_dir").to_dataframe()       # the sim-to-real gap of bench data
"""

from __future__ import annotations

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
    "OutputLoad": "rvflex.tilt",
    "PartSettings": "rvflex.fe.reduce",
    "Result": "rvflex.result",
    "SpecError": "rvflex.spec",
    "ReducerSpec": "rvflex.spec",
    "ErrorSpec": "rvflex.spec",
    "LoadedTE": "rvflex.scenarios.loaded_te",
    "LostMotion": "rvflex.scenarios.lost_motion",
    "ReversalBacklash": "rvflex.scenarios.reversal_backlash",
    "FlexibilityEffect": "rvflex.scenarios.flexibility_effect",
    "sweep": "rvflex.studies",
    "load_design": "rvflex.studies",
    "Design": "rvflex.sweeps.designs",
    "Factor": "rvflex.sweeps.designs",
    "diagnose": "rvflex.studies",
    "read_bench": "rvflex.diagnosis.bench",
    "DiagnosisSettings": "rvflex.diagnosis.settings",
    "selfcheck": "rvflex.studies",
}

__all__ = ["Design", "DiagnosisSettings", "ErrorSpec", "Factor", "FlexibilityEffect", "LoadedTE", "LostMotion",
           "ModelOptions", "OutputLoad", "PartSettings", "ReducerModel", "ReducerSpec", "Result", "ReversalBacklash", "RunError",
           "SpecError", "__version__", "build_reducer", "diagnose", "load_design", "load_errors", "load_reducer",
           "read_bench", "run", "selfcheck", "sweep"]

if TYPE_CHECKING:  # for type checkers and IDEs; at run time the names load lazily
    from rvflex.api import RunError, load_errors, load_reducer, run
    from rvflex.diagnosis.bench import read_bench
    from rvflex.diagnosis.settings import DiagnosisSettings
    from rvflex.fe.reduce import PartSettings
    from rvflex.model import ReducerModel, build_reducer
    from rvflex.options import ModelOptions
    from rvflex.result import Result
    from rvflex.scenarios.flexibility_effect import FlexibilityEffect
    from rvflex.scenarios.loaded_te import LoadedTE
    from rvflex.scenarios.lost_motion import LostMotion
    from rvflex.scenarios.reversal_backlash import ReversalBacklash
    from rvflex.spec import ErrorSpec, ReducerSpec, SpecError
    from rvflex.studies import diagnose, load_design, selfcheck, sweep
    from rvflex.sweeps.designs import Design, Factor
    from rvflex.tilt import OutputLoad


def __getattr__(name: str):
    """Load a public name on first use; an unknown name is refused suggesting the closest one."""
    import importlib

    module = _LAZY.get(name)
    if module is None:
        hint = ""
        if not name.startswith("_"):  # tools probe _private/__dunder__ names: answer those without importing
            from rvflex.choices import did_you_mean

            hint = did_you_mean(name, __all__)
        raise AttributeError(f"module 'rvflex' has no attribute {name!r}{hint}", name=name)
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later look-ups skip __getattr__
    return value


def __dir__() -> list[str]:
    """The public names (``__all__``): not the module's imports, nor the submodules it loaded."""
    return sorted(__all__)

"""The Python API behind ``import rvflex``: load a reducer and its errors, build a model, run a
scenario and get a labelled :class:`~rvflex.result.Result`.

::

    import rvflex
    spec = rvflex.load_reducer("rv40e")
    r = rvflex.run(rvflex.LoadedTE(spec, load_Nm=412.0, positions_per_rev=256))
    r.metrics.te_pp_arcsec, r.to_dataframe(), r.plot()

The ``rvflex`` command calls exactly these functions.
"""

from __future__ import annotations

import os
from pathlib import Path

from rvflex import catalog
from rvflex.spec import ErrorSpec, ReducerSpec, SpecError, load_spec
from rvflex.spec import load_errors as load_errors_file

__all__ = ["SCENARIO_TYPES", "RunError", "describe_run", "load_errors", "load_reducer", "one_line", "run"]

SCENARIO_TYPES = ("LoadedTE", "LostMotion", "ReversalBacklash", "FlexibilityEffect")


class RunError(RuntimeError):
    """A run that was set up correctly failed: its model could not be built (an FE reduction, the
    Exudyn assembly) or its solve did not converge.

    ``str(error)`` is one line, ``"<unit>, <run>: <what failed>"``, e.g. ``"rv80e, loaded TE
    (flexible, 800 N·m, 256 positions/rev): Craig–Bampton reduction of the disc (maxh 6 mm, order 2,
    12 modes) failed: ..."``; the ``rvflex`` command prints the same line. The original exception
    is ``error.__cause__`` (its traceback: ``rvflex --debug``).

    Attributes
    ----------
    unit : str
        The reducer's name (``spec.name``).
    run : str
        The scenario with its fidelity and main settings.
    failure : str
        What failed (the first line of the original message).

    Parameters
    ----------
    unit, run, failure : str
        As the attributes.
    """

    def __init__(self, unit: str, run: str, failure: str):
        super().__init__(f"{unit}, {run}: {failure}")
        self.unit, self.run, self.failure = unit, run, failure

    def __reduce__(self):  # picklable: a failing run in a worker process stays a RunError
        return (type(self), (self.unit, self.run, self.failure))


def one_line(err: BaseException) -> str:
    """The first line of ``err``'s message, prefixed by its type unless it is one of rvflex's own
    errors or a plain RuntimeError (whose messages say what failed); '(more with --debug)' when
    lines were dropped."""
    lines = [ln.strip() for ln in str(err).splitlines() if ln.strip()]
    text = lines[0] if lines else "(no message)"
    if len(lines) > 1:
        text += " (more with --debug)"
    if type(err).__module__.startswith("rvflex") or type(err) is RuntimeError:
        return text
    return f"{type(err).__name__}: {text}"


def describe_run(scenario) -> str:
    """``"loaded TE (flexible, 800 N·m, 256 positions/rev)"``: the scenario, its fidelity and main
    settings, as :class:`RunError` names a run."""
    name = {"LoadedTE": "loaded TE", "LostMotion": "lost motion", "ReversalBacklash": "reversal backlash",
            "FlexibilityEffect": "flexibility effect"}.get(type(scenario).__name__, type(scenario).__name__)
    opts = getattr(scenario, "options", None)
    parts = [opts.fidelity] if opts is not None and hasattr(opts, "fidelity") else []
    for field, fmt in (("load_Nm", "{:g} N·m"), ("torque_Nm", "±{:g} N·m"), ("positions_per_rev", "{} positions/rev"),
                       ("steps", "{} steps"), ("positions", "{} positions")):
        v = getattr(scenario, field, None)
        if v is not None:
            parts.append(fmt.format(v))
    return f"{name} ({', '.join(parts)})" if parts else name


def load_reducer(name_or_path: str | os.PathLike, *, field: str = "name_or_path") -> ReducerSpec:
    """Load a built-in catalogue reducer or a reducer spec TOML file.

    Parameters
    ----------
    name_or_path : str or os.PathLike
        A built-in name (``"rv40e"``, ``"rv80e"``; :func:`rvflex.catalog.names`) or the path of a
        spec TOML file (a value ending in ``.toml``, containing a path separator, or a path object).
    field : str, optional
        The name errors give the value (the caller's parameter or flag).

    Returns
    -------
    ReducerSpec
        The validated spec (SI units), its profile geometry checked.

    Raises
    ------
    SpecError
        Unknown name (with the closest built-in name suggested), missing file or an invalid
        spec, naming ``field``.
    """
    if not isinstance(name_or_path, (str, os.PathLike)):
        raise TypeError(f"load_reducer: expected a catalogue name or a TOML path, got {type(name_or_path).__name__}")
    name = os.fspath(name_or_path)
    if name.endswith(".toml") or os.sep in name or isinstance(name_or_path, os.PathLike):
        path = Path(name)
        if not path.is_file():
            raise SpecError(field, name, "file not found")
        return load_spec(path)
    return catalog.load(name, field=field)


def load_errors(name_or_path: str | os.PathLike, spec: ReducerSpec, *, field: str = "name_or_path") -> ErrorSpec:
    """Load the manufacturing and assembly errors of a reducer.

    Parameters
    ----------
    name_or_path : str or os.PathLike
        An ErrorSpec TOML file (omitted keys are zero; lengths in m, angles in rad) or a built-in
        error set (``"rv40e_seed001"``; :func:`rvflex.catalog.error_set_names`).
    spec : ReducerSpec
        The reducer the errors belong to (pin and disc counts are checked against it).
    field : str, optional
        The name errors give the value (the caller's parameter or flag).

    Returns
    -------
    ErrorSpec
        The errors, checked against ``spec``.

    Raises
    ------
    SpecError
        Unknown name (with the closest built-in name suggested), missing file, or errors that do
        not fit ``spec``, naming ``field``.
    TypeError
        ``spec`` is not a ReducerSpec.
    """
    if not isinstance(spec, ReducerSpec):
        raise TypeError(f"load_errors: spec must be a ReducerSpec (rvflex.load_reducer(...)), got {type(spec).__name__}")
    name = os.fspath(name_or_path)
    if Path(name).is_file():
        return load_errors_file(name, spec)
    if not name.endswith(".toml") and os.sep not in name:
        return catalog.load_error_set(name, spec, field=field)
    raise SpecError(field, name, "file not found")


def run(scenario, *, model=None, progress=None):
    """Run a scenario and return its labelled result.

    Parameters
    ----------
    scenario : LoadedTE, LostMotion, ReversalBacklash or FlexibilityEffect
        What to run (:class:`~rvflex.scenarios.loaded_te.LoadedTE`,
        :class:`~rvflex.scenarios.lost_motion.LostMotion`,
        :class:`~rvflex.scenarios.reversal_backlash.ReversalBacklash`,
        :class:`~rvflex.scenarios.flexibility_effect.FlexibilityEffect`).
    model : ReducerModel, optional
        A model from :func:`rvflex.build_reducer` with the scenario's spec, errors and options,
        reused instead of building one and left as it was found: the same items, and the loads,
        drive and regulariser settings and coordinates it had.
    progress : callable, optional
        ``progress(done, total)``, called as the run advances.

    Returns
    -------
    Result
        The scenario's :class:`~rvflex.result.Result`: ``.metrics``, ``.to_xarray()``,
        ``.to_dataframe()``, ``.plot()``, ``.write(dir)``.

    Raises
    ------
    TypeError
        ``scenario`` is not one of the scenario types, or ``model`` not a ReducerModel.
    SpecError
        Bad input: ``model`` was built from another spec, errors or options than the scenario's,
        or a setting is out of range (the message names the field and the rule).
    RunError
        Anything else that failed while building the model or solving (an FE reduction, a step
        that did not converge): one line naming the unit, the run and what failed, the original
        exception as ``__cause__``.
    """
    from rvflex.scenarios.flexibility_effect import FlexibilityEffect
    from rvflex.scenarios.loaded_te import LoadedTE
    from rvflex.scenarios.lost_motion import LostMotion
    from rvflex.scenarios.reversal_backlash import ReversalBacklash

    types = (LoadedTE, LostMotion, ReversalBacklash, FlexibilityEffect)
    if not isinstance(scenario, types):
        raise TypeError(f"rvflex.run: expected a scenario ({', '.join('rvflex.' + n for n in SCENARIO_TYPES)}), "
                        f"got {type(scenario).__name__}: {scenario!r:.80}")
    if model is not None:
        preserved = _preserved(model)
    try:
        if model is None:
            return scenario.run(progress=progress)
        with preserved:
            return scenario.run(model=model, progress=progress)
    except (SpecError, RunError):
        raise
    except Exception as exc:
        raise RunError(scenario.spec.name, describe_run(scenario), one_line(exc)) from exc


class _preserved:
    """Restore the run-time settings a solver changes on a model (output load, regulariser,
    input drive, coordinates), so a run leaves a passed-in model as it found it."""

    def __init__(self, model):
        from rvflex.model import ReducerModel

        if not isinstance(model, ReducerModel):
            raise TypeError(f"rvflex.run: model must be a ReducerModel (rvflex.build_reducer(...)) or None, "
                            f"got {type(model).__name__}")
        self.model = model

    def __enter__(self):
        import exudyn as exu

        m = self.model
        mbs, sd = m.mbs, m.mbs.systemData
        self.load = mbs.GetLoadParameter(m.carrier.load, "load")
        self.reg = {k: mbs.GetObjectParameter(m.carrier.regulariser, k) for k in ("stiffness", "offset")}
        self.drive = mbs.GetObjectParameter(m.sun.drive, "offset")
        self.items = m.item_count
        self.q = {c: (sd.GetODE2Coordinates(configuration=c), sd.GetODE2Coordinates_t(configuration=c))
                  for c in (exu.ConfigurationType.Initial, exu.ConfigurationType.Current)}
        return self

    def __exit__(self, *exc):
        m = self.model
        mbs, sd = m.mbs, m.mbs.systemData
        mbs.SetLoadParameter(m.carrier.load, "load", self.load)
        for k, v in self.reg.items():
            mbs.SetObjectParameter(m.carrier.regulariser, k, v)
        mbs.SetObjectParameter(m.sun.drive, "offset", self.drive)
        for c, (q, v) in self.q.items():
            sd.SetODE2Coordinates(q, configuration=c)
            sd.SetODE2Coordinates_t(v, configuration=c)
        if m.item_count != self.items:  # a solver that adds items is a bug: say so rather than hide it
            raise RuntimeError(f"rvflex.run changed the model's item count ({self.items} → {m.item_count})")
        return False

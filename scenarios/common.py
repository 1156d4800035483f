"""What the model scenarios share: normalising their spec/errors/options and checking a
model passed in for reuse."""

from __future__ import annotations

import functools

from rvflex.model import ReducerModel, build_reducer
from rvflex.options import as_options
from rvflex.spec import ErrorSpec, ReducerSpec, SpecError

__all__ = ["OutputLoaded", "check_model", "check_scenario_inputs"]


def check_scenario_inputs(scenario) -> None:
    """Normalise and check the spec, errors and options shared by the model scenarios (in
    ``__post_init__``): errors None → none, options a preset name → its preset."""
    if not isinstance(scenario.spec, ReducerSpec):
        raise TypeError(f"{type(scenario).__name__}.spec: expected a ReducerSpec (rvflex.load_reducer(...)), "
                        f"got {type(scenario.spec).__name__}")
    if scenario.errors is None:
        object.__setattr__(scenario, "errors", ErrorSpec())
    elif not isinstance(scenario.errors, ErrorSpec):
        raise TypeError(f"{type(scenario).__name__}.errors: expected an ErrorSpec or None "
                        f"(rvflex.load_errors(...)), got {type(scenario.errors).__name__}")
    scenario.errors.check_against(scenario.spec)
    object.__setattr__(scenario, "options", as_options(scenario.options, "options"))


def check_model(scenario, model: ReducerModel | None) -> ReducerModel:
    """``model`` if it was built from the scenario's spec, errors and options, else a SpecError
    naming what differs; None builds the model."""
    # a scenario that moves parts (a tilting moment on the output) builds its model with those errors added
    errors = getattr(scenario, "model_errors", scenario.errors)
    if model is None:
        return build_reducer(scenario.spec, errors, scenario.options)
    if not isinstance(model, ReducerModel):
        raise TypeError(f"model: expected a ReducerModel (rvflex.build_reducer(...)) or None, "
                        f"got {type(model).__name__}")
    want = {"spec": scenario.spec, "errors": errors, "options": scenario.options}
    for name in ("spec", "errors", "options"):
        if getattr(model, name) != want[name]:
            def show(x):
                return x.name if name == "spec" else x.describe() if name == "options" else x
            got, need = show(getattr(model, name)), show(want[name])
            how = "scenario.model_errors" if hasattr(scenario, "model_errors") else "scenario.errors"
            raise SpecError("model", f"{name} {got}",
                            f"the model was built from another {name} than the scenario's ({need}): "
                            f"build it with rvflex.build_reducer(scenario.spec, {how}, scenario.options)")
    return model


class OutputLoaded:
    """What a model scenario with an ``output_load`` field (:class:`rvflex.tilt.OutputLoad` or None) derives from
    it: the carrier's tilt on its main bearing pair alone, and how the model takes the load. The planar model takes
    it one way, as the pins moved against the pair's tilt (:attr:`model_errors`); the spatial model
    (``options.spatial``) carries it as a load on the carrier (:attr:`solver_load`), its tilt solved with the
    gear train."""

    def _check_output_load(self) -> None:
        """Check the load against the spec (in ``__post_init__``): a moment within the allowable, the main
        bearing pair given, no ball beyond its static limit; an empty load becomes None."""
        from rvflex.tilt import OutputLoad

        load = self.output_load
        if load is not None and not isinstance(load, OutputLoad):
            raise TypeError(f"{type(self).__name__}.output_load: expected an rvflex.tilt.OutputLoad or None, "
                            f"got {type(load).__name__}")
        if load is not None and not load.any:
            object.__setattr__(self, "output_load", None)
        _ = self.tilt

    @functools.cached_property
    def tilt(self):
        """The carrier on its main bearing pair under ``output_load`` (:class:`rvflex.tilt.OutputTilt`); None
        without one. Solved once per scenario (the check, the model's errors, the result's attributes and the
        command's report all read it)."""
        from rvflex.tilt import carrier_tilt

        return None if self.output_load is None else carrier_tilt(self.spec, self.output_load)

    @property
    def model_errors(self) -> ErrorSpec:
        """The errors the model is built with: the unit's, with (planar model) the pins moved against the carrier
        displaced by ``output_load`` (:func:`rvflex.tilt.tilted_errors`); the spatial model's are the unit's."""
        from rvflex.tilt import tilted_errors

        tilt = self.tilt
        return self.errors if tilt is None or self.options.spatial is not None else tilted_errors(self.errors, tilt)

    @property
    def solver_load(self):
        """The output load the solver puts on the carrier (``output_load=`` of :func:`rvflex.solve.quasi_static`
        and :func:`rvflex.solve.torque_stepping`): ``output_load`` for the spatial model, None for the planar one
        (it is in :attr:`model_errors`)."""
        return self.output_load if self.options.spatial is not None else None

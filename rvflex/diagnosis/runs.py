"""Model runs of a diagnosis: evaluated serially or in the warm process pool of
:func:`rvflex.parallel.map_warm` (a dead worker is a failed evaluation), cached on disk by a content
hash of everything that determines them (spec, errors, plan, resolution, law, active effects)."""

from __future__ import annotations

import dataclasses as dc
import hashlib
import pickle
from collections import Counter
from pathlib import Path

import numpy as np

from rvflex.diagnosis.features import features
from rvflex.diagnosis.replay import EvaluationFailed, ModelRun, combine, joined, plan_evaluation, run_model
from rvflex.io import write_atomic
from rvflex.options import ModelOptions
from rvflex.parallel import Outcome, map_warm

__all__ = ["CACHE_VERSION", "FAILURE_REVISION", "ModelRunner"]

FAILURE_REVISION = "f5"  # failed runs are remembered per solver revision (f5: FE discs and carrier take the
# compiled step; f4: a cycle's first step that floats at
# zero torque is taken on the positive side; f3: a compiled step that fails is taken
# by the chord Newton before Exudyn's solver; f2: a torque cycle's step out of zero
# torque goes by the continuation once one has needed it; f1: a loading step or a cycle step that
# fails is solved again from the state converged at that torque, or left out): a solver that learns to take a
# step runs the point again, while every run that converged stays valid
CACHE_VERSION = "diag-13"  # 13: the FE discs of a diagnosis meshed with the unit's profile (model.disc_mesh_spec); 12: the plan in the key as plain tuples (no module path); 11: a rigid TE run goes on by the chord Newton once Exudyn's solver bisects; 10: the chord Newton re-initialised after Exudyn's solver ran


# ----------------------------------------------------------------------------- workers (module level: picklable)

def _run_item(item):
    """The response of one model run, or the failure message. Exudyn's console banners of retried
    static steps are silenced meanwhile (the retries are expected)."""
    import exudyn as exu

    spec, errors, plan, settings, law, run, parts = item
    before = exu.config.printToConsole
    exu.config.printToConsole = False
    try:
        return run_model(spec, errors, plan, settings, run, law=law, parts=parts, mesh_as_spec=True), ""
    except EvaluationFailed as err:
        return None, str(err)
    finally:
        exu.config.printToConsole = before


PLAN_RUNS_PER_PART = {"rigid": 1, "elastic": 2}
"""Plan runs per part of a model run in a pool. A rigid build takes 2 ms (the disc's checks kept per curve), so
each plan run is a part; an elastic one loads the reductions and builds in about 0.4 s of a 10-20 s run, so
two plan runs share it."""


def _joined(values: list[tuple]) -> tuple:
    """(response, message) of a run from its parts' in plan order: the first failing part's message, else
    the parts' responses joined."""
    for resp, msg in values:
        if resp is None:
            return None, msg
    return joined([v[0] for v in values]), ""


class ModelRunner:
    """Evaluates model runs (serially or in a process pool), each once per runner (in memory) and with an
    on-disk cache by content hash."""

    def __init__(self, spec, errors, plan, settings, law, cache_dir: Path | None, progress=None):
        self.spec, self.errors, self.plan, self.settings, self.law = spec, errors, plan, settings, law
        self.cache_dir = Path(cache_dir) if cache_dir else None
        self.progress = progress
        self.done = 0
        self.total = 0
        self.model_runs = 0
        # the runs made here, pickled (a caller gets its own copy, as from the disk): a model point asked for again
        # (the calibration's rigid run by the refinement, the fidelity re-measurement and the re-evaluation) is
        # not run again when there is no disk cache either
        self._memo: dict[str, bytes] = {}
        self._runs: dict[str, tuple] = {}  # the model runs other than the diagnosing model's, by key (in memory)
        self._process_warm = False
        from rvflex.spec import dumps_errors, dumps_spec

        # the plan as plain tuples: a pickled PlanRun carries its module path, and moving the class would void
        # every cache
        self._base = hashlib.sha256(pickle.dumps((CACHE_VERSION, dumps_spec(spec), dumps_errors(errors),
                                                  tuple(dc.astuple(p) for p in plan),
                                                  settings.positions_per_rev, settings.max_order,
                                                  settings.hysteresis_steps, repr(law)))).hexdigest()

    def key(self, active) -> str:
        # the model an effect blends in is part of what it means (no entry when there is none)
        desc = [(e.name, e.kind, tuple(p.name for p in e.params), tuple(np.round(np.asarray(x, float), 15)))
                + ((repr(e.options), getattr(e.alt_law, "__qualname__", None))
                   if e.options is not None or e.alt_law is not None else ()) for e, x in active]
        return hashlib.sha256((self._base + repr(desc)).encode()).hexdigest()[:24]

    def _load(self, key):
        if key in self._memo:
            return pickle.loads(self._memo[key])
        if self.cache_dir is None:
            return None
        for p in (self.cache_dir / f"{key}.pkl", self._failed_path(key)):
            if p.is_file():
                try:
                    data = p.read_bytes()
                    value = pickle.loads(data)
                except (OSError, pickle.UnpicklingError, EOFError, AttributeError):  # a damaged entry is recomputed
                    return None
                if value[0] is not None or p.name != f"{key}.pkl":
                    self._memo[key] = data  # asked for again, it is not read again
                    return value  # (a failure kept under the plain key was written by an older solver)
        return None

    def _failed_path(self, key) -> Path:
        return self.cache_dir / f"{key}.failed-{FAILURE_REVISION}.pkl"

    def _store(self, key, value) -> None:
        data = pickle.dumps(value)
        self._memo[key] = data
        if self.cache_dir is None:
            return
        # a unique temporary file per writer: side-by-side diagnoses sharing the cache (the self-check) may store
        # the same run at once, and forked workers can share an object's id
        write_atomic(self.cache_dir / f"{key}.pkl" if value[0] is not None else self._failed_path(key), data)

    def run(self, actives: list[tuple]) -> list[tuple]:
        """Evaluate each active set; returns (features | None, response | None, message) per set.

        An evaluation is made of model runs (:func:`~rvflex.diagnosis.replay.plan_evaluation`): the model
        with the effects applied, and for a fidelity effect the model it blends in. The pool runs each model
        run the batch needs once (the elastic discs' model of a point serves the contact-law form and the
        disc-flexibility share alike), the slow ones first, and an evaluation is combined here as soon as
        its runs are in. A run of the diagnosing model itself is the evaluation of its effects alone, kept as
        such (an evaluation's rigid run is not made again when that evaluation was made before)."""
        keys = [self.key(a) for a in actives]
        out: list = [self._load(k) for k in keys]
        first = {}  # a point asked for twice in one batch is evaluated once
        for i, o in enumerate(out):
            if o is None:
                first.setdefault(keys[i], i)
        todo = sorted(first.values())
        self.total += len(first) + sum(o is not None for o in out)
        self.done += sum(o is not None for o in out)
        if self.progress:
            self.progress(self.done, self.total)
        evals = {i: plan_evaluation(actives[i]) for i in todo}
        runs: dict[str, ModelRun] = {}
        got: dict[str, tuple] = {}  # run key → (response | None, message)
        waiting = {i: [self._run_key(r) for r in evals[i].runs] for i in todo}  # each evaluation's run keys
        for i in todo:
            for r, k in zip(evals[i].runs, waiting[i]):
                if k not in runs:
                    runs[k] = r
                    v = self._load_run(k, r)
                    if v is not None:
                        got[k] = v
        pending = {keys[i] for i in todo}

        def combined() -> None:  # every evaluation whose runs are all in
            for i in [i for i, ks in waiting.items() if all(k in got for k in ks)]:
                out[i] = self._combined(evals[i], [got[k] for k in waiting.pop(i)])
                self._finish(keys[i], out[i])

        new = sorted((k for k in runs if k not in got), key=lambda k: runs[k].plain)  # the slow (elastic) runs first
        # in a pool, a model run is split into parts (its plan runs, PLAN_RUNS_PER_PART), each built and run on
        # its own: the parts of a few unequal runs keep both workers busy where whole runs left one idle (measured:
        # the baseline's elastic run alone beside a rigid one, a calibration step's runs of 2 to 6 s)
        split = self.settings.workers > 1
        items = [(k, part) for k in new for part in (self._parts(runs[k]) if split else [None])]
        workers = min(self.settings.workers, len(items)) if split and len(items) > 1 else 0
        n_parts = Counter(k for k, _ in items)
        pieces: dict[str, list] = {k: [] for k in new}  # run key → its parts' (part, (response | None, message))

        def done(o: Outcome) -> None:  # a dying worker or an exception is a failed run, not a crash
            k, part = items[o.index]
            pieces[k].append((part or (), o.value if o.ok else (None, "worker died" if o.died else
                                                                f"{type(o.error).__name__}: {o.error}")))
            if len(pieces[k]) < n_parts[k]:
                return
            got[k] = _joined([v for _, v in sorted(pieces[k], key=lambda pv: pv[0])])
            self.model_runs += 1
            r = runs[k]
            if not r.plain:
                self._runs[k] = got[k]
            elif (full := self.key(r.active)) not in pending:  # the evaluation of its effects alone
                self._store(full, self._combined(plan_evaluation(r.active), [got[k]]))
            combined()

        combined()
        args = (self.spec, self.errors, self.plan, self.settings, self.law)
        if workers:
            self._warm_process()
            self._warm_fe([runs[k] for k in new])
        map_warm(_run_item, [(*args, runs[k], part) for k, part in items], workers, on_outcome=done)
        return [o if o is not None else self._load(k) for o, k in zip(out, keys)]

    def _parts(self, run: ModelRun) -> list[tuple[int, ...]]:
        """The plan runs of ``run`` in the parts a pool runs separately (:data:`PLAN_RUNS_PER_PART` groups each).
        Plan runs under the same conditions (a map's other speeds; its other temperatures when no effect of the
        run reads the temperature) form one group, so that one part solves them once
        (:func:`~rvflex.diagnosis.replay.run_model`)."""
        per = PLAN_RUNS_PER_PART["rigid" if run.options == ModelOptions.rigid() else "elastic"]
        reads_temperature = any(e.run_fields for e, _ in run.active)
        groups: dict[tuple, list[int]] = {}
        for i, p in enumerate(self.plan):
            same = (p.kind, p.direction, p.load_Nm, p.torque_path_Nm, p.torque_eff_Nm,
                    p.temperature_C if reads_temperature else None)
            groups.setdefault(same, []).append(i)
        g = list(groups.values())
        return [tuple(sorted(i for grp in g[k:k + per] for i in grp)) for k in range(0, len(g), per)]

    def _run_key(self, run: ModelRun) -> str:
        if run.plain:
            return self.key(run.active)
        return hashlib.sha256((self._base + "run" + repr(run.key())).encode()).hexdigest()[:24]

    def _load_run(self, key: str, run: ModelRun) -> tuple | None:
        """A model run made before: a plain one as its evaluation (in memory or on disk), another from
        memory."""
        if not run.plain:
            return self._runs.get(key)
        v = self._load(key)
        return None if v is None else (v[1], v[2])

    def _combined(self, ev, values: list[tuple]) -> tuple:
        """(features, response, "") of the evaluation ``ev`` from its runs' (response, message), or the
        first failure's (None, None, message)."""
        for resp, msg in values:
            if resp is None:
                return None, None, msg
        try:
            resp = combine(ev, [v[0] for v in values], self.plan, self.settings, self.spec)
            return features(resp, self.plan, self.settings)[0], resp, ""
        except (ValueError, ArithmeticError) as err:  # a response the features cannot read is a failed evaluation
            return None, None, f"{type(err).__name__}: {err}"

    def _warm_process(self) -> None:
        """Build the unit's rigid model here once, before the first pool forks, and take a few steps with it:
        the disc profiles' checks and contact zones are kept per curve in the process
        (:class:`~rvflex.geometry.profile.CurveKey`), and the compiled step's machine code, once loaded from
        numba's disk cache, stays in the process; so every worker forked later builds the same discs without
        checking them again (a tenth of a rigid run) and steps without loading the compiled code (0.1 s, ten
        times a rigid part's run), in every worker of every batch otherwise."""
        if self._process_warm:
            return
        self._process_warm = True
        from rvflex.model import build_reducer
        from rvflex.solve import quasi_static, torque_stepping

        try:
            model = build_reducer(self.spec, self.errors, ModelOptions.rigid())
            load = 0.1 * self.spec.rated_torque_Nm
            quasi_static(model, np.linspace(0.0, 0.01, 4), load, fail_fast=True, skip_unsolved=True,
                         contact_states=False)
            torque_stepping(model, np.array([0.0, load, 0.0]), skip_unsolved=True)
        except Exception:  # noqa: BLE001 -- the runs themselves report what fails
            pass

    def _warm_fe(self, runs: list[ModelRun]) -> None:
        """Build here, before the pool forks, every disc reduction the pool's runs need (from the
        disk cache, or meshed here), once, instead of in each worker that needs it. (A worker
        never meshes in its own process anyway: OpenCascade's thread pool, copied by the fork
        without its threads, would hang it; :mod:`rvflex.fe.isolated` builds there in a fresh
        interpreter.)"""
        import dataclasses

        from rvflex.fe.reduce import reduce_part
        from rvflex.model import disc_mesh_spec

        seen = set()
        for run in runs:
            if not run.options.flexible_discs_on:
                continue
            spec = self.spec
            for e, x in run.active:
                if e.kind == "model" and not e.per_run:  # what can change the disc's geometry or material
                    spec, _ = e.apply_to(spec, self.errors, np.asarray(x, float), self.plan[0])
            spec = disc_mesh_spec(spec, self.spec.cycloid.modification)  # (as run_model meshes it)
            key = (repr(spec), repr(run.options.discs))
            if key not in seen:
                seen.add(key)
                try:
                    reduce_part(spec, "disc", **dataclasses.asdict(run.options.discs))
                except Exception:  # noqa: BLE001 -- the run itself reports what fails
                    pass

    def _finish(self, key, value) -> None:
        self._store(key, value)
        self.done += 1
        if self.progress:
            self.progress(self.done, self.total)


# ----------------------------------------------------------------------------- fitted candidates

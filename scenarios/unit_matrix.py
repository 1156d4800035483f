"""The unit matrix: every unit at every fidelity (the computation behind ``rvflex units``).

Each cell is one unit × one fidelity: the model is built once (FE reductions from the cache
or computed, the build time says which) and runs the two catalogue tests on it — loaded TE
at rated torque over one output revolution, and the lost-motion torque cycle ±rated. The
``"spatial"`` cells build every part a rigid body free out of its plane
(:meth:`~rvflex.options.ModelOptions.spatial_rigid`); a spec without the geometry that needs
(main bearing pair, crank support span) gets a row saying so, not a failure. The
table (:func:`markdown`) is docs/units.md; ``rvflex units --markdown docs/units.md``
regenerates it. ``coarse=True`` swaps the FE reductions for the quick ones the tests use
(8 mm linear tets), for CI.

Run as a script for the full matrix::

    python -m rvflex.scenarios.unit_matrix docs/units.md
"""

from __future__ import annotations

import dataclasses
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from rvflex import catalog
from rvflex.api import RunError, one_line
from rvflex.choices import Fidelity, check_choice, choices
from rvflex.model import build_reducer
from rvflex.options import ModelOptions
from rvflex.scenarios.loaded_te import LoadedTE
from rvflex.scenarios.lost_motion import LostMotion
from rvflex.spec import ReducerSpec, SpecError

__all__ = ["COARSE_CARRIER", "COARSE_DISC", "COARSE_HOUSING", "FIDELITIES", "Cell", "markdown", "options_for", "run_cell",
           "run_matrix"]

FIDELITIES: tuple[Fidelity, ...] = ("rigid", "flexible", "flexible-carrier", "spatial")
"""The matrix's default fidelities; ``"flexible-all"`` (with the FE pin housing) runs when asked
(``--fidelity``), not by default: it adds a housing reduction per unit."""
COARSE_DISC = {"maxh_m": 8e-3, "n_modes": 12, "mesh_order": 1, "attach_per_tooth": 0}
"""The tests' quick disc reduction (tests/conftest.py COARSE_DISC)."""
COARSE_CARRIER = {"maxh_m": 8e-3, "n_modes": 6, "mesh_order": 1}
"""The tests' quick carrier reduction (tests/test_flexible_carrier.py)."""
COARSE_HOUSING = {"maxh_m": 8e-3, "n_modes": 8, "mesh_order": 1}
"""The tests' quick housing reduction (tests/test_flexible_housing.py)."""


@dataclass(frozen=True)
class Cell:
    """One unit at one fidelity (SI inside; the report units are in the names).

    ``error`` is the one-line failure when the cell did not run (then the figures are NaN)."""

    unit: str
    fidelity: Fidelity
    ratio: float
    rated_torque_Nm: float
    cranks: int
    te_pp_arcsec: float = float("nan")
    windup_arcsec: float = float("nan")
    lost_motion_arcmin: float = float("nan")
    stiffness_Nm_per_arcmin: float = float("nan")
    build_s: float = float("nan")
    te_s: float = float("nan")
    lost_motion_s: float = float("nan")
    reductions_cached: bool = True
    moment_Nm: float = float("nan")
    te_pp_moment_arcsec: float = float("nan")
    windup_moment_arcsec: float = float("nan")
    lost_motion_moment_arcmin: float = float("nan")
    face_load_ratio: float = float("nan")
    error: str = ""
    not_built: str = ""  # why the spec cannot be built at this fidelity (not a failure: it lacks the data)


def options_for(fidelity: Fidelity, *, coarse: bool = False) -> ModelOptions:
    """The ModelOptions preset of ``fidelity``; ``coarse`` with the tests' quick reductions."""
    check_choice("fidelity", fidelity, Fidelity)
    if fidelity == "rigid":
        return ModelOptions.rigid()
    if fidelity == "spatial":
        return ModelOptions.spatial_rigid()
    if fidelity == "flexible":
        opts = ModelOptions.flexible_discs()
        return opts.with_fe("discs", **COARSE_DISC) if coarse else opts
    if fidelity == "flexible-carrier":
        opts = ModelOptions.flexible_discs_and_carrier()
        return opts.with_fe("discs", **COARSE_DISC).with_fe("carrier", **COARSE_CARRIER) if coarse else opts
    opts = ModelOptions.flexible_all()
    if not coarse:
        return opts
    return opts.with_fe("discs", **COARSE_DISC).with_fe("carrier", **COARSE_CARRIER).with_fe("housing", **COARSE_HOUSING)


def run_cell(spec: ReducerSpec, fidelity: Fidelity, *, positions: int = 2048, steps: int = 200,
             coarse: bool = False, moment_fraction: float = 0.0) -> Cell:
    """Build ``spec`` at ``fidelity`` and run loaded TE (rated torque, one output revolution,
    ``positions`` positions) and the lost-motion cycle (``steps`` torque steps) on it.

    With ``moment_fraction`` > 0 both run again under that fraction of the spec's allowable tilting moment: on a
    second planar model whose carrier the moment tilts on its main bearing pair alone (:mod:`rvflex.tilt`), the pin
    contact in :data:`~rvflex.tilt.MOMENT_SLICES` slices along the face width; a ``"spatial"`` cell's own model
    carries the moment on its output (solved with the gear train). Recorded: the TE, wind-up and lost motion under
    the moment and the largest line load at the discs' faces over the largest mean over the face width
    (``face_load_ratio``); a spec without a main bearing pair or an allowable moment leaves them NaN.

    A spec the spatial model cannot be built from (:meth:`~rvflex.spec.ReducerSpec.check_spatial`) gives a
    ``"spatial"`` cell with ``not_built`` saying what it lacks.

    A failure (a reduction, a step that does not converge) is recorded in ``Cell.error`` as
    :class:`rvflex.RunError` words it, so one bad cell does not stop the matrix.
    """
    import rvflex

    base = Cell(spec.name, fidelity, spec.nominal_ratio, spec.rated_torque_Nm, spec.cranks.count)
    opts = options_for(fidelity, coarse=coarse)
    if opts.spatial is not None:
        try:
            spec.check_spatial("the spatial fidelity")
        except SpecError as exc:
            return dataclasses.replace(base, not_built=str(exc))
    te = LoadedTE(spec, positions_per_rev=positions, options=opts)
    lm = LostMotion(spec, steps=steps, options=opts)
    t0 = time.perf_counter()
    try:
        model = build_reducer(spec, None, opts)
    except Exception as exc:  # noqa: BLE001 -- recorded per cell, the matrix goes on
        return dataclasses.replace(base, error=f"model build: {one_line(exc)}")
    t1 = time.perf_counter()
    cached = all(r.meta.get("cached", False) for r in (*model.reduced_discs, model.reduced_carrier,
                                                       model.reduced_housing) if r is not None)
    base = dataclasses.replace(base, build_s=t1 - t0, reductions_cached=cached)
    try:
        r = rvflex.run(te, model=model)
        t2 = time.perf_counter()
        base = dataclasses.replace(base, te_pp_arcsec=r.metrics.te_pp_arcsec, windup_arcsec=r.metrics.mean_windup_arcsec,
                                   te_s=t2 - t1)
        h = rvflex.run(lm, model=model)
        base = dataclasses.replace(base, lost_motion_arcmin=h.metrics.lost_motion_arcmin,
                                   stiffness_Nm_per_arcmin=h.metrics.torsional_stiffness_Nm_per_arcmin,
                                   lost_motion_s=time.perf_counter() - t2)
    except RunError as exc:
        return dataclasses.replace(base, error=exc.failure)
    if moment_fraction > 0.0:
        return _under_moment(base, spec, opts, positions, steps, moment_fraction)
    return base


def _under_moment(base: Cell, spec: ReducerSpec, opts: ModelOptions, positions: int, steps: int,
                  fraction: float) -> Cell:
    """``base`` with the loaded TE and the lost-motion cycle under ``fraction`` of the allowable moment."""
    import rvflex
    from rvflex.tilt import MOMENT_SLICES, OutputLoad

    if spec.allowable_moment_Nm is None or spec.bearings.main_pair is None:
        return base  # nothing to tilt it on: the columns stay empty ("—")
    load = OutputLoad(moment_Nm=fraction * spec.allowable_moment_Nm)
    # planar: sliced, the carrier's tilt from its pair alone; spatial: the cell's own model, the moment on its output
    sliced = opts if opts.spatial is not None else dataclasses.replace(opts, face_slices=MOMENT_SLICES)
    te = LoadedTE(spec, positions_per_rev=positions, options=sliced, output_load=load)
    try:
        model = build_reducer(spec, te.model_errors, sliced)
        r = rvflex.run(te, model=model)
        h = rvflex.run(LostMotion(spec, steps=steps, options=sliced, output_load=load), model=model)
    except RunError as exc:
        return dataclasses.replace(base, moment_Nm=load.moment_Nm, error=f"under a moment: {exc.failure}")
    except Exception as exc:  # noqa: BLE001 -- recorded per cell, the matrix goes on
        return dataclasses.replace(base, moment_Nm=load.moment_Nm, error=f"under a moment: {one_line(exc)}")
    loads = r.pin_end_loads()
    return dataclasses.replace(base, moment_Nm=load.moment_Nm, te_pp_moment_arcsec=r.metrics.te_pp_arcsec,
                               windup_moment_arcsec=r.metrics.mean_windup_arcsec,
                               lost_motion_moment_arcmin=h.metrics.lost_motion_arcmin,
                               face_load_ratio=float(loads["end_line_load_N_m"].max() / loads["mid_line_load_N_m"].max()))


def run_matrix(units=None, fidelities=FIDELITIES, *, positions: int = 2048, steps: int = 200, coarse: bool = False,
               progress=None, moment_fraction: float = 0.0) -> list[Cell]:
    """:func:`run_cell` for every unit (catalogue names or spec TOML paths; default every built-in
    unit) at every fidelity, in order. ``progress(cell)`` is called after each cell."""
    if not 0.0 <= moment_fraction <= 1.0:
        raise SpecError("moment_fraction", moment_fraction, "must lie in [0, 1] (of each unit's allowable moment)")
    cells = []
    for u in units or catalog.names():
        spec = catalog.resolve(str(u))
        for f in fidelities:
            cells.append(run_cell(spec, f, positions=positions, steps=steps, coarse=coarse,
                                  moment_fraction=moment_fraction))
            if progress is not None:
                progress(cells[-1])
    return cells


def _f(x: float, fmt: str) -> str:
    return "—" if x != x else format(x, fmt)


def markdown(cells: list[Cell], *, command: str, positions: int, steps: int, coarse: bool) -> str:
    """The matrix as the table of docs/units.md (with the command that made it)."""
    moment = any(c.moment_Nm == c.moment_Nm for c in cells)
    extra_head = (" moment (N·m) | TE p-p under it (″) | wind-up under it (″) | lost motion under it (′) | "
                  "face / mean line load |") if moment else ""
    lines = [f"| unit | ratio | cranks | fidelity | TE p-p (″) | wind-up (″) | lost motion (′) | stiffness (N·m/′) "
             f"| build (s) | TE {positions} pos. (s) | lost motion {steps} steps (s) |" + extra_head,
             "|---|---|---|---|---|---|---|---|---|---|---|" + ("---|" * 5 if moment else "")]
    for c in cells:
        build = _f(c.build_s, ".1f") + ("" if c.reductions_cached or c.fidelity == "rigid" else " (reduced)")
        row = (f"| {c.unit} | {c.ratio:g} | {c.cranks} | {c.fidelity} | {_f(c.te_pp_arcsec, '.2f')} | "
               f"{_f(c.windup_arcsec, '.1f')} | {_f(c.lost_motion_arcmin, '.3f')} | {_f(c.stiffness_Nm_per_arcmin, '.0f')} | "
               f"{build} | {_f(c.te_s, '.1f')} | {_f(c.lost_motion_s, '.1f')} |")
        if moment:
            row += (f" {_f(c.moment_Nm, '.0f')} | {_f(c.te_pp_moment_arcsec, '.2f')} | {_f(c.windup_moment_arcsec, '.1f')} | "
                    f"{_f(c.lost_motion_moment_arcmin, '.3f')} | {_f(c.face_load_ratio, '.2f')} |")
        lines.append(row + (f" failed: {c.error}" if c.error else f" not built: {c.not_built}" if c.not_built else ""))
    fe = "the tests' coarse reductions (8 mm linear tets)" if coarse else "the presets' reductions (6 mm quadratic tets)"
    head = (f"<!-- generated by `{command}`; do not edit the table by hand -->\n\n"
            f"Loaded TE at rated torque over one output revolution ({positions} positions) and the lost-motion "
            f"cycle 0 → +T_r → −T_r → 0 ({steps} torque steps) on one model per cell, FE parts from {fe}. "
            f"Wind-up is the mean TE (negative: the output lags). \"build\" includes the FE reductions; "
            f"\"(reduced)\" marks a cell that computed them (otherwise they came from the cache)."
            + " \"spatial\": every part a rigid body free out of its plane, the pin contact in slices along the face "
              "width ([spatial](spatial.md))."
            + (" Under a moment: the same runs on a second model, the carrier tilted on its main bearing pair by that "
               "moment and the pin contact in slices along the face width; a spatial cell carries the moment on its own "
               "model's output, solved with the gear train; the last column is "
               "the largest line load at the discs' faces over the largest mean over the face width; \"—\": the spec gives no "
               "main bearing pair." if moment else "")
            + "\n\n")
    return head + "\n".join(lines) + "\n"


if __name__ == "__main__":  # python -m rvflex.scenarios.unit_matrix [OUT.md]
    cells = run_matrix(progress=lambda c: print(c, file=sys.stderr, flush=True))
    text = markdown(cells, command="python -m rvflex.scenarios.unit_matrix", positions=2048, steps=200, coarse=False)
    if len(sys.argv) > 1:
        Path(sys.argv[1]).write_text(text, encoding="utf-8")
    print(text)


def register(sub) -> None:
    """Add ``rvflex units`` to the ``rvflex`` parser."""
    p = sub.add_parser("units", help="the unit matrix: every unit at every fidelity (loaded TE, lost motion)",
                       description="Build each unit at each fidelity once and run loaded TE at rated torque (one "
                                   "output revolution) and the lost-motion cycle on it; print the table of "
                                   "docs/units.md (TE peak-to-peak, wind-up, lost motion, stiffness, wall times). "
                                   "Exit code 1 when a cell failed (its row says what failed).")
    p.add_argument("--units", nargs="+", metavar="UNIT",
                   help=f"catalogue names or spec TOML paths (default every built-in unit: {', '.join(catalog.names())})")
    p.add_argument("--fidelity", nargs="+", choices=choices(Fidelity), default=list(FIDELITIES),
                   help=f"fidelities (default {', '.join(FIDELITIES)})")
    p.add_argument("--positions", type=int, default=2048, help="loaded-TE positions per output revolution (default 2048)")
    p.add_argument("--steps", type=int, default=200, help="lost-motion torque steps (default 200)")
    p.add_argument("--coarse", action="store_true",
                   help="the tests' quick FE reductions (8 mm linear tets) instead of the presets' (for CI)")
    p.add_argument("--moment-fraction", type=float, default=0.0,
                   help="also run each cell under this fraction of the unit's allowable tilting moment, the pin contact "
                        "in slices along the face width (default 0: not)")
    p.add_argument("--markdown", help="write the table (with the command that made it) to this file, e.g. docs/units.md")
    p.add_argument("--json", help="write the cells as JSON to this path")
    p.set_defaults(func=_cmd_units, flags={"moment_fraction": "--moment-fraction"})


def _cmd_units(args) -> int:
    from rvflex.io import write_json, write_text

    cells = run_matrix(args.units, tuple(args.fidelity), positions=args.positions, steps=args.steps,
                       coarse=args.coarse, moment_fraction=args.moment_fraction, progress=lambda c: print(f"{c.unit} {c.fidelity}: "
                                                                    f"{c.error or c.not_built or 'done'}", file=sys.stderr, flush=True))
    words = ["rvflex units"]
    if args.units:
        words.append("--units " + " ".join(args.units))
    if tuple(args.fidelity) != FIDELITIES:
        words.append("--fidelity " + " ".join(args.fidelity))
    words += [f"--positions {args.positions}", f"--steps {args.steps}"] + (["--coarse"] if args.coarse else [])
    words += [f"--moment-fraction {args.moment_fraction:g}"] if args.moment_fraction else []
    if args.markdown:
        words.append(f"--markdown {args.markdown}")
    text = markdown(cells, command=" ".join(words), positions=args.positions, steps=args.steps, coarse=args.coarse)
    print(text)
    if args.markdown:
        write_text(Path(args.markdown), _splice(Path(args.markdown), text))
    if args.json:
        write_json(Path(args.json), [dataclasses.asdict(c) for c in cells])
    return 1 if any(c.error for c in cells) else 0


BEGIN, END = "<!-- unit matrix: begin -->", "<!-- unit matrix: end -->"


def _splice(path: Path, table: str) -> str:
    """The file's text with the part between the unit-matrix markers replaced by ``table`` (the
    whole file when it has no markers), so the prose around the table survives regeneration."""
    block = f"{BEGIN}\n{table}{END}\n"
    if not path.is_file():
        return block
    old = path.read_text(encoding="utf-8")
    if BEGIN in old and END in old:
        return old[:old.index(BEGIN)] + block + old[old.index(END) + len(END) + 1:]
    return old.rstrip("\n") + "\n\n" + block

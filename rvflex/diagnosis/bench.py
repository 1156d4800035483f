"""Bench data I/O (``/work/shared/bench-data-format.md``): a folder with ``bench.toml`` and one
CSV per run.

:func:`read_bench` validates everything before it returns: a missing file, a missing or
misspelled column, a non-numeric cell, NaN/inf, non-monotonic time, fewer samples than one
output revolution needs, a reducer not in the catalogue, or a load beyond the reducer's
momentary maximum each raise one :class:`BenchError` naming the file, row or key.
:func:`write_bench` writes a dataset through temporary names, so nothing is left half-written.
"""

from __future__ import annotations

import csv
import difflib
import math
import os
import tempfile
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rvflex.choices import RunKind, choices
from rvflex.diagnosis.errors import BenchError
from rvflex.diagnosis.measured import TEWindow, te_window
from rvflex.spec import ReducerSpec, SpecError

__all__ = [
    "HYST_COLUMNS",
    "TE_ANGLE_COLUMN",
    "MIN_HYSTERESIS_SAMPLES",
    "MIN_SAMPLES_PER_REV",
    "TE_COLUMNS",
    "BenchDataset",
    "BenchError",
    "BenchRun",
    "read_bench",
    "write_bench",
]

TE_COLUMNS = ("time_s", "theta_in_rad", "theta_out_rad")
TE_OPTIONAL = ("torque_Nm",)
TE_ANGLE_COLUMN = "output_angle_deg"  # the second TE form: output angle (°) and TE (″ or °)
HYST_COLUMNS = ("time_s", "torque_Nm", "theta_out_rad")
MIN_SAMPLES_PER_REV = 256  # the order decomposition up to ≥ 3·z_b = 120 needs ≥ 2·128 samples per revolution
MIN_HYSTERESIS_SAMPLES = 40  # a 0 → +T → −T → 0 cycle sampled at fewer points has no usable branches
RUN_KINDS = choices(RunKind)
DIRECTIONS = ("forward", "reverse")


@dataclass(frozen=True, eq=False)
class BenchRun:
    """One bench run (SI): a loaded-TE run at constant speed or a torque-cycle (hysteresis) run.

    Attributes
    ----------
    file : str
        CSV file name, relative to the dataset folder.
    kind : {"te", "hysteresis"}
    time_s : ndarray
        Sample times (s), increasing (empty for a TE run given as output angle and TE).
    theta_in_rad, theta_out_rad : ndarray
        Unwrapped encoder angles (rad); empty for hysteresis runs and for TE runs given as
        output angle and TE.
    torque_Nm : ndarray
        Output torque (N·m) for hysteresis runs (positive forward); optional for TE runs.
    direction : str
        "forward" or "reverse" (TE runs).
    load_Nm : float
        Output load magnitude opposing the motion (N·m, TE runs).
    speed_out_rpm : float
        Output speed (rpm, TE runs).
    torque_max_Nm : float
        Torque amplitude of the cycle (N·m, hysteresis runs).
    temperature_C : float
        Temperature (°C), NaN when not given.
    extra : dict
        Unknown keys of the run table, kept and ignored.
    form : {"encoder", "angle"}
        TE runs: raw encoder angles (``time_s, theta_in_rad, theta_out_rad``) or output angle
        and TE (``output_angle_deg, te_arcsec`` or ``te_deg``).
    position_rad, te_rad : ndarray
        TE runs: output position p (rad, forward coordinate: θ_in/i for encoder data) and
        TE = θ_out − θ_in/i (rad) per sample, in file order. The reader fills them; a run made
        in code in the encoder form may leave them empty (they follow from the angles).
    te_unit : {"arcsec", "deg"}
        Unit of the TE column of the angle form (what the writer writes).
    window : TEWindow or None
        TE runs read from disk: the analysed whole revolutions and their coverage.
    """

    file: str
    kind: RunKind
    time_s: np.ndarray
    theta_in_rad: np.ndarray
    theta_out_rad: np.ndarray
    torque_Nm: np.ndarray
    direction: str = "forward"
    load_Nm: float = 0.0
    speed_out_rpm: float = 0.0
    torque_max_Nm: float = 0.0
    temperature_C: float = math.nan
    extra: dict = field(default_factory=dict)
    form: str = "encoder"
    position_rad: np.ndarray = field(default_factory=lambda: np.empty(0))
    te_rad: np.ndarray = field(default_factory=lambda: np.empty(0))
    te_unit: str = "arcsec"
    window: TEWindow | None = None

    @property
    def label(self) -> str:
        """Short human label: ``te forward 412 N·m`` or ``hysteresis ±412 N·m``, with
        `` at 40 °C`` when the run records its temperature."""
        at = f" at {self.temperature_C:g} °C" if math.isfinite(self.temperature_C) else ""
        if self.kind == "te":
            return f"te {self.direction} {self.load_Nm:g} N·m{at}"
        return f"hysteresis ±{self.torque_max_Nm:g} N·m{at}"

    def te_samples(self, ratio: float) -> tuple[np.ndarray, np.ndarray]:
        """(position p in rad, TE in rad) of a TE run, from the angle columns or the encoders
        (p = θ_in/i, TE = θ_out − θ_in/i with the nominal ratio ``ratio``)."""
        if len(self.position_rad):
            return self.position_rad, self.te_rad
        p = np.asarray(self.theta_in_rad, float) / ratio
        return p, np.asarray(self.theta_out_rad, float) - p


@dataclass(frozen=True, eq=False)
class BenchDataset:
    """A bench dataset: the reducer (catalogue name or spec file) and its runs."""

    reducer: ReducerSpec
    reducer_source: str
    runs: tuple[BenchRun, ...]
    path: str = ""
    extra: dict = field(default_factory=dict)


# ----------------------------------------------------------------------------- reading

def _need(table: dict, key: str, where: str):
    if key not in table:
        close = difflib.get_close_matches(key, list(table), n=1)
        hint = f" (found '{close[0]}': misspelled?)" if close else ""
        raise BenchError(where, f"missing required key '{key}'{hint}")
    return table[key]


def _number(table: dict, key: str, where: str, *, positive: bool = False, default: float | None = None) -> float:
    if key not in table and default is not None:
        return default
    v = _need(table, key, where)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise BenchError(f"{where}, key '{key}'", f"must be a finite number, found {v!r}")
    if positive and not v > 0:
        raise BenchError(f"{where}, key '{key}'", f"must be positive, found {v!r}")
    return float(v)


def _read_rows(path: Path) -> tuple[list[str], list[list[str]]]:
    """Header (stripped names) and data rows of a CSV file."""
    if not path.is_file():
        raise BenchError(str(path), "file not found")
    with path.open(newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    if not rows:
        raise BenchError(path.name, "empty file (a header row is required)")
    return [h.strip() for h in rows[0]], rows[1:]


def _read_csv(path: Path, required: tuple[str, ...], optional: tuple[str, ...],
              table: tuple[list[str], list[list[str]]] | None = None) -> dict[str, np.ndarray]:
    name = path.name
    header, rows = table or _read_rows(path)
    for col in required:
        if col not in header:
            close = difflib.get_close_matches(col, header, n=1)
            hint = f" (found '{close[0]}': misspelled?)" if close else ""
            raise BenchError(f"{name}, header", f"missing column '{col}'{hint}; required: {', '.join(required)}")
    use = [c for c in required + optional if c in header]
    idx = {c: header.index(c) for c in use}
    data = {c: np.empty(len(rows)) for c in use}
    for r, row in enumerate(rows):
        line = r + 2  # 1-based file line; the header is line 1
        if len(row) != len(header):
            raise BenchError(f"{name}, row {line}", f"has {len(row)} cells, the header has {len(header)}")
        for c in use:
            cell = row[idx[c]].strip()
            try:
                v = float(cell)
            except ValueError:
                raise BenchError(f"{name}, row {line}, column '{c}'", f"not a number: {cell!r}") from None
            if not math.isfinite(v):
                raise BenchError(f"{name}, row {line}, column '{c}'", f"must be finite, found {cell!r}")
            data[c][r] = v
    if "time_s" in data:
        t = data["time_s"]
        bad = np.nonzero(np.diff(t) <= 0)[0]
        if len(bad):
            line = int(bad[0]) + 3
            raise BenchError(f"{name}, row {line}, column 'time_s'",
                             f"time must increase strictly (row {line - 1}: {t[bad[0]]!r}, row {line}: {t[bad[0] + 1]!r})")
    return data


SPIKE_MIN_ARCSEC = 60.0  # a TE sample this far off both neighbours, the same way, is an outlier: no mesh turns so
SPIKE_FACTOR = 50.0  # fast between two log points (and at least this many typical sample-to-sample steps)


def _spike_check(te_arcsec: np.ndarray, name: str, column: str) -> None:
    """Refuse a single-sample spike: a TE sample that lies more than :data:`SPIKE_MIN_ARCSEC` (and
    :data:`SPIKE_FACTOR` typical steps) off both its neighbours, on the same side, naming its row (data row k is
    file row k + 2)."""
    te = np.asarray(te_arcsec, float)
    if len(te) < 5:
        return
    d = np.diff(te)
    limit = max(SPIKE_MIN_ARCSEC, SPIKE_FACTOR * float(np.median(np.abs(d))))
    left, right = d[:-1], -d[1:]  # sample k minus its left and its right neighbour
    bad = np.nonzero((np.sign(left) == np.sign(right)) & (np.minimum(np.abs(left), np.abs(right)) > limit))[0]
    if len(bad):
        k = int(bad[0]) + 1
        raise BenchError(f"{name}, row {k + 2}, column '{column}'",
                         f"an outlier: its TE is {min(abs(left[k - 1]), abs(right[k - 1])):.4g}″ off both neighbouring "
                         f"rows ({k + 1} and {k + 3}), a single-sample spike no mesh makes between two samples; "
                         f"remove or re-log the row")


def _angle_form(path: Path, table, direction: str, where: str) -> dict[str, tuple[np.ndarray, np.ndarray, str]]:
    """TE given as output angle and TE: ``{direction: (position_rad, te_rad, unit)}`` for one
    direction (``te_arcsec``/``te_deg``) or both (``te_forward_*`` and ``te_reverse_*``,
    ``direction = "both"``). Angles must run one way along the file; a repeated angle must repeat
    its TE (it is dropped); TE in degrees beyond 1° peak-to-peak in a revolution is refused as
    arcseconds written as degrees."""
    name = path.name
    header = table[0]
    dirs = ("forward", "reverse") if direction == "both" else (direction,)
    cols, units = {}, {}
    for d in dirs:
        names = ([f"te_{d}_arcsec", f"te_{d}_deg"] if direction == "both" else ["te_arcsec", "te_deg"])
        found = [c for c in names if c in header]
        if len(found) != 1:
            close = difflib.get_close_matches(names[0], header, n=1)
            hint = f" (found '{close[0]}': misspelled?)" if close and not found else ""
            what = "both" if found else "neither"
            raise BenchError(f"{name}, header", f"{what} of '{names[0]}' and '{names[1]}'{hint}: a TE run given as output "
                                                f"angle needs exactly one of them"
                                                + (" (direction = \"both\" in bench.toml)" if direction == "both" else ""))
        cols[d], units[d] = found[0], found[0].rsplit("_", 1)[1]
    data = _read_csv(path, (TE_ANGLE_COLUMN, *cols.values()), (), table)
    ang = data[TE_ANGLE_COLUMN]
    step = np.diff(ang)
    up = np.sum(step > 0) >= np.sum(step < 0)
    back = np.nonzero(step < 0 if up else step > 0)[0]
    if len(back):
        line = int(back[0]) + 3
        raise BenchError(f"{name}, row {line}, column '{TE_ANGLE_COLUMN}'",
                         f"output angles must {'increase' if up else 'decrease'} along the file (row {line - 1}: "
                         f"{ang[back[0]]!r}, row {line}: {ang[back[0] + 1]!r}); write several revolutions unwrapped "
                         f"(0 … 720°), not restarting at 0°")
    out = {}
    keep = np.r_[True, step != 0]
    for d in dirs:
        te = data[cols[d]]
        _spike_check(te * (1.0 if units[d] == "arcsec" else 3600.0), name, cols[d])
        rep = np.nonzero(step == 0)[0]
        for i in rep:
            if abs(te[i + 1] - te[i]) > 0.05 * (1.0 if units[d] == "arcsec" else 1 / 3600):
                raise BenchError(f"{name}, rows {i + 2} and {i + 3}",
                                 f"the output angle {ang[i]!r}° appears twice with different TE ({te[i]!r} and "
                                 f"{te[i + 1]!r} in '{cols[d]}')")
        scale = math.pi / 648000.0 if units[d] == "arcsec" else math.pi / 180.0
        pos = np.radians(ang[keep])
        out[d] = (pos, te[keep] * scale, units[d])
    return out


def _te_run(rt: dict, rwhere: str, folder: Path, spec: ReducerSpec, temp: float, known: set) -> list[BenchRun]:
    """The TE run(s) of one ``[[run]]`` table: one, or two for an angle-form file with both directions."""
    fname = rt["file"]
    path = folder / fname
    direction = _need(rt, "direction", rwhere)
    load = _number(rt, "load_Nm", rwhere)
    if not 0.0 <= load <= spec.momentary_max_torque_Nm:
        raise BenchError(f"{rwhere}, key 'load_Nm'",
                         f"{load:g} N·m lies outside [0, {spec.momentary_max_torque_Nm:g}] N·m, the momentary "
                         f"maximum of {spec.name}: the model cannot reproduce this run")
    speed = _number(rt, "speed_out_rpm", rwhere, positive=True)
    table = _read_rows(path)
    extra = {x: v for x, v in rt.items() if x not in known | {"direction", "load_Nm", "speed_out_rpm"}}
    ratio = spec.nominal_ratio
    if TE_ANGLE_COLUMN in table[0]:
        if direction not in DIRECTIONS + ("both",):
            raise BenchError(f"{rwhere}, key 'direction'",
                             f"must be 'forward', 'reverse' or 'both', found {direction!r}")
        runs = []
        for d, (pos, te, unit) in _angle_form(path, table, direction, rwhere).items():
            win = _checked_window(pos, fname, len(table[1]))
            if unit == "deg":
                w = te[win.index]
                pp = float(np.degrees(w.max() - w.min()))
                if pp > 1.0:
                    raise BenchError(f"{fname}, column 'te_{d + '_' if direction == 'both' else ''}deg'",
                                     f"TE peak-to-peak {pp:.4g}° within one revolution: more than 1° is no "
                                     f"transmission error (arcseconds written as degrees? use 'te_arcsec')")
            runs.append(BenchRun(fname, "te", np.empty(0), np.empty(0), np.empty(0), np.empty(0), direction=d,
                                 load_Nm=load, speed_out_rpm=speed, temperature_C=temp, extra=extra, form="angle",
                                 position_rad=pos, te_rad=te, te_unit=unit, window=win))
        return runs
    if direction not in DIRECTIONS:
        raise BenchError(f"{rwhere}, key 'direction'", f"must be 'forward' or 'reverse', found {direction!r}")
    if not any(c in table[0] for c in TE_COLUMNS[1:]) and any(c.startswith("te_") for c in table[0]):
        raise BenchError(f"{fname}, header", f"TE columns without '{TE_ANGLE_COLUMN}': the angle form needs "
                                             f"'{TE_ANGLE_COLUMN}' and 'te_arcsec' (or 'te_deg')")
    data = _read_csv(path, TE_COLUMNS, TE_OPTIONAL, table)
    th_in = data["theta_in_rad"]
    sign = 1.0 if direction == "forward" else -1.0
    if not sign * (th_in[-1] - th_in[0]) > 0:
        raise BenchError(f"{fname}, column 'theta_in_rad'",
                         f"the input does not turn {direction} (net {th_in[-1] - th_in[0]:+.4g} rad)")
    pos = th_in / ratio
    _spike_check((data["theta_out_rad"] - pos) * 648000.0 / math.pi, fname, "theta_out_rad")
    win = _checked_window(pos, fname, len(th_in))
    return [BenchRun(fname, "te", data["time_s"], th_in, data["theta_out_rad"], data.get("torque_Nm", np.empty(0)),
                     direction=direction, load_Nm=load, speed_out_rpm=speed, temperature_C=temp, extra=extra,
                     form="encoder", position_rad=pos, te_rad=data["theta_out_rad"] - pos, window=win)]


def _checked_window(pos: np.ndarray, fname: str, n: int) -> TEWindow:
    """The analysed window of a TE run, refused with fewer than MIN_SAMPLES_PER_REV per revolution."""
    revs = abs(pos[-1] - pos[0]) / (2 * math.pi) if len(pos) else 0.0
    if len(pos) < MIN_SAMPLES_PER_REV:
        raise BenchError(fname, f"{n} samples over {revs:.3f} output revolutions: the order analysis needs at least "
                                f"one whole output revolution with ≥ {MIN_SAMPLES_PER_REV} samples per revolution")
    win = te_window(pos, fname)
    if win.samples < MIN_SAMPLES_PER_REV * win.revolutions:
        raise BenchError(fname, f"{win.samples} samples over {win.revolutions} output revolutions: the order analysis "
                                f"needs at least one whole output revolution with ≥ {MIN_SAMPLES_PER_REV} samples "
                                f"per revolution")
    return win


def _resolve_reducer(table: dict, folder: Path, where: str) -> tuple[ReducerSpec, str]:
    from rvflex import catalog
    from rvflex.spec import load_spec

    if "catalog" in table:
        name = table["catalog"]
        if name not in catalog.names():
            raise BenchError(f"{where}, key 'reducer.catalog'",
                             f"{name!r} is not in the catalogue (available: {', '.join(catalog.names())})")
        return catalog.load(name), name
    if "spec" in table:
        p = folder / str(table["spec"])
        if not p.is_file():
            raise BenchError(f"{where}, key 'reducer.spec'", f"spec file {p} not found")
        try:
            return load_spec(p), str(table["spec"])
        except SpecError as err:
            raise BenchError(str(p), str(err)) from None
    raise BenchError(f"{where}, table [reducer]", "needs 'catalog' (a catalogue name) or 'spec' (a spec file)")


def read_bench(folder: str | Path) -> BenchDataset:
    """Read and validate a bench dataset folder.

    Parameters
    ----------
    folder : str or os.PathLike
        The dataset: ``bench.toml`` (the reducer and one ``[[run]]`` table per run) and one CSV
        file per run, SI columns (``time_s``, ``theta_in_rad``, ``theta_out_rad``, ``torque_Nm``);
        the format is described in the diagnosis guide (docs/diagnosis.md).

    Returns
    -------
    BenchDataset
        The reducer spec and the runs, every value checked.

    Raises
    ------
    BenchError
        One clear message naming the file, row or key of the first problem found.
    """
    folder = Path(folder)
    toml_path = folder / "bench.toml"
    if not toml_path.is_file():
        raise BenchError(str(toml_path), "file not found (a dataset folder needs bench.toml)")
    try:
        doc = tomllib.loads(toml_path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as err:
        raise BenchError(str(toml_path), f"not valid TOML: {err}") from None
    where = "bench.toml"
    red = _need(doc, "reducer", where)
    if not isinstance(red, dict):
        raise BenchError(f"{where}, key 'reducer'", "must be a table [reducer]")
    spec, source = _resolve_reducer(red, folder, where)
    run_tables = _need(doc, "run", where)
    if not isinstance(run_tables, list) or not run_tables:
        raise BenchError(f"{where}, key 'run'", "needs at least one [[run]] table")
    runs = []
    for k, rt in enumerate(run_tables):
        rwhere = f"{where}, run {k + 1}"
        fname = _need(rt, "file", rwhere)
        rwhere = f"{where}, run {k + 1} ({fname})"
        kind = _need(rt, "kind", rwhere)
        if kind not in RUN_KINDS:
            raise BenchError(f"{rwhere}, key 'kind'", f"must be one of {', '.join(RUN_KINDS)}, found {kind!r}")
        temp = _number(rt, "temperature_C", rwhere, default=math.nan)
        known = {"file", "kind", "temperature_C"}
        if kind == "te":
            runs += _te_run(rt, rwhere, folder, spec, temp, known)
        else:
            tmax = _number(rt, "torque_max_Nm", rwhere, positive=True)
            if tmax > spec.momentary_max_torque_Nm:
                raise BenchError(f"{rwhere}, key 'torque_max_Nm'",
                                 f"{tmax:g} N·m exceeds the momentary maximum {spec.momentary_max_torque_Nm:g} N·m "
                                 f"of {spec.name}: the model cannot reproduce this run")
            data = _read_csv(folder / fname, HYST_COLUMNS, ())
            tq = data["torque_Nm"]
            if len(tq) < MIN_HYSTERESIS_SAMPLES or tq.max() < 0.9 * tmax or tq.min() > -0.9 * tmax:
                raise BenchError(fname, f"{len(tq)} samples, torque {tq.min():.4g} … {tq.max():.4g} N·m: a hysteresis "
                                        f"run needs ≥ {MIN_HYSTERESIS_SAMPLES} samples reaching ±torque_max_Nm "
                                        f"({tmax:g} N·m)")
            runs.append(BenchRun(fname, "hysteresis", data["time_s"], np.empty(0), data["theta_out_rad"], tq,
                                 torque_max_Nm=tmax, temperature_C=temp,
                                 extra={x: v for x, v in rt.items() if x not in known | {"torque_max_Nm"}}))
    extra = {k: v for k, v in doc.items() if k not in ("reducer", "run")}
    return BenchDataset(spec, source, tuple(runs), str(folder), extra)


# ----------------------------------------------------------------------------- writing

def _toml_value(v) -> str:
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, bool):
        return "true" if v else "false"
    return repr(float(v)) if isinstance(v, float) else str(v)


def _groups(dataset: BenchDataset) -> list[list[BenchRun]]:
    """Runs grouped by file (an angle-form file may hold a forward and a reverse run)."""
    out: dict[str, list[BenchRun]] = {}
    for r in dataset.runs:
        out.setdefault(r.file, []).append(r)
    for name, runs in out.items():
        if len(runs) > 1 and not (len(runs) == 2 and all(r.kind == "te" and r.form == "angle" for r in runs)
                                  and {r.direction for r in runs} == set(DIRECTIONS)
                                  and np.array_equal(runs[0].position_rad, runs[1].position_rad)):
            raise ValueError(f"{name}: only an angle-form forward and reverse run on the same angles share a file")
    return list(out.values())


def _is_spec_file(source: str) -> bool:
    return str(source).endswith(".toml")


def bench_toml(dataset: BenchDataset) -> str:
    """The ``bench.toml`` text of ``dataset``."""
    src = dataset.reducer_source
    lines = ["[reducer]", (f"spec = {_toml_value(Path(src).name)}" if _is_spec_file(src)
                           else f"catalog = {_toml_value(src)}"), ""]
    for runs in _groups(dataset):
        r = runs[0]
        lines += ["[[run]]", f"file = {_toml_value(r.file)}", f"kind = {_toml_value(r.kind)}"]
        if r.kind == "te":
            lines += [f"direction = {_toml_value(r.direction if len(runs) == 1 else 'both')}",
                      f"load_Nm = {_toml_value(float(r.load_Nm))}",
                      f"speed_out_rpm = {_toml_value(float(r.speed_out_rpm))}"]
        else:
            lines.append(f"torque_max_Nm = {_toml_value(float(r.torque_max_Nm))}")
        if math.isfinite(r.temperature_C):
            lines.append(f"temperature_C = {_toml_value(float(r.temperature_C))}")
        lines.append("")
    return "\n".join(lines)


def _csv_text(runs: list[BenchRun]) -> str:
    run = runs[0]
    if run.kind == "te" and run.form == "angle":
        cols = [(TE_ANGLE_COLUMN, np.degrees(run.position_rad))]
        for r in runs:
            scale = 648000.0 / math.pi if r.te_unit == "arcsec" else 180.0 / math.pi
            name = f"te_{r.direction}_{r.te_unit}" if len(runs) > 1 else f"te_{r.te_unit}"
            cols.append((name, r.te_rad * scale))
    elif run.kind == "te":
        cols = [("time_s", run.time_s), ("theta_in_rad", run.theta_in_rad), ("theta_out_rad", run.theta_out_rad)]
        if len(run.torque_Nm):
            cols.append(("torque_Nm", run.torque_Nm))
    else:
        cols = [("time_s", run.time_s), ("torque_Nm", run.torque_Nm), ("theta_out_rad", run.theta_out_rad)]
    arr = np.column_stack([c[1] for c in cols])
    body = "\n".join(",".join(f"{x:.17g}" for x in row) for row in arr)
    return ",".join(c[0] for c in cols) + "\n" + body + "\n"


def write_bench(folder: str | Path, dataset: BenchDataset) -> Path:
    """Write ``dataset`` to ``folder`` (created): every file goes to a temporary name first and
    is renamed only when all are written, so a failure leaves no half-written dataset.
    ``dataset.reducer_source`` is a catalogue name, or a spec file name (``*.toml``): the spec is then
    written beside the runs under that file's name."""
    from rvflex.spec import dumps_spec

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    files = {runs[0].file: _csv_text(runs) for runs in _groups(dataset)}
    files["bench.toml"] = bench_toml(dataset)
    if _is_spec_file(dataset.reducer_source):
        files[Path(dataset.reducer_source).name] = dumps_spec(dataset.reducer)
    tmps = []
    try:
        for name, text in files.items():
            fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{name}.", suffix=".tmp")
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(text)
            os.chmod(tmp, 0o644)
            tmps.append((tmp, folder / name))
        for tmp, dst in tmps:
            os.replace(tmp, dst)
    finally:
        for tmp, _ in tmps:
            Path(tmp).unlink(missing_ok=True)
    return folder

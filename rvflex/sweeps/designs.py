"""Sweep designs: the :class:`Design` and its TOML file, and the points each kind of design samples.

A design TOML has a ``[sweep]`` table (name, reducer, scenario, kind, load, resolution,
sampling), one ``[[factor]]`` table per factor, and an optional ``[model]`` table, the model
options every point runs with (:meth:`rvflex.options.ModelOptions.from_table`: ``fidelity`` =
``"rigid"`` (default) | ``"flexible"`` | ``"flexible-carrier"``, ``[model.discs]`` /
``[model.carrier]`` overriding that preset's reduction fields).

Kinds: single factor, orthogonal arrays (L9, L16(4^5), L27), Latin hypercube and Sobol
(scipy.stats.qmc), Monte Carlo tolerance stacks (seeded normal or uniform), and two global
sensitivity designs sampled with SALib: ``morris`` (elementary-effects trajectories) and
``sobol-indices`` (Saltelli's scheme).
"""

from __future__ import annotations

import dataclasses as dc
import hashlib
import json
import math
import os
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rvflex.choices import DesignKind, Distribution, check_choice, choices, did_you_mean
from rvflex.options import ModelOptions
from rvflex.spec import SpecError
from rvflex.sweeps import registry
from rvflex.sweeps.factors import FACTORS
from rvflex.units import UM

__all__ = ["DESIGN_KINDS", "SALIB_KINDS", "Design", "Factor", "design_points", "load_design", "monte_carlo_design",
           "orthogonal_array", "salib_problem", "salib_samples", "toml_key"]

DESIGN_KINDS: tuple[str, ...] = choices(DesignKind)
SALIB_KINDS = ("morris", "sobol-indices")


def orthogonal_array(name: str) -> np.ndarray:
    """Standard orthogonal array as 0-based levels: L9(3^4), L16(4^5), L27(3^13)."""
    if name == "L9":
        a = np.array([[i, j, (i + j) % 3, (i + 2 * j) % 3] for i in range(3) for j in range(3)])
        return a
    if name == "L16":  # GF(4) construction: columns x, y, x+y, x+2y, x+3y
        add = np.array([[0, 1, 2, 3], [1, 0, 3, 2], [2, 3, 0, 1], [3, 2, 1, 0]])
        mul = np.array([[0, 0, 0, 0], [0, 1, 2, 3], [0, 2, 3, 1], [0, 3, 1, 2]])
        return np.array([[x, y, add[x, y], add[x, mul[2, y]], add[x, mul[3, y]]] for x in range(4) for y in range(4)])
    if name == "L27":  # GF(3): columns a, b, c and their combinations (13 columns)
        rows = []
        for a_ in range(3):
            for b_ in range(3):
                for c_ in range(3):
                    v = (a_, b_, c_)
                    cols = []
                    for coeff in ((1, 0, 0), (0, 1, 0), (1, 1, 0), (1, 2, 0), (0, 0, 1), (1, 0, 1), (1, 0, 2),
                                  (0, 1, 1), (1, 1, 1), (1, 2, 2), (0, 1, 2), (1, 2, 1), (1, 1, 2)):
                        cols.append(sum(k * x for k, x in zip(coeff, v)) % 3)
                    rows.append(cols)
        return np.array(rows)
    raise ValueError(f"orthogonal array {name!r}: available L9, L16, L27")


@dataclass(frozen=True)
class Factor:
    """A design factor: a named deviation from the nominal reducer and the values it takes.

    Parameters
    ----------
    name : str
        A registered factor (:data:`~rvflex.sweeps.factors.FACTORS`: ``"eccentricity"``,
        ``"pin_radius"``, ...).
    levels : tuple of float, optional
        The deviations of a single-factor or orthogonal-array design (m), each within ±1 mm.
    low, high : float, optional
        The range of a Latin-hypercube, Sobol, uniform Monte Carlo, Morris or Sobol-indices
        design (m), each within ±1 mm.
    sigma : float, optional
        Standard deviation of a normal Monte Carlo design (m).
    """

    name: str
    levels: tuple[float, ...] = ()
    low: float = math.nan
    high: float = math.nan
    sigma: float = math.nan

    def __post_init__(self) -> None:
        if self.name not in FACTORS:
            raise SpecError("name", self.name, f"unknown factor; valid: {', '.join(FACTORS)}"
                                               f"{did_you_mean(self.name, FACTORS)}")
        if not isinstance(self.levels, tuple):
            raise SpecError("levels", self.levels, "must be a tuple of deviations (m)")
        for key, v in [*((f"levels[{k}]", x) for k, x in enumerate(self.levels)),
                       ("low", self.low), ("high", self.high), ("sigma", self.sigma)]:
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise SpecError(key, v, "must be a number (a deviation in m)")
            if math.isnan(v) and not key.startswith("levels"):
                continue  # not given
            if not abs(v) <= 1e-3:
                raise SpecError(key, v, "expected a deviation in metres, at most ±1 mm")
            if self.name == "eccentric_bearing_clearance" and v < 0 and key != "sigma":
                raise SpecError(key, v, "a clearance cannot be negative")
        if not (math.isnan(self.sigma) or self.sigma > 0):
            raise SpecError("sigma", self.sigma, "must be positive (m)")


@dataclass(frozen=True)
class Design:
    """A sweep definition: what every point runs and which deviations the points take.

    Made from Python, a bad value is refused naming the parameter (``kind``, ``factors[1].levels``);
    read by :func:`load_design`, naming the file and its TOML key (``[sweep].kind``,
    ``factor[1].levels``). A design file: ``scenarios/designs/smoke.toml``.

    Parameters
    ----------
    name, reducer : str
        Sweep name; built-in reducer name or spec TOML path (:func:`rvflex.catalog.resolve`).
    scenario : str
        A registered sweep scenario (:mod:`rvflex.sweeps.registry`: ``te``, ``lost-motion``).
    kind : DesignKind
        How the points are chosen (:data:`DESIGN_KINDS`).
    factors : tuple of Factor
        Levels or ranges of the deviations (m).
    load_Nm : float
        Output load of every point (N·m).
    positions_per_rev : int, optional
        Model positions per output revolution of each point.
    revolutions : float, optional
        Output revolutions of each point's run (revolutions).
    samples : int, optional
        Points of a sampled design (LHS, Sobol, Monte Carlo), Morris trajectories or Saltelli
        base samples.
    seed : int, optional
        Random seed of a sampled design.
    distribution : {"uniform", "normal"}, optional
        Monte Carlo sampling: uniform in [low, high] or normal with ``sigma``.
    morris_levels : int, optional
        Grid levels of a Morris design (even).
    options : ModelOptions
        The model every point builds (default rigid; TOML: the ``[model]`` table).
    source : str
        Where the design came from (for messages).
    """

    name: str
    reducer: str
    scenario: str
    kind: DesignKind
    factors: tuple[Factor, ...]
    load_Nm: float
    positions_per_rev: int = 256
    revolutions: float = 1.0
    samples: int = 8
    seed: int = 1
    distribution: Distribution = "uniform"
    morris_levels: int = 4
    options: ModelOptions = dc.field(default_factory=ModelOptions.rigid)
    source: str = "<design>"

    def __post_init__(self) -> None:
        # the rules name the Python parameters; load_design names the TOML keys and the file instead
        src = None if self.source == "<design>" else self.source
        check_choice("kind", self.kind, DesignKind, src)
        check_choice("distribution", self.distribution, Distribution, src)
        for key in ("name", "reducer", "scenario"):
            if not isinstance(getattr(self, key), str) or not getattr(self, key):
                raise SpecError(key, getattr(self, key), "must be a non-empty string", src)
        if not isinstance(self.factors, tuple) or not self.factors:
            raise SpecError("factors", self.factors, "a design needs a non-empty tuple of Factor", src)
        for k, f in enumerate(self.factors):
            if not isinstance(f, Factor):
                raise SpecError(f"factors[{k}]", f, "must be an rvflex.Factor", src)
        for key, positive in (("load_Nm", False), ("revolutions", True)):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0 \
                    or (positive and v == 0):
                raise SpecError(key, v, f"must be a {'positive' if positive else 'non-negative'} number", src)
        for key, least in (("positions_per_rev", 4), ("samples", 1), ("morris_levels", 2)):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, int) or v < least:
                raise SpecError(key, v, f"must be an integer ≥ {least}", src)
        if isinstance(self.seed, bool) or not isinstance(self.seed, int):
            raise SpecError("seed", self.seed, "must be an integer", src)
        if not isinstance(self.options, ModelOptions):
            raise SpecError("options", self.options, "must be an rvflex.options.ModelOptions (TOML: the [model] "
                                                     "table)", src)
        if self.kind in ("L9", "L16", "L27"):
            columns, levels = orthogonal_array(self.kind).shape[1], orthogonal_array(self.kind).max() + 1
            if len(self.factors) > columns:
                raise SpecError("factors", len(self.factors), f"{self.kind} has {columns} columns", src)
            for k, f in enumerate(self.factors):
                if len(f.levels) != levels:
                    raise SpecError(f"factors[{k}].levels", f.levels, f"{self.kind} needs {levels} levels", src)
        if self.kind in SALIB_KINDS:
            salib_problem(self)  # bounds and sample counts checked before anything runs

    @property
    def digest(self) -> str:
        """Content hash of everything that defines the points and their evaluation."""
        d = dc.asdict(self)
        d.pop("source")
        if self.kind != "morris":  # only Morris uses it: older stores keep their digest
            d.pop("morris_levels")
        d.pop("options")
        if self.options != ModelOptions.rigid():  # rigid designs keep the digest they had before options
            d["options"] = self.options.as_dict()
        return hashlib.sha256(json.dumps(d, sort_keys=True, default=str).encode()).hexdigest()[:16]


def toml_key(field: str) -> str:
    """The design TOML's key of a :class:`Design` parameter, as errors from a file name it:
    ``factors[1].levels`` → ``factor[1].levels``, ``factors`` → ``[[factor]]``, ``options`` →
    ``[model]``, ``load_Nm`` → ``[sweep].load_Nm``."""
    if field.startswith("factors["):
        return "factor" + field[len("factors"):]
    if field == "factors":
        return "[[factor]]"
    if field == "options":
        return "[model]"
    return f"[sweep].{field}"


def load_design(path: str | os.PathLike) -> Design:
    """Read and validate a design TOML file.

    Parameters
    ----------
    path : str or os.PathLike
        The design file: a ``[sweep]`` table, one ``[[factor]]`` table per factor (deviations in
        m) and an optional ``[model]`` table (see the module's description and
        ``scenarios/designs/smoke.toml``).

    Returns
    -------
    Design
        The validated design (``source`` is the file).

    Raises
    ------
    SpecError
        An unreadable file or a bad value, naming the file, the TOML key (``[sweep].kind``,
        ``factor[2].levels``, ``[model].fidelity``), the value and the rule.
    """
    path = Path(path)
    src = str(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, tomllib.TOMLDecodeError) as err:
        raise SpecError("design", src, f"cannot be read as TOML: {err}") from None
    top = sorted(set(data) - {"sweep", "factor", "model"})
    if top:
        raise SpecError(f"[{top[0]}]", data[top[0]], "unknown table; valid: [sweep], [[factor]], [model]", src)
    sw = data.get("sweep", {})
    if not isinstance(sw, dict):
        raise SpecError("[sweep]", sw, "must be a table", src)
    for key in ("name", "reducer", "scenario", "kind", "load_Nm"):
        if key not in sw:
            raise SpecError(f"[sweep].{key}", None, "missing key", src)
    known = {f.name for f in dc.fields(Design)} - {"factors", "options", "source"}
    extra = set(sw) - known
    if extra:
        hint = " (model options go in the [model] table)" if min(extra) in ("fidelity", "options") else ""
        hint = hint or did_you_mean(min(extra), known)
        raise SpecError(f"[sweep].{min(extra)}", sw[min(extra)], f"unknown key{hint}", src)
    if sw["scenario"] not in registry.names():  # the registry is filled by importing the scenarios
        raise SpecError("[sweep].scenario", sw["scenario"], f"must be one of {', '.join(registry.names())} "
                                                            f"(the registered sweep scenarios)"
                                                            f"{did_you_mean(sw['scenario'], registry.names())}", src)
    tables = data.get("factor", [])
    if not isinstance(tables, list) or not tables:
        raise SpecError("[[factor]]", tables or None, "a design needs at least one [[factor]] table", src)
    factors = []
    fields = {f.name for f in dc.fields(Factor)}
    for k, f in enumerate(tables):
        unknown = sorted(set(f) - fields) if isinstance(f, dict) else []
        if not isinstance(f, dict) or unknown:
            key = f"factor[{k}].{unknown[0]}" if unknown else f"factor[{k}]"
            raise SpecError(key, f[unknown[0]] if unknown else f,
                            f"unknown key; valid: {', '.join(sorted(fields))}{did_you_mean(unknown[0], fields)}"
                            if unknown else "must be a table", src)
        if "name" not in f:
            raise SpecError(f"factor[{k}].name", None, "missing key", src)
        levels = f.get("levels", [])
        if not isinstance(levels, list):
            raise SpecError(f"factor[{k}].levels", levels, "must be an array of deviations (m)", src)
        try:
            factors.append(Factor(f["name"], tuple(map(_number, levels)),
                                  **{x: _number(f[x]) for x in ("low", "high", "sigma") if x in f}))
        except SpecError as err:
            raise SpecError(f"factor[{k}].{err.field}", err.value, err.rule, src) from None
    options = ModelOptions.from_table(data.get("model", {}), "[model]", src)
    try:
        return Design(factors=tuple(factors), options=options, source=src, **sw)
    except SpecError as err:
        raise SpecError(toml_key(err.field), err.value, err.rule, src) from None


def _number(v):
    """A TOML number as float (the digest of a design is the same for ``1`` and ``1.0``); anything
    else as it is, for Factor to refuse."""
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else v


def salib_problem(design: Design) -> dict:
    """SALib problem dict of a ``morris`` / ``sobol-indices`` design (bounds are the factors'
    ``low``/``high`` deviations, m); refuses missing or empty ranges and too few samples,
    naming the :class:`Design` parameter."""
    src = None if design.source == "<design>" else design.source
    for k, f in enumerate(design.factors):
        if not (math.isfinite(f.low) and math.isfinite(f.high) and f.low < f.high):
            raise SpecError(f"factors[{k}]", (f.low, f.high), f"{f.name}: {design.kind} needs low < high", src)
    if design.samples < 2:
        raise SpecError("samples", design.samples, "at least 2 (Morris trajectories / Saltelli base samples)", src)
    if design.kind == "morris" and not (design.morris_levels >= 2 and design.morris_levels % 2 == 0):
        raise SpecError("morris_levels", design.morris_levels, "an even number of grid levels, at least 2", src)
    if design.kind == "sobol-indices" and design.samples & (design.samples - 1):
        raise SpecError("samples", design.samples,
                        "a power of two (Saltelli's scheme keeps the Sobol sequence's balance)", src)
    return {"num_vars": len(design.factors), "names": [f.name for f in design.factors],
            "bounds": [[f.low, f.high] for f in design.factors]}


def salib_samples(design: Design) -> np.ndarray:
    """The SALib sample matrix (rows = points, SI deviations), seeded by ``design.seed``.

    ``morris``: ``samples`` trajectories of D + 1 points on a ``morris_levels`` grid;
    ``sobol-indices``: Saltelli's scheme, ``samples`` × (D + 2) points (first and total order).
    """
    problem = salib_problem(design)
    if design.kind == "morris":
        from SALib.sample import morris

        return morris.sample(problem, design.samples, num_levels=design.morris_levels, seed=design.seed)
    from SALib.sample import sobol

    return sobol.sample(problem, design.samples, calc_second_order=False, scramble=True, seed=design.seed)


def design_points(design: Design) -> list[dict[str, float]]:
    """The design's points: one dict factor → deviation per point."""
    names = [f.name for f in design.factors]
    kind = design.kind
    if kind == "single-factor":
        pts = []
        for f in design.factors:
            for v in f.levels:
                p = dict.fromkeys(names, 0.0)
                p[f.name] = v
                pts.append(p)
        return pts
    if kind in ("L9", "L16", "L27"):
        oa = orthogonal_array(kind)  # its column and level counts were checked by Design
        return [{f.name: f.levels[row[j]] for j, f in enumerate(design.factors)} for row in oa]
    if kind in SALIB_KINDS:
        return [dict(zip(names, map(float, row))) for row in salib_samples(design)]
    rng = np.random.default_rng(design.seed)
    if kind in ("lhs", "sobol"):
        from scipy.stats import qmc

        sampler = (qmc.LatinHypercube(d=len(names), seed=rng) if kind == "lhs"
                   else qmc.Sobol(d=len(names), scramble=True, seed=rng))
        u = sampler.random(design.samples)
        lo = np.array([f.low for f in design.factors])
        hi = np.array([f.high for f in design.factors])
        return [dict(zip(names, map(float, lo + row * (hi - lo)))) for row in u]
    # Monte Carlo tolerance stack
    pts = []
    for _ in range(design.samples):
        p = {}
        for f in design.factors:
            if design.distribution == "normal":
                p[f.name] = float(rng.normal(0.0, f.sigma))
            else:
                p[f.name] = float(rng.uniform(f.low, f.high))
        pts.append(p)
    return pts


def monte_carlo_design(points: int, seed: int = 1, positions_per_rev: int = 2048) -> Design:
    """Monte Carlo tolerance stack of seed 004's five sensitive characteristics on the rigid
    RV-40E (uniform within their tolerance bands), quasi-static loaded TE at rated torque over
    one output revolution: the benchmark design of ``rvflex bench sweep``."""
    return Design(
        name=f"mc{points}", reducer="rv40e", scenario="te", kind="monte-carlo", load_Nm=412.0,
        positions_per_rev=positions_per_rev, samples=points, seed=seed, distribution="uniform",
        factors=(Factor("eccentricity", low=-3 * UM, high=3 * UM), Factor("moved_modification", low=-1 * UM, high=1 * UM),
                 Factor("equidistant_modification", low=-2 * UM, high=2 * UM),
                 Factor("pin_circle_radius", low=-3 * UM, high=3 * UM), Factor("pin_radius", low=-1 * UM, high=1 * UM)))

"""The null distribution: what healthy units of other model forms make each candidate effect look like.

Every candidate effect can absorb some model-form gap: on a healthy unit of another make it gains evidence
and a size although nothing is wrong with the unit. How much is not a property of the benches at hand but
of the candidate against the range of model forms units come in, so the acceptance is set from an ensemble
of such units (:class:`~rvflex.diagnosis.ensemble.EnsembleMismatch`), each diagnosed as a bench with no
effect (:func:`rvflex.diagnosis.null_build.build_null`, the command ``rvflex null-distribution``). Per candidate effect the ensemble's
controls give

- ``evidence_max``, ``evidence_q95``: the largest and the 95th percentile over the controls of the most evidence
  the effect earns on its own in any candidate containing it (:func:`own_evidence`: a pair's evidence less that of
  its other effect alone; 0 where it gained none);
- ``magnitude_max``, ``magnitude_q95``: the same of the size the controls reach with evidence: the upper end of
  the 95 % interval of the effect's size in that best candidate (:func:`reached`) where its evidence is
  significant (``bic_threshold``), 0 where it is not (a fit without evidence has a size set by noise, often at
  the bound of its range);
- ``magnitude_max_positive``, ``magnitude_max_negative``: for a one-parameter effect whose range spans both
  signs (:func:`signed`), the largest size on each side, which a finding of that sign must exceed;
- ``false_alarm_rate``: the share of controls in which a candidate with the effect was accepted by the
  other tests alone (before these thresholds).

The same figures are kept per unit; a diagnosis takes those of the built-in unit its spec is a variant of
(:meth:`NullDistribution.for_spec`), the pooled ones for any other unit.

A finding is established only when each of its effects earns more evidence on its own than the controls give it,
and its size exceeds the largest size the controls reach for it (:func:`rvflex.diagnosis.grade.grade`): a size
healthy units reach is not a finding. The largest, not the 95th percentile: a unit has 14 controls, whose 95th
percentile lies between their two largest values and below the true one about half the time, and a diagnosis
tries some twenty effects, so per-effect percentiles let more than one case in twenty through (measured on the
ensemble self-checks at 06f66ff: 2 false names in 20 cases for seeds 1 and 3 with the percentiles, 1 with the
largest). :func:`leave_one_out` measures what the thresholds hold on controls they were not made from. The
distribution ships with the package (:data:`NULL_PATH`) and names the commit-independent settings it was made with.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["NULL_PATH", "NullDistribution", "leave_one_out", "load_null", "null_from_reports", "own_evidence", "reached",
           "report_singles", "signed"]

NULL_PATH = Path(__file__).with_name("null_distribution.json")
"""The null distribution shipped with the package (made by ``rvflex null-distribution``)."""

QUANTILE = 0.95


@dataclass(frozen=True)
class NullDistribution:
    """Per candidate effect: ``evidence_q95``, ``magnitude_q95`` (the effect's magnitude unit: m, rad,
    1/K, …), ``false_alarm_rate`` and ``controls`` (how many controls it was taken over); ``source``: how
    it was made (units, cases, seeds); ``per_unit``: the same per built-in unit, ``unit`` the one
    :meth:`for_spec` chose (None: all units pooled)."""

    effects: dict = field(default_factory=dict)
    source: dict = field(default_factory=dict)
    per_unit: dict = field(default_factory=dict)
    unit: str | None = None

    def for_spec(self, spec) -> NullDistribution:
        """The distribution of the built-in unit ``spec`` is a variant of, else of all units pooled. How a model
        form projects onto a candidate depends on the unit's geometry (the RV-80E's healthy controls reach a 9.4 µm
        pin-ring runout, the RV-40E's 1.8 µm), so a unit is judged against the ensemble of its own nominal unit:
        the built-in unit with the same pin and tooth counts and, within 1 %, the same pin-circle radius and
        eccentricity, whatever its name or its stiffnesses."""
        from rvflex import catalog

        c = spec.cycloid
        for name, effects in self.per_unit.items():
            try:
                u = catalog.load(name).cycloid
            except Exception:  # a unit no longer in the catalogue: not matched
                continue
            if (u.pin_count, u.disc_teeth) == (c.pin_count, c.disc_teeth) and all(
                    abs(a / b - 1.0) <= 0.01 for a, b in ((c.pin_circle_radius_m, u.pin_circle_radius_m),
                                                          (c.eccentricity_m, u.eccentricity_m))):
                return NullDistribution(effects, self.source, self.per_unit, name)
        return self

    def evidence_threshold(self, name: str) -> float | None:
        """The evidence effect ``name`` must earn on its own (:func:`own_evidence`) in a finding; None when it is
        not in the distribution."""
        e = self.effects.get(name)
        return None if e is None else e["evidence_max"]

    def magnitude_threshold(self, name: str, sign: float = 0.0) -> float | None:
        """The size effect ``name`` must exceed (None: not in the distribution); for an effect kept per sign
        (:func:`signed`), the threshold of the side ``sign`` (> 0 or < 0) when one is given."""
        e = self.effects.get(name)
        return None if e is None else _size_threshold(e, sign)


def load_null(path: str | Path | None = None) -> NullDistribution | None:
    """The null distribution at ``path`` (default :data:`NULL_PATH`); None when there is none."""
    p = Path(path) if path is not None else NULL_PATH
    if not p.is_file():
        return None
    doc = json.loads(p.read_text(encoding="utf-8"))
    return NullDistribution(doc.get("effects", {}), doc.get("source", {}), doc.get("per_unit", {}))


def signed(name: str) -> str | None:
    """The parameter of effect ``name`` whose sign the null distribution keeps apart (its full name,
    ``effect.param``), or None. A one-parameter effect whose range spans both signs describes two opposite
    deviations (a housing that expands more than the steel parts, or less), each with its own signature: a
    model form that projects onto one side (measured, the RV-80E's controls: every thermal fit negative, down
    to −5 ppm/K) says nothing of how far healthy units reach on the other."""
    from rvflex.diagnosis.effects import EFFECTS

    e = EFFECTS.get(name)
    if e is None or e.n != 1 or e.nominal or not e.params[0].low < 0.0 < e.params[0].high:
        return None
    return f"{name}.{e.params[0].name}"


def _side(entry: dict, name: str) -> float:
    """The sign of effect ``name``'s parameter in a report's effect ``entry`` (0 when not kept per sign)."""
    key = signed(name)
    return float(np.sign(entry.get("params", {}).get(key, 0.0))) if key else 0.0


def reached(entry: dict, name: str) -> float:
    """The size a control reaches for effect ``name`` in its report's effect ``entry``: the upper end of the size's
    95 % interval (on the side of its estimate for an effect kept per sign), the estimate where no interval is
    given. A control's fitted size is an estimate as a finding's is: taken at its point value, the thresholds
    moved by a micrometre with every re-fit of the same controls (measured, RV-80E: the largest pin-ring runout
    6.8 µm or 8.2 µm as the modification deviation's secants changed, a crank phase error's 7.8 µm runout
    stand-in on one side of it or the other); its interval's upper end (7.8 µm) covers that."""
    size = abs(float(entry["magnitude"].get(name, 0.0)))
    iv = entry.get("interval") or {}
    if not isinstance(iv, dict):
        return size
    if f"{name}.magnitude" in iv:
        return max(size, abs(float(iv[f"{name}.magnitude"][1])))
    own = [k for k in iv if k.startswith(f"{name}.")]
    if len(own) != 1:
        return size
    lo, hi = (float(v) for v in iv[own[0]])
    x = float(entry.get("params", {}).get(own[0], 0.0))
    return max(size, hi if x > 0 else -lo if x < 0 else max(abs(lo), abs(hi)))


def own_evidence(score: float, names: list[str], name: str, singles: dict) -> float:
    """The evidence effect ``name`` earns in a candidate of effects ``names`` with evidence ``score``: all of it for a
    single effect; for a pair, what it adds to the better of the other effect alone (``singles``: effect → its
    evidence alone) and the calibrated model (evidence 0). A pair's evidence is mostly its first effect's: held
    against the pair's, a second effect that adds little would pass on the first one's strength."""
    if len(names) == 1:
        return float(score)
    others = [max(float(singles.get(n, 0.0)), 0.0) for n in names if n != name]
    return float(score) - max(others + [0.0])


def report_singles(report: dict) -> dict:
    """Effect → evidence of the single-effect candidates of a diagnosis document."""
    return {e["name"]: float(e["score"]) for e in report["effects"] if " + " not in e["name"]}


def null_from_reports(reports: list[dict], significant: float = 10.0) -> dict:
    """Per effect: the ensemble controls' evidence and magnitude quantiles and false-alarm rate, from their
    diagnosis documents (``rvflex diagnose --json``). A control's evidence for an effect is the most the effect
    earns on its own in any of its candidates (:func:`own_evidence`), its size the one it reaches in that candidate
    where that evidence reaches ``significant`` (the diagnosis's ``bic_threshold``). An effect kept per sign
    (:func:`signed`) also has ``magnitude_max_positive`` and ``magnitude_max_negative``, the largest size on each
    side."""
    names = sorted({n for d in reports for e in d["effects"] for n in e["name"].split(" + ")})
    out = {}
    singles_of = [report_singles(d) for d in reports]  # once per report, not once per effect name
    for name in names:
        ev, mag, side, alarms = [], [], [], 0
        for d, singles in zip(reports, singles_of):
            having = [e for e in d["effects"] if name in e["name"].split(" + ")]
            if not having:
                continue
            own = [own_evidence(e["score"], e["name"].split(" + "), name, singles) for e in having]
            i = int(np.argmax(own))
            best = having[i]
            ev.append(max(own[i], 0.0))
            mag.append(reached(best, name) if own[i] >= significant else 0.0)
            side.append(_side(best, name))
            alarms += any(e["accepted"] for e in having)
        if ev:
            out[name] = {"evidence_q95": float(np.quantile(ev, QUANTILE)),
                         "magnitude_q95": float(np.quantile(mag, QUANTILE)),
                         "evidence_max": float(max(ev)), "magnitude_max": float(max(mag)),
                         "false_alarm_rate": alarms / len(ev), "controls": len(ev)}
            if signed(name):
                out[name] |= {f"magnitude_max_{k}": float(max([m for m, sg in zip(mag, side) if sg * v > 0] or [0.0]))
                              for k, v in (("positive", 1.0), ("negative", -1.0))}
    return out


def _named(report: dict, thresholds: dict, significant: float) -> str | None:
    """The candidate a diagnosis made without a null distribution (``report``, its JSON) would accept under
    ``thresholds`` (effect → {evidence_max, magnitude_max}): the first refined one by score that passed every
    other test and lies beyond the thresholds of its effects, each by its own evidence (an effect without
    figures: never)."""
    singles = report_singles(report)
    for e in report["effects"]:
        names = e["name"].split(" + ")
        if not e.get("refined") or e["score"] < significant or e.get("grade_fails") or any(
                n not in thresholds for n in names):
            continue
        if all(own_evidence(e["score"], names, n, singles) > thresholds[n]["evidence_max"] for n in names) and all(
                abs(e["magnitude"].get(n, 0.0)) > _size_threshold(thresholds[n], _side(e, n)) for n in names):
            return e["name"]
    return None


def _size_threshold(figures: dict, sign: float) -> float:
    """The size threshold of an effect's null ``figures`` on the side ``sign`` (0: either side)."""
    if sign and "magnitude_max_positive" in figures:
        return figures["magnitude_max_positive" if sign > 0 else "magnitude_max_negative"]
    return figures["magnitude_max"]


def leave_one_out(reports: list[dict], significant: float = 10.0) -> dict:
    """How many of a unit's controls (``reports``, diagnosed without a null distribution) would name an effect
    under the thresholds of the other controls alone: ``named`` (their count), ``controls``, ``names`` (control
    index → the name), and ``named_q95``, the same with the others' 95th percentiles as thresholds."""
    out = {"controls": len(reports), "named": 0, "named_q95": 0, "names": {}}
    for i, d in enumerate(reports):
        rest = null_from_reports(reports[:i] + reports[i + 1:], significant)
        name = _named(d, rest, significant)
        q95 = {k: {"evidence_max": v["evidence_q95"], "magnitude_max": v["magnitude_q95"]} for k, v in rest.items()}
        # (the 95th percentiles are not kept per sign: both sides take the pooled one)
        out["named_q95"] += _named(d, q95, significant) is not None
        if name is not None:
            out["named"] += 1
            out["names"][str(i)] = name
    return out

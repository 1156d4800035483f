"""The null distribution: what healthy units of other model forms make each candidate effect look like.

Every candidate effect can absorb some model-form gap: on a healthy unit of another make it gains evidence
and a size although nothing is wrong with the unit. How much is not a property of the benches at hand but
of the candidate against the range of model forms units come in, so the acceptance is set from an ensemble
of such units (:class:`~rvflex.diagnosis.ensemble.EnsembleMismatch`), each diagnosed as a bench with no
effect (:func:`rvflex.diagnosis.null_build.build_null`, the command ``rvflex null-distribution``). Per candidate
effect, over the controls, each taken at its candidate in which the effect earns the most evidence on its own
(:func:`own_evidence`: all of a single's; a pair's less that of its other effect alone):

- ``relative_max``: the largest *relative evidence*, that evidence over what the candidate leaves unexplained
  (``leftover``: its weighted residual energy in units of the discrepancy the calibrated model leaves), 0 where
  the evidence is not significant (``bic_threshold``); ``relative_threshold``, the threshold a finding's must
  exceed: the second largest (:data:`RELATIVE_RANK`);
- ``magnitude_max``: the largest size the controls reach with a determined fit (:func:`reached`: the upper end of
  the size's 95 % interval, where the evidence is significant, the interval excludes zero and no parameter sits
  at its bound; 0 elsewhere); for an effect on the same quantity as a nominal parameter (the eccentric-bearing
  clearance), the total of the two (:func:`total_size`), also as the calibration alone reaches it; for an effect
  kept per side (:func:`signed`: a one-parameter effect whose range
  spans both signs, or a two-parameter one whose parameters of one sign nearly cancel), ``magnitude_max_positive``
  and ``magnitude_max_negative``, the largest on each side (:func:`side`), which a finding on that side must
  exceed;
- ``off_period_max``: the largest own off-period evidence (what a candidate removes at the TE orders that are not
  multiples of z_b, :func:`rvflex.diagnosis.grade.off_period_rows`) of any of the control's candidates with the
  effect, linearised ones included: a finding beyond :data:`OFF_PERIOD_MARGIN` times it is not held to the size;
- ``evidence_max``: the largest own evidence (reported, not a threshold);
- ``false_alarm_rate``: the share of controls in which a candidate with the effect was accepted by the other
  tests alone (before these thresholds).

The same figures are kept per unit; a diagnosis takes those of the built-in unit its spec is a variant of
(:meth:`NullDistribution.for_spec`), the pooled ones for any other unit.

A finding is established only when each of its effects earns a larger relative evidence than all but one of the
controls give it and its size exceeds the largest determined size they reach (:func:`rvflex.diagnosis.grade.grade`). *Why
relative*: the evidence a stand-in earns is the model-form residual it absorbs, so it grows with the square of
the gap's amplitude and with the number of features (with the discrepancy at its floor, as on most benches,
evidence is weighted residual energy). Held against a control's evidence, a finding is judged by how far the
unit's model form and campaign are from the controls'; the ratio to what the candidate leaves does not change
when the gap is scaled or the campaign repeated (it still differs between model forms, as their shapes differ:
over the two halves of the RV-80E's controls a thermal mismatch reaches 1.70 and 1.43).
*Why determined sizes*: a fit the runs cannot determine is no finding and its interval's upper end is set by the
noise (measured: the RV-80E controls' undetermined runouts reach 23 µm with evidence 12 to 15).
:func:`leave_one_out` measures what the thresholds hold on controls they were not made from.
The distribution ships with the package (:data:`NULL_PATH`) and names the commit-independent settings it was
made with.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rvflex.diagnosis.nominal import SAME_QUANTITY

__all__ = ["NULL_PATH", "OFF_PERIOD_MARGIN", "RELATIVE_RANK", "NullDistribution", "determined", "halves", "leave_one_out", "load_null", "null_from_reports",
           "own_evidence", "reached", "relative_evidence", "relative_threshold_of", "report_singles", "side", "side_text", "signed",
           "off_period_frees", "total_size", "unrefined_setters"]

NULL_PATH = Path(__file__).with_name("null_distribution.json")
"""The null distribution shipped with the package (made by ``rvflex null-distribution``)."""

OFF_PERIOD_MARGIN = 2.0
"""An effect's own off-period evidence must exceed OFF_PERIOD_MARGIN times the most any control gives it for its
size not to be held against the controls' (:func:`rvflex.diagnosis.grade.grade`). The rule loosens the acceptance,
so its threshold stands clear of the controls' top, where their figures sit close together (RV-80E, a
modification deviation: 63.5, 61.9, 59.6, 59.2): at the largest alone, the control that sets it is named when
held out (1 of 168, ``leave_one_out``)."""

RELATIVE_RANK = 2
"""The relative evidence a finding must exceed is the controls' RELATIVE_RANK-th largest for its effect (the size
it must exceed stays their largest). The largest of some fifty controls is its most volatile order statistic, set
by whichever single model form projects best onto the candidate (the two halves of the RV-40E's controls put a
thermal mismatch's at 1.53 and 0.39); the second largest is about their 96th percentile, and with the size
still held at the largest, a control judged by its unit's other 55 names nothing (``leave_one_out``: 0 of 168,
as with the largest)."""


@dataclass(frozen=True)
class NullDistribution:
    """Per candidate effect: ``relative_max``, ``magnitude_max`` (the effect's magnitude unit: m, rad, 1/K, …),
    ``evidence_max``, ``false_alarm_rate`` and ``controls`` (how many controls it was taken over); ``source``: how
    it was made (units, cases, seeds); ``per_unit``: the same per built-in unit, ``unit`` the one
    :meth:`for_spec` chose (None: all units pooled)."""

    effects: dict = field(default_factory=dict)
    source: dict = field(default_factory=dict)
    per_unit: dict = field(default_factory=dict)
    unit: str | None = None

    def for_spec(self, spec) -> NullDistribution:
        """The distribution of the built-in unit ``spec`` is a variant of, else of all units pooled. How a model
        form projects onto a candidate depends on the unit's geometry (the RV-80E's healthy controls reach a 20.9 µm
        pin-ring runout, the RV-40E's none), so a unit is judged against the ensemble of its own nominal unit:
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

    def relative_threshold(self, name: str) -> float | None:
        """The relative evidence (:func:`relative_evidence`) effect ``name`` must exceed in a finding; None when
        the distribution holds no such figure for it (not diagnosed with it, or made by an older rvflex)."""
        e = self.effects.get(name)
        return None if e is None else relative_threshold_of(e)

    def off_period_threshold(self, name: str) -> float | None:
        """The off-period evidence (:func:`rvflex.diagnosis.grade.off_period_rows`) effect ``name`` must exceed for
        its size not to be held against the controls' (None: no such figure, a distribution made by an older
        rvflex)."""
        e = self.effects.get(name)
        return None if e is None else e.get("off_period_max")

    def magnitude_threshold(self, name: str, sign: float = 0.0) -> float | None:
        """The size effect ``name`` must exceed (None: not in the distribution); for an effect kept per side
        (:func:`signed`), the threshold of the side ``sign`` (> 0 or < 0, :func:`side`) when one is given."""
        e = self.effects.get(name)
        return None if e is None else _size_threshold(e, sign)


def load_null(path: str | Path | None = None) -> NullDistribution | None:
    """The null distribution at ``path`` (default :data:`NULL_PATH`); None when there is none."""
    p = Path(path) if path is not None else NULL_PATH
    if not p.is_file():
        return None
    doc = json.loads(p.read_text(encoding="utf-8"))
    return NullDistribution(doc.get("effects", {}), doc.get("source", {}), doc.get("per_unit", {}))


def signed(name: str) -> bool:
    """Whether the null distribution keeps effect ``name``'s sizes per side (:func:`side`).

    A one-parameter effect whose range spans both signs describes two opposite deviations (a housing that expands
    more than the steel parts, or less), each with its own signature: a model form that projects onto one side
    (measured, the RV-80E's controls: 34 of their 35 determined thermal fits negative, down to −5 ppm/K) says
    little of how far healthy units reach on the other. A two-parameter effect whose parameters of one sign nearly cancel
    (``Effect.corners``: the moved and equidistant modification deviations, whose difference is the profile's
    working clearance) describes a shape change along that diagonal and a clearance change across it: the
    controls' stand-ins lie along it (measured, the 168 controls' 64 determined fits: 49 along it, up to 15.7 µm,
    10 across it, up to 4.0 µm, 5 on the dividing line, up to 6.2 µm), which says little of how far they reach in
    clearance."""
    from rvflex.diagnosis.effects import EFFECTS

    e = EFFECTS.get(name)
    if e is None or e.nominal:
        return False
    return e.corners or (e.n == 1 and e.params[0].low < 0.0 < e.params[0].high)


def side(name: str, x) -> float:
    """The side of effect ``name`` at parameters ``x`` (its own, in its order) the null distribution keeps its
    size on: for a one-parameter effect the sign of ``x``; for a corners effect +1 across its cancelling diagonal
    (parameters of opposite signs: the clearance side) and −1 along it (of one sign: the shape side); 0 at the
    dividing line (a control there counts on both sides, a finding there is held against the larger) and for an
    effect not kept per side."""
    if not signed(name):
        return 0.0
    x = np.asarray(x, float)
    return float(np.sign(x[0])) if x.size == 1 else float(-np.sign(x[0] * x[1]))


def side_text(name: str, sign: float) -> str:
    """The words a size threshold of effect ``name`` on side ``sign`` is given ("" when not kept per side)."""
    if not sign or not signed(name):
        return ""
    from rvflex.diagnosis.effects import EFFECTS

    if EFFECTS[name].n == 1:
        return " on that side of zero"
    return (" with its parameters of opposite signs (the clearance side)" if sign > 0 else
            " with its parameters of one sign (the shape side)")


def _side(entry: dict, name: str) -> float:
    """The side (:func:`side`) of effect ``name`` in a report's effect ``entry`` (0 when not kept per side)."""
    if not signed(name):
        return 0.0
    from rvflex.diagnosis.effects import EFFECTS

    params = entry.get("params", {})
    return side(name, [params.get(f"{name}.{p.name}", 0.0) for p in EFFECTS[name].params])


def reached(entry: dict, name: str) -> float:
    """The size a control reaches for effect ``name`` in its report's effect ``entry``: the upper end of the size's
    95 % interval (on the side of its estimate for a one-parameter effect kept per side), the estimate where no interval is
    given. A control's fitted size is an estimate as a finding's is: taken at its point value, the thresholds
    moved by a micrometre with every re-fit of the same controls (measured, RV-80E: the largest pin-ring runout
    6.8 µm or 8.2 µm as the modification deviation's secants changed, a crank phase error's 7.8 µm runout
    stand-in on one side of it or the other); its interval's upper end (7.8 µm) covers that. For an effect on the
    same quantity as a nominal parameter (:data:`~rvflex.diagnosis.nominal.SAME_QUANTITY`), the total the runs
    determine: that upper end plus the calibrated parameter's (:func:`total_size`)."""
    partner = SAME_QUANTITY.get(name)
    if partner is not None:
        iv = (entry.get("interval") or {}).get(f"{partner}.magnitude")
        return _own_reached(entry, name) + abs(float(iv[1] if iv is not None else entry["magnitude"].get(partner, 0.0)))
    return _own_reached(entry, name)


def total_size(name: str, magnitudes: dict) -> float:
    """The size of effect ``name`` as the null distribution judges it, from a candidate's ``magnitudes`` (effect or
    nominal parameter → magnitude): its own, or for an effect on the same quantity as a nominal parameter
    (:data:`~rvflex.diagnosis.nominal.SAME_QUANTITY`: the eccentric-bearing clearance and the calibrated crank-bearing
    clearance) the total of the two. The runs determine only the total, and how they split it is the calibration's
    prior, not the unit: a healthy RV-80E control with 3.7 µm of clearance was split 2.0 µm calibrated and 1.6 µm
    effect, an independent simulator's unit with 9 µm 6.1 µm (the class top) and 2.2 µm. Judged by the effect's
    share, the second is within what the first reaches; by the total, it is beyond every control."""
    own = abs(float(magnitudes.get(name, 0.0)))
    partner = SAME_QUANTITY.get(name)
    return own + abs(float(magnitudes.get(partner, 0.0))) if partner is not None else own


def _own_reached(entry: dict, name: str) -> float:
    """:func:`reached` for the effect's own size alone."""
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


def report_singles(report: dict, key: str = "score") -> dict:
    """Effect → evidence (or another figure ``key``, where given) of the single-effect candidates of a diagnosis
    document."""
    return {e["name"]: float(e[key]) for e in report["effects"] if " + " not in e["name"] and e.get(key) is not None}


def determined(entry: dict, name: str) -> bool:
    """Whether effect ``name``'s size in a report's effect ``entry`` is determined: the 95 % interval of its
    magnitude excludes zero and no parameter of it sits at its range's bound (the acceptance's rule,
    :func:`~rvflex.diagnosis.verdict.undetermined_effect`). An entry without intervals counts as determined."""
    if any(b.split(".")[0] == name for b in entry.get("at_bound", ())):
        return False
    iv = (entry.get("interval") or {}).get(f"{name}.magnitude")
    return iv is None or float(iv[0]) > 0.0


def relative_evidence(own: float, leftover: float) -> float:
    """The relative evidence of an effect that earns ``own`` evidence in a candidate leaving ``leftover`` (its
    weighted residual energy in units of the discrepancy the calibrated model leaves): with the discrepancy at its
    floor, what the effect removes over what the candidate leaves, which neither the model-form gap's amplitude
    nor the number of runs changes."""
    return float(own) / max(float(leftover), 1.0)


def null_from_reports(reports: list[dict], significant: float = 10.0) -> dict:
    """Per effect: the ensemble controls' thresholds (see the module docstring) and false-alarm rate, from their
    diagnosis documents (``rvflex diagnose --json``). Each control is taken at its candidate in which the effect
    earns the most evidence on its own (:func:`own_evidence`); where that evidence reaches ``significant`` (the
    diagnosis's ``bic_threshold``) it gives its relative evidence (:func:`relative_evidence`, the entry's
    ``leftover``) and, where the fit is also :func:`determined`, its size (:func:`reached`); 0 otherwise. For an
    effect on the same quantity as a nominal parameter, the size is the total (:func:`total_size`; the entry's
    ``magnitude_is_total_with`` names the parameter), and the largest includes what each control's calibration
    alone reaches. An effect kept per side (:func:`signed`) also has ``magnitude_max_positive`` and ``magnitude_max_negative``, the largest
    size on each side (:func:`side`)."""
    out = {}
    for name, rows in _rows(reports, significant).items():
        if rows:
            rel, mag = [r["relative"] for r in rows], [max(r["size"], r["calibrated"]) for r in rows]
            ranked = sorted(rel, reverse=True)
            out[name] = {"relative_max": float(ranked[0]),
                         "relative_threshold": float(ranked[min(RELATIVE_RANK, len(ranked)) - 1]),
                         "magnitude_max": float(max(mag)),
                         "evidence_max": float(max(r["evidence"] for r in rows)),
                         "false_alarm_rate": sum(r["alarm"] for r in rows) / len(rows), "controls": len(rows)}
            if name in SAME_QUANTITY:
                out[name]["magnitude_is_total_with"] = SAME_QUANTITY[name]
            offs = [r["off_period"] for r in rows if r["off_period"] is not None]
            if offs:
                out[name]["off_period_max"] = float(max(offs))
            if signed(name):  # a control on the dividing line (side 0: a parameter held at zero) counts on both
                out[name] |= {f"magnitude_max_{k}": float(max([r["size"] for r in rows if r["side"] * v >= 0] or [0.0]))
                              for k, v in (("positive", 1.0), ("negative", -1.0))}
    return out


def _rows(reports: list[dict], significant: float) -> dict:
    """Per effect, a row per control that has a candidate with it: the control's index (``control``), the
    candidate in which the effect earns the most evidence on its own (``candidate``, its name; ``refined``),
    that evidence (``evidence``, ≥ 0), its relative evidence and size as :func:`null_from_reports` counts them
    (``relative``, ``size``: 0 where not counted), its ``side`` and whether any candidate with it was accepted
    (``alarm``); for an effect on the same quantity as a nominal parameter, ``calibrated``: what the control's
    calibration alone reaches of it (:func:`_calibrated_reach`; 0 for every other effect); ``off_period``: the most
    own off-period evidence any of its candidates with the effect earns (None when its report has none)."""
    names = sorted({n for d in reports for e in d["effects"] for n in e["name"].split(" + ")})
    singles_of = [report_singles(d) for d in reports]  # once per report, not once per effect name
    singles_off_of = [report_singles(d, "off_period_evidence") for d in reports]
    out = {}
    for name in names:
        rows = out[name] = []
        for k, (d, singles, singles_off) in enumerate(zip(reports, singles_of, singles_off_of)):
            having = [e for e in d["effects"] if name in e["name"].split(" + ")]
            if not having:
                continue
            own = [own_evidence(e["score"], e["name"].split(" + "), name, singles) for e in having]
            i = int(np.argmax(own))
            best, strong = having[i], own[i] >= significant
            if strong and "leftover" not in best:
                raise ValueError(f"a control's candidate {best['name']!r} has no 'leftover': its report was made by an "
                                 "older rvflex (rebuild the null distribution: rvflex null-distribution)")
            offs = [own_evidence(e["off_period_evidence"], e["name"].split(" + "), name, singles_off)
                    for e in having if e.get("off_period_evidence") is not None]
            rows.append({"control": k, "candidate": best["name"], "refined": bool(best.get("refined")),
                         "off_period": max(offs) if offs else None,
                         "evidence": max(own[i], 0.0),
                         "relative": relative_evidence(own[i], best["leftover"]) if strong else 0.0,
                         "size": reached(best, name) if strong and determined(best, name) else 0.0,
                         "calibrated": _calibrated_reach(d, SAME_QUANTITY[name]) if name in SAME_QUANTITY else 0.0,
                         "side": _side(best, name), "alarm": any(e["accepted"] for e in having)})
    return out


def _calibrated_reach(report: dict, name: str) -> float:
    """The upper end of nominal parameter ``name``'s 95 % interval in a diagnosis document's calibration (0 when
    it was not calibrated or the runs did not determine it)."""
    for row in report.get("calibration", ()):
        if row["name"] == name and row.get("determined"):
            return abs(float(row["interval"][1]))
    return 0.0


def unrefined_setters(reports: list[dict], significant: float = 10.0, tried: set | None = None) -> dict:
    """The linearised control fits that set a threshold of :func:`null_from_reports`: per effect and figure (its
    relative evidence; its size, on each side for an effect kept per side), every control whose figure lies above
    the largest one a refined fit gives (and above 0), as control index → the names of its candidates to refine;
    pairs (control, name) in ``tried`` are left out (a refinement that failed stays linearised).

    A finding is accepted only refined, with the model in the loop; a linearised fit far from the calibration can
    promise what the model does not give (measured, one RV-80E control: a pin-ring runout paired with a series
    compliance reaches 21.3 µm and a relative evidence of 1.47 linearised, 14.8 µm and 0.57 refined). So a control's fit that sets a threshold is
    refined too (``DiagnosisSettings.also_refine``) before it counts, and the figures compare like with like."""
    tried = tried or set()
    out: dict = {}
    for name, rows in _rows(reports, significant).items():
        figures = [("relative", 0.0), ("size", 0.0)]
        if signed(name):
            figures += [("size", 1.0), ("size", -1.0)]
        for key, sign in figures:
            mine = [r for r in rows if r[key] > 0.0 and (not sign or r["side"] * sign >= 0)]
            top = max([r[key] for r in mine if r["refined"]] or [0.0])
            for r in mine:
                if not r["refined"] and r[key] > top and (r["control"], r["candidate"]) not in tried:
                    out.setdefault(r["control"], set()).add(r["candidate"])
    return out


def _named(report: dict, thresholds: dict, significant: float) -> str | None:
    """The candidate a diagnosis made without a null distribution (``report``, its JSON) would accept under
    ``thresholds`` (effect → :func:`null_from_reports` figures): the first refined one by score that passed every
    other test and lies beyond the thresholds of its effects, each by its own relative evidence (an effect without
    figures: never)."""
    singles, singles_off = report_singles(report), report_singles(report, "off_period_evidence")
    for e in report["effects"]:
        names = e["name"].split(" + ")
        if not e.get("refined") or e["score"] < significant or e.get("grade_fails") or any(
                n not in thresholds for n in names):
            continue
        rel = [relative_evidence(own_evidence(e["score"], names, n, singles), e["leftover"]) for n in names]
        if all(r > relative_threshold_of(thresholds[n]) for r, n in zip(rel, names)) and all(
                total_size(n, e["magnitude"]) > _size_threshold(thresholds[n], _side(e, n))
                or _off_period_beyond(e, n, thresholds[n], singles_off, significant) for n in names):
            return e["name"]
    return None


def off_period_frees(own: float | None, top: float | None, significant: float) -> bool:
    """Whether an effect's own off-period evidence ``own`` frees it from the controls' size: significant and beyond
    :data:`OFF_PERIOD_MARGIN` times ``top``, the most the controls give it (``off_period_max``; never when either
    is None)."""
    return own is not None and top is not None and own >= significant and own > OFF_PERIOD_MARGIN * top


def _off_period_beyond(entry: dict, name: str, figures: dict, singles_off: dict, significant: float) -> bool:
    """:func:`off_period_frees` for effect ``name`` of a report's effect ``entry`` under the null ``figures``."""
    off = entry.get("off_period_evidence")
    own = None if off is None else own_evidence(off, entry["name"].split(" + "), name, singles_off)
    return off_period_frees(own, figures.get("off_period_max"), significant)


def relative_threshold_of(figures: dict) -> float | None:
    """The relative evidence a finding must exceed under an effect's null ``figures`` (:data:`RELATIVE_RANK`; a
    distribution without ``relative_threshold``: its ``relative_max``; None without either)."""
    return figures.get("relative_threshold", figures.get("relative_max"))


def _size_threshold(figures: dict, sign: float) -> float:
    """The size threshold of an effect's null ``figures`` on the side ``sign`` (0: either side)."""
    if sign and "magnitude_max_positive" in figures:
        return figures["magnitude_max_positive" if sign > 0 else "magnitude_max_negative"]
    return figures["magnitude_max"]


def leave_one_out(reports: list[dict], significant: float = 10.0) -> dict:
    """How many of a unit's controls (``reports``, diagnosed without a null distribution) would name an effect
    under the thresholds of the other controls alone: ``named`` (their count), ``controls`` and ``names`` (control
    index → the name)."""
    out = {"controls": len(reports), "named": 0, "names": {}}
    for i, d in enumerate(reports):
        name = _named(d, null_from_reports(reports[:i] + reports[i + 1:], significant), significant)
        if name is not None:
            out["named"] += 1
            out["names"][str(i)] = name
    return out


def halves(reports: list[dict], significant: float = 10.0) -> dict:
    """The thresholds of the first and of the second half of a unit's controls, side by side: per effect with
    evidence in either, ``relative``, ``magnitude`` and, for comparison, ``evidence`` (each a pair, first half
    first). How far they differ says how far the figures of all the controls can be trusted."""
    k = len(reports) // 2
    a, b = null_from_reports(reports[:k], significant), null_from_reports(reports[k:], significant)
    out = {}
    for n in sorted(set(a) | set(b)):
        fa, fb = a.get(n, {}), b.get(n, {})
        if max(fa.get("evidence_max", 0.0), fb.get("evidence_max", 0.0)) < significant:
            continue
        out[n] = {key: [float(fa.get(f, 0.0)), float(fb.get(f, 0.0))]
                  for key, f in (("relative", "relative_max"), ("magnitude", "magnitude_max"),
                                 ("evidence", "evidence_max"))}
    return out

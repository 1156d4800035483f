"""Seed 001 as its paper built it: the RV-40E with the Table 2 errors at rated torque with its
cycloid discs, output carrier and pin housing flexible (the paper's three MNF bodies), and the
elastic share of the wind-up per part, adding one FE part at a time: rigid → + discs →
+ carrier → + housing.

Global deformation of each FE part comes from its Craig–Bampton modes, the local contact
approach from the line-contact law in every row (docs/flexible.md).

    python -m rvflex.scenarios.seed001_flexible out/ [positions per revolution]
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from rvflex.fe.reduce import PartSettings
from rvflex.options import CARRIER_FE, DISC_FE, HOUSING_FE, ModelOptions
from rvflex.scenarios.loaded_te import LoadedTE, run_loaded_te
from rvflex.spec import ErrorSpec, ReducerSpec, SpecError

__all__ = ["PARTS", "Seed001Parts", "markdown", "run_seed001_parts"]

PARTS = ("discs", "carrier", "housing")
"""The FE parts in the order they are made flexible."""


@dataclass(frozen=True)
class Seed001Parts:
    """Loaded TE of a unit with its parts made flexible one after another.

    Parameters
    ----------
    spec : ReducerSpec
        The reducer.
    errors : ErrorSpec
        Its errors (seed 001: ``rvflex.catalog.load_error_set("rv40e_seed001", spec)``).
    positions_per_rev : int, optional
        TE positions over the one output revolution.
    discs, carrier, housing : PartSettings, optional
        The reduction of each part (default the presets': DISC_FE, CARRIER_FE, HOUSING_FE).
    """

    spec: ReducerSpec
    errors: ErrorSpec
    positions_per_rev: int = 256
    discs: PartSettings = DISC_FE
    carrier: PartSettings = CARRIER_FE
    housing: PartSettings = HOUSING_FE

    def __post_init__(self) -> None:
        if not (isinstance(self.positions_per_rev, int) and self.positions_per_rev >= 16):
            raise SpecError("positions_per_rev", self.positions_per_rev, "must be an integer ≥ 16 (as LoadedTE)")
        for name in PARTS:
            if not isinstance(getattr(self, name), PartSettings):
                raise SpecError(name, getattr(self, name), "must be an rvflex.fe.reduce.PartSettings")

    @property
    def variants(self) -> dict[str, ModelOptions]:
        """``rigid`` and, cumulatively, ``+discs``, ``+carrier``, ``+housing`` (the last is
        :meth:`ModelOptions.flexible_all` with these reductions)."""
        out, flex = {"rigid": ModelOptions.rigid()}, {}
        for part in PARTS:
            flex[part] = getattr(self, part)
            out[f"+{part}"] = ModelOptions(**flex)
        return out


def run_seed001_parts(scenario: Seed001Parts, progress=print) -> list[dict]:
    """One row per variant: ``variant, te_pp_arcsec, windup_arcsec, share_of_windup, wall_s``.

    ``share_of_windup`` of ``+part`` is the wind-up that part adds over the variant before it,
    as a fraction of the all-flexible wind-up (the parts' shares and the rigid row's add up to
    1); the rigid row's is the rigid unit's fraction of it.
    """
    rows = []
    for name, options in scenario.variants.items():
        t0 = time.perf_counter()
        _, met = run_loaded_te(LoadedTE(scenario.spec, scenario.errors, scenario.spec.rated_torque_Nm, 1.0,
                                        scenario.positions_per_rev, options=options))
        rows.append({"variant": name, "te_pp_arcsec": met.te_pp_arcsec, "windup_arcsec": met.mean_windup_arcsec,
                     "wall_s": time.perf_counter() - t0})
        if progress is not None:
            progress(f"{name:10s} TE pp {met.te_pp_arcsec:7.2f}″  wind-up {met.mean_windup_arcsec:8.2f}″  "
                     f"{rows[-1]['wall_s']:.0f} s")
    full = rows[-1]["windup_arcsec"]
    for k, row in enumerate(rows):
        before = rows[k - 1]["windup_arcsec"] if k else 0.0
        row["share_of_windup"] = (row["windup_arcsec"] - before) / full
    return rows


def markdown(rows: list[dict]) -> str:
    """The rows as a Markdown table (TE pp, wind-up, added wind-up and its share)."""
    lines = ["| variant | TE pp | mean wind-up | added wind-up | share of the all-flexible wind-up |",
             "|---|---|---|---|---|"]
    for k, r in enumerate(rows):
        added = r["windup_arcsec"] - (rows[k - 1]["windup_arcsec"] if k else 0.0)
        lines.append(f"| {r['variant']} | {r['te_pp_arcsec']:.2f}″ | {r['windup_arcsec']:.2f}″ | {added:+.2f}″ | "
                     f"{100 * r['share_of_windup']:.1f} % |")
    return "\n".join(lines)


if __name__ == "__main__":
    import json
    import sys
    from pathlib import Path

    from rvflex import catalog

    out = Path(sys.argv[1] if len(sys.argv) > 1 else "out")
    out.mkdir(parents=True, exist_ok=True)
    spec = catalog.load("rv40e")
    sc = Seed001Parts(spec, catalog.load_error_set("rv40e_seed001", spec),
                      positions_per_rev=int(sys.argv[2]) if len(sys.argv) > 2 else 256)
    result = run_seed001_parts(sc)
    (out / "seed001_parts.json").write_text(json.dumps(result, indent=1))
    print(markdown(result))

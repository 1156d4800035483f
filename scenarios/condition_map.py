"""A bench of a map of conditions: TE runs at 3 loads × 3 output speeds × 2 temperatures × 2 directions (36
runs, no torque cycle), written from the model of another resolution (the self-check's generator) with a hidden
2nd-harmonic pin pattern, to be diagnosed in one go::

    python -m rvflex.scenarios.condition_map out/map            # writes out/map/bench and out/map/truth.json
    rvflex diagnose out/map/bench --json out/map/diagnosis.json --out out/map/report

The diagnosis replays the 36 runs quasi-statically: runs at the same load and direction whose model does not
read the temperature are one model run (speed never enters a quasi-static replay), so the map costs about as
much as a few-run campaign. Its residual table gives each significant order's load, temperature and speed
dependence (a component that grows with speed is named as dynamic).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

__all__ = ["write_map"]


def write_map(out: str | Path, reducer: str = "rv40e", seed: int = 1, pin_h2_m: float = 3e-6) -> dict:
    """Write the map bench to ``out/bench`` and its truth to ``out/truth.json``; returns the truth document.

    Parameters
    ----------
    out : path
        Output folder.
    reducer : str
        A built-in unit.
    seed : int
        Random seed (encoder origin, noise, sampling).
    pin_h2_m : float
        Amplitude of the hidden 2nd-harmonic radial pin pattern (m); 0 for none.
    """
    from rvflex import catalog
    from rvflex.diagnosis.effects import EFFECTS
    from rvflex.diagnosis.selfcheck import generate_case, map_runs

    spec = catalog.resolve(reducer)
    out = Path(out)
    hidden = [(EFFECTS["pin_position_h2"], np.array([pin_h2_m, 0.0]))] if pin_h2_m else []
    return generate_case(out / "bench", out / "truth.json", spec, hidden, np.random.default_rng(seed),
                         reducer_name=reducer, runs=map_runs(spec))


def main(argv: list[str] | None = None) -> int:
    """The command (see the module docstring); returns the exit status."""
    ap = argparse.ArgumentParser(prog="python -m rvflex.scenarios.condition_map", description=__doc__.split("\n\n")[0])
    ap.add_argument("out", help="output folder (bench/ and truth.json are written there)")
    ap.add_argument("--reducer", default="rv40e", help="built-in unit (default rv40e)")
    ap.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
    ap.add_argument("--pin-h2-um", type=float, default=3.0, help="hidden 2nd-harmonic pin pattern, µm (default 3)")
    a = ap.parse_args(argv)
    truth = write_map(a.out, a.reducer, a.seed, a.pin_h2_um * 1e-6)
    print(f"wrote {Path(a.out) / 'bench'} ({len(truth.get('effects', []))} hidden effect(s)); "
          f"diagnose it with: rvflex diagnose {Path(a.out) / 'bench'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

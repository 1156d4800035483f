"""Pin ring (housing): fixed pins as exact circles, per-pin errors included.

In the rigid fidelity the housing is ground; the pins live inside each disc's contact
element (:mod:`rvflex.contact.cycloid_pin`), which takes them from here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rvflex.choices import BodyFidelity, check_choice
from rvflex.geometry.pins import pin_centres, pin_radii
from rvflex.spec import ErrorSpec, ReducerSpec

__all__ = ["PinRingHandles", "build"]


@dataclass(frozen=True, eq=False)
class PinRingHandles:
    """Pin centres (n, 2) in the housing frame and radii (n,), errors included (m)."""

    centres_m: np.ndarray
    radii_m: np.ndarray


def build(mbs, spec: ReducerSpec, errors: ErrorSpec, *, fidelity: BodyFidelity = "rigid") -> PinRingHandles:
    """The pin ring of ``spec`` (ground in the rigid fidelity; nothing is added to ``mbs``)."""
    check_choice("fidelity", fidelity, BodyFidelity)
    if fidelity != "rigid":
        raise NotImplementedError(f"fidelity = {fidelity!r}: the flexible housing comes with the FE issue")
    return PinRingHandles(pin_centres(spec.cycloid, errors), pin_radii(spec.cycloid, errors))

"""Inject error sources one at a time into the RV-40E at rated load and print the TE orders each
one adds over the error-free unit (the measured side of docs/te_orders.md).

    python -m rvflex.scenarios.te_orders
"""

from __future__ import annotations

import numpy as np

from rvflex.metrics import order_spectrum
from rvflex.scenarios.loaded_te import LoadedTE, run_loaded_te
from rvflex.spec import ErrorSpec
from rvflex.units import UM

__all__ = ["SOURCES", "added_orders"]

SOURCES = {
    "sun eccentricity 10 µm": ErrorSpec(sun_base_eccentricity_m=10 * UM),
    "planet eccentricity 10 µm (crank 1)": ErrorSpec(planet_base_eccentricity_m=(10 * UM, 0.0)),
    "one pin 8 µm outward": ErrorSpec(pin_radial_m=(8 * UM,) + (0.0,) * 39),
    "pin-ring runout 5 µm": ErrorSpec(pin_ring_runout_m=5 * UM),
    "carrier runout 5 µm": ErrorSpec(carrier_runout_m=5 * UM),
    "crank 1 eccentricity +2 µm": ErrorSpec(crank_eccentricity_error_m=(2 * UM, 0.0)),
    "profile error 2 µm, one tooth of disc 1": ErrorSpec(disc_profile_error_m=((2 * UM,) + (0.0,) * 38, (0.0,) * 39)),
}


def added_orders(spec, errors: ErrorSpec, load_Nm: float, positions: int = 1024, top: int = 5):
    """The ``top`` orders whose amplitude (arcsec) ``errors`` adds most over the error-free unit."""
    base = run_loaded_te(LoadedTE(spec, ErrorSpec(), load_Nm, positions_per_rev=positions))[0]
    res = run_loaded_te(LoadedTE(spec, errors, load_Nm, positions_per_rev=positions))[0]
    orders, amp = order_spectrum(res.te_rad, 1.0)
    added = amp - order_spectrum(base.te_rad, 1.0)[1]
    idx = np.argsort(added[1:])[::-1][:top] + 1
    return [(int(orders[i]), float(added[i])) for i in idx]


if __name__ == "__main__":
    from rvflex import catalog

    spec = catalog.load("rv40e")
    for name, e in SOURCES.items():
        print(f"{name:42s}", ", ".join(f"{o}: +{a:.3f}″" for o, a in added_orders(spec, e, spec.rated_torque_Nm)))

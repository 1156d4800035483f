"""Units: rvflex is SI inside; these constants convert at the edges (reports, tables, plots).

Catalogues report TE in arcsec, lost motion and backlash in arcmin, stiffness in
N·m/arcmin and lengths in µm or mm; multiply a value in those units by the constant to get SI
(``2 * UM`` is 2 µm in metres), divide an SI value by it to report (``te_rad / ARCSEC``).
The ``*_PER_RAD`` factors are the same conversions written the other way round.
"""

from __future__ import annotations

import math

__all__ = [
    "ARCMIN",
    "ARCMIN_PER_RAD",
    "ARCSEC",
    "ARCSEC_PER_RAD",
    "MM",
    "UM",
    "arcmin",
    "arcsec",
    "from_arcmin",
    "from_arcsec",
]

MM = 1e-3
"""One millimetre in metres."""
UM = 1e-6
"""One micrometre in metres."""
ARCSEC = math.pi / 648000.0
"""One arc second in radians (1″ = π/648000 rad)."""
ARCMIN = math.pi / 10800.0
"""One arc minute in radians."""
ARCSEC_PER_RAD = 180.0 * 3600.0 / math.pi
"""Arc seconds per radian."""
ARCMIN_PER_RAD = 180.0 * 60.0 / math.pi
"""Arc minutes per radian."""


def arcsec(angle_rad):
    """An angle (rad; float or array) in arc seconds."""
    return angle_rad * ARCSEC_PER_RAD


def arcmin(angle_rad):
    """An angle (rad; float or array) in arc minutes."""
    return angle_rad * ARCMIN_PER_RAD


def from_arcsec(value_arcsec):
    """Arc seconds (float or array) in radians."""
    return value_arcsec * ARCSEC


def from_arcmin(value_arcmin):
    """Arc minutes (float or array) in radians."""
    return value_arcmin * ARCMIN

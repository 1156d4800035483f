"""Design factors of a sweep: each a named deviation (SI) applied to the nominal spec or errors."""

from __future__ import annotations

import dataclasses as dc

__all__ = ["FACTORS"]


def _cycloid(spec, errors, **kw):
    return dc.replace(spec, cycloid=dc.replace(spec.cycloid, **kw)), errors


def _modification(spec, errors, **kw):
    c = spec.cycloid
    return dc.replace(spec, cycloid=dc.replace(c, modification=dc.replace(c.modification, **kw))), errors


def _per(spec, errors, field: str, value: float, count: int):
    return spec, dc.replace(errors, **{field: (value,) * count})


FACTORS = {
    # name: (description, unit, apply(spec, errors, deviation) -> (spec, errors))
    "eccentricity": ("crank eccentricity e (both cranks)", "m",
                     lambda s, e, v: _cycloid(s, e, eccentricity_m=s.cycloid.eccentricity_m + v)),
    "moved_modification": ("moved modification Δr_p", "m",
                           lambda s, e, v: _modification(s, e, moved_m=s.cycloid.modification.moved_m + v)),
    "equidistant_modification": ("equidistant modification Δr_rp", "m",
                                 lambda s, e, v: _modification(s, e, equidistant_m=s.cycloid.modification.equidistant_m + v)),
    "pin_circle_radius": ("pin-circle radius r_b", "m", lambda s, e, v: (s, dc.replace(e, pin_circle_radius_error_m=v))),
    "pin_radius": ("pin radius r_r", "m", lambda s, e, v: (s, dc.replace(e, pin_radius_error_m=v))),
    "sun_pitch_radius": ("sun pitch radius r1", "m", lambda s, e, v: (s, dc.replace(e, sun_pitch_radius_error_m=v))),
    "planet_pitch_radius": ("planet pitch radius r2", "m",
                            lambda s, e, v: _per(s, e, "planet_pitch_radius_error_m", v, s.cranks.count)),
    "disc_bore_distance": ("disc crank-bore distance a_c", "m",
                           lambda s, e, v: _per(s, e, "disc_bore_distance_error_m", v, s.cycloid.disc_count)),
    "input_carrier_hole_distance": ("input-end carrier hole distance a_k", "m",
                                    lambda s, e, v: (s, dc.replace(e, input_carrier_hole_distance_error_m=v))),
    "output_carrier_hole_distance": ("output-end carrier hole distance a_k", "m",
                                     lambda s, e, v: (s, dc.replace(e, output_carrier_hole_distance_error_m=v))),
    "eccentric_bearing_clearance": ("radial clearance of every eccentric bearing", "m",
                                    lambda s, e, v: _per(s, e, "eccentric_bearing_clearance_m", v,
                                                         s.cranks.count * s.cycloid.disc_count)),
}
"""Design factors: each a deviation (SI) applied to the nominal spec or errors."""

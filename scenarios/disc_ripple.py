"""Why flexible discs ripple the loaded TE of two-crank units and hardly that of three-crank ones.

A flexible disc is held by its crank bores; the pin load zone turns against it once per crank
turn (relative to the disc, ``z_b`` times per output revolution). Each disc's compliance between
load zone and bores therefore repeats ``n_c`` times per crank turn (``n_c`` cranks), and so does
the TE the disc alone would make: order ``n_c·z_b``. Disc d runs at crank phase φ_d, so its
ripple harmonic k (per crank turn) has phase k·φ_d. Two discs 180° apart: with two cranks the
harmonic-2 ripples are 2·180° = 360° apart and add in the TE; with three cranks 3·180° = 540° ≡
180° apart: the discs exchange torque in antiphase at order ``3·z_b`` and the TE keeps only what
is left at twice that order. :func:`disc_ripple` measures it: the TE and each disc's share of the
ring torque over one crank turn, with their harmonics per crank turn; :func:`with_disc_phases` makes
variants (other disc counts and phases: two pairs 90° apart on a two-crank unit, three discs
120° apart on a three-crank unit) that test the rule; :func:`with_crank_count` puts the same
discs on three cranks. docs/units.md quotes the table.

    python -m rvflex.scenarios.disc_ripple [positions [load as a fraction of the rated torque]]
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from rvflex.geometry.formulas import ARCSEC_PER_RAD
from rvflex.model import build_reducer
from rvflex.options import ModelOptions
from rvflex.solve import quasi_static
from rvflex.spec import ReducerSpec, SpecError

__all__ = ["DiscRipple", "disc_ripple", "with_crank_count", "with_disc_phases"]


@dataclass(frozen=True)
class DiscRipple:
    """Loaded TE and the discs' ring torques over one crank turn relative to the discs.

    Parameters
    ----------
    unit : str
        The spec's name.
    cranks : int
        Crank count n_c.
    pin_count : int
        z_b: crank turns (relative to the discs) per output revolution.
    disc_phases_rad : tuple of float
        Each disc's crank phase φ_d, rad.
    load_Nm : float
        Output torque, N·m.
    te_arcsec : numpy.ndarray
        TE θ_out − θ_in/i at each position, arcsec (positions,).
    disc_torque_Nm : numpy.ndarray
        Torque of each disc's pin forces about the reducer axis, N·m (positions, discs); positive
        for the loaded direction, their sum is the ring torque T(1 − 1/i).
    """

    unit: str
    cranks: int
    pin_count: int
    disc_phases_rad: tuple[float, ...]
    load_Nm: float
    te_arcsec: np.ndarray
    disc_torque_Nm: np.ndarray

    def te_harmonic(self, k: int) -> complex:
        """Harmonic ``k`` per crank turn (order k·z_b per output revolution) of the TE.

        Parameters
        ----------
        k : int
            Harmonic number per crank turn (≥ 1, below half the positions).

        Returns
        -------
        complex
            Amplitude (arcsec) and phase (rad) as a complex number.
        """
        return complex(_harmonics(self.te_arcsec, k))

    def torque_harmonic(self, k: int) -> np.ndarray:
        """Harmonic ``k`` per crank turn of each disc's ring torque.

        Parameters
        ----------
        k : int
            Harmonic number per crank turn (≥ 1, below half the positions).

        Returns
        -------
        numpy.ndarray
            Complex amplitude (N·m) per disc (discs,).
        """
        return _harmonics(self.disc_torque_Nm, k)

    @property
    def windup_arcsec(self) -> float:
        """Mean TE (arcsec)."""
        return float(self.te_arcsec.mean())


def _harmonics(x: np.ndarray, k: int) -> np.ndarray:
    """Complex amplitude of harmonic k over the window (rows: samples)."""
    n = x.shape[0]
    if not 1 <= k < n / 2:
        raise SpecError("k", k, f"harmonic must lie in [1, {n / 2}) for {n} positions")
    return 2.0 * np.fft.rfft(x - x.mean(axis=0), axis=0)[k] / n


def with_disc_phases(spec: ReducerSpec, phases_rad: tuple[float, ...]) -> ReducerSpec:
    """``spec`` with one disc per entry of ``phases_rad`` (crank phases, rad), the eccentrics
    spread evenly over the original stack (only an FE carrier or housing sees axial positions).

    Parameters
    ----------
    spec : ReducerSpec
        The unit.
    phases_rad : tuple of float
        Crank phase of each disc, rad in [0, 2π].

    Returns
    -------
    ReducerSpec
        The variant.
    """
    pos = spec.cranks.eccentric_axial_positions_m
    axial = tuple(float(z) for z in np.linspace(min(pos), max(pos), len(phases_rad))) if len(phases_rad) > 1 else (0.0,)
    return dataclasses.replace(
        spec, cycloid=dataclasses.replace(spec.cycloid, disc_count=len(phases_rad), disc_phase_rad=tuple(phases_rad)),
        cranks=dataclasses.replace(spec.cranks, eccentric_axial_positions_m=axial))


def with_crank_count(spec: ReducerSpec, count: int) -> ReducerSpec:
    """``spec`` with ``count`` cranks evenly spaced on its crank circle and as many pillars (the
    carrier's hole distance follows): the same discs, teeth and bearings on another support
    layout — a variant for comparison, not a unit anyone sells.

    Parameters
    ----------
    spec : ReducerSpec
        The unit.
    count : int
        Crank count.

    Returns
    -------
    ReducerSpec
        The variant (named ``<name>-<count>crank``).
    """
    cr = spec.cranks
    return dataclasses.replace(
        spec, name=f"{spec.name}-{count}crank",
        cranks=dataclasses.replace(cr, count=count, angles_rad=tuple(2 * math.pi * k / count for k in range(count))),
        carrier=dataclasses.replace(spec.carrier, pillar_count=count,
                                    hole_distance_m=2 * cr.crank_circle_radius_m * math.sin(math.pi / count)))


def disc_ripple(spec: ReducerSpec, options: ModelOptions | None = None, *, load_per_disc_Nm: float | None = None,
                positions: int = 96) -> DiscRipple:
    """Loaded TE and each disc's ring torque over one crank turn relative to the discs (1/z_b
    output revolution, where the pattern of an error-free unit repeats), quasi-static.

    Parameters
    ----------
    spec : ReducerSpec
        The unit (:func:`with_disc_phases` for variants).
    options : ModelOptions, optional
        Model fidelity; None: the flexible-disc preset.
    load_per_disc_Nm : float, optional
        Output torque per disc, N·m; None: the rated torque shared by two discs (a variant with
        more discs gets proportionally more load, so each disc carries what it does in the unit).
    positions : int, optional
        Positions over the crank turn.

    Returns
    -------
    DiscRipple
        TE and ring torques per position.
    """
    options = ModelOptions.flexible_discs() if options is None else options
    nd = spec.cycloid.disc_count
    load = (spec.rated_torque_Nm / 2 if load_per_disc_Nm is None else load_per_disc_Nm) * nd
    model = build_reducer(spec, None, options)
    theta = np.linspace(0.0, 2 * math.pi * model.ratio / spec.cycloid.pin_count, positions, endpoint=False)
    res = quasi_static(model, theta, load)
    return DiscRipple(spec.name, spec.cranks.count, spec.cycloid.pin_count, tuple(spec.cycloid.disc_phase_rad), load,
                      res.te_rad * ARCSEC_PER_RAD, res.disc_torque_Nm)


def _table(cases, positions: int, load_fraction: float = 1.0) -> str:
    rows = ["| unit | cranks | disc phases | TE pp | TE harmonic n_c (order) | TE harmonic 2n_c | "
            "disc torque harmonic n_c per disc (phase) |", "|---|---|---|---|---|---|---|"]
    for spec in cases:
        r = disc_ripple(spec, positions=positions, load_per_disc_Nm=load_fraction * spec.rated_torque_Nm / 2)
        nc, zb = r.cranks, r.pin_count
        t1, t2 = r.te_harmonic(nc), r.te_harmonic(2 * nc)
        tq = ", ".join(f"{abs(c):.2f} N·m ({math.degrees(np.angle(c)):.0f}°)" for c in r.torque_harmonic(nc))
        phases = ", ".join(f"{math.degrees(p):.0f}°" for p in r.disc_phases_rad)
        rows.append(f"| {r.unit} | {nc} | {phases} | {np.ptp(r.te_arcsec):.2f}″ | {abs(t1):.4f}″ ({nc * zb}) | "
                    f"{abs(t2):.4f}″ ({2 * nc * zb}) | {tq} |")
    return "\n".join(rows)


if __name__ == "__main__":
    import sys
    from pathlib import Path

    from rvflex import catalog

    n = int(sys.argv[1]) if len(sys.argv) > 1 else 96
    fraction = float(sys.argv[2]) if len(sys.argv) > 2 else 1.0
    rv40e, rv160n = catalog.load("rv40e"), catalog.load("rv160n")
    pi = math.pi
    rv40e3 = with_crank_count(rv40e, 3)
    cases = [rv40e, with_disc_phases(rv40e, (0.0, pi, 0.0, pi)), with_disc_phases(rv40e, (0.0, pi, pi / 2, 3 * pi / 2)),
             rv40e3, with_disc_phases(rv40e3, (0.0, 2 * pi / 3, 4 * pi / 3)), rv160n]
    fixture = Path(__file__).resolve().parents[1] / "tests" / "fixtures" / "drive3_user.toml"  # a source checkout
    if fixture.is_file():
        user = catalog.resolve(str(fixture))
        cases += [user, with_disc_phases(user, (0.0, 2 * pi / 3, 4 * pi / 3))]
    print(_table(cases, n, fraction))

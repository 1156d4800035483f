"""Loaded transmission error (the computation behind ``rvflex te``).

Run as a script for the RV-40E with seed 001's Table 2 errors at rated load::

    python -m rvflex.scenarios.loaded_te out/
"""

from __future__ import annotations

import dataclasses as dc
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rvflex.choices import TEMode, check_choice
from rvflex.geometry.formulas import ARCSEC_PER_RAD
from rvflex.metrics import TEMetrics, order_spectrum, te_metrics
from rvflex.model import ReducerModel
from rvflex.options import ModelOptions
from rvflex.result import Result, new_axes, new_figure, scenario_attrs, spatial_variables, variable
from rvflex.scenarios.common import OutputLoaded, check_model, check_scenario_inputs
from rvflex.solve import QuasiStaticResult, dynamic, quasi_static
from rvflex.spec import ErrorSpec, ReducerSpec, SpecError
from rvflex.tilt import OutputLoad

__all__ = ["LoadedTE", "LoadedTEResult", "perfect_spec", "run_loaded_te", "seed001_errors",
           "write_te_outputs"]


@dataclass(frozen=True)
class LoadedTE(OutputLoaded):
    """Loaded transmission error over whole output revolutions (``rvflex te``).

    Parameters
    ----------
    spec : ReducerSpec
        The reducer (:func:`rvflex.load_reducer`).
    errors : ErrorSpec, optional
        Manufacturing and assembly errors (:func:`rvflex.load_errors`); None: none.
    load_Nm : float, optional
        Output torque resisting the motion, N·m; None: the rated torque.
    revolutions : float, optional
        Output revolutions of the run.
    positions_per_rev : int, optional
        Input positions per output revolution (at least 16).
    direction : {1, -1}, optional
        +1 turns the input forward, −1 in reverse (quasi-static only).
    mode : {"quasi-static", "dynamic"}, optional
        Quasi-static stepping, or a generalized-α time integration from the loaded static state.
    speed_out_rpm : float, optional
        Output speed of the dynamic mode, rpm.
    step_s : float, optional
        Time step of the dynamic mode, s.
    options : ModelOptions or str, optional
        Model fidelity per part: a :class:`~rvflex.options.ModelOptions` or a preset name
        (``"rigid"``, ``"flexible"``, ``"flexible-carrier"``); ``ModelOptions(face_slices=…)`` for the load
        along the pins' length.
    output_load : rvflex.tilt.OutputLoad, optional
        Tilting moment, axial and radial force on the output (None: none); needs the spec's
        ``bearings.main_pair`` (and ``allowable_moment_Nm`` for a moment). The carrier tilts and moves on its main
        bearing pair and the discs with it against the pins (:mod:`rvflex.tilt`).

    Raises
    ------
    SpecError
        A value out of range, naming the parameter (``load_Nm = -5.0: must lie in [0, …] N·m``).

    Examples
    --------
    >>> import rvflex
    >>> spec = rvflex.load_reducer("rv40e")
    >>> r = rvflex.run(rvflex.LoadedTE(spec, load_Nm=412.0, positions_per_rev=64))  # doctest: +SKIP
    >>> r.metrics.te_pp_arcsec  # doctest: +SKIP
    """

    spec: ReducerSpec
    errors: ErrorSpec | None = None
    load_Nm: float | None = None
    revolutions: float = 1.0
    positions_per_rev: int = 2048
    direction: int = 1
    mode: TEMode = "quasi-static"
    speed_out_rpm: float = 15.0
    step_s: float = 1e-4
    options: ModelOptions | str = ModelOptions()
    output_load: OutputLoad | None = None

    def __post_init__(self) -> None:
        check_scenario_inputs(self)
        self._check_output_load()
        if self.load_Nm is None:
            object.__setattr__(self, "load_Nm", self.spec.rated_torque_Nm)
        self.spec.check_torque("load_Nm", self.load_Nm, allow_zero=True)
        if not self.revolutions > 0:
            raise SpecError("revolutions", self.revolutions, "must be positive (output revolutions)")
        if not self.positions_per_rev >= 16:
            raise SpecError("positions_per_rev", self.positions_per_rev, "must be at least 16 per output revolution")
        if self.direction not in (1, -1):
            raise SpecError("direction", self.direction, "must be +1 (forward) or -1 (reverse)")
        check_choice("mode", self.mode, TEMode)
        if self.mode == "dynamic" and not self.speed_out_rpm > 0:
            raise SpecError("speed_out_rpm", self.speed_out_rpm, "must be positive in dynamic mode (rpm at the output)")
        if self.mode == "dynamic" and self.output_load is not None and self.options.spatial is not None:
            raise SpecError("mode", self.mode, "the spatial model's dynamic run takes no output load yet: run it "
                                               "quasi-static")
        if self.mode == "dynamic" and self.direction < 0:
            raise SpecError("direction", self.direction, "dynamic runs go forward (reverse: quasi-static)")

    @property
    def n_positions(self) -> int:
        """Positions over the whole run."""
        return int(round(self.positions_per_rev * self.revolutions))

    def run(self, *, model: ReducerModel | None = None, progress=None) -> LoadedTEResult:
        """Run the scenario (:func:`rvflex.run` calls this).

        Parameters
        ----------
        model : ReducerModel, optional
            A model from :func:`rvflex.build_reducer` with this scenario's spec, errors and
            options, reused instead of building one; None builds it.
        progress : callable, optional
            ``progress(done, total)``, called as the run advances (per position).

        Returns
        -------
        LoadedTEResult
            The labelled result.
        """
        t0 = time.perf_counter()
        res, met = run_loaded_te(self, progress, model=model)
        return LoadedTEResult(self, met, time.perf_counter() - t0, res)


@dataclass(frozen=True, eq=False)
class LoadedTEResult(Result):
    """Loaded TE: per position the input, output and TE angles, and the pin forces and gaps
    (quasi-static runs; a dynamic run records the angles only). ``raw`` is the solver's record.

    Parameters
    ----------
    scenario : LoadedTE
        The scenario that ran.
    metrics : TEMetrics
        TE peak-to-peak, minimum, maximum and mean wind-up (arcsec), the strongest orders.
    wall_s : float
        Wall time of the run, s.
    raw : QuasiStaticResult
        The solver's record (angles in rad, pin forces in N, gaps in m).
    """

    raw: QuasiStaticResult

    name = "te"
    main_dim = "position"

    def to_xarray(self):
        """Dataset over ``position`` (nominal output angle θ_in/i, rad) and, for quasi-static runs,
        ``disc`` × ``pin``: ``theta_out`` (rad), ``te`` (arcsec), ``pin_force`` (N), ``pin_gap`` (m); with the
        contact in slices ``pin_slice_force`` (N); the spatial model's ``carrier_tilt`` (rad), ``carrier_shift``
        (m) and ``disc_tilt`` (rad) (:func:`rvflex.result.spatial_variables`); the metrics in ``attrs`` (with an
        output load, its components and the pair-alone tilt and shift: ``carrier_tilt_rad``/``carrier_shift_m``,
        named ``pair_carrier_tilt_rad``/``pair_carrier_shift_m`` beside the spatial model's solved ones).

        Returns
        -------
        xarray.Dataset
            Named dimensions, SI coordinates, ``units`` and ``long_name`` on every variable.
        """
        import xarray as xr

        r = self.raw
        dims = ("position",)
        data = {"theta_out": variable(dims, r.theta_out, "rad", "output angle θ_out"),
                "te": variable(dims, r.te_rad * ARCSEC_PER_RAD, "arcsec", "transmission error θ_out − θ_in/i")}
        coords = {"position": variable(dims, r.theta_in / r.ratio, "rad", "nominal output angle θ_in/i"),
                  "theta_in": variable(dims, r.theta_in, "rad", "input angle θ_in")}
        if r.pin_force_N.size:
            nd, zb = r.pin_force_N.shape[1:]
            coords["disc"] = variable(("disc",), np.arange(1, nd + 1), "1", "cycloid disc number")
            coords["pin"] = variable(("pin",), np.arange(1, zb + 1), "1", "pin number")
            data["pin_force"] = variable(("position", "disc", "pin"), r.pin_force_N, "N", "pin normal force")
            data["pin_gap"] = variable(("position", "disc", "pin"), r.pin_gap_m, "m", "pin normal gap")
        if r.pin_slice_force_N is not None:
            from rvflex.parts.cycloid_disc import slice_planes

            ns = r.pin_slice_force_N.shape[2]
            coords["slice"] = variable(("slice",), np.arange(1, ns + 1), "1", "contact slice along the face width")
            coords["slice_axial"] = variable(("disc", "slice"), slice_planes(self.scenario.spec, ns), "m",
                                             "axial position of the slice from the discs' mid-plane")
            data["pin_slice_force"] = variable(("position", "disc", "slice", "pin"), r.pin_slice_force_N, "N",
                                               "pin normal force of each contact slice")
        more, axes = spatial_variables(r, "position")
        data.update(more)
        coords.update(axes)
        m = self.metrics
        extra = {}
        tilt = self.scenario.tilt
        if tilt is not None:
            # the pair-alone tilt; the spatial model's solved one is the variable carrier_tilt
            pair = "pair_" if more else ""
            extra = {**{k: float(v) for k, v in dc.asdict(tilt.load).items()},
                     f"{pair}carrier_tilt_rad": list(tilt.tilt_rad), f"{pair}carrier_shift_m": list(tilt.shift_m)}
        attrs = scenario_attrs(self.scenario, te_pp_arcsec=m.te_pp_arcsec, te_min_arcsec=m.te_min_arcsec,
                               te_max_arcsec=m.te_max_arcsec, mean_windup_arcsec=m.mean_windup_arcsec,
                               output_torque_Nm=float(r.torque_out_Nm), ratio=float(r.ratio), **extra)
        return xr.Dataset(data, coords=coords, attrs=attrs)

    def pin_end_loads(self) -> dict | None:
        """The load along the pins' length (a run with the contact in slices; None otherwise).

        Returns
        -------
        dict or None
            ``axial_m`` (discs, slices): each slice's axial position (m); ``line_load_N_m`` (discs, slices): the
            largest line load of each slice over the run's positions and pins (N/m); ``end_line_load_N_m``
            (discs, 2): the largest line load at each face of each disc (−z, +z), extrapolated linearly from the
            two outer slices to the face (N/m); ``mid_line_load_N_m`` (discs,): the largest of the mean over the
            face width (N/m); ``end_ratio`` (discs,): the +z over the −z face's largest line load.
        """
        from rvflex.parts.cycloid_disc import face_line_loads, slice_line_loads, slice_planes

        f = self.raw.pin_slice_force_N
        if f is None:
            return None
        q = slice_line_loads(self.scenario.spec, f)  # N/m
        lo, hi = face_line_loads(q)
        ends = np.stack([lo.max(axis=(0, 2)), hi.max(axis=(0, 2))], axis=1)
        return {"axial_m": slice_planes(self.scenario.spec, f.shape[2]), "line_load_N_m": q.max(axis=(0, 3)),
                "end_line_load_N_m": ends, "mid_line_load_N_m": q.mean(axis=2).max(axis=(0, 2)),
                "end_ratio": ends[:, 1] / ends[:, 0]}

    def plot_pin_loads(self, ax=None):
        """The load along the pins' length, per disc: the line load (N/mm) of each contact slice against its axial
        position (mm) for the pin and position of the disc's largest pin force (solid), and the largest of each
        slice over the whole run (dashed); the faces' values extrapolated from the two outer slices.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on; None draws on a new Figure's axes (pyplot and the backend untouched).

        Returns
        -------
        matplotlib.axes.Axes
            The axes drawn on.
        """
        loads = self.pin_end_loads()
        if loads is None:
            raise SpecError("plot_pin_loads", self.scenario.options.face_slices,
                            "needs the contact in slices along the face width (ModelOptions(face_slices ≥ 2))")
        from rvflex.parts.cycloid_disc import face_line_loads, slice_line_loads

        ax = new_axes(ax, figsize=(7, 4.2))
        sc = self.scenario
        b = sc.spec.cycloid.disc_thickness_m
        f = slice_line_loads(sc.spec, self.raw.pin_slice_force_N)

        def faces(z, q):
            mid = z.mean()
            lo, hi = face_line_loads(q, axis=0)
            return (np.concatenate([[mid - b / 2], z, [mid + b / 2]]) * 1e3, np.concatenate([[lo], q, [hi]]) / 1e3)

        for d, z in enumerate(loads["axial_m"]):
            step, pin = np.unravel_index(np.argmax(self.raw.pin_force_N[:, d]), self.raw.pin_force_N[:, d].shape)
            line = ax.plot(*faces(z, f[step, d, :, pin]), "-o", ms=4, lw=1.4,
                           label=f"disc {d + 1}, pin {pin + 1} at its largest load")[0]
            ax.plot(*faces(z, loads["line_load_N_m"][d]), "--", lw=0.9, color=line.get_color(),
                    label=f"disc {d + 1}, each slice's largest over the run")
        load = sc.output_load
        moment = f", moment {load.moment_Nm:g} N·m" if load is not None and load.moment_Nm else ", no moment"
        ax.set_xlabel("axial position from the discs' mid-plane (mm)")
        ax.set_ylabel("line load on the pin (N/mm)")
        ax.set_title(f"load along the pins: {sc.load_Nm:g} N·m{moment}")
        ax.set_ylim(bottom=0.0)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        return ax

    def to_dataframe(self):
        """One row per position: ``position_rad``, ``theta_in_rad``, ``theta_out_rad``, ``te_arcsec``.

        Returns
        -------
        pandas.DataFrame
            The table, the unit in each column name.
        """
        return super().to_dataframe()

    def plot(self, ax=None, *, label: str | None = None):
        """TE (arcsec) against the output angle (°) with the mean wind-up, on ``ax`` or a new
        Figure's axes; the curve's ``label`` defaults to the model's fidelity. Returns the axes.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on; None draws on a new Figure's axes (pyplot and the backend untouched).
        label : str, optional
            The curve's label; None: the model's fidelity.

        Returns
        -------
        matplotlib.axes.Axes
            The axes drawn on.
        """
        ax = new_axes(ax)
        r, m, sc = self.raw, self.metrics, self.scenario
        ax.plot(np.degrees(r.theta_in / r.ratio), r.te_rad * ARCSEC_PER_RAD, lw=1.0,
                label=sc.options.fidelity if label is None else label)
        ax.axhline(m.mean_windup_arcsec, color="0.5", ls="--", lw=0.8, label=f"mean wind-up {m.mean_windup_arcsec:.1f}″")
        ax.set_xlabel("output angle (°)")
        ax.set_ylabel("TE = θ_out − θ_in/i (arcsec)")
        direction = "forward" if sc.direction > 0 else "reverse"
        ax.set_title(f"{sc.spec.name}: loaded TE at {sc.load_Nm:g} N·m, {direction}, {sc.mode}, "
                     f"peak-to-peak {m.te_pp_arcsec:.2f}″")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        return ax

    def plot_orders(self, ax=None):
        """The order spectrum (amplitude in arcsec per order of the output revolution).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on; None draws on a new Figure's axes (pyplot and the backend untouched).

        Returns
        -------
        matplotlib.axes.Axes
            The axes drawn on.
        """
        ax = new_axes(ax)
        sc = self.scenario
        orders, amp = order_spectrum(self.raw.te_rad, sc.revolutions)
        keep = (orders > 0) & (orders <= max(3 * sc.spec.cycloid.pin_count, 10))
        ax.bar(orders[keep], amp[keep], width=0.8 / sc.revolutions)
        ax.set_xlabel("order (per output revolution)")
        ax.set_ylabel("amplitude (arcsec)")
        ax.set_title("order spectrum")
        ax.grid(alpha=0.3)
        return ax

    def plot_load_sharing(self, ax=None, position: int = 0):
        """Pin normal forces (N) of each disc at ``position`` (quasi-static runs).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on; None draws on a new Figure's axes (pyplot and the backend untouched).
        position : int, optional
            Index of the position drawn.

        Returns
        -------
        matplotlib.axes.Axes
            The axes drawn on.
        """
        f = self.raw.pin_force_N
        if f.size == 0:
            raise SpecError("plot_load_sharing", self.scenario.mode, "a dynamic run records the angles only")
        ax = new_axes(ax, figsize=(7, 4.2))
        zb = f.shape[2]
        for d in range(f.shape[1]):
            ax.bar(np.arange(zb) + 0.4 * d - 0.2, f[position, d], width=0.4, label=f"disc {d + 1}")
        ax.set_xlabel("pin number")
        ax.set_ylabel("normal force (N)")
        where = "the first position" if position == 0 else f"position {position}"
        ax.set_title(f"pin load sharing at {where} ({self.scenario.load_Nm:g} N·m)")
        ax.legend()
        ax.grid(alpha=0.3)
        return ax

    def files(self, out: Path) -> list[Path]:
        """te.csv (per step), te.png (TE vs output angle with the order spectrum) and
        load_sharing.png (pin forces at the first position; quasi-static runs).

        Parameters
        ----------
        out : pathlib.Path
            An existing directory.

        Returns
        -------
        list of pathlib.Path
            The files written.
        """
        return write_te_outputs(out, self.raw, self.metrics, self.scenario)


def perfect_spec(spec: ReducerSpec) -> ReducerSpec:
    """The theoretical reducer: no tooth modification, no gear backlash, no bearing clearance."""
    c, b = spec.cycloid, spec.bearings
    return dc.replace(
        spec,
        cycloid=dc.replace(c, modification=dc.replace(c.modification, moved_m=0.0, equidistant_m=0.0, tip_amount_m=0.0,
                                                      root_amount_m=0.0, compensation_m=0.0)),
        input_stage=dc.replace(spec.input_stage, backlash_m=0.0),
        bearings=dc.replace(b, crank_support=dc.replace(b.crank_support, clearance_m=0.0),
                            eccentric=dc.replace(b.eccentric, clearance_m=0.0), main=dc.replace(b.main, clearance_m=0.0)))


def run_loaded_te(scenario: LoadedTE, progress=None, *, model: ReducerModel | None = None
                  ) -> tuple[QuasiStaticResult, TEMetrics]:
    """Loaded TE over whole output revolutions, quasi-static or dynamic (the constant-speed part
    after the ramp, resampled at ``positions_per_rev``), on ``model`` (None: built here)."""
    model = check_model(scenario, model)
    n = scenario.n_positions
    if scenario.mode == "dynamic":
        ramp = 0.2
        dyn = dynamic(model, scenario.speed_out_rpm, scenario.revolutions, scenario.load_Nm, step_s=scenario.step_s,
                      ramp_s=ramp)
        th_start = float(np.interp(ramp, dyn.time_s, dyn.theta_in))  # constant speed from here on
        theta = th_start + np.linspace(0.0, 2 * math.pi * scenario.revolutions * model.ratio, n, endpoint=False)
        te = np.interp(theta, dyn.theta_in, dyn.te_rad)
        res = QuasiStaticResult(theta, te + theta / model.ratio, te, np.zeros((n, 0, 0)), np.zeros((n, 0, 0)),
                                scenario.load_Nm, model.ratio, dyn.wall_s)
        if progress is not None:
            progress(n, n)
        return res, te_metrics(res.te_rad, scenario.revolutions)
    theta = np.linspace(0.0, 2 * math.pi * scenario.revolutions * model.ratio, n, endpoint=False)
    if scenario.direction < 0:
        theta = -theta
    res = quasi_static(model, theta, scenario.load_Nm, progress=progress, output_load=scenario.solver_load)
    return res, te_metrics(res.te_rad, scenario.revolutions)


def write_te_outputs(out: Path, res: QuasiStaticResult, metrics: TEMetrics, scenario: LoadedTE) -> list[Path]:
    """Write te.csv (per step), te.png (TE vs output angle with the order spectrum) and
    load_sharing.png (pin forces at the first position) to ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    result = LoadedTEResult(scenario, metrics, res.wall_s, res)
    te_as = res.te_rad * ARCSEC_PER_RAD
    out_deg = np.degrees(res.theta_in / res.ratio)
    csv = out / "te.csv"
    np.savetxt(csv, np.column_stack([res.theta_in, res.theta_out, out_deg, te_as]), delimiter=",",
               header="theta_in_rad,theta_out_rad,output_angle_deg,te_arcsec", comments="", fmt="%.12g")
    fig = new_figure(figsize=(13, 4.6), layout="constrained")
    a0, a1 = fig.subplots(1, 2, width_ratios=(2.2, 1))
    result.plot(a0, label="_te")  # one curve: only the wind-up line in the legend
    result.plot_orders(a1)
    te_png = out / "te.png"
    fig.savefig(te_png, dpi=120)
    if res.pin_force_N.size == 0:  # dynamic runs record the angles only
        return [csv, te_png]
    ax = result.plot_load_sharing()
    share_png = out / "load_sharing.png"
    ax.figure.savefig(share_png, dpi=120)
    if res.pin_slice_force_N is None:
        return [csv, te_png, share_png]
    ax = result.plot_pin_loads()
    pins_png = out / "pin_loads.png"
    ax.figure.savefig(pins_png, dpi=120)
    return [csv, te_png, share_png, pins_png]


def seed001_errors(spec: ReducerSpec, seed: int = 1) -> ErrorSpec:
    """Seed 001 Table 2 errors on ``spec`` (µm values of the paper in SI). What the paper leaves
    open is chosen as stated: the ±8 µm pin-hole radial position error is a tolerance band,
    drawn uniformly per pin (``seed``); eccentricity-like errors at phase 0; pin diameter −8 µm
    (radius −4 µm); the 12 µm radial clearance on every eccentric (disc) bearing, where seed 001
    puts its clearance bushing."""
    nc, nd, zb = spec.cranks.count, spec.cycloid.disc_count, spec.cycloid.pin_count
    um = 1e-6
    pins = np.random.default_rng(seed).uniform(-8 * um, 8 * um, zb)
    return ErrorSpec(
        sun_base_eccentricity_m=10 * um, sun_runout_m=5 * um,
        planet_base_eccentricity_m=(10 * um,) * nc, planet_base_eccentricity_phase_rad=(0.0,) * nc,
        pin_radial_m=tuple(float(x) for x in pins), pin_radius_error_m=-4 * um,
        carrier_bore_eccentricity_m=(5 * um,) * nc, carrier_bore_eccentricity_phase_rad=(0.0,) * nc,
        carrier_runout_m=5 * um, pin_circle_radius_error_m=10 * um,
        crank_eccentricity_error_m=tuple((-2 * um, 2 * um)[k % 2] for k in range(nc)),
        eccentric_bearing_clearance_m=(12 * um,) * (nc * nd),
    )


if __name__ == "__main__":
    import sys

    from rvflex import catalog

    spec = catalog.load("rv40e")
    result = LoadedTE(spec, seed001_errors(spec), spec.rated_torque_Nm).run()
    paths = result.write(sys.argv[1] if len(sys.argv) > 1 else "out")
    met = result.metrics
    print(f"TE peak-to-peak {met.te_pp_arcsec:.2f}″, mean wind-up {met.mean_windup_arcsec:.1f}″; wrote",
          ", ".join(map(str, paths)))

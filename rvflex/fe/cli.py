"""The FE commands of ``rvflex``: ``rvflex reduce``, and ``rvflex units`` (the unit matrix at every
fidelity, :mod:`rvflex.scenarios.unit_matrix`)."""

from __future__ import annotations

import argparse
import json
import sys
import time

from rvflex import catalog
from rvflex.choices import FEPart, choices
from rvflex.fe.reduce import DEFAULTS, DISC_FLANK_BASIS, STEPS, reduce_part
from rvflex.io import emit
from rvflex.spec import SpecError


def register(sub: argparse._SubParsersAction) -> None:
    """Add the FE sub-commands to the ``rvflex`` parser."""
    disc, carrier = DEFAULTS["disc"], DEFAULTS["carrier"]
    p = sub.add_parser("reduce", help="Craig–Bampton-reduce a flexible part (cached on disk)",
                       description="Mesh a part with netgen, reduce it (Hurty–Craig–Bampton; disc: rigid RBE2 "
                                   "bores; carrier: output face the reference, distributing RBE3 crank seats; housing: "
                                   "mount face clamped, the pin seats distributing) and "
                                   "report its size, eigenfrequencies and the reduced-vs-full static error at "
                                   "rated load. JSON keys: n_nodes, n_modes, freqs_hz, static_error_pct "
                                   "({flank, interface, max}, %), wall_s, cached. Defaults: the one reduction per "
                                   "part that the models of --fidelity flexible / flexible-carrier use "
                                   "(rvflex.fe.reduce.DEFAULTS, the ModelOptions presets' DISC_FE and CARRIER_FE): "
                                   f"disc {_describe(disc, 'disc')}; carrier {_describe(carrier, 'carrier')}. The disc basis the "
                                   "static flank check is about, with flank attachment modes "
                                   f"(rvflex.fe.reduce.DISC_FLANK_BASIS): --modes {DISC_FLANK_BASIS.n_modes} "
                                   f"--attach {DISC_FLANK_BASIS.attach_per_tooth}.")
    p.add_argument("--reducer", required=True, help="catalogue name (rv40e) or spec TOML path")
    p.add_argument("--part", required=True, choices=choices(FEPart))
    p.add_argument("--disc", type=int, default=0, metavar="D",
                   help="with --part disc: the disc whose FE body to reduce (default 0); a disc that is not disc 0 "
                        "turned by a symmetry of the layout (three cranks, discs 180° apart) has its own reduction, "
                        "which the flexible models compute on first use")
    p.add_argument("--json", help="write the result document here")
    p.add_argument("--maxh", type=float, metavar="M", help=f"largest element size, m (default {disc.maxh_m:g} for the disc, "
                                              f"{carrier.maxh_m:g} for the carrier)")
    p.add_argument("--modes", type=int, metavar="N", help=f"fixed-interface eigenmodes (default {disc.n_modes} for the disc, "
                                             f"{carrier.n_modes} for the carrier)")
    p.add_argument("--attach", type=int, dest="attach_per_tooth", metavar="N",
                   help=f"disc only: flank attachment patches per tooth, normal and tangential loads (default "
                        f"{disc.attach_per_tooth})")
    p.add_argument("--order", type=int, choices=(1, 2), dest="mesh_order",
                   help=f"tet order (default {disc.mesh_order} for the disc, {carrier.mesh_order} for the carrier)")
    p.add_argument("--no-cache", action="store_true", help="compute afresh and do not write the cache")
    p.add_argument("--cache-dir", help="cache directory (default $RVFLEX_CACHE_DIR or ~/.cache/rvflex)")
    p.add_argument("--out", help=argparse.SUPPRESS)
    p.set_defaults(func=_cmd_reduce)
    from rvflex.scenarios import unit_matrix  # every unit at every fidelity (flexible discs and carrier included)

    unit_matrix.register(sub)


def _describe(s, part: FEPart) -> str:
    """The settings of one part in words, for the help text."""
    words = [f"maxh {s.maxh_m * 1e3:g} mm", f"{s.n_modes} eigenmodes", f"order-{s.mesh_order} tets",
             f"curvature safety {s.curvature_safety:g}"]
    if part == "carrier":
        words.append("distributing (RBE3) crank seats, 6 seat attachment modes each" if s.seat_coupling == "rbe3"
                     else "rigid (RBE2) crank seats")
    elif part == "housing":
        words.append("mount face clamped, 2 in-plane attachment modes per pin seat")
    elif s.attach_per_tooth:
        words.append(f"{s.attach_per_tooth} attachment modes per tooth"
                     f"{' (normal and tangential)' if s.attach_tangential else ''}, {s.patch_shape} patches of "
                     f"half-width {s.patch_half_width_m * 1e3:g} mm")
    else:
        words.append(f"no flank attachment modes (flank rows on {s.patch_shape} patches of half-width "
                     f"{s.patch_half_width_m * 1e3:g} mm)")
    return ", ".join(words)


def reduce_settings(args: argparse.Namespace) -> dict:
    """The :func:`reduce_part` settings the ``rvflex reduce`` flags give (omitted flags: the
    defaults, :data:`rvflex.fe.reduce.DEFAULTS`); ``--attach`` applies to the disc only."""
    if args.attach_per_tooth is not None and args.part != "disc":
        raise SpecError("--attach", args.attach_per_tooth, "flank attachment modes apply to --part disc only")
    given = {"maxh_m": args.maxh, "n_modes": args.modes, "attach_per_tooth": args.attach_per_tooth,
             "mesh_order": args.mesh_order}
    return {k: v for k, v in given.items() if v is not None}


def _cmd_reduce(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    spec = catalog.resolve(args.reducer)
    settings = reduce_settings(args)
    if args.disc:
        from rvflex.parts.cycloid_disc import fe_disc_placements, fe_disc_spec

        if args.part != "disc" or not 0 <= args.disc < spec.cycloid.disc_count:
            raise SpecError("--disc", args.disc, f"applies to --part disc, 0 to {spec.cycloid.disc_count - 1}")
        spec = fe_disc_spec(spec, fe_disc_placements(spec)[args.disc].holes_turn_rad)
    t0 = time.perf_counter()
    with tqdm(total=len(STEPS), desc=f"reduce {args.part}", unit="step", file=sys.stderr, mininterval=0.2,
              bar_format="{desc}: {n}/{total} {postfix} [{elapsed}]") as bar:
        def progress(step: str) -> None:
            bar.set_postfix_str(step)
            bar.update(1)

        rp = reduce_part(spec, args.part, cache_dir=args.cache_dir, use_cache=not args.no_cache, progress=progress,
                         **settings)
    wall = time.perf_counter() - t0
    chk = rp.check
    doc = {
        "n_nodes": rp.n_nodes,
        "n_modes": rp.n_modes,
        "freqs_hz": [round(float(f), 3) for f in rp.freqs_hz],
        "static_error_pct": {"flank": chk.flank_pct, "interface": chk.interface_pct, "max": chk.max_pct},
        "wall_s": round(wall, 3),
        "cached": bool(rp.meta.get("cached", False)),
    }
    print(json.dumps(doc, indent=2))
    print(f"{args.part}: {rp.n_nodes} nodes, {rp.n_modes} modes ({rp.n_static} static, {rp.n_eigen} eigen, "
          f"{rp.n_attach} attachment); static error flank {chk.flank_pct:.2f} %, interface "
          f"{chk.interface_pct:.2g} % ({chk.case}); {'cached' if doc['cached'] else 'computed'} in {wall:.1f} s",
          file=sys.stderr)
    return emit(args, doc, lambda out: [])

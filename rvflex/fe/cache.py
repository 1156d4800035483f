"""On-disk cache of reduced parts, keyed by a content hash of everything the numbers depend on.

Directory: ``cache_dir`` argument, else ``$RVFLEX_CACHE_DIR``, else ``~/.cache/rvflex``
(files ``fe-<key>.rvfe``). A file is one header line (JSON: format, key, payload length,
SHA-256 of the payload) followed by the payload (an ``.npz`` archive, no pickles). It is
written to a unique temporary file in the same directory and moved into place with
``os.replace``, so readers see either the old file or a complete new one, and concurrent
workers writing the same key each replace it with a complete, identical file. A file whose
header, length or checksum does not match is deleted and rebuilt, never loaded.
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import json
import os
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from rvflex.choices import FEPart
from rvflex.fe import geometry
from rvflex.fe.types import FlankRows, Interface, PartSettings, ReducedPart, StaticCheck
from rvflex.io import write_atomic
from rvflex.spec import ReducerSpec

__all__ = ["FORMAT", "cache_root", "key_for", "load", "path_for", "store"]

FORMAT = "rvflex-fe-cache-1"


def cache_root(cache_dir: str | os.PathLike | None = None) -> Path:
    """The cache directory (not created)."""
    if cache_dir is not None:
        return Path(cache_dir)
    env = os.environ.get("RVFLEX_CACHE_DIR")
    return Path(env) if env else Path.home() / ".cache" / "rvflex"


def _inputs(spec: ReducerSpec, part: FEPart) -> dict:
    """The spec fields the part's geometry and material depend on (and nothing else, so a
    sweep over bearing stiffness or errors reuses the reduction)."""
    cy, cr, ca = spec.cycloid, spec.cranks, spec.carrier
    crank = {"count": cr.count, "r": cr.crank_circle_radius_m, "angles": list(cr.angles_rad),
             "bore": cr.disc_bore_radius_m}
    if part == "disc":
        return {"cycloid": {k: v for k, v in dataclasses.asdict(cy).items() if k not in ("disc_count", "disc_phase_rad")},
                "cranks": crank,
                "pillars": {"n": ca.pillar_count, "r": ca.pillar_circle_radius_m, "hole": ca.disc_pillar_hole_radius_m},
                "material": dataclasses.asdict(spec.materials.gears_cranks_discs)}
    if part == "housing":
        return {"pins": {"n": cy.pin_count, "circle": cy.pin_circle_radius_m, "r": cy.pin_radius_m},
                "stack": {"thickness": cy.disc_thickness_m, "axial": list(cr.eccentric_axial_positions_m)},
                "wall": geometry.HOUSING_WALL_FRACTION, "material": dataclasses.asdict(spec.materials.pin_housing)}
    return {"carrier": dataclasses.asdict(ca), "cranks": {**crank, "axial": list(cr.eccentric_axial_positions_m)},
            "disc": {"thickness": cy.disc_thickness_m, "hole": cy.disc_center_hole_radius_m},
            "material": dataclasses.asdict(spec.materials.carriers)}


def key_for(spec: ReducerSpec, part: FEPart, settings, code_version: str) -> str:
    """Content hash (hex, 24 chars) of geometry, material, mesh/reduction settings and code version."""
    # versions from the metadata: importing exudyn/ngsolve here would slow every warm load
    from importlib.metadata import version

    sett = dataclasses.asdict(settings)
    if part != "carrier":
        sett.pop("seat_coupling", None)  # a carrier setting: disc keys stay what they were
    doc = {"part": part, "inputs": _inputs(spec, part), "settings": sett,
           "code": code_version, "samples_per_tooth": geometry.SAMPLES_PER_TOOTH, "axial_gap": geometry.AXIAL_GAP_M,
           "exudyn": version("exudyn"), "ngsolve": version("ngsolve")}
    return hashlib.sha256(json.dumps(doc, sort_keys=True, default=float).encode()).hexdigest()[:24]


def path_for(key: str, cache_dir: str | os.PathLike | None = None) -> Path:
    """The cache file of ``key``."""
    return cache_root(cache_dir) / f"fe-{key}.rvfe"


# --------------------------------------------------------------------------- (de)serialisation


def _to_arrays(rp) -> dict[str, np.ndarray]:
    fem = rp.fem
    M, K = fem.GetMassMatrix(sparse=True).tocsr(), fem.GetStiffnessMatrix(sparse=True).tocsr()
    surf = fem.surface[0]
    a = {
        "nodes": rp.node_positions_m, "tets": np.asarray(fem.elements[0]["Tet4"]),
        "trigs": np.asarray(surf["Trigs"]), "trigs6": np.asarray(surf.get("Trigs6", np.zeros((0, 6), int))),
        "M_data": M.data, "M_indices": M.indices, "M_indptr": M.indptr,
        "K_data": K.data, "K_indices": K.indices, "K_indptr": K.indptr,
        "modes": rp.mode_basis, "eigenvalues": np.asarray(fem.eigenValues, float),
        "freqs_hz": rp.freqs_hz, "mass_reduced": rp.mass_reduced, "stiffness_reduced": rp.stiffness_reduced,
    }
    ns_names = [ns["Name"] for ns in fem.nodeSets]
    for i, ns in enumerate(fem.nodeSets):
        a[f"ns{i}_nodes"] = np.asarray(ns["NodeNumbers"], dtype=np.int64)
        a[f"ns{i}_weights"] = np.asarray(ns["NodeWeights"], float)
    for i, itf in enumerate(rp.interfaces):
        a[f"itf{i}_nodes"], a[f"itf{i}_weights"], a[f"itf{i}_centre"] = itf.nodes, itf.weights, itf.centre_m
    if rp.flank is not None:
        a["flank_t"], a["flank_rows"] = rp.flank.t_grid, rp.flank.rows
    meta = {"part": rp.part, "key": rp.key, "settings": dataclasses.asdict(rp.settings),
            "interfaces": [i.name for i in rp.interfaces], "nodesets": ns_names,
            "n_static": rp.n_static, "n_eigen": rp.n_eigen, "n_attach": rp.n_attach,
            "check": dataclasses.asdict(rp.check), "wall_s": rp.wall_s,
            "patch_half_width_m": rp.flank.patch_half_width_m if rp.flank is not None else None,
            "meta": {k: v for k, v in rp.meta.items() if k != "cached"}}
    a["meta_json"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    return a


def _from_arrays(a) -> object:
    from exudyn.FEM import FEMinterface

    meta = json.loads(bytes(a["meta_json"]).decode())
    nn = a["nodes"].shape[0]
    fem = FEMinterface()
    fem.nodes = {"Position": a["nodes"]}
    fem.elements = [{"Name": "NGsolve", "Tet4": a["tets"]}]
    fem.massMatrix = sp.csr_matrix((a["M_data"], a["M_indices"], a["M_indptr"]), shape=(3 * nn, 3 * nn))
    fem.stiffnessMatrix = sp.csr_matrix((a["K_data"], a["K_indices"], a["K_indptr"]), shape=(3 * nn, 3 * nn))
    surf = {"Name": "meshSurface", "Trigs": a["trigs"]}
    if a["trigs6"].size:
        surf["Trigs6"] = a["trigs6"]
    fem.surface = [surf]
    fem.nodeSets = [{"Name": name, "NodeNumbers": a[f"ns{i}_nodes"], "NodeWeights": a[f"ns{i}_weights"],
                     "type": "boundary"} for i, name in enumerate(meta["nodesets"])]
    fem.modeBasis = {"matrix": a["modes"], "type": "HCBmodes"}
    fem.eigenValues = a["eigenvalues"]
    fem.metaData = {"source": "NGsolve", "rvflex_key": meta["key"]}
    itfs = tuple(Interface(name, a[f"itf{i}_nodes"], a[f"itf{i}_weights"], a[f"itf{i}_centre"])
                 for i, name in enumerate(meta["interfaces"]))
    flank = FlankRows(a["flank_t"], a["flank_rows"], meta["patch_half_width_m"]) if "flank_t" in a else None
    return ReducedPart(meta["part"], PartSettings(**meta["settings"]), meta["key"], fem, a["nodes"], itfs,
                       meta["n_static"], meta["n_eigen"], meta["n_attach"], a["freqs_hz"], a["mass_reduced"],
                       a["stiffness_reduced"], flank, StaticCheck(**{**meta["check"], "flank_full_by_angle_m": tuple(meta["check"].get("flank_full_by_angle_m", ()))}), meta["wall_s"],
                       {**meta["meta"], "cached": True})


# --------------------------------------------------------------------------- file I/O


def store(rp, cache_dir: str | os.PathLike | None = None) -> Path:
    """Write ``rp`` atomically (unique temporary file + ``os.replace``); returns the path."""
    buf = io.BytesIO()
    np.savez(buf, **_to_arrays(rp))
    payload = buf.getvalue()
    header = json.dumps({"format": FORMAT, "key": rp.key, "length": len(payload),
                         "sha256": hashlib.sha256(payload).hexdigest()}).encode() + b"\n"
    return write_atomic(path_for(rp.key, cache_dir), header + payload, fsync=True)


def _read_valid(path: Path, key: str) -> bytes | None:
    """The payload of a complete, uncorrupted file of ``key``, else None."""
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        return None
    nl = raw.find(b"\n")
    if nl < 0 or nl > 4096:
        return None
    try:
        head = json.loads(raw[:nl])
    except ValueError:
        return None
    payload = raw[nl + 1:]
    if (not isinstance(head, dict) or head.get("format") != FORMAT or head.get("key") != key
            or head.get("length") != len(payload) or head.get("sha256") != hashlib.sha256(payload).hexdigest()):
        return None
    return payload


def load(key: str, cache_dir: str | os.PathLike | None = None):
    """The cached :class:`~rvflex.fe.types.ReducedPart` of ``key``, or None (missing, or
    corrupt/partial: then the bad file is removed so that it is rebuilt)."""
    path = path_for(key, cache_dir)
    if not path.exists():
        return None
    payload = _read_valid(path, key)
    if payload is None:
        path.unlink(missing_ok=True)
        return None
    with np.load(io.BytesIO(payload), allow_pickle=False) as z:
        return _from_arrays({k: z[k] for k in z.files})

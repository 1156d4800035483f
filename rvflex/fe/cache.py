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
import math
import os
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from rvflex.choices import FEPart
from rvflex.fe import geometry
from rvflex.fe.types import FlankRows, Interface, PartSettings, ReducedPart, StaticCheck
from rvflex.io import write_atomic
from rvflex.spec import ReducerSpec

__all__ = ["FORMAT", "cache_root", "key_for", "load", "load_at_modulus", "modulus", "modulus_free_key", "note_modulus",
           "path_for", "store"]

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


def _doc(spec: ReducerSpec, part: FEPart, settings, code_version: str) -> dict:
    # versions from the metadata: importing exudyn/ngsolve here would slow every warm load
    from importlib.metadata import version

    sett = dataclasses.asdict(settings)
    if part != "carrier":
        sett.pop("seat_coupling", None)  # a carrier setting: disc keys stay what they were
    return {"part": part, "inputs": _inputs(spec, part), "settings": sett,
            "code": code_version, "samples_per_tooth": geometry.SAMPLES_PER_TOOTH, "axial_gap": geometry.AXIAL_GAP_M,
            "exudyn": version("exudyn"), "ngsolve": version("ngsolve")}


def _hash(doc: dict) -> str:
    return hashlib.sha256(json.dumps(doc, sort_keys=True, default=float).encode()).hexdigest()[:24]


def key_for(spec: ReducerSpec, part: FEPart, settings, code_version: str) -> str:
    """Content hash (hex, 24 chars) of geometry, material, mesh/reduction settings and code version."""
    return _hash(_doc(spec, part, settings, code_version))


# --------------------------------------------------------------------------- the same part at another modulus
# Linear elasticity at a fixed Poisson ratio: the stiffness matrix is proportional to Young's modulus E and the
# mass matrix does not depend on it, so the Craig–Bampton basis (constraint modes K_ii⁻¹K_ib, the fixed-interface
# eigenvectors, the attachment modes' span and the Ritz step) is the same at every E, and the reduced stiffness,
# the eigenvalues ω² and the full stiffness scale by E/E₀ (frequencies by its square root, the static check's
# displacements by its inverse). A diagnosis calibrates the contact stiffness through the moduli, so each
# calibrated value would otherwise be a new mesh and reduction (about 17 s and 50-120 MB for the RV-40E disc).


def modulus(spec: ReducerSpec, part: FEPart) -> float:
    """Young's modulus (Pa) of the material ``part`` is made of."""
    return float(_inputs(spec, part)["material"]["youngs_modulus_Pa"])


def modulus_free_key(spec: ReducerSpec, part: FEPart, settings, code_version: str) -> str:
    """:func:`key_for` of everything but Young's modulus (the parts that differ only in it share it)."""
    doc = _doc(spec, part, settings, code_version)
    doc["inputs"]["material"].pop("youngs_modulus_Pa")
    return _hash(doc)


def _sibling_path(free_key: str, cache_dir) -> Path:
    return cache_root(cache_dir) / f"fe-E-{free_key}.json"


def note_modulus(free_key: str, key: str, youngs_modulus_Pa: float, cache_dir=None) -> None:
    """Record that the cached reduction ``key`` is the part of ``free_key`` at ``youngs_modulus_Pa``
    (one small JSON file; the first reduction recorded stays the reference)."""
    path = _sibling_path(free_key, cache_dir)
    if not path.exists():
        write_atomic(path, json.dumps({"key": key, "youngs_modulus_Pa": youngs_modulus_Pa}).encode())


def load_at_modulus(free_key: str, key: str, youngs_modulus_Pa: float, part: FEPart, cache_dir=None):
    """The cached reduction of the same part at another modulus (:func:`note_modulus`), scaled to
    ``youngs_modulus_Pa`` and named ``key`` (not written: it is made again from the reference in a
    fraction of a second); None when there is none."""
    note = _sibling_path(free_key, cache_dir)
    try:
        ref = json.loads(note.read_text())
        a = _arrays(path_for(ref["key"], cache_dir), ref["key"])
        e0 = float(ref["youngs_modulus_Pa"])
    except FileNotFoundError:
        return None
    except (OSError, ValueError, KeyError, TypeError):
        a, e0 = None, 0.0
    if a is None or not e0 > 0:  # a note whose reduction is gone or damaged: the next one built is noted
        note.unlink(missing_ok=True)
        return None
    f = youngs_modulus_Pa / e0
    for name in ("K_data", "eigenvalues", "stiffness_reduced"):
        a[name] = a[name] * f
    a["freqs_hz"] = a["freqs_hz"] * math.sqrt(f)
    meta = json.loads(bytes(a["meta_json"]).decode())
    meta["key"] = key
    chk = meta["check"]
    chk["flank_full_m"] = chk["flank_full_m"] / f
    chk["flank_full_by_angle_m"] = [v / f for v in chk.get("flank_full_by_angle_m", ())]
    if part != "disc":  # a seat displacement (m); the disc's is a bore reaction (N), set by the load
        chk["interface_full"] = chk["interface_full"] / f
    if "ritz_freqs_hz" in meta["meta"]:
        meta["meta"]["ritz_freqs_hz"] = [v * math.sqrt(f) for v in meta["meta"]["ritz_freqs_hz"]]
    meta["meta"]["scaled_from"] = {"key": ref["key"], "modulus_factor": f}
    a["meta_json"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    return _from_arrays(a)


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


_READ: dict = {}
"""The arrays of the cache files read last in this process, by (path, key, size, mtime) (at most
:data:`READ_KEPT`). Every elastic model build loads its reductions: read, checked and unpacked
from disk that was 0.4 s of a 1 s flexible RV-40E run, and a diagnosis builds hundreds (the same
disc file each time, at other moduli through :func:`load_at_modulus`). A rewritten file has
another size or time, so it is read again; each load gets copies, so no caller shares an array."""
READ_KEPT = 2


def _arrays(path: Path, key: str) -> dict[str, np.ndarray] | None:
    """The arrays of the valid cache file ``path`` of ``key`` (copies), or None (missing, corrupt)."""
    try:
        st = path.stat()
    except FileNotFoundError:
        return None
    tag = (str(path), key, st.st_size, st.st_mtime_ns)
    a = _READ.get(tag)
    if a is None:
        payload = _read_valid(path, key)
        if payload is None:
            return None
        with np.load(io.BytesIO(payload), allow_pickle=False) as z:
            a = {k: z[k] for k in z.files}
        _READ[tag] = a
        while len(_READ) > READ_KEPT:
            del _READ[next(iter(_READ))]  # the oldest read
    return {k: v.copy() for k, v in a.items()}


def load(key: str, cache_dir: str | os.PathLike | None = None):
    """The cached :class:`~rvflex.fe.types.ReducedPart` of ``key``, or None (missing, or
    corrupt/partial: then the bad file is removed so that it is rebuilt)."""
    path = path_for(key, cache_dir)
    if not path.exists():
        return None
    a = _arrays(path, key)
    if a is None:
        path.unlink(missing_ok=True)
        return None
    return _from_arrays(a)

"""Import-layer contract: no import cycle among rvflex modules, no ``_private`` name imported
from another module.

The check walks the AST of every module of the installed package layout (``rvflex/``,
``parts/`` as ``rvflex.parts``, ``scenarios/`` as ``rvflex.scenarios``). Every import counts as
an edge, including imports inside functions and under ``TYPE_CHECKING``: a function-local
import hides a dependency, it does not remove it.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCES = {"rvflex": ROOT / "rvflex", "rvflex.parts": ROOT / "parts", "rvflex.scenarios": ROOT / "scenarios"}


def modules() -> dict[str, Path]:
    """Module name -> source file, for every module of the package."""
    found: dict[str, Path] = {}
    for prefix, base in SOURCES.items():
        for path in sorted(base.rglob("*.py")):
            rel = path.relative_to(base).with_suffix("").parts
            if rel[-1] == "__init__":
                rel = rel[:-1]
            name = ".".join((prefix, *rel))
            if name.startswith("rvflex.") and any(name.startswith(p + ".") or name == p
                                                   for p in SOURCES if p != prefix and p != "rvflex"):
                continue  # e.g. rvflex/parts would shadow the mapped package (there is none; be safe)
            found[name] = path
    return found


def _package(name: str, path: Path) -> str:
    return name if path.name == "__init__.py" else name.rpartition(".")[0]


def imports(name: str, path: Path, known: set[str]) -> list[tuple[str, str | None, int]]:
    """(imported module, imported name or None, line) of every import in one module.

    ``from X import y`` yields module ``X.y`` when that is a module, else module ``X`` and name ``y``.
    """
    out: list[tuple[str, str | None, int]] = []
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.extend((alias.name, None, node.lineno) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = _package(name, path)
                for _ in range(node.level - 1):
                    base = base.rpartition(".")[0]
                mod = f"{base}.{node.module}" if node.module else base
            else:
                mod = node.module or ""
            for alias in node.names:
                sub = f"{mod}.{alias.name}"
                out.append((sub, None, node.lineno) if sub in known else (mod, alias.name, node.lineno))
    return out


def graph() -> tuple[dict[str, set[str]], list[str]]:
    """The import graph among rvflex modules and the private-name imports across modules."""
    mods = modules()
    known = set(mods)
    edges: dict[str, set[str]] = {m: set() for m in mods}
    private: list[str] = []
    for name, path in mods.items():
        for target, imported, line in imports(name, path, known):
            if target not in known:
                continue
            if target != name:
                edges[name].add(target)
            if imported and imported.startswith("_") and not imported.startswith("__") and target != name:
                private.append(f"{name}:{line} imports {target}.{imported}")
            if imported is None and target.rpartition(".")[2].startswith("_") and \
                    target.rpartition(".")[0] != _package(name, path) and target != name:
                # a private module may be imported by its own package only
                private.append(f"{name}:{line} imports private module {target}")
    return edges, private


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(edges[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


def test_no_import_cycles():
    edges, _ = graph()
    found = cycles(edges)
    detail = []
    for comp in found:
        members = set(comp)
        detail.append(" <-> ".join(comp) + "\n    " + "\n    ".join(
            f"{a} -> {b}" for a in comp for b in sorted(edges[a] & members)))
    assert not found, "import cycles among rvflex modules:\n" + "\n".join(detail)


def test_no_private_imports_across_modules():
    _, private = graph()
    assert not private, "private names imported from another module:\n" + "\n".join(private)


# Upward edges that would not (yet) close a cycle but break the layering of docs/architecture.md:
# (importing modules, imported modules, importers exempt, imports exempt), all as module-name prefixes.
PLUMBING = ("rvflex.units", "rvflex.io", "rvflex.numerics", "rvflex.parallel")
LOW = ("rvflex.spec_types", "rvflex.geometry", "rvflex.contact", "rvflex.fe", "rvflex.parts", "rvflex.catalog")
FORBIDDEN = [
    (("rvflex.sweeps",), ("rvflex.scenarios",), (), ()),  # scenarios register with the sweep engine
    (("rvflex",), ("rvflex.cli",), ("rvflex.cli",), ()),  # nothing imports the command
    (LOW, ("rvflex.model", "rvflex.solve", "rvflex.scenarios", "rvflex.sweeps", "rvflex.diagnosis"), ("rvflex.fe.cli",), ()),
    (("rvflex.spec_types", "rvflex.geometry"), ("rvflex.spec", "rvflex.catalog"), (), ()),  # the loader sits above
    (("rvflex.model", "rvflex.solve"), ("rvflex.scenarios", "rvflex.sweeps", "rvflex.diagnosis"), (), ()),
    (("rvflex.solve",), ("rvflex.parts",), (), ()),  # solvers talk to the model; shared numbers: rvflex.numerics
    (PLUMBING + ("rvflex.spec_types",), ("rvflex",), (), PLUMBING),  # plumbing and the spec types at the bottom
    (("rvflex.choices",), ("rvflex",), (), PLUMBING + ("rvflex.spec_types",)),  # the option types, just above them
]


def _under(name: str, prefixes: tuple[str, ...]) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


def test_no_upward_imports():
    edges, _ = graph()
    bad = sorted({f"{src} -> {dst}" for src, targets in edges.items() for dst in targets
                  for froms, tos, src_ok, dst_ok in FORBIDDEN
                  if _under(src, froms) and _under(dst, tos) and not _under(src, src_ok) and not _under(dst, dst_ok)})
    assert not bad, "imports against the layering (docs/architecture.md):\n" + "\n".join(bad)


def test_walker_sees_the_whole_package():
    mods = modules()
    assert {"rvflex.cli", "rvflex.parts.carrier", "rvflex.scenarios.loaded_te", "rvflex.fe.reduce",
            "rvflex.sweeps.executors"} <= set(mods)
    edges, _ = graph()
    assert "rvflex.fe.reduce" in edges["rvflex.model"]  # a function-local import is an edge


# Options that select behaviour are Literal types checked by rvflex.choices.check_choice, never a
# bare ``str``: a dataclass field or a function parameter with one of these names annotated ``str``
# fails. Known exceptions, each with its reason:
OPTION_NAMES = {"mode", "kind", "fidelity", "mismatch", "seat_marker", "seat_coupling", "patch_shape", "executor", "distribution",
                "part"}
BARE_STRING_ALLOWED = {
    "rvflex.spec_types:kind",  # Bearing.kind describes the bearing (checked against BEARING_KINDS), selects no code
}


def bare_string_options() -> set[str]:
    """``module:name`` of every option-named field or parameter annotated plain ``str``."""
    found = set()
    for name, path in modules().items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
                target, annotation = node.target.id, node.annotation
            elif isinstance(node, ast.arg) and node.annotation is not None:
                target, annotation = node.arg, node.annotation
            else:
                continue
            if target in OPTION_NAMES and isinstance(annotation, ast.Name) and annotation.id == "str":
                found.add(f"{name}:{target}")
    return found


def test_options_that_select_behaviour_are_literal_types():
    found = bare_string_options()
    assert not found - BARE_STRING_ALLOWED, "bare str options (type them with rvflex.choices):\n" + "\n".join(
        sorted(found - BARE_STRING_ALLOWED))
    assert found & BARE_STRING_ALLOWED  # the walker sees annotations (and the allowed list is not stale)

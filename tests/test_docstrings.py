"""The docstring habit, checked: every public name of ``import rvflex`` (the names the API
reference lists) and every public method of its classes has a numpydoc docstring, and every
physical parameter states its unit.

Scope: ``rvflex.__all__``, the result class each scenario's ``run`` returns, and the methods
and properties those classes define (the user's surface). Checked with numpydoc's own validator: a docstring (GL08) with a one-line summary
(SS01), every parameter documented (PR01) and no stale one (PR02), a Returns section where the
function returns a value (RT01). Units: a parameter typed ``float`` (or a tuple of floats)
carries its SI unit in its name (``load_Nm``, ``step_s``: the DESIGN rule) or its description
names the unit, or says it is dimensionless. Exempt, with the reason: :class:`PartSettings`
lives in ``rvflex.fe`` (the FE work's files); its fields carry their units in their names.
"""

from __future__ import annotations

import inspect
import re
import sys

import pytest

numpydoc_validate = pytest.importorskip("numpydoc.validate", reason="numpydoc comes with the test extra")

import rvflex  # noqa: E402 -- after the importorskip

CODES = {"GL08", "SS01", "PR01", "PR02", "RT01"}
EXEMPT = {"rvflex.fe.types.PartSettings": "FE work's module; fields carry their units in their names"}
UNIT_SUFFIX = re.compile(r"_(m|mm|um|N|Nm|Nm_per_arcmin|N_per_m|Ns_m|rad|deg|s|rpm|Hz|Pa|kg|arcsec|arcmin|pct)$")
UNIT_WORDS = re.compile(r"(\b(m|mm|µm|N|N·m|N·m/arcmin|N/m|rad|s|rpm|Hz|Pa|kg|arcsec|arcmin|deg)\b|[°″′]|\(–\)|"
                        r"dimensionless|fraction|%|revolutions|per output revolution|\bcount\b)")


def _public_objects() -> list[object]:
    """The public names' objects and the result types their scenarios' ``run`` returns."""
    objs = [getattr(rvflex, n) for n in sorted(rvflex.__all__) if not n.startswith("__")]
    results = []
    for obj in objs:
        returns = inspect.signature(obj.run).return_annotation if inspect.isclass(obj) and hasattr(obj, "run") else None
        if isinstance(returns, str):  # ``from __future__ import annotations``: resolve in the class's module
            returns = getattr(sys.modules[obj.__module__], returns)
        if inspect.isclass(returns) and returns not in objs + results:
            results.append(returns)
    return objs + results


def _returned_classes() -> list[type]:
    """The classes the public functions return that are not public names themselves (a sweep's
    SweepResult, the Diagnosis): their methods are the user's surface too."""
    objs = [getattr(rvflex, n) for n in sorted(rvflex.__all__) if not n.startswith("__")]
    out = []
    for obj in objs:
        if not inspect.isfunction(obj):
            continue
        returns = inspect.signature(obj).return_annotation
        if isinstance(returns, str):
            returns = getattr(sys.modules[obj.__module__], returns, None)
        if inspect.isclass(returns) and returns.__module__.startswith("rvflex") and returns not in objs + out:
            out.append(returns)
    return out


def _surface() -> list[tuple[str, object]]:
    """(qualified name, object) of every public object and the public members its classes define,
    and the public methods of the classes the public functions return."""
    out = []
    for cls in _returned_classes():
        for member, value in vars(cls).items():
            if not member.startswith("_") and inspect.isfunction(value):
                out.append((f"{cls.__module__}.{cls.__qualname__}.{member}", value))
    for obj in _public_objects():
        qual = f"{obj.__module__}.{obj.__qualname__}"
        out.append((qual, obj))
        if inspect.isclass(obj):
            for member, value in vars(obj).items():
                if member.startswith("_"):
                    continue
                func = value.__func__ if isinstance(value, (classmethod, staticmethod)) else value
                if inspect.isfunction(func) or isinstance(value, property):
                    out.append((f"{qual}.{member}", value))
    return out


SURFACE = _surface()


def _float_typed(annotation) -> bool:
    text = annotation if isinstance(annotation, str) else getattr(annotation, "__name__", str(annotation))
    return bool(re.search(r"\bfloat\b", text))


@pytest.mark.parametrize("qual", [q for q, _ in SURFACE if q not in EXEMPT])
def test_numpydoc_docstring(qual):
    result = numpydoc_validate.validate(qual)
    errors = [f"{code}: {msg}" for code, msg in result["errors"] if code in CODES]
    if isinstance(dict(SURFACE)[qual], property):  # a property is documented by its summary
        errors = [e for e in errors if e[:4] in ("GL08", "SS01")]
    assert not errors, f"{qual}:\n  " + "\n  ".join(errors)


@pytest.mark.parametrize("qual", [q for q, _ in SURFACE if q not in EXEMPT])
def test_physical_parameters_state_their_unit(qual):
    obj = dict(SURFACE)[qual]
    target = obj.fget if isinstance(obj, property) else getattr(obj, "__func__", obj)
    try:
        signature = inspect.signature(target)
    except (TypeError, ValueError):
        return
    from numpydoc.docscrape import ClassDoc, FunctionDoc

    doc = ClassDoc(target) if inspect.isclass(target) else FunctionDoc(target)
    described = {}
    for p in doc["Parameters"]:
        for name in p.name.split(","):
            described[name.strip()] = " ".join(p.desc) + " " + p.type
    missing = [name for name, p in signature.parameters.items()
               if p.annotation is not inspect.Parameter.empty and _float_typed(p.annotation)
               and not UNIT_SUFFIX.search(name) and not UNIT_WORDS.search(described.get(name, ""))]
    assert not missing, f"{qual}: physical parameters without a unit in name or description: {missing}"


def test_the_check_sees_a_missing_unit_and_a_missing_section():
    """The checks can fail: a float parameter without a unit, and an undocumented parameter."""

    def bad(load: float, count: int) -> float:
        """Do something.

        Parameters
        ----------
        load : float
            The load.

        Returns
        -------
        float
            Something.
        """
        return load * count

    assert not UNIT_SUFFIX.search("load") and not UNIT_WORDS.search("The load. float")
    assert UNIT_WORDS.search("Output torque, N·m.") and UNIT_SUFFIX.search("load_Nm")
    codes = {code for code, _ in numpydoc_validate.validate(f"{__name__}._bad_example")["errors"]}
    assert "PR01" in codes  # ``count`` is not documented


def _bad_example(load_Nm: float, count: int) -> float:
    """Return the product.

    Parameters
    ----------
    load_Nm : float
        Output torque.

    Returns
    -------
    float
        The product.
    """
    return load_Nm * count

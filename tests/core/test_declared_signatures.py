"""The mechanism behind "every refused call names its argument" covers the whole module.

The bindings declare each entry point's signature from its C++ types (`_core._signatures`,
cpp/bindings/declared.hpp) and deformkit/_arguments.py explains from it the calls pybind11 refuses.
Walked here independently of that table: every public callable the module has (found by
introspection) is declared and wrapped, the declarations agree with what pybind11 itself
registered (its printed signatures), and every typed parameter of every entry point, given a value
of the wrong type, is refused with a message that names it -- generated from the declarations, so
a pybind11 upgrade that changes its internals (method objects, refusal messages, converters)
fails here instead of silently bringing back "incompatible function arguments"."""
import inspect
import types

import numpy as np
import pytest

import deformkit as dk
from deformkit import _core
from deformkit._arguments import parse_signature

CUBE = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
CUBE_FACES = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
GRID = np.array([[x, y, 0.1 * x * y] for y in range(3) for x in range(3)], float)
QUADS = np.array([[0, 1, 4, 3], [1, 2, 5, 4], [3, 4, 7, 6], [4, 5, 8, 7]])
PTS = np.random.default_rng(7).uniform(0.2, 0.8, (5, 3))

# An instance of every class whose methods are declared (the self of a method call).
SAMPLES = {
    "Deformer": lambda: dk.Twist(), "Stack": lambda: dk.Stack([dk.Twist()]), "SimpleDeform": lambda: dk.SimpleDeform(),
    "Lattice": lambda: dk.FFD(2), "LatticeBinding": lambda: dk.FFD(2).bind(PTS),
    "SurfaceDeformer": lambda: dk.SurfaceDeformer(GRID, QUADS, anchors=[0, 1, 2], handles=[8]),
    "SubdividedMesh": lambda: dk.subdivide(CUBE, CUBE_FACES, 1), "Subdivider": lambda: dk.Subdivider(CUBE, CUBE_FACES, 1),
    "LimitSurface": lambda: dk.LimitSurface(CUBE, CUBE_FACES),
    "SmoothnessReport": lambda: dk.smoothness_report(CUBE, CUBE_FACES),
    "CageDeformer": lambda: dk.MeanValueCage(CUBE * 2 - 0.5, CUBE_FACES),
    "CageBinding": lambda: dk.MeanValueCage(CUBE * 2 - 0.5, CUBE_FACES).bind(PTS),
    "MeshDeform": lambda: dk.MeshDeform(CUBE * 2 - 0.5, CUBE_FACES, precision=3),
    "MeshDeformBinding": lambda: dk.MeshDeform(CUBE * 2 - 0.5, CUBE_FACES, precision=3).bind(PTS),
    "RBF": lambda: dk.RBF(CUBE, CUBE + 0.1), "RBFBinding": lambda: dk.RBF(CUBE, CUBE + 0.1).bind(PTS),
    "DeformationTransfer": lambda: dk.DeformationTransfer(GRID, QUADS, GRID * 1.5),
    "FFD": lambda: dk.FFD(2), "BezierFFD": lambda: dk.BezierFFD(1), "BSplineLattice": lambda: dk.BSplineLattice(4),
    "BlenderLattice": lambda: dk.BlenderLattice(2), "VolumeRatioBounds": lambda: dk.FFD(2).volume_ratio_bounds(),
    "FoldCertificate": lambda: dk.FFD(2).fold_free(),
}
# A value each kind of parameter takes (for the arguments a call needs besides the one under test;
# pybind11 refuses the call while converting, so the body never sees them), and values it refuses.
VALID = {"real": 1.0, "integer": 1, "str": "x", "bool": True, "object": None}
WRONG = {"real": ["text", 1j, 10**400, object()], "integer": [2.5, "3", 2**64, -(2**63) - 1, object()],
         "str": [1.5, 3, object()], "bool": ["yes", object()], "class": [object(), "x", 1.0]}


def public_callables():
    """(key, the object found there) for every public routine of the module, found by introspection."""
    for name, obj in vars(_core).items():
        if name.startswith("_"):
            continue
        if inspect.isclass(obj):
            for attr, member in vars(obj).items():
                if isinstance(member, types.WrapperDescriptorType):
                    continue  # a class without a constructor: pybind11's "No constructor defined!"
                if attr == "__init__" or (not attr.startswith("_") and not isinstance(member, property)
                                          and callable(getattr(obj, attr))):
                    yield f"{name}.{attr}", member
        elif callable(obj):
            yield name, obj


def test_every_public_callable_is_declared_and_wrapped():
    found = dict(public_callables())
    assert len(found) > 40, "the introspection found too little: it is broken"
    missing = sorted(set(found) - set(_core._signatures))
    assert not missing, f"defined without declaring (use Class<...> / def(m, ...) in cpp/bindings): {missing}"
    for key, member in found.items():
        function = member.__func__ if isinstance(member, staticmethod) else member
        assert inspect.isfunction(function) and hasattr(function, "_declared"), f"{key} is not wrapped: {member!r}"


@pytest.mark.parametrize("key", sorted(_core._signatures))
def test_declarations_agree_with_what_pybind11_registered(key):
    """Names, order, keyword-only and defaults as pybind11 prints them in the docstring."""
    declared = _core._signatures[key]["parameters"]
    doc_name = key.rpartition(".")[2]
    printed = parse_signature(getattr(_core, key.partition(".")[0]).__dict__[doc_name].__doc__
                              if "." in key else getattr(_core, key).__doc__, doc_name)
    assert printed is not None, f"{key}: pybind11 printed no signature"
    printed = [p for p in printed if p.name != "self"]
    assert [p["name"] for p in declared] == [p.name for p in printed]
    assert [p["kind"] == "keyword_only" for p in declared] == [p.keyword_only for p in printed]
    assert ["default" in p for p in declared] == [p.has_default for p in printed]


def entry(key):
    """The callable of `key` as a user calls it (the class, a bound method, the function)."""
    scope, _, attr = key.rpartition(".")
    if not scope:
        return getattr(_core, attr)
    cls = getattr(_core, scope)
    if attr == "__init__":
        return cls
    if not _core._signatures[key]["method"]:
        return getattr(cls, attr)
    assert scope in SAMPLES, f"{scope}: give the class a sample instance"
    return getattr(SAMPLES[scope](), attr)


def valid_for(accepts):
    if accepts["kind"] == "class":
        return SAMPLES[accepts["class"].__name__]()
    return VALID[accepts["kind"]]


TYPED = [(key, p["name"]) for key, s in sorted(_core._signatures.items()) for p in s["parameters"]
         if p["accepts"]["kind"] != "object"]


def test_the_walk_covers_every_kind():
    kinds = {p["accepts"]["kind"] for s in _core._signatures.values() for p in s["parameters"]}
    assert {"real", "integer", "str", "class", "object"} <= kinds
    assert len(TYPED) > 50


@pytest.mark.parametrize("key, name", TYPED, ids=[f"{k}-{n}" for k, n in TYPED])
def test_a_wrongly_typed_value_is_refused_naming_its_parameter(key, name):
    params = _core._signatures[key]["parameters"]
    accepts = next(p["accepts"] for p in params if p["name"] == name)
    required = {p["name"]: valid_for(p["accepts"]) for p in params if "default" not in p and p["name"] != name}
    call = entry(key)
    for value in WRONG[accepts["kind"]] + ([] if accepts["none"] else [None]):
        with pytest.raises(TypeError) as info:
            call(**required, **{name: value})
        message = str(info.value)
        assert message.startswith(f"{name}: ") and " got " in message and "(accepts " in message, \
            f"{key}({name}={value!r}): {message}"


@pytest.mark.parametrize("key", sorted(_core._signatures))
def test_unknown_keywords_and_extra_positionals_are_refused_naming_the_entry_point(key):
    params = _core._signatures[key]["parameters"]
    scope, _, attr = key.rpartition(".")
    title = f"{scope}()" if attr == "__init__" else f"{key}()"
    call = entry(key)
    with pytest.raises(TypeError, match=rf"^{title.replace('(', '[(]').replace(')', '[)]')}: unknown keyword "
                                        r"argument 'zz_not_a_parameter'"):
        call(zz_not_a_parameter=1)
    positional = [p for p in params if p["kind"] != "keyword_only"]
    with pytest.raises(TypeError, match=rf"takes at most {len(positional)} positional argument"):
        call(*[None] * (len(positional) + 1))


def test_the_signatures_python_shows_are_the_declared_ones():
    assert str(inspect.signature(dk.Twist.deform)) == "(self, /, points: 'see the docstring', *, out: " \
                                                      "'see the docstring' = None)"
    assert list(inspect.signature(dk.subdivide).parameters)[:3] == ["points", "faces", "level"]
    assert inspect.signature(dk.FFD).parameters["strength"].default == 1.0


def test_a_deformers_overflow_names_its_type_in_cpp():
    """The C++ call guard words the core's "deformer: row ..." as the deformer's type: the raw
    pybind11 function (under the Python wrapper) already says "Taper: row ..."."""
    raw = dk.Deformer.deform.__wrapped__
    with pytest.raises(ValueError, match=r"^Taper: row 0 maps to a non-finite position"):
        raw(dk.Taper(rate=1e308), np.full((1, 3), 10.0))
    with pytest.raises(ValueError, match=r"^Taper: row 0 maps to a non-finite volume ratio"):
        dk.Deformer.volume_ratio.__wrapped__(dk.Taper(rate=1e300), np.ones((1, 3)))
    with pytest.raises(ValueError, match=r"^deformer: has per-point weights"):  # an argument named deformer stays
        dk.LimitSurface.smoothness_report.__wrapped__(dk.LimitSurface(CUBE, CUBE_FACES),
                                                      deformer=dk.Twist(weights=np.ones(8)))

"""One conversion rule for every real-valued array that crosses into C++.

docs/errors.md, "One rule for real-valued arrays": a numpy array must be float32 or float64; any
other dtype is refused by a TypeError naming the argument, the dtype it got and what is accepted
-- in constructors, setters and methods alike.

The setters are found by introspection (every property with a setter on every exported class),
and so are the methods and their array parameters (each public method's signature, its valid
call below): a setter, method or parameter added later is walked, or this test fails until it
is given a valid call."""
import inspect

import numpy as np
import pytest

import deformkit as dk
from deformkit._arguments import parse_signature

CUBE = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
CUBE_FACES = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
CUBE_EDGES = np.array(sorted({tuple(sorted(p)) for f in CUBE_FACES.tolist() for p in zip(f, f[1:] + f[:1])}))
GRID = np.array([[x, y, 0.1 * x * y] for y in range(3) for x in range(3)], float)
QUADS = np.array([[0, 1, 4, 3], [1, 2, 5, 4], [3, 4, 7, 6], [4, 5, 8, 7]])
PTS = np.random.default_rng(5).uniform(0.1, 0.9, (6, 3))
TRIANGLE = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)


def bad_arrays(like):
    """`like` (a float array) in every dtype the rule refuses, same shape."""
    ints = np.rint(like).astype(np.int64)
    return [ints, ints.astype(np.int32), ints.astype(np.uint8), like > 0.5, like.astype(np.float16),
            like.astype(np.longdouble), like.astype(np.complex128), like.astype(object),
            ints.astype("datetime64[s]"), ints.astype("timedelta64[s]"), like.astype(str)]


# One instance of every exported class with an array setter or an array-taking method.
SAMPLES = {
    "Twist": lambda: dk.Twist(rate=0.5), "Taper": lambda: dk.Taper(rate=0.5), "Stretch": lambda: dk.Stretch(),
    "Bend": lambda: dk.Bend(curvature=0.5), "SimpleDeform": lambda: dk.SimpleDeform(),
    "BarrDeformer": lambda: dk.SimpleDeform().bind(PTS), "Stack": lambda: dk.Stack([dk.Twist(rate=0.5)]),
    "FFD": lambda: dk.FFD(2), "BezierFFD": lambda: dk.BezierFFD(1), "BSplineLattice": lambda: dk.BSplineLattice(4),
    "BlenderLattice": lambda: dk.BlenderLattice(2),
    "ExtendedFFD": lambda: dk.ExtendedFFD(dk.BezierFFD(1).rest_control_points),
    "MeanValueCage": lambda: dk.MeanValueCage(CUBE * 2 - 0.5, CUBE_FACES),
    "GreenCage": lambda: dk.GreenCage(CUBE * 2 - 0.5, CUBE_FACES),
    "MeshDeform": lambda: dk.MeshDeform(CUBE * 2 - 0.5, CUBE_FACES, precision=3),
    "RBF": lambda: dk.RBF(CUBE, CUBE + 0.1),
    "SurfaceDeformer": lambda: dk.SurfaceDeformer(GRID, QUADS, anchors=[0, 1, 2], handles=[8]),
    "Subdivider": lambda: dk.Subdivider(CUBE, CUBE_FACES, 1),
    "LimitSurface": lambda: dk.LimitSurface(CUBE, CUBE_FACES),
    "DeformationTransfer": lambda: dk.DeformationTransfer(GRID, QUADS, GRID * 1.5, fixed_vertices=[0]),
}
# Classes whose instances only report (results): nothing of theirs takes an array.
RESULTS = {"LatticeBinding", "CageBinding", "RBFBinding", "MeshDeformBinding", "DirectManipulation", "SubdividedMesh", "SmoothnessReport",
           "Deformer", "Lattice", "CageDeformer", "VolumeRatioBounds", "FoldCertificate"}

# Valid positional arguments of each public method, by name, given its instance: the walk replaces
# each float array among them (and each keyword array) by every refused dtype.
METHOD_CALLS = {
    "deform": lambda d: (((GRID[[8]] + 0.2,), {"initial": GRID}) if isinstance(d, dk.SurfaceDeformer) else ((PTS,), {})),
    "displacement": lambda d: ((PTS,), {}), "jacobian": lambda d: ((PTS,), {}),
    "volume_ratio": lambda d: ((PTS,), {}), "transform_normals": lambda d: ((PTS, PTS), {}),
    # MeshDeform's from a saved bind's rows (their data walked); the others' plain
    "bind": lambda d: ((PTS,), {"rows": d.bind(PTS).weights()} if isinstance(d, dk.MeshDeform) else {}),
    "lattice_coordinates": lambda d: ((PTS,), {}),
    "direct_manipulation": lambda d: ((PTS[:2], PTS[:2] + 0.05), {"preserve_volume": (CUBE * 0.5 + 0.25, CUBE_FACES)}),
    "deform_bound": lambda d: ((d.bind(PTS),), {}), "displacement_bound": lambda d: ((d.bind(PTS),), {}),
    "replace": lambda d: ((), {"origin": np.eye(4), "limits": np.array([0.0, 1.0])}),
    "subdivide": lambda d: ((), {"points": CUBE}), "mesh": lambda d: ((), {"points": CUBE}),
    "limit_points": lambda d: ((), {"points": CUBE}),
    "blender_order": lambda d: ((CUBE_EDGES,), {}),
    "evaluate": lambda d: (([0], np.array([[0.5, 0.5]])), {"points": CUBE}),
    "smoothness_report": lambda d: ((), {"points": CUBE, "reference": CUBE}),
    "transfer": lambda d: ((GRID,), {"fixed_positions": GRID[:1]}),
    "volume_ratio_bounds": lambda d: ((), {"points": PTS}), "fold_free": lambda d: ((PTS,), {}),
}
# Methods that take no array: binding results, generators (walked as functions below), reports.
NO_ARRAYS = {"weights", "cylinder", "prism", "vertex_parameters", "deformed_volume", "volume_ratio_coefficients",
             "cell_control_indices"}

# Constructors and functions: valid calls with every real-valued array argument given.
FUNCTIONS = {
    "Twist": (dk.Twist, "__init__", (), {"frame": np.eye(4), "weights": np.ones(6) * 0.5, "limits": np.array([-1.0, 1.0])}),
    "Bend": (dk.Bend, "__init__", (), {"region": np.array([-0.5, 0.5])}),
    "Twist.profile": (dk.Twist, "__init__", (), {"profile": (np.array([0.0, 1.0]), np.array([0.0, 0.5]))}),
    "SimpleDeform": (dk.SimpleDeform, "__init__", (), {"origin": np.eye(4), "limits": np.array([0.0, 1.0]),
                                                       "weights": np.ones(6) * 0.5}),
    "FFD": (dk.FFD, "__init__", (1,), {"origin": np.zeros(3), "edges": np.eye(3),
                                       "control_points": dk.FFD(1).rest_control_points}),
    "FFD.frame": (dk.FFD, "__init__", (1,), {"frame": np.eye(4)}),
    "ExtendedFFD": (dk.ExtendedFFD, "__init__", (dk.BezierFFD(1).rest_control_points,), {}),
    "ExtendedFFD.cylinder": (dk.ExtendedFFD.cylinder, "cylinder", (), {"center": np.zeros(3)}),
    "ExtendedFFD.prism": (dk.ExtendedFFD.prism, "prism", (TRIANGLE, np.array([0.0, 0.0, 1.0])), {}),
    "MeanValueCage": (dk.MeanValueCage, "__init__", (CUBE, CUBE_FACES), {}),
    "RBF": (dk.RBF, "__init__", (CUBE, CUBE + 0.1), {}),
    "Stack": (dk.Stack, "__init__", ([dk.Twist()],), {"weights": np.ones(6) * 0.5}),
    "SurfaceDeformer": (dk.SurfaceDeformer, "__init__", (GRID, QUADS), {"anchors": [0]}),
    "Subdivider": (dk.Subdivider, "__init__", (CUBE, CUBE_FACES, 1),
                   {"creases": (np.array([[0, 1]]), np.array([1.0])), "corners": (np.array([0]), np.array([2.0]))}),
    "subdivide": (dk.subdivide, "subdivide", (CUBE, CUBE_FACES, 1), {"uvs": np.zeros((24, 2))}),
    "mesh_volume": (dk.mesh_volume, "mesh_volume", (CUBE, CUBE_FACES), {}),
    "generate_cage": (dk.generate_cage, "generate_cage", (CUBE, CUBE_FACES), {"max_faces": 12}),
    "cotangent_laplacian": (dk.cotangent_laplacian, "cotangent_laplacian", (GRID, QUADS), {}),
    "extrapolated_start": (dk.extrapolated_start, "extrapolated_start", (GRID, GRID, PTS, PTS, PTS), {}),
    "GreenCage": (dk.GreenCage, "__init__", (CUBE, CUBE_FACES), {}),
    "MeshDeform": (dk.MeshDeform, "__init__", (CUBE, CUBE_FACES), {"precision": 3}),
    "DeformationTransfer": (dk.DeformationTransfer, "__init__", (GRID, QUADS, GRID * 1.5), {}),
    "LimitSurface": (dk.LimitSurface, "__init__", (CUBE, CUBE_FACES), {}),
    "smoothness_report": (dk.smoothness_report, "smoothness_report", (CUBE, CUBE_FACES), {}),
}


def arrays_in(value, path=()):
    """(path, array) for every float array in `value` (tuples walked: a profile, creases)."""
    if isinstance(value, np.ndarray) and value.dtype.kind == "f":
        yield path, value
    elif isinstance(value, tuple):
        for i, v in enumerate(value):
            yield from arrays_in(v, path + (i,))


def replaced(value, path, new):
    if not path:
        return new
    items = list(value)
    items[path[0]] = replaced(items[path[0]], path[1:], new)
    return tuple(items)


def assert_refused(call, name, bad):
    with pytest.raises((TypeError, ValueError)) as info:
        call()
    message = str(info.value)
    assert message.startswith(name), message                                  # the argument
    assert str(bad.dtype) in message, message                                 # what it got
    assert "float32 or float64" in message, message                            # what is accepted


def array_calls():
    """(label, call maker, argument name, valid array) for every float array of every valid call."""
    out = []
    for label, (function, _, args, kwargs) in FUNCTIONS.items():
        params = [p.name for p in signature_of(label)]
        for i, arg in enumerate(args):
            for path, a in arrays_in(arg):
                out.append((label, function, args, kwargs, ("pos", i), path, params[i], a))
        for key, arg in kwargs.items():
            for path, a in arrays_in(arg):
                out.append((label, function, args, kwargs, ("kw", key), path, key, a))
    return out


def signature_of(label):
    function, doc_name, _, _ = FUNCTIONS[label]
    doc = (function.__init__ if doc_name == "__init__" else function).__doc__
    params = parse_signature(doc, doc_name)
    return [p for p in params if p.name != "self"]


CALLS = array_calls()


@pytest.mark.parametrize("case", CALLS, ids=[f"{c[0]}-{c[6]}{''.join(map(str, c[5]))}" for c in CALLS])
def test_constructors_and_functions_refuse_other_dtypes(case):
    label, function, args, kwargs, (kind, where), path, name, valid = case
    function(*args, **kwargs)  # the valid call succeeds
    for bad in bad_arrays(valid):
        if kind == "pos":
            a = list(args)
            a[where] = replaced(args[where], path, bad)
            assert_refused(lambda: function(*a, **kwargs), name, bad)
        else:
            k = dict(kwargs, **{where: replaced(kwargs[where], path, bad)})
            assert_refused(lambda: function(*args, **k), name, bad)


def test_every_object_parameter_is_walked_or_not_an_array():
    """A parameter typed `object` (how arrays cross) is given a float array in some call above, or
    takes no real-valued array; a new one fails here until it is classified."""
    not_real = {"faces", "cage_faces", "anchors", "handles", "roi", "deformers", "degree", "blocks", "resolution",
                "interpolation", "axis", "deform_axis", "source_faces", "target_faces", "markers", "correspondence",
                "fixed_vertices", "lock_x", "lock_y", "lock_z", "invert_weights", "stretch", "binding", "out",
                "ptex", "deformer", "sharpen_two_edge_vertices", "limit_surface", "mode", "angle", "factor",
                "quads", "dynamic", "blender_version", "inside", "cell"}
    walked = {c[6] for c in CALLS} | {"cage_points", "targets", "handle_targets", "initial", "source_pose",
                                      "fixed_positions", "points", "normals", "reference", "uv", "profile",
                                      "preserve_volume", "rows"}
    for cls_name in (n for n in dir(dk) if not n.startswith("_")):
        obj = getattr(dk, cls_name)
        members = [("__init__", obj.__init__)] if inspect.isclass(obj) else [(cls_name, obj)]
        if inspect.isclass(obj):
            members += [(n, getattr(obj, n)) for n in vars(obj) if not n.startswith("_") and callable(getattr(obj, n))]
        for doc_name, member in members:
            for p in parse_signature(getattr(member, "__doc__", None), doc_name) or []:
                if p.annotation == "object" and p.name != "self":
                    assert p.name in walked | not_real, f"{cls_name}.{doc_name}: parameter {p.name} is not walked"


def setters():
    out = []
    for cls_name in sorted(dk.__all__):
        cls = getattr(dk, cls_name)
        if not inspect.isclass(cls) or cls_name in RESULTS:  # abstract bases: walked through their classes
            continue
        for attr in dir(cls):
            prop = inspect.getattr_static(cls, attr, None)
            if isinstance(prop, property) and prop.fset is not None:
                out.append((cls_name, attr))
    return out


def test_every_class_with_arrays_has_a_sample():
    classes = {n for n in dk.__all__ if inspect.isclass(getattr(dk, n))}
    assert classes - set(SAMPLES) - RESULTS == set()
    assert setters(), "no setters found: the introspection is broken"


@pytest.mark.parametrize("cls_name, attr", setters())
def test_setters_refuse_what_constructors_refuse(cls_name, attr):
    assert cls_name in SAMPLES, f"{cls_name}.{attr}: give the class a sample"
    instance = SAMPLES[cls_name]()
    valid = getattr(instance, attr)
    assert isinstance(valid, np.ndarray) and valid.dtype == np.float64
    setattr(instance, attr, valid)  # the valid value is taken back
    for bad in bad_arrays(valid):
        assert_refused(lambda: setattr(instance, attr, bad), attr, bad)
        np.testing.assert_array_equal(getattr(instance, attr), valid)  # and nothing changed


def methods():
    out = []
    for cls_name, make in SAMPLES.items():
        cls = getattr(dk, cls_name)
        for attr in dir(cls):
            if attr.startswith("_") or attr in NO_ARRAYS:
                continue
            if callable(inspect.getattr_static(cls, attr)) and not inspect.isclass(getattr(cls, attr)):
                out.append((cls_name, attr))
    return out


@pytest.mark.parametrize("cls_name, method", methods())
def test_methods_refuse_other_dtypes(cls_name, method):
    assert method in METHOD_CALLS, f"{cls_name}.{method}: give it a valid call in METHOD_CALLS"
    instance = SAMPLES[cls_name]()
    args, kwargs = METHOD_CALLS[method](instance)
    bound = getattr(instance, method)
    names = [p.name for p in parse_signature(getattr(type(instance), method).__doc__, method) or []
             if p.name != "self"]
    bound(*args, **kwargs)
    for i, arg in enumerate(args):
        for path, valid in arrays_in(arg):
            for bad in bad_arrays(valid):
                a = list(args)
                a[i] = replaced(arg, path, bad)
                assert_refused(lambda: bound(*a, **kwargs), names[i], bad)
    for key, arg in kwargs.items():
        for path, valid in arrays_in(arg):
            for bad in bad_arrays(valid):
                assert_refused(lambda: bound(*args, **dict(kwargs, **{key: replaced(arg, path, bad)})), key, bad)


def test_python_sequences_of_numbers_are_read_as_float64():
    """A list has no dtype: its numbers are read as float64 (an int list is not an int array)."""
    lattice = dk.FFD(1)
    as_list = lattice.rest_control_points.astype(int).tolist()
    lattice.control_points = as_list
    np.testing.assert_array_equal(lattice.control_points, np.array(as_list, float))
    twist = dk.Twist(rate=1.0, limits=[-1, 1])
    np.testing.assert_allclose(twist.deform(PTS), dk.Twist(rate=1.0, limits=(-1.0, 1.0)).deform(PTS), rtol=0, atol=0)
    with pytest.raises(TypeError, match=r"^weights: expected real numbers .*got list of bool"):
        dk.Twist(weights=[True, False])

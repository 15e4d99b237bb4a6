"""Every public entry point, every parameter: a wrongly typed value or a misspelt keyword gets an
error that names the argument (and, for a keyword, the nearest valid name) -- never pybind11's
generic "incompatible function arguments". The parameters are read from each entry point's own
signature, so a parameter added later is walked too."""
import numpy as np
import pytest

import deformkit as dk
from deformkit._arguments import parse_signature

GRID = np.array([[x, y, 0.1 * x * y] for y in range(3) for x in range(3)], float)
QUADS = np.array([[0, 1, 4, 3], [1, 2, 5, 4], [3, 4, 7, 6], [4, 5, 8, 7]])
CUBE = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
CUBE_FACES = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
PTS = np.random.default_rng(3).uniform(-1, 1, (20, 3))
TRIANGLE = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)


def ffd():
    return dk.FFD(2)


def surface():
    return dk.SurfaceDeformer(GRID, QUADS, anchors=[0, 1, 2], handles=[8])


def limit():
    return dk.LimitSurface(CUBE, CUBE_FACES)


def mean_value_cage():
    return dk.MeanValueCage(CUBE, CUBE_FACES)


def mesh_deform():
    return dk.MeshDeform(CUBE, CUBE_FACES, precision=3)


def rbf():
    return dk.RBF(CUBE, CUBE + 0.1)


def subdivider():
    return dk.Subdivider(CUBE, CUBE_FACES, 1)


# name -> (the callable, its name in its docstring, valid positional arguments, valid keywords)
ENTRY_POINTS = {
    "Twist": (dk.Twist, "__init__", (), {}),
    "Taper": (dk.Taper, "__init__", (), {}),
    "Stretch": (dk.Stretch, "__init__", (), {}),
    "Bend": (dk.Bend, "__init__", (), {}),
    "SimpleDeform": (dk.SimpleDeform, "__init__", (), {}),
    "SimpleDeform.bind": (lambda *a, **k: dk.SimpleDeform().bind(*a, **k), "bind", (PTS,), {}),
    "Stack": (dk.Stack, "__init__", ([dk.Twist()],), {}),
    "FFD": (dk.FFD, "__init__", (), {}),
    "BezierFFD": (dk.BezierFFD, "__init__", (), {}),
    "BSplineLattice": (dk.BSplineLattice, "__init__", (), {}),
    "BlenderLattice": (dk.BlenderLattice, "__init__", (), {}),
    "ExtendedFFD": (dk.ExtendedFFD, "__init__", (dk.BezierFFD(1).rest_control_points,), {}),
    "ExtendedFFD.cylinder": (dk.ExtendedFFD.cylinder, "cylinder", (), {}),
    "ExtendedFFD.prism": (dk.ExtendedFFD.prism, "prism", (TRIANGLE, [0, 0, 1]), {}),
    "MeanValueCage": (dk.MeanValueCage, "__init__", (CUBE, CUBE_FACES), {}),
    "GreenCage": (dk.GreenCage, "__init__", (CUBE, CUBE_FACES), {"stretch": True}),
    "MeanValueCage.bind": (lambda *a, **k: mean_value_cage().bind(*a, **k), "bind", (PTS,), {}),
    "MeanValueCage.deform_bound": (lambda *a, **k: mean_value_cage().deform_bound(*a, **k), "deform_bound",
                                   (mean_value_cage().bind(PTS),), {}),
    "MeshDeform": (dk.MeshDeform, "__init__", (CUBE, CUBE_FACES), {"precision": 3, "dynamic": True,
                                                                   "blender_version": (5, 0)}),
    "MeshDeform.bind": (lambda *a, **k: mesh_deform().bind(*a, **k), "bind", (PTS,), {}),
    "MeshDeform.deform_bound": (lambda *a, **k: mesh_deform().deform_bound(*a, **k), "deform_bound",
                                (mesh_deform().bind(PTS),), {}),
    "RBF": (dk.RBF, "__init__", (CUBE, CUBE + 0.1), {"kernel": "gaussian", "epsilon": 2.0, "degree": 1,
                                                      "smoothing": 0.0}),
    "RBF.bind": (lambda *a, **k: rbf().bind(*a, **k), "bind", (PTS,), {}),
    "RBF.deform_bound": (lambda *a, **k: rbf().deform_bound(*a, **k), "deform_bound", (rbf().bind(PTS),), {}),
    "DeformationTransfer": (dk.DeformationTransfer, "__init__", (GRID, QUADS, GRID * 1.5), {}),
    "DeformationTransfer.unlike": (dk.DeformationTransfer, "__init__", (GRID, QUADS, CUBE, CUBE_FACES),
                                   {"markers": ([0], [7]), "fixed_vertices": [1]}),
    "DeformationTransfer.transfer": (lambda *a, **k: dk.DeformationTransfer(GRID, QUADS, GRID).transfer(*a, **k),
                                     "transfer", (GRID,), {}),
    "SurfaceDeformer": (dk.SurfaceDeformer, "__init__", (GRID, QUADS), {"anchors": [0, 1, 2], "handles": [8]}),
    "Subdivider": (dk.Subdivider, "__init__", (CUBE, CUBE_FACES, 1), {}),
    "LimitSurface": (dk.LimitSurface, "__init__", (CUBE, CUBE_FACES), {}),
    "subdivide": (dk.subdivide, "subdivide", (CUBE, CUBE_FACES, 1), {}),
    "smoothness_report": (dk.smoothness_report, "smoothness_report", (CUBE, CUBE_FACES), {}),
    "mesh_volume": (dk.mesh_volume, "mesh_volume", (CUBE, CUBE_FACES), {}),
    "generate_cage": (dk.generate_cage, "generate_cage", (TRIANGLE, [[0, 1, 2]]), {"max_faces": 12}),
    "cotangent_laplacian": (dk.cotangent_laplacian, "cotangent_laplacian", (GRID, QUADS), {}),
    "extrapolated_start": (dk.extrapolated_start, "extrapolated_start", (GRID, GRID, PTS, PTS, PTS), {}),
    "deform": (lambda *a, **k: dk.Twist().deform(*a, **k), "deform", (PTS,), {}),
    "displacement": (lambda *a, **k: dk.Twist().displacement(*a, **k), "displacement", (PTS,), {}),
    "jacobian": (lambda *a, **k: dk.Twist().jacobian(*a, **k), "jacobian", (PTS,), {}),
    "transform_normals": (lambda *a, **k: dk.Twist().transform_normals(*a, **k), "transform_normals", (PTS, PTS), {}),
    "volume_ratio": (lambda *a, **k: dk.Twist().volume_ratio(*a, **k), "volume_ratio", (PTS,), {}),
    "bind": (lambda *a, **k: ffd().bind(*a, **k), "bind", (PTS,), {}),
    "deform_bound": (lambda *a, **k: ffd().deform_bound(*a, **k), "deform_bound", (ffd().bind(PTS),), {}),
    "lattice_coordinates": (lambda *a, **k: ffd().lattice_coordinates(*a, **k), "lattice_coordinates", (PTS,), {}),
    "direct_manipulation": (lambda *a, **k: ffd().direct_manipulation(*a, **k), "direct_manipulation",
                            (PTS[:3], PTS[:3] + 0.1), {}),
    "volume_ratio_bounds": (lambda *a, **k: ffd().volume_ratio_bounds(*a, **k), "volume_ratio_bounds", (),
                            {"points": PTS}),
    "fold_free": (lambda *a, **k: ffd().fold_free(*a, **k), "fold_free", (PTS,), {}),
    "volume_ratio_coefficients": (lambda *a, **k: ffd().volume_ratio_coefficients(*a, **k),
                                  "volume_ratio_coefficients", ((0, 0, 0),), {}),
    "cell_control_indices": (lambda *a, **k: ffd().cell_control_indices(*a, **k), "cell_control_indices",
                             ((0, 0, 0),), {}),
    "SurfaceDeformer.deform": (lambda *a, **k: surface().deform(*a, **k), "deform", (GRID[[8]] + 0.2,), {}),
    "Subdivider.subdivide": (lambda *a, **k: subdivider().subdivide(*a, **k), "subdivide", (), {}),
    "Subdivider.mesh": (lambda *a, **k: subdivider().mesh(*a, **k), "mesh", (), {}),
    "LimitSurface.evaluate": (lambda *a, **k: limit().evaluate(*a, **k), "evaluate", ([0], [[0.5, 0.5]]), {}),
    "LimitSurface.limit_points": (lambda *a, **k: limit().limit_points(*a, **k), "limit_points", (), {}),
    "LimitSurface.smoothness_report": (lambda *a, **k: limit().smoothness_report(*a, **k), "smoothness_report", (), {}),
}
DOC_OWNER = {  # where each entry point's signature is documented
    "deform": dk.Deformer.deform, "displacement": dk.Deformer.displacement, "jacobian": dk.Deformer.jacobian,
    "transform_normals": dk.Deformer.transform_normals, "volume_ratio": dk.Deformer.volume_ratio,
    "SimpleDeform.bind": dk.SimpleDeform.bind, "bind": dk.Lattice.bind, "deform_bound": dk.Lattice.deform_bound,
    "lattice_coordinates": dk.Lattice.lattice_coordinates, "direct_manipulation": dk.Lattice.direct_manipulation,
    "volume_ratio_bounds": dk.FFD.volume_ratio_bounds, "fold_free": dk.FFD.fold_free,
    "volume_ratio_coefficients": dk.FFD.volume_ratio_coefficients, "cell_control_indices": dk.FFD.cell_control_indices,
    "MeanValueCage.bind": dk.CageDeformer.bind, "MeanValueCage.deform_bound": dk.CageDeformer.deform_bound,
    "RBF.bind": dk.RBF.bind, "RBF.deform_bound": dk.RBF.deform_bound,
    "MeshDeform.bind": dk.MeshDeform.bind, "MeshDeform.deform_bound": dk.MeshDeform.deform_bound,
    "DeformationTransfer.transfer": dk.DeformationTransfer.transfer,
    "SurfaceDeformer.deform": dk.SurfaceDeformer.deform, "Subdivider.subdivide": dk.Subdivider.subdivide,
    "Subdivider.mesh": dk.Subdivider.mesh, "LimitSurface.evaluate": dk.LimitSurface.evaluate,
    "LimitSurface.limit_points": dk.LimitSurface.limit_points,
    "LimitSurface.smoothness_report": dk.LimitSurface.smoothness_report,
}
BAD_VALUES = [1j, "not-a-value", object(), 10**400, b"\x00", {"a": 1}]
BAD_INTEGERS = [-(2**63) - 1, 2**64, 2.5, np.eye(2), np.array([np.nan]), np.array(["a"]),  # integer parameters
                np.array([3])]  # one element, but an array: NumPy's conversion of it is deprecated
BAD_REALS = [np.array([0.5]), np.array([[0.5]])]  # real parameters: arrays, even of one element


def parameters(entry):
    function, doc_name, _, _ = ENTRY_POINTS[entry]
    owner = DOC_OWNER.get(entry, function)
    doc = (owner.__init__ if doc_name == "__init__" else owner).__doc__
    params = parse_signature(doc, doc_name)
    assert params, f"{entry}: no signature in its docstring"
    return [p for p in params if p.name != "self"]


def call_with(entry, name, value):
    function, _, args, kwargs = ENTRY_POINTS[entry]
    params = parameters(entry)
    positional = [p.name for p in params if not p.keyword_only][:len(args)]
    given = dict(zip(positional, args), **kwargs)
    given[name] = value
    # Positional-only use would hide the keyword path: pass every argument by name.
    return function(**given)


def names_argument(message, name):
    return f"{name}:" in message or f"'{name}'" in message


CASES = [(entry, p.name) for entry in ENTRY_POINTS for p in parameters(entry)]


def test_every_entry_point_is_walked():
    """The table covers the whole public API: every class and function deformkit exports."""
    exported = {n for n in dk.__all__ if callable(getattr(dk, n))}
    walked = {e.split(".")[0] for e in ENTRY_POINTS} | {"Deformer", "Lattice", "CageDeformer"}
    results = {"LatticeBinding", "BarrDeformer", "DirectManipulation", "SubdividedMesh", "SmoothnessReport", "build_info",
               "CageBinding", "RBFBinding", "MeshDeformBinding", "VolumeRatioBounds", "FoldCertificate"}
    assert exported - walked - results == set()


def test_valid_calls_succeed():
    for entry, (function, _, args, kwargs) in ENTRY_POINTS.items():
        function(*args, **kwargs)


@pytest.mark.parametrize("entry, name", CASES, ids=[f"{e}-{n}" for e, n in CASES])
def test_wrong_values_name_their_argument(entry, name):
    annotation = next(p.annotation for p in parameters(entry) if p.name == name)
    scalars = BAD_INTEGERS if "SupportsInt" in annotation else BAD_REALS if "SupportsFloat" in annotation else []
    for value in BAD_VALUES + scalars:
        try:
            call_with(entry, name, value)
        except (TypeError, ValueError, OverflowError) as exc:
            message = str(exc)
            assert "incompatible function arguments" not in message and "incompatible constructor" not in message
            assert names_argument(message, name), f"{entry}({name}={value!r}): {message}"
        else:
            pytest.fail(f"{entry}({name}={value!r}) was accepted")


@pytest.mark.parametrize("entry", list(ENTRY_POINTS))
def test_misspelt_keywords_suggest_the_nearest_name(entry):
    function, _, args, kwargs = ENTRY_POINTS[entry]
    for p in parameters(entry):
        if len(p.name) < 4:
            continue
        typo = p.name + "s"
        if typo in {q.name for q in parameters(entry)}:
            continue
        with pytest.raises(TypeError) as info:
            function(*args, **dict(kwargs, **{typo: 1}))
        message = str(info.value)
        assert f"unknown keyword argument '{typo}'" in message, message
        assert f"did you mean '{p.name}'" in message, message


@pytest.mark.parametrize("entry", list(ENTRY_POINTS))
def test_too_many_positional_arguments(entry):
    function, _, args, kwargs = ENTRY_POINTS[entry]
    positional = [p for p in parameters(entry) if not p.keyword_only]
    filler = list(args) + [None] * (len(positional) - len(args)) + [None]
    with pytest.raises(TypeError, match=rf"takes at most {len(positional)} positional argument"):
        function(*filler)


def test_messages_blame_the_right_argument():
    cases = [
        (lambda: dk.Bend(region=(np.inf, np.inf)), "region:"),
        (lambda: dk.BezierFFD(blocks=(64, 64, 64)), "blocks:"),
        (lambda: dk.FFD(degree=(15, 15, 15)), None),
        (lambda: dk.ExtendedFFD.prism([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [0, 0, 1]), "triangle:"),
        (lambda: dk.ExtendedFFD.prism(TRIANGLE, [1, 1, 0]), "height:"),
        (lambda: dk.ExtendedFFD.cylinder(radius=1e300), "radius:"),
        (lambda: dk.ExtendedFFD.cylinder(height=1e300), "height:"),
        (lambda: dk.ExtendedFFD.cylinder(radius=1e-300), "radius:"),
        (lambda: dk.SurfaceDeformer(GRID, QUADS, anchors=[0], iterations=2**31), "iterations: must be 1..10000"),
        (lambda: dk.subdivide(CUBE, CUBE_FACES, 2**31), "level: must be 1..8, got 2147483648"),
        (lambda: limit().evaluate([0], [[0.5, 0.5]], derivatives=2**31), "derivatives: must be 0..2"),
        (lambda: dk.ExtendedFFD.cylinder(max_iterations=2**40), "max_iterations: must be 1..1000"),
    ]
    for make, words in cases:
        if words is None:
            make()
            continue
        with pytest.raises(ValueError) as info:
            make()
        assert str(info.value).startswith(words), str(info.value)


@pytest.mark.parametrize("make, name", [
    (lambda: dk.Twist(limits=np.array(1.0)), "limits"),
    (lambda: dk.Twist(profile=np.array(1.0)), "profile"),
    (lambda: dk.Bend(region=np.array(0.5)), "region"),
    (lambda: dk.BezierFFD(blocks=np.array([1, 2])), "blocks"),
    (lambda: dk.Stack(np.array(1.0)), "deformers"),
    (lambda: dk.BlenderLattice(2, np.array("linear")), "interpolation"),
    (lambda: dk.subdivide(CUBE, np.array(3), 1), "faces"),
])
def test_zero_dimensional_arrays_for_sequences(make, name):
    """A 0-d array passes for a sequence but has no length: named, not "len() of unsized object"."""
    with pytest.raises((TypeError, ValueError)) as info:
        make()
    assert str(info.value).startswith(name + ":"), str(info.value)


def test_unbound_methods_called_on_the_wrong_object():
    with pytest.raises(TypeError, match=r"^Lattice.bind\(\): called on Twist .*, not on a Lattice"):
        dk.Lattice.bind(dk.Twist(), PTS)
    with pytest.raises(TypeError, match=r"^Deformer.deform\(\): called on NoneType None, not on a Deformer"):
        dk.Deformer.deform(None, PTS)


def test_generated_lattices_are_scale_free_and_name_their_own_arguments():
    """A cylinder or prism of any size or aspect a double can hold is built; one it cannot is refused
    naming the generator's arguments, not rest_control_points (which the caller never gave)."""
    for make in (lambda: dk.ExtendedFFD.cylinder(radius=1e-5), lambda: dk.ExtendedFFD.cylinder(radius=1e8),
                 lambda: dk.ExtendedFFD.cylinder(height=1e6),
                 lambda: dk.ExtendedFFD.prism(np.eye(3) * 1e-100, [0, 0, 1e-100]),
                 lambda: dk.ExtendedFFD.prism(np.eye(3) * 1e60, [0, 0, 1e60])):
        lattice = make()
        inside = lattice.rest_control_points.reshape(-1, 3).mean(axis=0, keepdims=True)
        np.testing.assert_array_equal(lattice.deform(inside), inside)
    for make, words in [(lambda: dk.ExtendedFFD.cylinder(1e39), "radius, height, center: the cylinder"),
                        (lambda: dk.ExtendedFFD.cylinder(center=[1e20, 0, 0]), "radius, height, center: the cylinder"),
                        (lambda: dk.ExtendedFFD.prism(np.eye(3), [0, 0, np.nan]), "height: must be finite"),
                        (lambda: dk.ExtendedFFD.prism(np.eye(3), [0, 0, 1e300]), "height: must be at most 1e100")]:
        with pytest.raises(ValueError) as info:
            make()
        assert str(info.value).startswith(words), str(info.value)


def test_direct_manipulation_from_absurd_control_points_names_them():
    lattice = dk.FFD(2)
    lattice.control_points = lattice.rest_control_points * 1e308
    with pytest.raises(ValueError, match="^targets: .* where the current control_points put the points"):
        lattice.direct_manipulation(np.full((1, 3), 0.5), np.full((1, 3), 0.6))


def test_the_deformer_argument_keeps_its_name():
    """Only a deformer's own overflow is renamed to its type; a deformer= argument stays named."""
    with pytest.raises(ValueError, match="^deformer: has per-point weights"):
        dk.LimitSurface(CUBE, CUBE_FACES).smoothness_report(deformer=dk.Twist(weights=np.ones(8)))


def test_a_strength_too_small_for_direct_manipulation_is_named():
    with pytest.raises(ValueError, match=r"^strength: 4.94066e-324 is too small"):
        dk.BSplineLattice(4, strength=5e-324).direct_manipulation(PTS[:4] * 0.3 + 0.5, PTS[:4] * 0.3 + 0.6)

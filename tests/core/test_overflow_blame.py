"""An overflow is blamed on the argument that is at fault.

docs/errors.md, "Overflow blames the argument at fault": points beyond the magnitude a deformer
maps are named `points` (row, value, accepted magnitude) -- or mapped to a finite result -- for
every deformer, in place too; a parameter set to a huge or degenerate value is named itself."""
import numpy as np
import pytest

import deformkit as dk

CUBE = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
CUBE_FACES = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
C = np.random.default_rng(0).random((30, 3))
# sqrt(DBL_MAX) / 16: the accepted magnitude the messages state.
RANGE = np.sqrt(np.finfo(np.float64).max) / 16

DEFORMERS = {
    "Twist": lambda: dk.Twist(rate=1.0), "Taper": lambda: dk.Taper(rate=0.5), "Stretch": lambda: dk.Stretch(),
    "Bend": lambda: dk.Bend(curvature=0.5), "SimpleDeform": lambda: dk.SimpleDeform().bind(C),
    "Stack": lambda: dk.Stack([dk.Twist(rate=1.0), dk.Taper(rate=0.5)]),
    "FFD": lambda: dk.FFD(2), "BSplineLattice": lambda: dk.BSplineLattice(4, outside="extrapolate"),
    "BezierFFD": lambda: dk.BezierFFD(1, outside="extrapolate"), "BlenderLattice": lambda: dk.BlenderLattice(3),
    "MeanValueCage": lambda: dk.MeanValueCage(CUBE, CUBE_FACES), "GreenCage": lambda: dk.GreenCage(CUBE, CUBE_FACES),
    "RBF": lambda: dk.RBF(C, C + 0.1), "RBF.gaussian": lambda: dk.RBF(C, C + 0.1, kernel="gaussian", epsilon=2.0),
    "RBF.quintic": lambda: dk.RBF(C, C + 0.1, kernel="quintic"),
    "RBF.wendland": lambda: dk.RBF(C, C + 0.1, kernel="wendland_c2", radius=0.5),
}
METHODS = ["deform", "displacement", "jacobian", "volume_ratio"]


@pytest.mark.parametrize("name", list(DEFORMERS))
@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("value", [1e154, 1e200, -1e300])
def test_points_out_of_range_are_named_points(name, method, value):
    points = np.full((3, 3), 0.5)
    points[1] = value
    try:
        result = getattr(DEFORMERS[name](), method)(points)
    except ValueError as exc:
        message = str(exc)
        assert message.startswith("points: row 1 maps to a non-finite "), message
        assert f"its coordinates ({value:g}, {value:g}, {value:g}) are beyond the magnitude" in message, message
        assert f"|coordinate| < {RANGE:.3g}" in message, message
    else:
        assert np.isfinite(result).all()


@pytest.mark.parametrize("make, name", [
    (lambda: dk.RBF(C, C + 0.1, kernel="gaussian", epsilon=1e-300), "epsilon"),
    (lambda: dk.RBF(C, C + 0.1, kernel="multiquadric", epsilon=1e300), "epsilon"),
    (lambda: dk.RBF(C, C + 0.1, kernel="gaussian", epsilon=-1.0), "epsilon"),
    (lambda: dk.RBF(C, C + 0.1, kernel="wendland_c2", radius=1e300), "radius"),
    (lambda: dk.RBF(C, C + 0.1, kernel="wendland_c2", radius=1e-300), "radius"),
    (lambda: dk.RBF(C, C + 0.1, smoothing=-1.0), "smoothing"),
    (lambda: dk.RBF(C * 1e154, kernel="wendland_c2", radius=1.0), "control_points"),
    (lambda: dk.RBF(C * 1e154), "control_points"),
    (lambda: dk.extrapolated_start(C, C, C, C * 1e300, C), "previous_targets"),
    (lambda: dk.extrapolated_start(C, C, C, C, C * 1e300), "earlier_targets"),
])
def test_a_bad_parameter_is_named(make, name):
    try:
        make()
    except ValueError as exc:
        assert str(exc).startswith(f"{name}:"), str(exc)
    else:
        pytest.fail("accepted")


def with_cage_points(cage, points):
    cage.cage_points = points
    return cage


def with_control_points(lattice, scale):
    lattice.control_points = lattice.rest_control_points * scale
    return lattice


# A parameter at a huge value, a point within range: the overflow names the deformer and that parameter.
HUGE_PARAMETERS = [
    (lambda: dk.Twist(rate=1e308, limits=(-1e10, 1e10)), "Twist", "rate"),
    (lambda: dk.Taper(rate=1e308), "Taper", "rate"),
    (lambda: dk.Stretch(factor=1e308), "Stretch", "factor"),
    (lambda: dk.Bend(curvature=1e308), "Bend", "curvature"),
    (lambda: dk.SimpleDeform("TAPER", factor=1e308).bind(C), "BarrDeformer", "factor"),
    (lambda: with_control_points(dk.FFD(2), 1e308), "FFD", "control_points"),
    (lambda: dk.FFD(2, control_points=dk.FFD(2).rest_control_points + 1e10, strength=1e300), "FFD", "strength"),
    (lambda: with_cage_points(dk.MeanValueCage(CUBE, CUBE_FACES), CUBE * 1e308), "MeanValueCage", "cage_points"),
    (lambda: with_cage_points(dk.GreenCage(CUBE, CUBE_FACES), CUBE * 1e308), "GreenCage", "cage_points"),
    (lambda: dk.RBF(C, C * 1e307), "RBF", "targets"),
    (lambda: dk.RBF(C, C + 0.1, kernel="gaussian", epsilon=1e300), "RBF", "epsilon"),
]


@pytest.mark.parametrize("make, kind, name", HUGE_PARAMETERS, ids=[f"{k}-{n}" for _, k, n in HUGE_PARAMETERS])
def test_huge_parameters_are_named(make, kind, name):
    points = np.random.default_rng(1).uniform(-2, 2, (50, 3))
    deformer = make()
    with pytest.raises(ValueError) as info:
        for method in METHODS:
            getattr(deformer, method)(points)
    message = str(info.value)
    assert message.startswith(f"{kind}: row "), message
    assert "its parameters (" in message and name in message.split("its parameters (")[1].split(")")[0], message
    assert "is within the accepted magnitude" in message, message


@pytest.mark.parametrize("value", [1e154, 1e200, -1e300])
def test_in_place_points_out_of_range_are_named_points(value):
    for make in (DEFORMERS["Stretch"], DEFORMERS["RBF"], DEFORMERS["MeanValueCage"], DEFORMERS["Stack"]):
        points = np.full((3, 3), 0.5)
        points[2] = value
        try:
            make().deform(points, out=points)
        except ValueError as exc:
            assert str(exc).startswith("points: row 2 maps to a non-finite position: its coordinates"), str(exc)


def test_a_fast_growing_kernel_maps_a_shorter_range():
    """The quintic kernel grows as r^5: a point at 1e100 is beyond what it maps, and is named."""
    with pytest.raises(ValueError, match=r"^points: row 0 maps to a non-finite position: its coordinates \(1e\+100"):
        DEFORMERS["RBF.quintic"]().deform(np.full((1, 3), 1e100))

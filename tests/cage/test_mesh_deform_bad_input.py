"""dk.MeshDeform refuses what Blender's Mesh Deform cannot bind, naming the argument, what it got
and what it accepts: the cage errors every cage deformer gives, a precision outside Blender's 2..10,
Blender's "cannot find a bind solution" (no grid cell inside the cage), and bad points, cages and
bindings later on."""
import numpy as np
import pytest

import deformkit as dk

CUBE = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
FACES = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]


def message(call, kind=(ValueError, TypeError)):
    with pytest.raises(kind) as info:
        call()
    return str(info.value)


@pytest.mark.parametrize("points,faces", [
    (CUBE, FACES[:5]),                                                    # open
    (CUBE, [f[::-1] if i == 3 else f for i, f in enumerate(FACES)]),      # inconsistent orientation
    (CUBE, [[4, 6, 7, 6] if i == 1 else f for i, f in enumerate(FACES)]),  # a repeated vertex
    (np.where(np.arange(8)[:, None] >= 4, CUBE * [0, 1, 1], CUBE), FACES),  # a zero-area face
    (CUBE, [[8, 1, 3, 2]] + FACES[1:]),                                     # an index out of range
    (np.vstack([CUBE, CUBE + 0.4]), FACES + [[v + 8 for v in f] for f in FACES]),  # self-intersecting
    (CUBE[:, :2], FACES),
])
def test_bad_cages_get_the_cage_family_errors(points, faces):
    expected = message(lambda: dk.MeanValueCage(points, faces))
    assert message(lambda: dk.MeshDeform(points, faces)) == expected


def test_nan_cage_point_is_named():
    nan = CUBE.copy()
    nan[1, 1] = np.nan
    assert message(lambda: dk.MeshDeform(nan, FACES)).startswith("cage_points: row 1 is not finite")


@pytest.mark.parametrize("value,words", [
    (1, "precision: must be 2..10, got 1"), (11, "precision: must be 2..10, got 11"),
    (2 ** 40, "precision: must be 2..10, got 1099511627776"),
    (2.5, "precision: expected an integer, not a float"), ("5", "precision: expected an integer"),
])
def test_precision_outside_blenders_range_is_refused(value, words):
    assert message(lambda: dk.MeshDeform(CUBE, FACES, precision=value)).startswith(words)


@pytest.mark.parametrize("kwargs,words", [
    ({"dynamic": "yes"}, "dynamic: expected True or False, got str 'yes'"),
    ({"blender_version": "5.0"}, "blender_version: expected (major, minor) integers of a Blender release"),
    ({"blender_version": (1, 0)}, "blender_version: expected (major, minor) integers"),
    ({"blender_version": (5,)}, "blender_version: expected (major, minor) integers"),
    ({"blender_version": (5.0, 0)}, "blender_version: expected (major, minor) integers"),
])
def test_bad_keywords_are_named(kwargs, words):
    assert message(lambda: dk.MeshDeform(CUBE, FACES, **kwargs)).startswith(words)


def test_no_cell_inside_the_cage_is_blenders_bind_failure():
    """A slab thinner than the cells and between their centres leaves no unknown: Blender binds
    nothing there ("failed to find bind solution"); deformkit says so, naming the cage and the way out."""
    slab = CUBE * [10, 10, 0.5]
    text = message(lambda: dk.MeshDeform(slab, FACES, precision=2), ValueError)
    assert text.startswith("cage_points: cannot find a bind solution: no cell of the precision-2 grid lies inside the cage")
    assert text.endswith("raise precision")
    assert dk.MeshDeform(slab, FACES, precision=6).unknowns > 0  # finer cells reach inside


def test_bad_cage_points_points_and_bindings():
    md = dk.MeshDeform(CUBE, FACES, precision=3)
    for value, words in [(CUBE[:3], "cage_points: expected shape (8, 3), got (3, 3)"),
                         (np.full((8, 3), np.inf), "cage_points: point 0 is not finite"),
                         ("cube", "cage_points: expected real numbers")]:
        def assign(v=value):
            md.cage_points = v
        assert message(assign).startswith(words)
    np.testing.assert_array_equal(md.cage_points, CUBE)  # a refused assignment changes nothing
    bad = np.array([[0.5, 0.5, 0.5], [np.nan, 0, 0]])
    assert message(lambda: md.bind(bad)).startswith("points: row 1 is not finite")
    assert message(lambda: md.deform(bad)).startswith("points: row 1 is not finite")
    assert message(lambda: md.bind("x")).startswith("points: expected a numpy array of shape (n, 3)")
    binding = md.bind(np.full((3, 3), 0.5))
    assert message(lambda: dk.MeshDeform(CUBE, FACES, precision=4).deform_bound(binding)).startswith(
        "binding: was made by another MeshDeform (another rest cage, precision, bind mode or blender_version)")
    assert message(lambda: md.deform_bound(dk.MeanValueCage(CUBE, FACES).bind(np.full((3, 3), 0.5)))).startswith(
        "binding: expected a MeshDeformBinding")
    assert message(lambda: dk.MeanValueCage(CUBE, FACES).deform_bound(binding)).startswith("binding: expected a CageBinding")
    weighted = dk.MeshDeform(CUBE, FACES, precision=3, weights=np.full(5, 0.5))
    assert message(lambda: weighted.deform_bound(weighted.bind(np.full((3, 3), 0.5)))).startswith(
        "weights: has 5 entries but the binding has 3 points")


def saved_bind(dynamic=False):
    """A static bind of points in and around the cube, and its rows (binding.weights())."""
    md = dk.MeshDeform(CUBE, FACES, precision=3, dynamic=dynamic)
    pts = np.random.default_rng(1).uniform(-0.2, 1.2, (200, 3)).astype(np.float32)
    return md, pts, md.bind(pts)


def with_value(rows, k, value):
    indptr, indices, data = (np.array(a) for a in rows)
    data[k] = value
    return indptr, indices, data


def test_rows_that_are_no_static_bind_of_the_points_are_refused():
    md, pts, b = saved_bind()
    indptr, indices, data = b.weights()
    first = int(np.flatnonzero(np.diff(indptr) >= 2)[0])  # a point with two or more weights
    at = int(indptr[first])
    swapped = indices.copy()
    swapped[[at, at + 1]] = swapped[[at + 1, at]]
    outside = int(np.flatnonzero(~b.inside)[0])
    flags = b.inside.copy()
    flags[first] = False
    cases = [
        ((indptr[:-1], indices, data), None, "rows: indptr: expected shape (201,), got (200,)"),
        ((indptr, indices, data[:-1]), None, f"rows: data: expected shape ({len(indices)},), got ({len(indices) - 1},)"),
        ((indptr, indices.astype(float), data), None, "rows: indices: expected integer cage vertex indices"),
        ((indptr, np.where(np.arange(len(indices)) == at, 8, indices), data), None, "rows: column 8 is outside 0..8 - 1"),
        ((indptr, swapped, data), None, f"rows: the cage vertices of point {first}'s row do not rise"),
        (with_value(b.weights(), at, 0.0), None, f"rows: weight {at} is 0.000000, not in (0, 1]"),
        (with_value(b.weights(), at, 1.5), None, f"rows: weight {at} is 1.500000, not in (0, 1]"),
        (with_value(b.weights(), at, np.nan), None, f"rows: weight {at} is not finite"),
        (with_value(b.weights(), at, data[at] / 2), None, f"rows: point {first}'s weights sum to"),
        ((indptr, indices, data), flags, f"rows: point {first} has a row but is outside the cage"),
        ((indptr, indices), None, "rows: expected 3 arrays (indptr, indices, data)"),
        ("rows", None, "rows: expected (indptr, indices, data)"),
    ]
    assert not b.inside[outside]
    for rows, inside, words in cases:
        assert message(lambda: md.bind(pts, rows=rows, inside=inside)).startswith(words), words
    dynamic, _, _ = saved_bind(dynamic=True)
    assert message(lambda: dynamic.bind(pts, rows=b.weights())).startswith("rows: a dynamic MeshDeform keeps no rows")
    assert message(lambda: md.bind(pts, rows=b.weights(), inside=b.inside[:-1])).startswith(
        "inside: expected one flag per point, shape (200,)")

"""Every cage the coordinates cannot use, and every bad argument, is refused with an error that
names the argument, what it got and what it accepts; the first offending face or edge is named."""
import numpy as np
import pytest

import deformkit as dk

CUBE = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
FACES = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]


def refused(points, faces):
    with pytest.raises((ValueError, TypeError)) as info:
        dk.MeanValueCage(points, faces)
    return str(info.value)


def test_bad_cages_name_the_first_offence():
    assert refused(CUBE, FACES[:5]) == ("cage_faces: edge (1, 3) of face 0 belongs to no other face: "
                                        "the cage is open (it must be closed)")
    turned = [f[::-1] if i == 3 else f for i, f in enumerate(FACES)]
    assert refused(CUBE, turned).startswith("cage_faces: edge (3, 2) runs the same way in faces 0 and 3: "
                                            "inconsistent orientation")
    fin = np.vstack([CUBE, [[-1, 0, 0.5]]])
    assert refused(fin, FACES + [[0, 1, 8]]).startswith("cage_faces: edge (0, 1) is shared by 3 faces (0, 2, 6)")
    assert refused(CUBE, [[4, 6, 7, 6] if i == 1 else f for i, f in enumerate(FACES)]).startswith(
        "cage_faces: face 1 repeats vertex 6")
    flat = CUBE.copy()
    flat[4:, 0] = 0
    assert refused(flat, FACES) == "cage_faces: face 2 has zero area (degenerate)"
    assert refused(CUBE, [[8, 1, 3, 2]] + FACES[1:]).startswith("cage_faces: face 0 has corner index 8, outside 0..7")
    nan = CUBE.copy()
    nan[1, 1] = np.nan
    assert refused(nan, FACES).startswith("cage_points: row 1 is not finite")
    two = np.vstack([CUBE, CUBE + [0.5, 0.3, 0.4]])
    assert refused(two, FACES + [[v + 8 for v in f] for f in FACES]).endswith(
        "intersect (the cage intersects itself)")
    assert refused(CUBE, [[0, 1]] + FACES[1:]).startswith("cage_faces: ")
    assert refused(CUBE[:, :2], FACES).startswith("cage_points: expected shape (n, 3), got (8, 2)")
    assert refused(CUBE.tolist(), FACES).startswith("cage_points: expected a numpy array")
    assert refused(CUBE, "faces").startswith("cage_faces: ")
    assert refused(CUBE, np.array(FACES, float)).startswith("cage_faces: expected integer vertex indices")


def test_bad_cage_points_and_binding_arguments():
    cage = dk.MeanValueCage(CUBE, FACES)
    for value, words in [(CUBE[:3], "cage_points: expected shape (8, 3), got (3, 3)"),
                         (np.full((8, 3), np.inf), "cage_points: point 0 is not finite"),
                         ("cube", "cage_points: expected real numbers"),
                         (CUBE + 1j, "cage_points: ")]:
        with pytest.raises((ValueError, TypeError)) as info:
            cage.cage_points = value
        assert str(info.value).startswith(words), str(info.value)
    np.testing.assert_array_equal(cage.cage_points, CUBE)  # a refused assignment changes nothing
    pts = np.full((4, 3), 0.5)
    for kwargs, words in [({"precision": "float16"}, "precision: expected 'float64' or 'float32', got 'float16'"),
                          ({"sparsify": 0.0}, "sparsify: expected a positive threshold"),
                          ({"sparsify": np.nan}, "sparsify: "),
                          ({"sparsify": 0.1, "precision": "float32"},
                           "sparsify: a sparsified binding keeps its weights in the points' dtype"),
                          ({"sparsify": 2.0}, "sparsify: threshold 2.000000 leaves the weights of point 0 summing to zero")]:
        with pytest.raises(ValueError) as info:
            cage.bind(pts, **kwargs)
        assert str(info.value).startswith(words), str(info.value)
    with pytest.raises(ValueError, match="^points: row 1 is not finite"):
        cage.bind(np.array([[0.5, 0.5, 0.5], [np.nan, 0, 0]]))


def test_a_binding_is_used_only_by_its_cage():
    cage = dk.MeanValueCage(CUBE, FACES)
    other = dk.MeanValueCage(CUBE * 2, FACES)
    b = cage.bind(np.full((3, 3), 0.5))
    with pytest.raises(ValueError, match="^binding: was made by a cage of another coordinate kind or rest cage"):
        other.deform_bound(b)
    with pytest.raises(TypeError, match="binding"):
        cage.deform_bound(dk.FFD(2).bind(np.full((3, 3), 0.5)))
    weighted = dk.MeanValueCage(CUBE, FACES, weights=np.full(5, 0.5))
    with pytest.raises(ValueError, match="^weights: has 5 entries but the binding has 3 points"):
        weighted.deform_bound(weighted.bind(np.full((3, 3), 0.5)))
    with pytest.raises(TypeError, match="^out: must have dtype float64"):
        cage.deform_bound(b, out=np.zeros((3, 3), np.float32))

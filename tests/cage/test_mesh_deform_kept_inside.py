"""A dynamic MeshDeform bound with the inside flags of Bind (`bind(points, inside=...)`), as
Blender's dynamic bind keeps them (its dynverts): the flags, not where the points are now, decide
which points deform, and a kept point is interpolated from the grid wherever it went. The truth for
points in both sets is the plain dynamic binding; against Blender's own modifier, see
tests/addon/test_mesh_deform_addon.py::test_a_dynamic_bind_keeps_the_points_inside_at_bind."""
import numpy as np
import pytest

import deformkit as dk

CUBE = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
FACES = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]


def moved_cage(md, seed):
    md.cage_points = CUBE + np.random.default_rng(seed).normal(0.0, 0.08, CUBE.shape)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_the_flags_of_bind_decide_which_points_deform(dtype):
    md = dk.MeshDeform(CUBE, FACES, precision=4, dynamic=True)
    rng = np.random.default_rng(1)
    at_bind = rng.uniform(-0.2, 1.2, (400, 3)).astype(dtype)
    kept = md.bind(at_bind).inside
    now = (at_bind + rng.normal(0.0, 0.15, at_bind.shape)).astype(dtype)  # some cross the cage either way
    plain = md.bind(now)
    crossed = kept != plain.inside
    assert crossed.sum() > 20, "the test needs points that crossed the cage"
    bound = md.bind(now, inside=kept)
    np.testing.assert_array_equal(bound.inside, kept)
    moved_cage(md, 2)
    ours, theirs = md.deform_bound(bound), md.deform_bound(plain)
    both = kept & plain.inside
    np.testing.assert_array_equal(ours[both], theirs[both])  # the same interpolation where both deform
    np.testing.assert_array_equal(ours[~kept], now[~kept])  # not inside at bind: not deformed
    assert np.abs(ours[kept & ~plain.inside] - now[kept & ~plain.inside]).max() > 1e-3  # kept: still deformed
    assert np.isfinite(ours).all()


def test_kept_points_far_outside_the_grid_stay_finite():
    """A kept point that left the grid is interpolated from its clamped edge cells, as Blender
    clamps the cell indices; cells without coordinates give no displacement, not a division by 0."""
    md = dk.MeshDeform(CUBE, FACES, precision=3, dynamic=True)
    far = np.array([[0.5, 0.5, 0.5], [50.0, 0.5, 0.5], [-1e6, 3.0, 0.5]])
    bound = md.bind(far, inside=np.ones(3, bool))
    moved_cage(md, 3)
    out = md.deform_bound(bound)
    assert np.isfinite(out).all()
    np.testing.assert_allclose(md.displacement_bound(bound), out - far, rtol=0, atol=1e-12)


def test_flags_equal_to_the_ray_test_give_the_plain_binding():
    md = dk.MeshDeform(CUBE, FACES, precision=3, dynamic=True)
    points = np.random.default_rng(4).uniform(-0.3, 1.3, (200, 3))
    plain = md.bind(points)
    flagged = md.bind(points, inside=plain.inside)
    moved_cage(md, 5)
    np.testing.assert_array_equal(md.deform_bound(flagged), md.deform_bound(plain))


@pytest.mark.parametrize("inside,kind,words", [
    ([1, 0, 1], TypeError, "inside: expected one True/False flag per point (a bool array), got dtype int64"),
    (np.ones(3, np.float32), TypeError, "inside: expected one True/False flag per point (a bool array), got dtype"),
    ("yes", TypeError, "inside: expected one True/False flag per point"),
    (np.ones(2, bool), ValueError, "inside: expected one flag per point, shape (3,), got shape (2,)"),
    (np.ones((3, 1), bool), ValueError, "inside: expected one flag per point, shape (3,), got shape (3, 1)"),
])
def test_bad_flags_are_named(inside, kind, words):
    md = dk.MeshDeform(CUBE, FACES, precision=3, dynamic=True)
    with pytest.raises(kind) as info:
        md.bind(np.full((3, 3), 0.5), inside=inside)
    assert str(info.value).startswith(words), str(info.value)


def test_a_static_bind_refuses_flags():
    md = dk.MeshDeform(CUBE, FACES, precision=3)
    with pytest.raises(ValueError, match="^inside: only a dynamic MeshDeform takes"):
        md.bind(np.full((3, 3), 0.5), inside=np.ones(3, bool))

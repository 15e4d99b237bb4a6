"""dk.GreenCage against what defines Green coordinates: linear reproduction (sum phi v + sum psi n
= x) inside, near and, through the exterior extension, outside the cage; similarities of the cage
reproduced; continuity across the cage surface; central differences for the Jacobian; and, under
the same cage edit, less angle distortion of small triangles than mean value coordinates."""
import numpy as np
import pytest

import deformkit as dk

from test_mean_value_cage import CUBE, CUBE_FACES, L_FACES, L_POINTS, inside_l, weights_of


def reproduction_error(cage, x):
    """|sum phi v + sum psi n - x| per point, from the binding's weights and the rest cage's unit normals."""
    w = weights_of(cage, x)
    m = len(cage.rest_cage_points)
    p = cage.rest_cage_points[cage.triangles]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return np.linalg.norm(w[:, :m] @ cage.rest_cage_points + w[:, m:] @ n - x, axis=1), w[:, :m].sum(1)


def stretched_normals(cage):
    """s_k n_k of each deformed cage triangle: its unit normal times the stretch factor of Lipman,
    Levin and Cohen-Or (2008, "Green Coordinates"; 1 for a rigid motion of the triangle), the
    columns the normal weights multiply (cage.stretch is True); checked against deform below."""
    tris = cage.triangles
    (a, b, c), (a2, b2, c2) = ([p[tris[:, i]] for i in range(3)] for p in (cage.rest_cage_points, cage.cage_points))
    u, v, u2, v2 = b - a, c - a, b2 - a2, c2 - a2
    area = 0.5 * np.linalg.norm(np.cross(u, v), axis=1)
    s = np.sqrt((u2 * u2).sum(1) * (v * v).sum(1) - 2 * (u2 * v2).sum(1) * (u * v).sum(1)
                + (v2 * v2).sum(1) * (u * u).sum(1)) / (np.sqrt(8) * area)
    n = np.cross(u2, v2)
    return s[:, None] * n / np.linalg.norm(n, axis=1, keepdims=True)


def similarity(x, s=1.7):
    c, si = np.cos(0.6), np.sin(0.6)
    r = np.array([[c, -si, 0], [si, c, 0], [0, 0, 1]]) @ np.array([[1, 0, 0], [0, c, -si], [0, si, c]])
    return s * x @ r.T + np.array([0.4, -0.2, 1.1])


def test_linear_reproduction_inside_near_and_outside(rng):
    cage = dk.GreenCage(L_POINTS, L_FACES)
    assert cage.columns == len(L_POINTS) + len(cage.triangles)
    inside = rng.uniform(0, 2, (400, 3)) * [1, 1, 0.5]
    inside = inside[inside_l(inside)]
    near = np.array([[1e-3, 0.5, 0.5], [1e-7, 0.3, 0.6], [1e-11, 1.5, 0.4], [0.5, 0.5, 1 - 1e-9]])
    outside = np.array([[-0.5, 0.5, 0.5], [2.7, 0.4, 0.3], [1.3, 1.6, 0.5], [0.5, 0.5, 1.8], [-1.0, -1.0, -1.0]])
    for points in (inside, near, outside):
        err, total = reproduction_error(cage, points)
        assert err.max() < 1e-12 * 10 and np.abs(total - 1).max() < 1e-12, (points, err.max())


@pytest.mark.parametrize("stretch", [True, False])
def test_similarities_of_the_cage(rng, stretch):
    cage = dk.GreenCage(CUBE, CUBE_FACES, stretch=stretch)
    x = np.r_[rng.uniform(0.05, 0.95, (50, 3)), rng.uniform(-0.5, 1.5, (50, 3))]
    cage.cage_points = similarity(CUBE, 1.0)  # a rigid motion: s_j = 1 either way
    np.testing.assert_allclose(cage.deform(x), similarity(x, 1.0), atol=1e-11)
    cage.cage_points = similarity(CUBE, 1.7)
    if stretch:  # Lipman's stretch factors: a scaled cage scales the normals' part too
        np.testing.assert_allclose(cage.deform(x), similarity(x, 1.7), atol=1e-10)
    else:
        assert np.abs(cage.deform(x) - similarity(x, 1.7)).max() > 1e-2


def test_rest_cage_is_the_identity_and_bound_equals_deform(rng):
    cage = dk.GreenCage(L_POINTS, L_FACES)
    x = rng.uniform(-0.3, 2.3, (300, 3))
    assert cage.deform(x).tobytes() == x.tobytes()
    b = cage.bind(x)
    cage.cage_points = L_POINTS + rng.normal(0, 0.1, L_POINTS.shape)
    np.testing.assert_allclose(cage.deform_bound(b), cage.deform(x), atol=1e-12)
    y32 = cage.deform_bound(cage.bind(x.astype(np.float32), precision="float32"))
    assert y32.dtype == np.float32
    y, w = cage.deform(x), weights_of(cage, x)
    columns = np.r_[cage.cage_points, stretched_normals(cage)]  # what the weights multiply
    np.testing.assert_allclose(w @ columns, y, rtol=0, atol=1e-12)
    # float32 rounds three things by half an eps each: the points (moved through the Jacobian), every
    # weight (times its column's length) and the result; weights summed in float32 would cost more.
    half = 0.5 * np.finfo(np.float32).eps
    tol = half * (np.abs(cage.jacobian(x)).sum(2).max(1) * np.abs(x).max(1)
                  + np.abs(w) @ np.linalg.norm(columns, axis=1) + np.abs(y).max(1))
    assert (np.abs(y32 - y).max(1) <= tol).all(), (np.abs(y32 - y).max(1) / tol).max()


def test_jacobian_matches_central_differences(rng):
    cage = dk.GreenCage(CUBE, CUBE_FACES)
    cage.cage_points = CUBE + rng.normal(0, 0.1, CUBE.shape)
    x = rng.uniform(0.1, 0.9, (40, 3))
    j = cage.jacobian(x)
    h = 1e-6
    for c in range(3):
        e = np.zeros(3)
        e[c] = h
        fd = (cage.deform(x + e) - cage.deform(x - e)) / (2 * h)
        np.testing.assert_allclose(j[:, :, c], fd, atol=1e-6)


def test_continuous_across_the_cage_surface(rng):
    """The exterior extension: a point just inside and just outside a face deform to the same place."""
    cage = dk.GreenCage(CUBE, CUBE_FACES)
    cage.cage_points = CUBE + rng.normal(0, 0.1, CUBE.shape)
    on = np.c_[np.zeros(20), rng.uniform(0.1, 0.9, (20, 2))]  # on the face x = 0
    step = np.array([1e-9, 0, 0])
    jump = np.abs(cage.deform(on + step) - cage.deform(on - step)).max()
    assert jump < 1e-7, jump


def angle_distortion(before, after, tris):
    def angles(p):
        a, b, c = p[tris[:, 0]], p[tris[:, 1]], p[tris[:, 2]]
        def angle(u, v):
            return np.arctan2(np.linalg.norm(np.cross(u, v), axis=1), (u * v).sum(1))
        return np.stack([angle(b - a, c - a), angle(a - b, c - b), angle(a - c, b - c)], 1)
    return np.degrees(np.abs(angles(after) - angles(before))).mean()


def test_green_keeps_angles_better_than_mean_value(record_property):
    """Quasi-conformality: small triangles inside the cube, the same non-rigid cage edit."""
    g = np.linspace(0.2, 0.8, 9)
    centers = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    tri = np.array([[0, 0, 0], [0.02, 0, 0], [0, 0.02, 0.01]])
    points = (centers[:, None] + tri[None]).reshape(-1, 3)
    tris = np.arange(len(points)).reshape(-1, 3)
    edit = CUBE.copy()
    edit[CUBE[:, 2] > 0.5] *= [1.6, 1.0, 1.3]  # the top widens along x and rises
    edit[CUBE[:, 0] > 0.5, 1] += 0.3            # one side shears
    figures = {}
    for name, cage in (("green", dk.GreenCage(CUBE, CUBE_FACES)), ("mean value", dk.MeanValueCage(CUBE, CUBE_FACES))):
        cage.cage_points = edit
        figures[name] = float(angle_distortion(points, cage.deform(points), tris))
    record_property("mean angle change, degrees", figures)
    assert figures["green"] < 0.9 * figures["mean value"], figures

"""dk.GreenCage outside its cage (docs/math/green_coordinates.md, "Exterior extension"): the blend of
the per-face continuations is continuous, so tiny moves of a point (one ulp, 1e-9, its rounding to
float32) move its image by at most the move times the Jacobian's norm (checked against central
differences in test_green_cage.py and the C++ tests), plus rounding; linear and similarity
reproduction hold outside; bind, deform and sparse bindings agree there. On an edited
tetrahedron, the cube and a shared cage (Beast), at 1-3 cage radii."""
import numpy as np
import pytest

import deformkit as dk

from cage_files import CAGES, read_polygons, require_cages
from test_mean_value_cage import CUBE, CUBE_FACES

TETRAHEDRON = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float) + np.array(
    [[0.03, -0.02, 0.05], [-0.04, 0.01, 0.02], [0.02, 0.05, -0.03], [-0.01, -0.03, 0.04]])
TETRAHEDRON_FACES = np.array([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]])


def case(name, rng):
    """(rest points, faces, an edited cage) by name."""
    if name == "tetrahedron":
        return TETRAHEDRON, TETRAHEDRON_FACES, TETRAHEDRON + rng.normal(0, 0.15, TETRAHEDRON.shape)
    if name == "cube":
        return CUBE, CUBE_FACES, CUBE + rng.normal(0, 0.1, CUBE.shape)
    require_cages()
    rest, faces = read_polygons(CAGES / "Beast_Cage.obj")
    deformed, _ = read_polygons(CAGES / "Beast_Cage_Deformed.obj")
    return rest, faces, deformed


def exterior_points(rest, rng, n=400):
    """Random directions at 1-3 radii of the cage about its centroid, and each vertex pushed out to
    twice its distance (where the faces around it are equally near: the nearest-face rule's ties)."""
    centre = rest.mean(axis=0)
    radius = np.linalg.norm(rest - centre, axis=1).max()
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.r_[centre + d * radius * rng.uniform(1, 3, (n, 1)), centre + 2 * (rest - centre)]


def jacobian_norm(cage, x):
    return np.linalg.norm(cage.jacobian(x), axis=(1, 2))  # Frobenius: above the operator norm


def rounding(y, cage):
    """A few hundred ulps of the image's and the cage's scale: the evaluation's rounding, far below
    the nearest-face rule's jumps (0.1-4)."""
    return 2.0 ** -52 * 256 * (np.linalg.norm(y, axis=1) + np.abs(cage.cage_points).max())


@pytest.mark.parametrize("name", ["tetrahedron", "cube", "beast"])
def test_tiny_moves_outside_stay_within_the_lipschitz_bound(rng, name):
    rest, faces, edited = case(name, rng)
    cage = dk.GreenCage(rest, faces)
    cage.cage_points = edited
    x = exterior_points(rest, rng)
    y, lip = cage.deform(x), jacobian_norm(cage, x)
    for moved in (np.nextafter(x, np.inf), np.nextafter(x, -np.inf), x + 1e-9 * rng.choice([-1, 1], x.shape)):
        step = np.linalg.norm(moved - x, axis=1)
        bound = 1.01 * step * np.maximum(lip, jacobian_norm(cage, moved)) + rounding(y, cage)
        change = np.linalg.norm(cage.deform(moved) - y, axis=1)
        assert np.all(change <= bound), (change / bound).max()


@pytest.mark.parametrize("name", ["tetrahedron", "cube", "beast"])
def test_float32_and_float64_points_agree_to_float32_resolution(rng, name):
    rest, faces, edited = case(name, rng)
    cage = dk.GreenCage(rest, faces)
    cage.cage_points = edited
    x64 = exterior_points(rest, rng)
    x32 = x64.astype(np.float32)
    y64, y32 = cage.deform(x64), cage.deform(x32)
    assert y32.dtype == np.float32
    # |F(x32) - F(x64)| <= |x32 - x64| max |J| (1% for J's change over 1e-7), then the output's own
    # rounding to float32: half an ulp per coordinate.
    step = np.linalg.norm(x32.astype(np.float64) - x64, axis=1)
    lip = np.maximum(jacobian_norm(cage, x64), jacobian_norm(cage, x32.astype(np.float64)))
    bound = 1.01 * step * lip + 2.0 ** -24 * np.linalg.norm(y64, axis=1) + rounding(y64, cage)
    assert np.all(np.linalg.norm(y32.astype(np.float64) - y64, axis=1) <= bound)


@pytest.mark.parametrize("name", ["tetrahedron", "cube", "beast"])
def test_linear_and_similarity_reproduction_outside(rng, name):
    rest, faces, _ = case(name, rng)
    cage = dk.GreenCage(rest, faces)
    x = exterior_points(rest, rng)
    indptr, indices, data = cage.bind(x).weights()
    w = np.zeros((len(x), cage.columns))
    w[np.repeat(np.arange(len(x)), np.diff(indptr)), indices] = data
    m = len(rest)
    p = rest[cage.triangles]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    scale = np.abs(x).max()
    np.testing.assert_allclose(w[:, :m].sum(axis=1), 1.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(w[:, :m] @ rest + w[:, m:] @ n, x, rtol=0, atol=1e-12 * scale)
    c, s = np.cos(0.8), np.sin(0.8)
    rotation = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    def similar(q):
        return 1.6 * q @ rotation.T + np.array([0.3, -0.7, 1.2])
    cage.cage_points = similar(rest)
    np.testing.assert_allclose(cage.deform(x), similar(x), rtol=0, atol=1e-11 * 1.6 * scale)


@pytest.mark.parametrize("name", ["tetrahedron", "beast"])
def test_bind_deform_and_sparse_agree_outside(rng, name):
    rest, faces, edited = case(name, rng)
    cage = dk.GreenCage(rest, faces)
    x = exterior_points(rest, rng)
    dense, sparse = cage.bind(x), cage.bind(x, sparsify=1e-12)
    cage.cage_points = edited
    y = cage.deform(x)
    scale = np.abs(y).max()
    np.testing.assert_allclose(cage.deform_bound(dense), y, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(cage.deform_bound(sparse), y, rtol=0, atol=1e-10 * scale)

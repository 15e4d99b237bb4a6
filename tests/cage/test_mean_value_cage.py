"""dk.MeanValueCage against the properties that define mean value coordinates (linear precision,
partition of unity, interpolation on the cage), the affine map they must reproduce, central
finite differences for the Jacobian, and the shared deformer interface (bind / deform_bound,
weights, Stack)."""
import numpy as np
import pytest

import deformkit as dk

CUBE = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
CUBE_FACES = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
RING = [(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)]
L_POINTS = np.array([[x, y, z] for z in (0, 1) for x, y in RING], float)
L_FACES = [[5, 4, 3, 2, 1, 0], [6, 7, 8, 9, 10, 11]] + [[i, (i + 1) % 6, 6 + (i + 1) % 6, 6 + i] for i in range(6)]


def inside_l(x):
    return (x.min(axis=1) > 0) & (x[:, 0] < 2) & (x[:, 1] < 2) & (x[:, 2] < 1) & ~((x[:, 0] > 1) & (x[:, 1] > 1))


def weights_of(cage, points):
    """The dense weight matrix (n, m) from the binding's CSR export."""
    indptr, indices, data = cage.bind(points).weights()
    w = np.zeros((len(points), cage.columns))
    for i in range(len(points)):
        w[i, indices[indptr[i]:indptr[i + 1]]] = data[indptr[i]:indptr[i + 1]]
    return w


def plane_condition(cage, x):
    """max(1, d / h) over the triangles whose plane passes at h from x with x's projection outside
    them (d: x's distance to their nearest vertex): there the determinant form's cancellation costs
    eps d / h (docs/math/cage.md, "Accuracy near the cage")."""
    p = cage.rest_cage_points[cage.triangles]  # (t, 3, 3)
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    area2 = np.linalg.norm(n, axis=1)
    n /= area2[:, None]
    e = p[None] - x[:, None, None]  # (k, t, 3, 3)
    h = np.abs(np.einsum("tc,ktc->kt", n, e[:, :, 0]))
    bary = np.stack([np.einsum("tc,ktc->kt", n, np.cross(e[:, :, (i + 1) % 3], e[:, :, (i + 2) % 3]))
                     for i in range(3)], axis=2) / area2[None, :, None]
    beside = bary.min(axis=2) < 0
    d = np.linalg.norm(e, axis=3).min(axis=2)
    ratio = np.where(beside, d / np.maximum(h, 1e-300), 1.0)
    return np.maximum(1.0, ratio.max(axis=1))


def moved(cage, rng, amount=0.15):
    cage.cage_points = cage.rest_cage_points + rng.normal(0, amount, cage.rest_cage_points.shape)
    return cage


def test_linear_precision_and_partition_of_unity_inside_near_on_and_outside(rng):
    cage = dk.MeanValueCage(L_POINTS, L_FACES)
    tri = cage.triangles
    p = cage.rest_cage_points
    a, b = 0.31, 0.27
    on = (1 - a - b) * p[tri[:, 0]] + a * p[tri[:, 1]] + b * p[tri[:, 2]]
    n = np.cross(p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    near = np.concatenate([on + s * d * n for d in (1e-3, 1e-6, 1e-9, 1e-12) for s in (-1, 1)])
    inside = rng.uniform(0, 2, (2000, 3)) * [1, 1, 0.5]
    inside = inside[inside_l(inside)]
    for x in (near, on):
        w = weights_of(cage, x)
        np.testing.assert_allclose(w.sum(axis=1), 1, rtol=0, atol=1e-14)
        np.testing.assert_allclose(w @ p, x, rtol=0, atol=2e-14)
    far = rng.uniform(-3, 5, (500, 3))
    for x in (inside, far[~inside_l(far)]):
        w = weights_of(cage, x)
        # Outside the weights change sign and grow: rounding scales with sum |w_j| |p_j - x|, and
        # beside a face's plane with the plane condition.
        scale = (1 + (np.abs(w) * np.linalg.norm(p[None] - x[:, None], axis=2)).sum(axis=1)) * plane_condition(cage, x)
        assert np.all(np.abs(w.sum(axis=1) - 1) < 1e-14 * scale)
        assert np.all(np.linalg.norm(w @ p - x, axis=1) < 1e-14 * scale)
        if x is inside:
            assert np.median(np.linalg.norm(w @ p - x, axis=1)) < 1e-15


def test_on_the_cage_the_weights_interpolate():
    cage = dk.MeanValueCage(L_POINTS, L_FACES)
    np.testing.assert_array_equal(weights_of(cage, L_POINTS), np.eye(len(L_POINTS)))
    tri, p = cage.triangles, cage.rest_cage_points
    on = 0.3 * p[tri[:, 0]] + 0.2 * p[tri[:, 1]] + 0.5 * p[tri[:, 2]]
    w = weights_of(cage, on)
    expected = np.zeros_like(w)
    for t, (i, j, k) in enumerate(tri):
        expected[t, [i, j, k]] = [0.3, 0.2, 0.5]
    np.testing.assert_allclose(w, expected, rtol=0, atol=1e-14)


def test_an_affine_cage_map_is_reproduced(rng):
    a = np.linalg.qr(rng.normal(size=(3, 3)))[0] @ np.diag([1.3, 0.7, 1.1])
    t = rng.normal(size=3)
    cage = dk.MeanValueCage(L_POINTS, L_FACES)
    cage.cage_points = L_POINTS @ a.T + t
    x = rng.uniform(0, 2, (3000, 3)) * [1, 1, 0.5]
    x = x[inside_l(x)]
    np.testing.assert_allclose(cage.deform(x), x @ a.T + t, rtol=0, atol=1e-13)
    # Gradients lose eps times the plane condition (within 1e-6 of a face it is ~1e6).
    error = np.abs(cage.jacobian(x) - a).max(axis=(1, 2))
    assert np.all(error < 1e-13 * plane_condition(cage, x)), error.max()
    assert np.median(error) < 1e-13
    np.testing.assert_allclose(np.median(cage.volume_ratio(x)), np.linalg.det(a), rtol=1e-12)


def test_the_rest_cage_is_the_identity_bit_for_bit(rng):
    cage = dk.MeanValueCage(CUBE, CUBE_FACES)
    pts = np.array([[-0.0, 0.5, 0.5], [0.25, -0.0, 1e300], [2.0, -1e-310, 0.5]])
    assert cage.deform(pts).tobytes() == pts.tobytes()
    assert cage.deform_bound(cage.bind(pts[:1])).tobytes() == pts[:1].tobytes()
    moved(cage, rng)
    assert cage.deform(pts[:1]).tobytes() != pts[:1].tobytes()
    cage.cage_points = CUBE.copy()
    assert cage.deform(pts).tobytes() == pts.tobytes()
    np.testing.assert_array_equal(cage.jacobian(pts), np.broadcast_to(np.eye(3), (3, 3, 3)))


def test_jacobian_matches_central_differences(rng):
    cage = moved(dk.MeanValueCage(L_POINTS, L_FACES), rng)
    x = rng.uniform(-0.5, 2.5, (60, 3))
    j = cage.jacobian(x)
    h = 1e-6
    fd = np.stack([(cage.deform(x + h * e) - cage.deform(x - h * e)) / (2 * h) for e in np.eye(3)], axis=2)
    np.testing.assert_allclose(j, fd, rtol=0, atol=1e-6 * (1 + np.abs(j).max()))


def test_continuous_across_every_face(rng):
    cage = moved(dk.MeanValueCage(L_POINTS, L_FACES), rng, 0.2)
    tri, p = cage.triangles, cage.rest_cage_points
    on = 0.25 * p[tri[:, 0]] + 0.4 * p[tri[:, 1]] + 0.35 * p[tri[:, 2]]
    n = np.cross(p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    at = cage.deform(on)
    for d in (1e-4, 1e-8):
        for s in (-1, 1):
            assert np.abs(cage.deform(on + s * d * n) - at).max() < 100 * d


def test_bound_equals_deform_bit_for_bit_with_weights_and_both_dtypes(rng):
    for dtype in (np.float64, np.float32):
        pts = rng.uniform(-0.2, 2.2, (20_003, 3)).astype(dtype)
        w = rng.uniform(0, 1, len(pts))
        w[::7] = 0.0
        cage = moved(dk.MeanValueCage(L_POINTS, L_FACES, weights=w), rng)
        bound = cage.deform_bound(cage.bind(pts))
        assert bound.dtype == dtype
        assert bound.tobytes() == cage.deform(pts).tobytes()
        np.testing.assert_array_equal(bound[::7], pts[::7])


def test_float32_and_sparsified_bindings_agree_with_dense(rng):
    cage = moved(dk.MeanValueCage(L_POINTS, L_FACES), rng, 0.2)
    pts = rng.uniform(-0.2, 2.2, (5000, 3))
    dense = cage.deform_bound(cage.bind(pts))
    single = cage.bind(pts, precision="float32")
    assert single.storage == "float32"
    # Each weight is rounded by at most 2^-24 of itself: the error is at most that L1 change
    # times the largest control value.
    bound = single.float32_rounding_max * np.abs(cage.cage_points).max(axis=0).max()
    assert 0 < single.float32_rounding_max < 2 ** -24 * 50
    assert np.abs(cage.deform_bound(single) - dense).max() <= bound * (1 + 1e-9)
    sparse = cage.bind(pts, sparsify=1e-3)
    assert sparse.storage == "sparse"
    indptr, indices, data = sparse.weights()
    assert len(data) < len(pts) * cage.columns
    got = cage.deform_bound(sparse)
    c = cage.cage_points
    radius = np.linalg.norm(c - c.mean(axis=0), axis=1).max()
    error = np.linalg.norm(got - dense, axis=1).max()
    assert 0 < error <= sparse.weight_change_max * radius * (1 + 1e-12)
    assert 0 < sparse.dropped_weight_max <= sparse.weight_change_max
    # The kept weights still sum to 1 row by row.
    np.testing.assert_allclose(np.add.reduceat(data, indptr[:-1]), 1, rtol=0, atol=1e-13)


def test_the_csr_weights_reproduce_the_bound_deformation(rng):
    cage = moved(dk.MeanValueCage(L_POINTS, L_FACES), rng)
    pts = rng.uniform(0, 2, (300, 3))
    b = cage.bind(pts)
    indptr, indices, data = b.weights()
    assert indptr.dtype == np.int64 and indices.dtype == np.int32 and len(indptr) == len(pts) + 1
    w = np.zeros((len(pts), cage.columns))
    for i in range(len(pts)):
        w[i, indices[indptr[i]:indptr[i + 1]]] = data[indptr[i]:indptr[i + 1]]
    np.testing.assert_allclose(w @ cage.cage_points, cage.deform_bound(b), rtol=0, atol=1e-13)


def test_cage_points_are_copied_in_and_out(rng):
    cage = dk.MeanValueCage(CUBE, CUBE_FACES)
    new = CUBE + rng.normal(0, 0.1, CUBE.shape)
    cage.cage_points = new
    expected = new.copy()
    new[:] = 0
    np.testing.assert_array_equal(cage.cage_points, expected)
    out = cage.cage_points
    out[:] = 5
    np.testing.assert_array_equal(cage.cage_points, expected)
    np.testing.assert_array_equal(cage.rest_cage_points, CUBE)


def test_stack_composition_and_normals_follow_the_chain_rule(rng):
    cage = moved(dk.MeanValueCage(L_POINTS, L_FACES), rng)
    twist = dk.Twist(rate=0.7)
    stack = dk.Stack([cage, twist])
    x = rng.uniform(0, 2, (50, 3)) * [1, 1, 0.5]
    np.testing.assert_array_equal(stack.deform(x), twist.deform(cage.deform(x)))
    j = np.einsum("nij,njk->nik", twist.jacobian(cage.deform(x)), cage.jacobian(x))
    np.testing.assert_allclose(stack.jacobian(x), j, rtol=1e-12, atol=1e-12)
    normals = rng.normal(size=x.shape)
    expected = np.einsum("nji,nj->ni", np.linalg.inv(cage.jacobian(x)), normals)  # J^-T N
    expected *= np.sign(np.linalg.det(cage.jacobian(x)))[:, None]
    expected /= np.linalg.norm(expected, axis=1, keepdims=True)
    np.testing.assert_allclose(cage.transform_normals(x, normals), expected, rtol=0, atol=1e-10)
    np.testing.assert_allclose(cage.volume_ratio(x), np.linalg.det(cage.jacobian(x)), rtol=1e-12)


def test_an_inward_cage_is_flipped_and_gives_the_same_map(rng):
    outward = dk.MeanValueCage(L_POINTS, L_FACES)
    inward = dk.MeanValueCage(L_POINTS, [f[::-1] for f in L_FACES])
    assert inward.flipped and not outward.flipped
    np.testing.assert_array_equal(inward.triangles, outward.triangles)
    assert inward.volume == pytest.approx(3.0) and outward.volume == pytest.approx(3.0)
    deformed = L_POINTS + rng.normal(0, 0.1, L_POINTS.shape)
    outward.cage_points = inward.cage_points = deformed
    x = rng.uniform(0, 2, (100, 3))
    np.testing.assert_array_equal(inward.deform(x), outward.deform(x))


def test_the_polygon_split_ignores_where_a_face_is_listed_from():
    rolled = [list(np.roll(f, k + 1)) for k, f in enumerate(L_FACES)]
    a, b = dk.MeanValueCage(L_POINTS, L_FACES), dk.MeanValueCage(L_POINTS, rolled)
    np.testing.assert_array_equal(a.triangles, b.triangles)
    x = np.random.default_rng(0).uniform(0, 2, (100, 3))
    a.cage_points = b.cage_points = L_POINTS * 1.1
    assert a.deform(x).tobytes() == b.deform(x).tobytes()
    # Each hexagon cap of the L becomes 4 triangles, each quad 2, all inside their polygon's outline.
    assert np.bincount(a.triangle_faces).tolist() == [4, 4] + [2] * 6

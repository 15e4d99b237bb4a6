"""Sparsified cage bindings (bind(points, sparsify=t)), mean value and Green coordinates alike:
deform_bound is the product of the binding's own CSR table (binding.weights()) with the control
values, summed in numpy in row order, to rounding; its distance from the dense result stays within
the bound the binding reports (docs/math/cage.md, "Sparsified bindings"); float32 points keep
float32 weights and report their rounding. test_mean_value_cage.py checks the row sums."""
import numpy as np
import pytest

import deformkit as dk

from test_mean_value_cage import L_FACES, L_POINTS


def make(kind):
    # Without Lipman's stretch factors the Green triangle columns' control values are the current
    # triangles' unit normals, which the test can compute on its own.
    return dk.MeanValueCage(L_POINTS, L_FACES) if kind == "mvc" else dk.GreenCage(L_POINTS, L_FACES, stretch=False)


def control_values(cage):
    """c (columns, 3): the current cage's vertices, then (Green) its triangles' unit normals."""
    c = cage.cage_points
    if cage.columns == len(c):
        return c
    p = c[cage.triangles]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    return np.vstack([c, n / np.linalg.norm(n, axis=1, keepdims=True)])


def radius(points):
    return np.linalg.norm(points - points.mean(axis=0), axis=1).max()


def bound_radius(cage):
    """The radius the sparsification bound multiplies (docs/math/cage.md, "Sparsified bindings"): the
    deformed cage's about its centroid; for Green coordinates without stretch factors, at least the
    rest cage's."""
    if isinstance(cage, dk.GreenCage) and not cage.stretch:
        return max(radius(cage.cage_points), radius(cage.rest_cage_points))
    return radius(cage.cage_points)


def csr_product(binding, c):
    """W c from binding.weights(), one product per stored weight added row by row, and what bounds
    the rounding of any other order of those sums, row by row: 2 n_i u sum_j |w_ij c_j| (Higham
    2002, Section 3.1: each order carries at most gamma_n of it)."""
    indptr, indices, data = binding.weights()
    assert len(indptr) == len(binding) + 1 and len(indices) == len(data) == indptr[-1]
    rows = np.repeat(np.arange(len(binding)), np.diff(indptr))
    out, magnitude = np.zeros((len(binding), 3)), np.zeros((len(binding), 3))
    np.add.at(out, rows, data[:, None] * c[indices])
    np.add.at(magnitude, rows, np.abs(data[:, None] * c[indices]))
    return out, 2 * np.diff(indptr)[:, None] * 2.0 ** -53 * magnitude * (1 + 1e-9)


@pytest.mark.parametrize("kind", ["mvc", "green"])
@pytest.mark.parametrize("threshold", [1e-4, 1e-3, 3e-2])
def test_sparse_deform_bound_is_its_csr_table_times_the_control_values(rng, kind, threshold):
    cage = make(kind)
    pts = rng.uniform(-0.3, 2.3, (20000, 3))  # inside, near and outside: past the parallel grain
    dense = cage.bind(pts)
    sparse = cage.bind(pts, sparsify=threshold)
    cage.cage_points = cage.rest_cage_points + rng.normal(0, 0.2, cage.rest_cage_points.shape)
    c = control_values(cage)
    # The construction of c is the test's own: it must reproduce the dense binding first.
    want_dense, _ = csr_product(dense, c)
    np.testing.assert_allclose(cage.deform_bound(dense), want_dense, rtol=0, atol=1e-12)
    got = cage.deform_bound(sparse)
    want, rounding = csr_product(sparse, c)
    assert np.all(np.abs(got - want) <= rounding)
    # Against the dense result: within weight_change_max times the deformed cage's radius (with
    # stretch=False, at least the rest cage's: the faces' control values are unit normals).
    radius = bound_radius(cage)
    error = np.linalg.norm(got - cage.deform_bound(dense), axis=1).max()
    assert 0 < error <= sparse.weight_change_max * radius * (1 + 1e-9)
    assert sparse.float32_rounding_max == 0.0


@pytest.mark.parametrize("kind", ["mvc", "green"])
def test_float32_points_keep_float32_weights_within_the_reported_bound(rng, kind):
    cage = make(kind)
    pts = rng.uniform(-0.3, 2.3, (20000, 3))
    sparse64 = cage.bind(pts, sparsify=1e-3)
    sparse32 = cage.bind(pts.astype(np.float32), sparsify=1e-3)
    _, _, data32 = sparse32.weights()
    _, _, data64 = sparse64.weights()
    assert data32.dtype == np.float64
    # The float32 points' kept weights are float32 values (widened in the export) ...
    np.testing.assert_array_equal(data32.astype(np.float32).astype(np.float64), data32)
    # ... of the same table as the float64 points', up to the points' own rounding to float32.
    assert len(data32) == pytest.approx(len(data64), rel=1e-3)
    indptr32 = sparse32.weights()[0]
    # Each kept weight rounded by at most 2^-24 of itself: a row's L1 change by 2^-24 of its L1 norm.
    row_l1 = np.add.reduceat(np.abs(data32), indptr32[:-1]).max()
    assert 0 < sparse32.float32_rounding_max <= 2.0 ** -24 * row_l1 * (1 + 1e-6)
    cage.cage_points = cage.rest_cage_points + rng.normal(0, 0.2, cage.rest_cage_points.shape)
    c = control_values(cage)
    got = cage.deform_bound(sparse32)
    assert got.dtype == np.float32
    want, rounding = csr_product(sparse32, c)
    # The product in double, then one rounding to float32 (half an ulp: 2^-24 relative).
    assert np.all(np.abs(got - want) <= rounding + 2.0 ** -24 * np.abs(want))
    # Against the dense result for the same (float32) points: the sparsification bound plus the
    # rounding's, float32_rounding_max times the largest control value, plus the output's rounding.
    dense = cage.deform_bound(cage.bind(pts.astype(np.float32))).astype(np.float64)
    radius = bound_radius(cage)
    bound = (sparse32.weight_change_max * radius + sparse32.float32_rounding_max * np.linalg.norm(c, axis=1).max()
             + 2 * 2.0 ** -24 * np.abs(dense).max() * np.sqrt(3))
    assert np.linalg.norm(got - dense, axis=1).max() <= bound


def random_cage(rng):
    """An edited cube or L prism, or a tetrahedron, at a random size, turn and place."""
    from test_green_exterior import TETRAHEDRON, TETRAHEDRON_FACES  # noqa: PLC0415
    from test_mean_value_cage import CUBE, CUBE_FACES  # noqa: PLC0415
    rest, faces = [(CUBE, CUBE_FACES), (L_POINTS, L_FACES), (TETRAHEDRON, TETRAHEDRON_FACES)][rng.integers(3)]
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    scale = 10 ** rng.uniform(-2, 2)
    return scale * (rest + rng.normal(0, 0.03, rest.shape)) @ q + rng.normal(0, scale, 3), faces


@pytest.mark.parametrize("seed", range(12))
def test_green_sparse_error_within_the_reported_bound_on_random_cages(seed):
    """|sparse - dense| <= weight_change_max * R' (the deformed cage's radius), whatever the cage's
    size and deformation: the faces' columns multiply s_j n'_j, at most kappa_j R' long, so their
    changes count kappa_j times (docs/math/cage.md, "Sparsified bindings"). Without stretch factors
    the radius is at least the rest cage's. Inside, near and outside the cage."""
    rng = np.random.default_rng(seed)
    rest, faces = random_cage(rng)
    centre, size = rest.mean(axis=0), radius(rest)
    x = centre + size * rng.uniform(-2, 2, (3000, 3))
    for stretch in (True, False):
        cage = dk.GreenCage(rest, faces, stretch=stretch)
        dense = cage.bind(x)
        for threshold in (1e-3, 1e-2, 3e-2):
            sparse = cage.bind(x, sparsify=threshold)
            for _ in range(3):
                sigma = 10 ** rng.uniform(-1.5, 1)  # shrunk or grown, then edited
                cage.cage_points = centre + sigma * (rest - centre) + rng.normal(0, 0.2 * sigma * size, rest.shape)
                error = np.linalg.norm(cage.deform_bound(sparse) - cage.deform_bound(dense), axis=1).max()
                scale = np.abs(cage.deform_bound(dense)).max()
                assert error <= sparse.weight_change_max * bound_radius(cage) * (1 + 1e-9) + 1e-13 * scale, (
                    stretch, threshold, sigma)

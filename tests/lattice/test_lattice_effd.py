"""Coquillart's extended FFD: Newton inversion of a non-parallelepiped grid of tricubic Bezier blocks,
checked by forward-evaluating the grid in numpy (docs/math/lattice.md, "Extended FFD")."""
import numpy as np
import pytest

import deformkit as dk
from support.helpers import bezier_grid_eval, box_grid, cofactor_normals, csr_dense, fd_jacobian

BLOCKS = (2, 2, 1)
COUNTS = tuple(3 * b + 1 for b in BLOCKS)


def warped_grid(rng, noise=0.03):
    """A box grid bent by a smooth map, plus noise on the interior control points only."""
    g = box_grid(COUNTS, (0, 0, 0), np.diag([2.0, 1.5, 1.0]))
    x, y, z = g[..., 0], g[..., 1], g[..., 2]
    g = np.stack([x + 0.25 * np.sin(1.7 * y) * (1 + 0.3 * z), y + 0.2 * x * z - 0.1 * x * x,
                  z * (1 + 0.25 * np.cos(x)) + 0.15 * y], axis=-1)
    g[1:-1, 1:-1, 1:-1] += noise * rng.uniform(-1, 1, g[1:-1, 1:-1, 1:-1].shape)
    return g


def size(grid):
    return np.linalg.norm(np.ptp(grid.reshape(-1, 3), axis=0))


def params_jacobian(grid, p, h=1e-6):
    return fd_jacobian(lambda q: bezier_grid_eval(grid, q), p, h)


@pytest.fixture
def rest(rng):
    grid = warped_grid(rng)
    p = rng.uniform(0, 1, (2000, 3))
    assert (np.linalg.det(params_jacobian(grid, p)) > 0.05).all()  # the test lattice does not fold
    return grid


def inner_params(rng, n=300, margin=0.0):
    """Global block coordinates, with the block faces and the lattice corners among them."""
    p = rng.uniform(margin, 1 - margin, (4 * n, 3))
    if margin:  # away from block faces too
        ok = np.ones(len(p), bool)
        for a, b in enumerate(BLOCKS):
            ok &= np.abs(p[:, a, None] * b - np.arange(b + 1)[None, :]).min(axis=1) > margin * b
        return p[ok][:n]
    faces = np.stack(np.meshgrid(*[[0.0, 0.5, 1.0]] * 3, indexing="ij"), -1).reshape(-1, 3)
    return np.vstack([p[:n], faces])


def test_inversion_round_trip(rest, rng):
    lat = dk.ExtendedFFD(rest)
    assert tuple(lat.resolution) == COUNTS
    np.testing.assert_array_equal(lat.rest_control_points, rest)
    p = inner_params(rng)
    x = bezier_grid_eval(rest, p)
    b = lat.bind(x)
    np.testing.assert_array_equal(b.status, 0)
    assert b.parameters.dtype == np.float64
    np.testing.assert_allclose(bezier_grid_eval(rest, b.parameters), x, rtol=0, atol=1e-9 * size(rest))
    np.testing.assert_allclose(b.parameters, p, atol=1e-7)  # the grid is one-to-one: the same parameters
    np.testing.assert_array_equal(lat.lattice_coordinates(x), b.parameters)


def test_points_outside_get_status_1_and_stay(rest, rng):
    moved = rest + 0.05 * rng.normal(size=rest.shape)
    lat = dk.ExtendedFFD(rest, control_points=moved)
    lo, hi = rest.reshape(-1, 3).min(0), rest.reshape(-1, 3).max(0)
    far = rng.uniform(lo - 1, hi + 1, (400, 3))
    far = far[np.any((far < lo) | (far > hi), axis=1)]  # outside the control points' bounding box
    # Just beyond a curved face: the face's polynomial continued by 5% of the lattice.
    p = rng.uniform(0.1, 0.9, (60, 3))
    p[np.arange(60), np.arange(60) % 3] = np.where(np.arange(60) % 2, 1.05, -0.05)
    near = bezier_grid_eval(rest, p)
    pts = np.vstack([far, near])
    b = lat.bind(pts)
    np.testing.assert_array_equal(b.status, 1)
    np.testing.assert_array_equal(lat.deform(pts), pts)
    assert np.diff(b.weights()[0]).max() == 0


def test_rest_lattice_is_the_identity(rest, rng):
    lat = dk.ExtendedFFD(rest)
    pts = np.vstack([bezier_grid_eval(rest, inner_params(rng)), rng.uniform(-1, 3, (200, 3))])
    np.testing.assert_array_equal(lat.deform(pts), pts)
    np.testing.assert_allclose(lat.deform(pts.astype(np.float32)), pts.astype(np.float32), rtol=0, atol=1e-6)


def test_deformation_is_the_bezier_map_at_the_found_parameters(rest, rng):
    moved = rest + 0.08 * rng.normal(size=rest.shape)
    lat = dk.ExtendedFFD(rest, control_points=moved)
    x = bezier_grid_eval(rest, inner_params(rng))
    b = lat.bind(x)
    out = lat.deform(x)
    assert np.abs(out - x).max() > 1e-2
    np.testing.assert_allclose(out, bezier_grid_eval(moved, b.parameters), rtol=0, atol=1e-9 * size(rest))
    np.testing.assert_allclose(lat.deform_bound(b), out, atol=1e-13)
    w = csr_dense(b.weights(), np.prod(COUNTS))
    np.testing.assert_allclose(w.sum(axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(x + w @ (moved - rest).reshape(-1, 3), out, atol=1e-12)
    half = dk.ExtendedFFD(rest, control_points=moved, strength=0.5)
    np.testing.assert_allclose(half.deform(x), x + 0.5 * (out - x), atol=1e-12)


def test_newton_that_cannot_converge_reports_status_2(rest, rng):
    moved = rest + 0.05 * rng.normal(size=rest.shape)
    lat = dk.ExtendedFFD(rest, control_points=moved, max_iterations=1)
    x = bezier_grid_eval(rest, inner_params(rng))
    b = lat.bind(x)
    failed = b.status == 2
    assert failed.any() and set(np.unique(b.status)) <= {0, 2}
    out = lat.deform(x)
    assert np.isfinite(out).all()
    np.testing.assert_array_equal(out[failed], x[failed])
    placed = b.status == 0  # whatever it did place, it placed correctly
    np.testing.assert_allclose(bezier_grid_eval(rest, b.parameters[placed]), x[placed], atol=1e-9 * size(rest))
    indptr = b.weights()[0]
    assert (np.diff(indptr)[failed] == 0).all()


def test_folded_or_flat_rest_lattices_are_refused(rest):
    # Newton would pick an arbitrary preimage where a block folds over, and any u where it is
    # flat: both are refused when the lattice is made, naming the block.
    folded = rest.copy()
    folded[[1, 5]] = folded[[5, 1]]  # two s-layers swapped: the blocks fold over
    with pytest.raises(ValueError, match=r"rest_control_points: block \(\d+, \d+, \d+\) is folded"):
        dk.ExtendedFFD(folded)
    flat = rest.copy()
    flat[..., 2] = 0.0
    with pytest.raises(ValueError, match=r"rest_control_points: block \(0, 0, 0\) is flat"):
        dk.ExtendedFFD(flat)


def test_prism_lattice(rng):
    triangle = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.1], [0.5, 1.5, 0.0]])
    height = np.array([0.1, 0.2, 1.0])
    lat = dk.ExtendedFFD.prism(triangle, height, blocks=(1, 2, 1))
    res = lat.resolution
    # The t = 1 layer collapses onto the edge through C: one handle per height there.
    assert lat.handles == res[0] * res[1] * res[2] - (res[0] - 1) * res[2]
    # Barycentric samples inside the prism are placed and round-trip; the lattice's rest map is
    # X = A + (1 - t) s (B - A) + t (C - A) + u H.
    w = rng.dirichlet(np.ones(3), 400)
    u = rng.uniform(0.02, 0.98, 400)
    x = w @ triangle + u[:, None] * height
    b = lat.bind(x)
    assert (b.status == 0).all()
    s, t, uu = b.parameters.T
    back = triangle[0] + ((1 - t) * s)[:, None] * (triangle[1] - triangle[0]) + t[:, None] * (triangle[2] - triangle[0]) \
        + uu[:, None] * height
    np.testing.assert_allclose(back, x, atol=1e-9 * size(lat.rest_control_points))
    # Outside the triangle: status 1, unchanged.
    outside = np.array([[1.5, 1.5, 0.5], [-0.3, -0.3, 0.5]])
    assert (lat.bind(outside).status == 1).all()
    # Moving the merged apex edge moves every point of the edge together.
    cp = lat.control_points
    cp[:, -1, :, 0] += 0.3
    lat.control_points = cp
    apex = triangle[2] + 0.5 * height
    np.testing.assert_allclose(lat.deform(apex[None] * (1 - 1e-12)), apex[None] + [0.3, 0, 0], atol=1e-6)


def test_jacobian_matches_finite_differences(rest, rng):
    moved = rest + 0.05 * rng.normal(size=rest.shape)
    lat = dk.ExtendedFFD(rest, control_points=moved, tolerance=1e-13)
    x = bezier_grid_eval(rest, inner_params(rng, 150, margin=2e-3))
    fd = fd_jacobian(lat.deform, x, h=1e-5)
    np.testing.assert_allclose(lat.jacobian(x), fd, atol=1e-6)
    # Independent truth: J = dX'/ds (dX/ds)^-1 from the numpy Bezier map.
    p = lat.lattice_coordinates(x)
    chain = params_jacobian(moved, p) @ np.linalg.inv(params_jacobian(rest, p))
    np.testing.assert_allclose(fd, chain, atol=1e-5)
    np.testing.assert_allclose(lat.volume_ratio(x), np.linalg.det(fd), atol=1e-5)
    normals = rng.normal(size=x.shape)
    np.testing.assert_allclose(lat.transform_normals(x, normals), cofactor_normals(fd, normals), atol=1e-5)


# ---- cylindrical lattice ------------------------------------------------------------------------

@pytest.fixture
def cylinder():
    return dk.ExtendedFFD.cylinder(radius=1.0, height=1.0, blocks=(1, 4, 1), center=(0, 0, 0), axis="z")


def cyl_points(r, phi, z):
    r, phi, z = np.broadcast_arrays(*map(np.atleast_1d, (r, phi, z)))
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1).astype(float)


def test_cylinder_rest_grid(cylinder):
    rest = cylinder.rest_control_points
    assert rest.shape == (4, 13, 4, 3)
    np.testing.assert_allclose(rest[0, ..., :2], 0, atol=1e-15)  # s = 0 is the axis
    np.testing.assert_allclose(np.hypot(rest[3, ..., 0], rest[3, ..., 1])[::3], 1.0, atol=1e-12)
    np.testing.assert_allclose([rest[..., 2].min(), rest[..., 2].max()], [-0.5, 0.5], atol=1e-12)
    np.testing.assert_allclose(rest[:, 0], rest[:, 12], atol=1e-15)  # the seam closes


def test_cylinder_places_and_inverts_points_inside(cylinder, rng):
    rest = cylinder.rest_control_points
    n = 500
    x = cyl_points(np.sqrt(rng.uniform(0, 0.9, n)), rng.uniform(-np.pi, np.pi, n), rng.uniform(-0.45, 0.45, n))
    axis = cyl_points(0.0, 0.0, np.linspace(-0.45, 0.45, 7))  # J is singular there: the fallback
    seam = cyl_points(0.5, np.array([0.0, 1e-12, -1e-12, np.pi / 2, np.pi]), 0.2)
    pts = np.vstack([x, axis, seam])
    b = cylinder.bind(pts)
    np.testing.assert_array_equal(b.status, 0)
    np.testing.assert_allclose(bezier_grid_eval(rest, b.parameters), pts, rtol=0, atol=1e-9 * size(rest))
    # Beyond the mantle (the Bezier arcs bulge by < 3e-4) or the caps, yet inside the control points' box.
    out = np.vstack([cyl_points(rng.uniform(1.01, 1.4, n), rng.uniform(-np.pi, np.pi, n), rng.uniform(-0.5, 0.5, n)),
                     cyl_points(rng.uniform(0, 0.9, n), rng.uniform(-np.pi, np.pi, n), rng.choice([-0.55, 0.55], n))])
    np.testing.assert_array_equal(cylinder.bind(out).status, 1)


@pytest.mark.parametrize("kw", [dict(blocks=(2, 3, 2)), dict(axis="x", center=(1, 2, 3), radius=2, height=3),
                                dict(blocks=(2, 8, 3), axis="y", center=(0, -1, 0.5))], ids=["blocks", "x", "y"])
def test_other_cylinders_place_and_invert(kw, rng):
    cyl = dk.ExtendedFFD.cylinder(**kw)
    rest, axis = cyl.rest_control_points, "xyz".index(kw.get("axis", "z"))
    radius, height, center = kw.get("radius", 1.0), kw.get("height", 1.0), np.array(kw.get("center", (0, 0, 0)))
    n = 1000
    local = cyl_points(radius * np.sqrt(rng.uniform(0, 0.9, n)), rng.uniform(-np.pi, np.pi, n),
                       height * rng.uniform(-0.45, 0.45, n))
    pts = np.roll(local, axis + 1, axis=1) + center  # local z onto the cylinder's axis
    b = cyl.bind(pts)
    np.testing.assert_array_equal(b.status, 0)
    np.testing.assert_allclose(bezier_grid_eval(rest, b.parameters), pts, rtol=0, atol=1e-9 * size(rest))
    along = rest[..., axis] - center[axis]
    np.testing.assert_allclose([along.min(), along.max()], [-height / 2, height / 2], atol=1e-12)
    ring = np.linalg.norm(np.delete(rest[-1, ::3] - center, axis, axis=-1), axis=-1)
    np.testing.assert_allclose(ring, radius, atol=1e-12)


def test_cylinder_parameters_follow_radius_and_angle(cylinder):
    phi = 0.3 + 2 * np.pi * np.arange(97) / 97
    t = cylinder.lattice_coordinates(cyl_points(0.6, phi, 0.1))[:, 1]
    steps = np.diff(np.append(t, t[0])) % 1.0  # once around: every step forward, one wrap at the seam
    assert (steps > 0.002).all() and (steps < 0.03).all(), steps
    s = cylinder.lattice_coordinates(cyl_points(np.linspace(0.05, 0.95, 19), 2.0, -0.2))[:, 0]
    assert (np.diff(s) > 0).all()


def test_merged_handles_move_together(cylinder, rng):
    index = np.asarray(cylinder.handle_index)
    assert index.shape == (4, 13, 4)
    np.testing.assert_array_equal(index[:, 0], index[:, 12])  # seam
    assert (index[0] == index[0, :1]).all()  # the axis: one handle per height layer
    # 4 x 13 x 4 grid points; the seam merges 4 x 4 pairs, the axis 12 points per layer into one
    assert len(np.unique(index)) == cylinder.handles == 4 * 12 * 4 - 4 * 11
    seam = index[2, 0, 1]
    grid = cylinder.control_points
    grid[index == seam] += [0.0, 0.3, 0.1]
    cylinder.control_points = grid
    np.testing.assert_allclose(cylinder.control_points[2, 0, 1], cylinder.control_points[2, 12, 1])
    # A point just either side of the seam moves the same: the handle is one control point.
    out = cylinder.deform(cyl_points(0.6, np.array([1e-9, 2 * np.pi - 1e-9]), -0.1))
    assert np.abs(out[0] - out[1]).max() < 1e-7 and np.abs(out[0] - cyl_points(0.6, 0.0, -0.1)[0]).max() > 1e-3
    torn = cylinder.control_points
    torn[2, 0, 1] += 0.2  # one of two merged points alone: the seam would tear
    with pytest.raises(ValueError, match="control_points"):
        cylinder.control_points = torn

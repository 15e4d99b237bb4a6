"""Direct manipulation (Hsu, Hughes, Kaufman 1992; docs/math/lattice.md): the minimum-norm least-squares
change of the control points, against numpy's SVD and lstsq on the binding's weight matrix."""
import numpy as np
import pytest

import deformkit as dk
from support.helpers import bezier_grid_eval, box_grid, box_point, csr_dense

BOX = dict(origin=(0.3, -0.2, 0.5), edges=((1.5, 0.2, -0.1), (0.3, 1.1, 0.2), (-0.2, 0.4, 0.9)))
SIZE = np.linalg.norm(np.sum(BOX["edges"], axis=0))


def effd_rest():
    g = box_grid((4, 4, 4), (0, 0, 0), np.diag([1.5, 1.2, 1.0]))
    x, y, z = g[..., 0], g[..., 1], g[..., 2]
    return np.stack([x + 0.2 * np.sin(2 * y), y + 0.15 * x * z, z + 0.1 * x * x], axis=-1)


MAKERS = {
    "ffd": lambda cp=None, **kw: dk.FFD((2, 3, 2), control_points=cp, **BOX, **kw),
    "bspline": lambda cp=None, **kw: dk.BSplineLattice((5, 5, 5), control_points=cp, **BOX, **kw),
    "blender": lambda cp=None, **kw: dk.BlenderLattice((3, 4, 3), "bspline", control_points=cp, **BOX, **kw),
    "effd": lambda cp=None, **kw: dk.ExtendedFFD(effd_rest(), control_points=cp, **kw),
}


def setup(name, rng, m, **kw):
    """A lattice already deformed a little, and m points inside it."""
    lat = MAKERS[name](**kw)
    lat = MAKERS[name](lat.rest_control_points + 0.03 * rng.normal(size=lat.rest_control_points.shape), **kw)
    p = rng.uniform(0.3, 0.7, (m, 3))  # inside the B-spline's domain too
    pts = bezier_grid_eval(effd_rest(), p) if name == "effd" else box_point(p, BOX["origin"], BOX["edges"])
    return lat, pts


def weight_matrix(lat, pts):
    return csr_dense(lat.bind(pts).weights(), int(np.prod(lat.resolution)))


@pytest.mark.parametrize("name", MAKERS)
def test_targets_are_hit_and_the_lattice_is_untouched(name, rng):
    lat, pts = setup(name, rng, 4)
    targets = lat.deform(pts) + 0.1 * rng.normal(size=pts.shape)
    before = lat.control_points
    r = lat.direct_manipulation(pts, targets)
    np.testing.assert_array_equal(lat.control_points, before)
    assert r.control_points.shape == before.shape and r.displacement.shape == before.shape
    np.testing.assert_allclose(r.displacement, r.control_points - before, atol=1e-14)
    np.testing.assert_allclose(MAKERS[name](r.control_points).deform(pts), targets, rtol=0, atol=1e-9 * SIZE)
    assert r.residual.shape == (4,) and r.residual.max() <= 1e-9 * SIZE
    assert r.max_residual == r.residual.max() and r.rank == 4


@pytest.mark.parametrize("name", MAKERS)
def test_displacement_is_the_minimum_norm_solution(name, rng):
    lat, pts = setup(name, rng, 5)
    targets = lat.deform(pts) + 0.1 * rng.normal(size=pts.shape)
    dq = targets - lat.deform(pts)
    dp = lat.direct_manipulation(pts, targets).displacement.reshape(-1, 3)
    w = weight_matrix(lat, pts)
    np.testing.assert_allclose(w @ dp, dq, atol=1e-10)
    _, sv, vt = np.linalg.svd(w)
    null = vt[int((sv > sv[0] * 1e-12).sum()):]
    assert len(null) > 0
    # Orthogonal to the null space of W: adding any null vector keeps W dP and only adds length.
    assert np.abs(null @ dp).max() < 1e-10 * np.abs(dp).max()
    for _ in range(5):
        other = dp + null.T @ rng.normal(size=(len(null), 3)) * 1e-3
        np.testing.assert_allclose(w @ other, dq, atol=1e-10)
        assert np.linalg.norm(other) > np.linalg.norm(dp)
    np.testing.assert_allclose(dp, np.linalg.lstsq(w, dq, rcond=None)[0], atol=1e-10)


@pytest.mark.parametrize("name", MAKERS)
def test_one_point_is_the_closed_form(name, rng):
    """dP_i = B_i dQ / sum_k B_k^2."""
    lat, pts = setup(name, rng, 1)
    dq = np.array([[0.2, -0.1, 0.15]])
    dp = lat.direct_manipulation(pts, lat.deform(pts) + dq).displacement.reshape(-1, 3)
    b = weight_matrix(lat, pts)[0]
    np.testing.assert_allclose(dp, np.outer(b, dq[0]) / (b @ b), atol=1e-12)


def test_strength_scales_the_solution(rng):
    lat, pts = setup("bspline", rng, 3, strength=0.5)
    targets = lat.deform(pts) + 0.1 * rng.normal(size=pts.shape)
    r = lat.direct_manipulation(pts, targets)
    np.testing.assert_allclose(MAKERS["bspline"](r.control_points, strength=0.5).deform(pts), targets, atol=1e-9)
    w = weight_matrix(lat, pts)
    np.testing.assert_allclose(r.displacement.reshape(-1, 3),
                               np.linalg.lstsq(0.5 * w, targets - lat.deform(pts), rcond=None)[0], atol=1e-10)


def test_more_constraints_than_unknowns_is_least_squares(rng):
    lat = dk.FFD(1, **BOX)  # 8 control points per coordinate
    pts = box_point(rng.uniform(0, 1, (20, 3)), BOX["origin"], BOX["edges"])
    targets = pts + 0.2 * rng.normal(size=pts.shape)
    r = lat.direct_manipulation(pts, targets)
    w = weight_matrix(lat, pts)
    dp = np.linalg.lstsq(w, targets - pts, rcond=None)[0]
    np.testing.assert_allclose(r.displacement.reshape(-1, 3), dp, atol=1e-10)
    assert r.rank == 8
    reached = dk.FFD(1, control_points=r.control_points, **BOX).deform(pts)
    np.testing.assert_allclose(r.residual, np.linalg.norm(reached - targets, axis=1), atol=1e-12)
    np.testing.assert_allclose(r.residual, np.linalg.norm(w @ dp - (targets - pts), axis=1), atol=1e-12)
    assert r.max_residual > 0.05


@pytest.mark.parametrize("name", MAKERS)
def test_contradicting_targets_meet_halfway(name, rng):
    lat, pts = setup(name, rng, 2)
    pts = np.vstack([pts, pts[:1]])  # the first point twice, with two different targets
    base = lat.deform(pts)
    targets = base + np.array([[0.1, 0.0, 0.0], [0.0, 0.05, 0.0], [-0.1, 0.2, 0.0]])
    r = lat.direct_manipulation(pts, targets)
    reached = MAKERS[name](r.control_points).deform(pts)
    np.testing.assert_allclose(reached[0], (targets[0] + targets[2]) / 2, atol=1e-9)
    np.testing.assert_allclose(reached[1], targets[1], atol=1e-9)
    half = np.linalg.norm(targets[0] - targets[2]) / 2
    np.testing.assert_allclose(r.residual, [half, 0.0, half], atol=1e-9)
    assert r.rank == 2
    w = weight_matrix(lat, pts)
    np.testing.assert_allclose(r.displacement.reshape(-1, 3), np.linalg.lstsq(w, targets - base, rcond=None)[0],
                               atol=1e-10)


def test_cylinder_moves_merged_handles_together(rng):
    """EFFD: the unknowns are the handles, so W's columns of one handle add up."""
    cyl = dk.ExtendedFFD.cylinder(radius=1.0, height=1.0, blocks=(1, 4, 1))
    pts = np.array([[0.5, 1e-3, 0.1], [0.0, 0.0, -0.2], [-0.3, 0.4, 0.3]])  # by the seam, on the axis, inside
    targets = pts + np.array([[0.0, 0.1, 0.05], [0.1, 0.0, 0.0], [0.0, 0.0, -0.1]])
    r = cyl.direct_manipulation(pts, targets)
    index = np.asarray(cyl.handle_index).ravel()
    grid, delta = r.control_points.reshape(-1, 3), r.displacement.reshape(-1, 3)
    for h in np.unique(index):  # merged at rest up to rounding, so equal up to rounding
        np.testing.assert_allclose(grid[index == h], np.broadcast_to(grid[index == h][0], (sum(index == h), 3)),
                                   atol=1e-14)
        np.testing.assert_array_equal(delta[index == h], np.broadcast_to(delta[index == h][0], (sum(index == h), 3)))
    moved = dk.ExtendedFFD.cylinder(radius=1.0, height=1.0, blocks=(1, 4, 1))
    moved.control_points = r.control_points
    np.testing.assert_allclose(moved.deform(pts), targets, atol=1e-9)
    handles = np.zeros((len(index), index.max() + 1))
    handles[np.arange(len(index)), index] = 1.0
    w = csr_dense(cyl.bind(pts).weights(), len(index)) @ handles
    dh = np.linalg.lstsq(w, targets - pts, rcond=None)[0]
    np.testing.assert_allclose(r.displacement.reshape(-1, 3), handles @ dh, atol=1e-10)


def test_points_the_lattice_cannot_move_are_reported():
    """Outside an 'unchanged' lattice a point has an empty weight row: its whole offset is residual."""
    lat = dk.FFD(2, outside="unchanged", **BOX)
    pts = box_point(np.array([[1.5, 0.5, 0.5], [0.5, 0.5, 0.5]]), BOX["origin"], BOX["edges"])
    targets = pts + [[0.1, 0.0, 0.0], [0.0, 0.1, 0.0]]
    r = lat.direct_manipulation(pts, targets)
    np.testing.assert_allclose(r.residual, [0.1, 0.0], atol=1e-12)
    assert r.rank == 1
    np.testing.assert_allclose(dk.FFD(2, control_points=r.control_points, **BOX).deform(pts)[1], targets[1],
                               atol=1e-12)

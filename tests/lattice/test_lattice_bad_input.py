"""Bad input to the lattices gets a ValueError/TypeError naming the argument; nothing crashes and a
failed call leaves the lattice as it was."""
import numpy as np
import pytest

import deformkit as dk

NAN = np.nan
PTS = np.random.default_rng(3).uniform(0, 1, (20, 3))
GRID = np.stack(np.meshgrid(*[np.linspace(0, 1, 4)] * 3, indexing="ij"), axis=-1)  # a 4x4x4 Bezier block


def with_nan(a, where, value=NAN):
    a = np.array(a, float)
    a[where] = value
    return a


PARALLEL = np.eye(4)
PARALLEL[:3, 1] = (2.0, 0.0, 0.0)  # the frame's first two axes are parallel


@pytest.mark.parametrize("make, words", [
    # resolution out of range
    (lambda: dk.FFD(0), "degree"),
    (lambda: dk.FFD((1, 0, 2)), "degree"),
    (lambda: dk.FFD(16), "degree"),
    (lambda: dk.FFD((1, 2)), "degree"),
    (lambda: dk.BezierFFD(0), "blocks"),
    (lambda: dk.BezierFFD((1, 0, 1)), "blocks"),
    (lambda: dk.BSplineLattice(3), "resolution"),
    (lambda: dk.BSplineLattice((4, 4, 3)), "resolution"),
    (lambda: dk.BlenderLattice(0), "resolution"),
    (lambda: dk.BlenderLattice((2, 65, 2)), "resolution"),
    (lambda: dk.BlenderLattice((2, -1, 2)), "resolution"),
    # control points
    (lambda: dk.FFD(3, control_points=with_nan(GRID, (1, 2, 3, 0))), "control_points"),
    (lambda: dk.FFD(3, control_points=with_nan(GRID, (0, 0, 0, 2), np.inf)), "control_points"),
    (lambda: dk.FFD(3, control_points=GRID[:, :, :3]), "control_points"),
    (lambda: dk.FFD(3, control_points=GRID[..., :2]), "control_points"),
    (lambda: dk.FFD(3, control_points=GRID.reshape(-1, 3)), "control_points"),
    (lambda: dk.BSplineLattice(4, control_points=GRID[:3]), "control_points"),
    (lambda: dk.BlenderLattice(2, control_points=GRID), "control_points"),
    # placement
    (lambda: dk.FFD(edges=((1, 0, 0), (0, 1, 0), (1, 1, 0))), "edges"),   # coplanar: zero volume
    (lambda: dk.FFD(edges=((1, 0, 0), (2, 0, 0), (0, 0, 1))), "edges"),   # two parallel edges
    (lambda: dk.FFD(edges=((0, 0, 0), (0, 1, 0), (0, 0, 1))), "edges"),   # a zero edge
    (lambda: dk.FFD(edges=((1, 0, 0), (0, 1, 0))), "edges"),
    (lambda: dk.FFD(edges=((1, 0, 0), (0, NAN, 0), (0, 0, 1))), "edges"),
    (lambda: dk.FFD(origin=(0, NAN, 0)), "origin"),
    (lambda: dk.FFD(origin=(0, 0)), "origin"),
    (lambda: dk.BlenderLattice(frame=np.diag([1.0, 1.0, 0.0, 1.0])), "frame"),
    (lambda: dk.BlenderLattice(frame=PARALLEL), "frame"),
    (lambda: dk.FFD(frame=np.eye(3)), "frame"),
    (lambda: dk.FFD(frame=np.full((4, 4), NAN)), "frame"),
    (lambda: dk.FFD(frame=np.eye(4), origin=(0, 0, 0)), "frame|origin"),
    (lambda: dk.BSplineLattice(frame=np.eye(4), edges=np.eye(3)), "frame|edges"),
    # options
    (lambda: dk.BlenderLattice(interpolation="cubic"), "interpolation"),
    (lambda: dk.BlenderLattice(interpolation=("linear", "bspline")), "interpolation"),
    (lambda: dk.BlenderLattice(interpolation=("linear", "bspline", "KEY_SMOOTH")), "interpolation"),
    (lambda: dk.FFD(outside="wrap"), "outside"),
    (lambda: dk.BezierFFD(outside=""), "outside"),
    (lambda: dk.BlenderLattice(outside="extrapolate"), "outside"),
    (lambda: dk.FFD(strength=NAN), "strength"),
    (lambda: dk.BlenderLattice(strength=np.inf), "strength"),
    (lambda: dk.BSplineLattice(weights=[0.5, NAN]), "weights"),
    # extended FFD
    (lambda: dk.ExtendedFFD(np.zeros((5, 4, 4, 3))), "rest_control_points"),
    (lambda: dk.ExtendedFFD(np.zeros((4, 4, 3, 3))), "rest_control_points"),
    (lambda: dk.ExtendedFFD(np.zeros((4, 4, 4))), "rest_control_points"),
    (lambda: dk.ExtendedFFD(with_nan(GRID, (1, 1, 1, 1))), "rest_control_points"),
    (lambda: dk.ExtendedFFD(GRID, control_points=GRID[:, :, :3]), "control_points"),
    (lambda: dk.ExtendedFFD(GRID, control_points=with_nan(GRID, (0, 0, 0, 0))), "control_points"),
    (lambda: dk.ExtendedFFD(GRID, max_iterations=0), "max_iterations"),
    (lambda: dk.ExtendedFFD(GRID, tolerance=-1.0), "tolerance"),
    (lambda: dk.ExtendedFFD(GRID, tolerance=NAN), "tolerance"),
    (lambda: dk.ExtendedFFD.cylinder(radius=0.0), "radius"),
    (lambda: dk.ExtendedFFD.cylinder(height=NAN), "height"),
    (lambda: dk.ExtendedFFD.cylinder(blocks=(1, 0, 1)), "blocks"),
    (lambda: dk.ExtendedFFD.cylinder(axis="w"), "axis"),
])
def test_bad_construction(make, words):
    with pytest.raises((ValueError, TypeError), match=words):
        make()


@pytest.mark.parametrize("lat", [dk.FFD(3), dk.BlenderLattice(4), dk.ExtendedFFD(GRID)], ids=["ffd", "blender", "effd"])
@pytest.mark.parametrize("bad", [with_nan(GRID, (3, 0, 2, 1)), GRID[:3], GRID[..., :2], GRID.reshape(-1, 3)],
                         ids=["nan", "rows", "columns", "flat"])
def test_bad_control_points_setter_leaves_the_lattice_alone(lat, bad):
    before = lat.control_points
    with pytest.raises(ValueError, match="control_points"):
        lat.control_points = bad
    np.testing.assert_array_equal(lat.control_points, before)
    with pytest.raises((AttributeError, TypeError)):
        lat.rest_control_points = GRID


@pytest.mark.parametrize("lat", [dk.FFD(2), dk.BSplineLattice(5), dk.ExtendedFFD(GRID)], ids=["ffd", "bspline", "effd"])
def test_bad_points(lat):
    bad = PTS.copy()
    bad[7, 1] = NAN
    for call in (lat.deform, lat.bind, lat.lattice_coordinates, lat.jacobian):
        with pytest.raises(ValueError, match="points: row 7 is not finite"):
            call(bad)
    with pytest.raises(ValueError, match=r"points: expected shape \(n, 3\)"):
        lat.bind(PTS[:, :2])
    with pytest.raises(TypeError, match="points"):
        lat.bind(PTS.astype(np.int32))


@pytest.mark.parametrize("lat", [dk.FFD(2), dk.BlenderLattice(3), dk.ExtendedFFD(GRID)], ids=["ffd", "blender", "effd"])
def test_bad_direct_manipulation(lat):
    pts = PTS[:3] * 0.5 + 0.25
    targets = pts + 0.1
    before = lat.control_points
    for bad_targets in (targets[:2], targets[:, :2], targets.ravel()):
        with pytest.raises(ValueError, match="targets"):
            lat.direct_manipulation(pts, bad_targets)
    with pytest.raises(ValueError, match="targets"):
        lat.direct_manipulation(pts, with_nan(targets, (1, 2)))
    with pytest.raises(ValueError, match="points: row 1 is not finite"):
        lat.direct_manipulation(with_nan(pts, (1, 0)), targets)
    with pytest.raises(ValueError, match="points"):
        lat.direct_manipulation(pts[:, :2], targets)
    np.testing.assert_array_equal(lat.control_points, before)


@pytest.mark.parametrize("other", [dk.FFD(3), dk.BezierFFD(1), dk.BSplineLattice(4), dk.BlenderLattice(3),
                                   dk.ExtendedFFD(GRID)], ids=["ffd3", "bezier", "bspline", "blender", "effd"])
def test_binding_from_another_lattice_is_refused(other):
    """A binding stores lattice coordinates for one basis and resolution; another layout would read
    the wrong control points (or past the end of them)."""
    b = dk.FFD(2).bind(PTS)
    with pytest.raises(ValueError, match="binding"):
        other.deform_bound(b)
    with pytest.raises(TypeError):
        other.deform_bound(PTS)


def test_bad_out_for_deform_bound():
    lat = dk.FFD(2)
    b = lat.bind(PTS)
    with pytest.raises(ValueError, match="out"):
        lat.deform_bound(b, out=np.empty((19, 3)))
    with pytest.raises(ValueError, match="out"):
        lat.deform_bound(b, out=np.empty((3, 20)).T)


def test_box_size_does_not_matter_but_flatness_does():
    for scale in (1e-8, 1e8):
        lat = dk.FFD(2, edges=np.diag([scale, 2 * scale, scale]))
        np.testing.assert_allclose(lat.lattice_coordinates(np.array([[scale / 2, scale, scale / 4]])), [[0.5, 0.5, 0.25]])
    with pytest.raises(ValueError, match="edges"):
        dk.FFD(2, edges=((1, 0, 0), (0, 1, 0), (1, 1, 1e-17)))


def test_weights_must_match_the_bound_points():
    lat = dk.FFD(2, weights=np.full(20, 0.5))
    with pytest.raises(ValueError, match=r"weights: has 20 entries but .*\b10\b"):
        lat.deform_bound(lat.bind(PTS[:10]))


# Found in review: finite input that overflows must raise, not crash or hand back inf/NaN.
@pytest.mark.parametrize("make", [
    lambda: dk.FFD(2, origin=(-1e308, 0, 0)),
    lambda: dk.BSplineLattice(5, origin=(-1e308, 0, 0)),
    lambda: dk.BlenderLattice(3, origin=(-1e308, 0, 0)),
])
def test_points_whose_lattice_coordinates_overflow(make):
    lat, far = make(), np.array([[1e308, 0.5, 0.5]])
    grid = lat.control_points
    grid[0, 0, 0] += 0.25  # at rest a lattice is the identity, far points included
    lat.control_points = grid
    for call in (lat.deform, lat.bind, lat.jacobian, lat.lattice_coordinates):
        with pytest.raises(ValueError, match=r"^points: row 0 \(1e\+308, 0\.5, 0\.5\) lies so far from the lattice"):
            call(far)


def test_deform_bound_refuses_overflowing_results():
    lat = dk.FFD(3, strength=1e308)
    cp = lat.control_points
    cp[1, 1, 1] += 1.0
    lat.control_points = cp
    pts = np.full((5, 3), 0.5, np.float32)
    with pytest.raises(ValueError, match=r"^[A-Za-z]+: row 0 maps to a non-finite position"):
        lat.deform_bound(lat.bind(pts))


def test_binding_from_another_outside_policy_is_refused():
    pts = np.array([[1.5, 0.5, 0.5]])
    with pytest.raises(ValueError, match="binding: was made by a lattice"):
        dk.FFD(2, outside="unchanged").deform_bound(dk.FFD(2, outside="clamp").bind(pts))


def test_direct_manipulation_that_overflows_raises():
    with pytest.raises(ValueError, match="targets: the control-point change needed overflows"):
        dk.FFD(2).direct_manipulation(np.array([[0.5, 0.5, 0.5]]), np.array([[0.5, 0.5, 1e308]]))


def test_huge_edges_are_named_too_large():
    with pytest.raises(ValueError, match="edges: the lattice box is too large"):
        dk.FFD(2, edges=np.eye(3) * 1e120)


def test_many_constraints_match_lstsq(rng):
    # More constraints than handles, many of them zero columns (rank deficient): numpy's minimum-norm
    # least-squares solution.
    lat = dk.BSplineLattice(5)
    pts = rng.uniform(0.3, 0.7, (600, 3))
    targets = pts + rng.normal(0, 0.02, pts.shape)
    r = lat.direct_manipulation(pts, targets)
    indptr, indices, data = lat.bind(pts).weights()
    w = np.zeros((len(pts), lat.control_points[..., 0].size))
    w[np.repeat(np.arange(len(pts)), np.diff(indptr)), indices] = data
    expected = np.linalg.lstsq(w, targets - pts, rcond=None)[0]
    np.testing.assert_allclose(r.displacement.reshape(-1, 3), expected, atol=1e-8)
    assert r.rank == np.linalg.matrix_rank(w)

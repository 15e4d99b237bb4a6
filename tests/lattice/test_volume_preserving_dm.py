"""Volume-preserving direct manipulation (docs/math/lattice.md, "Volume-preserving direct manipulation"):
the volume measured independently (the divergence theorem on lattice.deform of the mesh, in numpy), the
handles against the unconstrained solve, optimality against finite differences and scipy's SLSQP."""
import numpy as np
import pytest
import scipy.optimize

import deformkit as dk
from support.helpers import box_grid, csr_dense
from support.subdivision_meshes import prism, signed_volume, sphere

BOX = dict(origin=(0.1, -0.2, 0.3), edges=((1.2, 0.1, 0.0), (0.0, 1.0, 0.1), (0.1, 0.0, 1.1)))
CENTRE = np.sum(BOX["edges"], axis=0) / 2 + BOX["origin"]


def effd_rest():
    g = box_grid((4, 4, 4), BOX["origin"], np.array(BOX["edges"]).T)
    x, y, z = g[..., 0], g[..., 1], g[..., 2]
    return np.stack([x + 0.05 * np.sin(2 * y), y + 0.04 * x * z, z + 0.03 * x * x], axis=-1)


MAKERS = {
    "ffd": lambda cp=None, **kw: dk.FFD((3, 2, 3), control_points=cp, **BOX, **kw),
    "bezier": lambda cp=None, **kw: dk.BezierFFD((2, 1, 2), control_points=cp, **BOX, **kw),
    "bspline": lambda cp=None, **kw: dk.BSplineLattice((5, 6, 5), control_points=cp, **BOX, **kw),
    "blender-bspline": lambda cp=None, **kw: dk.BlenderLattice((4, 3, 4), "bspline", control_points=cp, **BOX, **kw),
    "blender-linear": lambda cp=None, **kw: dk.BlenderLattice((4, 4, 3), "linear", control_points=cp, **BOX, **kw),
    "effd": lambda cp=None, **kw: dk.ExtendedFFD(effd_rest(), control_points=cp, **kw),
}


def volume(points, faces):
    """The divergence theorem in numpy, from the centroid: independent of the solver's formula."""
    return signed_volume(points - points.mean(axis=0), faces)


def setup(name, rng, **kw):
    """A lattice already deformed a little, and a closed quad sphere inside it."""
    lat = MAKERS[name](**kw)
    lat = MAKERS[name](lat.rest_control_points + 0.02 * rng.normal(size=lat.rest_control_points.shape), **kw)
    points, faces = sphere(level=2, radius=0.3, center=CENTRE)
    return lat, points, faces


def handles_on_top(lat, points, lift):
    """Two mesh vertices near the top of the sphere, pulled outward by `lift`."""
    top = np.argsort(points[:, 2])[-2:]
    x = points[top]
    return x, lat.deform(x) + lift * (x - CENTRE) / np.linalg.norm(x - CENTRE, axis=1)[:, None]


def deformed_volume(name, control_points, points, faces):
    return volume(MAKERS[name](control_points).deform(points), faces)


@pytest.mark.parametrize("name", MAKERS)
def test_the_volume_is_kept_and_the_handles_met_as_without_it(name, rng):
    lat, points, faces = setup(name, rng)
    x, targets = handles_on_top(lat, points, 0.15)
    before = lat.control_points
    free = lat.direct_manipulation(x, targets)
    r = lat.direct_manipulation(x, targets, preserve_volume=(points, faces))
    np.testing.assert_array_equal(lat.control_points, before)  # the lattice is not modified
    v0 = volume(lat.deform(points), faces)
    # The edit alone changes the volume by more than a percent; the constrained one keeps it.
    assert abs(deformed_volume(name, free.control_points, points, faces) / v0 - 1) > 1e-2
    assert abs(deformed_volume(name, r.control_points, points, faces) / v0 - 1) < 1e-10
    assert r.volume_target == pytest.approx(v0, rel=1e-12)
    assert r.volume == pytest.approx(deformed_volume(name, r.control_points, points, faces), rel=1e-12)
    assert r.volume_residual <= 1e-12 and r.iterations >= 1
    # The handles reach their targets exactly as closely as without the constraint.
    np.testing.assert_allclose(MAKERS[name](r.control_points).deform(x), targets, rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.residual, free.residual, rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.displacement, r.control_points - before, atol=1e-15)
    assert r.rank == free.rank and free.volume is None and free.iterations == 0


def handle_basis(lat, x):
    """B over flattened control points (merged ones add up in their handle): rows of handles."""
    w = csr_dense(lat.bind(x).weights(), int(np.prod(lat.resolution)))
    index = lat.handle_index.ravel()
    b = np.zeros((len(x), lat.handles))
    np.add.at(b.T, index, w.T)
    return b, index


@pytest.mark.parametrize("name, lift", [("ffd", 0.1), ("bspline", 0.1), ("effd", 0.1), ("ffd", 1.0), ("bspline", 1.0)])
def test_the_change_is_stationary_against_finite_differences(name, lift, rng):
    """KKT: the part of dP the handles leave free is parallel to the free part of grad V, with grad V
    taken by central differences of the deformed mesh's volume; a lift of three radii included,
    in a few Newton steps."""
    lat, points, faces = setup(name, rng)
    x, targets = handles_on_top(lat, points, lift)
    r = lat.direct_manipulation(x, targets, preserve_volume=(points, faces))
    assert r.iterations <= 12 and r.volume_residual <= 1e-12
    b, index = handle_basis(lat, x)
    _, sv, vt = np.linalg.svd(b)
    null = vt[int((sv > sv[0] * 1e-12).sum()):]
    dp = np.zeros((lat.handles, 3))
    dp[index] = r.displacement.reshape(-1, 3)
    grad = np.zeros((lat.handles, 3))
    h = 1e-6
    for k in range(lat.handles):
        for a in range(3):
            e = np.zeros((lat.handles, 3))
            e[k, a] = h
            v = [deformed_volume(name, r.control_points + s * e[index].reshape(r.control_points.shape), points, faces)
                 for s in (1, -1)]
            grad[k, a] = (v[0] - v[1]) / (2 * h)
    free_dp, free_grad = null @ dp, null @ grad
    unit = free_grad / np.linalg.norm(free_grad)
    across = free_dp - np.sum(free_dp * unit) * unit
    assert np.linalg.norm(across) < 1e-6 * np.linalg.norm(free_dp)
    # And dP's constrained part is the least-squares solve's (the row space of B).
    free = lat.direct_manipulation(x, targets)
    fdp = np.zeros((lat.handles, 3))
    fdp[index] = free.displacement.reshape(-1, 3)
    np.testing.assert_allclose(dp - null.T @ free_dp, fdp, atol=1e-12)


def test_no_smaller_change_than_scipys_slsqp(rng):
    """A small FFD: SLSQP on min |dP|^2 s.t. B dP = dQ, V(dP) = V0 (V in numpy from the weight
    matrix) finds no smaller feasible change."""
    lat, points, faces = setup("ffd", rng)
    lat = dk.FFD((1, 2, 1), control_points=None, **BOX)
    lat = dk.FFD((1, 2, 1), control_points=lat.rest_control_points + 0.02 * rng.normal(size=(2, 3, 2, 3)), **BOX)
    x, targets = handles_on_top(lat, points, 0.1)
    r = lat.direct_manipulation(x, targets, preserve_volume=(points, faces))
    n = int(np.prod(lat.resolution))
    w = csr_dense(lat.bind(points).weights(), n)
    b = csr_dense(lat.bind(x).weights(), n)
    y0, dq = lat.deform(points), targets - lat.deform(x)
    v0 = volume(y0, faces)
    cons = [{"type": "eq", "fun": lambda d: (b @ d.reshape(n, 3) - dq).ravel()},
            {"type": "eq", "fun": lambda d: volume(y0 + w @ d.reshape(n, 3), faces) / v0 - 1}]
    start = r.displacement.ravel() + 1e-2 * rng.normal(size=3 * n)
    ref = scipy.optimize.minimize(lambda d: d @ d, start, jac=lambda d: 2 * d, constraints=cons, method="SLSQP",
                                  options={"ftol": 1e-14, "maxiter": 500})
    assert ref.success
    assert np.linalg.norm(r.displacement) <= np.linalg.norm(ref.x) * (1 + 1e-6)
    np.testing.assert_allclose(r.displacement.ravel(), ref.x, atol=1e-5)


def test_per_point_weights_plan_the_handles_and_leave_the_mesh(rng):
    """Weights belong to the handles' rows: a point of weight 0.5 moves half as far; the mesh is
    carried by the lattice without them."""
    lat, points, faces = setup("bspline", rng)
    x, targets = handles_on_top(lat, points, 0.15)
    weighted = MAKERS["bspline"](lat.control_points, weights=[0.5, 1.0])
    r = weighted.direct_manipulation(x, targets, preserve_volume=(points, faces))
    free = weighted.direct_manipulation(x, targets)
    v0 = volume(lat.deform(points), faces)
    assert abs(deformed_volume("bspline", r.control_points, points, faces) / v0 - 1) < 1e-10
    np.testing.assert_allclose(MAKERS["bspline"](r.control_points, weights=[0.5, 1.0]).deform(x), targets, atol=1e-12)
    np.testing.assert_allclose(r.residual, free.residual, atol=1e-12)


def test_polygons_of_mixed_sizes_and_a_handle_moved_along_the_surface(rng):
    lat, _, _ = setup("bezier", rng)
    points, faces = prism(6)
    points = (points - points.mean(axis=0)) * 0.2 + CENTRE
    x = points[[6]]
    normal = (x - CENTRE) / np.linalg.norm(x - CENTRE)
    tangent = np.cross(normal, [0, 0, 1.0])
    targets = lat.deform(x) + 0.1 * tangent
    r = lat.direct_manipulation(x, targets, preserve_volume=(points, faces))
    v0 = volume(lat.deform(points), faces)
    assert abs(deformed_volume("bezier", r.control_points, points, faces) / v0 - 1) < 1e-10
    assert r.max_residual < 1e-12


def test_targets_where_they_are_change_nothing(rng):
    lat, points, faces = setup("ffd", rng)
    x = points[:3]
    r = lat.direct_manipulation(x, lat.deform(x), preserve_volume=(points, faces))
    assert np.abs(r.displacement).max() < 1e-14 and r.iterations == 0 and r.volume_residual <= 1e-12


def test_conflicting_targets_stay_least_squares(rng):
    lat, points, faces = setup("bspline", rng)
    x = np.repeat(points[:1], 2, axis=0)
    targets = lat.deform(x) + [[0, 0, 0.1], [0, 0, 0.2]]
    r = lat.direct_manipulation(x, targets, preserve_volume=(points, faces))
    np.testing.assert_allclose(r.residual, [0.05, 0.05], atol=1e-12)
    assert abs(deformed_volume("bspline", r.control_points, points, faces) / r.volume_target - 1) < 1e-10


def test_bad_meshes_and_pairs_are_named(rng):
    lat, points, faces = setup("ffd", rng)
    x, targets = handles_on_top(lat, points, 0.1)
    dm = lambda pv: lat.direct_manipulation(x, targets, preserve_volume=pv)
    for bad in ((points,), (points, faces, faces), {"points": points}, np.zeros((2, 3)), "mesh"):
        with pytest.raises(TypeError, match=r"^preserve_volume: expected a pair \(mesh_points, mesh_faces\)"):
            dm(bad)
    with pytest.raises(ValueError, match="^preserve_volume: mesh_faces: .*not closed"):
        dm((points, faces[1:]))
    flipped = faces.copy()
    flipped[0] = flipped[0][::-1]
    with pytest.raises(ValueError, match="^preserve_volume: mesh_faces: .*same direction"):
        dm((points, flipped))
    out = faces.copy()
    out[3, 1] = len(points)
    with pytest.raises(ValueError, match="^preserve_volume: mesh_faces: "):
        dm((points, out))
    nan = points.copy()
    nan[4, 1] = np.nan
    with pytest.raises(ValueError, match="^preserve_volume: mesh_points: "):
        dm((nan, faces))
    with pytest.raises(TypeError, match="^preserve_volume: mesh_faces: "):
        dm((points, faces.astype(float)))
    # Two triangles back to back: closed and oriented, but no volume.
    flat = np.array([[0.4, 0.4, 0.5], [0.6, 0.4, 0.5], [0.5, 0.6, 0.5]])
    with pytest.raises(ValueError, match="^preserve_volume: the mesh encloses no volume"):
        dm((flat, [[0, 1, 2], [0, 2, 1]]))
    with pytest.raises(ValueError, match="^preserve_volume: mesh_points: the mesh's volume .* overflows"):
        dm((points * 1e120, faces))
    np.testing.assert_array_equal(lat.control_points, setup("ffd", np.random.default_rng(1234))[0].control_points)


def test_pinned_control_points_are_refused(rng):
    """A trilinear FFD's 8 control points all pinned by 8 handles: none is left to restore the volume."""
    lat = dk.FFD(1, **BOX)
    points, faces = sphere(level=2, radius=0.3, center=CENTRE)
    x = CENTRE + 0.25 * np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
    targets = lat.deform(x) + 0.05 * (x - CENTRE)
    with pytest.raises(ValueError, match="^preserve_volume: no volume-preserving change exists near: the handle "
                                         "constraints pin every control point"):
        lat.direct_manipulation(x, targets, preserve_volume=(points, faces))
    # The same handles moved rigidly keep the volume: nothing to correct, no error.
    r = lat.direct_manipulation(x, lat.deform(x) + [0.05, 0, 0], preserve_volume=(points, faces))
    assert r.volume_residual <= 1e-12 and r.rank == 8


LATTICES = {
    "strength": lambda cp=None: dk.BSplineLattice((5, 5, 5), control_points=cp, strength=-0.7, **BOX),
    "clamp-outside": lambda cp=None: dk.FFD(2, control_points=cp, **BOX),
    "extrapolate-outside": lambda cp=None: dk.BezierFFD(1, control_points=cp, outside="extrapolate", **BOX),
    "unchanged-outside": lambda cp=None: dk.BlenderLattice(4, "cardinal", control_points=cp, outside="unchanged", **BOX),
}


@pytest.mark.parametrize("name", LATTICES)
@pytest.mark.parametrize("inward", [False, True])
def test_strength_points_outside_and_inward_meshes(name, inward, rng):
    """The mesh is carried as lattice.deform carries it (strength, every outside policy: a sphere that
    sticks out of the box), and an inward-facing mesh keeps its negative volume."""
    make = LATTICES[name]
    lat = make(make().rest_control_points + 0.02 * rng.normal(size=make().rest_control_points.shape))
    points, faces = sphere(level=2, radius=0.45, center=CENTRE + [0.3, 0, 0])
    if inward:
        faces = faces[:, ::-1]
    x, targets = handles_on_top(lat, points, 0.1)
    r = lat.direct_manipulation(x, targets, preserve_volume=(points, faces))
    v0 = volume(lat.deform(points), faces)
    assert (v0 < 0) == inward and r.volume_target == pytest.approx(v0, rel=1e-12)
    assert abs(volume(make(r.control_points).deform(points), faces) / v0 - 1) < 1e-10
    assert abs(volume(make(lat.direct_manipulation(x, targets).control_points).deform(points), faces) / v0 - 1) > 1e-3
    np.testing.assert_allclose(make(r.control_points).deform(x), targets, atol=1e-12)


def test_merged_handles_of_a_cylinder_move_together():
    cyl = dk.ExtendedFFD.cylinder(radius=1.0, height=1.0, blocks=(1, 4, 1))
    points, faces = sphere(level=2, radius=0.5)
    x = points[np.argsort(points[:, 0])[-1:]]
    targets = cyl.deform(x) + [0.2, 0.0, 0.1]
    r = cyl.direct_manipulation(x, targets, preserve_volume=(points, faces))
    index = cyl.handle_index.ravel()
    delta = r.displacement.reshape(-1, 3)
    for h in np.unique(index):  # merged control points coincide at rest up to rounding; they move as one
        np.testing.assert_array_equal(delta[index == h], np.broadcast_to(delta[index == h][0], delta[index == h].shape))
    moved = dk.ExtendedFFD.cylinder(radius=1.0, height=1.0, blocks=(1, 4, 1))
    moved.control_points = r.control_points
    assert abs(volume(moved.deform(points), faces) / volume(cyl.deform(points), faces) - 1) < 1e-10
    np.testing.assert_allclose(moved.deform(x), targets, atol=1e-12)

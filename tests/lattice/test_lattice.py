"""Parallelepiped lattices (FFD, BezierFFD, BSplineLattice, BlenderLattice) against independent
numpy evaluations of the formulas in docs/math/lattice.md, finite differences and invariants."""
import re
from typing import Callable, NamedTuple

import numpy as np
import pytest
import trimesh

import deformkit as dk
from support.helpers import (bernstein, bezier_blocks_basis, blender_basis, box_coordinates, box_grid, box_point,
                     box_surface, bspline_basis, cofactor_normals, csr_dense, fd_jacobian, frame_box,
                     gauss_box, mesh_volume, random_frame, tensor_weights)

# A sheared, non-axis-aligned box given by origin/edges, and one given by a sheared frame.
BOX = ((0.3, -0.2, 0.5), ((1.5, 0.2, -0.1), (0.3, 1.1, 0.2), (-0.2, 0.4, 0.9)))
FRAME = np.array([[0.9, 0.3, 0.1, 0.2], [-0.2, 1.2, 0.25, -0.4], [0.15, -0.1, 0.8, 0.6], [0, 0, 0, 1.0]])
PLACEMENTS = {"box": (dict(origin=BOX[0], edges=BOX[1]), BOX), "frame": (dict(frame=FRAME), frame_box(FRAME))}


class Kind(NamedTuple):
    cls: Callable
    arg: tuple
    counts: tuple
    bases: list   # per axis: t -> (n, count) dense weights, the polynomial pieces continued outside
    kinks: list   # per axis: coordinates where the map may not be smooth
    domain: tuple  # (lo, hi) per axis
    blender: bool = False


def ffd(deg):
    return Kind(dk.FFD, (deg,), tuple(d + 1 for d in deg), [lambda t, d=d: bernstein(d, t) for d in deg],
                [[0.0, 1.0]] * 3, ((0.0,) * 3, (1.0,) * 3))


def bezier(blocks):
    return Kind(dk.BezierFFD, (blocks,), tuple(3 * b + 1 for b in blocks),
                [lambda t, n=3 * b + 1: bezier_blocks_basis(n, t) for b in blocks],
                [np.linspace(0, 1, b + 1) for b in blocks], ((0.0,) * 3, (1.0,) * 3))


def bspline(res):
    return Kind(dk.BSplineLattice, (res,), res, [lambda t, n=n: bspline_basis(n, t) for n in res],
                [np.linspace(0, 1, n) for n in res],
                (tuple(1 / (n - 1) for n in res), tuple((n - 2) / (n - 1) for n in res)))


def blender(res, interp):
    names = (interp,) * 3 if isinstance(interp, str) else interp
    short = [n.lower().replace("key_", "") for n in names]
    return Kind(dk.BlenderLattice, (res, interp), res,
                [lambda t, n=n, k=k: blender_basis(n, k, t) for n, k in zip(res, short)],
                [np.linspace(0, 1, max(n, 2)) for n in res], ((0.0,) * 3, (1.0,) * 3), True)


KINDS = {
    "ffd333": ffd((3, 3, 3)), "ffd123": ffd((1, 2, 3)), "ffd555": ffd((5, 5, 5)),
    "bezier213": bezier((2, 1, 3)), "bspline": bspline((6, 4, 5)),
    "blender_linear": blender((3, 4, 2), "linear"), "blender_cardinal": blender((4, 3, 5), "cardinal"),
    "blender_catmull_rom": blender((5, 2, 4), "catmull_rom"), "blender_bspline": blender((4, 5, 3), "bspline"),
    "blender_mixed": blender((3, 4, 5), ("KEY_LINEAR", "KEY_BSPLINE", "KEY_CATMULL_ROM")),
    "blender_res1": blender((1, 3, 2), "bspline"),
}
TRICUBIC = {"ffd333", "bezier213", "bspline", "blender_cardinal", "blender_catmull_rom", "blender_bspline"}
CASES = [(k, p) for k in KINDS for p in (("clamp", "unchanged") if KINDS[k].blender else
                                         ("clamp", "unchanged", "extrapolate"))]


def perturbed(kind, box, rng, amount=0.1):
    """Rest grid plus noise of `amount` grid spacings: large enough to matter, small enough not to fold."""
    grid = box_grid(kind.counts, *box)
    spacing = min(np.linalg.norm(e) / max(n - 1, 1) for e, n in zip(np.asarray(box[1]), kind.counts))
    return grid + amount * spacing * rng.uniform(-1, 1, grid.shape)


def make(name, placement="box", control=None, **kw):
    kind = KINDS[name]
    return kind.cls(*kind.arg, control_points=control, **PLACEMENTS[placement][0], **kw)


def reference(kind, box, grid, pts, policy, strength=1.0):
    """What the contract says deform returns, from the numpy bases; position form where it applies."""
    s = box_coordinates(pts, *box)
    lo, hi = map(np.asarray, kind.domain)
    inside = np.all((s >= lo) & (s <= hi), axis=1)
    # On a face, rounding decides inside or outside: only 'unchanged' cares, so such points are not compared.
    clear = np.all((np.abs(s - lo) > 1e-9) & (np.abs(s - hi) > 1e-9), axis=1) | (policy != "unchanged")
    rest = box_grid(kind.counts, *box).reshape(-1, 3)
    if not kind.blender and policy == "clamp":
        s = np.clip(s, lo, hi)  # Blender clamps indices instead, inside its own basis
    w = tensor_weights(*(b(s[:, a]) for a, b in enumerate(kind.bases)))
    out = pts + strength * w @ (grid.reshape(-1, 3) - rest)
    if not kind.blender and strength == 1.0:  # Sederberg-Parry's position form, linear precision aside
        pos = w @ grid.reshape(-1, 3)
        use = np.ones(len(pts), bool) if policy == "extrapolate" else inside
        out[use] = pos[use]
    if policy == "unchanged":
        out[~inside] = pts[~inside]
        w[~inside] = 0
    return out, inside, w, clear


def sample(kind, box, rng, n=400, lo=-0.4, hi=1.4, margin=0.0):
    """Points at random lattice coordinates, kept `margin` away from every kink when asked."""
    s = rng.uniform(lo, hi, (4 * n, 3))
    if margin:
        ok = np.ones(len(s), bool)
        for a in range(3):
            kinks = np.concatenate([kind.kinks[a], kind.domain[0][a:a + 1], kind.domain[1][a:a + 1]])
            ok &= np.abs(s[:, a, None] - kinks[None, :]).min(axis=1) > margin
        s = s[ok]
    corners = np.stack(np.meshgrid(*[[0.0, 0.5, 1.0]] * 3, indexing="ij"), -1).reshape(-1, 3)
    s = s[:n] if margin else np.vstack([s[:n], corners])
    return box_point(s, *box)


@pytest.mark.parametrize("placement", PLACEMENTS)
@pytest.mark.parametrize("name", KINDS)
def test_rest_lattice_is_the_identity(name, placement, rng):
    kind, box = KINDS[name], PLACEMENTS[placement][1]
    lat = make(name, placement)
    assert tuple(lat.resolution) == kind.counts and lat.control_points.shape == (*kind.counts, 3)
    np.testing.assert_allclose(lat.rest_control_points, box_grid(kind.counts, *box), atol=1e-13)
    np.testing.assert_array_equal(lat.control_points, lat.rest_control_points)
    pts = sample(kind, box, rng)
    np.testing.assert_allclose(lat.deform(pts), pts, rtol=0, atol=1e-12)
    out32 = lat.deform(pts.astype(np.float32))
    assert out32.dtype == np.float32
    np.testing.assert_allclose(out32, pts.astype(np.float32), rtol=0, atol=1e-6)
    # The rest grid recomputed independently differs by rounding only: still the identity.
    again = make(name, placement, control=box_grid(kind.counts, *box))
    np.testing.assert_allclose(again.deform(pts), pts, rtol=0, atol=1e-12)


@pytest.mark.parametrize("placement", PLACEMENTS)
@pytest.mark.parametrize("name", KINDS)
def test_lattice_coordinates_are_the_cross_product_formula(name, placement, rng):
    kind, box = KINDS[name], PLACEMENTS[placement][1]
    lat = make(name, placement)
    pts = sample(kind, box, rng)
    expected = box_coordinates(pts, *box)
    coords = lat.lattice_coordinates(pts)
    assert coords.dtype == np.float64
    np.testing.assert_allclose(coords, expected, atol=1e-12)
    np.testing.assert_array_equal(lat.bind(pts).parameters, coords)


@pytest.mark.parametrize("placement", PLACEMENTS)
@pytest.mark.parametrize("name, policy", CASES)
def test_deform_matches_numpy_evaluation(name, policy, placement, rng):
    kind, box = KINDS[name], PLACEMENTS[placement][1]
    grid = perturbed(kind, box, rng)
    lat = make(name, placement, control=grid, outside=policy)
    pts = sample(kind, box, rng)
    expected, inside, _, clear = reference(kind, box, grid, pts, policy)
    assert inside.any() and (~inside).any()
    out = lat.deform(pts)
    assert np.abs(out - pts).max() > 1e-3  # the perturbation is visible, so agreement means something
    # Blender's key.cc constants are floats (0.16666666f, 0.71f); 1e-7 admits either spelling of them.
    np.testing.assert_allclose(out[clear], expected[clear], rtol=0, atol=1e-7 if kind.blender else 1e-11)
    _, _, _, clear = reference(kind, box, grid, pts, "unchanged")
    np.testing.assert_array_equal(lat.bind(pts).status[clear], np.where(inside, 0, 1)[clear])


def test_bezier_ffd_with_one_block_is_cubic_ffd(rng):
    box = PLACEMENTS["box"][1]
    grid = perturbed(KINDS["ffd333"], box, rng)
    pts = sample(KINDS["ffd333"], box, rng)
    a = dk.BezierFFD((1, 1, 1), control_points=grid, origin=BOX[0], edges=BOX[1])
    b = dk.FFD(3, control_points=grid, origin=BOX[0], edges=BOX[1])
    np.testing.assert_allclose(a.deform(pts), b.deform(pts), atol=1e-12)
    np.testing.assert_allclose(a.jacobian(pts), b.jacobian(pts), atol=1e-10)


@pytest.mark.parametrize("c1", [True, False])
def test_bezier_blocks_jacobian_is_continuous_exactly_when_c1_holds(c1, rng):
    """B.1: P3 - P2 = P4 - P3 across a block face makes dX/ds continuous there; otherwise it jumps."""
    box = PLACEMENTS["box"][1]
    grid = perturbed(KINDS["bezier213"], box, rng, 0.2)
    if c1:
        grid[3] = (grid[2] + grid[4]) / 2            # the face s = 1/2 between the two s-blocks
        for k in (3, 6):                              # the faces u = 1/3, 2/3
            grid[:, :, k] = (grid[:, :, k - 1] + grid[:, :, k + 1]) / 2
    lat = dk.BezierFFD((2, 1, 3), control_points=grid, origin=BOX[0], edges=BOX[1])
    st = rng.uniform(0.05, 0.95, (50, 3))
    for axis, face in ((0, 0.5), (2, 1 / 3), (2, 2 / 3)):
        below, above = st.copy(), st.copy()
        below[:, axis], above[:, axis] = face - 1e-9, face + 1e-9
        jump = np.abs(lat.jacobian(box_point(below, *box)) - lat.jacobian(box_point(above, *box))).max()
        assert (jump < 1e-6) if c1 else (jump > 1e-2), (axis, face, jump)
        gap = np.abs(lat.deform(box_point(below, *box)) - lat.deform(box_point(above, *box))).max()
        assert gap < 1e-7  # C0 always: the blocks share the face layer


@pytest.mark.parametrize("name, policy", CASES)
def test_derivatives_match_finite_differences(name, policy, rng):
    kind, box = KINDS[name], PLACEMENTS["box"][1]
    lat = make(name, control=perturbed(kind, box, rng), outside=policy)
    pts = sample(kind, box, rng, n=200, margin=2e-3)
    fd = fd_jacobian(lat.deform, pts)
    jac = lat.jacobian(pts)
    assert jac.shape == (len(pts), 3, 3)
    np.testing.assert_allclose(jac, fd, atol=2e-6)
    assert np.abs(fd - np.eye(3)).max() > 1e-2  # not trivially the identity
    np.testing.assert_allclose(lat.volume_ratio(pts), np.linalg.det(fd), atol=5e-6)
    normals = rng.normal(size=pts.shape)
    np.testing.assert_allclose(lat.transform_normals(pts, normals), cofactor_normals(fd, normals), atol=1e-5)


VOLUME_KINDS = {  # their knots fall on the mesh's grid lines and the quadrature's breakpoints
    "ffd232": ffd((2, 3, 2)), "bezier213": KINDS["bezier213"], "bspline777": bspline((7, 7, 7)),
    "blender_bspline777": blender((7, 7, 7), "bspline"), "blender_cr444": blender((4, 4, 4), "catmull_rom"),
}


@pytest.mark.parametrize("name", VOLUME_KINDS)
def test_deformed_volume_is_the_integral_of_det_j(name, rng):
    """Volume of the deformed closed surface of the sub-box [0.2, 0.8]^3 (Richardson over two mesh
    sizes) against Gauss quadrature of volume_ratio over the same sub-box, piece by piece."""
    kind, box = VOLUME_KINDS[name], PLACEMENTS["box"][1]
    lat = kind.cls(*kind.arg, control_points=perturbed(kind, box, rng, 0.2), origin=BOX[0], edges=BOX[1])
    vols = []
    for n in (36, 72):
        verts, faces = box_surface(n)
        vols.append(mesh_volume(lat.deform(box_point(0.2 + 0.6 * verts, *box)), faces))
    surface = (4 * vols[1] - vols[0]) / 3
    breaks = [np.unique(np.concatenate([[0.2, 0.8], [k for k in ks if 0.2 < k < 0.8]])) for ks in kind.kinks]
    nodes, weights = gauss_box(breaks)
    integral = abs(np.linalg.det(np.asarray(BOX[1]))) * weights @ lat.volume_ratio(box_point(nodes, *box))
    assert np.ptp(lat.volume_ratio(box_point(nodes, *box))) > 0.1  # far from volume preserving
    np.testing.assert_allclose(integral, surface, rtol=1e-7)  # measured: 2e-10 .. 2e-8


@pytest.mark.parametrize("name", KINDS)
def test_translating_every_control_point_keeps_volume(name, rng):
    kind, box = KINDS[name], PLACEMENTS["box"][1]
    shift = np.array([0.3, -0.7, 0.45])
    lat = make(name, control=box_grid(kind.counts, *box) + shift)
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.5)
    verts = sphere.vertices + box_point([0.5, 0.5, 0.5], *box)
    pts = np.vstack([verts, sample(kind, box, rng)])  # and points outside: clamp carries the shift
    np.testing.assert_allclose(lat.deform(pts), pts + shift, atol=1e-12)
    np.testing.assert_allclose(mesh_volume(lat.deform(verts), sphere.faces), sphere.volume, rtol=1e-12)
    np.testing.assert_allclose(lat.volume_ratio(pts), 1.0, atol=1e-12)


@pytest.mark.parametrize("name, policy", CASES)
def test_outside_policies_at_the_box_face(name, policy, rng):
    kind, box = KINDS[name], PLACEMENTS["box"][1]
    lat = make(name, control=perturbed(kind, box, rng), outside=policy)
    lo, hi = kind.domain
    for axis in range(3):
        for face, out_dir in ((lo[axis], -1), (hi[axis], 1)):
            st = rng.uniform(0.3, 0.7, (20, 3))
            st[:, axis] = face
            on = box_point(st, *box)
            beyond = st.copy()
            beyond[:, axis] = face + out_dir * 1e-9
            near = lat.deform(box_point(beyond, *box))
            if policy == "unchanged":
                np.testing.assert_array_equal(near, box_point(beyond, *box))
            else:
                assert np.abs(near - lat.deform(on)).max() < 1e-7, (axis, face)
            if policy == "clamp" and not kind.blender:
                # outside points move with the displacement of the nearest boundary point
                far = st.copy()
                far[:, axis] = face + out_dir * 0.3
                far_pts = box_point(far, *box)
                np.testing.assert_allclose(lat.deform(far_pts) - far_pts, lat.deform(on) - on, atol=1e-12)


@pytest.mark.parametrize("name", ["ffd123", "bezier213", "bspline", "blender_bspline", "blender_linear"])
def test_bound_deform_follows_keyframed_control_points(name, rng):
    kind, box = KINDS[name], PLACEMENTS["box"][1]
    keys = [perturbed(kind, box, rng, 0.3) for _ in range(3)]
    lat = make(name, control=keys[0])
    pts = sample(kind, box, rng)
    b = lat.bind(pts)
    assert len(b) == len(pts) and b.status.dtype == np.uint8
    np.testing.assert_allclose(lat.deform_bound(b), lat.deform(pts), atol=1e-13)
    b = lat.bind(scratch := pts.copy())
    scratch[:] = np.nan  # the binding keeps its own copy
    for frame in np.linspace(0, 2, 9):
        i = min(int(frame), 1)
        current = keys[i] + (frame - i) * (keys[i + 1] - keys[i])
        lat.control_points = current
        np.testing.assert_array_equal(lat.control_points, current)
        np.testing.assert_allclose(lat.deform_bound(b), make(name, control=current).deform(pts), atol=1e-13)
    b32 = lat.bind(pts.astype(np.float32))
    assert lat.deform_bound(b32).dtype == np.float32
    out = np.empty_like(pts)
    assert lat.deform_bound(b, out=out) is out


def test_control_points_getter_returns_a_copy():
    lat = dk.FFD(2)
    cps = lat.control_points
    cps += 1.0
    np.testing.assert_array_equal(lat.control_points, lat.rest_control_points)


@pytest.mark.parametrize("name, policy", CASES)
def test_binding_weights_are_the_sparse_basis(name, policy, rng):
    kind, box = KINDS[name], PLACEMENTS["box"][1]
    grid = perturbed(kind, box, rng)
    lat = make(name, control=grid, outside=policy, strength=0.7)
    pts = sample(kind, box, rng)
    b = lat.bind(pts)
    indptr, indices, data = b.weights()
    assert indptr.dtype == np.int64 and indices.dtype == np.int32 and data.dtype == np.float64
    assert len(indptr) == len(pts) + 1 and indptr[-1] == len(indices) == len(data)
    for r in range(len(pts)):  # duplicates merged
        row = indices[indptr[r]:indptr[r + 1]]
        assert len(np.unique(row)) == len(row)
    nnz = np.diff(indptr)
    assert nnz.max() <= (64 if name in TRICUBIC else np.prod(kind.counts))
    w = csr_dense((indptr, indices, data), np.prod(kind.counts))
    rest = box_grid(kind.counts, *box).reshape(-1, 3)
    np.testing.assert_allclose(pts + 0.7 * w @ (grid.reshape(-1, 3) - rest), lat.deform(pts), atol=1e-11)
    _, inside, ref, clear = reference(kind, box, grid, pts, policy)
    if policy == "unchanged":
        assert (nnz[~inside & clear] == 0).all()
    np.testing.assert_allclose(w[clear], ref[clear], atol=1e-7 if kind.blender else 1e-12)
    np.testing.assert_allclose(w[inside].sum(axis=1), 1.0, atol=1e-12)


def rigid(rng):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q)), rng.uniform(-2, 2, 3)


@pytest.mark.parametrize("placement", PLACEMENTS)
@pytest.mark.parametrize("name", KINDS)
def test_moving_lattice_and_points_together_commutes(name, placement, rng):
    """An object moving through a fixed lattice vs. the lattice moving with it: the same shape."""
    kind, box = KINDS[name], PLACEMENTS[placement][1]
    grid = perturbed(kind, box, rng, 0.3)
    pts = sample(kind, box, rng)
    q, t = rigid(rng)
    if placement == "box":
        where = dict(origin=q @ np.asarray(BOX[0]) + t, edges=np.asarray(BOX[1]) @ q.T)
    else:
        m = np.eye(4)
        m[:3, :3], m[:3, 3] = q, t
        where = dict(frame=m @ FRAME)
    moved = kind.cls(*kind.arg, control_points=grid @ q.T + t, **where)
    fixed = make(name, placement, control=grid)
    np.testing.assert_allclose(moved.deform(pts @ q.T + t), fixed.deform(pts) @ q.T + t, atol=1e-11)
    pts = sample(kind, box, rng, margin=1e-6)  # J jumps across block faces: rounding would pick a side
    np.testing.assert_allclose(moved.jacobian(pts @ q.T + t), q @ fixed.jacobian(pts) @ q.T, atol=1e-10)


@pytest.mark.parametrize("name", ["ffd555", "bezier213", "bspline", "blender_cardinal"])
def test_composes_in_a_stack_with_a_twist(name, rng):
    kind, box = KINDS[name], PLACEMENTS["box"][1]
    lat = make(name, control=perturbed(kind, box, rng))
    twist = dk.Twist(rate=0.8, frame=random_frame(rng))
    stack = dk.Stack([lat, twist])
    pts = sample(kind, box, rng, n=100, margin=2e-3)
    np.testing.assert_allclose(stack.deform(pts), twist.deform(lat.deform(pts)), atol=1e-13)
    jac = stack.jacobian(pts)
    np.testing.assert_allclose(jac, fd_jacobian(stack.deform, pts), atol=2e-6)
    np.testing.assert_allclose(jac, twist.jacobian(lat.deform(pts)) @ lat.jacobian(pts), atol=1e-12)


@pytest.mark.parametrize("name", KINDS)
def test_strength_and_weights_scale_the_displacement(name, rng):
    kind, box = KINDS[name], PLACEMENTS["box"][1]
    grid = perturbed(kind, box, rng, 0.3)
    pts = sample(kind, box, rng)
    full = make(name, control=grid).deform(pts)
    np.testing.assert_array_equal(make(name, control=grid, strength=0.0).deform(pts), pts)
    np.testing.assert_allclose(make(name, control=grid, strength=0.35).deform(pts), pts + 0.35 * (full - pts),
                               atol=1e-12)
    w = rng.uniform(0, 1, len(pts))
    blended = make(name, control=grid, weights=w, strength=0.8)
    np.testing.assert_allclose(blended.deform(pts), pts + 0.8 * w[:, None] * (full - pts), atol=1e-12)
    np.testing.assert_allclose(blended.deform_bound(blended.bind(pts)), blended.deform(pts), atol=1e-13)
    np.testing.assert_allclose(make(name, control=grid).deform(pts.astype(np.float32)), full, atol=5e-6)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("name", ["ffd555", "bspline", "blender_mixed"])
def test_many_points_match_the_formula(name, dtype, rng):
    """Enough points for every thread and SIMD tail, against the numpy evaluation."""
    kind, box = KINDS[name], PLACEMENTS["frame"][1]
    grid = perturbed(kind, box, rng)
    lat = make(name, "frame", control=grid)
    pts = box_point(rng.uniform(-0.3, 1.3, (100_003, 3)), *box).astype(dtype)
    if kind.blender:  # Blender's key.cc weights with the constants spelled as deformkit computes them
        names = (kind.arg[1],) * 3 if isinstance(kind.arg[1], str) else kind.arg[1]
        kind = kind._replace(bases=[lambda t, n=n, k=k: blender_basis(n, k.lower().replace("key_", ""), t,
                                                                      float_constants=False)
                                    for n, k in zip(kind.counts, names)])
    expected, _, w, _ = reference(kind, box, grid, pts.astype(np.float64), "clamp")
    out = lat.deform(pts)
    assert out.dtype == dtype
    assert np.abs(expected - pts).max() > 1e-3  # the lattice moves the points: a lane or tail left out shows
    # float64: each of the `terms` weight products (three factors, one sum) is off by a few eps of
    # max |control point|, the point itself by one; float32 adds the one rounding of a float64
    # result (half an ulp of max |output|). A float32 step or a wrong lane costs far more.
    eps, terms = np.finfo(np.float64).eps, int((w != 0).sum(axis=1).max())
    tol = 4 * terms * eps * (np.abs(grid).max() + np.abs(pts).max())
    if dtype == np.float32:
        tol += 0.5 * np.finfo(np.float32).eps * np.abs(expected).max()
    np.testing.assert_allclose(out, expected, rtol=0, atol=tol)
    np.testing.assert_allclose(lat.deform_bound(lat.bind(pts)), out, rtol=0, atol=1e-6 if dtype == np.float32 else 1e-13)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("outside", ["clamp", "unchanged"])
def test_large_in_place_deform_equals_bound_and_scalar_weights(dtype, outside, rng):
    # Many chunks on both threads, points in random order, some outside: deform (chunked, unbound),
    # deform in place and deform_bound must agree with x + strength W (P - R) from the CSR weights.
    lat = dk.BlenderLattice((5, 4, 6), ("bspline", "cardinal", "linear"), outside=outside, strength=0.8)
    lat.control_points = lat.rest_control_points + rng.normal(0, 0.05, lat.control_points.shape)
    pts = rng.uniform(-0.3, 1.3, (70_001, 3)).astype(dtype)
    expected = pts.astype(np.float64).copy()
    indptr, indices, data = lat.bind(pts.astype(np.float64)).weights()
    offsets = (lat.control_points - lat.rest_control_points).reshape(-1, 3)
    rows = np.repeat(np.arange(len(pts)), np.diff(indptr))
    np.add.at(expected, rows, lat.strength * data[:, None] * offsets[indices])
    tol = 1e-12 if dtype == np.float64 else 2e-6
    out = lat.deform(pts)
    np.testing.assert_allclose(out, expected, rtol=0, atol=tol)
    np.testing.assert_array_equal(lat.deform_bound(lat.bind(pts)), out)
    inplace = pts.copy()
    lat.deform(inplace, out=inplace)
    np.testing.assert_array_equal(inplace, out)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("name", KINDS)
def test_displacement_bound_is_the_bound_offset_in_one_pass(name, dtype, rng):
    """displacement_bound = deform_bound - points (the blend's w (F(x) - x) with weights), to the
    rounding of the larger; at the control points' rest it is exactly zero, and it refuses what
    deform_bound refuses."""
    kind, box = KINDS[name], PLACEMENTS["box"][1]
    grid = perturbed(kind, box, rng, 0.3)
    pts = box_point(rng.uniform(-0.4, 1.4, (20_003, 3)), *box).astype(dtype)
    w = rng.uniform(0, 1, len(pts))
    for weights in (None, w):
        lat = make(name, control=grid, weights=weights, strength=0.8)
        b = lat.bind(pts)
        disp, moved = lat.displacement_bound(b), lat.deform_bound(b)
        assert disp.dtype == dtype
        ulp = np.spacing(np.maximum(np.abs(pts), np.abs(moved)).astype(dtype))
        assert (np.abs(disp - (moved.astype(np.float64) - pts)) <= 2 * ulp).all(), name
        out = np.empty_like(pts)
        assert lat.displacement_bound(b, out=out) is out
    rest = make(name, weights=w)
    assert not rest.displacement_bound(rest.bind(pts)).any()
    other = make(name, "frame")
    with pytest.raises(ValueError, match="binding: ") as refused:
        other.deform_bound(b)
    with pytest.raises(ValueError, match=re.escape(str(refused.value))):
        other.displacement_bound(b)
    with pytest.raises(TypeError, match="out: must have dtype"):
        lat.displacement_bound(b, out=np.empty(pts.shape, np.float16))

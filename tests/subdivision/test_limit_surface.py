"""dk.LimitSurface against finite differences, limit masks, refinement and affine invariance."""
import numpy as np
import pytest

import deformkit as dk
from support.subdivision_meshes import CUBE_FACES, CUBE_POINTS, OCTAHEDRON_FACES, OCTAHEDRON_POINTS, grid, prism

MESHES = {"cube": lambda: (dk.Twist(rate=0.4).deform(CUBE_POINTS), CUBE_FACES), "prism": prism,
          "grid": lambda: grid(3, bump=0.3), "octahedron": lambda: (OCTAHEDRON_POINTS, OCTAHEDRON_FACES)}


def samples(surface, per_face, seed, margin=0.0):
    rng = np.random.default_rng(seed)
    ptex = np.repeat(np.arange(surface.ptex_count), per_face)
    uv = margin + (1 - 2 * margin) * rng.random((len(ptex), 2))
    if surface.scheme == "loop":
        flip = uv.sum(axis=1) > 1
        uv[flip] = 1 - uv[flip]
        uv *= 0.9
    return ptex, uv


@pytest.mark.parametrize("name", list(MESHES))
def test_derivatives_match_finite_differences(name):
    points, faces = MESHES[name]()
    s = dk.LimitSurface(points, faces)
    ptex, uv = samples(s, 5, 1, margin=0.05)
    out = s.evaluate(ptex, uv, derivatives=2)
    h = 1e-6
    for key, axis, field in [("du", 0, "position"), ("dv", 1, "position"), ("duu", 0, "du"), ("duv", 1, "du"),
                             ("dvv", 1, "dv")]:
        step = np.zeros(2)
        step[axis] = h
        fd = (s.evaluate(ptex, uv + step, derivatives=1)[field] - s.evaluate(ptex, uv - step, derivatives=1)[field]) / (2 * h)
        np.testing.assert_allclose(out[key], fd, atol=2e-5 * max(1, np.abs(fd).max()), err_msg=key)
    n = np.cross(out["du"], out["dv"])
    np.testing.assert_allclose(out["normal"], n / np.linalg.norm(n, axis=1)[:, None], atol=1e-12)


@pytest.mark.parametrize("name", list(MESHES))
def test_affine_maps_commute_with_the_limit(name):
    points, faces = MESHES[name]()
    s = dk.LimitSurface(points, faces)
    ptex, uv = samples(s, 4, 2)
    A, t = np.array([[0.9, 0.4, 0.1], [-0.2, 1.3, 0.0], [0.3, 0.1, 0.7]]), np.array([1.0, -2.0, 0.5])
    moved = s.evaluate(ptex, uv, points=points @ A.T + t, derivatives=2)
    base = s.evaluate(ptex, uv, derivatives=2)
    np.testing.assert_allclose(moved["position"], base["position"] @ A.T + t, atol=1e-12)
    for key in ("du", "dv", "duu", "duv", "dvv"):
        np.testing.assert_allclose(moved[key], base[key] @ A.T, atol=1e-11)


def test_points_argument_equals_a_new_surface():
    points, faces = prism()
    bent = dk.Bend(curvature=0.4).deform(points)
    s = dk.LimitSurface(points, faces)
    ptex, uv = samples(s, 6, 3)
    a = s.evaluate(ptex, uv, points=bent, derivatives=2)
    b = dk.LimitSurface(bent, faces).evaluate(ptex, uv, derivatives=2)
    for key in a:
        np.testing.assert_array_equal(a[key], b[key])
    np.testing.assert_array_equal(s.limit_points(bent), dk.LimitSurface(bent, faces).limit_points())


def test_regular_vertex_limit_is_the_bicubic_b_spline_mask():
    points, faces = grid(4, bump=0.4)
    limit = dk.LimitSurface(points, faces).limit_points()
    w = np.outer([1, 4, 1], [1, 4, 1]) / 36.0
    for v in (6, 7, 8, 11, 12, 13, 16, 17, 18):  # interior vertices of the 5 x 5 grid of points
        ring = np.array([[v - 6, v - 5, v - 4], [v - 1, v, v + 1], [v + 4, v + 5, v + 6]])
        np.testing.assert_allclose(limit[v], np.tensordot(w, points[ring], axes=([0, 1], [0, 1])), atol=1e-13)


def test_loop_regular_vertex_limit_mask():
    # a valence-6 vertex of a triangulated grid: limit = (1 - 6 b) v + b * ring with b = 1/(6 + 3/(8 beta))
    points, quads = grid(4, bump=0.3)
    tris = np.r_[quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]]
    limit = dk.LimitSurface(points, tris).limit_points()
    v = 12
    ring = sorted({int(x) for t in tris if v in t for x in t} - {v})
    assert len(ring) == 6
    beta = (5 / 8 - (3 / 8 + np.cos(2 * np.pi / 6) / 4) ** 2) / 6
    chi = 1 / (3 / (8 * beta) + 6)
    np.testing.assert_allclose(limit[v], (1 - 6 * chi) * points[v] + chi * points[ring].sum(axis=0), atol=1e-13)


@pytest.mark.parametrize("name", ["cube", "prism"])
def test_refined_meshes_converge_to_the_limit(name):
    """Each level's refined vertices lie closer to the limit surface (which refinement leaves
    unchanged): their distance to it, measured as limit_points of the refined cage minus the
    refined points, shrinks by about 4x per level."""
    points, faces = MESHES[name]()
    gaps = []
    for level in range(1, 5):
        m = dk.subdivide(points, faces, level)
        gaps.append(np.abs(dk.LimitSurface(m.points, m.faces).limit_points() - m.points).max())
    ratios = np.array(gaps[:-1]) / np.array(gaps[1:])
    assert np.all(ratios > 3.0), (gaps, ratios)


def test_subdividing_keeps_the_limit_surface():
    """The refined cage has the same limit surface: a corner of every refined face, evaluated on
    the control mesh, equals the refined mesh's own limit point there."""
    points, faces = MESHES["cube"]()
    m = dk.subdivide(points, faces, 2)
    fine = dk.LimitSurface(m.points, m.faces).limit_points()
    coarse = dk.LimitSurface(points, faces).limit_points()
    # the control vertices are refined vertices 0..n-1 (OpenSubdiv numbers vertex children first)
    np.testing.assert_allclose(fine[: len(points)], coarse, atol=1e-12)
    # and the limit of the first refined face's centre vertex lies on the control surface
    s = dk.LimitSurface(points, faces)
    pos = s.evaluate(np.arange(6), np.full((6, 2), 0.5), derivatives=0)["position"]
    dist = np.min(np.linalg.norm(fine[:, None, :] - pos[None], axis=2), axis=0)
    assert dist.max() < 1e-12


def test_ptex_layout():
    points, faces = prism(5)
    s = dk.LimitSurface(points, faces)
    assert s.ptex_offset.tolist()[:3] == [0, 5, 10] and s.ptex_count == 15
    loop = dk.LimitSurface(OCTAHEDRON_POINTS, OCTAHEDRON_FACES)
    assert loop.scheme == "loop" and loop.ptex_count == 8
    # corner k of an n-gon is (0, 0) of sub-quad k; u runs towards corner k + 1
    limit = s.limit_points()
    corner = s.evaluate(np.arange(5), np.zeros((5, 2)), derivatives=0)["position"]
    np.testing.assert_allclose(corner, limit[faces[0]], atol=1e-12)
    toward = s.evaluate(np.arange(5), np.tile([0.999, 0.0], (5, 1)), derivatives=0)["position"]
    mid = s.evaluate(np.roll(np.arange(5), -1), np.tile([0.0, 0.999], (5, 1)), derivatives=0)["position"]
    np.testing.assert_allclose(toward, mid, atol=5e-3)  # both near the midpoint of edge k -> k+1


def test_gregory_region_derivatives_are_approximate():
    """Within 2^-4 of an extraordinary vertex the surface is a Gregory patch whose derivatives are
    OpenSubdiv's approximation (about 1% off the positions' finite differences); outside, exact."""
    points, faces = prism()
    points = points + 0.3 * np.random.default_rng(0).standard_normal(points.shape)
    s = dk.LimitSurface(points, faces)
    ptex = np.arange(s.ptex_count)
    h = 1e-6

    def relative_error(corner):
        uv = np.tile(corner, (len(ptex), 1))
        du = s.evaluate(ptex, uv)["du"]
        fd = (s.evaluate(ptex, uv + [h, 0], derivatives=0)["position"]
              - s.evaluate(ptex, uv - [h, 0], derivatives=0)["position"]) / (2 * h)
        return (np.linalg.norm(du - fd, axis=1) / np.linalg.norm(fd, axis=1)).max()

    assert relative_error((0.5, 0.5)) < 1e-8
    assert 1e-4 < relative_error((0.02, 0.03)) < 0.05


def test_the_surface_keeps_its_own_copy_of_the_cage():
    points, faces = prism()
    s = dk.LimitSurface(points, faces)
    sd = dk.Subdivider(points, faces, 1)
    limit, refined = s.limit_points(), sd.subdivide()
    points *= 2.0  # the caller's array changes; the surface and the subdivider do not
    np.testing.assert_array_equal(s.limit_points(), limit)
    np.testing.assert_array_equal(sd.subdivide(), refined)


def test_smooth_boundary_corner_is_the_exact_limit():
    """With boundary="edge_only" a valence-2 corner is smooth and its boundary curves are cubic
    B-splines, so its limit is (p_prev + 4 p + p_next) / 6 of its two border neighbours (and every
    border vertex's likewise). Blender at quality 10 gives the same (0.1667, 0.1667, ...)."""
    for n in (2, 3):
        points, faces = grid(n, bump=0.3)
        s = dk.LimitSurface(points, faces, boundary="edge_only")
        limit = s.limit_points()
        last = n * (n + 1)
        for corner, a, b in ((0, 1, n + 1), (n, n - 1, 2 * n + 1), (last, last - n - 1, last + 1),
                             (last + n, last + n - 1, last - 1)):
            np.testing.assert_allclose(limit[corner], (points[a] + 4 * points[corner] + points[b]) / 6, atol=1e-14)
        for v in range(1, n):  # the bottom border's other vertices
            np.testing.assert_allclose(limit[v], (points[v - 1] + 4 * points[v] + points[v + 1]) / 6, atol=1e-14)
        at_corner = s.evaluate([0], [[0.0, 0.0]], derivatives=0)["position"][0]
        np.testing.assert_allclose(at_corner, limit[0], atol=1e-14)


def test_subnormal_parameters_are_the_boundary():
    """u or v of 5e-324 is 0 to double precision: the result is finite and equals the one at 0,
    Gregory patches (every cube vertex is extraordinary) and n-gons included."""
    for points, faces in (MESHES["cube"](), prism(), MESHES["octahedron"]()):
        s = dk.LimitSurface(points, faces)
        ptex = np.arange(s.ptex_count)
        for tiny, zero in (([5e-324, 0.0], [0.0, 0.0]), ([0.0, 5e-324], [0.0, 0.0]),
                           ([5e-324, 5e-324], [0.0, 0.0]), ([1e-310, 0.25], [0.0, 0.25])):
            a = s.evaluate(ptex, np.tile(tiny, (len(ptex), 1)), derivatives=2)
            b = s.evaluate(ptex, np.tile(zero, (len(ptex), 1)), derivatives=2)
            for key in a:
                assert np.isfinite(a[key]).all(), (key, tiny)
                np.testing.assert_array_equal(a[key], b[key])


@pytest.mark.parametrize("scale", [1e-200, 1e-100, 1e103, 1e150, 1e200, 1e300])
def test_the_limit_surface_is_scale_invariant(scale):
    """Limit positions and derivatives scale with the cage, unit normals do not change: no product
    inside may overflow (du x dv at 1e103 did) or underflow."""
    for name in ("cube", "prism", "grid"):
        points, faces = MESHES[name]()
        s, big = dk.LimitSurface(points, faces), dk.LimitSurface(points * scale, faces)
        ptex, uv = samples(s, 3, 5)
        a, b = s.evaluate(ptex, uv, derivatives=2), big.evaluate(ptex, uv, derivatives=2)
        for key in ("position", "du", "dv", "duu", "duv", "dvv"):
            np.testing.assert_allclose(b[key] / scale, a[key], rtol=1e-12, atol=1e-12 * np.abs(a[key]).max())
        np.testing.assert_allclose(b["normal"], a["normal"], atol=1e-13)
        np.testing.assert_allclose(big.limit_points() / scale, s.limit_points(), rtol=1e-12, atol=1e-13)


def test_a_limit_beyond_the_double_range_is_refused():
    s = dk.LimitSurface(CUBE_POINTS * 1.6e308, CUBE_FACES)  # the cage is finite; its derivatives are not
    with pytest.raises(ValueError, match="^points: the limit surface at sample .* exceeds the double range"):
        s.evaluate(np.arange(6), np.full((6, 2), 0.5), derivatives=1)
    assert np.isfinite(s.limit_points()).all()

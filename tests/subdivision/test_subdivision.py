"""dk.subdivide and dk.Subdivider against the subdivision schemes written out independently here."""
import numpy as np
import pytest

import deformkit as dk
from support.subdivision_meshes import (CUBE_FACES, CUBE_POINTS, OCTAHEDRON_FACES, OCTAHEDRON_POINTS, edges_of, grid, prism,
                                signed_volume)


@pytest.mark.parametrize("mesh", ["cube", "prism", "grid"])
def test_catmull_clark_counts_follow_the_scheme(mesh):
    points, faces = {"cube": (CUBE_POINTS, CUBE_FACES), "prism": prism(), "grid": grid(3)}[mesh]
    V, F = len(points), len(faces)
    E = len(edges_of(faces)[0])
    corners = sum(len(f) for f in faces)
    for level in range(1, 5):
        m = dk.subdivide(points, faces, level)
        assert m.faces.shape == (corners * 4 ** (level - 1), 4)
        if level == 1:  # one point per vertex, edge and face
            assert len(m.points) == V + E + F
        assert len(m.points) == m.faces.max() + 1 and len(np.unique(m.faces)) == len(m.points)
        # each control face makes size * 4^(L-1) faces
        per_face = np.bincount(m.face_origin, minlength=F)
        assert per_face.tolist() == [len(f) * 4 ** (level - 1) for f in faces]


def test_loop_counts_follow_the_scheme():
    V, F = len(OCTAHEDRON_POINTS), len(OCTAHEDRON_FACES)
    E = len(edges_of(OCTAHEDRON_FACES)[0])
    for level in range(1, 5):
        m = dk.subdivide(OCTAHEDRON_POINTS, OCTAHEDRON_FACES, level)
        assert m.scheme == "loop" and m.faces.shape == (F * 4 ** level, 3)
        assert len(m.points) == 2 + F * 4 ** level // 2  # closed genus 0: V = F/2 + 2
        if level == 1:
            assert len(m.points) == V + E
        assert np.all(np.bincount(m.face_origin) == 4 ** level)


def test_output_is_consistently_wound_and_closed():
    for points, faces in [(CUBE_POINTS, CUBE_FACES), prism(), (OCTAHEDRON_POINTS, OCTAHEDRON_FACES)]:
        m = dk.subdivide(points, faces, 2)
        _, uses = edges_of(m.faces)
        assert np.all(uses == 2)
        directed = {(f[i], f[(i + 1) % len(f)]) for f in m.faces.tolist() for i in range(len(f))}
        assert len(directed) == 2 * len(uses)  # every edge once in each direction
        assert signed_volume(m.points, m.faces) > 0 and signed_volume(points, faces) > 0


def catmull_clark_once(points, faces):
    """Catmull-Clark level 1 on a closed manifold, from the paper's rules: sets of points."""
    face_pts = np.array([points[f].mean(axis=0) for f in faces])
    edges, _ = edges_of(faces)
    edge_faces = {tuple(e): [] for e in edges.tolist()}
    for fi, f in enumerate(faces):
        for i in range(len(f)):
            edge_faces[tuple(sorted((f[i], f[(i + 1) % len(f)])))].append(fi)
    edge_pts = {e: (points[e[0]] + points[e[1]] + face_pts[fs].sum(axis=0)) / 4 for e, fs in edge_faces.items()}
    vert_pts = []
    for v in range(len(points)):
        fs = [fi for fi, f in enumerate(faces) if v in f]
        es = [e for e in edge_faces if v in e]
        n = len(es)
        Q = face_pts[fs].mean(axis=0)
        R = np.mean([(points[a] + points[b]) / 2 for a, b in es], axis=0)
        vert_pts.append((Q + 2 * R + (n - 3) * points[v]) / n)
    return np.vstack([vert_pts, list(edge_pts.values()), face_pts])


def as_sorted(points):
    return points[np.lexsort(np.round(points, 9).T[::-1])]


def test_catmull_clark_level_one_matches_the_rules():
    rng = np.random.default_rng(1)
    points = CUBE_POINTS + 0.2 * rng.standard_normal(CUBE_POINTS.shape)
    m = dk.subdivide(points, CUBE_FACES, 1)
    np.testing.assert_allclose(as_sorted(m.points), as_sorted(catmull_clark_once(points, CUBE_FACES)), atol=1e-12)


def test_open_grid_boundary_rules():
    points, faces = grid(4, bump=0.3)
    m = dk.subdivide(points, faces, 1, boundary="edge_and_corner")
    corner_ids = [0, 4, 20, 24]
    for c in corner_ids:  # Keep Corners: a valence-2 corner stays put
        assert np.min(np.linalg.norm(m.points - points[c], axis=1)) < 1e-12
    # a boundary vertex: (1/8, 3/4, 1/8) along the boundary; a boundary edge point: the midpoint
    expect_vertex = (points[1] + 6 * points[2] + points[3]) / 8
    expect_edge = (points[1] + points[2]) / 2
    for p in (expect_vertex, expect_edge):
        assert np.min(np.linalg.norm(m.points - p, axis=1)) < 1e-12
    smooth = dk.subdivide(points, faces, 1, boundary="edge_only")  # the corner moves: a B-spline end
    assert np.min(np.linalg.norm(smooth.points - points[0], axis=1)) > 1e-3


def test_infinitely_sharp_crease_gets_midpoints():
    rng = np.random.default_rng(2)
    points = CUBE_POINTS + 0.1 * rng.standard_normal(CUBE_POINTS.shape)
    plain = dk.subdivide(points, CUBE_FACES, 1)
    creased = dk.subdivide(points, CUBE_FACES, 1, creases=(np.array([[0, 1]]), np.array([10.0])))
    mid = (points[0] + points[1]) / 2
    assert np.min(np.linalg.norm(creased.points - mid, axis=1)) < 1e-12
    assert np.min(np.linalg.norm(plain.points - mid, axis=1)) > 1e-3
    # a semi-sharp crease of 0.5 lies between the smooth and the sharp edge points
    half = dk.subdivide(points, CUBE_FACES, 1, creases=(np.array([[1, 0]]), np.array([0.5])))
    d = np.min(np.linalg.norm(half.points - mid, axis=1))
    assert 1e-6 < d < np.min(np.linalg.norm(plain.points - mid, axis=1))
    corner = dk.subdivide(points, CUBE_FACES, 1, corners=(np.array([3]), np.array([10.0])))
    assert np.min(np.linalg.norm(corner.points - points[3], axis=1)) < 1e-12


def test_loop_level_one_matches_the_masks():
    rng = np.random.default_rng(3)
    points = OCTAHEDRON_POINTS + 0.1 * rng.standard_normal(OCTAHEDRON_POINTS.shape)
    m = dk.subdivide(points, OCTAHEDRON_FACES, 1)
    edges, _ = edges_of(OCTAHEDRON_FACES)
    expected = []
    for a, b in edges.tolist():  # 3/8 the ends, 1/8 the two opposite corners
        opp = [next(v for v in f if v not in (a, b)) for f in OCTAHEDRON_FACES.tolist() if a in f and b in f]
        expected.append(3 / 8 * (points[a] + points[b]) + 1 / 8 * (points[opp[0]] + points[opp[1]]))
    for v in range(len(points)):  # Loop's beta for valence n
        ring = sorted({int(w) for f in OCTAHEDRON_FACES for w in f if v in f} - {v})
        n = len(ring)
        beta = (5 / 8 - (3 / 8 + np.cos(2 * np.pi / n) / 4) ** 2) / n
        expected.append((1 - n * beta) * points[v] + beta * points[ring].sum(axis=0))
    np.testing.assert_allclose(as_sorted(m.points), as_sorted(np.array(expected)), atol=1e-12)


def test_uvs_follow_the_faces_and_keep_seams():
    points, faces = grid(2)
    uv = points[:, :2] / 2  # a planar map: every rule reproduces a linear function inside
    corner_uv = uv[faces.ravel()]
    m = dk.subdivide(points, faces, 2, uvs=corner_uv, uv_smooth="smooth_all")
    assert m.uvs.shape == (m.faces.size, 2)
    # the refined points of a flat grid stay in z = 0 and the UVs stay linear in x, y inside
    inner = np.all((m.points[m.faces.ravel(), :2] > 0.3) & (m.points[m.faces.ravel(), :2] < 1.7), axis=1)
    np.testing.assert_allclose(m.uvs[inner], m.points[m.faces.ravel()][inner, :2] / 2, atol=1e-12)
    # a seam: the right column's corners get their own UVs; refined seam corners then differ
    seam = corner_uv.copy()
    right = np.isin(faces.ravel(), [2, 5, 8]) & (np.repeat(np.arange(len(faces)), 4) % 2 == 1)
    seam[right] += 10.0
    s = dk.subdivide(points, faces, 1, uvs=seam, uv_smooth="none")
    assert np.ptp(s.uvs[:, 0]) > 5


def test_subdivider_reuses_the_topology():
    points, faces = prism()
    sd = dk.Subdivider(points, faces, 3)
    once = dk.subdivide(points, faces, 3)
    np.testing.assert_array_equal(sd.faces, once.faces)
    np.testing.assert_array_equal(sd.face_origin, once.face_origin)
    moved = dk.Twist(rate=0.7).deform(points)
    np.testing.assert_allclose(sd.subdivide(moved), dk.subdivide(moved, faces, 3).points, atol=1e-14)
    # subdivision is linear in the cage: affine maps commute with it
    A, t = np.array([[1.2, 0.3, 0], [0, 0.8, 0.1], [0.2, 0, 1.1]]), np.array([0.5, -1, 2])
    np.testing.assert_allclose(sd.subdivide(points @ A.T + t), sd.subdivide(points) @ A.T + t, atol=1e-12)
    assert sd.vertex_count == len(once.points) and sd.level == 3


def test_inputs_are_not_modified():
    points, faces = prism()
    faces = [list(f) for f in faces]
    p0, f0 = points.copy(), [list(f) for f in faces]
    dk.subdivide(points, faces, 2)
    dk.smoothness_report(points, faces)
    np.testing.assert_array_equal(points, p0)
    assert faces == f0


def two_edge_mesh():
    """A cube whose bottom front edge is split by a vertex (8) off the line: two pentagons share
    it, and it has exactly two edges."""
    points = np.r_[CUBE_POINTS, [[0.2, -1.2, -1.1]]]
    faces = [[0, 2, 3, 1, 8], [4, 5, 7, 6], [0, 8, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]]
    return points, faces


def test_a_creased_border_keeps_its_corners():
    """The issue's plane: 2 x 2 quads, all 8 border edges infinitely sharp, Smooth boundary. A
    corner between two infinitely sharp edges is a corner (it stays put, as Blender keeps it);
    OpenSubdiv's plain rules make it a crease vertex, (a + 6 v + b) / 8 = (0.125, 0.125, 0)."""
    points, faces = grid(2)
    border = np.array([[0, 1], [1, 2], [2, 5], [5, 8], [8, 7], [7, 6], [6, 3], [3, 0]])
    creases = (border, np.full(8, 10.0))
    m = dk.subdivide(points, faces, 1, scheme="catmull_clark", boundary="edge_only", creases=creases)
    for c in (0, 2, 6, 8):
        np.testing.assert_array_equal(m.points[c], points[c])
    plain = dk.subdivide(points, faces, 1, boundary="edge_only", creases=creases, sharpen_two_edge_vertices=False)
    np.testing.assert_allclose(plain.points[0], (points[1] + 6 * points[0] + points[3]) / 8, atol=1e-15)


@pytest.mark.parametrize("boundary", ["edge_only", "edge_and_corner"])
def test_two_edge_vertices_take_the_smaller_crease(boundary):
    """Blender's rule written out: every vertex with exactly two edges gets its own sharpness plus
    the smaller of those edges' (at most 10). The same mesh with that sharpness given as corners
    and the rule off must subdivide, and have a limit surface, identically."""
    rng = np.random.default_rng(4)
    cases = [(two_edge_mesh(), [[0, 8], [8, 1], [4, 5]], [2]), (grid(3, bump=0.3), [[0, 1], [0, 4], [3, 7], [2, 3]], [3])]
    for (points, faces), pairs, vertex in cases:
        pairs = np.array(pairs)
        sharpness = rng.uniform(0.3, 4.0, len(pairs))
        corner_sharpness = np.array([1.5])
        edges, counts = edges_of(faces)
        degree = np.bincount(edges.ravel(), minlength=len(points))
        expected = np.zeros(len(points))
        expected[vertex] = corner_sharpness
        for v in np.flatnonzero(degree == 2):
            touching = [s for (a, b), s in zip(pairs, sharpness) if v in (a, b)]
            smaller = min(touching) if len(touching) == 2 else 0.0  # an uncreased edge counts 0
            expected[v] = min(expected[v] + smaller, 10.0)
        corners = (np.flatnonzero(expected), expected[expected > 0])
        kwargs = dict(scheme="catmull_clark", boundary=boundary, creases=(pairs, sharpness))
        ours = dk.subdivide(points, faces, 2, corners=(np.array(vertex), corner_sharpness), **kwargs)
        written = dk.subdivide(points, faces, 2, corners=corners, sharpen_two_edge_vertices=False, **kwargs)
        np.testing.assert_allclose(ours.points, written.points, atol=1e-6)  # OpenSubdiv keeps sharpness in float32
        surface = dk.LimitSurface(points, faces, corners=(np.array(vertex), corner_sharpness), **kwargs)
        written_surface = dk.LimitSurface(points, faces, corners=corners, sharpen_two_edge_vertices=False, **kwargs)
        np.testing.assert_allclose(surface.limit_points(), written_surface.limit_points(), atol=1e-6)
        off = dk.subdivide(points, faces, 2, corners=(np.array(vertex), corner_sharpness),
                           sharpen_two_edge_vertices=False, **kwargs)
        if boundary == "edge_only" or points is cases[0][0][0]:  # Keep Corners makes border corners sharp anyway
            assert np.abs(off.points - ours.points).max() > 1e-3  # the rule moves something here


def test_limit_surface_option_gives_the_limit_of_every_refined_vertex():
    """Refinement keeps the limit surface, so the limit point of each refined vertex is the refined
    cage's own limit_points(): an independent path (no ptex parameters). Uncreased meshes, whose
    refined cages carry every rule: quads, n-gons, both boundary rules, Loop."""
    cases = [(two_edge_mesh(), {}), (prism(), {}), (grid(3, bump=0.3), dict(boundary="edge_only")),
             (grid(3, bump=0.3), dict(boundary="edge_and_corner")),
             ((OCTAHEDRON_POINTS, OCTAHEDRON_FACES), dict(scheme="loop"))]
    for (points, faces), kwargs in cases:
        for level in (1, 2, 3):
            refined = dk.subdivide(points, faces, level, **kwargs)
            limit = dk.subdivide(points, faces, level, limit_surface=True, **kwargs)
            np.testing.assert_array_equal(limit.faces, refined.faces)
            truth = dk.LimitSurface(refined.points, refined.faces, **kwargs).limit_points()
            np.testing.assert_allclose(limit.points, truth, atol=1e-12, err_msg=f"{kwargs} level {level}")
            assert np.abs(limit.points - refined.points).max() > 1e-3
    points, faces = prism()
    s = dk.Subdivider(points, faces, 2, limit_surface=True)
    bent = dk.Bend(curvature=0.5).deform(points)
    assert s.limit_surface
    np.testing.assert_array_equal(s.subdivide(bent), dk.subdivide(bent, faces, 2, limit_surface=True).points)
    ptex, uv = s.vertex_parameters()
    surface = dk.LimitSurface(points, faces)
    np.testing.assert_array_equal(surface.evaluate(ptex, uv, points=bent, derivatives=0)["position"], s.subdivide(bent))

"""Every bad input to subdivision and the smoothness checks: a clear error naming the argument."""
import numpy as np
import pytest

import deformkit as dk
from support.subdivision_meshes import CUBE_FACES, CUBE_POINTS, OCTAHEDRON_FACES, OCTAHEDRON_POINTS, grid

P, F = CUBE_POINTS, CUBE_FACES


@pytest.mark.parametrize("call", [
    lambda pts, faces, **kw: dk.subdivide(pts, faces, 1, **kw),
    lambda pts, faces, **kw: dk.LimitSurface(pts, faces, **kw),
    lambda pts, faces, **kw: dk.smoothness_report(pts, faces, **kw),
    lambda pts, faces, **kw: dk.Subdivider(pts, faces, 1, **kw),
])
def test_topology_errors(call):
    book = np.r_[P, [[0.0, 0.0, 3.0]]]
    cases = [
        ((book, F.tolist() + [[0, 1, 8]]), "^faces: edge \\(0, 1\\) has 3 faces"),          # non-manifold
        ((np.r_[P, [[5.0, 5.0, 5.0]]], F), "^points: vertex 8 is in no face"),           # isolated
        ((P, np.r_[F[:5], [[1, 3, 3, 5]]]), "^faces: face 5 repeats vertex 3"),
        ((P, np.r_[F[:5], [F[5][::-1]]]), "^faces: faces .* same direction"),            # winding
        ((P, [[0, 1, 2, 3], [0, 1]]), "^faces: face 1 has fewer than 3 corners"),
        ((P, np.r_[F[:5], [[1, 3, 7, 9]]]), "^faces: face 5 has corner index 9"),
        ((np.where(np.arange(24).reshape(8, 3) == 4, np.nan, P), F), "^points: row 1 is not finite"),
    ]
    for (pts, faces), message in cases:
        with pytest.raises(ValueError, match=message):
            call(pts, faces)
    with pytest.raises(ValueError, match="^faces: the Loop scheme needs triangles"):
        call(P, F, scheme="loop")
    with pytest.raises(ValueError, match="^scheme:"):
        call(P, F, scheme="butterfly")
    with pytest.raises(ValueError, match="^boundary:"):
        call(P, F, boundary="none")
    with pytest.raises(ValueError, match="^creases: sharpness 0 is negative or NaN"):
        call(P, F, creases=(np.array([[0, 1]]), np.array([-1.0])))
    with pytest.raises(ValueError, match="^creases: sharpness 0 is negative or NaN"):
        call(P, F, creases=(np.array([[0, 1]]), np.array([np.nan])))
    with pytest.raises(ValueError, match="^creases: pair 0 \\(0, 7\\) is not an edge"):
        call(P, F, creases=(np.array([[0, 7]]), np.array([1.0])))
    with pytest.raises(ValueError, match="^creases: expected"):
        call(P, F, creases=(np.array([[0, 1], [1, 3]]), np.array([1.0])))
    with pytest.raises(TypeError, match="^creases: expected a pair"):
        call(P, F, creases=np.array([[0, 1]]))
    with pytest.raises(ValueError, match="^corners: sharpness 0 is negative"):
        call(P, F, corners=(np.array([0]), np.array([-2.0])))
    with pytest.raises(ValueError, match="^corners: vertex index 8"):
        call(P, F, corners=(np.array([8]), np.array([2.0])))
    with pytest.raises(TypeError, match="^points:"):
        call(P.astype(int), F)
    with pytest.raises(ValueError, match="^points: expected shape \\(n, 3\\)"):
        call(P[:, :2].copy(), F)


def test_levels_and_size_cap():
    for level in (0, -1, dk.SUBDIVISION_MAX_LEVEL + 1):
        with pytest.raises(ValueError, match="^level: must be 1..8"):
            dk.subdivide(P, F, level)
    with pytest.raises(ValueError, match="^level: 4 would make 1536 faces, more than max_faces=1000"):
        dk.subdivide(P, F, 4, max_faces=1000)
    assert len(dk.subdivide(P, F, 4, max_faces=1536).faces) == 1536
    with pytest.raises(ValueError, match="^max_faces:"):
        dk.subdivide(P, F, 1, max_faces=0)
    # the default cap stops a level that would need gigabytes, before any work
    big_p, big_f = grid(64)
    with pytest.raises(ValueError, match="^level: 8 would make 268435456 faces"):
        dk.subdivide(big_p, big_f, 8)


def test_uv_errors():
    corners = np.zeros((F.size, 2))
    with pytest.raises(ValueError, match="^uvs: expected one \\(u, v\\) per face corner \\(24 rows\\), got 23"):
        dk.subdivide(P, F, 1, uvs=corners[:23])
    with pytest.raises(ValueError, match="^uvs: expected shape \\(corners, 2\\)"):
        dk.subdivide(P, F, 1, uvs=np.zeros((24, 3)))
    bad = corners.copy()
    bad[5, 1] = np.inf
    with pytest.raises(ValueError, match="^uvs: row 5 is not finite"):
        dk.subdivide(P, F, 1, uvs=bad)
    with pytest.raises(ValueError, match="^uv_smooth:"):
        dk.subdivide(P, F, 1, uvs=corners, uv_smooth="smooth")


def test_evaluate_errors():
    s = dk.LimitSurface(P, F)
    with pytest.raises(ValueError, match="^ptex: sample 1 has ptex face 6, outside 0..5"):
        s.evaluate([0, 6], np.zeros((2, 2)))
    with pytest.raises(ValueError, match="^ptex: sample 0 has ptex face -1"):
        s.evaluate([-1], np.zeros((1, 2)))
    with pytest.raises(ValueError, match="^uv: sample 0 .* outside the unit square"):
        s.evaluate([0], [[1.5, 0.2]])
    with pytest.raises(ValueError, match="^uv: sample 0 .* outside"):
        s.evaluate([0], [[np.nan, 0.2]])
    with pytest.raises(ValueError, match="^uv: expected shape \\(2, 2\\)"):
        s.evaluate([0, 1], np.zeros((3, 2)))
    with pytest.raises(ValueError, match="^derivatives:"):
        s.evaluate([0], [[0.5, 0.5]], derivatives=3)
    with pytest.raises(ValueError, match="^points: expected 8 rows"):
        s.evaluate([0], [[0.5, 0.5]], points=np.zeros((7, 3)))
    with pytest.raises(ValueError, match="^points: row 0 is not finite"):
        s.limit_points(np.full((8, 3), np.nan))
    loop = dk.LimitSurface(OCTAHEDRON_POINTS, OCTAHEDRON_FACES)
    with pytest.raises(ValueError, match="^uv: sample 0 .* triangle"):
        loop.evaluate([0], [[0.7, 0.7]])


def test_report_errors():
    with pytest.raises(ValueError, match="^samples_per_edge: must be 1..1000"):
        dk.smoothness_report(P, F, samples_per_edge=0)
    with pytest.raises(ValueError, match="^worst:"):
        dk.smoothness_report(P, F, worst=-1)
    with pytest.raises(ValueError, match="^reference: expected 8 rows"):
        dk.smoothness_report(P, F, reference=P[:4])
    with pytest.raises(ValueError, match="^points: all points coincide"):
        dk.smoothness_report(np.zeros((8, 3)), F)
    with pytest.raises(TypeError, match="^deformer: expected a deformkit deformer"):
        dk.smoothness_report(P, F, deformer="twist")
    weighted = dk.Twist(rate=1.0, weights=np.ones(8))
    with pytest.raises(ValueError, match="^deformer: has per-point weights"):
        dk.smoothness_report(P, F, deformer=weighted)
    with pytest.raises(ValueError, match="^crease_grid: must be 1..64"):
        dk.smoothness_report(P, F, deformer=dk.Twist(rate=1.0), crease_grid=0)


def test_large_polygon_is_checked_quickly():
    # a 200,000-gon with its last corner repeating the first: found by sorting, not k^2 comparisons
    k = 200_000
    a = 2 * np.pi * np.arange(k) / k
    points = np.c_[np.cos(a), np.sin(a), np.zeros(k)]
    face = list(range(k - 1)) + [0]
    with pytest.raises(ValueError, match="^faces: face 0 repeats vertex 0"):
        dk.subdivide(points, [face], 1)


def test_blender_order_refuses_edges_that_are_not_the_faces_edges():
    """Subdivider.blender_order numbers by the control edges: they must be exactly the faces' edges."""
    points, faces = np.asarray(CUBE_POINTS, float), np.asarray(CUBE_FACES)
    s = dk.Subdivider(points, faces, 2, scheme="catmull_clark")
    edges = np.array(sorted({tuple(sorted((f[i], f[(i + 1) % 4]))) for f in faces.tolist() for i in range(4)}))
    assert len(s.blender_order(edges)[0]) == s.vertex_count
    # the first face, in order, that has the last edge: its corners name the edge
    face, a, b = next((i, f[j], f[(j + 1) % 4]) for i, f in enumerate(faces.tolist()) for j in range(4)
                      if sorted((f[j], f[(j + 1) % 4])) == edges[-1].tolist())
    cases = [
        (edges[:-1], f"edges: the edge ({a}, {b}) of face {face} is missing"),
        (np.vstack([edges, [0, 7]]), "edges: 13 edges, more than the faces have (loose edges are not subdivided)"),
        (np.vstack([edges, edges[:1]]), "edges: edge 12 repeats an earlier edge"),
        (np.vstack([edges[:-1], [8, 0]]), "edges: edge 11 (8, 0) is not a pair of distinct vertices 0..7"),
        (np.vstack([edges[:-1], [3, 3]]), "edges: edge 11 (3, 3) is not a pair of distinct vertices 0..7"),
        (edges[:, :1], "edges: expected shape (k, 2), got (12, 1)"),
    ]
    for bad, message in cases:
        with pytest.raises(ValueError) as info:
            s.blender_order(bad)
        assert str(info.value) == message
    loop = dk.Subdivider(np.asarray(OCTAHEDRON_POINTS, float), OCTAHEDRON_FACES, 1, scheme="loop")
    with pytest.raises(ValueError, match=r"^scheme: Blender's order is defined for Catmull-Clark only, got loop$"):
        loop.blender_order(np.array([[0, 1]]))


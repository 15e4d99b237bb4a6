"""SurfaceDeformer on non-manifold and badly oriented input: the documented handling is that the
cotangent weights of an edge sum over every triangle that has it (any number, any orientation),
so such meshes solve like any other. Checked against dense numpy least squares, rigid motions and
rest."""
import numpy as np
import pytest

import deformkit as dk
from support.helpers import cot_weights, naive_reference
from test_surface_deformer import rot, tube


def book(pages=3, rows=5):
    """`pages` bumpy sheets sharing their spine (the x axis): every spine edge has `pages` triangles."""
    xs = np.linspace(0.0, 2.0, rows)
    pts, tris = [[x, 0.0, 0.0] for x in xs], []
    for p in range(pages):
        a = 2 * np.pi * p / pages
        base = len(pts)
        for r in (0.5, 1.0):
            pts += [[x, r * np.cos(a) + 0.05 * np.sin(3 * x), r * np.sin(a)] for x in xs]
        for k in range(rows - 1):
            inner = [k, k + 1]
            ring1 = [base + k, base + k + 1]
            ring2 = [base + rows + k, base + rows + k + 1]
            for lo, hi in ((inner, ring1), (ring1, ring2)):
                tris += [[lo[0], lo[1], hi[0]], [lo[1], hi[1], hi[0]]]
    return np.array(pts), np.array(tris)


@pytest.mark.parametrize("method", ["laplacian", "arap", "rotation_invariant"])
def test_non_manifold_edges_rest_and_rigid_motion(method):
    pts, tris = book()
    n = len(pts)
    handles = np.arange(n)[pts[:, 0] > 1.9]
    anchors = np.arange(n)[pts[:, 0] < 0.1]
    ed = dk.SurfaceDeformer(pts, tris, anchors=anchors, handles=handles, method=method)
    assert ed.warnings == []
    np.testing.assert_allclose(ed.deform(pts[handles]), pts, rtol=0, atol=1e-14)
    out = ed.deform(pts[handles] + [0.0, 0.3, 0.1])
    assert np.isfinite(out).all() and np.abs(out - pts).max() > 0.05
    if method == "arap":  # the linear methods are not rotation invariant
        r, t = rot(2, 35) @ rot(0, 20), np.array([0.4, -0.2, 1.0])
        held = np.concatenate([anchors, handles])
        moved = dk.SurfaceDeformer(pts, tris, handles=held, iterations=200).deform(pts[held] @ r.T + t)
        np.testing.assert_allclose(moved, pts @ r.T + t, rtol=0, atol=1e-6)  # linear convergence from R = I


def test_non_manifold_laplacian_matches_numpy_with_summed_weights():
    pts, tris = book(pages=4)
    w = cot_weights(pts, tris)  # sums over every triangle of an edge
    edges = np.zeros_like(w, bool)
    for a, b in ((0, 1), (1, 2), (2, 0)):
        edges[tris[:, a], tris[:, b]] = edges[tris[:, b], tris[:, a]] = True
    w[edges] = np.maximum(w[edges], 1e-3 * w[edges & (w > 0)].mean())  # deformkit's floor (right angles here)
    spine = np.flatnonzero(np.abs(pts[:, 1:]).sum(1) == 0)
    assert np.count_nonzero(w[spine[1], spine[2]]) == 1 and len(spine) == 5
    anchors, handles = np.flatnonzero(pts[:, 0] < 0.1), np.flatnonzero(pts[:, 0] > 1.9)
    targets = pts[handles] + [0.0, 0.2, -0.3]
    out = dk.SurfaceDeformer(pts, tris, anchors=anchors, handles=handles, method="laplacian").deform(targets)
    ref = naive_reference(pts, w, np.concatenate([anchors, handles]), np.concatenate([pts[anchors], targets]), "ls")
    np.testing.assert_allclose(out, ref, rtol=0, atol=1e-9)


def test_vertex_shared_by_two_sheets_and_flipped_triangles():
    """Two tubes touching at one vertex (a non-manifold vertex), half the triangles of one flipped:
    cotangent weights do not depend on orientation, so the result equals the consistently oriented mesh."""
    pts, tris, idx = tube()
    second = pts * [-1.0, 1.0, 1.0] + [2 * pts[idx[-1][0]][0], 0, 0]  # mirrored: the end rings meet
    both = np.vstack([pts, second])
    faces = np.vstack([tris, tris + len(pts)])
    joint = idx[-1][0]
    other = len(pts) + idx[-1][0]
    assert np.allclose(both[joint], both[other])
    faces[faces == other] = joint  # weld: one vertex in both tubes
    flipped = faces.copy()
    flipped[len(tris)::2] = flipped[len(tris)::2, ::-1]
    anchors = np.concatenate([idx[0], len(pts) + idx[0]])
    handles = np.array([joint])
    results = [dk.SurfaceDeformer(both, f, anchors=anchors, handles=handles).deform(both[handles] + [0, 0.4, 0])
               for f in (faces, flipped)]
    assert np.isfinite(results[0]).all()
    np.testing.assert_allclose(results[0], results[1], rtol=0, atol=1e-12)

"""Soft constraints of SurfaceDeformer (Sorkine et al. 2004, eq. 5) against dense numpy least
squares, their limit (hard constraints) as the weight grows, invariants (translation, rigid
motion, rest) and the rotation-invariant form's regularised null space."""
import numpy as np
import pytest

import deformkit as dk
from support.helpers import cot_weights, lap
from test_surface_deformer import bend_targets, ends, rot, tube


def soft_reference(pts, w, anchors, handles, targets, weight):
    """min ||L x' - L x||^2 + weight^2 sum ||x'_c - c||^2 over every vertex, dense lstsq."""
    L = lap(w)
    held = np.concatenate([anchors, handles])
    goals = np.concatenate([pts[anchors], targets])
    rows = np.zeros((len(held), len(pts)))
    rows[np.arange(len(held)), held] = weight
    a = np.vstack([L, rows])
    return np.linalg.lstsq(a, np.vstack([L @ pts, weight * goals]), rcond=None)[0]


@pytest.mark.parametrize("weight", [0.3, 2.0, 50.0])
def test_soft_laplacian_matches_numpy_least_squares(weight):
    pts, tris, idx = tube()
    anchors, handles = ends(idx)
    targets = bend_targets(pts, handles, 3.0, 60) + [0, 0, 0.3]
    ed = dk.SurfaceDeformer(pts, tris, anchors=anchors, handles=handles, method="laplacian",
                            constraint_weight=weight)
    ref = soft_reference(pts, cot_weights(pts, tris), anchors, handles, targets, weight)
    np.testing.assert_allclose(ed.deform(targets), ref, rtol=0, atol=1e-9)


@pytest.mark.parametrize("method", ["laplacian", "arap", "rotation_invariant"])
def test_soft_constraints_tend_to_hard_ones(method):
    pts, tris, idx = tube()
    anchors, handles = ends(idx)
    targets = bend_targets(pts, handles, 3.0, 45)
    kw = dict(anchors=anchors, handles=handles, method=method, iterations=20)
    hard = dk.SurfaceDeformer(pts, tris, **kw).deform(targets)
    miss, gap = [], []
    for weight in (1.0, 10.0, 100.0, 1000.0):
        out = dk.SurfaceDeformer(pts, tris, constraint_weight=weight, **kw).deform(targets)
        miss.append(np.abs(out[handles] - targets).max())
        gap.append(np.abs(out - hard).max())
    assert miss[0] > 1e-3  # a soft handle does not reach its target ...
    assert all(b < a for a, b in zip(miss, miss[1:])), miss  # ... but gets closer as the weight grows
    assert all(b < a for a, b in zip(gap, gap[1:])), gap
    assert gap[-1] < 1e-2 * gap[0], gap


@pytest.mark.parametrize("method", ["laplacian", "arap", "rotation_invariant"])
def test_soft_rest_and_translation_are_exact(method):
    """Every method is translation invariant, so moving every constraint by t moves the whole mesh
    by t (zero energy), and rest targets give the rest mesh."""
    pts, tris, idx = tube()
    anchors, handles = ends(idx)
    ed = dk.SurfaceDeformer(pts, tris, anchors=anchors, handles=handles, method=method, constraint_weight=0.5)
    np.testing.assert_allclose(ed.deform(pts[handles]), pts, rtol=0, atol=1e-12)
    everything = np.arange(len(pts))
    moved = dk.SurfaceDeformer(pts, tris, handles=everything[::7], method=method, constraint_weight=0.5)
    t = np.array([0.3, -1.2, 2.0])
    np.testing.assert_allclose(moved.deform(pts[::7] + t), pts + t, rtol=0, atol=1e-9)


def test_soft_arap_follows_a_rigid_motion_with_monotone_energy():
    pts, tris, idx = tube()
    handles = np.concatenate(ends(idx))
    r, t = rot(1, 70) @ rot(2, 30), np.array([1.0, 2.0, -0.5])
    ed = dk.SurfaceDeformer(pts, tris, handles=handles, constraint_weight=1.0, iterations=200)
    out = ed.deform(pts[handles] @ r.T + t)
    e = np.asarray(ed.energy)
    assert np.all(e[1:] <= e[:-1] * (1 + 1e-12)), np.diff(e)
    np.testing.assert_allclose(out, pts @ r.T + t, rtol=0, atol=1e-9)


def test_a_component_held_softly_is_solved():
    pts, tris, idx = tube()
    shifted = np.vstack([pts, pts + [0, 3, 0]])
    faces = np.vstack([tris, tris + len(pts)])
    anchors, handles = ends(idx)
    ed = dk.SurfaceDeformer(shifted, faces, anchors=np.concatenate([anchors, anchors + len(pts)]),
                            handles=np.concatenate([handles, handles + len(pts)]), constraint_weight=5.0)
    assert ed.warnings == []
    targets = bend_targets(pts, handles, 3.0, 30)
    out = ed.deform(np.vstack([targets, targets + [0, 3, 0]]))
    np.testing.assert_allclose(out[len(pts):], out[:len(pts)] + [0, 3, 0], rtol=0, atol=1e-9)


@pytest.mark.parametrize("bad", [0.0, -1.0, np.nan, np.inf, 1e9])
def test_bad_constraint_weight_is_refused(bad):
    pts, tris, idx = tube()
    with pytest.raises(ValueError, match="constraint_weight"):
        dk.SurfaceDeformer(pts, tris, anchors=idx[0], constraint_weight=bad)


def test_rotation_invariant_with_one_held_vertex_stays_bounded():
    """One anchor and one handle leave the linearised rotations about their axis free (a singular
    system): it is regularised, with a warning; rest stays exact, and moving the handle gives a
    finite result whose free mode did not run away (no vertex moves much further than the handle)."""
    pts, tris, idx = tube()
    anchor, handle = idx[0][:1], idx[-1][:1]
    ed = dk.SurfaceDeformer(pts, tris, anchors=anchor, handles=handle, method="rotation_invariant")
    assert any("non-collinear" in w for w in ed.warnings), ed.warnings
    np.testing.assert_array_equal(ed.deform(pts[handle]), pts)
    shift = np.array([0.0, 0.4, 0.0])
    out = ed.deform(pts[handle] + shift)
    assert np.isfinite(out).all()
    np.testing.assert_array_equal(out[anchor], pts[anchor])
    np.testing.assert_allclose(out[handle], pts[handle] + shift, rtol=0, atol=1e-12)
    assert np.linalg.norm(out - pts, axis=1).max() < 2 * np.linalg.norm(shift)


def _surface_in_child(queue, method):
    pts, tris = _grid(40)
    handles = np.arange(len(pts))[pts[:, 0] > 38.5]
    ed = dk.SurfaceDeformer(pts, tris, anchors=np.flatnonzero(pts[:, 0] < 0.5), handles=handles, method=method)
    queue.put(float(np.abs(ed.deform(pts[handles] + [0, 0, 3.0]) - pts).max()))


def _grid(k):
    j, i = np.divmod(np.arange(k * k), k)
    pts = np.stack([i * 1.0, j * 1.0, 0.1 * np.sin(i) * np.cos(j)], 1)
    v = (np.arange(k - 1)[:, None] * k + np.arange(k - 1)[None, :]).ravel()
    return pts, np.concatenate([np.stack([v, v + 1, v + k], 1), np.stack([v + 1, v + k + 1, v + k], 1)])


@pytest.mark.parametrize("method", ["laplacian", "arap", "rotation_invariant"])
def test_forked_child_can_build_and_solve(method):
    """CHOLMOD's supernodal factorisation opens OpenMP regions, which hang in a child forked after
    the parent started OpenMP's threads; a forked child must still build and solve."""
    import multiprocessing
    pts, tris = _grid(60)
    handles = np.arange(len(pts))[pts[:, 0] > 58.5]
    dk.SurfaceDeformer(pts, tris, anchors=np.flatnonzero(pts[:, 0] < 0.5), handles=handles,
                      method=method).deform(pts[handles] + 1)
    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    child = ctx.Process(target=_surface_in_child, args=(queue, method))
    child.start()
    child.join(timeout=60)
    if child.is_alive():
        child.kill()
        pytest.fail("the forked child hung building a SurfaceDeformer")
    assert child.exitcode == 0 and queue.get(timeout=5) > 1.0


def test_rotation_invariant_with_one_handle_translates_the_mesh():
    """A single held vertex leaves the linearised system singular; among its solutions the one
    nearest naive editing is used, so translating the only handle translates the whole mesh."""
    pts, tris = _grid(20)
    ed = dk.SurfaceDeformer(pts, tris, handles=[210], method="rotation_invariant")
    t = np.array([0.3, -0.2, 1.0])
    np.testing.assert_allclose(ed.deform(pts[[210]] + t), pts + t, rtol=0, atol=1e-9)

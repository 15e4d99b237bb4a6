"""The bind's faster paths (issue 19) against what they replace: the AMD ordering remembered for a
connectivity and restricted to another set of free vertices still gives the dense least-squares
solution; the rotation-invariant fit of each one-ring on its centred coordinates keeps the method
invariant under translation; bind_stages accounts for the construction."""
import time

import numpy as np
import pytest
import trimesh

import deformkit as dk
from support.helpers import cot_weights, naive_reference


def bumpy_sphere(subdivisions, seed):
    """A slightly bumpy icosphere (acute triangles: no weight is raised) with its vertices numbered at
    random: a connectivity no other test binds, so that its ordering is not yet remembered."""
    m = trimesh.creation.icosphere(subdivisions=subdivisions)
    v = np.asarray(m.vertices)
    v = v * (1 + 0.02 * np.sin(3 * v[:, :1]) * np.cos(2 * v[:, 1:2])) * [1.0, 1.1, 0.9]
    order = np.random.default_rng(seed).permutation(len(v))
    new = np.empty_like(order)
    new[order] = np.arange(len(v))
    return v[order], new[np.asarray(m.faces)]


def stage_names(deformer):
    return [name for name, *_ in deformer.bind_stages]


def test_a_rebind_with_the_same_connectivity_reuses_the_ordering_and_still_solves_exactly():
    pts, tris = bumpy_sphere(3, 1)
    w = cot_weights(pts, tris)
    assert w[w != 0].min() > 0  # no weight is raised to deformkit's floor
    z = pts[:, 2]
    first = dk.SurfaceDeformer(pts, tris, anchors=np.flatnonzero(z < -0.8), handles=np.flatnonzero(z > 0.8),
                               method="laplacian")
    assert "ordering (AMD on all vertices)" in stage_names(first)
    # Other anchors and handles on the same mesh: the ordering of all vertices is reused,
    # restricted to the new free vertices.
    y = pts[:, 1]
    anchors, handles = np.flatnonzero(y < -0.7), np.flatnonzero(y > 0.75)
    second = dk.SurfaceDeformer(pts, tris, anchors=anchors, handles=handles, method="laplacian")
    assert "ordering (remembered for this connectivity)" in stage_names(second)
    targets = pts[handles] + [0.3, 0.1, -0.2]
    fixed = np.concatenate([anchors, handles])
    want = naive_reference(pts, w, fixed, np.concatenate([pts[anchors], targets]), "ls")
    np.testing.assert_allclose(second.deform(targets), want, rtol=0, atol=1e-9)


@pytest.mark.parametrize("method", ["arap", "rotation_invariant"])
def test_the_remembered_ordering_gives_the_same_result_as_a_fresh_one(method):
    pts, tris = bumpy_sphere(2, 2 if method == "arap" else 3)
    z = pts[:, 2]
    kw = dict(anchors=np.flatnonzero(z < -0.8), handles=np.flatnonzero(z > 0.8), method=method)
    fresh, again = dk.SurfaceDeformer(pts, tris, **kw), dk.SurfaceDeformer(pts, tris, **kw)
    assert "ordering (AMD on all vertices)" in stage_names(fresh)
    assert "ordering (remembered for this connectivity)" in stage_names(again)
    targets = pts[kw["handles"]] @ np.array([[1, 0, 0], [0, 0.8, -0.6], [0, 0.6, 0.8]]).T + [0.2, 0, 0]
    np.testing.assert_array_equal(fresh.deform(targets), again.deform(targets))  # one ordering, one factor


def test_rotation_invariant_commutes_with_a_translation():
    """Each one-ring's similarity fit is translation-free (t absorbs a shift), so the method's result
    for the mesh moved far from the origin is its result moved alike."""
    pts, tris = bumpy_sphere(2, 4)
    z = pts[:, 2]
    anchors, handles = np.flatnonzero(z < -0.7), np.flatnonzero(z > 0.7)
    targets = pts[handles] @ np.array([[0.8, -0.6, 0], [0.6, 0.8, 0], [0, 0, 1]]).T + [0.1, 0.2, 0.3]
    shift = np.array([3e3, -1e3, 2e3])
    here = dk.SurfaceDeformer(pts, tris, anchors=anchors, handles=handles, method="rotation_invariant").deform(targets)
    there = dk.SurfaceDeformer(pts + shift, tris, anchors=anchors, handles=handles,
                               method="rotation_invariant").deform(targets + shift)
    np.testing.assert_allclose(there - shift, here, rtol=0, atol=1e-8)
    assert np.abs(here - pts).max() > 0.1  # a real deformation


def test_bind_stages_account_for_the_construction():
    pts, tris = bumpy_sphere(3, 5)
    z = pts[:, 2]
    t0 = time.perf_counter()
    d = dk.SurfaceDeformer(pts, tris, anchors=np.flatnonzero(z < -0.8), handles=np.flatnonzero(z > 0.8),
                           method="laplacian")
    wall = time.perf_counter() - t0
    stages = d.bind_stages
    names = [s[0] for s in stages]
    assert any(n.startswith("L^T L: numeric (cholmod_factorize") for n in names), names
    assert all(s >= 0 and c >= 0 and f >= 0 for _, s, c, f in stages)
    assert sum(s for _, s, _, _ in stages) <= wall  # stages are disjoint parts of the construction

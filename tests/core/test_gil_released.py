"""Every place the bindings release the GIL around C++ work (cpp/bindings: each
py::gil_scoped_release, and without_gil in common.hpp through the Deformer methods that share it)
lets another Python thread run while that work is in progress. tests/support/gil_probe.py counts
only the other thread's stamps taken while this thread is inside the call's own C code, so a call
that holds the GIL gets none, on an idle or a loaded machine alike; no clock decides anything."""
import os
import zlib

import numpy as np
import pytest

import deformkit as dk
from support.gil_probe import stamps_inside, stamps_once

CUBE = np.array([[x, y, z] for x in (-1.0, 1.0) for y in (-1.0, 1.0) for z in (-1.0, 1.0)])
CUBE_QUADS = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]], np.int32)


def control_mesh(level):
    """A closed quad mesh (the cube refined `level` times): float64 points, int32 quads, both
    C-contiguous, so that no argument needs a numpy conversion (numpy releases the GIL in its own
    large casts)."""
    refined = dk.subdivide(CUBE, CUBE_QUADS, level)
    points = np.ascontiguousarray(refined.points, np.float64)
    return points, np.ascontiguousarray(np.asarray(refined.faces).reshape(-1, 4), np.int32)


def triangles(faces):
    return np.ascontiguousarray(np.concatenate([faces[:, [0, 1, 2]], faces[:, [0, 2, 3]]]), np.int32)


def cases():
    """(place in cpp/bindings, the call as fn, args, kwargs), built lazily: pytest ids first."""
    cage, quads = control_mesh(3)  # 384 quads: the subdivision calls refine it to 24k-98k faces
    big, big_quads = control_mesh(7)  # 98k quads for the one-pass volume
    limit = dk.LimitSurface(cage, quads)
    subdivider = dk.Subdivider(cage, quads, 3)
    rng = np.random.default_rng(0)
    samples = 200_000
    ptex = np.ascontiguousarray(rng.integers(0, len(quads), samples), np.int64)
    uv = np.ascontiguousarray(rng.uniform(0, 1, (samples, 2)))
    points = np.ascontiguousarray(rng.uniform(-1, 1, (1_000_000, 3)))
    stack = dk.Stack([dk.Twist(), dk.Bend(), dk.Taper()] * 2)
    surface_points, surface_quads = control_mesh(4)
    surface_faces = triangles(surface_quads)
    z = surface_points[:, 2]
    top = np.flatnonzero(z > np.quantile(z, 0.9)).astype(np.int64)
    bottom = np.flatnonzero(z < np.quantile(z, 0.1)).astype(np.int64)
    surface = dk.SurfaceDeformer(surface_points, surface_faces, anchors=bottom, handles=top)
    handles = np.ascontiguousarray(surface_points[top] + [0.0, 0.0, 0.5])
    return {
        "subdivision.cpp Subdivider()": (dk.Subdivider, (cage, quads, 4), {}),
        "subdivision.cpp Subdivider.subdivide": (subdivider.subdivide, (cage,), {}),
        "subdivision.cpp Subdivider.mesh": (subdivider.mesh, (cage,), {}),
        "subdivision.cpp subdivide()": (dk.subdivide, (cage, quads, 4), {}),
        "subdivision.cpp LimitSurface()": (dk.LimitSurface, (big, big_quads), {}),
        "subdivision.cpp LimitSurface.evaluate": (limit.evaluate, (ptex, uv), {"derivatives": 2}),
        "subdivision.cpp LimitSurface.limit_points": (dk.LimitSurface(big, big_quads).limit_points, (), {}),
        "subdivision.cpp LimitSurface.smoothness_report": (limit.smoothness_report, (), {"samples_per_edge": 32}),
        "subdivision.cpp smoothness_report()": (dk.smoothness_report, (cage, quads), {"samples_per_edge": 32}),
        "surface.cpp SurfaceDeformer()": (dk.SurfaceDeformer, (surface_points, surface_faces),
                                          {"anchors": bottom, "handles": top}),
        "core.cpp mesh_volume int32 faces, read in place": (dk.mesh_volume, (big, big_quads), {}),
        "core.cpp mesh_volume other faces": (dk.mesh_volume, (big, big_quads.astype(np.int64)), {}),
        "common.hpp without_gil: Deformer.deform": (stack.deform, (points,), {}),
        "common.hpp without_gil: Deformer.jacobian": (stack.jacobian, (points[:200_000],), {}),
        "common.hpp without_gil: Deformer.transform_normals": (stack.transform_normals, (points, points), {}),
        "common.hpp without_gil: Deformer.volume_ratio": (stack.volume_ratio, (points,), {}),
        "common.hpp without_gil: SurfaceDeformer.deform": (surface.deform, (handles,), {}),
    }


PLACES = ["subdivision.cpp Subdivider()", "subdivision.cpp Subdivider.subdivide", "subdivision.cpp Subdivider.mesh",
          "subdivision.cpp subdivide()", "subdivision.cpp LimitSurface()", "subdivision.cpp LimitSurface.evaluate",
          "subdivision.cpp LimitSurface.limit_points", "subdivision.cpp LimitSurface.smoothness_report",
          "subdivision.cpp smoothness_report()", "surface.cpp SurfaceDeformer()",
          "core.cpp mesh_volume int32 faces, read in place", "core.cpp mesh_volume other faces",
          "common.hpp without_gil: Deformer.deform", "common.hpp without_gil: Deformer.jacobian",
          "common.hpp without_gil: Deformer.transform_normals", "common.hpp without_gil: Deformer.volume_ratio",
          "common.hpp without_gil: SurfaceDeformer.deform"]


@pytest.fixture(scope="module")
def calls():
    built = cases()
    assert sorted(built) == sorted(PLACES)
    return built


@pytest.mark.parametrize("place", PLACES)
def test_another_thread_runs_inside_the_call(calls, place):
    fn, args, kwargs = calls[place]
    assert stamps_inside(fn, *args, **kwargs) > 0, f"{place}: no Python thread ran while it worked"


def test_the_probe_sees_a_call_that_holds_the_gil():
    """The probe can fail: sum() over a range is C code that never releases the GIL, and so is
    Stack's constructor converting 300,000 deformers (a binding that keeps the GIL while it works);
    however long they run, no stamp lands inside them (the window counter test_bad_input.py used
    before found thousands either way), while the same probe finds stamps in zlib.compress, which
    releases the GIL."""
    assert all(stamps_once(sum, range(2_000_000))[0] == 0 for _ in range(10))
    assert all(stamps_once(dk.Stack, [dk.Twist()] * 300_000)[0] == 0 for _ in range(3))
    assert stamps_inside(zlib.compress, os.urandom(1 << 21)) > 0

"""Cage deformation: deformkit's mean value and Green coordinates against Blender's Mesh Deform.

    .venv/bin/python benchmarks/bench_cage.py [--models Ogre,FireHydrant,Beast] [--repeats R] [--precision P]

For each model of ../shared/cages (model, rest cage, deformed cage: same vertex order), in one
bpy 5.0 process: Blender's Mesh Deform (Precision 5, its default) bind time and its frame after the
cage moves to the deformed cage (depsgraph update + evaluated vertex count), and deformkit's
dk.MeanValueCage / dk.GreenCage bind and deform_bound after setting the deformed cage (dense
float64, float32, and sparsified weights at Mesh Deform's threshold and at 1e-4, each with its
kept weights per point and distance from the dense result). Shape quality from the same run: the
mean change of the model's triangle angles (degrees) under the deformed cage, for each method, and
how far each method's result lies from Mesh Deform's (mean and max over the vertices). Skips with
a message when ../shared/cages is absent.
"""
import argparse
import pathlib
import statistics
import sys
import time

import numpy as np

from bench_common import evaluated, imported, mesh_deform_bind

CAGES = pathlib.Path(__file__).resolve().parents[1].parent / "shared" / "cages"

ap = argparse.ArgumentParser()
ap.add_argument("--models", default="Ogre,FireHydrant,Beast")
ap.add_argument("--repeats", type=int, default=7)
ap.add_argument("--precision", type=int, default=5)
args = ap.parse_args()
if not CAGES.is_dir():
    print(f"bench_cage: {CAGES} is absent (the project's test data); nothing to measure")
    sys.exit(0)

import bpy  # noqa: E402
import deformkit as dk  # noqa: E402


def triangles_of(faces):
    return np.array([[f[0], f[i], f[i + 1]] for f in faces for i in range(1, len(f) - 1)])


def angles(points, tris):
    a, b, c = (points[tris[:, k]] for k in range(3))

    def angle(u, v):
        return np.arctan2(np.linalg.norm(np.cross(u, v), axis=1), (u * v).sum(1))
    return np.stack([angle(b - a, c - a), angle(a - b, c - b), angle(a - c, b - c)], 1)


def angle_distortion(rest, deformed, tris):
    return float(np.degrees(np.abs(angles(deformed, tris) - angles(rest, tris))).mean())


def timed(fn, repeats):
    out, times = None, []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return out, statistics.median(times)


def mesh_deform(model, cage, cage_rest, cage_moved, repeats):
    """Blender's Mesh Deform: (bind s, frame s, deformed points)."""
    mod, bind = mesh_deform_bind(model, cage, args.precision)
    frames = []
    for i in range(repeats + 1):
        target = cage_moved if i % 2 == 0 else cage_rest
        cage.data.attributes["position"].data.foreach_set("vector", target.astype(np.float32).ravel())
        cage.data.update()
        t0 = time.perf_counter()
        dg = bpy.context.evaluated_depsgraph_get()
        dg.update()
        len(model.evaluated_get(dg).data.vertices)
        if i:
            frames.append(time.perf_counter() - t0)
    cage.data.attributes["position"].data.foreach_set("vector", cage_moved.astype(np.float32).ravel())
    cage.data.update()
    deformed = evaluated(model)
    model.modifiers.remove(mod)
    return bind, statistics.median(frames), deformed


def deformkit_cages(points, cage_rest, cage_faces, cage_moved, repeats):
    """(method, storage) -> (bind s, deform s, deformed points, note); a sparse row's note is its
    kept weights per point and its largest distance from the dense float64 result, relative to the
    rest cage's bounding-box diagonal."""
    rows = {}
    diagonal = float(np.linalg.norm(cage_rest.max(axis=0) - cage_rest.min(axis=0)))
    # Sparsified at two accuracies (docs/math/cage.md, "Sparsified bindings"): Mesh Deform's own
    # (its static bind keeps the harmonic weights above 1e-5, renormalised), and 1e-4, the largest
    # threshold keeping every vertex within 1e-3 of the cage's diagonal of the dense result on
    # Ogre, FireHydrant, Beast and WireSphere, for both coordinate kinds.
    storages = [("dense f64", {}), ("dense f32", {"precision": "float32"}),
                ("sparse 1e-5 (MD)", {"sparsify": 1e-5}), ("sparse 1e-4", {"sparsify": 1e-4})]
    for name in ("MeanValueCage", "GreenCage"):
        kind = getattr(dk, name, None)
        if kind is None:
            continue
        deformer = kind(cage_rest, cage_faces)
        dense = None
        for storage, options in storages:
            try:
                binding, bind = timed(lambda: deformer.bind(points, **options), 1)
            except TypeError:
                continue  # a storage this deformer does not offer
            deformer.cage_points = cage_moved
            deformed, deform = timed(lambda: deformer.deform_bound(binding), repeats)
            deformer.cage_points = cage_rest
            deformed = np.asarray(deformed, np.float64)
            dense = deformed if dense is None else dense
            note = ""
            if "sparsify" in options:
                kept = len(binding.weights()[2]) / len(points)
                error = np.linalg.norm(deformed - dense, axis=1).max() / diagonal
                note = f"{kept:.1f} of {deformer.columns} weights/pt, max |x - dense| {error:.1e} diag"
            rows[(name, storage)] = (bind, deform, deformed, note)
    return rows


print(f"deformkit {dk.build_info()}  |  bpy {bpy.app.version_string}  |  Mesh Deform precision {args.precision}")
print(f"{'model':18s}{'method':32s}{'bind s':>9s}{'frame ms':>10s}{'angle dist °':>14s}{'|x - MD| mean':>15s}"
      f"{'max':>10s}")
for name in args.models.split(","):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    model, points, faces = imported(CAGES / f"{name}.obj")
    cage, cage_rest, cage_faces = imported(CAGES / f"{name}_Cage.obj")
    _, cage_moved, moved_faces = imported(CAGES / f"{name}_Cage_Deformed.obj")
    # The files list the same faces in different orders; the vertices are in the same order.
    same = sorted(map(sorted, moved_faces)) == sorted(map(sorted, cage_faces))
    assert same and len(cage_moved) == len(cage_rest), f"{name}: cages differ in topology"
    tris = triangles_of(faces)
    bind, frame, md = mesh_deform(model, cage, cage_rest, cage_moved, args.repeats)
    label = f"{name} {len(points) // 1000}k/{len(cage_rest)}"
    print(f"{label:18s}{'Blender Mesh Deform':32s}{bind:9.3f}{frame * 1e3:10.2f}"
          f"{angle_distortion(points, md, tris):14.3f}{0.0:15.2e}{0.0:10.2e}")
    for (method, storage), (b, d, x, note) in deformkit_cages(points, cage_rest, cage_faces, cage_moved,
                                                               args.repeats).items():
        print(f"{'':18s}{method + ' ' + storage:32s}{b:9.3f}{d * 1e3:10.2f}"
              f"{angle_distortion(points, x, tris):14.3f}{np.linalg.norm(x - md, axis=1).mean():15.2e}"
              f"{np.linalg.norm(x - md, axis=1).max():10.2e}  {note}")

"""The 1M-vertex cage case: Ogre refined to 1.67M vertices, Mesh Deform vs dk.MeanValueCage / dk.GreenCage.

    .venv/bin/python benchmarks/bench_cage_large.py [--model Ogre] [--level 3] [--repeats R] [--precision P]
        [--storages float32,float64]

One bpy 5.0 process. The model of ../shared/cages is refined by deformkit's own subdivision
(dk.subdivide, Loop on the all-triangle Ogre: level 3 gives 1,673,794 vertices) and made into a
Blender mesh; its rest and deformed cages are the provided ones (a subdivision surface lies inside
its control mesh's hull, so the refined model keeps within the cage as the model does, up to a
little). Blender's Mesh Deform (Precision 5, the default): the Bind operator with the evaluation that
runs it, and its frame (cage positions set, depsgraph update, foreach_get of the evaluated
positions; median of R, deformed/rest alternating, after one warm-up). deformkit: bind once per
storage (dense float32 and float64 weights: n x columns x 4 or 8 bytes, printed; a storage whose
weights would take more than half the memory available now is skipped with a message) and
deform_bound into a preallocated array after setting the deformed cage (median of R).

Checked in the run (exit 1 otherwise): on 2,000 random model points, deform_bound equals
deformer.deform of the same points (the unbound path) within 1e-9 x model size, plus for float32
weights binding.float32_rounding_max x the largest control value (cage point, or Green's s n'); Mesh Deform's frame
moves the model. Also printed: how far each result lies from Mesh Deform's (mean and max). Skips with
a message when ../shared/cages is absent.
"""
import argparse
import statistics
import sys
import time

import numpy as np

from bench_common import OtherLoad, blender_mesh, cage_model, cpu_busy, mesh_deform_bind, set_positions, \
    shared_cages_or_exit

ap = argparse.ArgumentParser()
ap.add_argument("--model", default="Ogre")
ap.add_argument("--level", type=int, default=3)
ap.add_argument("--repeats", type=int, default=7)
ap.add_argument("--precision", type=int, default=5)
ap.add_argument("--storages", default="float32,float64")
args = ap.parse_args()
CAGES = shared_cages_or_exit("bench_cage_large")

busy = cpu_busy()
import bpy  # noqa: E402
import deformkit as dk  # noqa: E402

SAMPLE = 2000
BYTES = {"float32": 4, "float64": 8}


def available_bytes():
    with open("/proc/meminfo") as f:
        info = dict(line.split(":", 1) for line in f)
    return int(info["MemAvailable"].split()[0]) * 1024


def positions_of(obj, buf):
    dg = bpy.context.evaluated_depsgraph_get()
    dg.update()
    obj.evaluated_get(dg).data.attributes["position"].data.foreach_get("vector", buf)
    return buf


def mesh_deform(model, cage, rest, moved, points):
    """(bind s, frame s, deformed points) of Blender's Mesh Deform."""
    _, bind = mesh_deform_bind(model, cage, args.precision)
    buf, frames = np.empty(len(points) * 3, np.float32), []
    deformed = None
    for i in range(args.repeats + 1):
        target = moved if i % 2 == 0 else rest
        t0 = time.perf_counter()
        set_positions(cage.data, target)
        positions_of(model, buf)
        if i:
            frames.append(time.perf_counter() - t0)
        if target is moved:
            deformed = buf.reshape(-1, 3).astype(np.float64)
    return bind, statistics.median(frames), deformed


def control_value_max(deformer, moved):
    """The largest |coordinate| of the values deform_bound multiplies the weights with: the cage's
    points and, for Green coordinates, each triangle's normal times Lipman's stretch factor s
    (Lipman, Levin, Cohen-Or 2008, Section 3.1: s = sqrt(|u'|^2 |v|^2 - 2 (u'.v')(u.v) + |v'|^2 |u|^2)
    / (sqrt(8) area), u, v two edges of the rest triangle, u', v' of the deformed one)."""
    largest = float(np.abs(moved).max())
    if not hasattr(deformer, "stretch"):  # mean value coordinates: the cage points only
        return largest
    t = np.asarray(deformer.triangles)
    rest = np.asarray(deformer.rest_cage_points)
    u, v = rest[t[:, 1]] - rest[t[:, 0]], rest[t[:, 2]] - rest[t[:, 0]]
    u2, v2 = moved[t[:, 1]] - moved[t[:, 0]], moved[t[:, 2]] - moved[t[:, 0]]
    area = 0.5 * np.linalg.norm(np.cross(u, v), axis=1)
    dot = lambda a, b: (a * b).sum(1)  # noqa: E731
    s = np.sqrt(dot(u2, u2) * dot(v, v) - 2 * dot(u2, v2) * dot(u, v) + dot(v2, v2) * dot(u, u)) / (np.sqrt(8) * area)
    stretch = s if deformer.stretch else np.ones_like(s)
    return max(largest, float(stretch.max()))  # |n'| = 1: no coordinate of s n' exceeds s


def deformkit_rows(name, deformer, points, moved, sample, size):
    """storage -> (bind s, deform s, weight bytes, deformed points, |bound - unbound| max, allowed)."""
    rows = {}
    largest = control_value_max(deformer, moved)
    for storage in args.storages.split(","):
        weight_bytes = len(points) * deformer.columns * BYTES[storage]
        if 2 * weight_bytes > available_bytes():
            print(f"  {name} {storage}: skipped, its weights would take {weight_bytes / 2**30:.2f} GiB of the "
                  f"{available_bytes() / 2**30:.2f} GiB available")
            continue
        deformer.cage_points = deformer.rest_cage_points
        t0 = time.perf_counter()
        binding = deformer.bind(points, precision=storage)
        bind = time.perf_counter() - t0
        deformer.cage_points = moved
        out = np.empty_like(points)
        times = []
        for i in range(args.repeats + 1):
            t0 = time.perf_counter()
            deformer.deform_bound(binding, out=out)
            if i:
                times.append(time.perf_counter() - t0)
        unbound = deformer.deform(points[sample])
        error = float(np.abs(out[sample] - unbound).max())
        # float32: each point's weights moved by at most float32_rounding_max in L1 norm, so each
        # coordinate by at most that times the largest control value.
        allowed = 1e-9 * size + (0.0 if storage == "float64" else binding.float32_rounding_max * largest)
        rows[storage] = (bind, statistics.median(times), weight_bytes, out, error, allowed)
        del binding
    deformer.cage_points = deformer.rest_cage_points
    return rows


bpy.ops.wm.read_factory_settings(use_empty=True)
m = cage_model(CAGES, args.model)
t0 = time.perf_counter()
refined = dk.subdivide(m.points, m.faces, args.level)
subdivide = time.perf_counter() - t0
points = np.asarray(refined.points, np.float64)
triangles = np.asarray(refined.faces)
if triangles.ndim != 2 or triangles.shape[1] != 3:
    raise SystemExit(f"{args.model}: level {args.level} is not all triangles ({refined.scheme}); pick a triangle model")
model = blender_mesh(f"{args.model} level {args.level}", points, triangles)
points = np.empty(len(points) * 3, np.float32)
model.data.attributes["position"].data.foreach_get("vector", points)
points = points.reshape(-1, 3).astype(np.float64)  # the mesh's float32 values, as Mesh Deform sees them
bpy.data.objects.remove(m.model)
size = float(np.ptp(points, axis=0).max())
sample = np.random.default_rng(0).choice(len(points), SAMPLE, replace=False)

print(f"deformkit {dk.build_info()}  |  bpy {bpy.app.version_string}  |  Mesh Deform precision {args.precision}"
      f"  |  CPUs busy before the run {busy:.0%}  |  memory available {available_bytes() / 2**30:.1f} GiB")
print(f"{args.model} refined by dk.subdivide ({refined.scheme}, level {args.level}) in {subdivide:.2f} s: "
      f"{len(points):,} vertices, {len(triangles):,} triangles; cage {len(m.rest)} vertices, {len(m.cage_faces)} faces"
      + ("" if len(points) >= 1_000_000 else "  ** fewer than 1M vertices: raise --level **"))
print(f"frame / deform: median of {args.repeats} after 1 warm-up")
print(f"{'method':30s}{'bind s':>9s}{'frame ms':>10s}{'weights GiB':>13s}{'|x - MD| mean':>15s}{'max':>10s}"
      f"{'bound vs unbound':>18s}")
failed = []
with OtherLoad() as load:
    bind, frame, md = mesh_deform(model, m.cage, m.rest, m.moved, points)
    if float(np.abs(md - points).max()) < 1e-3 * size:
        failed.append("Mesh Deform's frame did not move the model")
    print(f"{'Blender Mesh Deform':30s}{bind:9.3f}{frame * 1e3:10.2f}{'':13s}{0.0:15.2e}{0.0:10.2e}")
    for cls in ("MeanValueCage", "GreenCage"):
        deformer = getattr(dk, cls)(m.rest, m.cage_faces)
        for storage, (b, d, nbytes, x, error, allowed) in deformkit_rows(cls, deformer, points, m.moved,
                                                                          sample, size).items():
            distance = np.linalg.norm(x - md, axis=1)
            print(f"{cls + ' dense ' + storage:30s}{b:9.3f}{d * 1e3:10.2f}{nbytes / 2**30:13.2f}"
                  f"{distance.mean():15.2e}{distance.max():10.2e}{error:11.1e} <= {allowed:.0e}")
            if not error <= allowed:
                failed.append(f"{cls} {storage}: deform_bound differs from deform by {error:.2e} (allowed {allowed:.1e})")
            del x
print(load.report())
if failed:
    print("FAILED: " + "; ".join(failed))
    sys.exit(1)

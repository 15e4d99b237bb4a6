"""dk.MeshDeform against Blender's Mesh Deform modifier: bind time and peak memory, and the frame.

    .venv/bin/python benchmarks/bench_mesh_deform.py [--model Ogre] [--precisions 5,6,7]
        [--deformkit-only 8] [--repeats 9]

One bpy 5.0 process. The model of ../shared/cages and its cage are imported (Blender's OBJ
importer, axes kept); for each precision Blender's modifier is added and bound by its Bind operator
(the operator and the evaluation that runs the bind: mesh_deform_bind), and dk.MeshDeform binds the
same float32 points to the same cage (constructor and bind: the grid, its solve and the points'
coordinates). Peak memory: the growth of the process's resident set over each bind (PeakMemory:
the kernel's high-water mark, reset before each). The precisions of --deformkit-only are bound by
deformkit only (Blender's would take minutes and gigabytes).

The frame, at each precision both bound: the cage set to its `_Cage_Deformed` pose or back to
rest, alternately; Blender: foreach_set of the cage's positions, depsgraph update, foreach_get of
the evaluated model (the modifier evaluates in that update); deformkit: cage_points set, then
deform_bound of the binding. Medians of the steps to the deformed pose. Checked in the run (exit 1
otherwise): at the deformed pose both agree within 1e-4 of the cage's bounding-box diagonal.

Precision: each precision's positions at the deformed pose (deformkit's, static bind) against the
next precision's, over the cage's diagonal (largest and mean over the vertices), so users can see
what a higher precision changes. Skips with a message when ../shared/cages is absent.
"""
import argparse
import statistics
import sys
import time

import numpy as np

from bench_common import OtherLoad, PeakMemory, cage_model, evaluated, mesh_deform_bind, set_positions, \
    shared_cages_or_exit

ap = argparse.ArgumentParser()
ap.add_argument("--model", default="Ogre")
ap.add_argument("--precisions", default="5,6,7")
ap.add_argument("--deformkit-only", default="8")
ap.add_argument("--repeats", type=int, default=9)
args = ap.parse_args()
CAGES = shared_cages_or_exit("bench_mesh_deform")

import bpy  # noqa: E402

import deformkit as dk  # noqa: E402

bpy.ops.wm.read_factory_settings(use_empty=True)
m = cage_model(CAGES, args.model)
diagonal = float(np.linalg.norm(m.rest.max(0) - m.rest.min(0)))
print(f"{args.model}: {len(m.points)} vertices, cage of {len(m.rest)} vertices; bpy {bpy.app.version_string}, "
      f"deformkit {dk.__version__ if hasattr(dk, '__version__') else ''}")


def deformkit_bind(precision):
    with PeakMemory() as mem:
        t0 = time.perf_counter()
        md = dk.MeshDeform(m.rest, m.cage_faces, precision=precision)
        binding = md.bind(m.points)
        seconds = time.perf_counter() - t0
    return md, binding, seconds, mem.growth


def frames(modifier, md, binding):
    steps = {"blender": [], "deformkit": []}
    worst = 0.0
    for step in range(2 * args.repeats + 1):
        pose = m.moved if step % 2 == 0 else m.rest
        t0 = time.perf_counter()
        set_positions(m.cage.data, pose)
        bpy.context.evaluated_depsgraph_get().update()
        expected = evaluated(m.model)
        t1 = time.perf_counter()
        md.cage_points = np.asarray(pose, np.float32).astype(np.float64)
        got = md.deform_bound(binding)
        t2 = time.perf_counter()
        if step % 2 == 0:
            worst = max(worst, float(np.linalg.norm(got - expected, axis=1).max()) / diagonal)
            if step > 0:  # the first is the warm-up
                steps["blender"].append(t1 - t0)
                steps["deformkit"].append(t2 - t1)
    set_positions(m.cage.data, m.rest)
    return statistics.median(steps["blender"]), statistics.median(steps["deformkit"]), worst


rows, failed, posed = [], False, {}


def deformed_positions(md, binding):
    md.cage_points = np.asarray(m.moved, np.float32).astype(np.float64)
    out = md.deform_bound(binding)
    md.cage_points = md.rest_cage_points
    return out



for precision in [int(p) for p in args.precisions.split(",") if p]:
    with OtherLoad() as load:
        with PeakMemory() as mem:
            modifier, blender_seconds = mesh_deform_bind(m.model, m.cage, precision)
        blender_memory = mem.growth
        md, binding, dk_seconds, dk_memory = deformkit_bind(precision)
        blender_frame, dk_frame, worst = frames(modifier, md, binding)
    failed |= worst > 1e-4
    rows.append((precision, blender_seconds, dk_seconds, blender_memory, dk_memory, blender_frame, dk_frame, worst,
                 md.unknowns))
    print(f"precision {precision}: Blender bind {blender_seconds:.2f} s ({blender_memory / 2**20:.0f} MB), "
          f"deformkit {dk_seconds:.2f} s ({dk_memory / 2**20:.0f} MB), {blender_seconds / dk_seconds:.1f}x; "
          f"frame {blender_frame * 1e3:.2f} ms vs {dk_frame * 1e3:.2f} ms; largest difference {worst:.1e} "
          f"of the diagonal\n{load.report()}")
    m.model.modifiers.remove(modifier)
    posed[precision] = deformed_positions(md, binding)
    del md, binding
for precision in [int(p) for p in args.deformkit_only.split(",") if p]:
    with OtherLoad() as load:
        md, binding, dk_seconds, dk_memory = deformkit_bind(precision)
    rows.append((precision, None, dk_seconds, None, dk_memory, None, None, None, md.unknowns))
    print(f"precision {precision}: deformkit {dk_seconds:.2f} s ({dk_memory / 2**20:.0f} MB), "
          f"{md.unknowns} unknowns\n{load.report()}")
    posed[precision] = deformed_positions(md, binding)
    del md, binding

print("\n| precision | unknowns | Blender bind | deformkit bind | speed-up | Blender peak memory | deformkit peak memory "
      "| Blender frame | deformkit frame |")
print("|---|---|---|---|---|---|---|---|---|")
for p, bs, ds, bm, dm, bf, df, worst, unknowns in rows:
    fmt = lambda v, f: "-" if v is None else f(v)  # noqa: E731
    print(f"| {p} | {unknowns} | {fmt(bs, lambda v: f'{v:.2f} s')} | {ds:.2f} s | {fmt(bs, lambda v: f'{v / ds:.1f}x')} "
          f"| {fmt(bm, lambda v: f'{v / 2**20:.0f} MB')} | {dm / 2**20:.0f} MB | {fmt(bf, lambda v: f'{v * 1e3:.2f} ms')} "
          f"| {fmt(df, lambda v: f'{v * 1e3:.2f} ms')} |")
levels = sorted(posed)
if len(levels) > 1:
    print("\n| precisions | largest difference | mean difference |  (over the cage's diagonal, at the deformed pose)")
    print("|---|---|---|")
    for a, b in zip(levels, levels[1:]):
        d = np.linalg.norm(posed[a] - posed[b], axis=1) / diagonal
        print(f"| {a} / {b} | {d.max():.2e} | {d.mean():.2e} |")
if failed:
    print("deformkit and Blender disagree by more than 1e-4 of the diagonal")
    sys.exit(1)

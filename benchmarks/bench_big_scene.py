"""What the add-on adds to every depsgraph update of a large scene: one object moved, among N.

    .venv/bin/python benchmarks/bench_big_scene.py [--objects N] [--repeats R] [--addon DIR]

One bpy process, a scene of N objects (half of them meshes sharing one small mesh, half empties)
and one mesh with a Lattice entry on its lattice. A step moves one of the empties (its location
set, then the depsgraph update): the add-on's handler runs on every such update. Timed with the
add-on's handlers registered and with them removed, alternating, medians of R; then a step of the
lattice (its points moved), which the entry follows, to show it still does.
"""
import argparse
import pathlib
import statistics
import time

import numpy as np

from bench_common import OtherLoad, blender_with_addon, cpu_busy

ap = argparse.ArgumentParser()
ap.add_argument("--objects", type=int, default=1000)
ap.add_argument("--repeats", type=int, default=101)
ap.add_argument("--addon", default=str(pathlib.Path(__file__).resolve().parents[1] / "python_addon"))
args = ap.parse_args()

busy = cpu_busy()
blender_with_addon(args.addon)
import bpy  # noqa: E402
from deformkit_addon import api, handlers  # noqa: E402

shared = bpy.data.meshes.new("shared")
shared.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
for i in range(args.objects):
    bpy.context.scene.collection.objects.link(bpy.data.objects.new(f"o{i}", shared if i % 2 else None))
bpy.ops.mesh.primitive_uv_sphere_add()
sphere = bpy.context.active_object
lattice = bpy.data.objects.new("lattice", bpy.data.lattices.new("lattice"))
bpy.context.scene.collection.objects.link(lattice)
lattice.scale = (3, 3, 3)
api.add_entry(sphere, "LATTICE", lattice=lattice)
bpy.context.view_layer.update()
moved = bpy.data.objects["o0"]
ours = [(lst, fn) for lst, fn in handlers.HANDLERS if fn in lst]


def step():
    t0 = time.perf_counter()
    moved.location.x += 1e-3
    bpy.context.view_layer.update()
    return time.perf_counter() - t0


runs = {"with the add-on": [], "without its handlers": []}
with OtherLoad() as load:
    for i in range(args.repeats + 3):
        for side in runs:
            for lst, fn in ours:
                if side == "with the add-on" and fn not in lst:
                    lst.append(fn)
                elif side != "with the add-on" and fn in lst:
                    lst.remove(fn)
            t = step()
            if i >= 3:
                runs[side].append(t)
    for lst, fn in ours:
        if fn not in lst:
            lst.append(fn)
    before = np.array([v.co[:] for v in sphere.evaluated_get(bpy.context.evaluated_depsgraph_get()).data.vertices])
    lattice.data.points[0].co_deform.x += 0.3
    lattice.data.update_tag()
    bpy.context.view_layer.update()
    after = np.array([v.co[:] for v in sphere.evaluated_get(bpy.context.evaluated_depsgraph_get()).data.vertices])
print(f"bpy {bpy.app.version_string}, {args.objects} objects and one stack, {args.repeats} steps each, "
      f"CPU busy before {busy:.0%}")
for side, ts in runs.items():
    print(f"{side:24s} median {statistics.median(ts) * 1e3:.3f} ms")
extra = statistics.median(runs["with the add-on"]) - statistics.median(runs["without its handlers"])
print(f"the add-on's part of an update: {extra * 1e3:.3f} ms; the entry still follows its lattice: "
      f"{bool(np.abs(after - before).max() > 1e-6)}")
print(load.report())

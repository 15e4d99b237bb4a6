"""An Edit Mode drag: a deformkit Twist entry vs Blender's Simple Deform, both shown in Edit Mode.

    .venv/bin/python benchmarks/bench_blender_edit.py [--vertices N] [--repeats R] [--addon DIR]

One Blender (bpy) process, two identical displaced grids in Edit Mode together: A with a deformkit
Twist entry (Z axis), B with a Simple Deform modifier (TWIST, Z). Each step moves the same upper
vertices of both by a little (what a mouse move during G does: bmesh edit + update_edit_mesh),
alternating which goes first; time = the edit's update_edit_mesh + depsgraph update (for A: the
add-on's handler reads the edit mesh, deforms and writes its result, and the depsgraph evaluates
both Geometry Nodes passes) + evaluated vertex count. The bmesh moves themselves are not timed.
"""
import argparse
import pathlib
import statistics
import time

import numpy as np

from bench_common import blender_with_addon, displaced_grid_pair

ap = argparse.ArgumentParser()
ap.add_argument("--vertices", type=int, default=100_000)
ap.add_argument("--repeats", type=int, default=15)
ap.add_argument("--warmup", type=int, default=3)
ap.add_argument("--addon", default=str(pathlib.Path(__file__).resolve().parents[1] / "python_addon"))
args = ap.parse_args()

blender_with_addon(args.addon)
import bpy  # noqa: E402
import bmesh  # noqa: E402  (after bpy, which provides it)
from deformkit_addon import api, meshdata, native  # noqa: E402
A, B, co = displaced_grid_pair(args.vertices)
mod = B.modifiers.new("SimpleDeform", "SIMPLE_DEFORM")
mod.deform_method, mod.deform_axis, mod.angle = "TWIST", "Z", 0.5
mod.show_in_editmode = True
api.add_entry(A, "TWIST", angle=0.5, deform_axis="Z")
for o in (A, B):
    o.select_set(True)
bpy.context.view_layer.objects.active = A
bpy.ops.object.mode_set(mode="EDIT")  # both, as multi-object editing does
meshes = {o.name: bmesh.from_edit_mesh(o.data) for o in (A, B)}
moved = {name: [v for v in bm.verts if v.co.y > 0.5] for name, bm in meshes.items()}
nverts = len(co)


def step(obj, dx):
    for v in moved[obj.name]:
        v.co.x += dx
    t0 = time.perf_counter()
    bmesh.update_edit_mesh(obj.data)
    dg = bpy.context.evaluated_depsgraph_get()
    dg.update()
    assert len(obj.evaluated_get(dg).data.vertices) == nverts
    return time.perf_counter() - t0


runs = {"deformkit": [], "blender": []}
for i in range(args.warmup + args.repeats):
    for side in (("deformkit", "blender") if i % 2 == 0 else ("blender", "deformkit")):
        t = step(A if side == "deformkit" else B, 0.002)
        if i >= args.warmup:
            runs[side].append(t)


def edited_result(obj):
    dg = bpy.context.evaluated_depsgraph_get()
    mesh = obj.evaluated_get(dg).to_mesh()
    try:
        return meshdata.base_positions(mesh).copy()
    finally:
        obj.evaluated_get(dg).to_mesh_clear()


diff = float(np.abs(edited_result(A) - edited_result(B)).max())
assert diff < 1e-4 * 2.0, diff  # both show the same deformed edit
print(f"deformkit {native.dk.build_info()}  |  bpy {bpy.app.version_string}")
print(f"Edit Mode drag, {nverts:,} vertices ({len(moved['deformkit']):,} moved per step), {args.repeats} steps "
      f"per side after {args.warmup} warm-up; |A - B| {diff:.1e} after the drag")
def p10(ts):  # the 10th percentile: steps the other programs on the machine did not delay
    return statistics.quantiles(ts, n=10)[0]


print(f"{'':40s}{'median ms':>11s}{'p10 ms':>10s}{'min ms':>10s}")
for side in runs:
    print(f"{side + ' (update_edit_mesh + depsgraph)':40s}{1e3 * statistics.median(runs[side]):11.2f}"
          f"{1e3 * p10(runs[side]):10.2f}{1e3 * min(runs[side]):10.2f}")
ratio = statistics.median(runs["deformkit"]) / statistics.median(runs["blender"])
print(f"ratio deformkit / Blender: median {ratio:.2f}, p10 {p10(runs['deformkit']) / p10(runs['blender']):.2f}")

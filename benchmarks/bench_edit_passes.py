"""Where an Edit Mode step's time goes: one edit, then the depsgraph update, on objects in Edit
Mode together that differ only in their modifiers.

    .venv/bin/python benchmarks/bench_edit_passes.py [--vertices N] [--repeats R]

"deformkit": a Twist entry (the Geometry Nodes modifier evaluated for the edit, the add-on's
handler, and the modifier again on the written result); "deformkit, no handler": the same with the
add-on's depsgraph handler removed for that step (one pass of its modifier, the result not
updated); "Simple Deform"; "no modifier"; "GN pass-through" (a Geometry Nodes modifier whose
group links its input to its output: the cost of any Geometry Nodes modifier in Edit Mode, which
converts the edit mesh). Steps alternate between the objects; median and 10th percentile.
"""
import argparse
import statistics
import time

from bench_common import blender_with_addon, displaced_grid_pair

ap = argparse.ArgumentParser()
ap.add_argument("--vertices", type=int, default=8000)
ap.add_argument("--repeats", type=int, default=201)
args = ap.parse_args()
blender_with_addon(str(__import__("pathlib").Path(__file__).resolve().parents[1] / "python_addon"))
import bpy  # noqa: E402
import bmesh  # noqa: E402
from deformkit_addon import api, handlers  # noqa: E402

dk_obj, simple, co = displaced_grid_pair(args.vertices)
mod = simple.modifiers.new("SimpleDeform", "SIMPLE_DEFORM")
mod.deform_method, mod.deform_axis, mod.angle, mod.show_in_editmode = "TWIST", "Z", 0.5, True
api.add_entry(dk_obj, "TWIST", angle=0.5, deform_axis="Z")


def copy(name):
    obj = simple.copy()
    obj.data = simple.data.copy()
    obj.modifiers.clear()
    obj.name = name
    bpy.context.scene.collection.objects.link(obj)
    return obj


plain, passing = copy("plain"), copy("pass_through")
group = bpy.data.node_groups.new("pass", "GeometryNodeTree")
group.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
group.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
group.links.new(group.nodes.new("NodeGroupInput").outputs[0], group.nodes.new("NodeGroupOutput").inputs[0])
gn = passing.modifiers.new("GN", "NODES")
gn.node_group, gn.show_in_editmode = group, True
objects = (dk_obj, simple, plain, passing)
for obj in objects:
    obj.select_set(True)
bpy.context.view_layer.objects.active = dk_obj
bpy.ops.object.mode_set(mode="EDIT")
edit_meshes = {o.name: bmesh.from_edit_mesh(o.data) for o in objects}  # kept: their vertices stay valid
moved = {name: [v for v in bm.verts if v.co.y > 0.5] for name, bm in edit_meshes.items()}


def step(obj):
    for v in moved[obj.name]:
        v.co.x += 0.001
    t0 = time.perf_counter()
    bmesh.update_edit_mesh(obj.data)
    bpy.context.evaluated_depsgraph_get().update()
    return time.perf_counter() - t0


runs = {k: [] for k in ("deformkit", "deformkit, no handler", "Simple Deform", "no modifier", "GN pass-through")}
for i in range(args.repeats + 10):
    times = {"deformkit": step(dk_obj), "Simple Deform": step(simple), "no modifier": step(plain),
             "GN pass-through": step(passing)}
    bpy.app.handlers.depsgraph_update_post.remove(handlers.on_depsgraph_update)
    times["deformkit, no handler"] = step(dk_obj)
    bpy.app.handlers.depsgraph_update_post.append(handlers.on_depsgraph_update)
    if i >= 10:
        for k, t in times.items():
            runs[k].append(t)
print(f"bpy {bpy.app.version_string}, {len(co):,} vertices, {args.repeats} steps each")
print(f"{'':24s}{'median ms':>10s}{'p10 ms':>9s}")
for k, ts in runs.items():
    print(f"{k:24s}{statistics.median(ts) * 1e3:10.2f}{statistics.quantiles(ts, n=10)[0] * 1e3:9.2f}")

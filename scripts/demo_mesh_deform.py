"""Blender's Mesh Deform beside deformkit's Cage entry with the Harmonic (Mesh Deform) method,
headlessly in bpy: Suzanne, subdivided once, inside a box cage whose top is turned and pulled;
both bound at the same precision, then the cage edited.

    .venv/bin/python scripts/demo_mesh_deform.py --out demo_out/mesh_deform [--precision 5]

Writes <out>/mesh_deform.png (rest, Mesh Deform, the Cage entry, side by side) and prints each
bind's time (the operator and the evaluation that shows its result) and the largest difference
between the two results over the cage's bounding-box diagonal.
"""
import argparse
import pathlib
import time

import numpy as np
from demo_laplacian import import_addon  # the add-on from this checkout, registered


def suzanne(bpy, name):
    bpy.ops.mesh.primitive_monkey_add()
    obj = bpy.context.active_object
    obj.name = name
    mod = obj.modifiers.new("Subdivision", "SUBSURF")
    mod.levels = 1
    with bpy.context.temp_override(object=obj, active_object=obj):
        bpy.ops.object.modifier_apply(modifier=mod.name)
    return obj


def box_cage(bpy, name, model):
    """A closed box of 3 x 3 quads a side around the model, 15% larger than its bounds."""
    bpy.ops.mesh.primitive_cube_add()
    cage = bpy.context.active_object
    cage.name = name
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.subdivide(number_cuts=2)
    bpy.ops.object.mode_set(mode="OBJECT")
    co = local_points(model)
    lo, hi = co.min(axis=0), co.max(axis=0)
    mid, half = (lo + hi) / 2, (hi - lo) / 2 * 1.15
    box = np.array([v.co[:] for v in cage.data.vertices])
    cage.data.vertices.foreach_set("co", (mid + box * half).astype(np.float32).ravel())
    cage.data.update()
    cage.display_type = "WIRE"
    return cage


def local_points(obj):
    return np.array([v.co[:] for v in obj.data.vertices])


def edit_cage(cage):
    """The top third turned 35 degrees about the vertical and pulled up and to the side."""
    co = local_points(cage)
    z0, z1 = co[:, 2].min(), co[:, 2].max()
    t = np.clip((co[:, 2] - z0) / (z1 - z0) * 1.5 - 0.5, 0.0, 1.0)
    angle = np.radians(35.0) * t
    x, y = co[:, 0], co[:, 1]
    moved = np.stack([x * np.cos(angle) - y * np.sin(angle) + 0.35 * t,
                      x * np.sin(angle) + y * np.cos(angle), co[:, 2] + 0.25 * t], axis=1)
    cage.data.vertices.foreach_set("co", moved.astype(np.float32).ravel())
    cage.data.update()
    return moved


def evaluated(bpy, obj):
    mesh = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    co = np.empty(3 * len(mesh.vertices))
    mesh.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def timed(bpy, bind):
    t0 = time.perf_counter()
    bind()
    bpy.context.evaluated_depsgraph_get().update()  # Mesh Deform binds in this evaluation
    return time.perf_counter() - t0


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="demo_out/mesh_deform")
    parser.add_argument("--precision", type=int, default=5)
    args = parser.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    import bpy
    from deformkit.preview import render_panels
    bpy.ops.wm.read_factory_settings(use_empty=True)
    api = import_addon().api
    blender, ours = suzanne(bpy, "Mesh Deform"), suzanne(bpy, "deformkit Harmonic")
    rest = local_points(blender)
    blender_cage, our_cage = box_cage(bpy, "Mesh Deform cage", blender), box_cage(bpy, "deformkit cage", ours)

    mod = blender.modifiers.new("MeshDeform", "MESH_DEFORM")
    mod.object, mod.precision = blender_cage, args.precision
    bpy.context.view_layer.objects.active = blender

    def bind_blender():
        with bpy.context.temp_override(object=blender, active_object=blender):
            bpy.ops.object.meshdeform_bind(modifier=mod.name)
    seconds = {"Mesh Deform": timed(bpy, bind_blender)}
    api.add_entry(ours, "CAGE", cage=our_cage, cage_method="HARMONIC", precision=args.precision)
    seconds["deformkit"] = timed(bpy, lambda: api.bind_cage(ours, 0))

    moved = [edit_cage(c) for c in (blender_cage, our_cage)][0]
    results = {"Mesh Deform": evaluated(bpy, blender), "deformkit Harmonic": evaluated(bpy, ours)}
    diagonal = float(np.linalg.norm(np.ptp(moved, axis=0)))
    gap = float(np.abs(results["Mesh Deform"] - results["deformkit Harmonic"]).max()) / diagonal
    print(f"precision {args.precision}: bind Mesh Deform {seconds['Mesh Deform']:.3f} s, deformkit "
          f"{seconds['deformkit']:.3f} s; |difference| / cage diagonal {gap:.1e}")
    faces = np.array([p.vertices[:] for p in blender.data.polygons])
    triangles = np.vstack([faces[:, [0, 1, 2]], faces[:, [0, 2, 3]]])
    path = out / "mesh_deform.png"
    render_panels(path, [rest, results["Mesh Deform"], results["deformkit Harmonic"]], triangles,
                  f"Mesh Deform and deformkit's Harmonic cage, precision {args.precision} "
                  f"(largest difference {gap:.1e} of the cage's diagonal)",
                  ["rest", f"Blender's Mesh Deform\nbind {seconds['Mesh Deform']:.2f} s",
                   f"deformkit Cage entry, Harmonic\nbind {seconds['deformkit']:.2f} s"],
                  elev=10.0, azim=-70.0, to_plot=np.eye(3))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()

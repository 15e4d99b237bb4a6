"""A plain tube bent 90 degrees by an empty, headlessly in bpy: a new deformkit Laplacian entry
beside Blender's Laplacian Deform with a Hook, and an ARAP entry of 10 iterations (the default
before issue 31), which kinks near the anchor and handle rings.

    .venv/bin/python scripts/demo_laplacian.py --out demo_out/laplacian_vs_blender

Writes <out>/tube_bend.png (rest and the three, side by side) and prints, per result, the largest
change of the tube axis's turn from one ring to the next over its mean turn (0 for a smooth bend;
a kink makes it jump) and the narrowest ring over the rest radius (a pinch makes it small).
"""
import argparse
import math
import pathlib
import sys
import tempfile

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
SEGMENTS, RINGS, LENGTH, RADIUS, DEGREES = 24, 41, 4.0, 0.5, 90.0


def import_addon():
    """The add-on from this checkout, under the package name users get (deformkit_addon)."""
    addons = pathlib.Path(tempfile.mkdtemp(prefix="deformkit_demo_"))
    (addons / "deformkit_addon").symlink_to(ROOT / "python_addon", target_is_directory=True)
    sys.path.insert(0, str(addons))
    import deformkit_addon
    deformkit_addon.register()
    return deformkit_addon


def tube(bpy, name, x):
    z = np.linspace(0.0, LENGTH, RINGS)
    theta = 2 * np.pi * np.arange(SEGMENTS) / SEGMENTS
    co = np.stack([RADIUS * np.cos(theta)[None].repeat(RINGS, 0), RADIUS * np.sin(theta)[None].repeat(RINGS, 0),
                   z[:, None].repeat(SEGMENTS, 1)], -1).reshape(-1, 3)
    ring = np.arange(RINGS * SEGMENTS).reshape(RINGS, SEGMENTS)
    faces = [tuple(int(i) for i in f) for r in range(RINGS - 1)
             for f in zip(ring[r], np.roll(ring[r], -1), np.roll(ring[r + 1], -1), ring[r + 1])]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(co.tolist(), [], faces)
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    obj.location = (x, 0.0, 0.0)
    for group, rows in (("Bottom", ring[:2]), ("Top", ring[-2:]), ("Ends", np.vstack([ring[:2], ring[-2:]]))):
        obj.vertex_groups.new(name=group).add(rows.ravel().tolist(), 1.0, "REPLACE")
    empty = bpy.data.objects.new(name + " Handle", None)
    bpy.context.scene.collection.objects.link(empty)
    empty.location = (x, 0.0, LENGTH)
    bpy.context.view_layer.update()
    return obj, empty, np.array(faces)


def bend(bpy, obj, empty):
    """The empty where the top is when the axis bends into a circular arc of its length."""
    a = math.radians(DEGREES)
    radius = LENGTH / a
    empty.location = np.array(obj.location) + (0.0, radius * (math.cos(a) - 1.0), radius * math.sin(a))
    empty.rotation_euler = (a, 0.0, 0.0)
    bpy.context.view_layer.update()


def laplacian_deform_with_hook(bpy, obj, empty):
    hook = obj.modifiers.new("Hook", "HOOK")
    hook.object, hook.vertex_group = empty, "Top"
    hook.matrix_inverse = (obj.matrix_world.inverted() @ empty.matrix_world).inverted()
    deform = obj.modifiers.new("LaplacianDeform", "LAPLACIANDEFORM")
    deform.vertex_group = "Ends"
    bpy.context.view_layer.objects.active = obj
    with bpy.context.temp_override(object=obj, active_object=obj):
        bpy.ops.object.laplaciandeform_bind(modifier=deform.name)


def local_positions(bpy, obj):
    mesh = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    co = np.empty(3 * len(mesh.vertices))
    mesh.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def curvature_jump(points):
    centres = points.reshape(RINGS, SEGMENTS, 3).mean(1)
    axis = np.diff(centres, axis=0)
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    turns = np.arccos(np.clip((axis[1:] * axis[:-1]).sum(1), -1.0, 1.0))
    return float(np.abs(np.diff(turns)).max() / turns.mean())


def narrowest(points):
    rings = points.reshape(RINGS, SEGMENTS, 3)
    return float(np.linalg.norm(rings - rings.mean(1)[:, None], axis=2).mean(1).min() / RADIUS)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="demo_out/laplacian_vs_blender")
    out = pathlib.Path(parser.parse_args().out)
    out.mkdir(parents=True, exist_ok=True)
    import bpy
    from deformkit.preview import render_panels
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon = import_addon()
    api = addon.api
    results = {}
    for label, method in (("deformkit, a new entry", None), ("Laplacian Deform + Hook", "BLENDER"),
                          ("ARAP, 10 iterations", "ARAP")):
        obj, empty, faces = tube(bpy, label, 0.0)
        if method == "BLENDER":
            laplacian_deform_with_hook(bpy, obj, empty)
        else:
            settings = {} if method is None else {"method": method, "iterations": 10}
            entry = api.add_laplacian(obj, anchors_group="Bottom", handles_group="Top", handle_target="OBJECT",
                                      handle_object=empty, **settings)
            label = f"{label} ({entry.method.replace('_', ' ').title()})" if method is None else label
        bend(bpy, obj, empty)
        results[label] = local_positions(bpy, obj)
    rest = np.array([v.co for v in bpy.data.objects["ARAP, 10 iterations"].data.vertices])  # the base mesh
    for label, points in results.items():
        print(f"{label}: curvature jump {curvature_jump(points):.3f}, narrowest ring {narrowest(points):.3f}")
    triangles = np.vstack([faces[:, [0, 1, 2]], faces[:, [0, 2, 3]]])
    path = out / "tube_bend.png"
    render_panels(path, [rest] + list(results.values()), triangles,
                  f"A plain tube bent {DEGREES:.0f} degrees by an empty (curvature jump: 0 is smooth)",
                  ["rest"] + [f"{label}\njump {curvature_jump(p):.2f}" for label, p in results.items()],
                  elev=5.0, azim=0.0, to_plot=np.eye(3))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()

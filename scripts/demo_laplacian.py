"""A plain tube bent 90 degrees by an empty, headlessly in bpy: a new deformkit Laplacian entry
beside Blender's Laplacian Deform with a Hook, and an ARAP entry of 10 iterations (the default
before issue 31), which kinks near the anchor and handle rings.

    .venv/bin/python scripts/demo_laplacian.py --out demo_out/laplacian_vs_blender

Writes <out>/tube_bend.png (rest and the three, side by side) and prints, per result, the largest
change of the tube axis's turn from one ring to the next over its mean turn (0 for a smooth bend;
a kink makes it jump) and the narrowest ring over the rest radius (a pinch makes it small).
"""
import argparse
import pathlib
import sys
import tempfile

import numpy as np
from tube_bend import add_empty, bend, curvature_jump, laplacian_deform_with_hook, narrowest, plain_tube

ROOT = pathlib.Path(__file__).resolve().parent.parent
DEGREES = 90.0


def import_addon():
    """The add-on from this checkout, under the package name users get (deformkit_addon)."""
    addons = pathlib.Path(tempfile.mkdtemp(prefix="deformkit_demo_"))
    (addons / "deformkit_addon").symlink_to(ROOT / "python_addon", target_is_directory=True)
    sys.path.insert(0, str(addons))
    import deformkit_addon
    deformkit_addon.register()
    return deformkit_addon


def local_positions(bpy, obj):
    mesh = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    co = np.empty(3 * len(mesh.vertices))
    mesh.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


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
        obj = plain_tube(bpy, label)
        empty = add_empty(bpy, obj)
        if method == "BLENDER":
            laplacian_deform_with_hook(bpy, obj, empty)
        else:
            settings = {} if method is None else {"method": method, "iterations": 10}
            entry = api.add_laplacian(obj, anchors_group="Bottom", handles_group="Top", handle_target="OBJECT",
                                      handle_object=empty, **settings)
            label = f"{label} ({entry.method.replace('_', ' ').title()})" if method is None else label
        bend(bpy, empty, obj, DEGREES)
        results[label] = local_positions(bpy, obj)
    base = bpy.data.objects["ARAP, 10 iterations"].data  # the base mesh, as every tube's
    rest = np.array([v.co for v in base.vertices])
    for label, points in results.items():
        print(f"{label}: curvature jump {curvature_jump(points):.3f}, narrowest ring {narrowest(points):.3f}")
    faces = np.array([p.vertices[:] for p in base.polygons])
    triangles = np.vstack([faces[:, [0, 1, 2]], faces[:, [0, 2, 3]]])
    path = out / "tube_bend.png"
    render_panels(path, [rest] + list(results.values()), triangles,
                  f"A plain tube bent {DEGREES:.0f} degrees by an empty (curvature jump: 0 is smooth)",
                  ["rest"] + [f"{label}\njump {curvature_jump(p):.2f}" for label, p in results.items()],
                  elev=5.0, azim=0.0, to_plot=np.eye(3))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()

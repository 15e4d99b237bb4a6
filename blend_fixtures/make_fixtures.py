"""Build the .blend fixtures that `make demo` and the batch tests process.

    blender -b --factory-startup --python-exit-code 1 -P blend_fixtures/make_fixtures.py -- OUT_DIR

From Blender primitives, plus, when ../shared/meshes is beside the repository, two real meshes.
One file carries a saved deformkit stack (for --evaluate-saved), one a lattice entry, one a bound
Laplacian entry."""
import glob
import math
import os
import sys
import tempfile

import bpy

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED_MESHES = os.path.join(os.path.dirname(REPO), "shared", "meshes")


def enable_addon():
    addons = tempfile.mkdtemp(prefix="deformkit_addons_")
    os.symlink(os.path.join(REPO, "python_addon"), os.path.join(addons, "deformkit_addon"))
    lib = tempfile.mkdtemp(prefix="deformkit_lib_")
    for package in glob.glob(os.path.join(REPO, ".venv", "lib", "python3*", "site-packages", "deformkit")):
        os.symlink(package, os.path.join(lib, "deformkit"))
    sys.path[:0] = [addons, lib]
    import deformkit_addon
    deformkit_addon.register()
    from deformkit_addon import api
    return api


def fresh():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def save(out_dir, name):
    path = os.path.join(out_dir, name + ".blend")
    bpy.ops.wm.save_as_mainfile(filepath=path + ".tmp.blend", copy=True)
    os.replace(path + ".tmp.blend", path)
    print("fixture:", path)


def subdivided(obj, cuts):
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.subdivide(number_cuts=cuts)
    bpy.ops.object.mode_set(mode="OBJECT")
    return obj


def main():
    out_dir = os.path.abspath(sys.argv[sys.argv.index("--") + 1])
    os.makedirs(out_dir, exist_ok=True)
    api = enable_addon()

    fresh()
    bpy.ops.mesh.primitive_monkey_add()
    subdivided(bpy.context.active_object, 2).name = "Suzanne"
    save(out_dir, "monkey")

    fresh()
    bpy.ops.mesh.primitive_cube_add(scale=(0.4, 0.4, 1.6))
    subdivided(bpy.context.active_object, 12).name = "Column"
    save(out_dir, "column")

    fresh()
    bpy.ops.mesh.primitive_torus_add(major_segments=96, minor_segments=24)
    bpy.context.active_object.name = "Torus"
    save(out_dir, "torus")

    fresh()  # a stack saved in the file, for --evaluate-saved
    bpy.ops.mesh.primitive_cylinder_add(vertices=48, depth=3.0)
    column = subdivided(bpy.context.active_object, 6)
    column.name = "Twisted"
    api.add_entry(column, "TWIST", angle=2.0, deform_axis="Z")
    api.add_entry(column, "TAPER", factor=-0.5, deform_axis="Z")
    save(out_dir, "saved_stack")

    fresh()  # a lattice entry saved in the file: a Blender Lattice object with edited points
    bpy.ops.mesh.primitive_cylinder_add(vertices=64, depth=2.0, radius=0.5)
    vase = subdivided(bpy.context.active_object, 8)
    vase.name = "Vase"
    api.add_lattice(vase, resolution=(3, 3, 4), basis="BLENDER")
    lattice = vase.deformkit.entries[0].lattice
    lattice.name = "VaseLattice"
    for p in lattice.data.points:
        x, y, z = p.co
        ring = 1.6 if -0.3 < z < 0.3 else (0.7 if z > 0.3 else 1.0)  # belly out, neck in
        turn = math.radians(35.0) * (z + 0.5)  # the upper rings turn
        c, s = math.cos(turn), math.sin(turn)
        p.co_deform = (ring * (c * x - s * y), ring * (s * x + c * y), z)
    api.evaluate(vase)
    save(out_dir, "lattice_vase")

    fresh()  # a bound Laplacian entry (new, so Rotation Invariant): the hand follows an empty moved and turned
    # after bind
    bpy.ops.mesh.primitive_cylinder_add(vertices=24, depth=3.0, radius=0.4, end_fill_type="TRIFAN")
    arm = subdivided(bpy.context.active_object, 6)
    arm.name = "Arm"
    for name, side in (("Shoulder", -1), ("Hand", 1)):
        group = arm.vertex_groups.new(name=name)
        group.add([v.index for v in arm.data.vertices if side * v.co.z > 1.3], 1.0, "REPLACE")
    bpy.ops.object.empty_add(location=(0.0, 0.0, 1.5))
    hand = bpy.context.active_object
    hand.name = "HandTarget"
    api.add_laplacian(arm, anchors_group="Shoulder", handles_group="Hand", handle_target="OBJECT", handle_object=hand)
    hand.location, hand.rotation_euler = (0.9, 0.0, 1.1), (0.0, math.radians(50.0), 0.0)
    bpy.context.view_layer.update()
    api.evaluate(arm)
    save(out_dir, "laplacian_arm")

    for mesh in ("spot.obj", "cow.obj"):
        path = os.path.join(SHARED_MESHES, mesh)
        if not os.path.exists(path):
            print(f"fixture: {path} not found, skipped (the shared meshes are not beside this checkout)")
            continue
        fresh()
        bpy.ops.wm.obj_import(filepath=path)
        bpy.context.selected_objects[0].name = os.path.splitext(mesh)[0].title()
        save(out_dir, os.path.splitext(mesh)[0])


main()

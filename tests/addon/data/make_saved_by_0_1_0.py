"""Made tests/addon/data/saved_by_0.1.0.blend and its .npz, once, with the add-on of release 0.1.0
(main before the entry-kind registry), in Blender 3.4 so that every Blender the tests use can open it:

    git archive 2461642 python_addon | tar -x -C /tmp/addon_0.1.0
    DEFORMKIT_ADDON=/tmp/addon_0.1.0/python_addon \
        blender -b --factory-startup --python-exit-code 1 -P tests/addon/data/make_saved_by_0_1_0.py

Kept for the record of how the file was made; running it with a later add-on would make a file
saved by that one instead, which is not what the fixture is for. The stacks are in saved_stack.py.
"""
import glob
import os
import sys
import tempfile

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(os.path.dirname(HERE)))
sys.path.insert(0, os.path.dirname(HERE))
import saved_stack  # noqa: E402


def enable_addon():
    addons = tempfile.mkdtemp(prefix="deformkit_addons_")
    source = os.environ.get("DEFORMKIT_ADDON", os.path.join(REPO, "python_addon"))
    os.symlink(source, os.path.join(addons, "deformkit_addon"))
    lib = tempfile.mkdtemp(prefix="deformkit_lib_")
    for package in glob.glob(os.path.join(REPO, ".venv", "lib", "python3*", "site-packages", "deformkit")):
        os.symlink(package, os.path.join(lib, "deformkit"))
    sys.path[:0] = [addons, lib]
    import deformkit_addon
    deformkit_addon.register()
    from deformkit_addon import api, evaluation
    return api, evaluation


def positions(mesh):
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def subdivided(obj, cuts):
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.subdivide(number_cuts=cuts)
    bpy.ops.object.mode_set(mode="OBJECT")
    return obj


def sphere(name, location):
    """make_object's off-centre stretched sphere, smaller: the vertex group "Upper" over its top."""
    bpy.ops.mesh.primitive_uv_sphere_add(segments=16, ring_count=10, location=location)
    obj = bpy.context.active_object
    obj.name = obj.data.name = name
    co = positions(obj.data)
    co[:, 2] *= 1.8
    co[:, 0] += 0.2 * co[:, 2]
    obj.data.vertices.foreach_set("co", co.ravel())
    obj.data.update()
    group = obj.vertex_groups.new(name="Upper")
    for v in obj.data.vertices:
        if v.co.z > -0.5:
            group.add([v.index], min(1.0, (v.co.z + 0.5) / 2.0), "REPLACE")
    return obj


def empty(name, location, rotation=(0.0, 0.0, 0.0)):
    bpy.ops.object.empty_add(location=location, rotation=rotation)
    obj = bpy.context.active_object
    obj.name = name
    return obj


def add_stack(api, obj, name):
    for kind, params in saved_stack.STACKS[name]:
        params = {k: bpy.data.objects[v] if k in ("origin", "lattice", "handle_object") else v
                  for k, v in params.items()}
        if kind == "LAPLACIAN":
            api.add_laplacian(obj, **params)  # bound at once, to what the entries above make
        else:
            api.add_entry(obj, kind, **params)
    obj.deformkit.show_volume_ratio = saved_stack.VOLUME_COLORS.get(name, False)
    for path, keys in saved_stack.KEYFRAMES.get(name, {}).items():
        prop_owner, prop = path.rsplit(".", 1)
        owner = obj.path_resolve(prop_owner)
        for frame, value in keys:
            setattr(owner, prop, value)
            owner.keyframe_insert(prop, frame=frame)
    for path, expression in saved_stack.DRIVERS.get(name, {}).items():
        prop_owner, prop = path.rsplit(".", 1)
        obj.path_resolve(prop_owner).driver_add(prop).driver.expression = expression


def main():
    api, evaluation = enable_addon()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene

    empty("Origin", (0.2, 0.1, -0.3), (0.3, 0.0, 0.4))
    add_stack(api, sphere("Barrs", (0.3, -0.2, 0.5)), "Barrs")

    latticed = sphere("Latticed", (3.0, 0.0, 0.0))
    data = bpy.data.lattices.new("Cage")
    cage = bpy.data.objects.new("Cage", data)
    data.points_u, data.points_v, data.points_w = 4, 3, 3  # with its object: the rest grid spans [-1/2, 1/2]
    co = np.empty(len(data.points) * 3, np.float32)
    data.points.foreach_get("co", co)
    moved = co.reshape(-1, 3) + np.random.default_rng(7).uniform(-0.15, 0.15, (len(data.points), 3)).astype(np.float32)
    data.points.foreach_set("co_deform", moved.ravel())
    scene.collection.objects.link(cage)
    cage.location, cage.rotation_euler, cage.scale = (3.2, 0.0, 0.4), (0.2, -0.1, 0.3), (3.0, 3.0, 4.4)
    bpy.context.view_layer.update()
    add_stack(api, latticed, "Latticed")

    bpy.ops.mesh.primitive_cylinder_add(vertices=12, depth=3.0, radius=0.4, end_fill_type="TRIFAN",
                                        location=(-3.0, 0.0, 0.0))
    arm = subdivided(bpy.context.active_object, 3)
    arm.name = arm.data.name = "Arm"
    for group, side in (("Bottom", -1), ("Top", 1)):
        arm.vertex_groups.new(name=group).add([v.index for v in arm.data.vertices if side * v.co.z > 1.2], 1.0,
                                              "REPLACE")
    hand = empty("Hand", (-3.0, 0.0, 1.5))
    add_stack(api, arm, "Arm")
    hand.location, hand.rotation_euler = (-2.3, 0.1, 1.2), (0.0, 0.8, 0.1)  # moved and turned after bind

    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, 3.0, 0.0))
    smooth = subdivided(bpy.context.active_object, 1)
    smooth.name = smooth.data.name = "Smooth"
    add_stack(api, smooth, "Smooth")

    recorded = {}
    for frame in saved_stack.FRAMES:
        scene.frame_set(frame)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        for name in saved_stack.STACKS:
            obj = bpy.data.objects[name]
            assert not obj.deformkit.error and not any(e.error for e in obj.deformkit.entries), name
            recorded[f"{name}/{frame}/viewport"] = evaluation.evaluated_positions(obj, depsgraph)
            render = obj.data.attributes.get("deformkit_position_render")
            if render is not None:
                values = np.empty(len(obj.data.vertices) * 3, np.float32)
                render.data.foreach_get("vector", values)
                recorded[f"{name}/{frame}/render"] = values.reshape(-1, 3)
    scene.frame_set(1)
    path = os.path.join(HERE, saved_stack.BLEND)
    bpy.ops.wm.save_as_mainfile(filepath=path, compress=True, copy=True)
    np.savez_compressed(os.path.join(HERE, saved_stack.POSITIONS), **recorded)
    print("saved", path, os.path.getsize(path), "bytes;", sorted(recorded))


main()

"""Helpers for the add-on tests: meshes and twins with Blender's own modifier."""
import os
import pathlib

import numpy as np

REPO = pathlib.Path(__file__).resolve().parents[2]
IN_BLENDER_BINARY = os.environ.get("DEFORMKIT_IN_BLENDER") == "1"


def positions(mesh):
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def make_object(bpy, name="Obj", location=(0.3, -0.2, 0.5)):
    """An off-centre UV sphere, stretched along z, with a vertex group over its upper half."""
    bpy.ops.mesh.primitive_uv_sphere_add(segments=24, ring_count=16, location=location)
    obj = bpy.context.active_object
    obj.name = name
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


def twin_with_simple_deform(bpy, obj, **settings):
    """A copy of obj with Blender's own Simple Deform modifier and the same settings."""
    twin = obj.copy()
    twin.data = obj.data.copy()
    twin.name = obj.name + "_blender"
    bpy.context.scene.collection.objects.link(twin)
    twin.deformkit.entries.clear()
    for mod in list(twin.modifiers):
        twin.modifiers.remove(mod)
    mod = twin.modifiers.new("SimpleDeform", "SIMPLE_DEFORM")
    for key, value in settings.items():
        setattr(mod, key, value)
    return twin

"""A plain tube bent by an empty, and the measures of how smoothly it bends: shared by the demo
(demo_laplacian.py) and the test that holds the Laplacian entry to them
(tests/addon/test_laplacian_determinism.py). Functions take `bpy`, so this imports without it."""
import math

import numpy as np

SEGMENTS, RINGS, LENGTH, RADIUS = 24, 41, 4.0, 0.5


def plain_tube(bpy, name="Tube", location=(0.3, -0.2, 0.1)):
    """An open cylinder along z (quads, RINGS rings), with vertex groups "Bottom" and "Top" (two
    rings each) and "Ends" (both), placed off the origin."""
    z = np.linspace(0.0, LENGTH, RINGS)
    theta = 2 * np.pi * np.arange(SEGMENTS) / SEGMENTS
    co = np.stack([RADIUS * np.cos(theta)[None].repeat(RINGS, 0), RADIUS * np.sin(theta)[None].repeat(RINGS, 0),
                   z[:, None].repeat(SEGMENTS, 1)], -1).reshape(-1, 3)
    ring = np.arange(RINGS * SEGMENTS).reshape(RINGS, SEGMENTS)
    faces = [tuple(int(i) for i in f) for r in range(RINGS - 1)
             for f in zip(ring[r], np.roll(ring[r], -1), np.roll(ring[r + 1], -1), ring[r + 1])]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(co.tolist(), [], faces)
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    obj.location = location
    bpy.context.view_layer.objects.active = obj
    for group, rows in (("Bottom", ring[:2]), ("Top", ring[-2:]), ("Ends", np.vstack([ring[:2], ring[-2:]]))):
        obj.vertex_groups.new(name=group).add(rows.ravel().tolist(), 1.0, "REPLACE")
    bpy.context.view_layer.update()
    return obj


def add_empty(bpy, obj):
    """An empty at the tube's top centre, in the world."""
    empty = bpy.data.objects.new(obj.name + " Handle", None)
    bpy.context.scene.collection.objects.link(empty)
    empty.location = np.array(obj.location) + (0.0, 0.0, LENGTH)
    bpy.context.view_layer.update()
    return empty


def bend(bpy, empty, obj, degrees):
    """Place the empty where the tube's top is when its axis is bent by `degrees` into a circular
    arc of its length about x (what an artist does to bend a tube)."""
    a = math.radians(degrees)
    radius = LENGTH / a
    empty.location = np.array(obj.location) + (0.0, radius * (math.cos(a) - 1.0), radius * math.sin(a))
    empty.rotation_euler = (a, 0.0, 0.0)
    bpy.context.view_layer.update()


def laplacian_deform_with_hook(bpy, obj, empty):
    """Blender's own: a Hook of Top to the empty, then Laplacian Deform anchored on both ends, bound
    at rest (the empty's place now)."""
    hook = obj.modifiers.new("Hook", "HOOK")
    hook.object, hook.vertex_group = empty, "Top"
    # The Hook's inverse: the empty's place now is its rest place (as Ctrl+H's Hook to Selected).
    hook.matrix_inverse = (obj.matrix_world.inverted() @ empty.matrix_world).inverted()
    deform = obj.modifiers.new("LaplacianDeform", "LAPLACIANDEFORM")
    deform.vertex_group = "Ends"
    bpy.context.view_layer.objects.active = obj
    with bpy.context.temp_override(object=obj, active_object=obj):
        bpy.ops.object.laplaciandeform_bind(modifier=deform.name)
    bpy.context.view_layer.update()
    return deform


def curvature_jump(points):
    """The largest change of the axis's turn (through the rings' centres) from one ring to the next,
    over the mean turn: near 0 for a bend whose curvature varies smoothly along the tube; a kink
    or a pinch at a ring makes it jump there."""
    centres = points.reshape(RINGS, SEGMENTS, 3).mean(1)
    axis = np.diff(centres, axis=0)
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    turns = np.arccos(np.clip((axis[1:] * axis[:-1]).sum(1), -1.0, 1.0))
    return float(np.abs(np.diff(turns)).max() / turns.mean())


def narrowest(points):
    """The smallest ring's mean radius over the rest's: a pinched neck makes it small."""
    rings = points.reshape(RINGS, SEGMENTS, 3)
    return float(np.linalg.norm(rings - rings.mean(1)[:, None], axis=2).mean(1).min() / RADIUS)

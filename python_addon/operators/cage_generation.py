"""Generate Cage: a cage made by deformkit (dk.generate_cage) around the active mesh, set as its
Cage entry's Object and bound (docs/cage.md, "Generated cages")."""
import bpy
import numpy as np
from bpy.props import BoolProperty, FloatProperty, IntProperty

from .. import api, meshdata, native
from .base import Operator, mesh_poll


def world_mesh(obj, context):
    """obj's evaluated mesh (modifiers, shape keys applied) in world space: points (n, 3) float64
    and its polygons as deformkit takes them."""
    evaluated = obj.evaluated_get(context.evaluated_depsgraph_get())
    mesh = evaluated.to_mesh()
    try:
        points = meshdata.base_positions(mesh).astype(np.float64)
        faces = meshdata.polygons(meshdata.topology(mesh)) if len(mesh.polygons) else None
    finally:
        evaluated.to_mesh_clear()
    world = np.array(obj.matrix_world)
    return points @ world[:3, :3].T + world[:3, 3], faces


def cage_entry_index(obj, index):
    """The Cage entry to receive the cage: `index`, else the active entry if it is a Cage entry,
    else the first Cage entry without a cage, else a new Cage entry."""
    stack = obj.deformkit
    if index >= 0:
        api.entry_of_type(obj, index, "CAGE")  # raises ValueError naming what the entry is
        return index
    if 0 <= stack.active_index < len(stack.entries) and stack.entries[stack.active_index].type == "CAGE":
        return stack.active_index
    for i, entry in enumerate(stack.entries):
        if entry.type == "CAGE" and entry.cage is None:
            return i
    name = api.add_entry(obj, "CAGE").name
    return [e.name for e in stack.entries].index(name)


def new_cage_object(obj, points, faces):
    """A mesh object "<obj> Cage" at the world origin, in obj's collections, shown as wire."""
    mesh = bpy.data.meshes.new(f"{obj.name} Cage")
    mesh.from_pydata(np.asarray(points).tolist(), [], [list(map(int, f)) for f in faces])
    mesh.update()
    cage = bpy.data.objects.new(f"{obj.name} Cage", mesh)
    for collection in obj.users_collection:
        collection.objects.link(cage)
    cage.display_type = "WIRE"
    return cage


class DEFORMKIT_OT_generate_cage(Operator, bpy.types.Operator):
    """Make a coarse cage that strictly encloses the active mesh (deformkit's alpha wrap and
    outward simplification), set it as the Cage entry's Object and bind"""
    bl_idname = "deformkit.generate_cage"
    bl_label = "Generate Cage"

    max_faces: IntProperty(name="Max Faces", default=200, min=4, soft_max=2000,
                           description="Most faces the cage may have (triangles; quads count as one)")
    offset: FloatProperty(name="Offset", default=0.0, min=0.0, subtype="DISTANCE", precision=4,
                          description="Gap between mesh and cage (0: 1/100 of the mesh's bounding-box diagonal)")
    quads: BoolProperty(name="Quads", default=False,
                        description="Merge pairs of nearly coplanar triangles into quads")
    index: IntProperty(name="Index", default=-1, options={"SKIP_SAVE"})

    @classmethod
    def poll(cls, context):
        return mesh_poll(cls, context, "Needs an active mesh object")

    def run(self, context):
        obj = context.object
        points, faces = world_mesh(obj, context)
        if not len(points):
            raise ValueError(f"'{obj.name}' has no vertices to make a cage around")
        cage_points, cage_faces = native.dk.generate_cage(points, faces, max_faces=self.max_faces,
                                                          offset=self.offset or None, quads=self.quads)
        index = cage_entry_index(obj, self.index)
        cage = new_cage_object(obj, cage_points, cage_faces)
        obj.deformkit.entries[index].cage = cage
        vertices = api.bind_cage(obj, index)
        self.report({"INFO"}, f"'{cage.name}': a cage of {len(cage_faces)} faces and {vertices} vertices, bound")


classes = (DEFORMKIT_OT_generate_cage,)

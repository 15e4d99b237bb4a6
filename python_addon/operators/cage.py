"""The Cage entry's Bind and Unbind (the panel names them by bl_idname, as Mesh Deform's names its
Bind), and Convert Mesh Deform to deformkit."""
import bpy

from .. import mesh_deform
from .base import BindOperator, Operator, UnbindOperator, mesh_poll

TYPES, NEEDS = ("CAGE",), "Needs a mesh with a Cage entry"


class DEFORMKIT_OT_cage_bind(BindOperator, bpy.types.Operator):
    """Record the cage's current shape as its rest: afterwards the mesh follows the cage's edits"""
    bl_idname = "deformkit.cage_bind"
    bl_label = "Bind to Cage"
    TYPES, NEEDS, REPORT = TYPES, NEEDS, "Bound '{obj}' to a cage of {result} vertices"


class DEFORMKIT_OT_cage_unbind(UnbindOperator, bpy.types.Operator):
    """Forget the cage's rest shape: the entry passes the mesh through until bound again"""
    bl_idname = "deformkit.cage_unbind"
    bl_label = "Unbind from Cage"
    TYPES, NEEDS = TYPES, NEEDS


class DEFORMKIT_OT_convert_mesh_deform(Operator, bpy.types.Operator):
    """Replace the active object's Mesh Deform modifiers by Cage entries (Harmonic, same cage, precision, """ \
        """dynamic, vertex group and keys), bound as they were, leaving the result as it was"""
    bl_idname = "deformkit.convert_mesh_deform"
    bl_label = "Convert Mesh Deform to deformkit"

    @classmethod
    def poll(cls, context):
        return mesh_poll(cls, context, "Needs a mesh with a Mesh Deform modifier", mesh_deform.mesh_deforms)

    def run(self, context):
        lines = mesh_deform.convert(context.object)
        for line in lines:
            self.report({"WARNING"} if "stays" in line or "dropped" in line else {"INFO"}, line)


classes = (DEFORMKIT_OT_cage_bind, DEFORMKIT_OT_cage_unbind, DEFORMKIT_OT_convert_mesh_deform)

"""The Cage entry's Bind and Unbind (the panel names them by bl_idname, as Mesh Deform's names its Bind)."""
import bpy

from .. import api
from .base import EntryOperator


class _CageOperator(EntryOperator):
    TYPES = ("CAGE",)
    NEEDS = "Needs a mesh with a Cage entry"


class DEFORMKIT_OT_cage_bind(_CageOperator, bpy.types.Operator):
    """Record the cage's current shape as its rest: afterwards the mesh follows the cage's edits"""
    bl_idname = "deformkit.cage_bind"
    bl_label = "Bind to Cage"

    def run(self, context):
        obj, index = self.target(context)
        count = api.bind(obj, index)
        self.report({"INFO"}, f"Bound '{obj.name}' to a cage of {count} vertices")


class DEFORMKIT_OT_cage_unbind(_CageOperator, bpy.types.Operator):
    """Forget the cage's rest shape: the entry passes the mesh through until bound again"""
    bl_idname = "deformkit.cage_unbind"
    bl_label = "Unbind from Cage"

    def run(self, context):
        api.unbind(*self.target(context))


classes = (DEFORMKIT_OT_cage_bind, DEFORMKIT_OT_cage_unbind)

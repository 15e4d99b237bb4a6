"""The Cage entry's Bind and Unbind (the panel names them by bl_idname, as Mesh Deform's names its Bind)."""
import bpy

from .base import BindOperator, UnbindOperator

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


classes = (DEFORMKIT_OT_cage_bind, DEFORMKIT_OT_cage_unbind)

"""The RBF entry's Bind and Unbind (named by bl_idname in the entry's panel)."""
import bpy

from .base import BindOperator, UnbindOperator

TYPES, NEEDS = ("RBF",), "Needs a mesh with an RBF entry"


class DEFORMKIT_OT_rbf_bind(BindOperator, bpy.types.Operator):
    """Record the controls' rest positions: afterwards the mesh follows the control object's vertices"""
    bl_idname = "deformkit.rbf_bind"
    bl_label = "Bind to Controls"
    TYPES, NEEDS, REPORT = TYPES, NEEDS, "Bound '{obj}' to {result} control points"


class DEFORMKIT_OT_rbf_unbind(UnbindOperator, bpy.types.Operator):
    """Forget the controls' rest positions: the entry passes the mesh through until bound again"""
    bl_idname = "deformkit.rbf_unbind"
    bl_label = "Unbind from Controls"
    TYPES, NEEDS = TYPES, NEEDS


classes = (DEFORMKIT_OT_rbf_bind, DEFORMKIT_OT_rbf_unbind)

"""The RBF entry's Bind and Unbind (named by bl_idname in the entry's panel)."""
import bpy

from .. import api
from .base import EntryOperator


class _RBFOperator(EntryOperator):
    TYPES = ("RBF",)
    NEEDS = "Needs a mesh with an RBF entry"


class DEFORMKIT_OT_rbf_bind(_RBFOperator, bpy.types.Operator):
    """Record the controls' rest positions: afterwards the mesh follows the control object's vertices"""
    bl_idname = "deformkit.rbf_bind"
    bl_label = "Bind to Controls"

    def run(self, context):
        obj, index = self.target(context)
        count = api.bind(obj, index)
        self.report({"INFO"}, f"Bound '{obj.name}' to {count} control points")


class DEFORMKIT_OT_rbf_unbind(_RBFOperator, bpy.types.Operator):
    """Forget the controls' rest positions: the entry passes the mesh through until bound again"""
    bl_idname = "deformkit.rbf_unbind"
    bl_label = "Unbind from Controls"

    def run(self, context):
        api.unbind(*self.target(context))


classes = (DEFORMKIT_OT_rbf_bind, DEFORMKIT_OT_rbf_unbind)

"""The Laplacian entry's Bind, Unbind and Select Parts Without Anchors (named by bl_idname in the
entry's panel)."""
import bpy

from .. import meshdata
from ..entries import laplacian
from .base import BindOperator, EntryOperator, UnbindOperator, mesh_object


TYPES, NEEDS = ("LAPLACIAN",), "Needs a mesh with a Laplacian entry"


class DEFORMKIT_OT_laplacian_bind(BindOperator, bpy.types.Operator):
    """Record the mesh as it comes into the entry as the rest shape, and prepare the solver"""
    bl_idname = "deformkit.laplacian_bind"
    bl_label = "Bind"
    TYPES, NEEDS, OBJECT_MODE, REPORT = TYPES, NEEDS, True, "Bound '{entry}': {result} vertices"


class DEFORMKIT_OT_laplacian_unbind(UnbindOperator, bpy.types.Operator):
    """Forget the rest shape: the entry passes the mesh through until bound again"""
    bl_idname = "deformkit.laplacian_unbind"
    bl_label = "Unbind"
    TYPES, NEEDS, OBJECT_MODE = TYPES, NEEDS, True


class DEFORMKIT_OT_laplacian_select_unanchored(EntryOperator, bpy.types.Operator):
    """Select the parts of the mesh that have no anchor and no handle, which the entry leaves where they are (in Edit Mode)"""
    bl_idname = "deformkit.laplacian_select_unanchored"
    bl_label = "Select Parts Without Anchors"
    TYPES, NEEDS = TYPES, NEEDS

    @classmethod
    def poll(cls, context):
        # Selecting needs no compiled core: only the mesh's topology.
        obj = mesh_object(context)
        if obj is None or not any(cls.of_kind(e) for e in obj.deformkit.entries):
            cls.poll_message_set(cls.NEEDS)
            return False
        return True

    def run(self, context):
        obj, index = self.target(context)
        if obj.mode == "EDIT":
            bpy.ops.object.mode_set(mode="OBJECT")  # writes the edit mesh back, to read it
        vertices = laplacian.unanchored_vertices(obj, obj.deformkit.entries[index])
        meshdata.select_vertices(obj.data, vertices)
        bpy.ops.object.mode_set(mode="EDIT")
        self.report({"INFO"}, f"{len(vertices)} vertices selected")


classes = (DEFORMKIT_OT_laplacian_bind, DEFORMKIT_OT_laplacian_unbind, DEFORMKIT_OT_laplacian_select_unanchored)

"""Operators: thin wrappers around `api` with poll, undo and reports."""
import bpy
from bpy.props import EnumProperty, IntProperty

from . import api, native
from .properties import ENTRY_TYPES


def _mesh_object(context):
    obj = context.object
    return obj if obj is not None and obj.type == "MESH" else None


class _EntryOperator:
    bl_options = {"REGISTER", "UNDO"}
    index: IntProperty(name="Index", default=-1, options={"SKIP_SAVE"})

    @classmethod
    def poll(cls, context):
        obj = _mesh_object(context)
        return obj is not None and len(obj.deformkit.entries) > 0

    def entry_index(self, context):
        return self.index if self.index >= 0 else context.object.deformkit.active_index


class DEFORMKIT_OT_entry_add(bpy.types.Operator):
    """Add a deformkit entry to the active object's stack"""
    bl_idname = "deformkit.entry_add"
    bl_label = "Add deformkit Entry"
    bl_options = {"REGISTER", "UNDO"}
    type: EnumProperty(name="Type", items=ENTRY_TYPES)

    @classmethod
    def poll(cls, context):
        if not native.available():
            cls.poll_message_set(native.IMPORT_ERROR)
            return False
        return _mesh_object(context) is not None

    def execute(self, context):
        try:
            api.add_entry(context.object, self.type)
        except ValueError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        return {"FINISHED"}


class DEFORMKIT_OT_entry_remove(_EntryOperator, bpy.types.Operator):
    """Remove the entry"""
    bl_idname = "deformkit.entry_remove"
    bl_label = "Remove deformkit Entry"

    def execute(self, context):
        api.remove_entry(context.object, self.entry_index(context))
        return {"FINISHED"}


class DEFORMKIT_OT_entry_move(_EntryOperator, bpy.types.Operator):
    """Move the entry up or down in the stack"""
    bl_idname = "deformkit.entry_move"
    bl_label = "Move deformkit Entry"
    direction: EnumProperty(items=[("UP", "Up", ""), ("DOWN", "Down", "")])

    def execute(self, context):
        try:
            api.move_entry(context.object, self.entry_index(context), -1 if self.direction == "UP" else 1)
        except IndexError:
            return {"CANCELLED"}
        return {"FINISHED"}


class DEFORMKIT_OT_entry_apply(_EntryOperator, bpy.types.Operator):
    """Apply the entry: bake its deformation into the mesh and remove it"""
    bl_idname = "deformkit.entry_apply"
    bl_label = "Apply deformkit Entry"

    @classmethod
    def poll(cls, context):
        if not super().poll(context):
            return False
        if context.object.mode == "EDIT":
            cls.poll_message_set("Leave edit mode to apply")
            return False
        return True

    def execute(self, context):
        try:
            warning = api.apply(context.object, self.entry_index(context))
        except ValueError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        if warning:
            self.report({"INFO"}, warning)
        return {"FINISHED"}


classes = (DEFORMKIT_OT_entry_add, DEFORMKIT_OT_entry_remove, DEFORMKIT_OT_entry_move, DEFORMKIT_OT_entry_apply)

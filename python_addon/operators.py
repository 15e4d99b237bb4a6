"""Operators on the stack: thin wrappers around `api` with poll, undo and reports. Each entry kind's
own operators (Lattice: fit, bind, reset, direct manipulation; Laplacian: bind, unbind) are in its
module under entries/."""
import math

import bpy
from bpy.props import EnumProperty, FloatProperty, IntProperty

from . import api, panel_text
from .entries.common import core_missing
from .entries.common import mesh_object as _mesh_object
from .properties import ENTRY_TYPES


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
        return not core_missing(cls) and _mesh_object(context) is not None

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
    """Move the entry up or down in the stack, or to its first or last place"""
    bl_idname = "deformkit.entry_move"
    bl_label = "Move deformkit Entry"
    direction: EnumProperty(items=[("UP", "Up", ""), ("DOWN", "Down", ""), ("FIRST", "First", "Move to the top"),
                                   ("LAST", "Last", "Move to the bottom (above a Subdivide entry)")])

    def execute(self, context):
        try:
            if self.direction in ("FIRST", "LAST"):
                api.move_entry_to(context.object, self.entry_index(context), self.direction)
            else:
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


class DEFORMKIT_OT_check_smoothness(bpy.types.Operator):
    """Check the limit surface of the cage (as the entries above any Subdivide entry leave it): select creased edges"""
    bl_idname = "deformkit.check_smoothness"
    bl_label = "Check Smoothness"
    bl_options = {"REGISTER", "UNDO"}  # the selection changes
    worst: IntProperty(name="Worst Edges", default=10, min=1, max=100000,
                       description="How many of the edges with the largest angles to consider for selection")
    min_angle: FloatProperty(name="Minimum Angle", subtype="ANGLE", default=1e-6, min=0.0, precision=6,
                             description="Select the worst edges whose angle exceeds this (smooth: rounding only)")

    @classmethod
    def poll(cls, context):
        return DEFORMKIT_OT_entry_add.poll(context)

    def execute(self, context):
        try:
            figures = api.check_smoothness(context.object, worst=self.worst, min_angle=self.min_angle)
        except ValueError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        edge = figures["worst_edge"]
        where = f" at edge {tuple(edge)}" if edge else ""
        self.report({"WARNING" if figures["selected_edges"] else "INFO"},
                    f"Max normal angle {panel_text.degrees(math.radians(figures['max_angle_degrees']))}{where}; gap {figures['max_gap']:.2g}, "
                    f"{figures['degenerate_samples']} degenerate, {figures['flipped_samples']} flipped samples; "
                    f"{len(figures['selected_edges'])} creased edges selected")
        return {"FINISHED"}


classes = (DEFORMKIT_OT_entry_add, DEFORMKIT_OT_entry_remove, DEFORMKIT_OT_entry_move, DEFORMKIT_OT_entry_apply,
           DEFORMKIT_OT_check_smoothness)

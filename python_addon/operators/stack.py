"""Operators on the stack: thin wrappers around `api` with poll, undo and reports (base.py reports
their errors). Each kind's own operators are in this folder under the kind's name."""
import math

import bpy
from bpy.props import EnumProperty, FloatProperty, IntProperty

from .. import api, entries, panel_text
from ..properties import ENTRY_TYPES
from .base import EntryOperator, Operator, core_missing, mesh_object


class _StackOperator(EntryOperator):
    """Acts on entry `index` of the active mesh, else on its active entry; available whenever the mesh
    has entries (without the compiled core too: the stack can still be edited)."""

    @classmethod
    def poll(cls, context):
        obj = mesh_object(context)
        return obj is not None and len(obj.deformkit.entries) > 0

    def entry_index(self, context):
        return self.index if self.index >= 0 else context.object.deformkit.active_index


class DEFORMKIT_OT_entry_add(Operator, bpy.types.Operator):
    """Add a deformkit entry to the active object's stack"""
    bl_idname = "deformkit.entry_add"
    bl_label = "Add deformkit Entry"
    type: EnumProperty(name="Type", items=ENTRY_TYPES)

    @classmethod
    def description(cls, context, properties):
        """The kind's own description in menus and F3 search (Twist, Cage, ... each say what they do)."""
        return next((row[2] for row in ENTRY_TYPES if row[0] == properties.type), cls.__doc__)

    @classmethod
    def poll(cls, context):
        return not core_missing(cls) and mesh_object(context) is not None

    def run(self, context):
        api.add_entry(context.object, self.type)


class DEFORMKIT_OT_entry_remove(_StackOperator, bpy.types.Operator):
    """Remove the entry"""
    bl_idname = "deformkit.entry_remove"
    bl_label = "Remove deformkit Entry"

    def run(self, context):
        api.remove_entry(context.object, self.entry_index(context))


class DEFORMKIT_OT_entry_move(_StackOperator, bpy.types.Operator):
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
        except IndexError:  # already first (last): nothing to do, as a modifier's Move Up on the first
            return {"CANCELLED"}
        return {"FINISHED"}


class DEFORMKIT_OT_entry_set_active(_StackOperator, bpy.types.Operator):
    """Make this the active entry (the one Ctrl+A applies)"""
    bl_idname = "deformkit.entry_set_active"
    bl_label = "Set Active deformkit Entry"

    def execute(self, context):
        stack = context.object.deformkit
        if not 0 <= self.index < len(stack.entries):
            return {"CANCELLED"}
        stack.active_index = self.index
        return {"FINISHED"}


class DEFORMKIT_OT_entry_duplicate(_StackOperator, bpy.types.Operator):
    """Duplicate the entry below it, with the same settings (a Laplacian entry's bind too)"""
    bl_idname = "deformkit.entry_duplicate"
    bl_label = "Duplicate deformkit Entry"

    @classmethod
    def description(cls, context, properties):
        # The menu greys the item out for a Subdivide entry; its tooltip says why.
        obj = mesh_object(context)
        stack = obj.deformkit if obj is not None else None
        index = properties.index if properties.index >= 0 else (stack.active_index if stack else -1)
        if stack is not None and 0 <= index < len(stack.entries) and entries.kind(stack.entries[index]).LAST:
            return "A Subdivide entry must be the last one, so it cannot be duplicated"
        return cls.__doc__

    def run(self, context):
        api.duplicate_entry(context.object, self.entry_index(context))


class DEFORMKIT_OT_entry_copy_to_selected(_StackOperator, bpy.types.Operator):
    """Copy the entry to the other selected mesh objects (a Laplacian entry arrives unbound: bind it there)"""
    bl_idname = "deformkit.entry_copy_to_selected"
    bl_label = "Copy deformkit Entry to Selected"

    @staticmethod
    def targets(context):
        return [o for o in getattr(context, "selected_objects", ()) if o != context.object and o.type == "MESH"]

    @classmethod
    def poll(cls, context):
        if not super().poll(context):
            return False
        if not cls.targets(context):
            cls.poll_message_set("Select the other mesh objects to copy to")
            return False
        return True

    def run(self, context):
        copies = api.copy_entry_to(context.object, self.entry_index(context), self.targets(context))
        unbound = [c.id_data.name for c in copies if c.bind_copied_from]
        if unbound:
            self.report({"WARNING"}, f"Copied unbound to {', '.join(unbound)}: a bind belongs to its mesh, Bind again")


class DEFORMKIT_OT_entry_apply(_StackOperator, bpy.types.Operator):
    """Apply the entry: bake its deformation into the mesh and remove it"""
    bl_idname = "deformkit.entry_apply"
    bl_label = "Apply deformkit Entry"

    @classmethod
    def poll(cls, context):
        if not super().poll(context):
            return False
        space = getattr(context, "space_data", None)
        if space is not None and space.type == "PROPERTIES" and space.context != "MODIFIER":
            return False  # Ctrl+A on another tab of the Properties editor is not ours
        if context.object.mode == "EDIT":
            cls.poll_message_set("Leave edit mode to apply")
            return False
        return True

    def invoke(self, context, event):
        if self.index < 0 and getattr(context, "region", None) is not None and context.area.type == "PROPERTIES":
            # The hotkey. Add-on key map items come before Blender's, whose Ctrl+A applies the modifier
            # whose panel is under the mouse (Python cannot find the panel under the mouse) and
            # passes the key on elsewhere: let it try first.
            if bpy.ops.object.modifier_apply.poll() and "FINISHED" in bpy.ops.object.modifier_apply("INVOKE_DEFAULT"):
                return {"FINISHED"}
        return self.execute(context)  # the active entry (pressed in the panel), or the menu's

    def run(self, context):
        warning = api.apply(context.object, self.entry_index(context))
        if warning:
            self.report({"INFO"}, warning)


def register():
    """Ctrl+A in the Properties editor applies the active entry, as it applies a modifier (over a
    modifier's panel, the modifier: see DEFORMKIT_OT_entry_apply.invoke)."""
    keyconfig = bpy.context.window_manager.keyconfigs.addon
    if keyconfig is None:  # some background runs have none: no keys to map
        return
    keymap = keyconfig.keymaps.new(name="Property Editor", space_type="PROPERTIES")
    item = keymap.keymap_items.new(DEFORMKIT_OT_entry_apply.bl_idname, "A", "PRESS", ctrl=True)
    KEYMAP_ITEMS.append((keymap, item))


def unregister():
    for keymap, item in KEYMAP_ITEMS:
        keymap.keymap_items.remove(item)
    KEYMAP_ITEMS.clear()


KEYMAP_ITEMS = []


class DEFORMKIT_OT_check_smoothness(Operator, bpy.types.Operator):
    """Check the limit surface of the cage (as the entries above any Subdivide entry leave it): select creased edges"""
    bl_idname = "deformkit.check_smoothness"
    bl_label = "Check Smoothness"
    worst: IntProperty(name="Worst Edges", default=10, min=1, max=100000,
                       description="How many of the edges with the largest angles to consider for selection")
    min_angle: FloatProperty(name="Minimum Angle", subtype="ANGLE", default=1e-6, min=0.0, precision=6,
                             description="Select the worst edges whose angle exceeds this (smooth: rounding only)")

    @classmethod
    def poll(cls, context):
        return DEFORMKIT_OT_entry_add.poll(context)

    def run(self, context):
        figures = api.check_smoothness(context.object, worst=self.worst, min_angle=self.min_angle)
        edge = figures["worst_edge"]
        where = f" at edge {tuple(edge)}" if edge else ""
        self.report({"WARNING" if figures["selected_edges"] else "INFO"},
                    f"Max normal angle {panel_text.degrees(math.radians(figures['max_angle_degrees']))}{where}; "
                    f"gap {panel_text.percent(figures['max_gap'])} of the diagonal, "
                    f"{figures['degenerate_samples']} degenerate, {figures['flipped_samples']} flipped samples; "
                    f"{len(figures['selected_edges'])} creased edges selected")


class DEFORMKIT_OT_select_flipped(Operator, bpy.types.Operator):
    """Select the control faces whose limit surface has flipped samples (folds the entries made)"""
    bl_idname = "deformkit.select_flipped"
    bl_label = "Select Flipped"

    @classmethod
    def poll(cls, context):
        return DEFORMKIT_OT_entry_add.poll(context)

    def run(self, context):
        faces = api.select_flipped(context.object)
        self.report({"WARNING" if faces else "INFO"}, f"{len(faces)} faces with flipped samples selected")


classes = (DEFORMKIT_OT_entry_add, DEFORMKIT_OT_entry_remove, DEFORMKIT_OT_entry_move, DEFORMKIT_OT_entry_set_active,
           DEFORMKIT_OT_entry_duplicate, DEFORMKIT_OT_entry_copy_to_selected, DEFORMKIT_OT_entry_apply,
           DEFORMKIT_OT_check_smoothness, DEFORMKIT_OT_select_flipped)

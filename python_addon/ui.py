"""Panel in the Modifiers tab, laid out like Blender's own modifier panels."""
import bpy

from . import native
from .properties import ENTRY_TYPES


class DEFORMKIT_MT_add(bpy.types.Menu):
    bl_label = "Add deformkit Entry"
    bl_idname = "DEFORMKIT_MT_add"

    def draw(self, context):
        for kind, label, _description, icon, _n in ENTRY_TYPES:
            self.layout.operator("deformkit.entry_add", text=label, icon=icon).type = kind


class DEFORMKIT_PT_stack(bpy.types.Panel):
    bl_label = "deformkit"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "modifier"

    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.type == "MESH"

    def draw(self, context):
        layout = self.layout
        obj = context.object
        stack = obj.deformkit
        if not native.available():
            layout.alert = True
            layout.label(text=native.IMPORT_ERROR, icon="ERROR")
            return
        layout.menu(DEFORMKIT_MT_add.bl_idname, icon="ADD")
        if stack.error:
            box = layout.box()
            box.alert = True
            box.label(text=stack.error, icon="ERROR")
        layout.prop(stack, "show_volume_ratio")
        for index, entry in enumerate(stack.entries):
            draw_entry(layout.box(), obj, entry, index, len(stack.entries))


def draw_entry(box, obj, entry, index, count):
    row = box.row(align=True)
    row.prop(entry, "show_expanded", text="", emboss=False,
             icon="DISCLOSURE_TRI_DOWN" if entry.show_expanded else "DISCLOSURE_TRI_RIGHT")
    row.label(icon="MOD_SIMPLEDEFORM")
    row.prop(entry, "name", text="")
    row.prop(entry, "show_viewport", text="", icon="RESTRICT_VIEW_OFF" if entry.show_viewport else "RESTRICT_VIEW_ON")
    row.prop(entry, "show_render", text="", icon="RESTRICT_RENDER_OFF" if entry.show_render else "RESTRICT_RENDER_ON")
    sub = row.row(align=True)
    sub.enabled = index > 0
    op = sub.operator("deformkit.entry_move", text="", icon="TRIA_UP")
    op.index, op.direction = index, "UP"
    sub = row.row(align=True)
    sub.enabled = index < count - 1
    op = sub.operator("deformkit.entry_move", text="", icon="TRIA_DOWN")
    op.index, op.direction = index, "DOWN"
    row.operator("deformkit.entry_apply", text="", icon="CHECKMARK").index = index
    row.operator("deformkit.entry_remove", text="", icon="X").index = index
    if entry.error:
        alert = box.row()
        alert.alert = True
        alert.label(text=entry.error, icon="ERROR")
    if not entry.show_expanded:
        return
    col = box.column()
    col.use_property_split = True
    col.prop(entry, "type")
    col.prop(entry, "angle" if entry.type in {"TWIST", "BEND"} else "factor")
    col.prop(entry, "deform_axis", expand=True)
    col.prop(entry, "origin")
    col.prop(entry, "limits", slider=True)
    if entry.type != "BEND":
        row = col.row(heading="Lock", align=True)
        for axis in "xyz":
            if axis.upper() != entry.deform_axis:
                row.prop(entry, f"lock_{axis}", text=axis.upper(), toggle=True)
    row = col.row(align=True)
    row.prop_search(entry, "vertex_group", obj, "vertex_groups", text="Vertex Group")
    row.prop(entry, "invert_vertex_group", text="", icon="ARROW_LEFTRIGHT")


classes = (DEFORMKIT_MT_add, DEFORMKIT_PT_stack)

"""Panel in the Modifiers tab, laid out like Blender's own modifier panels."""
import math

import bpy

from . import evaluation, lattices, native, surface
from .properties import ENTRY_TYPES

# The others: MOD_SIMPLEDEFORM.
ICONS = {"LATTICE": "MOD_LATTICE", "LAPLACIAN": "MOD_MESHDEFORM", "SUBDIVIDE": "MOD_SUBSURF"}


class DEFORMKIT_MT_add(bpy.types.Menu):
    bl_label = "Add deformkit Entry"
    bl_idname = "DEFORMKIT_MT_add"

    def draw(self, context):
        for kind, label, _description, _icon, _n in ENTRY_TYPES:
            icon = ICONS.get(kind, "MOD_SIMPLEDEFORM")
            self.layout.operator("deformkit.entry_add", text=label, icon=icon).type = kind
        self.layout.separator()
        self.layout.operator("object.deformkit_add_lattice", icon="OUTLINER_OB_LATTICE")


class DEFORMKIT_MT_entry_specials(bpy.types.Menu):
    """The drop-down of an entry's header, like a modifier's: apply and move."""
    bl_label = "deformkit Entry"
    bl_idname = "DEFORMKIT_MT_entry_specials"

    def draw(self, context):
        entry = getattr(context, "deformkit_entry", None)
        if entry is None:
            return
        stack = context.object.deformkit
        index = list(stack.entries).index(entry)
        layout = self.layout
        layout.operator("deformkit.entry_apply", text="Apply", icon="CHECKMARK").index = index
        layout.separator()
        for label, direction, icon, enabled in (("Move Up", "UP", "TRIA_UP", index > 0),
                                                ("Move Down", "DOWN", "TRIA_DOWN", index < len(stack.entries) - 1)):
            sub = layout.column()
            sub.enabled = enabled
            op = sub.operator("deformkit.entry_move", text=label, icon=icon)
            op.index, op.direction = index, direction


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
        row = layout.row()
        row.menu(DEFORMKIT_MT_add.bl_idname, icon="ADD")
        row.prop(stack, "show_volume_ratio", text="", icon="COLOR")
        broken = [e.name for e in stack.entries if e.error]
        for message in ([stack.error] if stack.error else []) + (
                [f"Result not updated until {', '.join(broken)} is fixed"] if broken else []):
            box = layout.box()
            box.alert = True
            box.label(text=message, icon="ERROR")
        mod = obj.modifiers.get("deformkit")
        if len(stack.entries) and mod is not None and not mod.show_viewport:
            layout.label(text="The 'deformkit' modifier, which shows the result, is hidden", icon="INFO")
        if stack.show_volume_ratio and any(e.type == "LAPLACIAN" and e.show_viewport for e in stack.entries):
            layout.label(text="Volume colors leave out Laplacian entries (no Jacobian)", icon="INFO")
        if stack.show_volume_ratio and any(e.type == "SUBDIVIDE" for e in stack.entries):
            layout.label(text="Volume colors are not carried through a Subdivide entry", icon="INFO")
        for entry in stack.entries:
            draw_entry(layout.box(), obj, entry)
        draw_smoothness(layout.box(), stack)


def draw_entry(box, obj, entry):
    """Laid out like Blender's Simple Deform panel: header, mode, amount, origin, axis, restrictions."""
    row = box.row()
    row.context_pointer_set("deformkit_entry", entry)
    row.prop(entry, "show_expanded", text="", emboss=False,
             icon="DOWNARROW_HLT" if entry.show_expanded else "RIGHTARROW")
    row.label(text="", icon=ICONS.get(entry.type, "MOD_SIMPLEDEFORM"))
    row.prop(entry, "name", text="")
    toggles = row.row(align=True)
    toggles.prop(entry, "show_viewport", text="", icon="RESTRICT_VIEW_OFF" if entry.show_viewport else "RESTRICT_VIEW_ON")
    toggles.prop(entry, "show_render", text="", icon="RESTRICT_RENDER_OFF" if entry.show_render else "RESTRICT_RENDER_ON")
    row.menu(DEFORMKIT_MT_entry_specials.bl_idname, text="", icon="DOWNARROW_HLT")
    row.operator("deformkit.entry_remove", text="", icon="X", emboss=False).index = list(
        obj.deformkit.entries).index(entry)
    if entry.error:
        alert = box.row()
        alert.alert = True
        alert.label(text=entry.error, icon="ERROR")
    if not entry.show_expanded:
        return
    box.row().prop(entry, "type", expand=True)
    col = box.column()
    col.use_property_split = True
    if entry.type == "LATTICE":
        draw_lattice(col, obj, entry)
        return
    if entry.type == "LAPLACIAN":
        draw_laplacian(col, obj, entry)
        return
    if entry.type == "SUBDIVIDE":
        draw_subdivide(col, entry)
        return
    col.prop(entry, "angle" if entry.type in {"TWIST", "BEND"} else "factor")
    col.prop(entry, "origin")
    col.row().prop(entry, "deform_axis", expand=True)
    col.separator()
    col.label(text="Restrictions")
    col.prop(entry, "limits", slider=True)
    if entry.type != "BEND":
        row = col.row(heading="Lock", align=True)
        for axis in "xyz":
            if axis.upper() != entry.deform_axis:
                row.prop(entry, f"lock_{axis}", text=axis.upper(), toggle=True)
    draw_vertex_group(col, obj, entry)


def draw_vertex_group(col, obj, entry):
    row = col.row(align=True)
    row.prop_search(entry, "vertex_group", obj, "vertex_groups", text="Vertex Group")
    sub = row.row(align=True)
    sub.active = bool(entry.vertex_group)
    sub.prop(entry, "invert_vertex_group", text="", icon="ARROW_LEFTRIGHT")


def draw_lattice(col, obj, entry):
    """Laid out like Blender's Lattice modifier panel, then the binding and the lattice tools."""
    index = list(obj.deformkit.entries).index(entry)
    col.prop(entry, "lattice", text="Object")
    col.prop(entry, "lattice_basis")
    col.prop(entry, "outside")
    col.prop(entry, "strength", slider=True)
    draw_vertex_group(col, obj, entry)
    col.separator()
    bound = lattices.binding_counts(evaluation.cache_key(obj), index)
    if bound is None:
        col.label(text="Not bound yet", icon="UNLINKED")
    else:
        unplaced = f", {bound[2]} not placed" if bound[2] else ""
        col.label(text=f"Bound: {bound[0]} vertices inside, {bound[1]} outside{unplaced}", icon="LINKED")
    row = col.row(align=True)
    row.operator("object.deformkit_lattice_bind", text="Rebind" if bound else "Bind",
                 icon="FILE_REFRESH").index = index
    row.operator("object.deformkit_lattice_reset", text="Reset", icon="LOOP_BACK").index = index
    row = col.row(align=True)
    for targets, label, icon in (("CURSOR", "Selection to Cursor", "PIVOT_CURSOR"),
                                 ("EMPTIES", "Selection to Empties", "EMPTY_AXIS")):
        op = row.operator("object.deformkit_lattice_direct", text=label, icon=icon)
        op.index, op.targets = index, targets


def draw_laplacian(col, obj, entry):
    """Laid out like Blender's Laplacian Deform panel: settings, then the bind state and button."""
    index = list(obj.deformkit.entries).index(entry)
    col.prop(entry, "method")
    col.prop(entry, "weights")
    sub = col.row()
    sub.active = entry.method != "LAPLACIAN"  # naive editing solves once
    sub.prop(entry, "iterations")
    col.prop_search(entry, "anchors_group", obj, "vertex_groups", text="Anchors")
    col.prop_search(entry, "handles_group", obj, "vertex_groups", text="Handles")
    col.row().prop(entry, "handle_target", expand=True)
    if entry.handle_target == "OBJECT":
        col.prop(entry, "handle_object")
    col.separator()
    text, warnings = surface.status(obj, entry)
    col.label(text=text, icon="LINKED" if surface.is_bound(entry) else "UNLINKED")
    for warning in warnings:
        col.label(text=warning, icon="INFO")
    if surface.is_bound(entry):
        col.operator("object.deformkit_laplacian_unbind", text="Unbind", icon="UNLINKED").index = index
    else:
        col.operator("object.deformkit_laplacian_bind", text="Bind", icon="LINKED").index = index


def draw_subdivide(col, entry):
    """Laid out like Blender's Subdivision Surface panel, then the size of what it made."""
    col.prop(entry, "levels", text="Levels Viewport")
    col.prop(entry, "render_levels", text="Render")
    col.prop(entry, "scheme")
    col.separator()
    col.label(text="Advanced")
    col.prop(entry, "use_limit_surface")
    col.prop(entry, "use_creases")
    col.prop(entry, "sharpen_two_edge_vertices")
    col.prop(entry, "boundary_smooth")
    col.prop(entry, "uv_smooth")
    render = entry.subdivision_render
    for label, helper in (("Viewport" if render else "Viewport and render", entry.subdivision_viewport),
                          ("Render", render)):
        if helper is not None:
            col.label(text=f"{label}: {len(helper.data.vertices)} vertices, {len(helper.data.polygons)} faces")


def draw_smoothness(box, stack):
    """Check Smoothness and the figures of its last run (of the cage, before any Subdivide entry)."""
    box.operator("object.deformkit_check_smoothness", icon="MOD_SMOOTH")
    figures = stack.smoothness
    if not figures.checked:
        return
    col = box.column(align=True)
    col.label(text="Last check, of the cage:")
    col.label(text=f"Max normal angle: {math.degrees(figures.max_angle):.3g}° at edge {tuple(figures.worst_edge)}")
    col.label(text=f"Max gap: {figures.max_gap:.2g} of the diagonal")
    col.label(text=f"Degenerate samples: {figures.degenerate}, flipped: {figures.flipped}")
    col.label(text=f"Creased edges selected: {figures.selected}",
              icon="ERROR" if figures.selected else "CHECKMARK")


classes = (DEFORMKIT_MT_add, DEFORMKIT_MT_entry_specials, DEFORMKIT_PT_stack)

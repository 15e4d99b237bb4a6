"""Panel in the Modifiers tab, laid out like Blender's own modifier panels."""
import bpy

from . import entries, mesh_deform, native, outputs, panel_text
from .operators import cage, cage_generation, laplacian, lattice, markers, rbf, stack
from .properties import ENTRY_TYPES

ICONS = {t[0]: entries.kind(t[0]).ICON for t in ENTRY_TYPES}


class DEFORMKIT_MT_add(bpy.types.Menu):
    bl_label = "Add deformkit Entry"
    bl_idname = "DEFORMKIT_MT_add"

    def draw(self, context):
        for kind, label, _description, _icon, _n in ENTRY_TYPES:
            self.layout.operator("deformkit.entry_add", text=label, icon=ICONS[kind]).type = kind
        self.layout.separator()
        for kind in entries.KINDS:
            for operator, icon in kind.MENU:
                self.layout.operator(operator, icon=icon)
        self.layout.separator()  # shape keys onto this mesh from another (transfer/)
        self.layout.operator("deformkit.transfer_deformation", icon="MOD_DATA_TRANSFER")


# Operators found through the Object menu (and so by F3's menu search) beside the entry kinds: all
# but the panel's own clicks and those DEFORMKIT_MT_add lists; they act on the active entry.
LISTED_ELSEWHERE = {"deformkit.entry_add", "deformkit.entry_set_active", "deformkit.entry_move"} | {
    operator for kind in entries.KINDS for operator, _icon in kind.MENU}
MOVES = (("Move Entry Up", "UP"), ("Move Entry Down", "DOWN"), ("Move Entry to First", "FIRST"),
         ("Move Entry to Last", "LAST"))


class DEFORMKIT_MT_object(bpy.types.Menu):
    """deformkit in the 3D View's Object menu (both versions): every entry kind and every operator
    on the active object's entries, so that F3 finds them by their names"""
    bl_label = "deformkit"
    bl_idname = "DEFORMKIT_MT_object"

    def draw(self, context):
        DEFORMKIT_MT_add.draw(self, context)
        layout = self.layout
        layout.separator()
        for module in (stack, lattice, laplacian, cage, cage_generation, rbf):
            for cls in module.classes:
                if cls.bl_idname not in LISTED_ELSEWHERE:
                    layout.operator(cls.bl_idname)
        for label, direction in MOVES:
            layout.operator("deformkit.entry_move", text=label).direction = direction
        layout.separator()  # marker pairs for Transfer Deformation (the active pair where one is meant)
        for cls in markers.classes:
            layout.operator(cls.bl_idname)


def draw_object_menu(self, context):
    self.layout.separator()
    self.layout.menu(DEFORMKIT_MT_object.bl_idname, icon="MOD_SIMPLEDEFORM")


def draw_kinds(layout, context, generate):
    """The entry kinds that deform (or, with generate, make new geometry) as Add Modifier items."""
    if context.object is None or context.object.type != "MESH":
        return
    layout.separator()
    for kind, label, _description, _icon, _n in ENTRY_TYPES:
        if bool(entries.kind(kind).LAST) == generate:  # the topology-changing kind: Subdivide
            layout.operator("deformkit.entry_add", text=f"{label} (deformkit)", icon=ICONS[kind]).type = kind


def draw_deform_menu(self, context):
    draw_kinds(self.layout, context, generate=False)


def draw_generate_menu(self, context):
    draw_kinds(self.layout, context, generate=True)


# Blender 4.2+ defines Add Modifier's columns as Python menus; 3.4 draws Add Modifier in C, so there
# the Object menu is the way in (F3 searches both).
MENU_HOOKS = (("VIEW3D_MT_object", draw_object_menu), ("OBJECT_MT_modifier_add_deform", draw_deform_menu),
              ("OBJECT_MT_modifier_add_generate", draw_generate_menu))


def register():
    for menu, draw in MENU_HOOKS:
        if hasattr(bpy.types, menu):
            getattr(bpy.types, menu).append(draw)


def unregister():
    for menu, draw in MENU_HOOKS:
        if hasattr(bpy.types, menu):
            getattr(bpy.types, menu).remove(draw)


class DEFORMKIT_MT_entry_specials(bpy.types.Menu):
    """The drop-down of an entry's header, like a modifier's: apply, copy and move."""
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
        if not smoothness_applies(stack):  # else it is under the stack
            layout.operator("deformkit.check_smoothness", icon="MOD_SMOOTH")
            layout.separator()
        layout.operator("deformkit.entry_copy_to_selected", text="Copy to Selected", icon="COPYDOWN").index = index
        sub = layout.column()
        sub.enabled = not entries.kind(entry).LAST  # the operator's description says why
        sub.operator("deformkit.entry_duplicate", text="Duplicate", icon="DUPLICATE").index = index
        layout.separator()
        last = index < len(stack.entries) - 1
        for label, direction, icon, enabled in (("Move Up", "UP", "TRIA_UP", index > 0),
                                                ("Move Down", "DOWN", "TRIA_DOWN", last),
                                                ("Move to First", "FIRST", "TRIA_UP_BAR", index > 0),
                                                ("Move to Last", "LAST", "TRIA_DOWN_BAR", last)):
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
            panel_text.label_wrapped(layout, native.IMPORT_ERROR, "ERROR", panel_text.context_budget(context))
            return
        budget = panel_text.context_budget(context)
        row = layout.row()
        row.menu(DEFORMKIT_MT_add.bl_idname, icon="ADD")
        if mesh_deform.mesh_deforms(obj):  # a rig's Mesh Deform modifiers to take over as Cage entries
            layout.operator("deformkit.convert_mesh_deform", icon="MOD_MESHDEFORM")
        if stack.notice:
            panel_text.label_wrapped(layout, stack.notice, "INFO", budget)
        if not len(stack.entries):  # on every mesh: compact until it has entries
            if stack.error:
                panel_text.label_wrapped(layout, stack.error, "ERROR", budget)
            if outputs.our_modifier(obj) is not None:  # Copy Modifiers brings the modifier, not the entries
                panel_text.label_wrapped(layout, "The 'deformkit' modifier here has no entries on this object "
                                         "(copied from another?): it leaves the mesh as it is. Copy entries with "
                                         "the entry menu's Copy to Selected", "INFO", budget)
            return
        row.prop(stack, "show_volume_ratio", text="", icon="COLOR")
        broken = [e.name for e in stack.entries if e.error]
        for message in ([stack.error] if stack.error else []) + (
                [f"See the message on {', '.join(broken)}; the other entries still apply"] if broken else []):
            box = layout.box()
            box.alert = True
            panel_text.label_wrapped(box, message, "ERROR", budget)
        mod = obj.modifiers.get("deformkit")
        if len(stack.entries) and mod is not None and not mod.show_viewport:
            panel_text.label_wrapped(layout, "The 'deformkit' modifier, which shows the result, is hidden", "INFO",
                                     budget)
        draw_modifier_place(layout, obj, budget)
        for note in entries.volume_notes(stack.entries) if stack.show_volume_ratio else ():
            panel_text.label_wrapped(layout, note, "INFO", budget)
        for entry in stack.entries:
            draw_entry(layout.box(), obj, entry)
        if smoothness_applies(stack):
            draw_smoothness(layout.box(), stack)


def draw_modifier_place(layout, obj, budget):
    """What moving the "deformkit" modifier below others does, with the button that moves it back."""
    problem = outputs.place_problem(obj)
    if problem:
        box = layout.box()
        panel_text.label_wrapped(box, problem, "INFO", budget)
        op = box.operator("object.modifier_move_to_index", text="Move 'deformkit' to First", icon="TRIA_UP_BAR")
        op.modifier, op.index = outputs.MODIFIER_NAME, 0


def draw_entry(box, obj, entry):
    """Laid out like Blender's modifier panels: the header, then the kind's settings."""
    row = box.row()
    row.context_pointer_set("deformkit_entry", entry)
    # The buttons in two aligned groups beside the name (no gaps within them): the box inside the
    # panel is narrower than a modifier's header, and the name field gets what is left ("Laplacian"
    # and "Subdivide" read whole at the default width; five gaps left "Lapl…" in Blender 3.4).
    start = row.row(align=True)
    start.prop(entry, "show_expanded", text="", emboss=False,
               icon="DOWNARROW_HLT" if entry.show_expanded else "RIGHTARROW")
    # The kind's icon, pressed on the active entry (the one Ctrl+A applies): a click makes it active,
    # as a click on a modifier's panel does.
    index = list(obj.deformkit.entries).index(entry)
    active = index == obj.deformkit.active_index
    start.operator("deformkit.entry_set_active", text="", icon=ICONS[entry.type], emboss=active,
                   depress=active).index = index
    row.prop(entry, "name", text="")
    toggles = row.row(align=True)
    if entry.show_in_editmode:  # Blender's order and icons; On Cage only where Edit Mode is on
        toggles.prop(entry, "show_on_cage", text="", icon="MESH_DATA")
    toggles.prop(entry, "show_in_editmode", text="", icon="EDITMODE_HLT")
    toggles.prop(entry, "show_viewport", text="", icon="RESTRICT_VIEW_OFF" if entry.show_viewport else "RESTRICT_VIEW_ON")
    toggles.prop(entry, "show_render", text="", icon="RESTRICT_RENDER_OFF" if entry.show_render else "RESTRICT_RENDER_ON")
    end = toggles  # the menu and X join the toggles: one gap less for the name
    end.menu(DEFORMKIT_MT_entry_specials.bl_idname, text="", icon="DOWNARROW_HLT")
    end.operator("deformkit.entry_remove", text="", icon="X", emboss=False).index = index
    if entry.error:
        alert = box.row()
        alert.alert = True
        panel_text.label_wrapped(alert, entry.error, "ERROR")
    if not entry.show_expanded:
        return
    col = box.column()
    col.use_property_split = True
    # A dropdown: seven expanded buttons are cut to "Str… Latt…" at the default width.
    col.prop(entry, "type", text=type_label(entry))
    entries.kind(entry).draw(col, obj, entry)


def type_label(entry):
    """The Type row's label, the kind's TYPE_LABEL: "Mode" for the Barr kinds, whose types are
    Simple Deform's modes (its deform_method is named Mode), "Type" for the others."""
    return entries.kind(entry).TYPE_LABEL


def smoothness_applies(stack):
    """Check Smoothness (of the cage a Subdivide entry refines) under the stack only with such an
    entry, or to show the figures of a check run from an entry's menu."""
    return stack.smoothness.checked or any(entries.kind(e).LAST for e in stack.entries)


def draw_smoothness(box, stack):
    """Check Smoothness and the figures of its last run (of the cage, before any Subdivide entry)."""
    box.operator("deformkit.check_smoothness", icon="MOD_SMOOTH")
    if not stack.smoothness.checked:
        return
    col = box.column(align=True)
    for text, icon in smoothness_lines(stack.smoothness):
        if text.startswith("Flipped") and stack.smoothness.flipped:
            row = col.row()
            row.label(text=text, icon=icon)
            row.operator("deformkit.select_flipped", text="Select", icon="RESTRICT_SELECT_OFF")
        else:
            col.label(text=text, icon=icon)


def smoothness_lines(figures):
    """(text, icon) of each line the panel shows for the last Check Smoothness: a problem (creased
    edges, flipped or degenerate samples) is a warning on its own line; the check mark only when
    there is none."""
    edge = f" at edge {tuple(figures.worst_edge)}" if figures.worst_edge[0] >= 0 else ""
    lines = [("Last check, of the cage:", "NONE"),
             (f"Max normal angle: {panel_text.degrees(figures.max_angle)}{edge}", "NONE"),
             (f"Max gap: {panel_text.percent(figures.max_gap)} of the diagonal", "NONE")]
    problems = [(f"Flipped samples: {figures.flipped}", figures.flipped),
                (f"Degenerate samples: {figures.degenerate}", figures.degenerate),
                (f"Creased edges selected: {figures.selected}", figures.selected)]
    lines += [(text, "ERROR" if count else "NONE") for text, count in problems]
    if not any(count for _text, count in problems):
        lines.append(("Smooth", "CHECKMARK"))
    return lines


classes = (DEFORMKIT_MT_add, DEFORMKIT_MT_object, DEFORMKIT_MT_entry_specials, DEFORMKIT_PT_stack)

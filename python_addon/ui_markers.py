"""The marker pairs' panel (Properties > Object Data, beside Vertex Groups): the pairs of the
active mesh and its partner (the other mesh in Edit Mode with it, else the other selected mesh) as
a list of the active mesh's marker vertex groups, with the tools of operators/markers.py."""
import bpy

from .transfer import DEFAULT_PREFIX, markers


def partner(context):
    """The other mesh the pairs are made with, or None."""
    try:
        source, _target = markers.pair_objects(context.object, getattr(
            context, "objects_in_mode" if context.object.mode == "EDIT" else "selected_objects", ()))
    except ValueError:
        return None
    return source


class DEFORMKIT_UL_marker_pairs(bpy.types.UIList):
    """The active mesh's vertex groups named with the marker prefix; a pair missing on the partner
    is flagged."""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index=0):
        other = partner(context)
        row = layout.row(align=True)
        paired = other is not None and other.vertex_groups.get(item.name) is not None
        row.label(text=item.name, icon="LINKED" if paired else "ERROR")
        if not paired:
            row.label(text="not on the other mesh" if other is not None else "select the other mesh")
        sub = row.row(align=True)
        sub.enabled = paired
        sub.operator("deformkit.select_marker_pair", text="", icon="RESTRICT_SELECT_OFF").name = item.name
        sub.operator("deformkit.remove_marker_pair", text="", icon="X").name = item.name

    def filter_items(self, context, data, propname):
        groups = getattr(data, propname)
        flags = [self.bitflag_filter_item if g.name.startswith(DEFAULT_PREFIX) else 0 for g in groups]
        return flags, []


class DEFORMKIT_PT_marker_pairs(bpy.types.Panel):
    """Deformation transfer's marker pairs between the active mesh (the target) and the other."""
    bl_label = "deformkit Marker Pairs"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "data"
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.type == "MESH"

    def draw(self, context):
        obj = context.object
        layout = self.layout
        other = partner(context)
        layout.label(text=f"With '{other.name}'" if other is not None else
                     "Select the other mesh too (in Edit Mode: both in Edit Mode)", icon="MOD_DATA_TRANSFER")
        layout.template_list("DEFORMKIT_UL_marker_pairs", "", obj, "vertex_groups", obj.vertex_groups,
                             "active_index", rows=4)
        col = layout.column(align=True)
        col.operator("deformkit.add_marker_pair", icon="ADD")
        row = col.row(align=True)
        row.operator("deformkit.mirror_marker_pair", icon="MOD_MIRROR")
        row.operator("deformkit.guess_marker_pairs", icon="VIEWZOOM")


classes = (DEFORMKIT_UL_marker_pairs, DEFORMKIT_PT_marker_pairs)

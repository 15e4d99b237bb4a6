"""The marker pairs' panel (Properties > Object Data, beside Vertex Groups): the pairs of the
active mesh and its partner (the other mesh in Edit Mode with it, else the other selected mesh) as
a list of the active mesh's marker vertex groups, with the tools of operators/markers.py; and the
pairs drawn in the 3D Viewport as numbered points on both meshes (the active pair in white)."""
import blf
import bpy
import gpu
import numpy as np
from gpu_extras.batch import batch_for_shader

from .transfer import DEFAULT_PREFIX, markers

# By "is the active pair": cyan apart from Edit Mode's orange selection, the active pair white.
COLOURS = {False: (0.2, 0.85, 1.0, 1.0), True: (1.0, 1.0, 1.0, 1.0)}
POINT_SIZE = 9.0
LABEL_SIZE = 13
HANDLES = []
DRAWN = []  # what draw_points drew, for draw_labels in the same redraw
# The marker points by (source, target, their modes): reading the groups walks every vertex in
# Python (0.1 s on the horse and camel), so a redraw that changed nothing (navigating the view)
# reuses them; any depsgraph update (an edit, a group assigned, an object moved), undo or load
# clears them.
CACHE = {}


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
    """Deformation transfer's marker pairs between the active mesh (the target) and the other:
    under Vertex Groups, shown when there is another mesh to pair with or the mesh has markers."""
    bl_label = "deformkit Marker Pairs"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "data"
    bl_parent_id = "DATA_PT_vertex_groups"

    @classmethod
    def poll(cls, context):
        obj = context.object
        if obj is None or obj.type != "MESH":
            return False
        return partner(context) is not None or any(g.name.startswith(DEFAULT_PREFIX) for g in obj.vertex_groups)

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
        row.operator("deformkit.mirror_marker_pair", text="Mirror", icon="MOD_MIRROR")
        row.operator("deformkit.mirror_marker_pair", text="Mirror All", icon="MOD_MIRROR").all_pairs = True
        col.operator("deformkit.guess_marker_pairs", icon="VIEWZOOM")


def shown_markers(context):
    """[(label, world position, is the active pair)] for both meshes of the active mesh's pairs,
    or [] when there is no partner or the viewport's overlays are off."""
    space = getattr(context, "space_data", None)
    overlay = getattr(space, "overlay", None)
    obj = context.object
    if (overlay is not None and not overlay.show_overlays) or obj is None or obj.type != "MESH":
        return []
    other = partner(context)
    if other is None:
        return []
    key = (other.name, obj.name, other.mode, obj.mode)
    if key not in CACHE:
        try:
            CACHE[key] = markers.marker_points(other, obj)
        except ValueError:
            return []
    sides = CACHE[key]
    active = obj.vertex_groups.active.name if obj.vertex_groups.active is not None else None
    return [(label(name), point, name == active) for _obj, names, points in sides for name, point in zip(names, points)]


def label(name):
    number = name[len(DEFAULT_PREFIX):]
    return str(int(number)) if number.isdigit() else number


def region_point(region, region_data, point):
    """The pixel of a world point in the region, or None behind the view."""
    clip = np.array(region_data.perspective_matrix, np.float64) @ np.append(point, 1.0)
    if clip[3] <= 0:
        return None
    return (region.width * (1.0 + clip[0] / clip[3]) / 2, region.height * (1.0 + clip[1] / clip[3]) / 2)


def draw_points(context=None):
    shown = shown_markers(context or bpy.context)
    DRAWN[:] = shown
    if not shown:
        return
    # Blender 4.0 dropped the "3D_" of the built-in shaders' names.
    shader = gpu.shader.from_builtin("UNIFORM_COLOR" if bpy.app.version >= (4, 0, 0) else "3D_UNIFORM_COLOR")
    gpu.state.point_size_set(POINT_SIZE)
    for active in (False, True):
        points = [tuple(point) for _label, point, is_active in shown if is_active == active]
        if points:
            batch = batch_for_shader(shader, "POINTS", {"pos": points})
            shader.uniform_float("color", COLOURS[active])
            batch.draw(shader)
    gpu.state.point_size_set(1.0)


def draw_labels(context=None):
    """The pairs' numbers beside the points draw_points drew in this redraw."""
    context = context or bpy.context
    region, region_data = getattr(context, "region", None), getattr(context, "region_data", None)
    shown = DRAWN if region is not None and region_data is not None else []
    if not shown:
        return
    try:
        blf.size(0, LABEL_SIZE)
    except TypeError:  # Blender before 3.6 also asks for the dpi
        blf.size(0, LABEL_SIZE, 72)
    for text, point, active in shown:
        at = region_point(region, region_data, point)
        if at is not None:
            blf.color(0, *COLOURS[active])
            blf.position(0, at[0] + 6, at[1] + 6, 0)
            blf.draw(0, text)


@bpy.app.handlers.persistent
def forget_drawn(*_args):
    CACHE.clear()


CLEARED_BY = ("depsgraph_update_post", "undo_post", "redo_post", "load_post")


def register():
    view3d = bpy.types.SpaceView3D
    HANDLES.append(view3d.draw_handler_add(draw_points, (), "WINDOW", "POST_VIEW"))
    HANDLES.append(view3d.draw_handler_add(draw_labels, (), "WINDOW", "POST_PIXEL"))
    for name in CLEARED_BY:
        getattr(bpy.app.handlers, name).append(forget_drawn)


def unregister():
    while HANDLES:
        bpy.types.SpaceView3D.draw_handler_remove(HANDLES.pop(), "WINDOW")
    for name in CLEARED_BY:
        handlers = getattr(bpy.app.handlers, name)
        while forget_drawn in handlers:
            handlers.remove(forget_drawn)
    CACHE.clear()


classes = (DEFORMKIT_UL_marker_pairs, DEFORMKIT_PT_marker_pairs)

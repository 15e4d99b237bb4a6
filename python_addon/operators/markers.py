"""The marker-pair tools of Transfer Deformation (docs/blender_addon.md, "Marker pairs"): the work
is transfer/markers.py's; the target is the active mesh and the source the other mesh in Edit Mode
with it (or, in Object Mode, the other selected mesh)."""
import bpy
from bpy.props import BoolProperty, FloatProperty, IntProperty, StringProperty

from ..transfer import DEFAULT_PREFIX, markers
from .base import Operator, mesh_object

PREFIX = StringProperty(name="Prefix", default=DEFAULT_PREFIX,
                        description="The marker vertex groups' common prefix (Transfer Deformation's Marker Prefix)")


def the_two(context):
    """(source, target) for the marker tools."""
    active = context.object
    if active is not None and active.mode == "EDIT":
        others = getattr(context, "objects_in_mode", ())
    else:
        others = getattr(context, "selected_objects", ())
    return markers.pair_objects(active, others)


def pair_name(context, name):
    """`name`, else the active vertex group's name."""
    if name:
        return name
    obj = context.object
    group = obj.vertex_groups.active if obj is not None else None
    if group is None:
        raise ValueError("name: empty and no active vertex group; name the pair (e.g. 'dt_001')")
    return group.name


class MarkerOperator(Operator):
    @classmethod
    def poll(cls, context):
        if mesh_object(context) is None:
            cls.poll_message_set("Needs an active mesh object (the target) and the source mesh")
            return False
        return True


class DEFORMKIT_OT_add_marker_pair(MarkerOperator, bpy.types.Operator):
    """Mark the one selected vertex of each of two meshes in Edit Mode as corresponding points for \
Transfer Deformation: a vertex group of the next number (dt_001, dt_002, ...) on each"""
    bl_idname = "deformkit.add_marker_pair"
    bl_label = "Add Marker Pair"
    prefix: PREFIX

    @classmethod
    def poll(cls, context):
        obj = mesh_object(context)
        if obj is None or obj.mode != "EDIT":
            cls.poll_message_set("Needs two meshes in Edit Mode together, one vertex selected on each")
            return False
        return True

    def run(self, context):
        source, target = the_two(context)
        name = markers.add_selected_pair(source, target, self.prefix)
        self.report({"INFO"}, f"Marker pair '{name}' on '{source.name}' and '{target.name}'")


class DEFORMKIT_OT_select_marker_pair(MarkerOperator, bpy.types.Operator):
    """Select the pair's two marker vertices (and nothing else) on both meshes"""
    bl_idname = "deformkit.select_marker_pair"
    bl_label = "Select Marker Pair"
    name: StringProperty(name="Name", description="The pair's vertex group name (empty: the active group)")
    prefix: PREFIX

    def run(self, context):
        source, target = the_two(context)
        markers.select_pair(source, target, pair_name(context, self.name), self.prefix)


class DEFORMKIT_OT_remove_marker_pair(MarkerOperator, bpy.types.Operator):
    """Remove the pair's vertex group from both meshes"""
    bl_idname = "deformkit.remove_marker_pair"
    bl_label = "Remove Marker Pair"
    name: StringProperty(name="Name", description="The pair's vertex group name (empty: the active group)")
    prefix: PREFIX

    def run(self, context):
        source, target = the_two(context)
        markers.remove_pair(source, target, pair_name(context, self.name), self.prefix)


class DEFORMKIT_OT_mirror_marker_pair(MarkerOperator, bpy.types.Operator):
    """Add the X-mirrored pair of a pair (or of every pair) on symmetric meshes: on each mesh the \
vertex nearest the marker's mirror image about the object's own X = 0"""
    bl_idname = "deformkit.mirror_marker_pair"
    bl_label = "Mirror Marker Pair"
    name: StringProperty(name="Name", description="The pair to mirror (empty: the active group)")
    tolerance: FloatProperty(name="Tolerance", default=markers.MIRROR_TOLERANCE, min=1e-6, max=1.0,
                             description="How far the nearest vertex may be from the mirrored position, as a "
                             "fraction of the mesh's bounding-box diagonal")
    all_pairs: BoolProperty(name="All Pairs", default=False,
                            description="Mirror every pair (skipping those on the plane or mirrored already)")
    prefix: PREFIX

    def run(self, context):
        source, target = the_two(context)
        if not self.all_pairs:
            name = markers.mirror_pair(source, target, pair_name(context, self.name), self.tolerance, self.prefix)
            self.report({"INFO"}, f"Mirrored pair '{name}'")
            return
        made, skipped = markers.mirror_all(source, target, self.tolerance, self.prefix)
        why = f"; skipped {len(skipped)}: " + "; ".join(skipped.values()) if skipped else ""
        self.report({"INFO"} if made else {"WARNING"}, f"Mirrored {len(made)} pairs{why}")


class DEFORMKIT_OT_guess_marker_pairs(MarkerOperator, bpy.types.Operator):
    """Propose marker pairs to correct: well-spread source vertices paired with the nearest target \
vertices once the source is placed on the target by a similarity fit (from the pairs already made, \
if three or more)"""
    bl_idname = "deformkit.guess_marker_pairs"
    bl_label = "Guess Marker Pairs"
    count: IntProperty(name="Count", default=20, min=1, soft_max=200, description="How many pairs to propose")
    prefix: PREFIX

    def run(self, context):
        source, target = the_two(context)
        names = markers.guess_pairs(source, target, self.count, self.prefix)
        self.report({"INFO"}, f"Proposed {len(names)} marker pairs: check them (Select) and correct or remove "
                    "the wrong ones")


classes = (DEFORMKIT_OT_add_marker_pair, DEFORMKIT_OT_select_marker_pair, DEFORMKIT_OT_remove_marker_pair,
           DEFORMKIT_OT_mirror_marker_pair, DEFORMKIT_OT_guess_marker_pairs)

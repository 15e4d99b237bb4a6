"""Transfer Deformation's operator and its menu entry beside Blender's Transfer Shape Key: it
gathers the settings and reports; the work is transfer/'s (base.py reports its errors)."""
import bpy
from bpy.props import BoolProperty, EnumProperty, IntProperty, StringProperty

from ..errors import EntryError
from ..transfer import DEFAULT_PREFIX, transfer_animation, transfer_shape_keys
from .base import Operator, core_missing, mesh_object

MODES = [("SHAPE_KEYS", "Shape Keys", "Each shape key of the source (its points) becomes a shape key of the target"),
         ("ANIMATION", "Animation", "The source's evaluated deformation (e.g. from an Armature) at each frame of the "
          "range becomes a shape key of the target, keyed to play on its frame")]


def selected_source(context, target):
    """The other selected mesh when exactly one is selected besides the target (as Blender's
    Transfer Shape Key takes it), else None."""
    others = [o for o in getattr(context, "selected_objects", ()) if o != target and o.type == "MESH"]
    return others[0] if len(others) == 1 else None


class DEFORMKIT_OT_transfer_deformation(Operator, bpy.types.Operator):
    """Transfer the source mesh's shape keys, or its animation baked per frame, onto the target as shape \
keys (deformation transfer: also between different meshes, through marker vertex groups)"""
    bl_idname = "deformkit.transfer_deformation"
    bl_label = "Transfer Deformation"

    source: StringProperty(name="Source", description="The mesh whose deformation is transferred (empty: the other "
                           "selected mesh)")
    target: StringProperty(name="Target", description="The mesh that receives the shape keys (empty: the active "
                           "object)")
    mode: EnumProperty(name="Mode", items=MODES, default="SHAPE_KEYS")
    use_scene_range: BoolProperty(name="Scene Frame Range", default=True,
                                  description="Bake the scene's frame range (else Start and End)")
    frame_start: IntProperty(name="Start", default=1, description="The first frame to bake")
    frame_end: IntProperty(name="End", default=250, description="The last frame to bake")
    marker_prefix: StringProperty(name="Marker Prefix", default=DEFAULT_PREFIX,
                                  description="Between different meshes: the vertex groups named alike on both, "
                                  "starting with this, mark corresponding points (each group's vertex of highest "
                                  "weight)")
    replace: BoolProperty(name="Replace Existing", default=False,
                          description="Overwrite the target's shape keys of the same names (else new, unique names)")

    @classmethod
    def poll(cls, context):
        if core_missing(cls):
            return False
        obj = mesh_object(context)
        if obj is None:
            cls.poll_message_set("Needs an active mesh object, the target")
            return False
        if obj.mode != "OBJECT":
            cls.poll_message_set("Leave Edit Mode first")
            return False
        return True

    def invoke(self, context, event):
        """The dialog opens on what is selected: the active object as the Target and the other
        selected mesh as the Source (the last run's names are remembered, so they are replaced)."""
        self.target = context.object.name
        found = selected_source(context, context.object)
        if found is not None or bpy.data.objects.get(self.source) in (None, context.object):
            self.source = found.name if found is not None else ""
        return context.window_manager.invoke_props_dialog(self)

    def draw(self, context):
        col = self.layout.column()
        col.use_property_split = True
        col.prop_search(self, "source", bpy.data, "objects")
        col.prop_search(self, "target", bpy.data, "objects")
        col.prop(self, "mode")
        if self.mode == "ANIMATION":
            col.prop(self, "use_scene_range")
            sub = col.column(align=True)
            sub.active = not self.use_scene_range
            sub.prop(self, "frame_start")
            sub.prop(self, "frame_end")
        col.prop(self, "marker_prefix")
        col.prop(self, "replace")

    def objects(self, context):
        target = bpy.data.objects.get(self.target) if self.target else context.object
        if self.target and target is None:
            raise EntryError(f"target: no object named '{self.target}'")
        if self.source:
            source = bpy.data.objects.get(self.source)
            if source is None:
                raise EntryError(f"source: no object named '{self.source}'")
        else:
            source = selected_source(context, target)
            if source is None:
                raise EntryError("no source object: select the source mesh and the target (active), or name the "
                                 "Source")
        return source, target

    def run(self, context):
        wm = context.window_manager
        wm.progress_begin(0, 1)

        def progress(done, total):
            wm.progress_update(done / max(total, 1))

        try:
            source, target = self.objects(context)
            if self.mode == "SHAPE_KEYS":
                result = transfer_shape_keys(source, target, self.replace, self.marker_prefix, progress)
            else:
                scene = context.scene
                start, end = ((scene.frame_start, scene.frame_end) if self.use_scene_range
                              else (self.frame_start, self.frame_end))
                result = transfer_animation(source, target, start, end, scene, self.replace, self.marker_prefix,
                                            progress)
        finally:
            wm.progress_end()
        self.report({"INFO"}, summary(source, target, result))


def summary(source, target, result):
    how = "same mesh, direct" if result.direct else (
        ("stored correspondence" if result.reused_correspondence else "correspondence computed")
        + f", {result.unmatched} target triangles unmatched")
    return (f"Transferred {len(result.keys)} shape key{'s' if len(result.keys) != 1 else ''} from "
            f"'{source.name}' to '{target.name}' ({how}) in {result.seconds:.2f} s")


def draw_menu_item(self, context):
    self.layout.separator()
    self.layout.operator(DEFORMKIT_OT_transfer_deformation.bl_idname, icon="MOD_DATA_TRANSFER")


def register():
    """Beside Blender's Transfer Shape Key (object.shape_key_transfer), in the shape-key specials."""
    bpy.types.MESH_MT_shape_key_context_menu.append(draw_menu_item)


def unregister():
    bpy.types.MESH_MT_shape_key_context_menu.remove(draw_menu_item)


classes = (DEFORMKIT_OT_transfer_deformation,)

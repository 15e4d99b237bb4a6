"""App handlers: playback, scrubbing, base-mesh edits, undo and file load re-evaluate stacks.

Every evaluation is skipped when its inputs (parameters, origin frames, weights, base positions)
are unchanged, which is also what stops the handlers from re-entering on their own writes."""
import bpy
from bpy.app.handlers import persistent

from . import evaluation


def _stack_objects(scene):
    return [o for o in scene.objects if o.type == "MESH" and len(o.deformkit.entries) > 0]


@persistent
def on_frame_change(scene, depsgraph=None):
    evaluation.forget_echoes()
    for obj in _stack_objects(scene):
        evaluation.evaluate(obj, reuse_weights=True)


@persistent
def on_depsgraph_update(scene, depsgraph):
    updates = [u for u in depsgraph.updates if isinstance(u.id, (bpy.types.Object, bpy.types.Mesh))]
    if not updates:
        return
    changed = {u.id.original for u in updates}
    moved = {u.id.original for u in updates if u.is_updated_transform}
    for obj in _stack_objects(scene):
        origins = {e.origin for e in obj.deformkit.entries if e.origin is not None}
        if origins & changed or (origins and obj in moved):
            evaluation.evaluate(obj)  # the origin frame in object space changed
        elif obj.data in changed and not evaluation.is_echo_of_own_write(obj):
            evaluation.evaluate(obj)  # the base mesh may have been edited


@persistent
def on_reload(*_args):
    evaluation.forget()
    for scene in bpy.data.scenes:
        for obj in _stack_objects(scene):
            evaluation.evaluate(obj)


HANDLERS = (
    (bpy.app.handlers.frame_change_post, on_frame_change),
    (bpy.app.handlers.depsgraph_update_post, on_depsgraph_update),
    (bpy.app.handlers.undo_post, on_reload),
    (bpy.app.handlers.redo_post, on_reload),
    (bpy.app.handlers.load_post, on_reload),
)


def register():
    for handler_list, fn in HANDLERS:
        if fn not in handler_list:
            handler_list.append(fn)


def unregister():
    for handler_list, fn in HANDLERS:
        if fn in handler_list:
            handler_list.remove(fn)

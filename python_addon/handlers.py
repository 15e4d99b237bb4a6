"""App handlers: playback, scrubbing, base-mesh edits (in Edit Mode too), shape-key values, origin,
lattice and handle-object edits, undo and file load re-evaluate stacks; a "deformkit" modifier that
was applied, converted, removed or copied to another object is noticed here.

Every evaluation is skipped when its inputs (parameters, origin frames, weights, base positions)
are unchanged, which is also what stops the handlers from re-entering on their own writes."""
import bpy
from bpy.app.handlers import persistent

from . import echo, entries, evaluation, follow, lattice_tools, outputs, properties
from .entries import common
from .evaluation import Reason

WATCHED = (bpy.types.Object, bpy.types.Mesh, bpy.types.Lattice, bpy.types.Collection, bpy.types.Key)
# Seconds without updates before the lattices' certificates are computed again: once at the end of
# a drag or of playback, not on every step of it.
LATTICE_CHECK_DELAY = 0.3


# scene name -> the keys (bpy.data.objects' (name, library)) of its mesh objects that have entries.
# Listing them reads every object of the scene, which every depsgraph update would pay (1 ms in a
# scene of 1000 objects, as much again as Blender's own update for a moved object), so the list is
# kept until objects come or go (a collection update: linked, unlinked, deleted, duplicated), a
# file is loaded, undo or redo, or an object not listed gets entries (a setting of one changed, or
# it was updated holding some).
_listed = {}


def _key(obj):
    return obj.name, obj.library.filepath if obj.library else None


def _stack_objects(scene):
    keys = _listed.get(scene.name_full)
    if keys is not None:
        listed = [bpy.data.objects.get(key) for key in keys]
        if None not in listed:
            return [o for o in listed if len(o.deformkit.entries) > 0]
        _listed.clear()  # one was renamed or removed: list them again
    found = [o for o in scene.objects if o.type == "MESH" and len(o.deformkit.entries) > 0]
    _listed[scene.name_full] = [_key(o) for o in found]
    return found


def _list_again_for(obj):
    """obj has entries now and may not be listed (_listed)."""
    if obj.type == "MESH" and not any(_key(obj) in keys for keys in _listed.values()):
        _listed.clear()


def _entry_changed(obj):
    """A property update of obj's stack (properties.on_change): it may be the first entry it has."""
    if isinstance(obj, bpy.types.Object):
        _list_again_for(obj)
    evaluation.request_update(obj)


@persistent
def on_frame_change(scene, depsgraph=None):
    echo.forget()
    for obj in _stack_objects(scene):
        evaluation.evaluate(obj, Reason.FRAME)


def _followed(obj):
    """The objects obj's entries follow (lattices, handle objects), as their kinds say."""
    return {target for e in obj.deformkit.entries for target, _ in entries.followed(e) if target is not None}


def _pointer_gone(obj):
    """An entry whose origin, lattice, handle or cage object was deleted or unlinked, and which does
    not say so yet (its message may be another one), or one with a message, in case the object came back."""
    for e in obj.deformkit.entries:
        pairs = entries.followed(e) + ([(e.origin, e.origin_name)] if "origin" in entries.params(e.type) else [])
        for target, name in pairs:
            if name or target is not None:
                missing = target is None or not target.users_scene
                if missing and (not e.error or (name and name not in e.error)) or (not missing and e.error):
                    return True
    return False


def _copies_let_go(updates):
    """A "deformkit" modifier that shows another object's result (Copy Modifiers) is emptied."""
    for u in updates:
        obj = u.id.original if isinstance(u.id, bpy.types.Object) else None
        if obj is not None and obj.type == "MESH" and outputs.is_copied(obj):
            outputs.let_go_of_copy(obj)


def _remove_orphaned_helpers():
    """Helper objects nothing uses any more (their object was deleted, and its modifier or entries
    with it) go with their meshes, as a modifier's data goes with its object; left, they would stay
    in the object pickers until the file is saved and reopened."""
    for helper in [o for o in bpy.data.objects if o.users == 0 and (outputs.is_helper_object(o) or entries.is_helper(o))]:
        mesh = helper.data
        bpy.data.objects.remove(helper)
        if mesh is not None and mesh.users == 0:
            bpy.data.meshes.remove(mesh)


@persistent
def on_depsgraph_update(scene, depsgraph):
    every = list(depsgraph.updates)
    if any(isinstance(u.id, bpy.types.NodeTree) for u in every):
        follow.groups_touched()  # the modifier's group may be broken: the next step checks it
    updates = [u for u in every if isinstance(u.id, WATCHED)]
    if not updates:
        return
    changed = {u.id.original for u in updates}
    moved = {u.id.original for u in updates if u.is_updated_transform}
    reshaped = {u.id.original for u in updates if u.is_updated_geometry}
    relinked = any(isinstance(u.id, bpy.types.Collection) for u in updates)  # objects deleted or linked
    if relinked:
        _listed.clear()
        _remove_orphaned_helpers()
    for obj in changed:
        if isinstance(obj, bpy.types.Object) and obj.type == "MESH" and len(obj.deformkit.entries) > 0:
            _list_again_for(obj)
    _copies_let_go(updates)
    objects = _stack_objects(scene)
    if any(o in changed for o in objects):
        follow.groups_touched()  # as an edit of its group may show: an update of the objects using it
    schedule_lattice_check(objects)
    for obj in objects:
        mesh_changed = obj.data in changed or (obj.data.shape_keys is not None and obj.data.shape_keys in changed)
        used = _followed(obj)
        # Lattice edits show as an update of the Lattice object and of its data.
        watched = {e.origin for e in obj.deformkit.entries if e.origin is not None} | used \
            | {o.data for o in used if o.type == "LATTICE"}
        if not (relinked or mesh_changed or obj in changed or watched & changed or evaluation.mode_changed(obj)):
            continue  # nothing of its own nor anything it follows changed: the others of a cage drag
        if evaluation.modifier_gone(obj):
            continue  # applied, converted or removed: the entries were removed or turned off
        if relinked and any([common.clear_deleted(e) for e in obj.deformkit.entries]):
            # Deleted in the UI: the fields are cleared at once, as Blender clears a modifier's, and
            # each entry says which object it lost (the rest of the stack keeps evaluating).
            evaluation.evaluate(obj, Reason.LINKS)
            continue
        # The echo of the add-on's own last write is consumed whichever way the update goes on: left
        # waiting, it would pass the next real edit of the mesh for itself. Only the base mesh's
        # own branch trusts it; the others read what they read anyway.
        echoed = mesh_changed and obj.mode != "EDIT" and evaluation.is_echo_of_own_write(obj)
        if evaluation.mode_changed(obj):
            evaluation.evaluate(obj, Reason.MESH)  # Edit Mode entered or left: the input and the result's place change
        elif watched & changed or (watched and obj in moved):
            # The origin frame, the lattice or a handle object changed (or the object moved, which
            # changes them in its space). The input is read again only if the mesh changed too (else
            # as for a setting's edit); either way the mesh update that this write causes needs no second look.
            evaluation.evaluate(obj, Reason.FOLLOWED if mesh_changed else Reason.MOVED)
        elif obj.mode == "EDIT":
            if obj.data in reshaped:  # an edit, not a selection change
                evaluation.evaluate(obj, Reason.EDIT_MODE, depsgraph)
        elif mesh_changed and not echoed:
            evaluation.evaluate(obj, Reason.MESH)  # the base mesh or a shape-key value may have changed
        elif relinked and _pointer_gone(obj):
            evaluation.evaluate(obj, Reason.LINKS)  # show (or clear) the entry's message


def check_lattices():
    """Every Lattice entry's certificate and volume change, computed again where its lattice or
    binding changed (lattice_tools.lattice_bounds), then the panels redrawn. Run by a timer after
    the last update."""
    for obj in [o for scene in bpy.data.scenes for o in _stack_objects(scene)]:
        for index in lattice_tools.lattice_entries(obj):
            lattice_tools.lattice_bounds(obj, index)
    for window in getattr(bpy.context.window_manager, "windows", ()):
        for area in window.screen.areas:
            if area.type == "PROPERTIES":
                area.tag_redraw()
    return None  # once


def schedule_lattice_check(objects):
    """Push the lattice check back to LATTICE_CHECK_DELAY from now, if any of objects has a Lattice entry."""
    if not any(lattice_tools.lattice_entries(o) for o in objects):
        return
    if bpy.app.timers.is_registered(check_lattices):
        bpy.app.timers.unregister(check_lattices)
    bpy.app.timers.register(check_lattices, first_interval=LATTICE_CHECK_DELAY)


@persistent
def on_reload(*_args):
    """Registration and file load: nothing kept is trusted; every stack is evaluated again."""
    evaluation.forget()
    _evaluate_all()


@persistent
def on_undo(*_args):
    """Undo and redo: as on_reload, but the kinds keep what they made of a bind (a Harmonic grid
    solve: seconds at high precision, which an undo would otherwise cost every time)."""
    evaluation.forget_undone()
    _evaluate_all()


def _evaluate_all():
    _listed.clear()
    for scene in bpy.data.scenes:
        objects = _stack_objects(scene)
        if any(e.origin is not None or any(t is not None for t, _ in entries.followed(e))
               for o in objects for e in o.deformkit.entries):
            # Blender 4+ does not save world matrices: at load_post they are unset until the
            # depsgraph runs, and origin and lattice frames, handle motions and the places of cages
            # and controls are made of them.
            with bpy.context.temp_override(scene=scene, view_layer=scene.view_layers[0]):
                bpy.context.evaluated_depsgraph_get()
        for obj in objects:
            evaluation.evaluate(obj, Reason.LOAD)
        schedule_lattice_check(objects)


@persistent
def on_load(*args):
    entries.file_loaded()
    on_reload(*args)


HANDLERS = (
    (bpy.app.handlers.frame_change_post, on_frame_change),
    (bpy.app.handlers.depsgraph_update_post, on_depsgraph_update),
    (bpy.app.handlers.undo_post, on_undo),
    (bpy.app.handlers.redo_post, on_undo),
    (bpy.app.handlers.load_post, on_load),
)


def register():
    properties.on_change = _entry_changed  # property updates re-evaluate (properties._changed)
    for handler_list, fn in HANDLERS:
        if fn not in handler_list:
            handler_list.append(fn)
    # Enabled again in a session: meshes, lattices or cages edited while the add-on was off would
    # show their old results until some other edit, so every stack is evaluated now, as on load. At
    # startup the data is not open yet (restricted) and load_post evaluates the file instead.
    if hasattr(bpy.data, "scenes"):
        on_reload()


def unregister():
    if bpy.app.timers.is_registered(check_lattices):
        bpy.app.timers.unregister(check_lattices)
    for handler_list, fn in HANDLERS:
        if fn in handler_list:
            handler_list.remove(fn)
    properties.on_change = None

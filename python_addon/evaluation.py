"""Evaluation: turn an object's deformkit stack into positions and hand them to Blender.

The base mesh is never written. The stack's result is stored as a per-point position attribute
(and a second one for renders when an entry is hidden in one of them) that a Geometry Nodes
modifier named "deformkit" stores into the positions, so the result takes part in Blender's own
modifier stack, saves with the file and survives with the add-on disabled; removing every entry
removes the modifier and the attributes, which gives back the original mesh bit for bit. A
Subdivide entry, last in the stack, subdivides that result into helper objects whose geometry the
modifier then outputs instead (subdivision.py).
"""
import time
import zlib

import bpy
import numpy as np

from . import lattices, meshdata, native, subdivision, surface
from .meshdata import base_positions, cache_key, vertex_group_weights  # noqa: F401
from .outputs import (ATTR_RENDER, ATTR_VIEWPORT, ATTR_VOLUME, MODIFIER_NAME, NODE_GROUP_NAME,  # noqa: F401
                      EntryError, ensure_modifier, outputs_present, remove_outputs, write_vector_attribute,
                      write_volume_colors)


_evaluating = set()  # session_uids being evaluated: writes below re-enter through handlers
_last_inputs = {}    # cache key -> (fingerprint of the settings, base positions) last written
_own_writes = {}     # cache key -> time of the add-on's last write, whose depsgraph echo is expected
ECHO_WINDOW = 1.0    # seconds within which a depsgraph update of the mesh counts as that echo


class EntryFailed(EntryError):
    """An entry that could not deform the points it was given (found while running the stack)."""

    def __init__(self, index, message):
        super().__init__(message)
        self.index = index


def object_problem(obj):
    """Why deformkit cannot run on `obj`, or '' if it can."""
    if obj.type != "MESH":
        return f"'{obj.name}' is not a mesh; deformkit entries work on meshes"
    if obj.data.shape_keys is not None:
        return "objects with shape keys are not supported yet (shape keys are evaluated before modifiers)"
    if len(obj.data.vertices) == 0:
        return "the mesh has no vertices"
    if obj.data.users > 1 + int(obj.data.use_fake_user):
        return (f"the mesh '{obj.data.name}' is shared by {obj.data.users} users; deformkit stores its result "
                "in the mesh, so make it single user (Object > Relations > Make Single User)")
    mod = obj.modifiers.get(MODIFIER_NAME)
    if mod is not None and mod.type != "NODES":
        return f"a {mod.type.lower()} modifier named '{MODIFIER_NAME}' is in the way; rename it"
    if not native.available():
        return native.IMPORT_ERROR
    return ""


def origin_matrix(obj, entry):
    """The origin object's frame in `obj`'s local space, as Simple Deform uses it."""
    if entry.origin is None:
        if entry.origin_name:
            raise EntryError(f"origin object '{entry.origin_name}' no longer exists")
        return None
    if entry.origin == obj:  # Blender ignores an object that is its own origin
        return None
    if not entry.origin.users_scene:  # deleted in the UI: unlinked, but still referenced here
        raise EntryError(f"origin object '{entry.origin.name}' was deleted (it is in no scene)")
    return np.array(obj.matrix_world.inverted() @ entry.origin.matrix_world)


def entry_weights(obj, entry, reuse_weights=False):
    """The entry's vertex-group weights, or None. They are read by a per-vertex loop; with
    reuse_weights, those read last time are used (parameter edits and frame changes do not change
    them; edits of the mesh re-read them)."""
    if not entry.vertex_group:
        return None
    return meshdata.group_weights(obj, entry.vertex_group, reuse_weights)


def entry_setup(obj, entry, reuse_weights=False):
    """(deformer, fingerprint of its settings, lattices.Setup, surface.Setup, subdivision.Setup or
    None) for one entry. Laplacian and Subdivide entries have no pointwise deformer (None): they
    need the whole mesh."""
    if entry.type == "SUBDIVIDE":
        sub = subdivision.setup(obj, entry)
        return None, sub.fingerprint, sub
    if entry.type == "LAPLACIAN":
        laplacian = surface.setup(obj, entry, reuse_weights)
        return None, laplacian.fingerprint, laplacian
    weights = entry_weights(obj, entry, reuse_weights)
    if entry.type == "LATTICE":
        if weights is not None and entry.invert_vertex_group:
            weights = 1.0 - weights  # the Lattice modifier's inversion; ungrouped vertices get 1
        lattice = lattices.setup(obj, entry, weights)
        return lattice.deformer, (entry.type, entry.show_viewport, entry.show_render, lattice.fingerprint), lattice
    lo, hi = entry.limits
    deformer = native.dk.SimpleDeform(
        mode=entry.type, angle=entry.amount, deform_axis=entry.deform_axis,
        origin=origin_matrix(obj, entry),
        limits=(min(lo, hi), hi),  # Blender clamps the lower limit to the upper one
        lock_x=entry.lock_x, lock_y=entry.lock_y, lock_z=entry.lock_z, weights=weights,
        invert_weights=bool(weights is not None and entry.invert_vertex_group))
    return deformer, _fingerprint(obj, entry, deformer), None


def entry_deformer(obj, entry, reuse_weights=False):
    """The deformkit deformer for this entry: Simple Deform's map, or the entry's lattice (None
    for a Laplacian entry)."""
    return entry_setup(obj, entry, reuse_weights)[0]


def _fingerprint(obj, entry, deformer):
    origin = None if entry.origin is None else tuple(map(tuple, obj.matrix_world.inverted() @ entry.origin.matrix_world))
    weights = deformer.weights
    return (entry.type, entry.show_viewport, entry.show_render, entry.amount, entry.deform_axis,
            tuple(entry.limits), entry.lock_x, entry.lock_y, entry.lock_z, entry.invert_vertex_group, origin,
            None if weights is None else zlib.crc32(weights.tobytes()))


def _set_if_changed(owner, prop, value):
    if getattr(owner, prop) != value:
        setattr(owner, prop, value)


def evaluate(obj, force=False, reuse_base=False, expect_echo=False, reuse_weights=None):
    """Recompute `obj`'s deformkit result. Returns True if it wrote a new result.

    With reuse_base, the base positions of the last evaluation are used when the settings changed
    (a parameter edit); with expect_echo, the depsgraph update this write causes is recognised as
    its echo (see is_echo_of_own_write). reuse_weights (default: as reuse_base) keeps the
    vertex-group weights read last time. On any problem the
    message goes on the stack or the entry and the mesh is left as it was."""
    uid = cache_key(obj)
    if uid in _evaluating or obj.mode == "EDIT":  # in edit mode the base mesh is stale until exit
        return False
    stack = obj.deformkit
    problem = object_problem(obj)
    _set_if_changed(stack, "error", problem)
    if problem:
        return False
    _evaluating.add(uid)
    try:
        if len(stack.entries) == 0:
            subdivision.discard(obj)
            subdivision.forget(uid)
            remove_outputs(obj)
            _last_inputs.pop(uid, None)
            surface.forget(uid)
            return True
        cached = _last_inputs.get(uid)
        if reuse_base and cached is not None and len(cached[1]) == len(obj.data.vertices):
            base = cached[1]
        else:
            base = base_positions(obj.data)
        built, key, failed, sub = [], [len(base), stack.show_volume_ratio], False, None
        surface.keep_only(uid, {e.bind_id for e in stack.entries if e.type == "LAPLACIAN"})
        for index, entry in enumerate(stack.entries):
            try:
                if sub is not None:
                    raise EntryError(f"comes after the Subdivide entry '{sub.entry.name}', which must be the last "
                                     "entry (it changes the topology): move this entry above it")
                deformer, fingerprint, special = entry_setup(
                    obj, entry, reuse_base if reuse_weights is None else reuse_weights)
            except ValueError as exc:
                _set_if_changed(entry, "error", str(exc))
                failed = True
                continue
            if entry.type == "SUBDIVIDE":
                sub = special  # its error is cleared once it has subdivided
            else:
                _set_if_changed(entry, "error", "")
                built.append((index, entry, deformer, special))
            key.append(fingerprint)
        if failed:
            return False
        key = tuple(key)
        if (not force and cached is not None and cached[0] == key and np.array_equal(cached[1], base)
                and outputs_present(obj)):
            return False
        viewport = [b for b in built if b[1].show_viewport]
        render = [b for b in built if b[1].show_render]
        pieces = [] if stack.show_volume_ratio else None
        try:
            positions = _deformed(uid, "viewport", viewport, base, pieces)
            same = [b[0] for b in render] == [b[0] for b in viewport]
            render_positions = positions if same else _deformed(uid, "render", render, base)
        except EntryFailed as exc:
            _set_if_changed(stack.entries[exc.index], "error", str(exc))
            return False
        except ValueError as exc:
            _set_if_changed(stack, "error", str(exc))
            return False
        subdivided = None
        if sub is not None:  # before anything is written: a refused subdivision leaves the result as it was
            try:
                subdivided = subdivision.results(uid, sub, positions, render_positions)
            except EntryError as exc:
                _set_if_changed(sub.entry, "error", str(exc))
                return False
            _set_if_changed(sub.entry, "error", "")
        mesh = obj.data
        split = render_positions is not positions
        write_vector_attribute(mesh, ATTR_VIEWPORT, positions)
        if split:
            write_vector_attribute(mesh, ATTR_RENDER, render_positions)
        elif ATTR_RENDER in mesh.attributes:
            mesh.attributes.remove(mesh.attributes[ATTR_RENDER])
        if stack.show_volume_ratio and viewport:
            # Laplacian entries have no Jacobian: det J of the others, each run at its own input.
            ratio = np.ones(len(base))
            for deformers, points in pieces:
                ratio *= native.dk.Stack(deformers).volume_ratio(points)
            write_volume_colors(mesh, ratio)
        elif ATTR_VOLUME in mesh.attributes:
            mesh.attributes.remove(mesh.attributes[ATTR_VOLUME])
        if sub is None:  # no Subdivide entry (any more): its refined topologies go
            subdivision.forget(uid)
        helpers = subdivided and subdivision.write(obj, sub, subdivided)  # None: nothing subdivided
        subdivision.discard(obj, keep=helpers or ())
        ensure_modifier(obj, split, helpers)
        mesh.update()
        _last_inputs[uid] = (key, base)
        if expect_echo:
            _own_writes[uid] = time.monotonic()
        return True
    finally:
        _evaluating.discard(uid)


def _deformed(uid, kind, built, base, pieces=None):
    """Run the entries in order: runs of Barr entries as one dk.Stack, each lattice entry through
    its binding (kept per object, entry and viewport/render, see lattices.deform), each Laplacian
    entry through its solver. `pieces`, if a list, receives (deformers, their input) for each
    stretch of entries between Laplacian entries: the factors of the volume ratio."""
    points, pending, piece, piece_input = base, [], [], base
    for index, _entry, deformer, special in built:
        if special is None:
            pending.append(deformer)
            piece.append(deformer)
            continue
        if pending:
            points, pending = native.dk.Stack(pending).deform(points), []
        if isinstance(special, surface.Setup):
            if pieces is not None and piece:
                pieces.append((piece, piece_input))
            try:
                points = surface.deform(special, points)
            except ValueError as exc:
                raise EntryFailed(index, str(exc)) from exc
            piece, piece_input = [], points
        else:
            points = lattices.deform((uid, index, kind), special, points)
            piece.append(deformer)
    if pending:
        points = native.dk.Stack(pending).deform(points)
    if pieces is not None and piece:
        pieces.append((piece, piece_input))
    return base.copy() if points is base else points


def entry_input(obj, index, kind="viewport"):
    """The points entry `index` deforms: the base mesh through the earlier entries shown in the
    viewport (or render), in the object's space. Raises EntryError for a problem on the way."""
    built = []
    for i, entry in enumerate(obj.deformkit.entries[:index]):
        if entry.type == "SUBDIVIDE":
            raise EntryError(f"{entry.name}: a Subdivide entry must be the last entry")
        if (entry.show_viewport if kind == "viewport" else entry.show_render):
            try:
                deformer, _, special = entry_setup(obj, entry, reuse_weights=True)
            except ValueError as exc:
                raise EntryError(f"{entry.name}: {exc}") from exc
            built.append((i, entry, deformer, special))
    try:
        return _deformed(cache_key(obj), kind, built, base_positions(obj.data))
    except EntryFailed as exc:
        raise EntryError(f"{obj.deformkit.entries[exc.index].name}: {exc}") from exc


def is_echo_of_own_write(obj):
    """True when a depsgraph update of obj's mesh is the echo of the add-on's own attribute write
    (within ECHO_WINDOW of it, with the vertex count unchanged), so the base need not be re-read.

    Any Python read of the positions makes Blender copy them out of their shared storage, which on
    a large mesh costs as much as Blender's own Simple Deform, so the echo is judged without one.
    The one case this misses: a script that changes a parameter and then edits base positions
    before any depsgraph update. Such scripts should call api.evaluate(obj); api.evaluated_positions,
    frame changes, undo, redo and file load compare every position anyway."""
    uid = cache_key(obj)
    written, cached = _own_writes.pop(uid, None), _last_inputs.get(uid)
    if written is None or cached is None or time.monotonic() - written > ECHO_WINDOW:
        return False
    return len(obj.data.vertices) == len(cached[1])


def forget_echoes():
    """A frame change evaluates without passing through depsgraph_update_post, so an echo still
    expected then would be mistaken for the next real edit of the mesh."""
    _own_writes.clear()


def request_update(obj):
    """Called by property updates: re-evaluate at once (parameter edits, keyframes, drivers)."""
    if isinstance(obj, bpy.types.Object) and obj.type == "MESH":
        evaluate(obj, reuse_base=True, expect_echo=True)


def forget(obj=None):
    """Drop cached fingerprints, weights, lattice bindings and Laplacian solvers (after undo or
    file load, when they may be stale; the solvers are built again from the saved rest)."""
    key = None if obj is None else cache_key(obj)
    if obj is None:
        _last_inputs.clear()
        _own_writes.clear()
    else:
        _last_inputs.pop(key, None)
        _own_writes.pop(key, None)
    meshdata.forget(key)
    lattices.forget(key)
    surface.forget(key)
    subdivision.forget(key)


def apply_entry(obj, index):
    """Bake entry `index` into the base mesh and remove it. Returns a warning or ''."""
    stack = obj.deformkit
    if obj.mode == "EDIT":
        raise EntryError("apply: leave edit mode first (edit mode holds its own copy of the mesh)")
    entry = stack.entries[index]
    base = base_positions(obj.data)
    deformer, _, special = entry_setup(obj, entry)
    if entry.type == "SUBDIVIDE":
        subdivision.bake(obj, entry)  # the base mesh's own topology changes, as with Blender's Apply
    else:
        # A Laplacian entry takes its handles from the base mesh (INCOMING).
        deformed = surface.deform(special, base) if entry.type == "LAPLACIAN" else deformer.deform(base)
        obj.data.vertices.foreach_set("co", deformed.ravel())
    stack.entries.remove(index)
    stack.active_index = min(stack.active_index, max(0, len(stack.entries) - 1))
    evaluate(obj, force=True)
    return "" if index == 0 else "Applied entry was not first, result may not be as expected"


def evaluated_positions(obj, depsgraph=None):
    """Positions of the fully evaluated object (all modifiers), as float32 (n, 3). The stack is
    brought up to date first, so a script that just edited the base mesh reads a current result."""
    stack = getattr(obj, "deformkit", None)  # None while the add-on is unregistered
    if depsgraph is None and obj.type == "MESH" and stack is not None and len(stack.entries) > 0:
        evaluate(obj)
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        return base_positions(mesh)
    finally:
        evaluated.to_mesh_clear()

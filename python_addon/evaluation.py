"""Evaluation: turn an object's deformkit stack into positions and hand them to Blender.

The base mesh is never written. The stack's result is stored as a per-point position attribute
(and a second one for renders when an entry is hidden in one of them) that a Geometry Nodes
modifier named "deformkit" stores into the positions, so the result takes part in Blender's own
modifier stack, saves with the file and survives with the add-on disabled; removing every entry
removes the modifier and the attributes, which gives back the original mesh bit for bit. A
Subdivide entry, last in the stack, subdivides that result into helper objects whose geometry the
modifier then outputs instead (entries/subdivide.py). Each entry runs through its kind (entries/).
"""
import time

import bpy
import numpy as np

from . import cache, entries, native
from .entries import common, subdivide
from .meshdata import base_positions, cache_key, vertex_group_weights  # noqa: F401
from .outputs import (ATTR_RENDER, ATTR_VIEWPORT, ATTR_VOLUME, MODIFIER_NAME, NODE_GROUP_NAME,  # noqa: F401
                      EntryError, ensure_modifier, outputs_present, remove_outputs, write_vector_attribute,
                      write_volume_colors)


_evaluating = set()  # session_uids being evaluated: writes below re-enter through handlers
# In the cache: "inputs", (cache key,) -> (fingerprint of the settings, base positions, {index: message}
# of the entries that failed on them) last written;
# "echo", (cache key,) -> time of the add-on's last write, whose depsgraph echo is expected.
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
    return entries.barr.origin_matrix(obj, entry)


def entry_weights(obj, entry, reuse_weights=False):
    """The entry's vertex-group weights as it applies them (inverted with Invert), or None."""
    return common.influence_weights(obj, entry, reuse_weights)


def entry_setup(obj, entry, reuse_weights=False):
    """(kind, common.Prepared) for one entry: its kind's setup, with the fingerprint that tells
    whether its result may have changed."""
    kind = entries.kind(entry)
    prepared = kind.setup(obj, entry, reuse_weights)
    fingerprint = (entry.type, entry.show_viewport, entry.show_render, prepared.fingerprint)
    return kind, prepared._replace(fingerprint=fingerprint)


def entry_deformer(obj, entry, reuse_weights=False):
    """The deformkit deformer for this entry: Simple Deform's map, or the entry's lattice (None
    for kinds without a pointwise map: Laplacian, Subdivide)."""
    return entry_setup(obj, entry, reuse_weights)[1].deformer


def _set_if_changed(owner, prop, value):
    if getattr(owner, prop) != value:
        setattr(owner, prop, value)


def evaluate(obj, force=False, reuse_base=False, expect_echo=False, reuse_weights=None):
    """Recompute `obj`'s deformkit result. Returns True if it wrote a new result.

    With reuse_base, the base positions of the last evaluation are used when the settings changed
    (a parameter edit); with expect_echo, the depsgraph update this write causes is recognised as
    its echo (see is_echo_of_own_write). reuse_weights (default: as reuse_base) keeps the
    vertex-group weights read last time. A problem of the object's goes on the stack and leaves the
    mesh as it was; an entry that fails shows its message and is skipped, the others still run."""
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
            subdivide.discard(obj)
            remove_outputs(obj)
            cache.forget(uid)
            return True
        cached = cache.get("inputs", (uid,))
        if reuse_base and cached is not None and len(cached[1]) == len(obj.data.vertices):
            base = cached[1]
        else:
            base = base_positions(obj.data)
        built, key, sub = [], [len(base), stack.show_volume_ratio], None
        entries.prune(uid, stack.entries)
        for index, entry in enumerate(stack.entries):
            try:
                if sub is not None:
                    raise EntryError(f"comes after the {entries.LABELS[sub.entry.type]} entry '{sub.entry.name}', "
                                     "which must be the last entry (it changes the topology): move this entry "
                                     "above it")
                kind, prepared = entry_setup(obj, entry, reuse_base if reuse_weights is None else reuse_weights)
            except ValueError as exc:
                # As Blender skips a modifier it cannot run: its input goes on to the next entry.
                _set_if_changed(entry, "error", str(exc))
                key.append((index, str(exc)))
                continue
            if kind.LAST:
                sub, sub_index = prepared.data, index  # its error is cleared once it has subdivided
            else:
                _set_if_changed(entry, "error", prepared.note)  # a note: the entry still runs
                built.append((index, entry, kind, prepared))
            key.append(prepared.fingerprint)
        key = tuple(key)
        if (not force and cached is not None and cached[0] == key and np.array_equal(cached[1], base)
                and outputs_present(obj)):
            for index, message in cached[2].items():  # the entries that failed on these inputs still do
                _set_if_changed(stack.entries[index], "error", message)
            return False
        viewport = [b for b in built if b[1].show_viewport]
        render = [b for b in built if b[1].show_render]
        pieces = [] if stack.show_volume_ratio else None
        failures = {}  # entry index -> message of the entries that failed on their input (skipped)
        try:
            positions = _deformed(uid, "viewport", viewport, base, pieces, failures)
            same = [b[0] for b in render] == [b[0] for b in viewport]
            render_positions = positions if same else _deformed(uid, "render", render, base, failures=failures)
        except ValueError as exc:
            _set_if_changed(stack, "error", str(exc))
            return False
        subdivided = None
        if sub is not None:
            try:
                subdivided = subdivide.results(uid, sub, positions, render_positions)
            except EntryError as exc:  # skipped as any failing entry: the cage is shown
                failures[sub_index] = str(exc)
            else:
                _set_if_changed(sub.entry, "error", "")
        for index, message in failures.items():
            _set_if_changed(stack.entries[index], "error", message)
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
            subdivide.forget(uid)
        helpers = subdivided and subdivide.write(obj, sub, subdivided)  # None: nothing subdivided
        subdivide.discard(obj, keep=helpers or ())
        ensure_modifier(obj, split, helpers)
        mesh.update()
        cache.put("inputs", (uid,), (key, base, failures))
        if expect_echo:
            cache.put("echo", (uid,), time.monotonic())
        return True
    finally:
        _evaluating.discard(uid)


def _deformed(uid, kind, built, base, pieces=None, failures=None):
    """Run the entries in order: runs of stackable (Barr) entries as one dk.Stack, each other
    entry through its kind (a lattice through its binding, kept per object, entry and
    viewport/render; a Laplacian entry through its solver). `pieces`, if a list, receives
    (deformers, their input) for each stretch of entries between those without a Jacobian: the
    factors of the volume ratio. `failures`, if a dict, receives {index: message} of the entries
    that failed on their input, which are skipped (their input goes on, as Blender skips a modifier
    that fails); without it the first failure raises EntryFailed."""
    points, pending, piece, piece_input = base, [], [], base
    for index, _entry, entry_kind, prepared in built:
        if entry_kind.STACKABLE:
            pending.append(prepared.deformer)
            piece.append(prepared.deformer)
            continue
        if pending:
            points, pending = native.dk.Stack(pending).deform(points), []
        if prepared.deformer is None and pieces is not None and piece:  # no Jacobian: the piece ends here
            pieces.append((piece, piece_input))
        try:
            points = entry_kind.deform((uid, index, kind), prepared, points)
        except EntryError as exc:
            if failures is None:
                raise EntryFailed(index, str(exc)) from exc
            failures.setdefault(index, str(exc))
            continue  # skipped: contributes no factor to the volume ratio either
        if prepared.deformer is None:
            piece, piece_input = [], points
        else:
            piece.append(prepared.deformer)
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
        if entries.kind(entry).LAST:
            raise EntryError(f"{entry.name}: a {entries.LABELS[entry.type]} entry must be the last entry")
        if (entry.show_viewport if kind == "viewport" else entry.show_render):
            try:
                built.append((i, entry, *entry_setup(obj, entry, reuse_weights=True)))
            except ValueError as exc:
                raise EntryError(f"{entry.name}: {exc}") from exc
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
    written, cached = cache.pop("echo", (uid,)), cache.get("inputs", (uid,))
    if written is None or cached is None or time.monotonic() - written > ECHO_WINDOW:
        return False
    return len(obj.data.vertices) == len(cached[1])


def forget_echoes():
    """A frame change evaluates without passing through depsgraph_update_post, so an echo still
    expected then would be mistaken for the next real edit of the mesh."""
    cache.forget(space="echo")


def request_update(obj):
    """Called by property updates: re-evaluate at once (parameter edits, keyframes, drivers)."""
    if isinstance(obj, bpy.types.Object) and obj.type == "MESH":
        evaluate(obj, reuse_base=True, expect_echo=True)


def forget(obj=None):
    """Drop cached fingerprints, weights, lattice bindings, Laplacian solvers and refined
    topologies (after undo or file load, when they may be stale; the solvers are built again from
    the saved rest)."""
    cache.forget(None if obj is None else cache_key(obj))


def apply_entry(obj, index):
    """Bake entry `index` into the base mesh and remove it. Returns a warning or ''."""
    stack = obj.deformkit
    if obj.mode == "EDIT":
        raise EntryError("apply: leave edit mode first (edit mode holds its own copy of the mesh)")
    entry = stack.entries[index]
    base = base_positions(obj.data)
    kind, prepared = entry_setup(obj, entry)
    kind.apply(obj, entry, prepared, base)
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

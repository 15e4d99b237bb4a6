"""Evaluation: turn an object's deformkit stack into a result and hand it to Blender.

The base mesh is never written. The entries deform the points Blender's first modifier gets (the
shape keys mixed, the edit mesh's in Edit Mode: meshdata.input_positions), and the result is stored
as offsets from them that a Geometry Nodes modifier named "deformkit" adds (outputs.py): in the
object's own mesh, or in a per-object helper in Edit Mode and on a mesh shared by linked
duplicates. So the result takes part in Blender's own modifier stack, saves with the file and
survives with the add-on disabled; removing every entry removes the modifier and the attributes,
which gives back the original mesh bit for bit. A Subdivide entry, last in the stack, subdivides
that result into helper objects whose geometry the modifier then outputs instead
(entries/subdivide.py). Each entry runs through its kind (entries/).
"""
import functools
import time

import bpy
import numpy as np

from . import cache, entries, native, outputs
from .entries import common, subdivide
from .meshdata import base_positions, cache_key, input_positions, vertex_group_weights  # noqa: F401
from .errors import EntryError
from .outputs import (ATTR_OFFSET, ATTR_OFFSET_RENDER, ATTR_VOLUME, MODIFIER_NAME, NODE_GROUP_NAME,  # noqa: F401
                      remove_outputs)


_evaluating = set()  # session_uids being evaluated: writes below re-enter through handlers
# In the cache: "inputs", (cache key,) -> (fingerprint of the settings, input positions, {index:
# message} of the entries that failed on them) last written;
# "echo", (cache key,) -> time of the add-on's last write into the object's own mesh, whose
# depsgraph echo is expected.
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
    if len(obj.data.vertices) == 0 and obj.mode != "EDIT":
        return "the mesh has no vertices"
    mod = obj.modifiers.get(MODIFIER_NAME)
    if mod is not None and mod.type != "NODES":
        return f"a {mod.type.lower()} modifier named '{MODIFIER_NAME}' is in the way; rename it"
    if not native.available():
        return native.IMPORT_ERROR
    return ""


def shared_mesh(obj):
    """True when other objects use obj's mesh too (linked duplicates): the result is kept per object."""
    return obj.data.users > 1 + int(obj.data.use_fake_user)


def shown(entry, kind, editing):
    """Whether the entry runs in the viewport (in Edit Mode: only with its Edit Mode toggle) or in renders."""
    if kind == "render":
        return entry.show_render
    return entry.show_viewport and (entry.show_in_editmode or not editing)


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


def evaluate(obj, force=False, reuse_base=False, expect_echo=False, reuse_weights=None, depsgraph=None):
    """Recompute `obj`'s deformkit result. Returns True if it wrote a new result.

    With reuse_base, the input positions of the last evaluation are used when the settings changed
    (a parameter edit); with expect_echo, the depsgraph update this write causes is recognised as
    its echo (see is_echo_of_own_write). reuse_weights (default: as reuse_base) keeps the
    vertex-group weights read last time. depsgraph: the one that just evaluated an edit (Edit Mode
    reads its input from it). A problem of the object's goes on the stack and leaves the mesh as it
    was; an entry that fails shows its message and is skipped, the others still run."""
    uid = cache_key(obj)
    if uid in _evaluating:
        return False
    stack = obj.deformkit
    problem = object_problem(obj)
    _set_if_changed(stack, "error", problem)
    if problem:
        return False
    _evaluating.add(uid)
    try:
        editing = obj.mode == "EDIT"
        if len(stack.entries) == 0 or not any(e.show_viewport or e.show_render for e in stack.entries):
            # Nothing shown anywhere: the original mesh, as with every modifier hidden.
            subdivide.discard(obj)
            remove_outputs(obj, mesh_attributes=not editing)  # Edit Mode: the edit mesh holds them
            cache.forget(uid)
            return True
        weights = reuse_base if reuse_weights is None else reuse_weights
        cached = cache.get("inputs", (uid,))
        count = len(obj.data.vertices) if not editing else None
        if reuse_base and cached is not None and (count is None or len(cached[1]) == count):
            base = cached[1]
        else:
            base = input_positions(obj, weights, depsgraph)
        per_object = editing or shared_mesh(obj)
        built, key, sub = [], [len(base), stack.show_volume_ratio, editing, per_object], None
        entries.prune(uid, stack.entries)
        for index, entry in enumerate(stack.entries):
            try:
                if sub is not None:
                    raise EntryError(f"comes after the {entries.LABELS[sub.entry.type]} entry '{sub.entry.name}', "
                                     "which must be the last entry (it changes the topology): move this entry "
                                     "above it")
                kind, prepared = entry_setup(obj, entry, weights)
            except ValueError as exc:
                # As Blender skips a modifier it cannot run: its input goes on to the next entry.
                _set_if_changed(entry, "error", str(exc))
                key.append((index, str(exc)))
                continue
            if kind.LAST:
                if not editing or entry.show_in_editmode:
                    sub, sub_index = prepared.data, index  # its error is cleared once it has subdivided
            else:
                _set_if_changed(entry, "error", prepared.note)  # a note: the entry still runs
                built.append((index, entry, kind, prepared))
            key.append((prepared.fingerprint, entry.show_in_editmode))
        key = tuple(key)
        if (not force and cached is not None and cached[0] == key and np.array_equal(cached[1], base)
                and _outputs_present(obj, per_object, sub is not None)):
            for index, message in cached[2].items():  # the entries that failed on these inputs still do
                _set_if_changed(stack.entries[index], "error", message)
            _edit_mode_toggles(obj, stack)
            return False
        viewport = [b for b in built if shown(b[1], "viewport", editing)]
        render = [b for b in built if shown(b[1], "render", editing)]
        pieces = [] if stack.show_volume_ratio else None
        failures = {}  # entry index -> message of the entries that failed on their input (skipped)
        same = [b[0] for b in render] == [b[0] for b in viewport]
        # The common case (own mesh, one result for viewport and render): the offsets are computed
        # straight into the mesh's attribute (outputs.vector_attribute_memory), the cheapest hand-over.
        in_place = same and sub is None and not per_object and not editing
        try:
            if in_place:
                offsets = _deformed(uid, "viewport", viewport, base, pieces, failures, offsets_into=functools.partial(
                    outputs.vector_attribute_memory, obj.data, ATTR_OFFSET, len(base)))
                positions = render_positions = None
            else:
                positions = _deformed(uid, "viewport", viewport, base, pieces, failures)
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
        ratio = None
        if stack.show_volume_ratio and viewport:
            # Laplacian entries have no Jacobian: det J of the others, each run at its own input.
            ratio = np.ones(len(base))
            for deformers, points in pieces:
                ratio *= native.dk.Stack(deformers).volume_ratio(points)
        if sub is None:  # no Subdivide entry (any more): its refined topologies go
            subdivide.forget(uid)
        helpers = subdivided and subdivide.write(obj, sub, subdivided)  # None: nothing subdivided
        subdivide.discard(obj, keep=helpers or ())
        # In place: on a large mesh a second copy of the points costs as much as the deformation.
        render_offsets = None if render_positions is positions else np.subtract(render_positions, base,
                                                                                 out=render_positions)
        if not in_place:
            offsets = np.subtract(positions, base, out=positions)
        if helpers:
            outputs.ensure_modifier(obj, "subdivided", list(zip(outputs.HELPER_INPUTS, helpers))
                                    + [(outputs.VERTICES_INPUT, len(base))])
        elif per_object:
            helper = outputs.result_helper(obj)
            outputs.write_result_helper(helper, offsets, render_offsets, ratio)
            outputs.ensure_modifier(obj, "per_object_volume" if ratio is not None else "per_object",
                                    [(outputs.RESULT_INPUT, helper)])
        else:
            outputs.ensure_modifier(obj, "offsets_split" if render_offsets is not None else "offsets")
        if not editing:
            # Under a Subdivide entry's result too: the cage's offsets, for stored_positions (batch previews).
            _write_own_mesh(obj, None if per_object else (None if in_place else offsets, render_offsets), ratio)
        offsets = None  # in place, a view of Blender's memory: not to be kept
        if not per_object:
            outputs.discard_result_helper(obj)
        _edit_mode_toggles(obj, stack)
        cache.put("inputs", (uid,), (key, base, failures))
        cache.put("mode", (uid,), obj.mode)
        _set_if_changed(stack, "notice", "")
        if expect_echo and not editing:
            cache.put("echo", (uid,), time.monotonic())
        return True
    finally:
        _evaluating.discard(uid)


def _write_own_mesh(obj, offsets, ratio):
    """The offsets (viewport or None when written in place, render or None) and volume colors in
    obj's own mesh; with offsets None (the result is elsewhere) none of them: a shared mesh's would
    show on every object using it."""
    mesh = obj.data
    outputs.remove_attributes(mesh, outputs.LEGACY_ATTRIBUTES)
    if offsets is None:
        outputs.remove_attributes(mesh, outputs.OUTPUT_ATTRIBUTES)
    else:
        viewport, render = offsets
        if viewport is not None:  # None: written in place already
            outputs.write_vector_attribute(mesh, ATTR_OFFSET, viewport)
        if render is not None:
            outputs.write_vector_attribute(mesh, ATTR_OFFSET_RENDER, render)
        else:
            outputs.remove_attributes(mesh, (ATTR_OFFSET_RENDER,))
        if ratio is not None:
            outputs.write_volume_colors(mesh, ratio)
        else:
            outputs.remove_attributes(mesh, (ATTR_VOLUME,))
    mesh.update()


def _edit_mode_toggles(obj, stack):
    """The modifier's Edit Mode and On Cage follow the entries': shown in Edit Mode when one entry
    is, on the cage when the last entry shown there is (one modifier shows the whole stack's result)."""
    mod = outputs.our_modifier(obj)
    if mod is None:
        return
    in_edit = [e for e in stack.entries if e.show_viewport and e.show_in_editmode]
    _set_if_changed(mod, "show_in_editmode", bool(in_edit))
    _set_if_changed(mod, "show_on_cage", bool(in_edit) and in_edit[-1].show_on_cage)


def _outputs_present(obj, per_object, subdivided):
    kind = outputs.modifier_kind(obj)
    if kind is None:
        return False
    if subdivided:
        return kind == "subdivided" and None not in outputs.helper_objects(obj)
    if per_object:
        return kind.startswith("per_object") and outputs.modifier_input(obj, outputs.RESULT_INPUT) is not None
    return kind.startswith("offsets") and ATTR_OFFSET in obj.data.attributes


def mode_changed(obj):
    """True when obj entered or left Edit Mode since its last evaluation."""
    seen = cache.get("mode", (cache_key(obj),))
    return seen is not None and seen != obj.mode


def modifier_gone(obj):
    """Notice a "deformkit" modifier that the user applied (Ctrl+A), converted (Object > Convert >
    Mesh) or removed, so the entries do not deform the result a second time: the mesh changed with
    it (its result is in the mesh) and the entries are removed; else they are turned off, as if the
    modifier were hidden. Returns True if it acted."""
    uid = cache_key(obj)
    cached = cache.get("inputs", (uid,))
    if cached is None or uid in _evaluating or obj.modifiers.get(MODIFIER_NAME) is not None:
        return False
    stack = obj.deformkit
    cache.forget(uid)
    base = None if obj.mode == "EDIT" else input_positions(obj)
    if base is None or np.array_equal(base, cached[1]):
        for entry in stack.entries:
            entry.show_viewport = entry.show_render = False
        stack.notice = ("The 'deformkit' modifier was removed, so the entries were turned off: turn one on to "
                        "show them again (the modifier comes back)")
    else:
        subdivide.discard(obj)
        stack.entries.clear()
        stack.active_index = 0
        outputs.remove_outputs(obj)
        stack.notice = ("The 'deformkit' modifier was applied: its result is in the mesh now, so the entries "
                        "were removed (Ctrl+Z brings them back)")
    return True


def stored_positions(obj, kind="viewport"):
    """The result the "deformkit" modifier shows (viewport or render; under a Subdivide entry, the
    cage it subdivides), from the stored offsets and the input of the last evaluation, float32
    (n, 3); None when there is none."""
    cached = cache.get("inputs", (cache_key(obj),))
    mod_kind = outputs.modifier_kind(obj)
    if cached is None or mod_kind is None:
        return None
    owner = outputs.modifier_input(obj, outputs.RESULT_INPUT).data if mod_kind.startswith("per_object") else obj.data
    if ATTR_OFFSET not in owner.attributes:
        return None
    name = ATTR_OFFSET_RENDER if kind == "render" and ATTR_OFFSET_RENDER in owner.attributes else ATTR_OFFSET
    offsets = np.empty(len(cached[1]) * 3, np.float32)
    owner.attributes[name].data.foreach_get("vector", offsets)
    return cached[1] + offsets.reshape(-1, 3)


def _deformed(uid, kind, built, base, pieces=None, failures=None, offsets_into=None):
    """Run the entries in order: runs of stackable (Barr) entries as one dk.Stack, each other
    entry through its kind (a lattice through its binding, kept per object, entry and
    viewport/render; a Laplacian entry through its solver). `pieces`, if a list, receives
    (deformers, their input) for each stretch of entries between those without a Jacobian: the
    factors of the volume ratio. `failures`, if a dict, receives {index: message} of the entries
    that failed on their input, which are skipped (their input goes on, as Blender skips a modifier
    that fails); without it the first failure raises EntryFailed.

    offsets_into: a function giving a float32 (n, 3) array (Blender's own attribute memory); with
    it, the result minus `base` is computed into that array and returned, the last step writing
    straight into it, with no temporary result and no copy."""
    points, pending, piece, piece_input = base, [], [], base
    out = None  # offsets_into's array, once asked for
    for position, (index, _entry, entry_kind, prepared) in enumerate(built):
        if entry_kind.STACKABLE:
            pending.append(prepared.deformer)
            piece.append(prepared.deformer)
            continue
        if pending:
            points, pending = native.dk.Stack(pending).deform(points), []
        if prepared.deformer is None and pieces is not None and piece:  # no Jacobian: the piece ends here
            pieces.append((piece, piece_input))
        into = {}
        if offsets_into is not None and position == len(built) - 1 and getattr(entry_kind, "DEFORMS_INTO", False) \
                and points.dtype == np.float32:
            out = offsets_into()
            into = {"out": out}
        try:
            points = entry_kind.deform((uid, index, kind), prepared, points, **into)
        except EntryError as exc:
            if failures is None:
                raise EntryFailed(index, str(exc)) from exc
            failures.setdefault(index, str(exc))
            continue  # skipped: contributes no factor to the volume ratio either
        if prepared.deformer is None:
            piece, piece_input = [], points
        else:
            piece.append(prepared.deformer)
    if pieces is not None and piece:
        pieces.append((piece, piece_input))
    if offsets_into is not None:
        return _offsets(points, pending, base, out, offsets_into)
    if pending:
        points = native.dk.Stack(pending).deform(points)
    return base.copy() if points is base else points


def _one_pass_displacements():
    """The deformer types whose displacement is one pass of SIMD lanes (Barr's)."""
    dk = native.dk
    return (dk.BarrDeformer, dk.Twist, dk.Bend, dk.Taper, dk.Stretch, dk.SimpleDeform)


def _offsets(points, pending, base, out, offsets_into):
    """The end of _deformed with offsets_into: the pending stack run on `points`, minus base,
    into offsets_into's array (`out` if already asked for). One Barr deformer on the base itself:
    its displacement, which the lanes write in one pass (F(x) - x exactly); otherwise deform then
    one numpy subtract, faster than the generic displacement's second pass (bridge_alternatives.py)."""
    if out is None:
        out = offsets_into()
    if (len(pending) == 1 and points is base and points.dtype == out.dtype
            and isinstance(pending[0], _one_pass_displacements())):
        return pending[0].displacement(points, out=out)
    if pending:
        points = native.dk.Stack(pending).deform(points, **({"out": out} if points.dtype == out.dtype else {}))
    return np.subtract(points, base, out=out, casting="same_kind")


def entry_input(obj, index, kind="viewport"):
    """The points entry `index` deforms: the base mesh through the earlier entries shown in the
    viewport (or render), in the object's space. Raises EntryError for a problem on the way."""
    built = []
    for i, entry in enumerate(obj.deformkit.entries[:index]):
        if entries.kind(entry).LAST:
            raise EntryError(f"{entry.name}: a {entries.LABELS[entry.type]} entry must be the last entry")
        if shown(entry, kind, obj.mode == "EDIT"):
            try:
                built.append((i, entry, *entry_setup(obj, entry, reuse_weights=True)))
            except ValueError as exc:
                raise EntryError(f"{entry.name}: {exc}") from exc
    try:
        return _deformed(cache_key(obj), kind, built, input_positions(obj, reuse_weights=True))
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
    if obj.data.shape_keys is not None:
        raise EntryError("apply: the mesh has shape keys, which the entry deforms mixed; applying it to the "
                         "base mesh would not change that mix: apply or remove the shape keys first "
                         "(Object Data > Shape Keys > Apply All Shape Keys / Delete All Shape Keys)")
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

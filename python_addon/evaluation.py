"""Evaluation: turn an object's deformkit stack into a result and hand it to Blender.

The base mesh is never written. The entries deform the points Blender's first modifier gets (the
shape keys mixed, the edit mesh's in Edit Mode: meshdata.input_positions), and the result is stored
as offsets from them that a Geometry Nodes modifier named "deformkit" adds (outputs.py): in the
object's own mesh, or in a per-object helper in Edit Mode and on a mesh shared by linked
duplicates. So the result takes part in Blender's own modifier stack, saves with the file and
survives with the add-on disabled; removing every entry removes the modifier and the attributes,
which gives back the original mesh bit for bit. An entry whose kind changes the topology (LAST:
Subdivide), last in the stack, turns that result into helper objects whose geometry the modifier
then outputs instead, through the registry's hooks (entries/__init__.py).

An evaluation is plan (what runs on which input; did anything change), run (stack_run.py: each
entry through its kind, the volume ratio, the topology-changing entry) and publish (messages,
outputs, modifier, cache). Its caller says why it asks (a Reason): what it may reuse follows.
"""
import enum
from typing import NamedTuple, Optional

import bpy
import numpy as np

from . import cache, echo, entries, entry_animation, follow, outputs, stack_run
from .errors import EntryError
from .meshdata import base_positions, cache_key, input_positions, object_problem
from .outputs import ATTR_OFFSET, ATTR_OFFSET_RENDER, ATTR_VOLUME, MODIFIER_NAME, remove_outputs
from .stack_run import Built, EntryFailed, shown

_evaluating = set()  # session_uids being evaluated: writes below re-enter through handlers
# In the cache: "inputs", (cache key,) -> Inputs last written (echo.py keeps its own space).


class Reason(enum.Enum):
    """Why a caller asks for an evaluation: what may have changed, which says what of the last
    evaluation it may reuse (the sets below)."""
    EDIT = enum.auto()       # a setting changed (property update, keyframe, driver)
    MOVED = enum.auto()      # a followed object (lattice, handle, cage) alone changed: not the stack nor the mesh
    FOLLOWED = enum.auto()   # a followed object changed and the mesh may have too
    FRAME = enum.auto()      # the frame changed (animated shape keys: the input is read again)
    EDIT_MODE = enum.auto()  # the edit mesh changed in Edit Mode (the depsgraph holds the new input)
    MESH = enum.auto()       # the base mesh or a shape-key value may have changed; Edit Mode entered or left
    LINKS = enum.auto()      # objects were deleted or linked: an entry may have lost or found its object
    LOAD = enum.auto()       # a file was loaded, or undo / redo (what was cached is forgotten)
    READ = enum.auto()       # a script reads the result: brought up to date first
    ADDED = enum.auto()      # the api added an entry (its property updates may have run it already)
    STACK = enum.auto()      # the api changed the stack (removed, moved, copied, bound, unbound, applied)
    SCRIPT = enum.auto()     # api.evaluate: a script asks for a fresh result


# What a reason lets an evaluation do; the others read everything again and run only on a change.
_FORCED = {Reason.STACK, Reason.SCRIPT}  # run even when the settings and input look unchanged
_REUSES_INPUT = {Reason.EDIT, Reason.MOVED}  # the last input positions, while the vertex count is unchanged
_REUSES_WEIGHTS = {Reason.EDIT, Reason.MOVED, Reason.FRAME, Reason.EDIT_MODE}  # the vertex-group weights read last time
# The mesh update this write causes comes as an update of its own (echo.py): a write from a property
# update. One from the handlers (a followed object's update) is evaluated again in the same update
# by Blender, which does not call the handlers for it: its echo never comes, and an expected one
# would take the next real edit of the mesh for itself.
_ECHOED = {Reason.EDIT}
# The stack is as it was, only what it follows or the edit mesh changed: _settled.
_KEEPS_LAYOUT = {Reason.MOVED, Reason.EDIT_MODE}
_STEPS = {Reason.MOVED, Reason.EDIT}  # one entry's drag or edit: follow.py, when its Follow holds


class Inputs(NamedTuple):
    """What the last evaluation ran on, kept in the cache's "inputs" space."""
    key: tuple  # everything the result depended on besides the input positions (Plan.key)
    base: np.ndarray  # the input positions
    failures: dict  # {entry index: message} of the entries that failed on them


class Plan(NamedTuple):
    """What an evaluation runs, on what, and what it compares with the last one."""
    uid: object  # the object's cache key
    editing: bool  # in Edit Mode
    per_object: bool  # the result goes into a per-object helper (Edit Mode, a shared mesh)
    volume_ratio: bool  # the volume colors are shown
    base: np.ndarray  # the input positions
    built: list  # [stack_run.Built] of the entries that run pointwise, in order
    last: Optional[Built]  # the topology-changing entry, run on their result, or None
    key: tuple  # everything the result depends on besides `base`
    cached: Optional[Inputs]  # the last evaluation's
    settled: bool  # what the last evaluation pruned and discarded holds for this one (_settled)


def shared_mesh(obj):
    """True when other objects use obj's mesh too (linked duplicates): the result is kept per object."""
    return obj.data.users > 1 + int(obj.data.use_fake_user)


def entry_setup(obj, entry, reuse_weights=False):
    """(kind, common.Prepared) for one entry: its kind's setup, with the fingerprint that tells
    whether its result may have changed."""
    kind = entries.kind(entry)
    prepared = kind.setup(obj, entry, reuse_weights)
    fingerprint = (entry.type, entry.show_viewport, entry.show_render, prepared.fingerprint)
    return kind, prepared._replace(fingerprint=fingerprint)


def _set_if_changed(owner, prop, value):
    if getattr(owner, prop) != value:
        setattr(owner, prop, value)


def evaluate(obj, reason, depsgraph=None):
    """Recompute `obj`'s deformkit result. Returns True if it wrote a new result.

    reason: a Reason, what may have changed, which says what of the last evaluation is reused.
    depsgraph: the one that just evaluated an edit (Edit Mode reads its input from it). A problem of
    the object's goes on the stack and leaves the mesh as it was; an entry that fails shows its
    message and is skipped, the others still run."""
    uid = cache_key(obj)
    if uid in _evaluating or not _usable(obj):
        return False
    _evaluating.add(uid)
    try:
        stepped = follow.step(obj, uid, reason is Reason.MOVED) if reason in _STEPS and not shared_mesh(obj) else None
        if stepped is not None:
            return stepped
        if not any(e.show_viewport or e.show_render for e in obj.deformkit.entries):
            _clear(obj, uid)
            return True
        plan = _plan(obj, uid, reason, depsgraph)
        if reason not in _FORCED and _unchanged(obj, plan):
            _show_failures(obj.deformkit, plan.cached.failures)  # the entries that failed on these inputs still do
            outputs.follow_toggles(obj, obj.deformkit.entries)
            return False
        try:
            result = stack_run.run(obj, plan)
        except ValueError as exc:  # the stack as a whole could not run: the last result stays
            _set_if_changed(obj.deformkit, "error", str(exc))
            return False
        _publish(obj, plan, stack_run.finish(plan, result), reason in _ECHOED)
        return True
    finally:
        _evaluating.discard(uid)


def _usable(obj):
    """Whether deformkit can run on obj; its problem, if any, goes on the stack (cleared if none)."""
    problem = object_problem(obj)
    _set_if_changed(obj.deformkit, "error", problem)
    return not problem


def _clear(obj, uid):
    """Nothing shown anywhere: the original mesh, as with every modifier hidden."""
    entries.discard_helpers(obj)
    remove_outputs(obj, mesh_attributes=obj.mode != "EDIT")  # Edit Mode: the edit mesh holds them
    cache.forget(uid)


# -- plan --------------------------------------------------------------------------------------------

def _plan(obj, uid, reason, depsgraph):
    """What runs on which input: the input positions (the last ones, when the reason allows it),
    each entry's setup and the key of everything the result depends on besides the input."""
    stack, editing = obj.deformkit, obj.mode == "EDIT"
    cached = cache.get("inputs", (uid,))
    base = _input(obj, cached, reason, depsgraph)
    per_object = editing or shared_mesh(obj)
    built, last, fingerprints = _setup_entries(obj, reason in _REUSES_WEIGHTS, editing)
    key = (len(base), stack.show_volume_ratio, editing, per_object, *fingerprints)
    settled = _settled(cached, key, reason)
    if not settled:  # what the kinds keep for entries gone: the same stack keeps it all
        entries.prune(uid, stack.entries)
    return Plan(uid, editing, per_object, stack.show_volume_ratio, base, built, last, key, cached, settled)


def _settled(cached, key, reason):
    """Whether what the last evaluation (published) pruned and the helpers it discarded are as this
    one would leave them: it ran the same entries with the same settings (its key), or (the stack as
    it was: _KEEPS_LAYOUT) the same entries, shown and failing alike, with the result in the same
    place. A drag's frames then pay for the deformation, not for this bookkeeping."""
    def layout(k):  # the key without the setups' fingerprints
        return k[:4] + tuple(f if isinstance(f[0], int) else (f[0][:3], f[1]) for f in k[4:])
    return cached is not None and (cached.key == key or reason in _KEEPS_LAYOUT and layout(cached.key) == layout(key))


def _input(obj, cached, reason, depsgraph):
    """The points the entries deform: the last evaluation's when the reason allows it and (out of
    Edit Mode) the vertex count is unchanged, else read again."""
    count = len(obj.data.vertices) if obj.mode != "EDIT" else None
    if reason in _REUSES_INPUT and cached is not None and (count is None or len(cached.base) == count):
        return cached.base
    return input_positions(obj, reason in _REUSES_WEIGHTS, depsgraph)


def _setup_entries(obj, reuse_weights, editing):
    """([Built] of the pointwise entries, the topology-changing entry's Built or None, [fingerprint
    per entry]). An entry that cannot set up shows why and is skipped, as Blender skips a modifier it
    cannot run: its input goes on to the next entry."""
    built, last, fingerprints = [], None, []
    for index, entry in enumerate(obj.deformkit.entries):
        try:
            if last is not None:
                raise EntryError(f"comes after the {entries.LABELS[last.entry.type]} entry '{last.entry.name}', "
                                 "which must be the last entry (it changes the topology): move this entry above it")
            kind, prepared = entry_setup(obj, entry, reuse_weights)
        except ValueError as exc:
            _set_if_changed(entry, "error", str(exc))
            fingerprints.append((index, str(exc)))
            continue
        if kind.LAST:
            if not editing or entry.show_in_editmode:
                last = Built(index, entry, kind, prepared)  # its error is cleared once it has run
        else:
            _set_if_changed(entry, "error", prepared.note)  # a note: the entry still runs
            built.append(Built(index, entry, kind, prepared))
        fingerprints.append((prepared.fingerprint, entry.show_in_editmode))
    return built, last, fingerprints


def _unchanged(obj, plan):
    """Whether the last evaluation ran on the same settings and input, and its outputs are still there."""
    cached = plan.cached
    return (cached is not None and cached.key == plan.key and np.array_equal(cached.base, plan.base)
            and _outputs_present(obj, plan.per_object, plan.last is not None))


def _outputs_present(obj, per_object, subdivided):
    kind = outputs.modifier_kind(obj)
    if kind is None:
        return False
    if subdivided:
        return kind == "subdivided" and None not in outputs.helper_objects(obj)
    if per_object:
        return kind.startswith("per_object") and outputs.modifier_input(obj, outputs.RESULT_INPUT) is not None
    return kind.startswith("offsets") and ATTR_OFFSET in obj.data.attributes


# -- publish -----------------------------------------------------------------------------------------

def _publish(obj, plan, result, expect_echo):
    """Hand the result to Blender: the entries' messages, the topology-changing entry's helpers, the
    offsets and volume colors, the modifier, and what the next evaluation compares with."""
    stack = obj.deformkit
    if plan.last is not None and plan.last.index not in result.failures:
        _set_if_changed(plan.last.entry, "error", "")  # it ran: its message goes
    _show_failures(stack, result.failures)
    helpers = _write_helpers(obj, plan, result.finished)
    # After the helpers (a level 0 result is the cage itself), in place: on a large mesh a second
    # copy of the points costs as much as the deformation.
    if result.in_place:
        offsets, render_offsets = result.viewport, None
    else:
        offsets = np.subtract(result.viewport, plan.base, out=result.viewport)
        render_offsets = None if result.render is result.viewport else np.subtract(result.render, plan.base,
                                                                                   out=result.render)
    _write_outputs(obj, plan, helpers, offsets, render_offsets, result)
    outputs.follow_toggles(obj, stack.entries)
    cache.put("inputs", (plan.uid,), Inputs(plan.key, plan.base, result.failures))
    follow.remember(obj, plan, result)
    cache.put("mode", (plan.uid,), obj.mode)
    _set_if_changed(stack, "notice", "")
    if expect_echo and not plan.editing:
        echo.expect(plan.uid)


def _show_failures(stack, failures):
    for index, message in failures.items():
        _set_if_changed(stack.entries[index], "error", message)


def _write_helpers(obj, plan, finished):
    """The topology-changing entry's results into its helper objects, the others of obj deleted.
    Returns the helpers written, or None (nothing made)."""
    if plan.last is None and plan.settled:
        return None  # as the last evaluation left them: none made, the others deleted then
    if plan.last is None:  # no such entry (any more): what its kind keeps to refine the mesh goes
        entries.forget_refined(plan.uid)
    helpers = finished and plan.last.kind.write(obj, plan.last.prepared.data, finished)
    entries.discard_helpers(obj, keep=helpers or ())
    return helpers


def _write_outputs(obj, plan, helpers, offsets, render_offsets, result):
    """The modifier, fed with the helpers, the per-object helper or the mesh's own attributes."""
    if helpers:
        outputs.ensure_modifier(obj, "subdivided", list(zip(outputs.HELPER_INPUTS, helpers))
                                + [(outputs.VERTICES_INPUT, len(plan.base))])
    elif plan.per_object:
        helper = outputs.result_helper(obj)
        outputs.write_result_helper(helper, offsets, render_offsets, result.ratio)
        outputs.ensure_modifier(obj, "per_object_volume" if result.ratio is not None else "per_object",
                                [(outputs.RESULT_INPUT, helper)])
    else:
        outputs.ensure_modifier(obj, "offsets_split" if render_offsets is not None else "offsets")
    if not plan.editing:
        # Under a topology-changing entry's result too: the cage's offsets, for stored_positions.
        own = None if plan.per_object else (None if result.in_place else offsets, render_offsets)
        _write_own_mesh(obj, own, result.ratio)
    if not plan.per_object and not plan.settled:
        outputs.discard_result_helper(obj)


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


# -- what the handlers and the api ask besides an evaluation ------------------------------------------

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
    if base is None or np.array_equal(base, cached.base):
        for entry in stack.entries:
            entry.show_viewport = entry.show_render = False
        stack.notice = ("The 'deformkit' modifier was removed, so the entries were turned off: turn one on to "
                        "show them again (the modifier comes back)")
    else:
        entries.discard_helpers(obj)
        entry_animation.cleared(obj)
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
    offsets = np.empty(len(cached.base) * 3, np.float32)
    owner.attributes[name].data.foreach_get("vector", offsets)
    return cached.base + offsets.reshape(-1, 3)


def entry_input(obj, index, kind="viewport"):
    """The points entry `index` deforms: the base mesh through the earlier entries shown in the
    viewport (or render), in the object's space. Raises EntryError for a problem on the way."""
    built = []
    for i, entry in enumerate(obj.deformkit.entries[:index]):
        if entries.kind(entry).LAST:
            raise EntryError(f"{entry.name}: a {entries.LABELS[entry.type]} entry must be the last entry")
        if shown(entry, kind, obj.mode == "EDIT"):
            try:
                built.append(Built(i, entry, *entry_setup(obj, entry, reuse_weights=True)))
            except ValueError as exc:
                raise EntryError(f"{entry.name}: {exc}") from exc
    try:
        return stack_run.deformed(cache_key(obj), kind, built, input_positions(obj, reuse_weights=True))
    except EntryFailed as exc:
        raise EntryError(f"{obj.deformkit.entries[exc.index].name}: {exc}") from exc


def is_echo_of_own_write(obj):
    """echo.is_echo for obj's last evaluation (its vertex count)."""
    cached = cache.get("inputs", (cache_key(obj),))
    return echo.is_echo(obj, None if cached is None else len(cached.base))


def request_update(obj):
    """Called by property updates (properties.on_change): re-evaluate at once (parameter edits,
    keyframes, drivers)."""
    if isinstance(obj, bpy.types.Object) and obj.type == "MESH":
        evaluate(obj, Reason.EDIT)


def forget(obj=None):
    """Drop cached fingerprints, weights, lattice bindings, Laplacian solvers and refined
    topologies (after a file load, when they may be stale; the solvers are built again from the
    saved rest)."""
    cache.forget(None if obj is None else cache_key(obj))


def forget_undone():
    """forget() after undo or redo, but for the values the kinds keep by bind (KEPT_THROUGH_UNDO) of
    the mesh objects still there: a bind undo brings back is the one they were made from."""
    cache.forget_but(entries.kept_through_undo(), {cache_key(o) for o in bpy.data.objects if o.type == "MESH"})


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
    entry_animation.removed(obj, index)
    stack.entries.remove(index)
    stack.active_index = min(stack.active_index, max(0, len(stack.entries) - 1))
    evaluate(obj, Reason.STACK)
    return "" if index == 0 else "Applied entry was not first, result may not be as expected"


def evaluated_positions(obj, depsgraph=None):
    """Positions of the fully evaluated object (all modifiers), as float32 (n, 3). The stack is
    brought up to date first, so a script that just edited the base mesh reads a current result."""
    stack = getattr(obj, "deformkit", None)  # None while the add-on is unregistered
    if depsgraph is None and obj.type == "MESH" and stack is not None and len(stack.entries) > 0:
        evaluate(obj, Reason.READ)
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        return base_positions(mesh)
    finally:
        evaluated.to_mesh_clear()

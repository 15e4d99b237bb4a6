"""One entry's edits and drags, step by step.

While only the object an entry follows changes (a cage, a lattice: evaluation's Reason.MOVED) or
only a setting of the entry (Reason.EDIT: an angle dragged in the panel), the rest of what the last
full evaluation read stands: the mesh, its weights, the stack and where its result goes. For the
common case (one entry, its offsets written into the mesh's own memory) that evaluation leaves a
Follow, and each step then only sets the entry up again (a MOVED step through its kind's
`refresh`, which reads the followed object again and keeps the settings), deforms into the offsets
and tells Blender: the same result as a full evaluation, without its reading of the whole stack and
its bookkeeping (the modifier, the helpers, the messages), which only other changes need. Anything
else, and any problem on the way, leaves the step to the full evaluation, which says what is wrong.
"""
import functools
from typing import NamedTuple

from . import cache, echo, outputs, stack_run
from .errors import EntryError


class Follow(NamedTuple):
    """What the last full evaluation of an object left for the steps that follow (cache "follow")."""
    identity: tuple  # (name, type) of the stack's one entry
    kind: object  # its kind (the registry's)
    prepared: object  # its setup (common.Prepared, the evaluation's fingerprint)
    key: tuple  # the plan's key (evaluation.Plan.key)
    base: object  # the input positions, the same array as the evaluation's Inputs.base


def remember(obj, plan, result):
    """Keep a Follow after a full evaluation (published) whose one entry wrote its offsets straight
    into the mesh's memory (stack_run.run's in-place case); else forget any."""
    stack = obj.deformkit.entries
    if not (result.in_place and not result.failures and result.ratio is None and plan.last is None
            and len(plan.built) == 1 and len(stack) == 1 and stack_run.shown(plan.built[0].entry, "viewport", False)):
        cache.pop("follow", (plan.uid,))
        return
    built = plan.built[0]
    cache.put("follow", (plan.uid,), Follow((built.entry.name, built.entry.type), built.kind, built.prepared,
                                            plan.key, plan.base))


# Node groups may have changed (handlers: groups_touched) since generation `_touched`; "checked",
# (object cache key,) in the cache: the generation a step last checked that object's modifier at.
_touched = 0


def groups_touched():
    """The handlers saw an update of a node group, or of an object with entries (as an edit of its
    modifier's group shows): each object's next drag step checks its modifier. A setting's step
    always does."""
    global _touched
    _touched += 1


def step(obj, uid, moved):
    """One step, on an object whose mesh only it uses: True if it wrote a new result, False if the
    result stands, None when the Follow does not hold for it (none, another evaluation since, Edit
    Mode, the mesh resized, the stack or the entry's toggles changed, its setup failed): the full
    evaluation runs instead. moved: only what the entry follows changed (else a setting of the entry
    may have). The evaluation's record (the cache's "inputs", evaluation.Inputs) gets the new key."""
    kept, last = cache.get("follow", (uid,)), cache.get("inputs", (uid,))
    if kept is None or last is None or kept.key != last.key or obj.mode == "EDIT" \
            or len(obj.data.vertices) != len(kept.base):
        return None
    stack = obj.deformkit
    if len(stack.entries) != 1:
        return None
    entry = stack.entries[0]
    (fingerprint, in_edit_mode), = kept.key[4:]
    if (entry.name, entry.type) != kept.identity or (entry.type, entry.show_viewport, entry.show_render) != fingerprint[:3] \
            or entry.show_in_editmode != in_edit_mode or stack.show_volume_ratio != kept.key[1]:
        return None
    try:
        if moved and kept.kind.refresh is not None:
            prepared = kept.kind.refresh(obj, entry, kept.prepared)
        else:  # as evaluation.entry_setup, with the weights read last (Reason.EDIT and MOVED reuse them)
            prepared = kept.kind.setup(obj, entry, True)
    except ValueError:  # the full evaluation shows it on the entry
        return None
    if entry.error != prepared.note:
        entry.error = prepared.note  # a note: the entry still runs
    prepared = prepared._replace(fingerprint=fingerprint[:3] + (prepared.fingerprint,))  # as evaluation.entry_setup's
    key = kept.key[:4] + ((prepared.fingerprint, in_edit_mode),)
    if key == last.key:
        return False
    into = functools.partial(outputs.vector_attribute_memory, obj.data, outputs.ATTR_OFFSET, len(kept.base))
    try:
        stack_run.deformed(uid, "viewport", [stack_run.Built(0, entry, kept.kind, prepared)], kept.base,
                           offsets_into=into)
    except EntryError:  # its failure: shown by the full evaluation, which also writes the offsets again
        return None
    if not moved or cache.get("checked", (uid,)) != _touched:
        # The modifier as a full evaluation leaves it: its group repaired after a stray edit (which a
        # drag's step knows of from the handlers: groups_touched), On Cage as the entry says.
        outputs.ensure_modifier(obj, "offsets")
        outputs.follow_toggles(obj, stack.entries)
        cache.put("checked", (uid,), _touched)
    obj.data.update()
    cache.put("follow", (uid,), kept._replace(prepared=prepared, key=key))
    cache.put("inputs", (uid,), last._replace(key=key, failures={}))
    if not moved:
        echo.expect(uid)  # a setting's edit: the mesh update this causes comes next (evaluation._ECHOED)
    return True

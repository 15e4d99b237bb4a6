"""Scripting API for batch scripts and tests: plain functions on objects, no context needed.

    from deformkit_addon import api
    entry = api.add_entry(obj, "TWIST", angle=math.radians(90), deform_axis="Z")
    api.set_params(entry, limits=(0.2, 0.8))
    api.evaluate(obj)
    api.apply(obj, 0)
"""
from . import evaluation
from .properties import ENTRY_TYPES

TYPES = tuple(t[0] for t in ENTRY_TYPES)
PARAMS = ("name", "show_viewport", "show_render", "angle", "factor", "deform_axis", "origin", "limits",
          "lock_x", "lock_y", "lock_z", "vertex_group", "invert_vertex_group")


def _require_mesh(obj):
    problem = evaluation.object_problem(obj)
    if problem:
        raise ValueError(problem)


def add_entry(obj, type="TWIST", **params):
    """Append an entry of `type` (Twist, Taper, Bend, Stretch; case-insensitive) and evaluate."""
    _require_mesh(obj)
    kind = str(type).upper()
    if kind not in TYPES:
        raise ValueError(f"type: expected one of {', '.join(TYPES)}, got {type!r}")
    stack = obj.deformkit
    name = _unique_name(stack, kind.title())  # before add(): the new entry has a default name
    entry = stack.entries.add()
    entry.type = kind
    entry.name = name
    stack.active_index = len(stack.entries) - 1
    set_params(entry, **params)
    evaluation.evaluate(obj)
    return entry


def _unique_name(stack, base):
    names = {e.name for e in stack.entries}
    if base not in names:
        return base
    i = 1
    while f"{base}.{i:03d}" in names:
        i += 1
    return f"{base}.{i:03d}"


def set_params(entry, **params):
    """Set entry parameters by name (as on Blender's Simple Deform where they overlap)."""
    for key, value in params.items():
        if key not in PARAMS:
            raise ValueError(f"{key}: not a deformkit entry parameter (expected one of {', '.join(PARAMS)})")
        setattr(entry, key, value)
    return entry


def entries(obj):
    return list(obj.deformkit.entries)


def evaluate(obj):
    """Recompute the result now; raises ValueError with the message an entry shows, if any."""
    evaluation.forget(obj)
    evaluation.evaluate(obj, force=True)
    problems = [obj.deformkit.error] + [f"{e.name}: {e.error}" for e in obj.deformkit.entries if e.error]
    problems = [p for p in problems if p]
    if problems:
        raise ValueError("; ".join(problems))


def remove_entry(obj, index):
    stack = obj.deformkit
    if not 0 <= index < len(stack.entries):
        raise IndexError(f"index: {index} is out of range for {len(stack.entries)} entries")
    stack.entries.remove(index)
    stack.active_index = min(stack.active_index, max(0, len(stack.entries) - 1))
    evaluation.evaluate(obj, force=True)


def move_entry(obj, index, direction):
    """Move entry `index` up (-1) or down (+1)."""
    stack = obj.deformkit
    target = index + direction
    if not (0 <= index < len(stack.entries) and 0 <= target < len(stack.entries)):
        raise IndexError(f"cannot move entry {index} by {direction}")
    stack.entries.move(index, target)
    stack.active_index = target
    evaluation.evaluate(obj, force=True)


def apply(obj, index=0):
    """Bake entry `index` into the mesh; returns Blender's warning when it was not first."""
    stack = obj.deformkit
    if not 0 <= index < len(stack.entries):
        raise IndexError(f"index: {index} is out of range for {len(stack.entries)} entries")
    _require_mesh(obj)
    return evaluation.apply_entry(obj, index)


def evaluated_positions(obj, depsgraph=None):
    return evaluation.evaluated_positions(obj, depsgraph)

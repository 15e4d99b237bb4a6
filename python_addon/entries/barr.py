"""Barr entries: Twist, Bend, Taper and Stretch, one kind for the four modes of Blender's Simple
Deform modifier (dk.SimpleDeform), with its settings and panel.

Their deformers are pointwise maps with a Jacobian, so runs of them go through one dk.Stack."""
import zlib

import numpy as np

from .. import native
from .common import Prepared, deleted_name, draw_subpanel, draw_vertex_group, influence_weights, write_base

TYPES = ("TWIST", "BEND", "TAPER", "STRETCH")
ICON = "MOD_SIMPLEDEFORM"
STACKABLE = True   # composed with neighbouring Barr entries in one dk.Stack
LAST = False       # keeps the topology
MENU = ()          # (operator, icon) below the Add menu's entry types
ANGLES = ("TWIST", "BEND")  # Simple Deform's amount is an angle in these modes, a factor otherwise
_PLACE = ("origin", "deform_axis", "limits", "vertex_group", "invert_vertex_group")
_LOCKS = ("lock_x", "lock_y", "lock_z")  # Simple Deform has no locks in Bend mode
FIELDS = ("angle", "factor", "deform_axis", "origin", "limits") + _LOCKS + ("vertex_group", "invert_vertex_group")


def fields(entry_type):
    """The entry properties this mode uses (the panel shows exactly these)."""
    amount = ("angle",) if entry_type in ANGLES else ("factor",)
    return amount + _PLACE + (() if entry_type == "BEND" else _LOCKS)


def amount(entry):
    """The one value Simple Deform uses: the angle for twist and bend, the factor otherwise."""
    return entry.angle if entry.type in ANGLES else entry.factor


def origin_matrix(obj, entry):
    """The origin object's frame in `obj`'s local space, as Simple Deform uses it: None (the
    object's own frame) without one, for the object itself (Blender ignores it) and for a deleted
    one (Blender clears the modifier's field, and Simple Deform then has no origin)."""
    if entry.origin is None or entry.origin == obj or deleted_name(entry, "origin"):
        return None
    return np.array(obj.matrix_world.inverted() @ entry.origin.matrix_world)


def origin_note(entry):
    """What the entry says when its origin object was deleted, else ''."""
    name = deleted_name(entry, "origin")
    return (f"origin object '{name}' no longer exists: deforming in the object's own frame, as Simple Deform "
            "does without an origin") if name else ""


def setup(obj, entry, reuse_weights=False):
    weights = influence_weights(obj, entry, reuse_weights)
    lo, hi = entry.limits
    origin = origin_matrix(obj, entry)
    deformer = native.dk.SimpleDeform(
        mode=entry.type, angle=amount(entry), deform_axis=entry.deform_axis, origin=origin,
        limits=(min(lo, hi), hi),  # Blender clamps the lower limit to the upper one
        lock_x=entry.lock_x, lock_y=entry.lock_y, lock_z=entry.lock_z, weights=weights)
    fingerprint = (amount(entry), entry.deform_axis, tuple(entry.limits), entry.lock_x, entry.lock_y, entry.lock_z,
                   entry.invert_vertex_group, None if origin is None else origin.tobytes(),
                   None if weights is None else zlib.crc32(deformer.weights.tobytes()))
    return Prepared(deformer, fingerprint, None, origin_note(entry))


def deform(key, prepared, points):
    return prepared.deformer.deform(points)


def apply(obj, entry, prepared, base):
    write_base(obj, prepared.deformer.deform(base))


def followed(entry):
    """(object, remembered name) of the objects the entry follows besides its origin (which every
    entry's is watched for, see handlers): none."""
    return []


def volume_note(entries):
    return ""


def prune(object_key, entries):
    """Nothing to drop: only Laplacian entries keep state per bind (their solvers)."""


def retyped(entry):
    """The entry became another kind: nothing of a Barr entry is hidden."""


def draw(col, obj, entry):
    """Laid out like Blender's Simple Deform panel: mode, amount, origin, axis, restrictions."""
    col.prop(entry, "angle" if entry.type in ANGLES else "factor")
    col.prop(entry, "origin")
    col.row().prop(entry, "deform_axis", expand=True)
    col.separator()
    group = draw_subpanel(col, entry, "show_restrictions", "Restrictions")
    if group is None:
        return
    group.prop(entry, "limits", slider=True)
    if entry.type != "BEND":
        row = group.row(heading="Lock", align=True)
        for axis in "xyz":
            if axis.upper() != entry.deform_axis:
                row.prop(entry, f"lock_{axis}", text=axis.upper(), toggle=True)
    draw_vertex_group(group, obj, entry)

"""Barr entries: Twist, Bend, Taper and Stretch, one kind for the four modes of Blender's Simple
Deform modifier (dk.SimpleDeform), with its settings and panel.

Their deformers are pointwise maps with a Jacobian, so runs of them go through one dk.Stack."""
import numpy as np

from .. import cache, meshdata, native
from .common import Prepared, deleted_name, draw_subpanel, draw_vertex_group, influence_weights, stack_index

# Its rows of the Type enum (entries.ENTRY_TYPES): the numbers are what saved files store.
ENTRY_TYPES = [
    ("TWIST", "Twist", "Rotate around the deform axis (Barr's twist)", "NONE", 0),
    ("BEND", "Bend", "Bend around the deform axis (Barr's bend)", "NONE", 1),
    ("TAPER", "Taper", "Scale linearly along the deform axis (Barr's taper)", "NONE", 2),
    ("STRETCH", "Stretch", "Stretch along the deform axis (Blender's stretch)", "NONE", 3),
]
TYPES = tuple(row[0] for row in ENTRY_TYPES)  # its entry.type identifiers
AXES = [("X", "X", "Deform around the local X axis"), ("Y", "Y", "Deform around the local Y axis"),
        ("Z", "Z", "Deform around the local Z axis")]
ICON = "MOD_SIMPLEDEFORM"
TYPE_LABEL = "Mode"  # the types are Simple Deform's modes (its deform_method is named Mode)
STACKABLE = True   # composed with neighbouring Barr entries in one dk.Stack
ANGLES = ("TWIST", "BEND")  # Simple Deform's amount is an angle in these modes, a factor otherwise
_PLACE = ("origin", "deform_axis", "limits", "vertex_group", "invert_vertex_group")
_LOCKS = ("lock_x", "lock_y", "lock_z")  # Simple Deform has no locks in Bend mode
# The entry properties each mode uses (the panel shows exactly these).
TYPE_FIELDS = {"TWIST": ("angle",) + _PLACE + _LOCKS, "BEND": ("angle",) + _PLACE,
               "TAPER": ("factor",) + _PLACE + _LOCKS, "STRETCH": ("factor",) + _PLACE + _LOCKS}


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
    """The entry's dk.SimpleDeform; the one made last time for the same settings and weights when
    there is one, else one sharing its weights when only the settings changed (a new one copies and
    checks every weight)."""
    weights = influence_weights(obj, entry, reuse_weights)
    lo, hi = entry.limits
    origin = origin_matrix(obj, entry)
    fingerprint = (entry.type, amount(entry), entry.deform_axis, tuple(entry.limits), entry.lock_x, entry.lock_y,
                   entry.lock_z, entry.invert_vertex_group, None if origin is None else origin.tobytes(),
                   meshdata.weights_crc(weights))
    key = (meshdata.cache_key(obj), stack_index(entry))
    kept = cache.get("barr", key)
    if kept is not None and kept[0] == fingerprint and kept[1] is weights:
        return Prepared(kept[2], fingerprint, None, origin_note(entry))
    settings = dict(mode=entry.type, angle=amount(entry), deform_axis=entry.deform_axis,
                    limits=(min(lo, hi), hi),  # Blender clamps the lower limit to the upper one
                    lock_x=entry.lock_x, lock_y=entry.lock_y, lock_z=entry.lock_z)
    if kept is not None and weights is not None and kept[1] is weights:  # a parameter edit: the weights are shared
        deformer = kept[2].replace(**settings, origin=np.eye(4) if origin is None else origin)
    else:
        deformer = native.dk.SimpleDeform(**settings, origin=origin, weights=weights)
    cache.put("barr", key, (fingerprint, weights, deformer))
    return Prepared(deformer, fingerprint, None, origin_note(entry))


def prune(object_key, entries):
    """The deformers kept for places no Barr entry has any more go."""
    alive = {stack_index(e) for e in entries}
    cache.forget(object_key, "barr", keep=lambda k: k[1] in alive)


def deform(key, prepared, points):
    return prepared.deformer.deform(points)


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

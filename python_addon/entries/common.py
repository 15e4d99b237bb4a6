"""What several entry kinds share: the value a setup returns, the entry at an index of a stack, the
objects entries follow and their evaluated meshes in the entry's space, the vertex-group influence,
bindings kept between evaluations, and panel rows."""
from collections import namedtuple

import bpy
import numpy as np

from .. import cache, meshdata
from ..errors import EntryError

# deformer: a dk.Deformer with a Jacobian (in dk.Stack and the volume ratio), or None for kinds
# without a pointwise map; fingerprint: everything besides the incoming points that the result
# depends on; data: the kind's own (lattice.Setup, laplacian.Setup, subdivide.Setup) or None;
# note: a message for the entry that still evaluates (a deleted origin), or "".
Prepared = namedtuple("Prepared", "deformer fingerprint data note", defaults=("",))
# Entry properties that point at objects, each with a <prop>_name remembering the object's name.
POINTERS = ("origin", "lattice", "handle_object", "cage", "controls", "rest_object")


def check_index(stack, index):
    """IndexError unless `index` is an entry of the stack (obj.deformkit)."""
    if not 0 <= index < len(stack.entries):
        raise IndexError(f"index: {index} is out of range for {len(stack.entries)} entries")


def entry_of_type(obj, index, entry_type):
    """Entry `index` of obj's stack, which must be of `entry_type`."""
    stack = obj.deformkit
    check_index(stack, index)
    entry = stack.entries[index]
    if entry.type != entry_type:
        labels = {item.identifier: item.name for item in entry.bl_rna.properties["type"].enum_items}  # "RBF"
        raise ValueError(f"entry '{entry.name}' is a {labels[entry.type]} entry, not a {labels[entry_type]} entry")
    return entry


def deleted_name(entry, prop):
    """The name of the object entry.<prop> pointed at if it was deleted (the pointer cleared, as
    Blender clears a modifier's, or the object unlinked from every scene while held here), else ''."""
    obj = getattr(entry, prop)
    if obj is None:
        return getattr(entry, prop + "_name")
    return "" if obj.users_scene else obj.name


def clear_deleted(entry):
    """Clear the pointers of `entry` whose objects were deleted in the UI (unlinked from every
    scene but kept alive by this pointer), as Blender clears a modifier's: the object can then be
    freed, and the entry remembers its name for its message. Returns True if it cleared any."""
    cleared = False
    for prop in POINTERS:
        obj = getattr(entry, prop)
        if obj is not None and obj != entry.id_data and not obj.users_scene:
            setattr(entry, prop, None)  # its update forgets the name (and re-evaluates)
            setattr(entry, prop + "_name", obj.name)
            cleared = True
    return cleared


def followed_object(entry, prop, role, unset=""):
    """The object entry.<prop> points at, or EntryError when it was deleted (the entry remembers
    its name in <prop>_name, so a deletion is told apart from "none set"). Unset: EntryError(unset),
    or None when `unset` is empty."""
    obj = getattr(entry, prop)
    if obj is None:
        name = getattr(entry, prop + "_name")
        if name:
            raise EntryError(f"{role} object '{name}' no longer exists")
        if unset:
            raise EntryError(unset)
        return None
    if not obj.users_scene:  # deleted in the UI: unlinked, but still referenced here
        raise EntryError(f"{role} object '{obj.name}' was deleted (it is in no scene)")
    return obj


def followed_mesh(entry, prop, role, obj, unset=""):
    """As followed_object, for a mesh object other than obj (a cage, an RBF's controls)."""
    other = followed_object(entry, prop, role, unset)
    if other is None:
        return None
    if other.type != "MESH":
        raise EntryError(f"{role} '{other.name}' is not a mesh object")
    if other == obj:
        raise EntryError(f"the {role} must be another object than the mesh it deforms")
    return other


def affine_inverse(m):
    """The inverse of an affine 4x4 matrix (an object's transform), in float64 by cofactors.
    numpy.linalg is kept off the evaluation path: its LAPACK call wakes OpenBLAS's threads, which
    on a busy machine costs up to a millisecond per 4x4, every frame. ValueError if singular."""
    m = np.asarray(m, np.float64)
    (a, b, c), (d, e, f), (g, h, i) = m[:3, :3].tolist()
    cofactors = np.array([[e * i - f * h, c * h - b * i, b * f - c * e],   # det(A) A^-1, row by row
                          [f * g - d * i, a * i - c * g, c * d - a * f],
                          [d * h - e * g, b * g - a * h, a * e - b * d]])
    det = a * cofactors[0, 0] + b * cofactors[1, 0] + c * cofactors[2, 0]
    if not (det != 0.0 and np.isfinite(det)):
        raise ValueError("the matrix is singular or not finite")
    inverse = np.eye(4)
    inverse[:3, :3] = cofactors / det
    inverse[:3, 3] = -inverse[:3, :3] @ m[:3, 3]
    return inverse


def determinant3(m):
    """det of a 3x3 matrix, by cofactors (not LAPACK: see affine_inverse)."""
    (a, b, c), (d, e, f), (g, h, i) = np.asarray(m, np.float64).tolist()
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)


def relative(obj, other):
    """obj^-1 other: other's local space in obj's (4 x 4, float64)."""
    return np.array(obj.matrix_world.inverted() @ other.matrix_world, np.float64)


def in_space_of(obj, other, points, local=None):
    """Points (m, 3) of other's local space in obj's (local: relative(obj, other), if made already),
    float64, rounded to float32 as the entries' stored rests are: a shape as it was at bind is then
    its rest bit for bit."""
    local = relative(obj, other) if local is None else local
    if is_identity(local):  # the same values (float32 already): objects that stand alike, as rigs' often do
        return np.array(points, np.float64)
    return (np.asarray(points, np.float64) @ local[:3, :3].T + local[:3, 3]).astype(np.float32).astype(np.float64)


_IDENTITY = np.eye(4)


def is_identity(matrix):
    """Whether a 4 x 4 transform is exactly the identity (x @ I + 0 is x, exactly)."""
    return np.array_equal(matrix, _IDENTITY)


def evaluated_mesh_in(obj, other, read=None, local=None):
    """other's evaluated mesh (its modifiers, shape keys and Edit Mode edits applied): its points in
    obj's space (in_space_of, with `local` if given), and read(mesh) of that mesh (None without `read`)."""
    evaluated = other.evaluated_get(bpy.context.evaluated_depsgraph_get())
    if other.mode != "EDIT":
        # The evaluated object's own mesh, its modifiers applied: to_mesh() would first copy it into
        # a new datablock, a third of a cage frame's reading. In Edit Mode it may wrap the edit mesh.
        return _read_mesh(obj, other, evaluated.data, read, local)
    try:
        return _read_mesh(obj, other, evaluated.to_mesh(), read, local)
    finally:
        evaluated.to_mesh_clear()


def _read_mesh(obj, other, mesh, read, local):
    extra = None if read is None else read(mesh)
    return in_space_of(obj, other, meshdata.base_positions(mesh), local), extra


def influence_weights(obj, entry, reuse_weights=False):
    """The entry's vertex-group weights as it applies them, inverted with Invert (as Simple Deform
    and the Lattice modifier: ungrouped vertices then get 1), or None without a group. They are read
    by a per-vertex loop; with reuse_weights, those read last time are used (parameter edits and
    frame changes do not change them; edits of the mesh re-read them)."""
    if not entry.vertex_group:
        return None
    weights = meshdata.group_weights(obj, entry.vertex_group, reuse_weights)
    return meshdata.inverted(weights) if entry.invert_vertex_group else weights


def scaled_influence(obj, entry, reuse_weights=False):
    """influence_weights times the entry's Strength (None: every vertex fully)."""
    weights = influence_weights(obj, entry, reuse_weights)
    if entry.strength != 1.0:
        weights = np.full(len(obj.data.vertices), entry.strength) if weights is None else weights * entry.strength
    return weights


def weights_crc(weights):
    """A fingerprint of per-point weights (None: no weights), kept with read-only ones."""
    return meshdata.weights_crc(weights)


def kept_binding(space, key, bind_key, points, bind):
    """bind(points), kept in the cache's `space` under `key` ((object cache key, entry index,
    "viewport"/"render")) while `bind_key` (what the binding depends on besides the points, its
    [0] the object's cache key) and the points stay: binding costs more than a frame's
    deform_bound. A ValueError of bind is the entry's failure (EntryError)."""
    cached = cache.get(space, key)
    if cached is None or cached[0] != bind_key or not np.array_equal(cached[1], points):
        try:
            cached = cache.put(space, key, (bind_key, points, bind(points)))
        except ValueError as exc:
            raise EntryError(str(exc)) from exc
    return cached[2]


def stack_index(entry):
    """The entry's place in its object's stack (an entry path ends in "entries[i]")."""
    path = entry.path_from_id()
    return int(path[path.rindex("[") + 1:-1])


def forget_bindings(object_key, space, entries, tail):
    """Drop the object's bindings in `space` but those of `entries` (of one kind) made for what
    they are now: kept under the entry's place in the whole stack (other kinds' entries count),
    with a bind key of (object cache key,) + tail(entry)."""
    alive = {(stack_index(e),) + tail(e) for e in entries}
    cache.forget(object_key, space, keep=lambda k: (k[1],) + cache.get(space, k)[0][1:] in alive)


def store_array(entry, name, values):
    """Keep a numpy array as the entry's ID property `name` (a bind's rest), replacing any old one:
    Blender 5.0 copies an array assigned over one of another length into the old buffer (a crash
    when longer, a truncated copy when shorter), so the old property goes first."""
    if name in entry:
        del entry[name]
    entry[name] = values


def write_base(obj, points):
    """Apply: the deformed points become the base mesh."""
    obj.data.vertices.foreach_set("co", points.ravel())


def draw_subpanel(col, entry, prop, label):
    """A collapsible group of an entry's settings, as a modifier's subpanel: a disclosure triangle
    and the label, open or closed as entry.<prop> (saved per entry, as Blender saves a subpanel's
    state per modifier). layout.panel() would do this but is Blender 4.2+ only. Returns the
    group's column when open, else None."""
    row = col.row(align=True)
    row.use_property_split = False  # the triangle and label sit left, as a subpanel header
    row.alignment = "LEFT"
    is_open = getattr(entry, prop)
    row.prop(entry, prop, text=label, emboss=False, icon="DOWNARROW_HLT" if is_open else "RIGHTARROW")
    return col.column() if is_open else None


def draw_vertex_group(col, obj, entry):
    row = col.row(align=True)
    row.prop_search(entry, "vertex_group", obj, "vertex_groups", text="Vertex Group")
    sub = row.row(align=True)
    sub.active = bool(entry.vertex_group)
    sub.prop(entry, "invert_vertex_group", text="", icon="ARROW_LEFTRIGHT")

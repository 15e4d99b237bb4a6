"""Laplacian entries: Laplacian surface editing and as-rigid-as-possible deformation
(dk.SurfaceDeformer) of the mesh coming into the entry.

As with Blender's Laplacian Deform, an entry deforms once it is bound. Bind records the positions
coming into the entry (the rest), a fingerprint of the topology and the handle object's place, all
on the entry itself: the rest is an ID property array of the entry, so it saves and undoes with
the object, goes away with the entry or on Unbind, and never reaches the mesh, whose attributes
belong to the Geometry Nodes output. Anchors stay at rest; handles go where the incoming mesh has
them (INCOMING), or to their rest moved as the handle object moved since bind, relative to the
mesh object as Blender's Hook modifier does (OBJECT).

Building the solver factorises its system (the expensive part). It is kept in memory per object
and bind, and built again from the saved rest when it is missing (file load, undo) or when what it
depends on changes: method, weights, iterations (ARAP, rotation-invariant), anchors, handles.

Here too: the entry's settings and panel; its operators are in operators/laplacian.py.
"""
import re
import zlib
from collections import namedtuple

import numpy as np

from .. import cache, meshdata, native
from ..errors import EntryError
from ..panel_text import label_wrapped
from . import binding
from .binding import is_bound, new_bind_id, signed
from .common import Prepared, affine_inverse, determinant3, followed_object, store_array, write_base

ENTRY_TYPES = [
    ("LAPLACIAN", "Laplacian", "Laplacian surface editing or as-rigid-as-possible deformation: anchors stay, "
     "handles move and the rest of the surface keeps its shape (Bind first, as Laplacian Deform)", "NONE", 5),
]
TYPES = tuple(row[0] for row in ENTRY_TYPES)  # its entry.type identifiers
SURFACE_METHODS = [
    ("ARAP", "As-Rigid-As-Possible", "Sorkine and Alexa 2007: local rotations and a global solve, repeated "
     "Iterations times; keeps details under large rotations", 0),
    ("ROTATION_INVARIANT", "Rotation Invariant", "Sorkine et al. 2004: the differential coordinates follow "
     "each one-ring's linearised similarity transform, then Iterations passes rotate them by each one-ring's "
     "rotation; keeps details under large rotations", 1),
    ("LAPLACIAN", "Laplacian", "Least squares on the differential coordinates, without rotations: one solve", 2),
]
# A new entry's settings where they differ from the properties' defaults, which stay as they were
# because a saved entry stores only what was set: an entry saved with the default method is ARAP.
# Rotation Invariant bends a tube smoothly, as Laplacian Deform does, where ARAP (at any number of
# iterations: converged, it pinches two necks) kinks near the anchor and handle rings
# (tests/addon/test_laplacian_determinism.py).
NEW_ENTRY = {"method": "ROTATION_INVARIANT"}
SURFACE_WEIGHTS = [
    ("COTANGENT", "Cotangent", "Cotangent weights: follow the surface's geometry", 0),
    ("UNIFORM", "Uniform", "Every neighbour counts the same: topology only", 1),
]
HANDLE_TARGETS = [
    ("INCOMING", "Incoming", "The handles go where the mesh coming into this entry has them (the base mesh "
     "through the entries above): move them by editing the mesh or with earlier entries, as with Laplacian "
     "Deform", 0),
    ("OBJECT", "Object", "The handles follow the handle object: they move as it moved since bind", 1),
]
ICON = "MOD_MESHDEFORM"
FIELDS = ("method", "weights", "iterations", "anchors_group", "handles_group", "handle_target", "handle_object")

REST = "deformkit_rest"  # the entry's ID property: the rest, x y z per vertex, float32
# A copy does not take the bind, the handle object's place at bind, nor where it was copied from.
NOT_COPIED = binding.NOT_COPIED + ("handle_matrix", "bind_copied_from")

# solver: the dk.SurfaceDeformer, None for an unbound entry (which passes its input through);
# targets: the handles' targets (OBJECT), or None to take them from the incoming points (INCOMING);
# fingerprint: everything besides the incoming points that the result depends on.
Setup = namedtuple("Setup", "solver handles targets fingerprint")
# settings: what the factorisation depends on besides the groups; rest: kept for OBJECT targets.
Solver = namedtuple("Solver", "settings anchors handles rest deformer")
# Solvers are kept in the cache's "laplacian" space: (object cache key, bind id) -> Solver.


def _settings(entry, topo):
    iterates = entry.method in ("ARAP", "ROTATION_INVARIANT")
    return (entry.method, entry.weights, entry.iterations if iterates else None, topo.crc)


def check_topology(entry, topo):
    """EntryError saying what changed when the mesh is not the one bound (the panel offers Rebind)."""
    changed = binding.counts_changed("the mesh", (entry.bind_vertices, entry.bind_faces), (topo.vertices, topo.faces))
    if not changed and signed(topo.crc) != entry.bind_topology:
        changed = (f"the mesh's faces connect its vertices differently than at bind ({binding.count(topo.vertices)} "
                   f"vertices and {binding.count(topo.faces)} faces, as then): Rebind")
    binding.require_current(entry, changed)


def members(obj, entry, reuse=False):
    """(anchors, handles): the vertices with a weight above 0 in each group, as Laplacian Deform."""
    found = []
    for role, name in (("anchors", entry.anchors_group), ("handles", entry.handles_group)):
        if not name:
            found.append(np.zeros(0, np.int64))
            continue
        if obj.vertex_groups.get(name) is None:
            raise EntryError(f"{role} vertex group '{name}' not found")
        found.append(np.flatnonzero(meshdata.group_weights(obj, name, reuse) > 0))
    anchors, handles = found
    if len(anchors) == 0 and len(handles) == 0:
        if not (entry.anchors_group or entry.handles_group):
            raise EntryError("no anchors and no handles: set the vertex group that stays (Anchors) or the one "
                             "that moves (Handles)")
        raise EntryError("the anchors and handles vertex groups have no vertex with a weight above 0, "
                         "so nothing holds the mesh")
    both = np.intersect1d(anchors, handles)
    if len(both):
        raise EntryError(f"{len(both)} vertices are in both the anchors group '{entry.anchors_group}' and the "
                         f"handles group '{entry.handles_group}': a vertex either stays or moves")
    return anchors, handles


def handle_object(entry):
    """The entry's handle object, or EntryError saying why it cannot be used."""
    return followed_object(entry, "handle_object", "handle", "no handle object set: pick one (an empty, say), or "
                           "let the handles follow the Incoming mesh")


def _matrix_of(obj):
    m = np.array(obj.matrix_world, np.float64)
    if not np.isfinite(m).all() or abs(determinant3(m[:3, :3])) < 1e-30:
        raise EntryError(f"handle object '{obj.name}' has a singular or non-finite transform (scale 0?)")
    return m


def _bind_matrix(obj, handle):
    """H(bind)^-1 obj(bind), which Blender's Hook modifier keeps too: with it, a handle object
    parented to the mesh object moves with it without deforming, and a handle object left in place
    while the mesh object moves holds the handles where they are in the world."""
    return affine_inverse(_matrix_of(handle)) @ np.array(obj.matrix_world, np.float64)


def handle_motion(obj, entry):
    """obj(now)^-1 H(now) H(bind)^-1 obj(bind): how the handles moved since bind, in obj's space."""
    now = np.array(handle_object(entry).matrix_world, np.float64)
    at_bind = np.array(entry.handle_matrix, np.float64).reshape(4, 4)
    if not at_bind.any():
        raise EntryError("the handle object's transform was singular when it was set: fix its scale, then Bind again")
    try:
        motion = affine_inverse(obj.matrix_world) @ now @ at_bind
    except ValueError:
        raise EntryError(f"the object '{obj.name}' has a singular transform (scale 0?)") from None
    if not np.isfinite(motion).all():
        raise EntryError(f"handle object '{entry.handle_object.name}': its transform is not finite (NaN or Inf)")
    return motion


def record_handle_matrix(entry):
    """The handle object's place now counts as its place at bind (zeros if it cannot be inverted,
    which handle_motion reports)."""
    try:
        entry.handle_matrix = _bind_matrix(entry.id_data, entry.handle_object).ravel().tolist()
    except EntryError:
        entry.handle_matrix = [0.0] * 16


def saved_rest(entry):
    data = entry.get(REST)
    if data is None or len(data) != 3 * entry.bind_vertices:
        raise EntryError("the bind data is missing or damaged: Unbind and Bind again")
    return np.array(data, np.float32).reshape(-1, 3)  # a copy: the ID property may go away


def build(entry, rest, topo, anchors, handles):
    """The factorised solver: the expensive step of a bind."""
    if topo.faces == 0:
        raise EntryError("the mesh has no faces: Laplacian entries deform a surface")
    try:
        return native.dk.SurfaceDeformer(rest, meshdata.triangles(topo), anchors=anchors, handles=handles,
                                         method=entry.method.lower(), weights=entry.weights.lower(),
                                         iterations=entry.iterations)
    except (ValueError, TypeError) as exc:
        raise EntryError(str(exc)) from exc
    except MemoryError:
        raise EntryError(f"not enough memory to factorise the system of {topo.vertices} vertices "
                         "(the Rotation Invariant method needs the most)") from None
    except RuntimeError as exc:  # CHOLMOD failures that are not the mesh's fault
        raise EntryError(f"the solver failed: {exc}") from exc


def _solver(obj, entry, topo, anchors, handles):
    key, settings = (meshdata.cache_key(obj), entry.bind_id), _settings(entry, topo)
    cached = cache.get("laplacian", key)
    if cached is None or cached.settings != settings or not np.array_equal(cached.anchors, anchors) \
            or not np.array_equal(cached.handles, handles):
        rest = saved_rest(entry)
        cached = cache.put("laplacian", key, Solver(settings, anchors, handles, rest,
                                                    build(entry, rest, topo, anchors, handles)))
    return cached


def setup(obj, entry, reuse_weights=False):
    """What the entry needs to deform its input (no pointwise deformer: it needs the whole mesh);
    EntryError for any problem with its settings."""
    laplacian = surface_setup(obj, entry, reuse_weights)
    return Prepared(None, laplacian.fingerprint, laplacian)


def surface_setup(obj, entry, reuse_weights=False):
    fingerprint = (entry.bind_id,)
    if not is_bound(entry):
        return Setup(None, None, None, fingerprint)
    topo = meshdata.topology(obj.data)
    check_topology(entry, topo)
    anchors, handles = members(obj, entry, reuse_weights)
    solver = _solver(obj, entry, topo, anchors, handles)
    targets, motion = None, None
    if entry.handle_target == "OBJECT":
        motion = handle_motion(obj, entry)
        targets = solver.rest[handles].astype(np.float64) @ motion[:3, :3].T + motion[:3, 3]
        if not np.isfinite(targets).all():
            raise EntryError("the handles' targets are not finite (the handle object is too far away)")
    fingerprint += (solver.settings, entry.handle_target, zlib.crc32(anchors.tobytes()),
                    zlib.crc32(handles.tobytes()), None if motion is None else motion.tobytes())
    return Setup(solver.deformer, handles, targets, fingerprint)


def deform(key, prepared, points):
    """The entry's result for the incoming points; a failure is the entry's (EntryError)."""
    try:
        return surface_deform(prepared.data, points)
    except EntryError:
        raise
    except ValueError as exc:
        raise EntryError(str(exc)) from exc


def apply(obj, entry, prepared, base):
    write_base(obj, surface_deform(prepared.data, base))  # the handles come from the base mesh (INCOMING)


def surface_deform(entry_setup, points):
    """The entry's result for the incoming points (float32, like every other entry's): a function
    of them and the entry's settings alone. ARAP starts every evaluation from R = I, never from an
    earlier evaluation's result: a start from the last result during a drag would make what the
    viewport shows depend on the drag's path, and with a fixed number of iterations differ from the
    render, the batch and the reopened file (docs/blender_addon.md, the Laplacian entries)."""
    if entry_setup.solver is None:
        return points
    targets = entry_setup.targets
    if targets is None:
        targets = points[entry_setup.handles].astype(np.float64)
        if not np.isfinite(targets).all():
            raise EntryError("the handles' incoming positions are not finite")
    return entry_setup.solver.deform(targets).astype(np.float32)


def bind(obj, entry, incoming):
    """Record the points coming into the entry (incoming()) as the rest, with the handle object's
    place, and build the solver; nothing changes if that fails. Returns the number of vertices."""
    if obj.mode == "EDIT":
        raise EntryError("bind: leave edit mode first (edit mode holds its own copy of the mesh)")
    points = incoming()
    topo = meshdata.topology(obj.data)
    anchors, handles = members(obj, entry)
    matrix = _bind_matrix(obj, entry.handle_object) if entry.handle_object is not None else np.eye(4)
    rest = np.array(points, np.float32).reshape(-1, 3)
    deformer = build(entry, rest, topo, anchors, handles)
    key = meshdata.cache_key(obj)
    cache.pop("laplacian", (key, entry.bind_id))
    bind_id = new_bind_id(obj)
    store_array(entry, REST, rest.ravel())
    entry.bind_vertices, entry.bind_faces, entry.bind_topology = topo.vertices, topo.faces, signed(topo.crc)
    entry.handle_matrix = matrix.ravel().tolist()
    entry.bind_id = bind_id
    entry.bind_copied_from = ""
    cache.put("laplacian", (key, bind_id), Solver(_settings(entry, topo), anchors, handles, rest, deformer))
    return topo.vertices


def copy_bind(source, target):
    """Give `target`, a copy of `source` on the same object (Duplicate), source's bind: the rest,
    the topology's fingerprint and the handle object's place at bind. Under a new bind id, so the
    two never share a solver (their settings may part); the copy's is built from its rest, which
    is source's, so it deforms as source does."""
    if not is_bound(source):
        return
    store_array(target, REST, saved_rest(source).ravel())
    target.bind_vertices, target.bind_faces = source.bind_vertices, source.bind_faces
    target.bind_topology = source.bind_topology
    target.handle_matrix = source.handle_matrix[:]
    target.bind_id = new_bind_id(target.id_data)


def unbind(obj, entry):
    cache.pop("laplacian", (meshdata.cache_key(obj), entry.bind_id))
    clear(entry)


def clear(entry):
    binding.forget(entry, (REST,))
    entry.bind_vertices = entry.bind_faces = entry.bind_topology = 0


def status(obj, entry):
    """(status line, the solver's warnings) for the panel."""
    if not is_bound(entry):
        if entry.bind_copied_from:  # Copy to Selected: a bind is of the mesh it was made on
            return f"Copied unbound from '{entry.bind_copied_from}': Bind again", []
        return "Not bound", []
    cached = cache.get("laplacian", (meshdata.cache_key(obj), entry.bind_id))
    if cached is None:
        return f"Bound: {entry.bind_vertices} vertices", []
    return (f"Bound: {entry.bind_vertices} vertices, {len(cached.anchors)} anchors, {len(cached.handles)} handles",
            list(cached.deformer.warnings))


# dk.SurfaceDeformer's warning for a connected component that nothing holds (surface_deformer.cpp,
# fixed_vertices): one per component, so a mesh of many loose parts would fill the panel.
_UNANCHORED = re.compile(r"component \d+ \(\d+ vertices\) has no anchor or handle; it is left where it is")


def summarised_warnings(warnings):
    """(number of parts left where they are, the other warnings) of the solver's warnings."""
    others = [w for w in warnings if not _UNANCHORED.fullmatch(w)]
    return len(warnings) - len(others), others


def unanchored_line(count):
    """The panel's one line for `count` parts without an anchor or handle."""
    # Short enough for one line beside the Select button at the default width; the button's
    # tooltip says that handles hold a part too.
    if count == 1:
        return "1 unanchored part stays in place"
    return f"{count} unanchored parts stay in place"


def unanchored_vertices(obj, entry):
    """The vertices of the components of the mesh with no anchor and no handle (those the
    solver leaves where they are), sorted."""
    topo = meshdata.topology(obj.data)
    anchors, handles = members(obj, entry)
    labels = meshdata.face_components(topo)
    held = np.zeros(topo.vertices, bool)
    held[labels[np.concatenate([anchors, handles]).astype(np.int64)]] = True
    return np.flatnonzero(~held[labels])


# Keyed by the bind (bind_id) and checked against the settings, anchors and handles: undo keeps
# the factorised solvers.
KEPT_THROUGH_UNDO = ("laplacian",)


def prune(object_key, entries):
    """Drop the solvers of binds that the object no longer has (removed, unbound, retyped)."""
    bind_ids = {e.bind_id for e in entries}
    cache.forget(object_key, "laplacian", keep=lambda key: key[1] in bind_ids)


def followed(entry):
    """(object, remembered name) of the objects the entry follows: the handle object, if the
    handles follow it."""
    return [(entry.handle_object, entry.handle_object_name)] if entry.handle_target == "OBJECT" else []


def volume_note(entries):
    if any(e.show_viewport for e in entries):
        return "Volume colors leave out Laplacian entries (no Jacobian)"
    return ""


def retyped(entry):
    """The entry became another kind: a bind belongs to a Laplacian entry, so no hidden rest is
    left on other kinds."""
    if is_bound(entry):
        clear(entry)


def draw(col, obj, entry):
    """Laid out like Blender's Laplacian Deform panel: settings, then the bind state and button."""
    index = list(obj.deformkit.entries).index(entry)
    col.prop(entry, "method")
    col.prop(entry, "weights")
    sub = col.row()
    sub.active = entry.method != "LAPLACIAN"  # naive editing solves once
    sub.prop(entry, "iterations")
    col.prop_search(entry, "anchors_group", obj, "vertex_groups", text="Anchors")
    col.prop_search(entry, "handles_group", obj, "vertex_groups", text="Handles")
    col.row().prop(entry, "handle_target", expand=True)
    if entry.handle_target == "OBJECT":
        col.prop(entry, "handle_object")
    col.separator()
    text, warnings = status(obj, entry)
    label_wrapped(col, text, "LINKED" if is_bound(entry) else "UNLINKED")
    unanchored, warnings = summarised_warnings(warnings)
    if unanchored:
        row = col.row()
        row.label(text=unanchored_line(unanchored), icon="INFO")
        row.operator("deformkit.laplacian_select_unanchored", text="Select", icon="RESTRICT_SELECT_OFF").index = index
    for warning in warnings:
        label_wrapped(col, warning, "INFO")
    if is_bound(entry):
        binding.draw_rebind(col, entry, "deformkit.laplacian_bind", index, "deformkit.laplacian_unbind")
    else:
        col.operator("deformkit.laplacian_bind", text="Bind", icon="LINKED").index = index


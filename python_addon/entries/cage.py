"""Cage entries: a closed mesh object (the cage) deforms the mesh through mean value, Green or
harmonic coordinates (dk.MeanValueCage, dk.GreenCage, dk.MeshDeform), as Blender's Mesh Deform
modifier is used; Harmonic is that modifier's own, with its Precision and Dynamic.

Bind records the cage's rest shape in this object's space, with a fingerprint of its topology, on
the entry itself (an ID property array, so it saves and undoes with the object and never reaches
the mesh). Afterwards the entry follows the cage object's *evaluated* mesh: a cage rigged with an
Armature, edited in Edit Mode, shape-keyed or keyframed drives the mesh, and (Mean Value, Green)
moving the cage object moves the mesh. The mesh is bound to the rest cage once per incoming points
(kept in the cache's "cage" space), and each evaluation is one product of the bound coordinates
with the current cage. Harmonic works as Mesh Deform does, in the cage object's own space at bind
(FRAME): a moved cage object turns the displacement and does not carry the mesh. Without Dynamic
it binds the points coming into the entry at Bind (kept with the file: saved_rows), whose
coordinates later points of the same count keep (x + W (c - c at bind)); another vertex count
asks for Rebind.

Here too: the entry's settings and panel; its operators are in operators/cage.py.
"""
import zlib
from collections import namedtuple

import bpy
import numpy as np

from .. import cache, meshdata, native, panel_text
from ..errors import EntryError
from . import binding, saved_rows
from .binding import is_bound, new_bind_id, signed
from .common import (Prepared, affine_inverse, draw_vertex_group, evaluated_mesh_in, followed_mesh, forget_bindings,
                     is_identity, kept_binding, relative, scaled_influence, stack_index, store_array, weights_crc)

ENTRY_TYPES = [  # saved as its number: listed before Subdivide, numbered after
    ("CAGE", "Cage", "A closed mesh object (the cage) deforms the mesh through mean value, Green or harmonic "
     "coordinates, as Mesh Deform (Bind first)", "NONE", 7),
]
TYPES = tuple(row[0] for row in ENTRY_TYPES)  # its entry.type identifiers
CAGE_METHODS = [
    ("MEAN_VALUE", "Mean Value", "Mean value coordinates (Ju, Schaefer, Warren 2005): smooth, interpolate the cage", 0),
    ("GREEN", "Green", "Green coordinates (Lipman, Levin, Cohen-Or 2008): keep details' shape (quasi-conformal)", 1),
    ("HARMONIC", "Harmonic", "Harmonic coordinates on a grid (Joshi et al. 2007), as Blender's Mesh "
     "Deform modifier computes them, with its Precision and Dynamic", 2),
]
ICON = "MOD_MESHDEFORM"
FIELDS = ("cage", "cage_method", "precision", "use_dynamic_bind", "strength", "vertex_group", "invert_vertex_group")
CLASSES = {"MEAN_VALUE": "MeanValueCage", "GREEN": "GreenCage", "HARMONIC": "MeshDeform"}

REST = "deformkit_cage_rest"  # the entry's ID property: the cage at bind, x y z per vertex, in this object's space
# Harmonic, not Dynamic: the points that came into the entry at bind, x y z: on the entry in
# binds before saved_rows, which keeps them now
BOUND = "deformkit_cage_bound"
# Harmonic, Dynamic: which of the points that came into the entry at bind were inside the cage (1/0
# per vertex): Mesh Deform's dynamic bind deforms those, wherever they are now (its dynverts).
INSIDE = "deformkit_cage_inside"
# Harmonic: this object's inverse times the cage object's matrix at bind (4 x 4, row-major). Mesh
# Deform lays its grid along the cage object's own axes and turns the displacement by how the two
# objects stand now, so the entry does too.
FRAME = "deformkit_cage_frame"
SAVED = (REST, BOUND, FRAME, INSIDE)  # what a bind writes on the entry
NOT_COPIED = binding.NOT_COPIED + ("harmonic_rows",)  # a copy arrives unbound

# deformer: the dk cage deformer with the current cage and the entry's influence; bind: the key its
# deformer and bindings are kept under; fingerprint: everything besides the incoming points;
# harmonic: a Harmonic entry's Frame, else None.
Setup = namedtuple("Setup", "deformer bind fingerprint harmonic", defaults=(None,))
# A Harmonic entry in the cage's own space: now, this object's space to the cage's (4 x 4); turn,
# the cage's displacements into this object's space (3 x 3, None when that is the identity; setup
# turns the cage's displacements, so the deformer's offsets are this object's);
# bound, (points, in the cage's space as float32, their saved rows or None) of a bind that keeps
# its points (not Dynamic), else None; inside, a Dynamic bind's flags of Bind (bool per point),
# else None; weights, the per-point influence (vertex group, strength) scaling the displacement,
# or None: the grid is solved without them, so a Strength drag never solves it again.
Frame = namedtuple("Frame", "now turn bound inside weights", defaults=(None, None))
# In the cache: "cage_binding", (object cache key, entry index, "viewport"/"render") -> (bind key
# (object cache key, bind id, method[, precision, dynamic]), points, binding); "cage_deformer", bind
# key -> (crc of the per-point weights, deformer); "cage_bound", bind key -> the points bound at Bind;
# "cage_inside", bind key -> a Dynamic bind's inside flags of Bind;
# "cage_rest", bind key -> a Harmonic entry's rest cage in the cage's space; "cage_towards", bind key
# -> (the cage's place in this object's space, its inverse, its turn) last seen.


UNSET = "no cage object set: pick a closed mesh object around the mesh"
HINT = "Pick a closed mesh object around the mesh as Object, then Bind"


def cage_object(entry, obj, unset=UNSET):
    return followed_mesh(entry, "cage", "cage", obj, unset)


def evaluated_cage(obj, cage, now=None):
    """The cage's evaluated mesh (its modifiers, shape keys and edits applied) in obj's space (now:
    relative(obj, cage), if made already): (points float64 (m, 3), its meshdata.Topology, topology
    fingerprint (vertices, faces, crc)). The polygons are made from the topology only where a
    deformer is built: splitting a cage of mixed polygons costs more than the rest of a frame."""
    points, topo = evaluated_mesh_in(obj, cage, meshdata.topology, now)
    return points, topo, (topo.vertices, topo.faces, signed(topo.crc))


def topology_change(entry, now):
    """What changed in the cage's topology since bind, or ''."""
    vertices, faces, crc = now
    # Not the cage's name: a message naming the cage reads as the one for its deletion (handlers).
    changed = binding.counts_changed("the cage", (entry.bind_vertices, entry.bind_faces), (vertices, faces))
    if not changed and crc != entry.bind_topology:
        changed = "the cage's faces connect its vertices differently than at bind: Rebind"
    return changed


def _class(entry):
    cls = getattr(native.dk, CLASSES[entry.cage_method], None)
    if cls is None:
        raise EntryError(f"this build of deformkit has no {CLASSES[entry.cage_method]}: {native.BUILD_HINT}")
    return cls


def _make(cls, entry, points, faces, weights=None):
    """The dk deformer of this rest cage with the entry's settings; ValueError naming what is wrong."""
    # blender_version: the ray casts of this Blender's own Mesh Deform (its tree changed in 4.4).
    harmonic = {"precision": entry.precision, "dynamic": entry.use_dynamic_bind,
                "blender_version": tuple(bpy.app.version[:2])} if entry.cage_method == "HARMONIC" else {}
    try:
        return cls(points, faces, weights=weights, **harmonic)
    except RuntimeError as exc:  # Mesh Deform's own failure, naming the cage: not the solver's fault
        raise EntryError(str(exc)) from exc


def bind_key(obj, entry):
    """What the entry's deformer and bindings are kept under: a new bind, method or grid is new."""
    return (meshdata.cache_key(obj),) + grid_tail(entry)


def _deformer(key, entry, topo, weights, rest=None):
    """The dk cage deformer of the rest cage (the saved one, or `rest`; its polygons from `topo`) with
    these per-point weights, kept under `key` (bind_key) while the bind and the weights stay:
    checking the cage and building its tables costs about as much as a frame."""
    cls = _class(entry)
    crc = weights_crc(weights)
    cached = cache.get("cage_deformer", key)
    if cached is not None and cached[0] == crc:
        return cached[1], crc
    if rest is None:
        rest = np.asarray(entry[REST], np.float64).reshape(-1, 3)
    try:
        deformer = _make(cls, entry, rest, meshdata.polygons(topo), weights)
    except ValueError as exc:
        raise EntryError(str(exc)) from exc
    cache.put("cage_deformer", key, (crc, deformer))
    return deformer, crc


def to_space(points, matrix):
    if is_identity(matrix):
        return np.array(points, np.float64)
    return np.asarray(points, np.float64) @ matrix[:3, :3].T + matrix[:3, 3]


def cage_space(points, to_cage):
    """Mesh points in the cage's space, as float32 (Blender's own bind and frame are float): their
    binding then writes float32 offsets straight into Blender's attribute."""
    return to_space(points, to_cage).astype(np.float32)


def saved_frame(entry):
    return np.array(entry[FRAME], np.float64).reshape(4, 4)


def bound_points(key, entry):
    """(points bound at Bind, the same in the cage's space at bind) of a Harmonic entry that is not
    Dynamic, or None; read from the entry once per bind (kept under its bind_key in the cache's
    "cage_bound" space), not every frame."""
    kept = cache.get("cage_bound", key)
    if kept is not None or entry.cage_method != "HARMONIC" or entry.use_dynamic_bind:
        return kept
    flat = saved_rows.points(entry)
    flat = entry.get(BOUND) if flat is None else flat
    if flat is None:
        return None
    points = np.array(flat, np.float32).reshape(-1, 3)
    rows = saved_rows.read(entry)
    return cache.put("cage_bound", key, (points, cage_space(points, affine_inverse(saved_frame(entry))), rows))


def inside_at_bind(key, entry):
    """A Dynamic Harmonic entry's inside flags of Bind (bool per point), or None (bound before the
    entry kept them: the points are then tested where they are); read once per bind."""
    kept = cache.get("cage_inside", key)
    if kept is not None or entry.cage_method != "HARMONIC" or not entry.use_dynamic_bind or INSIDE not in entry:
        return kept
    return cache.put("cage_inside", key, np.array(entry[INSIDE], np.int32) != 0)


def mesh_change(obj, entry, count):
    """What changed in the mesh since a Harmonic bind of its points (`count` of them), or ''. In
    Edit Mode the mesh's count is the edit mesh's: deform checks it there."""
    if count is None or obj.mode == "EDIT":
        return ""
    return binding.counts_changed("the mesh", (count,), (len(obj.data.vertices),))


def bound_count(frame):
    """How many points a Harmonic bind holds (Mesh Deform's verts_num, either mode), or None."""
    return len(frame.bound[0]) if frame.bound is not None else None if frame.inside is None else len(frame.inside)


def harmonic_frame(key, entry, now, points):
    """(Frame, the rest cage and the current cage in the cage's space) of a Harmonic entry whose
    cage stands at `now` (relative(obj, cage)) in this object's space."""
    to_cage, turn = _towards_cage(key, now)
    frame = Frame(to_cage, turn, bound_points(key, entry), inside_at_bind(key, entry))
    return frame, rest_in_cage(key, entry), to_space(points, to_cage)


def _towards_cage(key, now):
    """(now^-1, now's turn or None when it has none), kept while the two objects stand alike: on a
    cage drag they do frame after frame."""
    kept = cache.get("cage_towards", key)
    if kept is None or not np.array_equal(kept[0], now):
        turn = None if np.array_equal(now[:3, :3], np.eye(3)) else now[:3, :3]
        kept = cache.put("cage_towards", key, (now, affine_inverse(now), turn))
    return kept[1], kept[2]


def rest_in_cage(key, entry):
    """A Harmonic entry's rest cage in the cage's space at bind, read from the entry once per bind
    (the cache's "cage_rest" space), not every frame."""
    rest = cache.get("cage_rest", key)
    if rest is None:
        at_bind = affine_inverse(saved_frame(entry))
        rest = cache.put("cage_rest", key, to_space(np.asarray(entry[REST], np.float64).reshape(-1, 3), at_bind))
    return rest


def setup(obj, entry, reuse_weights=False):
    cage = cage_object(entry, obj, unset="")  # none picked yet: a hint in the panel, as Mesh Deform's
    if cage is None or not is_bound(entry) or REST not in entry:
        return Prepared(None, ("unbound",), None)  # as Mesh Deform before Bind: the mesh passes through
    key = bind_key(obj, entry)
    # Bound with Mean Value or Green, a Harmonic entry lacks the frame of its grid.
    lacks_frame = key[2] == "HARMONIC" and FRAME not in entry
    return _posed(obj, entry, cage, key, lambda: scaled_influence(obj, entry, reuse_weights), None, lacks_frame)


def refresh(obj, entry, prepared):
    """setup again where only the cage changed, or where it or this object stands, since `prepared`
    (evaluation's Reason.MOVED): the entry's settings, its bind, the mesh and its weights are as they
    were, so a frame of a cage drag reads the cage and nothing else."""
    last = prepared.data
    return prepared if last is None else _posed(obj, entry, entry.cage, last.bind, None, last)


def _posed(obj, entry, cage, key, influence, last, lacks_frame=False):
    """The rest of setup, from the cage on: its evaluated mesh and where it stands now, checked
    against the bind, set on the deformer. The weights are influence()'s, or with `last` (a Setup:
    refresh) its weights, deformer and the mesh's check."""
    now = relative(obj, cage)
    points, topology, topo = evaluated_cage(obj, cage, now)
    frame, rest = None, None
    changed = "bound for another method: Rebind" if lacks_frame else topology_change(entry, topo)
    if key[2] == "HARMONIC" and not changed:
        frame, rest, points = harmonic_frame(key, entry, now, points)
        changed = "" if last is not None else \
            mesh_change(obj, entry, bound_count(frame)) or saved_rows.gone(entry, frame.bound)
    binding.require_current(entry, changed)
    if last is not None:
        deformer, crc = last.deformer, last.fingerprint[2]
        weights = None if frame is None else last.harmonic.weights
    elif frame is not None:
        weights = influence()
        deformer, crc = _deformer(key, entry, topology, None, rest)[0], weights_crc(weights)
    else:
        deformer, crc = _deformer(key, entry, topology, influence())
    if frame is not None:
        frame = frame._replace(weights=weights)
        if frame.turn is not None:  # R sum_a w_a d_a = sum_a w_a (R d_a): the offsets come out turned
            rest = deformer.rest_cage_points
            points = rest + (points - rest) @ frame.turn.T
    deformer.cage_points = points
    fingerprint = (key, zlib.crc32(points.tobytes()), crc) + (() if frame is None else (frame.now.tobytes(),))
    return Prepared(deformer, fingerprint, Setup(deformer, key, fingerprint, frame))


def deform(key, prepared, points):
    """The entry's result on `points`, through a binding kept while the points and the bind stay."""
    setup_ = prepared.data
    if setup_ is None:
        return points
    if setup_.harmonic is not None:
        return harmonic_deform(key, setup_, points)
    # float32 weights, as the mesh's positions are: half the memory and time per frame.
    binding_ = kept_binding("cage_binding", key, setup_.bind, points,
                            lambda p: setup_.deformer.bind(p, precision="float32"))
    return setup_.deformer.deform_bound(binding_)


def harmonic_deform(key, setup_, points):
    """Mesh Deform's result in this object's space: the points as they come plus their offsets."""
    return (points + harmonic_offsets(key, setup_, points, None)).astype(np.float32, copy=False)


def displace(key, prepared, points, out):
    """The entry's offsets on `points` into `out` (float32): Harmonic's in one pass of the bound
    coordinates (Mesh Deform's own evaluation); the other methods' deform minus the points."""
    setup_ = prepared.data
    if setup_ is None:
        out[...] = 0.0
        return out
    if setup_.harmonic is not None:
        return harmonic_offsets(key, setup_, points, out)
    return np.subtract(deform(key, prepared, points), points, out=out, casting="same_kind")


def harmonic_offsets(key, setup_, points, out):
    """w R sum_a w_a (c_a - c_a at bind) / sum_a w_a at the points in the cage's space (as bound at
    Bind, or as they come with Dynamic), float32, into `out` if given: the deformer's cage carries
    the turn R (setup), its binding is float32, so this is one pass (exact zeros at the rest cage)."""
    frame = setup_.harmonic
    count = bound_count(frame)
    if count is not None and count != len(points):
        raise EntryError(binding.counts_changed("the mesh", (count,), (len(points),)))
    local = frame.bound[1] if frame.bound is not None else cage_space(points, frame.now)
    cached = cache.get("cage_binding", key)
    if cached is not None and cached[0] == setup_.bind and cached[1] is local:  # the points kept at Bind
        bound = cached[2]
    elif frame.inside is not None:
        bound = kept_binding("cage_binding", key, setup_.bind, local,
                             lambda p: setup_.deformer.bind(p, inside=frame.inside))
    else:
        rows = frame.bound[2] if frame.bound is not None else None
        bound = kept_binding("cage_binding", key, setup_.bind, local,
                             lambda p: saved_rows.bind(setup_.deformer, p, rows))
    moved = setup_.deformer.displacement_bound(bound, out=out)
    if frame.weights is not None:
        if len(frame.weights) != len(points):
            raise EntryError(f"the vertex group's weights are for {len(frame.weights)} vertices, the mesh coming into "
                             f"the entry has {len(points)}")
        np.multiply(moved, np.asarray(frame.weights)[:, None], out=moved, casting="same_kind")
    return moved


def bind(obj, entry, incoming, rest=None):
    """Record the cage's current evaluated shape (or `rest`, its points in obj's space) as its rest
    (checked: a closed, consistently oriented cage); Harmonic also binds the points coming into the
    entry (incoming()), as Mesh Deform's Bind: without Dynamic their coordinates, with it which of
    them are inside. Nothing changes if that fails. Returns the cage's vertex count."""
    cage = cage_object(entry, obj)
    points, topology, topo = evaluated_cage(obj, cage)
    faces = meshdata.polygons(topology)
    if rest is not None:
        points = np.asarray(rest, np.float32).astype(np.float64).reshape(points.shape)
    harmonic = entry.cage_method == "HARMONIC"
    frame = relative(obj, cage) if harmonic else None
    to_cage = None if frame is None else affine_inverse(frame)
    rest_points = points if frame is None else to_space(points.astype(np.float32), to_cage)
    # Checks the cage: ValueError naming its first open edge, bad face, ...
    deformer = _make(_class(entry), entry, rest_points, faces)
    mesh = np.asarray(incoming(), np.float32).reshape(-1, 3) if harmonic else None
    local = None if mesh is None else cage_space(mesh, to_cage)
    try:
        made = None if local is None else deformer.bind(local)  # Mesh Deform's solve: its failure leaves the entry
    except RuntimeError as exc:  # "cannot find a bind solution", naming the cage
        raise EntryError(str(exc)) from exc
    inside, rows = None, (None,) * len(saved_rows.ROWS)
    if made is not None and entry.use_dynamic_bind:  # only the flags are kept: the points are read as they come
        inside, mesh, made = made.inside, None, None
    elif made is not None:
        starts, vertices, weights = made.weights()
        rows = (starts.astype(np.int32), vertices, weights.astype(np.float32))
    bind_id = new_bind_id(obj)
    store_array(entry, REST, points.astype(np.float32).ravel())
    flags = None if inside is None else inside.astype(np.int32)  # an ID property takes int32, not bytes
    for name, values in ((BOUND, None), (FRAME, frame), (INSIDE, flags)):  # the points: saved_rows
        if values is not None:
            store_array(entry, name, values.ravel())
        elif name in entry:
            del entry[name]
    saved_rows.keep(entry, None if mesh is None else mesh.ravel(), rows)
    entry.bind_vertices, entry.bind_faces, entry.bind_topology = topo
    entry.bind_id = bind_id  # a new bind key: the old bindings are not used again
    key = bind_key(obj, entry)
    cache.put("cage_deformer", key, (weights_crc(None), deformer))  # a Dynamic grid: solved once
    if made is not None:  # the first evaluation uses this binding, not a second solve
        cache.put("cage_bound", key, (mesh, local, None))
        index = stack_index(entry)
        for kind in ("viewport", "render"):
            cache.put("cage_binding", (meshdata.cache_key(obj), index, kind), (key, local, made))
    return topo[0]


def unbind(obj, entry):
    binding.forget(entry, SAVED)
    saved_rows.keep(entry, None, None)


def followed(entry):
    return [(entry.cage, entry.cage_name)]


def grid_tail(entry):
    """bind_key without the object's key."""
    return (entry.bind_id, entry.cage_method) + ((entry.precision, entry.use_dynamic_bind)
                                                 if entry.cage_method == "HARMONIC" else ())


# Keyed by bind_key (its bind_id) or checked against it and the bound points: undo keeps them.
KEPT_THROUGH_UNDO = ("cage_deformer", "cage_binding", "cage_bound", "cage_rest", "cage_inside")


def prune(object_key, entries):
    """Bindings of binds no entry has any more go."""
    forget_bindings(object_key, "cage_binding", entries, grid_tail)
    alive = {grid_tail(e) for e in entries}
    for space in ("cage_deformer", "cage_bound", "cage_rest", "cage_inside", "cage_towards"):
        cache.forget(object_key, space, keep=lambda k: k[1:] in alive)


def retyped(entry):
    binding.forget(entry, SAVED)
    saved_rows.keep(entry, None, None)


def draw(col, obj, entry):
    """Laid out like Blender's Mesh Deform panel: the cage, the method, Bind / Unbind."""
    index = list(obj.deformkit.entries).index(entry)
    col.prop(entry, "cage", text="Object")
    if entry.cage is None and not entry.cage_name:
        panel_text.label_wrapped(col, HINT, "INFO", panel_text.box_budget())  # a label is cut
        col.operator("deformkit.generate_cage", icon="MESH_ICOSPHERE").index = index  # or let deformkit make one
    col.prop(entry, "cage_method", text="Method")
    if entry.cage_method == "HARMONIC":  # Mesh Deform's settings, read at Bind
        at_bind = col.column()
        at_bind.enabled = not is_bound(entry)
        at_bind.prop(entry, "precision")
        at_bind.prop(entry, "use_dynamic_bind")
    col.prop(entry, "strength", slider=True)
    draw_vertex_group(col, obj, entry)
    col.separator()
    if is_bound(entry):
        col.label(text=f"Bound: cage of {entry.bind_vertices} vertices", icon="LINKED")
        binding.draw_rebind(col, entry, "deformkit.cage_bind", index, "deformkit.cage_unbind")
    else:
        col.label(text="Not bound", icon="UNLINKED")
        col.operator("deformkit.cage_bind", text="Bind", icon="LINKED").index = index

"""Cage entries: a closed mesh object (the cage) deforms the mesh through mean value or Green
coordinates (dk.MeanValueCage, dk.GreenCage), as Blender's Mesh Deform modifier is used.

Bind records the cage's rest shape in this object's space, with a fingerprint of its topology, on
the entry itself (an ID property array, so it saves and undoes with the object and never reaches
the mesh). Afterwards the entry follows the cage object's *evaluated* mesh: a cage rigged with an
Armature, edited in Edit Mode, shape-keyed or keyframed drives the mesh, and moving the cage object
moves the mesh, as with Mesh Deform. The mesh is bound to the rest cage once per incoming points
(kept in the cache's "cage" space), and each evaluation is one product of the bound coordinates
with the current cage.

Here too: the entry's settings and panel; its operators are in operators/cage.py.
"""
import zlib
from collections import namedtuple

import numpy as np

from .. import cache, meshdata, native, panel_text
from ..errors import EntryError
from . import binding
from .binding import is_bound, new_bind_id, signed
from .common import (Prepared, draw_vertex_group, evaluated_mesh_in, followed_mesh, forget_bindings,
                     kept_binding, scaled_influence, store_array, weights_crc)

ENTRY_TYPES = [  # saved as its number: listed before Subdivide, numbered after
    ("CAGE", "Cage", "A closed mesh object (the cage) deforms the mesh through mean value or Green coordinates, "
     "as Mesh Deform (Bind first)", "NONE", 7),
]
TYPES = tuple(row[0] for row in ENTRY_TYPES)  # its entry.type identifiers
CAGE_METHODS = [
    ("MEAN_VALUE", "Mean Value", "Mean value coordinates (Ju, Schaefer, Warren 2005): smooth, interpolate the cage", 0),
    ("GREEN", "Green", "Green coordinates (Lipman, Levin, Cohen-Or 2008): keep details' shape (quasi-conformal)", 1),
]
ICON = "MOD_MESHDEFORM"
FIELDS = ("cage", "cage_method", "strength", "vertex_group", "invert_vertex_group")
CLASSES = {"MEAN_VALUE": "MeanValueCage", "GREEN": "GreenCage"}

REST = "deformkit_cage_rest"  # the entry's ID property: the cage at bind, x y z per vertex, in this object's space
NOT_COPIED = binding.NOT_COPIED  # a copy arrives unbound

# deformer: the dk cage deformer with the current cage and the entry's influence; bind: the key its
# deformer and bindings are kept under; fingerprint: everything besides the incoming points.
Setup = namedtuple("Setup", "deformer bind fingerprint")
# In the cache: "cage_binding", (object cache key, entry index, "viewport"/"render") -> (bind key
# (object cache key, bind id, method), points, binding); "cage_deformer", bind key -> (crc of the
# per-point weights, deformer).


UNSET = "no cage object set: pick a closed mesh object around the mesh"
HINT = "Pick a closed mesh object around the mesh as Object, then Bind"


def cage_object(entry, obj, unset=UNSET):
    return followed_mesh(entry, "cage", "cage", obj, unset)


def evaluated_cage(obj, cage):
    """The cage's evaluated mesh (its modifiers, shape keys and edits applied) in obj's space:
    (points float64 (m, 3), faces, topology fingerprint (vertices, faces, crc))."""
    points, topo = evaluated_mesh_in(obj, cage, meshdata.topology)
    return points, meshdata.polygons(topo), (topo.vertices, topo.faces, signed(topo.crc))


def topology_change(entry, now):
    """What changed in the cage's topology since bind, or ''."""
    vertices, faces, crc = now
    if (vertices, faces) != (entry.bind_vertices, entry.bind_faces):
        return (f"the cage had {entry.bind_vertices} vertices and {entry.bind_faces} faces at bind and has "
                f"{vertices} and {faces} now: bind again")
    if crc != entry.bind_topology:
        return "the cage's faces connect its vertices differently than at bind: bind again"
    return ""


def _deformer(obj, entry, faces, weights):
    """The dk cage deformer of the rest cage with these per-point weights, kept while the bind and
    the weights stay: checking the cage and building its tables costs about as much as a frame."""
    cls = getattr(native.dk, CLASSES[entry.cage_method], None)
    if cls is None:
        raise EntryError(f"this build of deformkit has no cage deformers: {native.BUILD_HINT}")
    bind_key = (meshdata.cache_key(obj), entry.bind_id, entry.cage_method)
    crc = weights_crc(weights)
    cached = cache.get("cage_deformer", bind_key)
    if cached is not None and cached[0] == crc:
        return bind_key, cached[1], crc
    rest = np.asarray(entry[REST], np.float64).reshape(-1, 3)
    try:
        deformer = cls(rest, faces, weights=weights)
    except ValueError as exc:
        raise EntryError(str(exc)) from exc
    cache.put("cage_deformer", bind_key, (crc, deformer))
    return bind_key, deformer, crc


def setup(obj, entry, reuse_weights=False):
    cage = cage_object(entry, obj, unset="")  # none picked yet: a hint in the panel, as Mesh Deform's
    if cage is None or not is_bound(entry) or REST not in entry:
        return Prepared(None, ("unbound",), None)  # as Mesh Deform before Bind: the mesh passes through
    points, faces, topo = evaluated_cage(obj, cage)
    changed = topology_change(entry, topo)
    if changed:
        raise EntryError(changed)
    key, deformer, crc = _deformer(obj, entry, faces, scaled_influence(obj, entry, reuse_weights))
    deformer.cage_points = points
    fingerprint = (key, zlib.crc32(points.tobytes()), crc)
    return Prepared(deformer, fingerprint, Setup(deformer, key, fingerprint))


def deform(key, prepared, points):
    """The entry's result on `points`, through a binding kept while the points and the bind stay."""
    setup_ = prepared.data
    if setup_ is None:
        return points
    # float32 weights, as the mesh's positions are: half the memory and time per frame.
    binding = kept_binding("cage_binding", key, setup_.bind, points,
                           lambda p: setup_.deformer.bind(p, precision="float32"))
    return setup_.deformer.deform_bound(binding)


def bind(obj, entry, incoming):
    """Record the cage's current evaluated shape as its rest (checked: a closed, consistently
    oriented cage); nothing changes if that fails. Returns the cage's vertex count. The points
    coming into the entry (incoming) play no part: the mesh is bound to the rest as it comes."""
    cage = cage_object(entry, obj)
    points, faces, topo = evaluated_cage(obj, cage)
    cls = getattr(native.dk, CLASSES[entry.cage_method], None)
    if cls is None:
        raise EntryError(f"this build of deformkit has no cage deformers: {native.BUILD_HINT}")
    cls(points, faces)  # checks the cage: ValueError naming the first open edge, bad face, ...
    bind_id = new_bind_id(obj)
    store_array(entry, REST, points.astype(np.float32).ravel())
    entry.bind_vertices, entry.bind_faces, entry.bind_topology = topo
    entry.bind_id = bind_id  # a new bind key: the old bindings are not used again
    return topo[0]


def unbind(obj, entry):
    binding.forget(entry, (REST,))


def followed(entry):
    return [(entry.cage, entry.cage_name)]


def prune(object_key, entries):
    """Bindings of binds no entry has any more go."""
    forget_bindings(object_key, "cage_binding", entries, lambda e: (e.bind_id, e.cage_method))
    alive = {(e.bind_id, e.cage_method) for e in entries}
    cache.forget(object_key, "cage_deformer", keep=lambda k: k[1:] in alive)


def retyped(entry):
    binding.forget(entry, (REST,))


def draw(col, obj, entry):
    """Laid out like Blender's Mesh Deform panel: the cage, the method, Bind / Unbind."""
    index = list(obj.deformkit.entries).index(entry)
    col.prop(entry, "cage", text="Object")
    if entry.cage is None and not entry.cage_name:
        panel_text.label_wrapped(col, HINT, "INFO", panel_text.box_budget())  # a label is cut
        col.operator("deformkit.generate_cage", icon="MESH_ICOSPHERE").index = index  # or let deformkit make one
    col.prop(entry, "cage_method", text="Method")
    col.prop(entry, "strength", slider=True)
    draw_vertex_group(col, obj, entry)
    col.separator()
    if is_bound(entry):
        col.label(text=f"Bound: cage of {entry.bind_vertices} vertices", icon="LINKED")
        col.operator("deformkit.cage_unbind", text="Unbind", icon="UNLINKED").index = index
    else:
        col.label(text="Not bound", icon="UNLINKED")
        col.operator("deformkit.cage_bind", text="Bind", icon="LINKED").index = index

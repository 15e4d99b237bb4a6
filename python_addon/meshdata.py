"""Reading the base mesh: whether deformkit can run on the object at all (object_problem), the points
the modifiers get (shape keys mixed, the edit mesh's in Edit Mode), vertex-group weights (kept between
reads, the read is a slow Python loop), the polygons with a fingerprint of their connectivity, their
corners polygon by polygon, the parts they join, and selecting vertices, edges or faces."""
import weakref
import zlib
from collections import namedtuple

import numpy as np

from . import cache, native
from .errors import EntryError
from .outputs import MODIFIER_NAME


def cache_key(obj):
    # session_uid (Blender 3.5+) survives renames; 3.4 has only the name.
    return getattr(obj, "session_uid", None) or obj.name_full


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


def require_mesh(obj):
    """ValueError saying why deformkit cannot run on `obj` (object_problem), if it cannot."""
    problem = object_problem(obj)
    if problem:
        raise ValueError(problem)


def base_positions(mesh):
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    position = mesh.attributes.get("position")  # Blender 3.5+: a plain memcpy, ~20x faster than "co"
    if position is not None and position.data_type == "FLOAT_VECTOR" and position.domain == "POINT":
        position.data.foreach_get("vector", co)
    else:
        mesh.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


EDIT_READER = ".deformkit edit mesh reader"  # a mesh without users, so never saved: edit meshes are read through it


def edit_positions(mesh):
    """The edit mesh's points (Edit Mode holds the mesh in a BMesh until it is left), copied out
    through a scratch mesh: a fifth of the time of reading each vertex from Python, which matters
    when every step of an Edit Mode drag reads them (handlers.on_depsgraph_update_pre). The copy
    leaves the edit mesh as it was, its shape-key indices included."""
    import bmesh
    import bpy
    reader = bpy.data.meshes.get(EDIT_READER)
    if reader is None or reader.library is not None or reader.users:
        reader = bpy.data.meshes.new(EDIT_READER)
    try:
        bmesh.from_edit_mesh(mesh).to_mesh(reader)
        return base_positions(reader)
    finally:
        reader.clear_geometry()


def input_positions(obj, reuse_weights=False, depsgraph=None):
    """The points Blender's first modifier gets, which the entries deform: the mesh's, or the edit
    mesh's in Edit Mode, with the shape keys mixed as Blender mixes them (shapekeys.py). In Edit
    Mode, with the depsgraph that just evaluated the edit, the modifier's own record of its input."""
    from . import outputs, shapekeys
    mesh = obj.data
    edit = None
    if obj.mode == "EDIT":
        import bmesh
        count = len(bmesh.from_edit_mesh(mesh).verts)
        captured = None if depsgraph is None else outputs.captured_input(obj, depsgraph, count)
        if captured is not None:
            return captured
        edit = edit_positions(mesh)
    if mesh.shape_keys is not None and len(mesh.shape_keys.key_blocks):
        def weights_of(name):
            return group_weights(obj, name, reuse_weights) if obj.vertex_groups.get(name) is not None else None
        return shapekeys.mix(obj, weights_of, edit)
    return edit if edit is not None else base_positions(mesh)


def vertex_group_weights(obj, name):
    group = obj.vertex_groups.get(name)
    if group is None:
        raise EntryError(f"vertex group '{name}' not found")
    index = group.index
    weights = np.zeros(len(obj.data.vertices))
    for v in obj.data.vertices:
        for g in v.groups:
            if g.group == index:
                weights[v.index] = g.weight
                break
    return weights


def group_weights(obj, name, reuse=False):
    """The weights of vertex group `name`. With reuse, those read last time are used (parameter
    edits and frame changes do not change them; edits of the mesh re-read them)."""
    key = (cache_key(obj), name)
    cached = cache.get("weights", key)
    if reuse and cached is not None and len(cached) == len(obj.data.vertices) \
            and obj.vertex_groups.get(name) is not None:
        return cached
    weights = vertex_group_weights(obj, name)
    weights.flags.writeable = False  # kept and shared (kept_for): nobody may change it
    return cache.put("weights", key, weights)


_kept = {}  # (id(array), name) -> value made from the array (kept_for), dropped with the array


def kept_for(array, name, make):
    """make(array), made once per read-only array (group_weights' are): a 1M-vertex group's
    checksum or inverse costs milliseconds, which evaluations that reuse the weights would pay
    every time. A writeable array could change under the kept value: it is made afresh."""
    if array.flags.writeable:
        return make(array)
    key = (id(array), name)
    if key not in _kept:
        _kept[key] = make(array)
        weakref.finalize(array, _kept.pop, key, None)
    return _kept[key]


def weights_crc(weights):
    """A fingerprint of per-point weights (None: no weights)."""
    if weights is None:
        return None
    return kept_for(weights, "crc", lambda w: zlib.crc32(np.ascontiguousarray(w).tobytes()))


def inverted(weights):
    """1 - weights (read-only, as the weights), kept with them (kept_for)."""
    def invert(w):
        result = 1.0 - w
        result.flags.writeable = False
        return result
    return kept_for(weights, "inverted", invert)


# corners: the vertex of each polygon corner, polygon by polygon; starts, totals: each polygon's
# first corner and corner count; crc: a fingerprint of all three.
Topology = namedtuple("Topology", "vertices faces crc corners starts totals")


def topology(mesh):
    corners = np.empty(len(mesh.loops), np.int32)
    starts = np.empty(len(mesh.polygons), np.int32)
    mesh.polygons.foreach_get("loop_start", starts)
    packed = mesh.attributes.get(".corner_vert")
    if packed is not None:
        # Blender 3.6+ keeps the corners' vertices as one array, read in one copy (the loops' item
        # by item reads cost 20 times more: the larger part of a cage frame), and the polygons as
        # offsets into it, so each one's corner count is the step to the next start.
        packed.data.foreach_get("value", corners)
        totals = np.empty_like(starts)  # not np.diff(append=): its overhead costs more than this whole read
        np.subtract(starts[1:], starts[:-1], out=totals[:-1])
        totals[-1:] = len(corners) - starts[-1:]
    else:
        mesh.loops.foreach_get("vertex_index", corners)
        totals = np.empty(len(mesh.polygons), np.int32)
        mesh.polygons.foreach_get("loop_total", totals)
    crc = zlib.crc32(totals.tobytes(), zlib.crc32(starts.tobytes(), zlib.crc32(corners.tobytes())))
    return Topology(len(mesh.vertices), len(mesh.polygons), crc, corners, starts, totals)


def corner_order(topo):
    """The mesh's corners polygon by polygon (their order in `polygons`), or None when that is
    already their order in the mesh (always since Blender 3.6)."""
    ends = np.cumsum(topo.totals)
    if (topo.starts == ends - topo.totals).all():
        return None
    return np.concatenate([np.arange(s, s + t) for s, t in zip(topo.starts, topo.totals)])


def in_polygon_order(topo, per_corner):
    """Per-corner values (first axis: the mesh's corners, e.g. `topo.corners`, UVs, edges) polygon
    by polygon, the order `polygons` gives the corners in."""
    order = corner_order(topo)
    return per_corner if order is None else per_corner[order]


# vertices: the vertex of each polygon corner, polygon by polygon; starts: each polygon's first
# corner in `vertices` (int64).
Corners = namedtuple("Corners", "vertices starts")


def polygon_corners(topo):
    """The corners polygon by polygon (Corners), as `polygons` gives them."""
    return Corners(in_polygon_order(topo, topo.corners), np.cumsum(topo.totals, dtype=np.int64) - topo.totals)


def polygons(topo):
    """The polygons as deformkit takes them: an (m, k) array when all have k corners, else a list."""
    corners = in_polygon_order(topo, topo.corners)
    if topo.faces and (topo.totals == topo.totals[0]).all():
        return corners.reshape(topo.faces, int(topo.totals[0]))
    return np.split(corners, np.cumsum(topo.totals)[:-1])


def triangles(topo):
    """Every polygon fanned from its first corner, as deformkit fans a list of polygons: (m, 3)."""
    count = topo.totals.astype(np.int64) - 2
    polygon = np.repeat(np.arange(len(count)), count)
    corner = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count) + 1  # 1 .. k-2
    first = topo.starts[polygon].astype(np.int64)
    c = topo.corners
    return np.stack([c[first], c[first + corner], c[first + corner + 1]], axis=1)


def edge_lookup(mesh):
    """{(a, b) with a < b: edge index} of the mesh's edges."""
    pairs = np.empty(len(mesh.edges) * 2, np.int32)
    mesh.edges.foreach_get("vertices", pairs)
    pairs = np.sort(pairs.reshape(-1, 2), axis=1)
    return {(int(a), int(b)): i for i, (a, b) in enumerate(pairs.tolist())}


def _edit_mesh_deselected(mesh):
    """The edit mesh with nothing selected."""
    import bmesh
    bm = bmesh.from_edit_mesh(mesh)
    for items in (bm.faces, bm.edges, bm.verts):
        for item in items:
            item.select = False
    return bm


def select_edges(obj, edges):
    """Select exactly these edges (and their vertices), in edit mode too."""
    mesh = obj.data
    if obj.mode == "EDIT":
        import bmesh
        bm = _edit_mesh_deselected(mesh)
        bm.edges.ensure_lookup_table()
        for i in edges:
            bm.edges[i].select_set(True)
        bm.select_flush(True)
        bmesh.update_edit_mesh(mesh)
        return
    chosen = np.zeros(len(mesh.edges), bool)
    chosen[list(edges)] = True
    pairs = np.empty(len(mesh.edges) * 2, np.int32)
    mesh.edges.foreach_get("vertices", pairs)
    vertices = np.zeros(len(mesh.vertices), bool)
    vertices[pairs.reshape(-1, 2)[chosen].ravel()] = True
    mesh.vertices.foreach_set("select", vertices)
    mesh.edges.foreach_set("select", chosen)
    mesh.polygons.foreach_set("select", np.zeros(len(mesh.polygons), bool))


def select_faces(obj, faces):
    """Select exactly these faces (with their edges and vertices), in edit mode too."""
    mesh = obj.data
    if obj.mode == "EDIT":
        import bmesh
        bm = _edit_mesh_deselected(mesh)
        bm.faces.ensure_lookup_table()
        for i in faces:
            bm.faces[i].select_set(True)  # its edges and vertices too
        bmesh.update_edit_mesh(mesh)
        return
    chosen = np.zeros(len(mesh.polygons), bool)
    chosen[faces] = True
    topo = topology(mesh)
    corner_face = np.repeat(chosen, topo.totals)  # corner by corner, polygon by polygon
    edge_of = np.empty(len(mesh.loops), np.int32)
    mesh.loops.foreach_get("edge_index", edge_of)
    for items, members in ((mesh.vertices, in_polygon_order(topo, topo.corners)),
                           (mesh.edges, in_polygon_order(topo, edge_of))):
        flags = np.zeros(len(items), bool)
        flags[members[corner_face]] = True
        items.foreach_set("select", flags)
    mesh.polygons.foreach_set("select", chosen)


def select_vertices(mesh, vertices):
    """Exactly `vertices` selected, with the edges and faces between them (as Edit Mode's flush)."""
    chosen = np.zeros(len(mesh.vertices), bool)
    chosen[vertices] = True
    mesh.vertices.foreach_set("select", chosen)
    edges = np.empty(2 * len(mesh.edges), np.int32)
    mesh.edges.foreach_get("vertices", edges)
    mesh.edges.foreach_set("select", chosen[edges].reshape(-1, 2).all(1))
    topo = topology(mesh)
    if topo.faces:
        corners, starts = polygon_corners(topo)
        inside = np.minimum.reduceat(chosen[corners].astype(np.int8), starts).astype(bool)
        mesh.polygons.foreach_set("select", inside)


def face_components(topo):
    """Each vertex's connected component through the polygons (a vertex in none is its own), as
    dk.SurfaceDeformer groups them: labels are the smallest vertex index of the component.
    Hooking and pointer jumping on numpy arrays (Shiloach-Vishkin): O(log n) rounds, no Python
    loop over the mesh."""
    parent = np.arange(topo.vertices)
    a, starts = polygon_corners(topo)
    b = np.repeat(a[starts], topo.totals)  # each corner joined to its polygon's first
    while True:
        ra, rb = parent[a], parent[b]
        differ = ra != rb
        if not differ.any():
            return parent
        np.minimum.at(parent, np.maximum(ra, rb)[differ], np.minimum(ra, rb)[differ])
        while True:  # every vertex points at its root again
            grand = parent[parent]
            if np.array_equal(grand, parent):
                break
            parent = grand


def float_layer(mesh, attribute, domain, legacy, count):
    """A float per element: the attribute (Blender 4.0+), else the legacy crease layer (3.x)."""
    values = np.empty(count, np.float32)
    attr = mesh.attributes.get(attribute)
    if attr is not None and attr.domain == domain and attr.data_type == "FLOAT":
        attr.data.foreach_get("value", values)
        return values
    layers = getattr(mesh, legacy, None)
    if layers is not None and len(layers):
        layers[0].data.foreach_get("value", values)
        return values
    return None

"""Subdivide entries: OpenSubdiv subdivision (dk.subdivide) of the cage that the entries above make,
as Blender's Subdivision Surface modifier placed after them would give.

Subdivision changes the topology, which the stack's usual result (a position attribute that the
"deformkit" Geometry Nodes modifier stores into the positions) cannot carry. So the subdivided mesh
goes into a helper mesh and object per result (viewport, and render when it differs), named from
the object, linked to no scene (nothing to select or see in the outliner's scenes) and kept alive by
the entry's pointers and the modifier's inputs; the modifier's node group then outputs the helper's
geometry (Object Info, original space) in place of its input. Helpers are output, not the user's
data: they are written on every evaluation, and deleted when the entry goes or stops subdividing.

Results are numbered as Blender's Subdivision Surface numbers its own (subdivision_order), but
for Loop (the modifier has none) and meshes with loose edges (it subdivides those too). Carried
over from the base mesh: the active UV map (face-varying, with UV Smooth), material indices and
smooth shading (through each face's control face); other attributes are not.

Evaluation reaches this kind only through the registry's hooks for a kind with LAST (results, write,
discard, forget: entries/__init__.py). Here too: the entry's settings and panel. Refined topologies
are kept in the cache's "subdivide" space ((object cache key, "viewport"/"render") -> (refine key,
dk.Subdivider, Result without points, gather)), and what each helper mesh holds in "subdivide_written"
((object cache key, helper mesh name) -> the key of the topology and face data written into it).
"""
import re
import zlib
from collections import namedtuple

import bpy
import numpy as np

from .. import cache, meshdata, native, outputs, subdivision_order
from ..errors import EntryError
from .common import Prepared

ENTRY_TYPES = [
    ("SUBDIVIDE", "Subdivide", "OpenSubdiv subdivision (Catmull-Clark or Loop, with creases) of the mesh the "
     "entries above make; the last entry of the stack", "NONE", 6),
]
TYPES = tuple(row[0] for row in ENTRY_TYPES)  # its entry.type identifiers
SCHEMES = [
    ("AUTO", "Auto", "Loop when every face is a triangle, Catmull-Clark otherwise", 0),
    ("CATMULL_CLARK", "Catmull-Clark", "Catmull-Clark: quads out, any polygons in (as Blender's Subdivision "
     "Surface)", 1),
    ("LOOP", "Loop", "Loop: triangles out, triangle meshes only", 2),
]
# Blender's Subdivision Surface names and identifiers (boundary_smooth, uv_smooth).
BOUNDARY_SMOOTH = [
    ("PRESERVE_CORNERS", "Keep Corners", "Smooth boundaries, but corners are kept sharp", 0),
    ("ALL", "All", "Smooth boundaries, including corners", 1),
]
UV_SMOOTH = [
    ("NONE", "None", "UVs are not smoothed, boundaries are kept sharp", 0),
    ("PRESERVE_CORNERS", "Keep Corners", "UVs are smoothed, corners on discontinuous boundary are kept sharp", 1),
    ("PRESERVE_CORNERS_AND_JUNCTIONS", "Keep Corners, Junctions", "UVs are smoothed, corners on discontinuous "
     "boundary and junctions of 3 or more regions are kept sharp", 2),
    ("PRESERVE_CORNERS_JUNCTIONS_AND_CONCAVE", "Keep Corners, Junctions, Concave", "UVs are smoothed, corners on "
     "discontinuous boundary, junctions of 3 or more regions and darts and concave corners are kept sharp", 3),
    ("PRESERVE_BOUNDARIES", "Keep Boundaries", "UVs are smoothed, boundaries are kept sharp", 4),
    ("SMOOTH_ALL", "All", "UVs and boundaries are smoothed", 5),
]
ICON = "MOD_SUBSURF"
LAST = True  # changes the topology: the last entry of a stack
FIELDS = ("levels", "render_levels", "scheme", "boundary_smooth", "use_creases", "uv_smooth", "use_limit_surface",
          "sharpen_two_edge_vertices")

NOT_COPIED = ("subdivision_viewport", "subdivision_render")  # a copy makes its own helpers
DK_SCHEMES = {"AUTO": "auto", "CATMULL_CLARK": "catmull_clark", "LOOP": "loop"}  # dk's names
DK_BOUNDARIES = {"PRESERVE_CORNERS": "edge_and_corner", "ALL": "edge_only"}
KINDS = ("viewport", "render")
OWNER = "deformkit_subdivision_of"  # on a helper object: the name of the object it belongs to

# topo: meshdata.Topology; kwargs: dk's topology arguments; refine: what a refined topology depends
# on; fingerprint: everything the result depends on besides the cage's positions; edges: Blender's (E, 2).
Setup = namedtuple("Setup", "entry topo kwargs uvs uv_name uv_smooth material smooth materials edges refine "
                    "fingerprint")
# One result: points and polygons (flat corners, starts, totals), the control face of each polygon,
# per-corner UVs or None, edges (K, 2) or None (then Blender makes them from the polygons).
Result = namedtuple("Result", "points corners starts totals face_origin uvs edges")


def crease_to_sharpness(crease):
    """Blender's mapping, in its float32: BKE_subdiv_crease_to_sharpness_f(c) = c * c * 10
    (blenkernel/intern/subdiv_inline.h; subdiv_converter_mesh.cc applies it to edge and vertex
    creases alike), so a crease of 1 is OpenSubdiv's infinitely sharp 10."""
    crease = np.asarray(crease, np.float32)
    return (crease * crease * np.float32(10.0)).astype(np.float64)


def read_creases(mesh):
    """(creases, corners) as dk wants them, from the mesh's edge and vertex creases (None where the
    mesh has none). Loose edges are left out: they bound no face."""
    edge = meshdata.float_layer(mesh, "crease_edge", "EDGE", "edge_creases", len(mesh.edges))
    if edge is None and "crease" in bpy.types.MeshEdge.bl_rna.properties:  # Blender 3.4: MeshEdge.crease
        edge = np.empty(len(mesh.edges), np.float32)
        mesh.edges.foreach_get("crease", edge)
    creases = corners = None
    if edge is not None and edge.any():
        loose = np.empty(len(mesh.edges), bool)
        mesh.edges.foreach_get("is_loose", loose)
        pairs = np.empty(len(mesh.edges) * 2, np.int32)
        mesh.edges.foreach_get("vertices", pairs)
        keep = (edge != 0) & ~loose
        creases = (pairs.reshape(-1, 2)[keep], crease_to_sharpness(edge[keep]))
    vertex = meshdata.float_layer(mesh, "crease_vert", "POINT", "vertex_creases", len(mesh.vertices))
    if vertex is not None and vertex.any():
        keep = np.flatnonzero(vertex)
        corners = (keep, crease_to_sharpness(vertex[keep]))
    return creases, corners


def topology_kwargs(mesh, entry=None):
    """dk's scheme, boundary, creases and corners for a Subdivide entry's settings (None: a new
    entry's defaults, as Check Smoothness uses them on a stack without one)."""
    scheme, boundary = (entry.scheme, entry.boundary_smooth) if entry else ("CATMULL_CLARK", "ALL")
    creases, corners = read_creases(mesh) if entry is None or entry.use_creases else (None, None)
    sharpen = entry.sharpen_two_edge_vertices if entry else True
    return dict(scheme=DK_SCHEMES[scheme], boundary=DK_BOUNDARIES[boundary], creases=creases, corners=corners,
                sharpen_two_edge_vertices=sharpen)


def _crc(*arrays):
    crc = 0
    for a in arrays:
        if a is not None:
            crc = zlib.crc32(np.ascontiguousarray(a).tobytes(), crc)
    return crc


def setup(obj, entry, reuse_weights=False):
    """The entry as evaluation runs it: no pointwise deformer; what it subdivides with."""
    sub = subdivision_setup(obj, entry)
    return Prepared(None, sub.fingerprint, sub)


def subdivision_setup(obj, entry):
    """What the entry needs besides the cage: the base mesh's topology, creases, UVs, materials."""
    mesh = obj.data
    topo = meshdata.topology(mesh)
    if topo.faces == 0:
        raise EntryError("the mesh has no faces: subdivision refines faces")
    kwargs = topology_kwargs(mesh, entry)
    layer = mesh.uv_layers.active
    if layer is not None and len(layer.data) != len(mesh.loops):
        layer = None  # Edit Mode: the edit mesh holds the UVs; the helpers get them back on leaving it
    uvs = None
    if layer is not None:
        uvs = np.empty(len(mesh.loops) * 2, np.float32)
        layer.data.foreach_get("uv", uvs)
        uvs = meshdata.in_polygon_order(topo, uvs.reshape(-1, 2))
    material, smooth = np.empty(topo.faces, np.int32), np.empty(topo.faces, bool)
    mesh.polygons.foreach_get("material_index", material)
    mesh.polygons.foreach_get("use_smooth", smooth)
    materials = tuple(mesh.materials)
    edges = subdivision_order.blender_edges(mesh, *meshdata.polygon_corners(topo), topo.totals)
    creases = kwargs["creases"] or (None, None)
    corners = kwargs["corners"] or (None, None)
    refine = (topo.vertices, topo.crc, entry.scheme, entry.boundary_smooth, entry.uv_smooth,
              _crc(*creases, *corners, edges), None if uvs is None else _crc(uvs), entry.sharpen_two_edge_vertices,
              entry.use_limit_surface, edges is None)
    fingerprint = (entry.levels, entry.render_levels,
                   refine, layer.name if layer else "", _crc(material, smooth), tuple(m and m.name for m in materials))
    return Setup(entry, topo, kwargs, uvs, layer.name if layer else "", entry.uv_smooth.lower(), material, smooth,
                 materials, edges, refine, fingerprint)


def level(entry, kind):
    """The entry's level for the viewport or renders: 0 (the cage itself) where it is hidden."""
    if kind == "viewport":
        return entry.levels if entry.show_viewport else 0
    return entry.render_levels if entry.show_render else 0


_TOO_MANY_FACES = re.compile(r"level: (\d+) would make (\d+) faces, more than max_faces=(\d+) ")


def in_ui_terms(message, setting):
    """dk.Subdivider's message, with what to do in the panel: its max_faces is no setting there
    (the add-on keeps the core's default), so the level (`setting`, the field's label) is what to lower."""
    found = _TOO_MANY_FACES.match(message)
    if found is None:
        return message
    level, faces, limit = (int(g) for g in found.groups())
    return (f"level {level} would make {faces:,} faces, more than the {limit:,} deformkit allows: "
            f"lower {setting}")


def subdivide(key, sub, level, cage):
    """The cage subdivided to `level` (level 0: the cage). The refined topology is kept under `key`
    (None: not kept), so that a new cage of the same mesh, a frame or a parameter edit of the
    entries above, only costs the interpolation."""
    topo = sub.topo
    if level == 0:
        corners, starts = meshdata.polygon_corners(topo)
        return Result(cage, corners, starts, topo.totals, np.arange(topo.faces), sub.uvs, sub.edges)
    cached = cache.get("subdivide", key) if key else None
    try:
        if cached is not None and cached[0] == (sub.refine, level):
            return cached[2]._replace(points=subdivision_order.gathered(cached[1].subdivide(cage), cached[3]))
        subdivider = native.dk.Subdivider(cage, meshdata.polygons(topo), level, uvs=sub.uvs,
                                          uv_smooth=sub.uv_smooth, limit_surface=sub.entry.use_limit_surface,
                                          **sub.kwargs)
        m = subdivider.mesh(cage)
        numbering = subdivision_order.numbering(subdivider, m, sub.edges)
    except (ValueError, TypeError) as exc:
        raise EntryError(in_ui_terms(str(exc), "Render" if key and key[1] == "render" else "Levels Viewport")) \
            from exc
    except MemoryError:
        raise EntryError(f"not enough memory for level {level}: lower the level") from None
    result = Result(subdivision_order.gathered(m.points, numbering.gather), *numbering[1:])
    if key:
        cache.put("subdivide", key, ((sub.refine, level), subdivider, result._replace(points=None), numbering.gather))
    return result


def results(object_key, sub, viewport_cage, render_cage):
    """{kind: Result} for the viewport and renders (the same object when they agree), or None
    when the entry subdivides neither (hidden, or level 0 in both)."""
    levels = {kind: level(sub.entry, kind) for kind in KINDS}
    if not any(levels.values()):
        return None
    viewport = subdivide((object_key, "viewport"), sub, levels["viewport"], viewport_cage)
    if levels["render"] == levels["viewport"] and render_cage is viewport_cage:
        return {"viewport": viewport, "render": viewport}
    return {"viewport": viewport, "render": subdivide((object_key, "render"), sub, levels["render"], render_cage)}


def _set_positions(mesh, points):
    flat = np.ascontiguousarray(points, np.float32).ravel()
    position = mesh.attributes.get("position")  # Blender 3.5+
    if position is not None and position.data_type == "FLOAT_VECTOR" and position.domain == "POINT":
        position.data.foreach_set("vector", flat)
    else:
        mesh.vertices.foreach_set("co", flat)


def _attribute(mesh, name, domain, data_type):
    attr = mesh.attributes.get(name)
    return attr if attr is not None and attr.domain == domain and attr.data_type == data_type else None


def _write(mesh, collection, prop, attribute, domain, data_type, values, new=False):
    """Write per-element values through the attribute (a copy, ~100x faster than the element
    properties) where this Blender has it, else through the elements' property."""
    attr = _attribute(mesh, attribute, domain, data_type)
    if attr is None and new:
        attr = mesh.attributes.new(attribute, data_type, domain)
    if attr is not None:
        attr.data.foreach_set("vector" if data_type == "FLOAT2" else "value", values)
    else:
        collection.foreach_set(prop, values)


def fill(mesh, result, sub, materials=True):
    """Replace the mesh's geometry with `result`: polygons, UVs, material indices, smooth shading."""
    mesh.clear_geometry()
    mesh.vertices.add(len(result.points))
    mesh.loops.add(len(result.corners))
    mesh.polygons.add(len(result.starts))
    _set_positions(mesh, result.points)
    corners = np.ascontiguousarray(result.corners, np.int32)
    _write(mesh, mesh.loops, "vertex_index", ".corner_vert", "CORNER", "INT", corners)  # 4.0+: an attribute
    mesh.polygons.foreach_set("loop_start", np.ascontiguousarray(result.starts, np.int32))
    mesh.polygons.foreach_set("loop_total", np.ascontiguousarray(result.totals, np.int32))  # 3.x needs it
    subdivision_order.set_edges(mesh, result.edges, corners, result.starts, result.totals, _write)
    if result.uvs is not None:
        layer = mesh.uv_layers.new(name=sub.uv_name)
        _write(mesh, layer.data, "uv", layer.name, "CORNER", "FLOAT2",
               np.ascontiguousarray(result.uvs, np.float32).ravel())
    if materials:
        mesh.materials.clear()
        for material in sub.materials:
            mesh.materials.append(material)
    material = sub.material[result.face_origin]
    if material.any():
        _write(mesh, mesh.polygons, "material_index", "material_index", "FACE", "INT", material, new=True)
    smooth = sub.smooth[result.face_origin]
    if bpy.app.version >= (4, 1, 0):  # smooth shading is the absence of a "sharp_face" attribute
        if not smooth.all():
            _write(mesh, mesh.polygons, "use_smooth", "sharp_face", "FACE", "BOOLEAN", ~smooth, new=True)
    else:
        mesh.polygons.foreach_set("use_smooth", smooth)


def owns(obj):
    """Whether obj is one of the helper objects a Subdivide entry writes (the batch's "*" skips them)."""
    return OWNER in obj


def _owner_uses(owner, helper):
    return any(getattr(e, f"subdivision_{kind}", None) == helper for e in owner.deformkit.entries for kind in KINDS)


def is_ours(obj, helper):
    """A helper is obj's if made for it, or if the object it was made for (by name: obj renamed
    since) no longer uses it. A copy of obj (Shift D) shares its helpers until it makes its own."""
    owner_name = helper.get(OWNER)
    if owner_name is None:
        return False  # not a helper: never the add-on's to write or delete
    if owner_name == obj.name_full:
        return True
    owner = bpy.data.objects.get(owner_name)
    return owner is None or not _owner_uses(owner, helper)


def _helper(obj, entry, kind):
    prop = f"subdivision_{kind}"
    helper = getattr(entry, prop)
    if helper is not None and helper.type == "MESH" and is_ours(obj, helper):
        if helper[OWNER] != obj.name_full:  # adopted after a rename
            helper[OWNER] = obj.name_full
            helper.name = helper.data.name = _helper_name(obj, kind)
        return helper
    name = _helper_name(obj, kind)
    helper = bpy.data.objects.new(name, bpy.data.meshes.new(name))
    helper[OWNER] = obj.name_full
    setattr(entry, prop, helper)
    return helper


def _helper_name(obj, kind):
    return f"{obj.name_full} subdivided" + ("" if kind == "viewport" else " (render)")


def write(obj, sub, found):
    """Write the results into the entry's helper objects; returns (viewport, render) helpers."""
    helpers = {}
    for kind in KINDS:
        if kind == "render" and found["render"] is found["viewport"]:
            helpers[kind] = helpers["viewport"]
            continue
        helper = helpers[kind] = _helper(obj, sub.entry, kind)
        mesh, result = helper.data, found[kind]
        key = (sub.fingerprint, level(sub.entry, kind), len(result.points), len(result.starts))
        written = (meshdata.cache_key(obj), mesh.name_full)
        if cache.get("subdivide_written", written) == key and len(mesh.vertices) == len(result.points):
            _set_positions(mesh, result.points)  # a new cage: the topology and face data are as written
        else:
            fill(mesh, result, sub)
            cache.put("subdivide_written", written, key)
        mesh.update()
    if helpers["render"] is helpers["viewport"]:
        sub.entry.subdivision_render = None
    return helpers["viewport"], helpers["render"]


def discard(obj, keep=()):
    """Delete obj's helper objects and meshes except `keep`: those its entries or its modifier
    refer to (a removed entry's are still on the modifier). Another object's are only let go."""
    found = {h for h in outputs.helper_objects(obj) if h is not None}
    for entry in obj.deformkit.entries:
        for kind in KINDS:
            helper = getattr(entry, f"subdivision_{kind}")
            if helper is not None and helper not in keep:
                setattr(entry, f"subdivision_{kind}", None)
                found.add(helper)
    for helper in found - set(keep):
        if is_ours(obj, helper):
            mesh = helper.data
            cache.pop("subdivide_written", (meshdata.cache_key(obj), mesh.name_full))
            bpy.data.objects.remove(helper)
            if mesh.users == 0:
                bpy.data.meshes.remove(mesh)


def lost_on_apply(obj):
    """What of the user's data `fill` would not carry into the subdivided mesh, as phrases."""
    mesh = obj.data
    lost = []
    if len(obj.vertex_groups):
        lost.append("vertex groups " + ", ".join(repr(g.name) for g in obj.vertex_groups))
    active = mesh.uv_layers.active
    others = [layer.name for layer in mesh.uv_layers if active is None or layer.name != active.name]
    if others:
        lost.append("UV maps " + ", ".join(map(repr, others)))
    colors = getattr(mesh, "color_attributes", None)
    if colors is not None and len(colors):
        lost.append("color attributes " + ", ".join(repr(c.name) for c in colors))
    creases, corners = read_creases(mesh)
    if creases is not None or corners is not None:
        lost.append("creases")
    return lost


def bake(obj, entry):
    """Apply: the base mesh subdivided at the viewport levels (as Blender applies its modifier),
    written into the mesh itself. Returns False if there was nothing to do (level 0)."""
    if entry.levels == 0:
        return False
    lost = lost_on_apply(obj)
    if lost:
        raise EntryError("apply: the subdivided mesh would lose " + "; ".join(lost) + " (a Subdivide entry carries "
                         "positions, the active UV map, materials and smooth shading only): remove them first, "
                         "or keep the entry")
    sub = subdivision_setup(obj, entry)
    result = subdivide(None, sub, entry.levels, meshdata.base_positions(obj.data))
    fill(obj.data, result, sub, materials=False)
    obj.data.update()
    return True


def deform(key, prepared, points):
    raise NotImplementedError("a Subdivide entry is run by evaluation.evaluate as the stack's last step")


def apply(obj, entry, prepared, base):
    bake(obj, entry)  # the base mesh's own topology changes, as with Blender's Apply


def forget(object_key):
    """The refined topologies go (the stack has no Subdivide entry any more)."""
    cache.forget(object_key, "subdivide")


def volume_note(entries):
    return "Volume colors are not carried through a Subdivide entry" if entries else ""


def draw(col, obj, entry):
    """Laid out like Blender's Subdivision Surface panel, then the size of what it made. Labels
    are shorter than the property names where those are cut in the label column at the default
    width (panel_text.label_column_budget): "Levels" over Viewport and Render, "Boundaries"."""
    col.label(text="Levels")
    col.prop(entry, "levels", text="Viewport")
    col.prop(entry, "render_levels", text="Render")
    col.prop(entry, "scheme")
    col.separator()
    col.label(text="Advanced")
    col.prop(entry, "use_limit_surface")
    col.prop(entry, "use_creases")
    col.row(heading="Sharpen").prop(entry, "sharpen_two_edge_vertices", text="Two-Edge Vertices")
    col.prop(entry, "boundary_smooth", text="Boundaries")
    col.prop(entry, "uv_smooth")
    render = entry.subdivision_render
    for label, helper in (("Viewport" if render else "Viewport and render", entry.subdivision_viewport),
                          ("Render", render)):
        if helper is not None:
            col.label(text=f"{label}: {len(helper.data.vertices)} vertices, {len(helper.data.polygons)} faces")



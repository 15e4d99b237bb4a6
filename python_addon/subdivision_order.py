"""Blender's numbering of a subdivided mesh: dk.Subdivider.blender_order (once per refined
topology) applied to a SubdividedMesh, and the edges written in that order. Blender's Subdivision
Surface numbers vertices, edges, faces and face corners by a fixed rule from the control mesh
(docs/subdivision.md, "Blender's order"); results numbered alike let index-based tools (Data
Transfer by index, caches, shape keys on the result) treat the Subdivide entry's and the
modifier's results as the same mesh."""
from collections import namedtuple

import numpy as np

# The numbering of a refined topology: its points are points[gather] (None: as they are); then the
# polygons (flat corners, starts, totals), each one's control face and per-corner UVs in that
# numbering, and edges (K, 2) in Blender's order (None: Blender makes them). After `gather`, the
# fields of entries.subdivide.Result.
Numbering = namedtuple("Numbering", "gather corners starts totals face_origin uvs edges")


def blender_edges(mesh, corners, starts, totals):
    """The mesh's edges (E, 2) in its order, or None when one is loose (bounds none of the polygons,
    given as flat corners, starts, totals): Blender subdivides loose edges, dk does not, so the
    numbering could not be Blender's. (Blender 3.4's stored loose flags can be stale: counted here.)"""
    edges = np.empty(len(mesh.edges) * 2, np.int32)
    mesh.edges.foreach_get("vertices", edges)
    a = np.asarray(corners, np.int64)
    b = a[next_corners(starts, totals)]
    keys = np.unique(np.minimum(a, b) * max(len(mesh.vertices), 1) + np.maximum(a, b))
    return edges.reshape(-1, 2) if len(keys) == len(mesh.edges) else None


def numbering(subdivider, m, edges):
    """How Blender's Subdivision Surface numbers the SubdividedMesh m of `subdivider` (a Numbering),
    or dk's numbering where Blender has no such result (Loop, or loose edges: `edges` None)."""
    count, k = m.faces.shape
    starts, totals = np.arange(count, dtype=np.int32) * k, np.full(count, k, np.int32)
    if edges is None or subdivider.scheme != "catmull_clark":
        return Numbering(None, m.faces.ravel(), starts, totals, m.face_origin, m.uvs, None)
    vertex, face, start, blender_edges = subdivider.blender_order(edges)
    gather = np.empty_like(vertex)
    gather[vertex] = np.arange(len(vertex), dtype=vertex.dtype)
    # Blender's corner r of its face face[f] is corner (start[f] + r) % k of face f.
    source = np.empty(count * k, np.int64)
    source.reshape(count, k)[face] = np.arange(count)[:, None] * k + (start[:, None] + np.arange(k)) % k
    origin = np.empty_like(m.face_origin)
    origin[face] = m.face_origin
    return Numbering(gather, vertex[m.faces.ravel()][source], starts, totals, origin,
                     None if m.uvs is None else m.uvs[source], blender_edges)


def gathered(points, gather):
    return points if gather is None else points[gather]


def next_corners(starts, totals):
    """For every corner of polygons (starts, totals, polygon order), the index of the next corner."""
    following = np.arange(1, int(np.sum(totals)) + 1)
    following[np.asarray(starts, np.int64) + totals - 1] = starts
    return following


def set_edges(mesh, edges, corners, starts, totals, write):
    """Write these edges (in this order) and every corner's edge, the edge to the next corner; or,
    with edges None, let Blender make them from the polygons."""
    if edges is None:
        mesh.update(calc_edges=True)
        return
    edges = np.ascontiguousarray(edges, np.int32)
    mesh.edges.add(len(edges))
    mesh.edges.foreach_set("vertices", edges.ravel())
    n = np.int64(len(mesh.vertices))
    keys = edges.min(axis=1).astype(np.int64) * n + edges.max(axis=1)
    order = np.argsort(keys)
    here = corners.astype(np.int64)
    nxt = here[next_corners(starts, totals)]
    found = order[np.searchsorted(keys, np.minimum(here, nxt) * n + np.maximum(here, nxt), sorter=order)]
    write(mesh, mesh.loops, "edge_index", ".corner_edge", "CORNER", "INT", np.ascontiguousarray(found, np.int32))
    mesh.update()

"""Check Smoothness, at the api's layer: dk.smoothness_report on the cage a Subdivide entry
subdivides (the mesh the entries above it make), its figures stored for the panel, and the creased
edges or flipped faces selected. api.py keeps one-line delegates under the same names for scripts."""
import bpy

from . import entries, evaluation, meshdata, native
from .entries import subdivide


def check_smoothness(obj, select=True, worst=10, min_angle=1e-6, samples_per_edge=8):
    """dk.smoothness_report on obj's cage: the base mesh through the entries above the Subdivide
    entry (all entries if there is none), with that entry's scheme, boundary and creases (a new
    entry's defaults without one). Stores the figures on the stack for the panel and, with select,
    selects the worst edges whose angle exceeds min_angle radians (above rounding, so a smooth
    surface selects none) and deselects the rest. Returns the report's to_dict() plus
    "worst_edge" (its vertices) and "selected_edges" (Blender edge indices)."""
    meshdata.require_mesh(obj)
    mesh = obj.data
    if obj.mode == "EDIT":
        # Edit mode keeps the mesh in its own copy, and attributes (creases) read through it: read a
        # plain copy of the mesh as edit mode leaves it.
        obj.update_from_editmode()
        mesh = obj.data.copy()
    try:
        stack = obj.deformkit.entries
        index = entries.last_index(stack)
        cage = evaluation.entry_input(obj, index)
        topo = meshdata.topology(mesh)
        if topo.faces == 0:
            raise ValueError("the mesh has no faces: there is no surface to check")
        kwargs = subdivide.topology_kwargs(mesh, stack[index] if index < len(stack) else None)
        # Flips are judged against the base mesh's own surface: where the entries turned it over.
        report = native.dk.smoothness_report(cage, meshdata.polygons(topo), samples_per_edge=samples_per_edge,
                                             worst=worst, reference=meshdata.base_positions(mesh), **kwargs)
        edge_index = meshdata.edge_lookup(mesh)
    finally:
        if mesh is not obj.data:
            bpy.data.meshes.remove(mesh)
    figures = report.to_dict()
    pairs, angles = report.edges[report.worst_edges], report.edge_angle[report.worst_edges]
    figures["worst_edge"] = [int(v) for v in pairs[0]] if len(pairs) else None
    figures["selected_edges"] = sorted(edge_index[tuple(p)] for p in pairs[angles > min_angle].tolist())
    if select:
        meshdata.select_edges(obj, figures["selected_edges"])
    stored = obj.deformkit.smoothness
    stored.checked = True
    stored.max_angle, stored.max_gap = report.max_angle, report.max_gap
    stored.degenerate, stored.flipped = report.degenerate_samples, report.flipped_samples
    stored.worst_edge = figures["worst_edge"] or (-1, -1)
    stored.selected = len(figures["selected_edges"])
    return figures


def select_flipped(obj, samples_per_edge=8):
    """Check Smoothness (its figures go to the panel), then select exactly the control faces with
    flipped samples, with their edges and vertices, in Object or Edit Mode. Returns their indices."""
    faces = sorted(check_smoothness(obj, select=False, samples_per_edge=samples_per_edge)["flipped_faces"])
    meshdata.select_faces(obj, faces)
    return faces

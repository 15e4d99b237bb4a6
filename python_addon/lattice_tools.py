"""The Lattice entry's tools, at the api's layer: a Lattice object fitted to a mesh, Reset, the
entries that use a lattice, direct manipulation (the lattice's points moved so that chosen
vertices reach targets, optionally keeping the mesh's volume), and the lattice's certificate (does
it fold where the mesh is?) with its volume change. api.py keeps one-line delegates under the same
names for scripts."""
from collections import namedtuple

import bpy
import numpy as np
from mathutils import Matrix

from . import cache, evaluation, meshdata
from .entries import common
from .entries import lattice as kind

# What direct_manipulation reports: the largest distance left, each vertex's, and the constraints'
# rank; with Preserve Volume, the mesh's volume the solve reached and its distance to the kept one.
Manipulated = namedtuple("Manipulated", "max_residual residual rank volume volume_residual", defaults=(None, None))


def fit_lattice(obj, resolution=(4, 4, 4), basis="BLENDER", selected_only=False, margin=1e-4):
    """A new Lattice object fitted to the bounding box of the mesh (as the stack leaves it; with
    selected_only, of its selected vertices) in its local frame, widened by `margin` of the box's
    largest side so that no vertex lies outside by rounding (api.add_lattice adds the entry)."""
    meshdata.require_mesh(obj)
    resolution = tuple(int(n) for n in resolution)
    if len(resolution) != 3 or not all(1 <= n <= 64 for n in resolution):
        raise ValueError(f"resolution: expected three counts in 1..64, got {resolution}")
    basis = str(basis).upper()
    if basis not in kind.BASES:
        raise ValueError(f"basis: expected one of {', '.join(kind.BASES)}, got {basis!r}")
    kind.check_basis(basis, "CLAMP", resolution, "the resolution")
    if obj.mode == "EDIT":
        obj.update_from_editmode()  # edit mode keeps the selection and positions in its own copy
    entries = obj.deformkit.entries
    points = evaluation.entry_input(obj, len(entries)) if len(entries) else meshdata.base_positions(obj.data)
    if selected_only:
        selected = np.zeros(len(obj.data.vertices), bool)
        obj.data.vertices.foreach_get("select", selected)
        if not selected.any():
            raise ValueError("no vertices are selected")
        points = points[selected]
    lo, hi = points.min(axis=0).astype(np.float64), points.max(axis=0).astype(np.float64)
    size = hi - lo
    largest = float(size.max()) or 1.0  # one vertex: a unit box around it
    size = np.where(size > 1e-6 * largest, size, 0.01 * largest) + 2 * margin * largest  # flat meshes
    box = Matrix.Diagonal((*size, 1.0))
    box.translation = (lo + hi) / 2
    data = bpy.data.lattices.new(f"{obj.name} Lattice")
    lat = bpy.data.objects.new(data.name, data)
    # With its object present, a resize keeps the box [-1/2, 1/2]; without, it spaces points 1 apart.
    data.points_u, data.points_v, data.points_w = resolution
    kind.reset(lat)  # the resize deforms the new points by the old grid: start exactly at rest
    for collection in obj.users_collection or (bpy.context.scene.collection,):
        collection.objects.link(lat)
    lat.matrix_world = obj.matrix_world @ box
    return lat


def reset_lattice(lattice_obj):
    """Put every point of the lattice back where it rests (co_deform = co) and re-evaluate its users."""
    if lattice_obj is None or lattice_obj.type != "LATTICE":
        raise ValueError(f"'{getattr(lattice_obj, 'name', lattice_obj)}' is not a lattice object")
    kind.reset(lattice_obj)
    _evaluate_users(lattice_obj)


def lattice_users(lattice_obj):
    """(mesh object, entry index) of every Lattice entry that uses lattice_obj."""
    return kind.users(lattice_obj, bpy.data.objects)


def _evaluate_users(lattice_obj):
    for obj in {o for o, _ in lattice_users(lattice_obj)}:
        evaluation.evaluate(obj, evaluation.Reason.FOLLOWED)


def _lattice_entry(obj, index):
    return common.entry_of_type(obj, index, "LATTICE")


def _entry_output(obj, index, vertex_indices):
    """At the given vertices: the lattice entry's input points, its current output, each vertex's
    influence (strength * weight), and the entry's lattice at strength 1 without weights."""
    entry = _lattice_entry(obj, index)
    vertex_indices = np.asarray(vertex_indices, np.int64).ravel()
    if len(vertex_indices) == 0:
        raise ValueError("no vertices are selected")
    if vertex_indices.min() < 0 or vertex_indices.max() >= len(obj.data.vertices):
        raise IndexError(f"vertex_indices: out of range for {len(obj.data.vertices)} vertices")
    points = evaluation.entry_input(obj, index)[vertex_indices].astype(np.float64)
    weights = common.influence_weights(obj, entry)
    influence = np.full(len(points), float(entry.strength))
    if weights is not None:
        influence *= weights[vertex_indices]
    plain = kind.lattice_setup(obj, entry, strength=1.0)
    return points, points + influence[:, None] * (plain.deformer.deform(points) - points), influence, plain


def manipulation_targets(obj, index, vertex_indices, mode, cursor=None, empties=()):
    """(vertex indices, targets in obj's local space) for direct manipulation. 'CURSOR': the
    vertices' centroid (as the entry deforms them) goes to `cursor` (world space), every vertex by
    the same offset. 'EMPTIES': for each empty, the nearest of the vertices goes to it."""
    _, current, _, _ = _entry_output(obj, index, vertex_indices)
    vertex_indices = np.asarray(vertex_indices, np.int64).ravel()
    to_local = np.array(obj.matrix_world.inverted())

    def local(p):
        return to_local[:3, :3] @ np.asarray(p, np.float64) + to_local[:3, 3]

    if mode == "CURSOR":
        if cursor is None:
            raise ValueError("cursor: a location is needed")
        return vertex_indices, current + (local(cursor) - current.mean(axis=0))
    if mode != "EMPTIES":
        raise ValueError(f"mode: expected 'CURSOR' or 'EMPTIES', got {mode!r}")
    if not empties:
        raise ValueError("select one or more empties as targets")
    world = np.array(obj.matrix_world)
    current_world = current @ world[:3, :3].T + world[:3, 3]
    picked, targets = [], []
    for empty in empties:
        at = np.array(empty.matrix_world.translation)
        picked.append(vertex_indices[np.argmin(((current_world - at) ** 2).sum(axis=1))])
        targets.append(local(at))
    return np.array(picked), np.array(targets)


def closed_mesh_faces(obj):
    """The polygons of obj's mesh, which must be closed (every edge between exactly two polygons,
    as a volume needs): else ValueError naming the mesh and its open edges."""
    mesh = obj.data
    edges = np.empty(len(mesh.loops), np.int32)
    mesh.loops.foreach_get("edge_index", edges)
    uses = np.bincount(edges, minlength=len(mesh.edges))
    open_edges, shared = int(np.count_nonzero(uses == 1)), int(np.count_nonzero(uses > 2))
    if not len(mesh.polygons) or open_edges or shared:
        what = [f"{open_edges} open edges"] if open_edges or not shared else []
        what += [f"{shared} edges shared by more than two faces"] if shared else []
        faces = "" if len(mesh.polygons) else " (no faces)"
        raise ValueError(f"Preserve Volume needs a closed mesh: '{obj.name}' has {' and '.join(what)}{faces} "
                         "(Select > Select All by Trait > Non Manifold shows them)")
    return meshdata.polygons(meshdata.topology(mesh))


def direct_manipulation(obj, index, vertex_indices, targets, preserve_volume=False):
    """Move the points of entry `index`'s lattice (the least change, Hsu-Hughes-Kaufman) so that
    the entry takes the vertices `vertex_indices` to `targets` ((m, 3), obj's local space), and
    write them to the Lattice object. Returns the distances left (after the float32 round trip
    through co_deform) and the rank of the constraints. With preserve_volume, the volume of the
    entry's input mesh (closed, or ValueError) under the lattice stays what it is now (Hirota et
    al.'s constrained solve, in the module), which needs the entry without a vertex group."""
    points, _, influence, plain = _entry_output(obj, index, vertex_indices)
    targets = np.asarray(targets, np.float64).reshape(-1, 3)
    if len(targets) != len(points):
        raise ValueError(f"targets: {len(targets)} rows for {len(points)} vertices")
    if (influence <= 0).any():
        raise ValueError("some of the vertices have no lattice influence (strength or vertex-group weight 0)")
    volume = None
    if preserve_volume:
        entry = _lattice_entry(obj, index)
        if entry.vertex_group:
            raise ValueError("Preserve Volume keeps the volume under the lattice itself: clear the entry's "
                             f"vertex group '{entry.vertex_group}', or turn Preserve Volume off")
        faces = closed_mesh_faces(obj)
        mesh_points = evaluation.entry_input(obj, index).astype(np.float64)
        plain = kind.lattice_setup(obj, entry)  # at the entry's strength: the map the mesh gets
        result = plain.deformer.direct_manipulation(points, targets, preserve_volume=(mesh_points, faces))
        volume = (float(result.volume), float(result.volume_residual))
    else:
        # The entry moves a vertex by influence * (lattice displacement): aim the plain lattice further.
        result = plain.deformer.direct_manipulation(points, points + (targets - points) / influence[:, None])
    kind.write_control_points(plain, result.control_points)
    _evaluate_users(plain.lattice)
    written = kind.lattice_setup(obj, _lattice_entry(obj, index), strength=1.0).deformer.deform(points)
    residual = np.linalg.norm(points + influence[:, None] * (written - points) - targets, axis=1)
    return Manipulated(float(residual.max()), residual, int(result.rank), *(volume or (None, None)))


def lattice_bounds(obj, index):
    """The certificate of entry `index`'s lattice over the cells that hold its points (fold_free:
    does det J stay positive there?) and the volume change of the lattice region (kind.Bounds),
    kept with the entry's binding and computed again only when the binding or the lattice changed.
    The lattice is the entry's at its strength, without its vertex group (which blends the map per
    vertex, not per cell). None while the entry is not bound (evaluation binds it) or fails."""
    key = meshdata.cache_key(obj)
    bound = cache.get("lattice", (key, index, "viewport"))
    kept = cache.get("lattice", (key, index, "setup"))
    bounds = cache.get("lattice", (key, index, "bounds"))
    if bound is None or kept is None:
        return None
    if kind.bounds_current(key, index, bounds):
        return bounds
    try:
        lattice = kind.lattice_setup(obj, _lattice_entry(obj, index))
    except ValueError:
        return None  # the entry shows its message
    layout, points, binding, _counts = bound
    if lattice.layout != layout:
        return None
    resolution = layout[1]
    frame = np.frombuffer(layout[4]).reshape(4, 4)
    centres = bounds.centres if bounds is not None and bounds.binding is binding else None
    if centres is None:
        inner, outside = kind.occupied_cells(binding, resolution, layout[3])
        centres = np.concatenate([inner @ frame[:3, :3].T + frame[:3, 3], np.asarray(points, np.float64)[outside]])
    deformer = lattice.deformer
    certificate = deformer.fold_free(centres) if len(centres) else None
    folds, lower, offending = False, 1.0, []
    if certificate is not None and not certificate:
        offending = [(tuple(cell), tuple(at), float(low)) for cell, at, low in certificate.cells]
        folds = True if any(certificate.folded) else None
        # The certificate stops at the first value <= 0 in a cell: how far it folds is the bounds'.
        lower = float(deformer.volume_ratio_bounds(points=centres).lower)
    volume = float(deformer.deformed_volume())
    # The region's rest volume: the box's, or the B-spline's inner part of it.
    rest = bounds.rest_volume if bounds is not None and bounds.layout == layout else None
    if rest is None:
        moved, deformer.control_points = deformer.control_points, deformer.rest_control_points
        rest = float(deformer.deformed_volume())
        deformer.control_points = moved
    bounds = kind.Bounds(layout, binding, kept[3], centres, folds, lower, offending, volume / rest - 1.0, rest)
    return cache.put("lattice", (key, index, "bounds"), bounds)


def folded_control_points(obj, index):
    """Blender's indices of the lattice points that shape the cells where entry `index`'s lattice
    folds (or may fold) where the mesh is; ValueError when it is certified there."""
    bounds = lattice_bounds(obj, index)
    if bounds is None:
        raise ValueError("the lattice entry is not bound yet, or shows a message: fix it first")
    if not bounds.cells:
        raise ValueError("the lattice does not fold where the mesh is: nothing to select")
    lattice = kind.lattice_setup(obj, _lattice_entry(obj, index))
    return kind.cell_control_points(lattice.deformer, bounds.layout[1], [cell for cell, _at, _low in bounds.cells])


def select_folded(obj, index):
    """Select exactly the lattice points of the cells where entry `index`'s lattice folds (the
    Lattice data's `select` flags: Edit Mode's selection); returns (lattice object, point indices).
    ValueError when it does not fold where the mesh is."""
    points = folded_control_points(obj, index)
    lattice = _lattice_entry(obj, index).lattice
    chosen = np.zeros(len(lattice.data.points), bool)
    chosen[points] = True
    lattice.data.points.foreach_set("select", chosen)
    lattice.data.update_tag()
    return lattice, points


def lattice_entries(obj):
    """Indices of obj's Lattice entries."""
    return [i for i, e in enumerate(obj.deformkit.entries) if e.type in kind.TYPES]
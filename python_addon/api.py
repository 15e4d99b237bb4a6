"""Scripting API for batch scripts and tests: plain functions on objects, no context needed.

    from deformkit_addon import api
    entry = api.add_entry(obj, "TWIST", angle=math.radians(90), deform_axis="Z")
    api.set_params(entry, limits=(0.2, 0.8))
    api.evaluate(obj)
    api.apply(obj, 0)

    entry = api.add_lattice(obj, resolution=(4, 4, 4), basis="BLENDER")  # a fitted Lattice object
    api.direct_manipulation(obj, 1, [12, 40], [(0, 0, 1.2), (0.3, 0, 1)])

    entry = api.add_laplacian(obj, anchors_group="Feet", handles_group="Hand", handle_target="OBJECT",
                              handle_object=empty)  # bound at once; move the empty
    api.unbind_laplacian(obj, 2)

    api.add_entry(obj, "RBF", controls=body, rest_from="SHAPE_KEY", rest_shape_key="Basis")
    api.bind_rbf(obj, 3)  # the body's vertices drive the mesh, from their Basis to the shape-key mix

    api.add_entry(obj, "SUBDIVIDE", levels=2, render_levels=3)  # last in the stack
    figures = api.check_smoothness(obj)  # of the cage; selects the creased edges
    api.select_flipped(obj)  # selects the faces with flipped samples instead

    api.duplicate_entry(obj, 0)  # below it, bind and all
    api.copy_entry_to(obj, 0, [other])  # Copy to Selected
"""
import re
from collections import namedtuple

import bpy
import numpy as np
from mathutils import Matrix

from . import cache, evaluation, meshdata, native
from . import entries as kinds  # api.entries(obj) lists an object's entries
from .entries import common
from .entries import cage as cages
from .entries import laplacian as surface
from .entries import lattice as lattices
from .entries import rbf as rbfs
from .entries import subdivide as subdivision
from .properties import LATTICE_BASES

TYPES = kinds.TYPES
BASES = tuple(b[0] for b in LATTICE_BASES)
PARAMS = kinds.PARAMS  # every entry parameter; kinds.params(type): those one type takes


def _require_mesh(obj):
    problem = evaluation.object_problem(obj)
    if problem:
        raise ValueError(problem)


def add_entry(obj, type="TWIST", **params):
    """Add an entry of `type` (Twist, Taper, Bend, Stretch, Lattice, Laplacian, Cage, RBF,
    Subdivide; case-insensitive) at the end of the stack, or just above a Subdivide entry (which
    must stay the last one), and evaluate. Laplacian, Cage and RBF entries start unbound (see
    add_laplacian, bind_cage, bind_rbf)."""
    _require_mesh(obj)
    kind = str(type).upper()
    if kind not in TYPES:
        raise ValueError(f"type: expected one of {', '.join(TYPES)}, got {type!r}")
    kinds.check_params(kind, params)  # before the entry is added: a refused call changes nothing
    stack = obj.deformkit
    entry = _insert_entry(stack, _place_for(stack, kind), kind, _unique_name(stack, kind.title()))
    set_params(entry, **params)
    evaluation.evaluate(obj, evaluation.Reason.ADDED)
    return entry


def _place_for(stack, entry_type):
    """Where a new entry of this type goes: the end, or just above a Subdivide entry."""
    return len(stack.entries) if kinds.kind(entry_type).LAST else kinds.last_index(stack.entries)


def _insert_entry(stack, at, entry_type, name):
    """A new entry of entry_type named `name` at index `at`, made the active one."""
    entry = stack.entries.add()  # may move the items: references to other entries are stale after it
    entry.type = entry_type
    entry.name = name
    if at < len(stack.entries) - 1:
        stack.entries.move(len(stack.entries) - 1, at)
        entry = stack.entries[at]  # the moved item: the old reference points at the end of the list
    stack.active_index = at
    return entry


def _unique_name(stack, base):
    """`base`, or with the first free .001 suffix (replacing one it has), as Blender names copies."""
    names = {e.name for e in stack.entries}
    if base not in names:
        return base
    base = re.sub(r"\.\d{3}$", "", base)
    i = 1
    while f"{base}.{i:03d}" in names:
        i += 1
    return f"{base}.{i:03d}"


# What a copy of an entry does not take from it: its type and name (set first), messages and the
# helper objects the add-on writes, and a Laplacian bind (laplacian.copy_bind, where it is valid).
_NOT_COPIED = {"rna_type", "type", "name", "error", "subdivision_viewport", "subdivision_render", "bind_id",
               "bind_vertices", "bind_faces", "bind_topology", "handle_matrix", "bind_copied_from"}


def _copy_settings(source, target):
    for prop in source.bl_rna.properties:
        if prop.identifier not in _NOT_COPIED and not prop.is_readonly:
            setattr(target, prop.identifier, getattr(source, prop.identifier))


def duplicate_entry(obj, index):
    """A copy of entry `index` just below it, with its settings and (Laplacian) its bind, so that
    it deforms as the original does, as a modifier's Duplicate; it becomes the active entry. A
    Subdivide entry, which must be the last one, cannot be duplicated (ValueError)."""
    stack = obj.deformkit
    _check_index(stack, index)
    source = stack.entries[index]
    if kinds.kind(source).LAST:
        raise ValueError(f"'{source.name}' cannot be duplicated: a {kinds.LABELS[source.type]} entry must be "
                         "the last one")
    copy = _insert_entry(stack, index + 1, source.type, _unique_name(stack, source.name))
    source = stack.entries[index]  # add() may have moved it
    _copy_settings(source, copy)
    surface.copy_bind(source, copy)
    evaluation.evaluate(obj, evaluation.Reason.STACK)
    return copy


def copy_entry_to(obj, index, targets):
    """Copy entry `index` to each of the other mesh objects in `targets`, as a modifier's Copy to
    Selected: at the end of their stacks (above a Subdivide entry), same settings, the active entry
    there. A Laplacian bind belongs to the mesh it was made on, so a copy of a bound entry arrives
    unbound and its panel says to Bind again. A Subdivide entry is refused (ValueError, nothing
    copied) if a target has one already. Returns the copies."""
    stack = obj.deformkit
    _check_index(stack, index)
    source = stack.entries[index]
    targets = [t for t in targets if t is not obj and t.type == "MESH"]
    if kinds.kind(source).LAST:
        having = [t.name for t in targets if kinds.last_index(t.deformkit.entries) < len(t.deformkit.entries)]
        if having:
            raise ValueError(f"{', '.join(having)} already {'has' if len(having) == 1 else 'have'} a "
                             f"{kinds.LABELS[source.type]} entry, which must be the last one")
    copies = []
    for target in targets:
        theirs = target.deformkit
        copy = _insert_entry(theirs, _place_for(theirs, source.type), source.type,
                             _unique_name(theirs, source.name))
        _copy_settings(source, copy)
        if surface.is_bound(source):
            copy.bind_copied_from = obj.name
        evaluation.evaluate(target, evaluation.Reason.STACK)
        copies.append(copy)
    return copies


def _check_index(stack, index):
    if not 0 <= index < len(stack.entries):
        raise IndexError(f"index: {index} is out of range for {len(stack.entries)} entries")


def set_params(entry, **params):
    """Set entry parameters by name (as on Blender's Simple Deform and Lattice modifiers where they
    overlap). Only those the entry's type uses (kinds.params) are accepted: any other would be
    stored and ignored."""
    kinds.check_params(entry.type, params)
    for key, value in params.items():
        setattr(entry, key, value)
    return entry


def entries(obj):
    return list(obj.deformkit.entries)


def evaluate(obj):
    """Recompute the result now; raises ValueError with the message an entry shows, if any."""
    evaluation.forget(obj)
    evaluation.evaluate(obj, evaluation.Reason.SCRIPT)
    problems = [obj.deformkit.error] + [f"{e.name}: {e.error}" for e in obj.deformkit.entries if e.error]
    problems = [p for p in problems if p]
    if problems:
        raise ValueError("; ".join(problems))


def remove_entry(obj, index):
    stack = obj.deformkit
    if not 0 <= index < len(stack.entries):
        raise IndexError(f"index: {index} is out of range for {len(stack.entries)} entries")
    stack.entries.remove(index)
    stack.active_index = min(stack.active_index, max(0, len(stack.entries) - 1))
    evaluation.evaluate(obj, evaluation.Reason.STACK)


def move_entry(obj, index, direction):
    """Move entry `index` up (-1) or down (+1)."""
    stack = obj.deformkit
    target = index + direction
    if not (0 <= index < len(stack.entries) and 0 <= target < len(stack.entries)):
        raise IndexError(f"cannot move entry {index} by {direction}")
    stack.entries.move(index, target)
    stack.active_index = target
    evaluation.evaluate(obj, evaluation.Reason.STACK)


def move_entry_to(obj, index, where):
    """Move entry `index` to the first or the last place ('FIRST', 'LAST'), as a modifier's Move to
    First/Last; the last place of an entry that keeps the topology is above a Subdivide entry,
    which must stay last. Returns the entry's new index."""
    stack = obj.deformkit
    if not 0 <= index < len(stack.entries):
        raise IndexError(f"index: {index} is out of range for {len(stack.entries)} entries")
    if where not in ("FIRST", "LAST"):
        raise ValueError(f"where: expected 'FIRST' or 'LAST', got {where!r}")
    others = [e for i, e in enumerate(stack.entries) if i != index]
    if where == "FIRST":
        target = 0
    elif kinds.kind(stack.entries[index]).LAST:
        target = len(stack.entries) - 1
    else:
        target = kinds.last_index(others)
    if target != index:
        stack.entries.move(index, target)
    stack.active_index = target
    evaluation.evaluate(obj, evaluation.Reason.STACK)
    return target


def apply(obj, index=0):
    """Bake entry `index` into the mesh; returns Blender's warning when it was not first."""
    stack = obj.deformkit
    if not 0 <= index < len(stack.entries):
        raise IndexError(f"index: {index} is out of range for {len(stack.entries)} entries")
    _require_mesh(obj)
    return evaluation.apply_entry(obj, index)


def evaluated_positions(obj, depsgraph=None):
    return evaluation.evaluated_positions(obj, depsgraph)


def entry_of_type(obj, index, entry_type):
    """Entry `index` of obj's stack, which must be of `entry_type`."""
    stack = obj.deformkit
    if not 0 <= index < len(stack.entries):
        raise IndexError(f"index: {index} is out of range for {len(stack.entries)} entries")
    entry = stack.entries[index]
    if entry.type != entry_type:
        raise ValueError(f"entry '{entry.name}' is a {entry.type.title()} entry, not a {entry_type.title()} entry")
    return entry


# Laplacian entries ----------------------------------------------------------------------------

def laplacian_entry(obj, index):
    """Entry `index` of obj's stack, which must be a Laplacian entry."""
    return entry_of_type(obj, index, "LAPLACIAN")


def add_laplacian(obj, bind=True, **params):
    """Append a Laplacian entry with these parameters and (by default) bind it at once."""
    entry = add_entry(obj, "LAPLACIAN", **params)
    if bind:
        bind_laplacian(obj, obj.deformkit.active_index)  # the new entry, which may be above a Subdivide entry
        entry = obj.deformkit.entries[obj.deformkit.active_index]
    return entry


def bind_laplacian(obj, index):
    """Record the points coming into entry `index` as its rest (and the handle object's place) and
    factorise its system, as Laplacian Deform's Bind; returns the number of vertices bound. Raises
    ValueError, and leaves the entry as it was, if it cannot be bound."""
    entry = laplacian_entry(obj, index)
    _require_mesh(obj)
    if obj.mode == "EDIT":
        raise ValueError("bind: leave edit mode first (edit mode holds its own copy of the mesh)")
    count = surface.bind(obj, entry, evaluation.entry_input(obj, index))
    evaluation.evaluate(obj, evaluation.Reason.STACK)
    return count


def unbind_laplacian(obj, index):
    """Forget entry `index`'s rest: it passes its input through until bound again."""
    surface.unbind(obj, laplacian_entry(obj, index))
    evaluation.evaluate(obj, evaluation.Reason.STACK)


# Cage entries ---------------------------------------------------------------------------------

def bind_cage(obj, index):
    """Record the cage's current evaluated shape as entry `index`'s rest, as Mesh Deform's Bind;
    returns the cage's vertex count. Raises ValueError (naming the first open edge or bad face of
    the cage, ...), and leaves the entry as it was, if it cannot be bound."""
    entry = entry_of_type(obj, index, "CAGE")
    _require_mesh(obj)
    count = cages.bind(obj, entry)
    evaluation.evaluate(obj, evaluation.Reason.STACK)
    return count


def unbind_cage(obj, index):
    """Forget entry `index`'s rest cage: it passes its input through until bound again."""
    cages.unbind(entry_of_type(obj, index, "CAGE"))
    evaluation.evaluate(obj, evaluation.Reason.STACK)


# RBF entries ----------------------------------------------------------------------------------

def bind_rbf(obj, index):
    """Record entry `index`'s controls (all, the selected or a vertex group's vertices of its
    control object) and their rest positions (the control object's current evaluated shape, another
    object's or a shape key's, as Rest From says); returns the number of controls. Raises
    ValueError (no control object, another vertex count, a system dk.RBF cannot fit, ...), and
    leaves the entry as it was, if it cannot be bound."""
    entry = entry_of_type(obj, index, "RBF")
    _require_mesh(obj)
    count = rbfs.bind(obj, entry)
    evaluation.evaluate(obj, evaluation.Reason.STACK)
    return count


def unbind_rbf(obj, index):
    """Forget entry `index`'s controls and rest: it passes its input through until bound again."""
    rbfs.unbind(entry_of_type(obj, index, "RBF"))
    evaluation.evaluate(obj, evaluation.Reason.STACK)


BINDS = {"LAPLACIAN": bind_laplacian, "CAGE": bind_cage, "RBF": bind_rbf}  # the entries that need a Bind


# Lattice entries ------------------------------------------------------------------------------

Bound = namedtuple("Bound", "inside outside not_placed")
Manipulated = namedtuple("Manipulated", "max_residual residual rank")


def lattice_entry(obj, index):
    """Entry `index` of obj's stack, which must be a Lattice entry."""
    return entry_of_type(obj, index, "LATTICE")


def add_lattice(obj, resolution=(4, 4, 4), basis="BLENDER", selected_only=False, margin=1e-4):
    """Add a Lattice object fitted to the bounding box of the mesh (as the stack leaves it; with
    selected_only, of its selected vertices) in its local frame, widened by `margin` of the box's
    largest side so that no vertex lies outside by rounding, and a Lattice entry using it."""
    _require_mesh(obj)
    resolution = tuple(int(n) for n in resolution)
    if len(resolution) != 3 or not all(1 <= n <= 64 for n in resolution):
        raise ValueError(f"resolution: expected three counts in 1..64, got {resolution}")
    basis = str(basis).upper()
    if basis not in BASES:
        raise ValueError(f"basis: expected one of {', '.join(BASES)}, got {basis!r}")
    lattices.check_basis(basis, "CLAMP", resolution, "the resolution")
    if obj.mode == "EDIT":
        obj.update_from_editmode()  # edit mode keeps the selection and positions in its own copy
    entries = obj.deformkit.entries
    points = evaluation.entry_input(obj, len(entries)) if len(entries) else evaluation.base_positions(obj.data)
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
    lattices.reset(lat)  # the resize deforms the new points by the old grid: start exactly at rest
    for collection in obj.users_collection or (bpy.context.scene.collection,):
        collection.objects.link(lat)
    lat.matrix_world = obj.matrix_world @ box
    return add_entry(obj, "LATTICE", lattice=lat, lattice_basis=basis)


def bind_lattice(obj, index):
    """Bind the mesh to the lattice of entry `index` again (deformkit also does this by itself
    when the mesh, the frame, the resolution or the basis change); returns the vertex counts."""
    entry = lattice_entry(obj, index)
    _require_mesh(obj)
    key = evaluation.cache_key(obj)
    cache.forget(key, "lattice")
    points = evaluation.entry_input(obj, index)
    lattice = evaluation.entry_setup(obj, entry)[1].data
    counts = lattices.bind((key, index, "viewport"), lattice, points)[3]
    evaluation.evaluate(obj, evaluation.Reason.STACK)
    return Bound(*counts)


def reset_lattice(lattice_obj):
    """Put every point of the lattice back where it rests (co_deform = co) and re-evaluate its users."""
    if lattice_obj is None or lattice_obj.type != "LATTICE":
        raise ValueError(f"'{getattr(lattice_obj, 'name', lattice_obj)}' is not a lattice object")
    lattices.reset(lattice_obj)
    _evaluate_users(lattice_obj)


def lattice_users(lattice_obj):
    """(mesh object, entry index) of every Lattice entry that uses lattice_obj."""
    return lattices.users(lattice_obj, bpy.data.objects)


def _evaluate_users(lattice_obj):
    for obj in {o for o, _ in lattice_users(lattice_obj)}:
        evaluation.evaluate(obj, evaluation.Reason.FOLLOWED)


def _entry_output(obj, index, vertex_indices):
    """At the given vertices: the lattice entry's input points, its current output, each vertex's
    influence (strength * weight), and the entry's lattice at strength 1 without weights."""
    entry = lattice_entry(obj, index)
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
    plain = lattices.lattice_setup(obj, entry, strength=1.0)
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


def direct_manipulation(obj, index, vertex_indices, targets):
    """Move the points of entry `index`'s lattice (the least change, Hsu-Hughes-Kaufman) so that
    the entry takes the vertices `vertex_indices` to `targets` ((m, 3), obj's local space), and
    write them to the Lattice object. Returns the distances left (after the float32 round trip
    through co_deform) and the rank of the constraints."""
    points, _, influence, plain = _entry_output(obj, index, vertex_indices)
    targets = np.asarray(targets, np.float64).reshape(-1, 3)
    if len(targets) != len(points):
        raise ValueError(f"targets: {len(targets)} rows for {len(points)} vertices")
    if (influence <= 0).any():
        raise ValueError("some of the vertices have no lattice influence (strength or vertex-group weight 0)")
    # The entry moves a vertex by influence * (lattice displacement): aim the plain lattice further.
    result = plain.deformer.direct_manipulation(points, points + (targets - points) / influence[:, None])
    lattices.write_control_points(plain, result.control_points)
    _evaluate_users(plain.lattice)
    written = lattices.lattice_setup(obj, lattice_entry(obj, index), strength=1.0).deformer.deform(points)
    residual = np.linalg.norm(points + influence[:, None] * (written - points) - targets, axis=1)
    return Manipulated(float(residual.max()), residual, int(result.rank))


# Smoothness ------------------------------------------------------------------------------------

def check_smoothness(obj, select=True, worst=10, min_angle=1e-6, samples_per_edge=8):
    """dk.smoothness_report on obj's cage: the base mesh through the entries above the Subdivide
    entry (all entries if there is none), with that entry's scheme, boundary and creases (a new
    entry's defaults without one). Stores the figures on the stack for the panel and, with select,
    selects the worst edges whose angle exceeds min_angle radians (above rounding, so a smooth
    surface selects none) and deselects the rest. Returns the report's to_dict() plus
    "worst_edge" (its vertices) and "selected_edges" (Blender edge indices)."""
    _require_mesh(obj)
    mesh = obj.data
    if obj.mode == "EDIT":
        # Edit mode keeps the mesh in its own copy, and attributes (creases) read through it: read a
        # plain copy of the mesh as edit mode leaves it.
        obj.update_from_editmode()
        mesh = obj.data.copy()
    try:
        stack = obj.deformkit.entries
        index = kinds.last_index(stack)
        cage = evaluation.entry_input(obj, index)
        topo = meshdata.topology(mesh)
        if topo.faces == 0:
            raise ValueError("the mesh has no faces: there is no surface to check")
        kwargs = subdivision.topology_kwargs(mesh, stack[index] if index < len(stack) else None)
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


# Any kind with a bind -----------------------------------------------------------------------------

def bind(obj, index):
    """Bind entry `index` (Laplacian, Cage, RBF: its rest; Lattice: bind again), as the entry's Bind
    button; returns what the kind reports (a count, or the Lattice's Bound)."""
    stack = obj.deformkit
    _check_index(stack, index)
    kind = stack.entries[index].type
    binds = dict(BINDS, LATTICE=bind_lattice)
    if kind not in binds:
        raise ValueError(f"entry '{stack.entries[index].name}' is a {kinds.LABELS[kind]} entry, which has no bind")
    return binds[kind](obj, index)


def unbind(obj, index):
    """Forget entry `index`'s bind: it passes its input through until bound again."""
    stack = obj.deformkit
    _check_index(stack, index)
    kind = stack.entries[index].type
    unbinds = {"LAPLACIAN": unbind_laplacian, "CAGE": unbind_cage, "RBF": unbind_rbf}
    if kind not in unbinds:
        raise ValueError(f"entry '{stack.entries[index].name}' is a {kinds.LABELS[kind]} entry, which has no unbind")
    unbinds[kind](obj, index)

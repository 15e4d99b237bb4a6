"""Lattice entries: a Blender Lattice object as the control grid of one of deformkit's lattices.

A Lattice object keeps its rest grid (`co`: fu + i du per axis, in lattice-local space) and its
edited points (`co_deform`). Blender's Lattice modifier moves each vertex by a blend of the offsets
co_deform - co, turned into the object's space. The entry does the same: its frame maps deformkit's
rest cube [-1/2, 1/2]^3 onto the box of the rest grid, and its control points are deformkit's rest
control points plus those offsets, so a lattice at rest is the identity bit for bit, in every basis.

Here too: the entry's settings and panel; its operators are in operators/lattice.py.
"""
import functools
import zlib
from collections import namedtuple

import numpy as np

from .. import cache, meshdata, native
from ..errors import EntryError
from ..panel_text import box_budget, label_wrapped
from .common import Prepared, affine_inverse, draw_vertex_group, followed_object, influence_weights, stack_index

ENTRY_TYPES = [
    ("LATTICE", "Lattice", "Free-form deformation by a Lattice object, edited with Blender's lattice tools",
     "NONE", 4),
]
TYPES = tuple(row[0] for row in ENTRY_TYPES)  # its entry.type identifiers
LATTICE_BASES = [
    ("BLENDER", "Blender", "Blender's Lattice modifier, with the lattice's own interpolation settings", 0),
    ("BERNSTEIN", "Bernstein", "Sederberg-Parry FFD: one Bernstein polynomial of degree points - 1 per axis", 1),
    ("BEZIER", "Bezier Blocks", "Piecewise tricubic Bezier blocks: 3k + 1 points per axis (4, 7, 10, ...)", 2),
    ("BSPLINE", "B-Spline", "Uniform cubic B-spline FFD (C2): at least 4 points per axis", 3),
]
OUTSIDE = [
    ("CLAMP", "Clamp", "Points outside the lattice move with its nearest boundary point, as in Blender", 0),
    ("UNCHANGED", "Unchanged", "Points outside the lattice do not move", 1),
    ("EXTRAPOLATE", "Extrapolate", "Continue the polynomial pieces outside the lattice (not with the Blender basis)",
     2),
]
ICON = "MOD_LATTICE"
DEFORMS_INTO = True  # deform takes out=: the result is written into the given array
MENU = (("deformkit.add_lattice", "OUTLINER_OB_LATTICE"),)  # below the Add menu's entry types
FIELDS = ("lattice", "lattice_basis", "outside", "strength", "vertex_group", "invert_vertex_group",
          "preserve_volume")

BASES = tuple(b[0] for b in LATTICE_BASES)
CLASSES = {"BLENDER": "BlenderLattice", "BERNSTEIN": "FFD", "BEZIER": "BezierFFD", "BSPLINE": "BSplineLattice"}


# deformer: the dk lattice; layout: what a binding depends on; local: lattice-local -> object space
# (4x4); co: the rest grid as Blender stores it (u fastest).
Setup = namedtuple("Setup", "deformer fingerprint layout lattice local co")
# The vertex counts of a binding (Bind's report).
Bound = namedtuple("Bound", "inside outside not_placed")
# The lattice's certificate over the cells that hold the mesh, and its volume change, as the panel
# shows them (lattice_tools.lattice_bounds computes them, after an edit rather than during it).
# layout, binding, offsets: what they were computed for; centres: the points standing for the
# cells that hold the mesh (occupied_cells), in the lattice's space, kept while the binding is;
# folds: True (det J <= 0 found), None (not proven positive within the work cap), False (proven
# positive); lower: a lower bound of det J there, within 1e-3 of its minimum (1 when certified:
# not computed); cells: the certificate's (cell, local coordinates, lower bound) of the offending
# cells; volume_change: deformed volume / rest volume - 1 of the lattice's whole region (the box,
# or the B-spline's inner part of it), rest_volume the latter.
Bounds = namedtuple("Bounds", "layout binding offsets centres folds lower cells volume_change rest_volume")

# Bindings are kept in the cache's "lattice" space: (object cache key, entry index, "viewport"/"render")
# -> (layout, bound points, binding, counts). The rest grids are not: they belong to Lattice data
# (session_uid or name), not to a mesh object, and are dropped on file load only.
_rest = {}  # Lattice data -> (resolution, rest grid `co`) read outside edit mode


def lattice_object(entry):
    """The entry's Lattice object, or EntryError saying why it cannot be used."""
    if entry.lattice is not None and entry.lattice.type != "LATTICE":
        raise EntryError(f"'{entry.lattice.name}' is not a lattice object")
    lat = followed_object(entry, "lattice", "lattice", "no lattice object set: pick one, or use Add Fitted Lattice")
    data = lat.data
    if data.vertex_group:
        raise EntryError(f"lattice '{lat.name}' weights its points by the vertex group '{data.vertex_group}', "
                         "which deformkit does not support: clear the lattice's Vertex Group")
    if data.shape_keys is not None:
        raise EntryError(f"lattice '{lat.name}' has shape keys, which deformkit does not evaluate")
    if len(lat.modifiers):
        names = ", ".join(m.name for m in lat.modifiers)
        raise EntryError(f"lattice '{lat.name}' has modifiers ({names}), which deformkit does not evaluate: "
                         "apply or remove them")
    return lat


def read_points(data, prop):
    flat = np.empty(len(data.points) * 3, np.float32)
    data.points.foreach_get(prop, flat)
    return flat.reshape(-1, 3)


def rest_points(data, resolution):
    """The rest grid `co`. In lattice edit mode Blender's `co` is wrong (it locates the edit copy's
    points in the original's array), so the grid read last outside edit mode is used there, or,
    for a lattice that has not been seen outside edit mode, the grid that the UI makes."""
    key = getattr(data, "session_uid", None) or data.name_full
    if not data.is_editmode:
        co = read_points(data, "co")
        _rest[key] = (resolution, co)
        return co
    cached = _rest.get(key)
    if cached is not None and cached[0] == resolution:
        return cached[1]
    axes = [np.linspace(-0.5, 0.5, n) if n > 1 else np.zeros(1) for n in resolution]
    w, v, u = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    return np.stack([u, v, w], axis=-1).reshape(-1, 3).astype(np.float32)


def to_grid(flat, resolution):
    """Blender's point order (u fastest, then v, then w) -> deformkit's grid [i, j, k]."""
    nu, nv, nw = resolution
    return flat.reshape(nw, nv, nu, 3).transpose(2, 1, 0, 3)


def from_grid(grid):
    return np.ascontiguousarray(grid.transpose(2, 1, 0, 3)).reshape(-1, 3)


@functools.lru_cache(maxsize=16)
def _grid_indices(resolution):
    """(i, j, k) of each point in Blender's order (u fastest)."""
    nu, nv, nw = resolution
    w, v, u = np.meshgrid(np.arange(nw), np.arange(nv), np.arange(nu), indexing="ij")
    return np.stack([u, v, w], axis=-1).reshape(-1, 3)


def rest_box(co, resolution, name):
    """(center, size) of the rest grid's box in lattice-local space. Lattices made in the UI span
    [-1/2, 1/2]; ones resized before they had an object, or back from one point, are spaced 1 apart."""
    counts = np.array(resolution)
    lo, hi = co[0].astype(np.float64), co[-1].astype(np.float64)
    expected = lo + (hi - lo) * _grid_indices(tuple(resolution)) / np.maximum(counts - 1, 1)
    uneven = np.abs(co - expected).max(axis=0) > 1e-5 * np.maximum(1.0, hi - lo)
    uneven |= (counts > 1) & ~(hi > lo)
    if uneven.any():
        raise EntryError(f"lattice '{name}': its rest grid is not evenly spaced along {'uvw'[np.argmax(uneven)]}, "
                         "which deformkit does not support")
    return (lo + hi) / 2, np.where(counts > 1, hi - lo, 1.0)


def check_basis(basis, outside, resolution, name="the lattice"):
    nu, nv, nw = resolution
    has = f"{name} has {nu} x {nv} x {nw} points"
    if basis == "BLENDER" and outside == "EXTRAPOLATE":
        raise EntryError("Outside 'Extrapolate' is not available with the Blender basis (Blender's modifier "
                         "clamps): choose Clamp or Unchanged, or another basis")
    if basis == "BERNSTEIN" and not all(2 <= n <= 16 for n in resolution):
        raise EntryError(f"the Bernstein basis needs 2 to 16 points per axis (degree 1 to 15); {has}")
    if basis == "BEZIER" and not all(n >= 4 and (n - 1) % 3 == 0 for n in resolution):
        raise EntryError(f"the Bezier Blocks basis needs 3k + 1 points per axis (4, 7, 10, ...); {has}")
    if basis == "BSPLINE" and min(resolution) < 4:
        raise EntryError(f"the B-Spline basis needs at least 4 points per axis; {has}")


def setup(obj, entry, reuse_weights=False):
    """The entry as evaluation runs it: its lattice, with its strength and vertex-group influence."""
    kept = (meshdata.cache_key(obj), stack_index(entry), "setup")
    lattice = lattice_setup(obj, entry, influence_weights(obj, entry, reuse_weights), kept=kept)
    return Prepared(lattice.deformer, lattice.fingerprint, lattice)


def refresh(obj, entry, prepared):
    """setup again where only the lattice changed (a drag of its points or of the lattice object):
    everything is read from the lattice again, the weights are those read last time."""
    return setup(obj, entry, reuse_weights=True)


def lattice_setup(obj, entry, weights=None, strength=None, kept=None):
    """The entry's deformkit lattice for `obj`. strength=None takes the entry's. kept: a key of the
    cache's "lattice" space under which the deformer is kept for the next setup, which then only
    moves its control points if nothing else changed (a new deformer copies and checks the weights)."""
    lat = lattice_object(entry)
    data = lat.data
    resolution = (data.points_u, data.points_v, data.points_w)
    basis, outside = entry.lattice_basis, entry.outside
    check_basis(basis, outside, resolution, f"lattice '{lat.name}'")
    cls = getattr(native.dk, CLASSES[basis], None)
    if cls is None:
        raise EntryError(f"this build of deformkit has no lattices: {native.BUILD_HINT}")
    co, deformed = rest_points(data, resolution), read_points(data, "co_deform")
    center, size = rest_box(co, resolution, lat.name)
    local = np.array(obj.matrix_world.inverted() @ lat.matrix_world)
    box = np.diag([*size, 1.0])
    box[:3, 3] = center
    frame = local @ box
    strength = entry.strength if strength is None else strength
    interpolation = None
    if basis == "BLENDER":
        interpolation = (data.interpolation_type_u, data.interpolation_type_v, data.interpolation_type_w)
    layout = (basis, resolution, interpolation, outside, frame.tobytes())
    offsets = to_grid(deformed - co, resolution).astype(np.float64)  # float32 difference, as Blender's
    deformer = _deformer(cls, layout, frame, strength, weights, offsets @ local[:3, :3].T, kept)
    fingerprint = (layout, deformer.strength, zlib.crc32(offsets.tobytes()), meshdata.weights_crc(weights))
    return Setup(deformer, fingerprint, layout, lat, local, co)


def _deformer(cls, layout, frame, strength, weights, offsets, kept):
    """The lattice of this layout, strength and weights with control points rest + offsets (in the
    object's space): the one kept under `kept` if made for the same, else a new one (kept there)."""
    was = None if kept is None else cache.get("lattice", kept)
    if was is not None and was[0] == (layout, strength) and was[1] is weights:
        deformer = was[2]
        if np.array_equal(was[3], offsets):
            return deformer
    else:
        basis, resolution, interpolation, outside = layout[:4]
        kwargs = dict(frame=frame, outside=outside.lower(), weights=weights, strength=strength)
        if basis == "BLENDER":
            deformer = cls(resolution, interpolation, **kwargs)
        elif basis == "BERNSTEIN":
            deformer = cls(tuple(n - 1 for n in resolution), **kwargs)
        elif basis == "BEZIER":
            deformer = cls(tuple((n - 1) // 3 for n in resolution), **kwargs)
        else:
            deformer = cls(resolution, **kwargs)
    if offsets.any():
        deformer.control_points = deformer.rest_control_points + offsets
    elif was is not None:  # back at rest: the identity exactly, as a new lattice is
        deformer.control_points = deformer.rest_control_points
    if kept is not None:
        cache.put("lattice", kept, ((layout, strength), weights, deformer, offsets))
    return deformer


def deform(key, prepared, points, out=None):
    """The entry's result on `points` (into `out` if given), through a binding kept for as long as
    the points and the lattice's layout (basis, resolution, interpolation, placement) stay the same."""
    lattice = prepared.data
    return lattice.deformer.deform_bound(_binding(key, lattice, points), out=out)


def displace(key, prepared, points, out):
    """The entry's offsets w (F(x) - x) on `points`, into `out`, in one pass (through the same binding)."""
    lattice = prepared.data
    return lattice.deformer.displacement_bound(_binding(key, lattice, points), out=out)


def _binding(key, lattice, points):
    cached = cache.get("lattice", key)
    if cached is None or cached[0] != lattice.layout:
        cached = bind_points(key, lattice, points)
    elif cached[1] is not points:
        if not np.array_equal(cached[1], points):
            cached = bind_points(key, lattice, points)
        else:  # the same positions read again: keep this array, which the next evaluation may reuse
            cached = cache.put("lattice", key, (cached[0], points) + cached[2:])
    return cached[2]


def bind_points(key, lattice_setup, points):
    """Bind the points to the lattice, kept in the cache's "lattice" space under `key`."""
    binding = lattice_setup.deformer.bind(points)
    status = np.asarray(binding.status)
    counts = tuple(int(np.count_nonzero(status == s)) for s in (0, 1, 2))
    # The points are kept, not copied: evaluation never writes into base positions or results.
    return cache.put("lattice", key, (lattice_setup.layout, points, binding, counts))


def bind(obj, entry, incoming):
    """Bind the points coming into the entry (incoming()) to its lattice again, dropping the
    object's other lattice bindings (each entry makes its own again by itself when its points or
    its lattice's layout change); returns the vertex counts (Bound)."""
    key = meshdata.cache_key(obj)
    cache.forget(key, "lattice")
    points = incoming()
    lattice = lattice_setup(obj, entry, influence_weights(obj, entry))
    return Bound(*bind_points((key, stack_index(entry), "viewport"), lattice, points)[3])


def prune(object_key, entries):
    """The lattices kept for places no Lattice entry has any more go (bindings stay: they are
    checked against the points and layout when used)."""
    alive = {stack_index(e) for e in entries}
    cache.forget(object_key, "lattice", keep=lambda k: k[2] not in ("setup", "bounds") or k[1] in alive)


def binding_counts(object_key, index):
    """(inside, outside, not placed) vertex counts of the entry's binding, or None if not bound."""
    for kind in ("viewport", "render"):
        cached = cache.get("lattice", (object_key, index, kind))
        if cached is not None:
            return cached[3]
    return None


def occupied_cells(binding, resolution, outside):
    """Indices of bound points that stand for the cells holding them all, as the lattice's
    certificate takes them, and the centres (in the rest cube [-1/2, 1/2]^3) of the grid intervals
    (points - 1 per axis) that hold points inside the lattice. Every basis's polynomial cells are
    unions of these intervals (Blender's cells, the B-spline's spans, Bezier blocks, the one
    Bernstein cell), so a centre stands for exactly the cell holding its interval's points, away
    from its boundaries. Outside the lattice, clamped or unchanged, the map depends on the side and
    the interval (two deep, as Blender's outside cells), so one point of each such group stands for
    it; extrapolated points all count (their cells widen with them). The certificate then costs
    the cells, not the vertices."""
    status = np.asarray(binding.status)
    bins = np.maximum(np.asarray(resolution) - 1, 1)
    index = np.clip(np.floor(np.asarray(binding.parameters) * bins), -2, bins + 1).astype(np.int64)
    inside = status == 0
    seen = np.zeros(int(np.prod(bins)), bool)
    seen[np.ravel_multi_index(np.minimum(np.maximum(index[inside], 0), bins - 1).T, bins)] = True
    occupied = np.stack(np.unravel_index(np.flatnonzero(seen), bins), axis=1)
    out = np.flatnonzero(status == 1)
    if outside != "EXTRAPOLATE" and len(out):
        _, first = np.unique(np.ravel_multi_index((index[out] + 2).T, bins + 4), return_index=True)
        out = out[first]
    return (occupied + 0.5) / bins - 0.5, out


def cell_control_points(deformer, resolution, cells):
    """Blender's indices (u fastest) of the lattice points that shape the given cells (the
    module's cell_control_indices: the points whose weight is not zero there)."""
    nu, nv, _nw = resolution
    grid = np.concatenate([deformer.cell_control_indices(cell) for cell in cells]).astype(np.int64)
    return np.unique(grid[:, 0] + nu * (grid[:, 1] + nv * grid[:, 2]))


def kept_bounds(object_key, index):
    """The last Bounds computed for the entry, if they are of its current binding's layout."""
    bounds = cache.get("lattice", (object_key, index, "bounds"))
    bound = cache.get("lattice", (object_key, index, "viewport"))
    if bounds is None or bound is None or bound[0] != bounds.layout:
        return None
    return bounds


def bounds_current(object_key, index, bounds):
    """Whether `bounds` were computed for the entry's binding and lattice as evaluation keeps them."""
    bound = cache.get("lattice", (object_key, index, "viewport"))
    kept = cache.get("lattice", (object_key, index, "setup"))
    return (bounds is not None and bound is not None and kept is not None and bound[2] is bounds.binding
            and kept[3] is bounds.offsets)


def fold_message(bounds):
    """The panel's warning for these bounds, or "" when the cells that hold the mesh are certified."""
    if bounds is None or bounds.folds is False:
        return ""
    cells = f"{len(bounds.cells)} cell{'s' if len(bounds.cells) != 1 else ''}"
    if bounds.folds:
        return f"The lattice folds: volume ratio down to {bounds.lower:.2f} in {cells}"
    return f"The lattice may fold: volume ratio not proven positive in {cells} (bound {bounds.lower:.2f})"


def volume_text(bounds):
    return f"Volume: {100 * bounds.volume_change:+.1f}%"


def followed(entry):
    """(object, remembered name) of the objects the entry follows: its lattice."""
    return [(entry.lattice, entry.lattice_name)]


def loaded():
    """On file load: another file's lattice may have the same name (Blender 3.4 has no session_uid)."""
    _rest.clear()


def write_control_points(lattice_setup, grid):
    """Store control points given in the object's space (nu, nv, nw, 3) as the lattice's co_deform."""
    offsets = (np.asarray(grid, np.float64) - lattice_setup.deformer.rest_control_points) \
        @ affine_inverse(lattice_setup.local)[:3, :3].T
    co_deform = lattice_setup.co.astype(np.float64) + from_grid(offsets)
    data = lattice_setup.lattice.data
    data.points.foreach_set("co_deform", co_deform.astype(np.float32).ravel())
    data.update_tag()


def reset(lattice_obj):
    data = lattice_obj.data
    rest = rest_points(data, (data.points_u, data.points_v, data.points_w))
    data.points.foreach_set("co_deform", rest.ravel())
    data.update_tag()


def users(lattice_obj, objects):
    """(object, entry index) of every Lattice entry that uses lattice_obj."""
    return [(obj, i) for obj in objects if obj.type == "MESH"
            for i, e in enumerate(obj.deformkit.entries) if e.type in TYPES and e.lattice == lattice_obj]


def draw(col, obj, entry):
    """Laid out like Blender's Lattice modifier panel, then the binding and the lattice tools."""
    index = list(obj.deformkit.entries).index(entry)
    col.prop(entry, "lattice", text="Object")
    col.prop(entry, "lattice_basis")
    col.prop(entry, "outside")
    col.prop(entry, "strength", slider=True)
    draw_vertex_group(col, obj, entry)
    col.separator()
    bound = binding_counts(meshdata.cache_key(obj), index)
    if bound is None:
        col.label(text="Not bound yet", icon="UNLINKED")
    else:
        unplaced = f", {bound[2]} not placed" if bound[2] else ""
        col.label(text=f"Bound: {bound[0]} vertices inside, {bound[1]} outside{unplaced}", icon="LINKED")
    row = col.row(align=True)
    row.operator("deformkit.lattice_bind", text="Rebind" if bound else "Bind", icon="FILE_REFRESH").index = index
    row.operator("deformkit.lattice_reset", text="Reset", icon="LOOP_BACK").index = index
    # The last check of the lattice (handlers.check_lattices, after an edit): not computed here.
    bounds = kept_bounds(meshdata.cache_key(obj), index)
    if bounds is not None:
        col.label(text=volume_text(bounds))
        message = fold_message(bounds)
        if message:
            label_wrapped(col, message, "ERROR", box_budget())
            col.operator("deformkit.lattice_select_folded", text="Select Folded Cells",
                         icon="RESTRICT_SELECT_OFF").index = index
    # Short labels: "Selection to Empties" is cut on a half row at the default width.
    col.label(text="Move Selection To")
    row = col.row(align=True)
    for targets, label, icon in (("CURSOR", "Cursor", "PIVOT_CURSOR"), ("EMPTIES", "Empties", "EMPTY_AXIS")):
        op = row.operator("deformkit.lattice_direct", text=label, icon=icon)
        op.index, op.targets = index, targets
    col.prop(entry, "preserve_volume")

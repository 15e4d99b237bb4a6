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

from . import entry_animation, evaluation, lattice_tools, meshdata, smoothness
from . import entries as kinds  # api.entries(obj) lists an object's entries
from .entries import common

TYPES = kinds.TYPES
PARAMS = kinds.PARAMS  # every entry parameter; kinds.params(type): those one type takes


def add_entry(obj, type="TWIST", **params):
    """Add an entry of `type` (Twist, Taper, Bend, Stretch, Lattice, Laplacian, Cage, RBF,
    Subdivide; case-insensitive) at the end of the stack, or just above a Subdivide entry (which
    must stay the last one), and evaluate. Laplacian, Cage and RBF entries start unbound (see
    add_laplacian, bind_cage, bind_rbf). Parameters left out take a new entry's values (the
    properties' defaults, but a Laplacian entry's method: Rotation Invariant)."""
    meshdata.require_mesh(obj)
    kind = str(type).upper()
    if kind not in TYPES:
        raise ValueError(f"type: expected one of {', '.join(TYPES)}, got {type!r}")
    kinds.check_params(kind, params)  # before the entry is added: a refused call changes nothing
    stack = obj.deformkit
    entry = _insert_entry(stack, _place_for(stack, kind), kind, _unique_name(stack, kinds.LABELS[kind]))
    set_params(entry, **{**kinds.kind(kind).NEW_ENTRY, **params})
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
        entry_animation.inserted(stack.id_data, at)
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


def _copy_settings(source, target):
    """Every setting of source that a copy takes (not those of kinds.NOT_COPIED: binds, helpers)."""
    for prop in source.bl_rna.properties:
        if prop.identifier not in kinds.NOT_COPIED and not prop.is_readonly:
            setattr(target, prop.identifier, getattr(source, prop.identifier))


def duplicate_entry(obj, index):
    """A copy of entry `index` just below it, with its settings and (Laplacian) its bind, so that
    it deforms as the original does, as a modifier's Duplicate; it becomes the active entry. A
    Subdivide entry, which must be the last one, cannot be duplicated (ValueError)."""
    stack = obj.deformkit
    common.check_index(stack, index)
    source = stack.entries[index]
    if kinds.kind(source).LAST:
        raise ValueError(f"'{source.name}' cannot be duplicated: a {kinds.LABELS[source.type]} entry must be "
                         "the last one")
    copy = _insert_entry(stack, index + 1, source.type, _unique_name(stack, source.name))
    source = stack.entries[index]  # add() may have moved it
    _copy_settings(source, copy)
    kinds.kind(source).copy_bind(source, copy)
    entry_animation.copy_animation(obj, index, obj, index + 1)
    evaluation.evaluate(obj, evaluation.Reason.STACK)
    return copy


def copy_entry_to(obj, index, targets):
    """Copy entry `index` to each of the other mesh objects in `targets`, as a modifier's Copy to
    Selected: at the end of their stacks (above a Subdivide entry), same settings, the active entry
    there. A Laplacian bind belongs to the mesh it was made on, so a copy of a bound entry arrives
    unbound and its panel says to Bind again. A Subdivide entry is refused (ValueError, nothing
    copied) if a target has one already. Returns the copies."""
    stack = obj.deformkit
    common.check_index(stack, index)
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
        entry_animation.copy_animation(obj, index, target, theirs.active_index)
        if kinds.kind(source).is_bound(source):
            copy.bind_copied_from = obj.name
        evaluation.evaluate(target, evaluation.Reason.STACK)
        copies.append(copy)
    return copies


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
    common.check_index(stack, index)
    entry_animation.removed(obj, index)
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
    entry_animation.moved(obj, index, target)
    stack.active_index = target
    evaluation.evaluate(obj, evaluation.Reason.STACK)


def move_entry_to(obj, index, where):
    """Move entry `index` to the first or the last place ('FIRST', 'LAST'), as a modifier's Move to
    First/Last; the last place of an entry that keeps the topology is above a Subdivide entry,
    which must stay last. Returns the entry's new index."""
    stack = obj.deformkit
    common.check_index(stack, index)
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
        entry_animation.moved(obj, index, target)
    stack.active_index = target
    evaluation.evaluate(obj, evaluation.Reason.STACK)
    return target


def apply(obj, index=0):
    """Bake entry `index` into the mesh; returns Blender's warning when it was not first."""
    stack = obj.deformkit
    common.check_index(stack, index)
    meshdata.require_mesh(obj)
    return evaluation.apply_entry(obj, index)


def evaluated_positions(obj, depsgraph=None):
    return evaluation.evaluated_positions(obj, depsgraph)


def entry_of_type(obj, index, entry_type):
    """Entry `index` of obj's stack, which must be of `entry_type`."""
    return common.entry_of_type(obj, index, entry_type)


def laplacian_entry(obj, index):
    """Entry `index` of obj's stack, which must be a Laplacian entry."""
    return entry_of_type(obj, index, "LAPLACIAN")


def lattice_entry(obj, index):
    """Entry `index` of obj's stack, which must be a Lattice entry."""
    return entry_of_type(obj, index, "LATTICE")


# Any kind with a bind (the kinds' bind protocol: entries/__init__.py) ---------------------------

def bind(obj, index):
    """Bind entry `index` as its Bind button does (Laplacian, Cage, RBF: record its rest; Lattice:
    bind again) and evaluate; returns what its kind reports (a count, or the Lattice's Bound).
    Raises ValueError, and leaves the entry as it was, if it cannot be bound."""
    stack = obj.deformkit
    common.check_index(stack, index)
    entry = stack.entries[index]
    kind = kinds.kind(entry)
    if kind.bind is None:
        raise ValueError(f"entry '{entry.name}' is a {kinds.LABELS[entry.type]} entry, which has no bind")
    meshdata.require_mesh(obj)
    result = kind.bind(obj, entry, lambda: evaluation.entry_input(obj, index))
    evaluation.evaluate(obj, evaluation.Reason.STACK)
    return result


def unbind(obj, index):
    """Forget entry `index`'s bind: it passes its input through until bound again."""
    stack = obj.deformkit
    common.check_index(stack, index)
    entry = stack.entries[index]
    kind = kinds.kind(entry)
    if kind.unbind is None:
        raise ValueError(f"entry '{entry.name}' is a {kinds.LABELS[entry.type]} entry, which has no unbind")
    kind.unbind(obj, entry)
    evaluation.evaluate(obj, evaluation.Reason.STACK)


def _checked(obj, index, entry_type):
    """`index`, once entry `index` is checked to be of entry_type (the per-kind functions' check)."""
    entry_of_type(obj, index, entry_type)
    return index


# Laplacian entries ----------------------------------------------------------------------------

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
    return bind(obj, _checked(obj, index, "LAPLACIAN"))


def unbind_laplacian(obj, index):
    """Forget entry `index`'s rest: it passes its input through until bound again."""
    unbind(obj, _checked(obj, index, "LAPLACIAN"))


# Cage entries ---------------------------------------------------------------------------------

def bind_cage(obj, index):
    """Record the cage's current evaluated shape as entry `index`'s rest, as Mesh Deform's Bind;
    returns the cage's vertex count. Raises ValueError (naming the first open edge or bad face of
    the cage, ...), and leaves the entry as it was, if it cannot be bound."""
    return bind(obj, _checked(obj, index, "CAGE"))


def unbind_cage(obj, index):
    """Forget entry `index`'s rest cage: it passes its input through until bound again."""
    unbind(obj, _checked(obj, index, "CAGE"))


# RBF entries ----------------------------------------------------------------------------------

def bind_rbf(obj, index):
    """Record entry `index`'s controls (all, the selected or a vertex group's vertices of its
    control object) and their rest positions (the control object's current evaluated shape, another
    object's or a shape key's, as Rest From says); returns the number of controls. Raises
    ValueError (no control object, another vertex count, a system dk.RBF cannot fit, ...), and
    leaves the entry as it was, if it cannot be bound."""
    return bind(obj, _checked(obj, index, "RBF"))


def unbind_rbf(obj, index):
    """Forget entry `index`'s controls and rest: it passes its input through until bound again."""
    unbind(obj, _checked(obj, index, "RBF"))


# Lattice entries (lattice_tools.py) -----------------------------------------------------------

def add_lattice(obj, resolution=(4, 4, 4), basis="BLENDER", selected_only=False, margin=1e-4):
    """Add a Lattice object fitted to the bounding box of the mesh (as the stack leaves it; with
    selected_only, of its selected vertices) in its local frame, widened by `margin` of the box's
    largest side so that no vertex lies outside by rounding, and a Lattice entry using it."""
    lattice = lattice_tools.fit_lattice(obj, resolution, basis, selected_only, margin)
    return add_entry(obj, "LATTICE", lattice=lattice, lattice_basis=str(basis).upper())


def bind_lattice(obj, index):
    """Bind the mesh to the lattice of entry `index` again (deformkit also does this by itself
    when the mesh, the frame, the resolution or the basis change); returns the vertex counts."""
    return bind(obj, _checked(obj, index, "LATTICE"))


def reset_lattice(lattice_obj):
    """Put every point of the lattice back where it rests (co_deform = co) and re-evaluate its users."""
    lattice_tools.reset_lattice(lattice_obj)


def lattice_users(lattice_obj):
    """(mesh object, entry index) of every Lattice entry that uses lattice_obj."""
    return lattice_tools.lattice_users(lattice_obj)


def manipulation_targets(obj, index, vertex_indices, mode, cursor=None, empties=()):
    """(vertex indices, targets in obj's local space) for direct manipulation (lattice_tools)."""
    return lattice_tools.manipulation_targets(obj, index, vertex_indices, mode, cursor, empties)


def direct_manipulation(obj, index, vertex_indices, targets, preserve_volume=False):
    """Move entry `index`'s lattice points so that the entry takes the vertices to `targets`
    (lattice_tools): returns the distances left and the constraints' rank; with preserve_volume,
    keeping the volume of the entry's (closed) input mesh."""
    return lattice_tools.direct_manipulation(obj, index, vertex_indices, targets, preserve_volume)


def lattice_bounds(obj, index):
    """Whether entry `index`'s lattice folds where the mesh is, and its volume change (lattice_tools)."""
    return lattice_tools.lattice_bounds(obj, index)


def folded_control_points(obj, index):
    """The lattice points of the cells where entry `index`'s lattice folds: ValueError when none (lattice_tools)."""
    return lattice_tools.folded_control_points(obj, index)


def select_folded(obj, index):
    """Select the lattice points of the cells where entry `index`'s lattice folds (lattice_tools)."""
    return lattice_tools.select_folded(obj, index)


# Smoothness (smoothness.py) ---------------------------------------------------------------------

def check_smoothness(obj, select=True, worst=10, min_angle=1e-6, samples_per_edge=8):
    """Check Smoothness of obj's cage (smoothness.check_smoothness): returns the report's figures."""
    return smoothness.check_smoothness(obj, select, worst, min_angle, samples_per_edge)


def select_flipped(obj, samples_per_edge=8):
    """Select exactly the control faces with flipped samples (smoothness.select_flipped)."""
    return smoothness.select_flipped(obj, samples_per_edge)

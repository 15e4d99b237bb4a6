"""Convert Mesh Deform to deformkit: an object's Mesh Deform modifiers taken over by Cage entries
(Harmonic, the modifier's own coordinates) at their places in the stack, with their cage,
Precision, Dynamic, vertex group and invert, their toggles, name, keys and drivers, and their bind.

Mesh Deform keeps the cage's shape at bind but does not show it; its displacement is linear in the
cage, d(c) = W (c - c_bind), so c_bind is found from the modifier's own results: the cage taken
where it is now and with its vertices moved, three at a time, on a stand-in cage object
(`bind_shape`). The entry is then bound to that shape, so a rig posed away from its bind converts
to the same result."""
import re

import bpy
import numpy as np

from . import api, entries, entry_animation, evaluation, meshdata, outputs
from .entries import cage as cages

# The modifier's properties that an entry has under the same name (keys and drivers follow them).
MAPPED = ("show_viewport", "show_render", "show_in_editmode", "show_on_cage", "precision", "use_dynamic_bind",
          "invert_vertex_group")


def mesh_deforms(obj):
    return [m for m in obj.modifiers if m.type == "MESH_DEFORM"]


def convertible(obj):
    """(modifiers that keep their place as entries, [(modifier, why it stays)]). The entries deform
    the mesh before Blender's other modifiers, so a Mesh Deform keeps its place when only Mesh
    Deforms and the "deformkit" modifier come before it."""
    ours, ok, left, blocker = outputs.our_modifier(obj), [], [], None
    for mod in obj.modifiers:
        if blocker is None and (mod.type == "MESH_DEFORM" or mod == ours):
            if mod != ours:
                ok.append(mod)
            continue
        blocker = blocker or mod
        if mod.type == "MESH_DEFORM":
            left.append((mod, f"it comes after '{blocker.name}', and deformkit's entries deform the mesh before "
                              "Blender's other modifiers: move it first to convert it"))
    return ok, left


def _split(obj, mods):
    """(those above the "deformkit" modifier, those below it) of the convertible modifiers."""
    ours = outputs.our_modifier(obj)
    if ours is None:  # it comes first when made: they all go above the entries
        return list(mods), []
    names = [m.name for m in obj.modifiers]
    at = names.index(ours.name)
    return [m for m in mods if names.index(m.name) < at], [m for m in mods if names.index(m.name) > at]


def convert(obj):
    """Replace obj's Mesh Deform modifiers by Cage entries (ValueError if none can be). Returns
    the report's lines: what was converted, bound or not, and what stayed or was dropped."""
    meshdata.require_mesh(obj)
    if obj.mode == "EDIT":
        raise ValueError("convert: leave Edit Mode first (Edit Mode holds its own copy of the mesh)")
    found = mesh_deforms(obj)
    if not found:
        raise ValueError(f"'{obj.name}' has no Mesh Deform modifier to convert")
    mods, left = convertible(obj)
    above, below = _split(obj, mods)
    if below and any(entries.kind(e).LAST for e in obj.deformkit.entries):
        left += [(m, "it deforms the subdivided mesh, and a Subdivide entry must stay last") for m in below]
        below = []
    if not above and not below:
        raise ValueError("; ".join(f"Mesh Deform '{m.name}' stays: {why}" for m, why in left))
    # By name: adding and removing modifiers leaves their Python objects pointing at freed data.
    left, above, below = [(m.name, why) for m, why in left], [m.name for m in above], [m.name for m in below]
    lines = []
    for name in reversed(above):  # each goes first: in the end they are in their order
        lines.append(_take_over(obj, name, first=True))
    for name in below:
        lines.append(_take_over(obj, name, first=False))
    return lines + [f"Mesh Deform '{name}' stays: {why}" for name, why in left]


def _take_over(obj, name, first):
    """One modifier into an entry: settings, place, keys and drivers, bind; the modifier goes."""
    mod = obj.modifiers[name]
    rest = bind_shape(obj, mod) if mod.is_bound and mod.object is not None else None
    settings = dict(cage_method="HARMONIC", precision=mod.precision, use_dynamic_bind=mod.use_dynamic_bind,
                    vertex_group=mod.vertex_group, invert_vertex_group=mod.invert_vertex_group)
    if mod.object is not None:
        settings["cage"] = mod.object
    toggles = {p: getattr(mod, p) for p in ("show_viewport", "show_render", "show_in_editmode", "show_on_cage")}
    entry = api.add_entry(obj, "CAGE", **settings)
    index = api.move_entry_to(obj, obj.deformkit.active_index, "FIRST") if first else obj.deformkit.active_index
    entry = obj.deformkit.entries[index]
    if name not in {e.name for e in obj.deformkit.entries}:  # else the name add_entry gave it (Cage.001)
        entry.name = name
    dropped = _move_animation(obj, name, index)
    obj.modifiers.remove(obj.modifiers[name])
    for prop, value in toggles.items():
        setattr(entry, prop, value)
    line = f"Mesh Deform '{name}' is the Cage entry '{entry.name}'"
    if rest is not None:
        try:
            cages.bind(obj, entry, lambda: evaluation.entry_input(obj, index), rest=rest)
            line += ", bound"
        except ValueError as exc:
            line += f", unbound ({exc}): Bind it"
    else:
        line += ", unbound (the modifier was not bound" + (")" if "cage" in settings else " and had no cage)")
        line += ": Bind it"
    evaluation.evaluate(obj, evaluation.Reason.STACK)
    if dropped:
        line += f"; its keys or drivers on {', '.join(dropped)} were dropped (the entry has no such setting)"
    return line


def _move_animation(obj, name, index):
    """The modifier's F-curves and drivers, and driver variables reading it, onto entry `index`
    where a property maps (MAPPED); the others are removed. Returns the unmapped properties."""
    path = re.compile(r'^modifiers\["' + re.escape(name.replace('"', '\\"')) + r'"\]\.(\w+)$')
    dropped = []
    lists = entry_animation.animation_lists(obj)
    if any(path.match(f.data_path) for fcurves in lists for f in fcurves):
        entry_animation.own_actions(obj, None, adding=True)  # another object's keys stay on its modifier
        lists = entry_animation.animation_lists(obj)
    for fcurves in lists:
        for fcurve in list(fcurves):
            found = path.match(fcurve.data_path)
            if found is None:
                continue
            if found.group(1) in MAPPED:
                fcurve.data_path = f"deformkit.entries[{index}].{found.group(1)}"
            else:
                dropped.append(found.group(1))
                fcurves.remove(fcurve)
    for target in entry_animation.targets_reading(obj):
        found = path.match(target.data_path or "")
        if found is not None and found.group(1) in MAPPED:
            target.data_path = f"deformkit.entries[{index}].{found.group(1)}"
    return sorted(set(dropped))


# The cage at bind ---------------------------------------------------------------------------

def _isolated(obj, mod):
    """obj's evaluated points with only `mod` of Blender's modifiers shown (None: none), the
    "deformkit" modifier as it is (its offsets cancel in the differences taken)."""
    ours = outputs.our_modifier(obj)
    shown = {m.name: m.show_viewport for m in obj.modifiers}
    try:
        for m in obj.modifiers:
            if m != ours:
                m.show_viewport = m == mod
        evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
        mesh = evaluated.to_mesh()
        try:
            return meshdata.base_positions(mesh).astype(np.float64)
        finally:
            evaluated.to_mesh_clear()
    finally:
        for m in obj.modifiers:
            m.show_viewport = shown[m.name]


def bind_shape(obj, mod):
    """The cage's shape (obj's space) when `mod` was bound, from the modifier's results: with the
    cage at c (a stand-in object of the cage's topology, placed as the cage is) it moves the mesh by
    W (c - c_bind); W's columns are read by moving the stand-in's vertices, and c_bind solves
    W c_bind = W c - d(c) in least squares. Cage vertices that move no vertex keep their place now."""
    cage = mod.object
    dg = bpy.context.evaluated_depsgraph_get()
    probe_mesh = bpy.data.meshes.new_from_object(cage.evaluated_get(dg))
    probe = bpy.data.objects.new("deformkit probe", probe_mesh)
    bpy.context.scene.collection.objects.link(probe)
    probe.matrix_world = cage.matrix_world
    try:
        mod.object = probe
        local = meshdata.base_positions(probe_mesh).astype(np.float64)
        to_obj = np.array(obj.matrix_world.inverted() @ cage.matrix_world)
        step = float(np.linalg.norm(np.ptp(local, axis=0))) or 1.0

        def moved_by(co):
            probe_mesh.vertices.foreach_set("co", co.astype(np.float32).ravel())
            probe_mesh.update()
            return _isolated(obj, mod)

        start = _isolated(obj, None)
        now = moved_by(local)
        m = len(local)
        weights = np.zeros((len(now), m))
        for first in range(0, m, 3):
            picked = list(range(first, min(first + 3, m)))
            co = local.copy()
            for axis, j in enumerate(picked):
                co[j, axis] += step
            moves = (moved_by(co) - now)
            dirs = np.array([to_obj[:3, axis] * step for axis in range(len(picked))])  # (k, 3) in obj's space
            weights[:, picked] = moves @ np.linalg.pinv(dirs)
    finally:
        mod.object = cage
        bpy.data.objects.remove(probe)
        bpy.data.meshes.remove(probe_mesh)
    current = local @ to_obj[:3, :3].T + to_obj[:3, 3]
    used = np.abs(weights).max(0) > 1e-6
    rows = np.abs(weights).sum(1) > 1e-6
    shape = current.copy()
    if used.any() and rows.any():
        w = weights[np.ix_(rows, used)]
        rhs = w @ current[used] - (now - start)[rows]
        shape[used] = np.linalg.lstsq(w, rhs, rcond=None)[0]
    return shape

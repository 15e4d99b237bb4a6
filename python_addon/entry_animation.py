"""Keys and drivers follow their entry. They are stored on index paths (`deformkit.entries[2].angle`,
the paths Blender makes for an add-on's collection), so every change of entry positions rewrites
them, as Blender rewrites `modifiers["Name"]` paths when a modifier is renamed: the object's action
(its slot's F-curves in Blender 4.4+), its NLA strips' actions, its drivers, and the driver variables
of any ID that read one of its entries. A removed entry's F-curves and drivers go with it; a copy
gets copies of them. All of it is the ID's data, so undo restores it with the stack."""
import re

import bpy

ENTRY_PATH = re.compile(r"^deformkit\.entries\[(\d+)\](.*)$")
# Where a driver variable that read a removed entry points: a path that resolves to nothing, so the
# driver shows as invalid (as one reading a deleted modifier does) and names what it read.
REMOVED_PATH = 'deformkit.removed_entries["{name}"]{rest}'


def entry_path(path):
    """(entry index, rest of the path) of a data path into an entry, else None."""
    found = ENTRY_PATH.match(path or "")
    return (int(found.group(1)), found.group(2)) if found else None


# Where F-curves live: one helper for Blender 3.4 (action.fcurves) and 4.4+ (layered actions) ------

def action_fcurves(action, slot, create=False):
    """The F-curves of `action` that animate through `slot` (Blender 4.4+: the channelbag of that
    slot in the action's keyframe strip; before: the action's one list), or None. With create, the
    layer, strip and channelbag are made when missing."""
    if action is None:
        return None
    if not hasattr(action, "layers"):  # Blender < 4.4: an action animates one ID through one list
        return action.fcurves
    if slot is None:
        return None
    if create and len(action.layers) == 0:
        action.layers.new("Layer").strips.new(type="KEYFRAME")
    for layer in action.layers:
        for strip in layer.strips:
            if strip.type == "KEYFRAME":
                bag = strip.channelbag(slot, ensure=create)
                if bag is not None:
                    return bag.fcurves
    return None


def _slot(holder):
    return getattr(holder, "action_slot", None)  # None before Blender 4.4, where there are no slots


def own_fcurves(id):
    """The F-curves of id's action, the action (and in Blender 4.4+ its slot for id) made if missing."""
    anim = id.animation_data_create()
    if anim.action is None:
        anim.action = bpy.data.actions.new(f"{id.name}Action")
    if hasattr(anim, "action_slot") and anim.action_slot is None:
        anim.action_slot = anim.action.slots.new(id_type=id.id_type, name=id.name)
    return action_fcurves(anim.action, _slot(anim), create=True)


def animation_lists(id):
    """Every F-curve list that animates `id`: its action's (through its slot), each NLA strip's
    action's, and its drivers; each list once."""
    anim = getattr(id, "animation_data", None)
    return [] if anim is None else action_lists(anim) + [anim.drivers]


def action_lists(anim):
    """The F-curve lists of the action and of each NLA strip's action of AnimData `anim`, each once."""
    lists, seen = [], set()

    def add(action, slot):
        key = (action.as_pointer(), getattr(slot, "handle", None)) if action is not None else None
        fcurves = action_fcurves(action, slot)
        if fcurves is not None and key not in seen:
            seen.add(key)
            lists.append(fcurves)

    for holder in _holders(anim):
        add(holder.action, _slot(holder))
    return lists


def _holders(anim):
    """What plays an action for AnimData `anim`: itself and each of its NLA strips."""
    yield anim
    for track in anim.nla_tracks:
        yield from _strips(track.strips)


def _strips(strips):
    for strip in strips:
        yield strip
        yield from _strips(strip.strips)  # meta strips hold strips


def _all_ids():
    """Every ID of the file, with the node trees embedded in materials, worlds, scenes, lights."""
    for prop in bpy.data.bl_rna.properties:
        if prop.type != "COLLECTION":
            continue
        for item in getattr(bpy.data, prop.identifier):
            if isinstance(item, bpy.types.ID):
                yield item
                tree = getattr(item, "node_tree", None)
                if isinstance(tree, bpy.types.NodeTree) and tree.is_embedded_data:
                    yield tree


def targets_reading(obj):
    """Every driver variable target of any local ID (linked data cannot be edited) that reads obj."""
    for id in _all_ids():
        anim = getattr(id, "animation_data", None)
        if anim is None or id.library is not None:
            continue
        for fcurve in anim.drivers:
            for var in fcurve.driver.variables:
                yield from (target for target in var.targets if target.id == obj)


def _reading_targets(obj):
    """(target, entry index, rest) of every driver variable target that reads obj's entries."""
    for target in targets_reading(obj):
        found = entry_path(target.data_path)
        if found is not None:
            yield (target, *found)


def own_actions(obj, touched, adding=False):
    """Copy each action obj plays that another ID plays too, or that is linked from a library (and
    cannot be edited), before obj's keys on an entry i with touched(i) are rewritten or copied in it
    (with adding: before any keys are added to it), as Make Single User / Make Local: the other
    ID's entries keep their keys. Blender rewrites a shared action for every user on a modifier
    rename, but there both users' modifiers are renamed alike; another object's stack does not
    move with obj's."""
    anim = obj.animation_data
    if anim is None:
        return
    copies = {}
    for holder in list(_holders(anim)):
        action = holder.action
        if action is None:
            continue
        if action.as_pointer() not in copies:
            fcurves = action_fcurves(action, _slot(holder)) or []
            paths = (entry_path(f.data_path) for f in fcurves)
            users = bpy.data.user_map(subset=[action]).get(action, set())
            shared = action.library is not None or any(u != obj for u in users)
            shared = shared and (adding or any(p is not None and touched(p[0]) for p in paths))
            copies[action.as_pointer()] = action.copy() if shared else None
        copy = copies[action.as_pointer()]
        if copy is not None:
            slot = _slot(holder)
            identifier = slot.identifier if slot is not None else None
            holder.action = copy
            if identifier is not None:
                holder.action_slot = next(s for s in copy.slots if s.identifier == identifier)


# Changes of positions -------------------------------------------------------------------------

def reindex(obj, new_index, removed_names=None):
    """Rewrite every path into obj's entries from entry i to entry new_index(i); where that is None
    (the entry is removed), its F-curves and drivers go and variables reading it point at nothing."""
    own_actions(obj, lambda i: new_index(i) != i)
    for fcurves in animation_lists(obj):
        gone = []
        for fcurve in fcurves:
            found = entry_path(fcurve.data_path)
            if found is None:
                continue
            index, rest = found
            new = new_index(index)
            if new is None:
                gone.append(fcurve)
            elif new != index:
                fcurve.data_path = f"deformkit.entries[{new}]{rest}"
        for fcurve in gone:
            fcurves.remove(fcurve)
    for target, index, rest in list(_reading_targets(obj)):
        new = new_index(index)
        if new is None:
            name = (removed_names or {}).get(index, str(index)).replace('"', "'")
            target.data_path = REMOVED_PATH.format(name=name, rest=rest)
        elif new != index:
            target.data_path = f"deformkit.entries[{new}]{rest}"


def moved(obj, old, new):
    """Entry `old` went to `new` (CollectionProperty.move): the entries between shift by one."""
    def new_index(i):
        if i == old:
            return new
        if old < i <= new:
            return i - 1
        if new <= i < old:
            return i + 1
        return i
    if old != new:
        reindex(obj, new_index)


def inserted(obj, at):
    """A new entry (no animation yet) took place `at`: the entries from there shift down by one."""
    reindex(obj, lambda i: i + 1 if i >= at else i)


def removed(obj, index):
    """Entry `index` is about to be removed: its F-curves and drivers go, later entries shift up."""
    names = {index: obj.deformkit.entries[index].name}
    reindex(obj, lambda i: None if i == index else (i - 1 if i > index else i), names)


def cleared(obj):
    """Every entry is about to be removed (a recipe's replace): their F-curves and drivers go."""
    names = {i: entry.name for i, entry in enumerate(obj.deformkit.entries)}
    reindex(obj, lambda i: None, names)


# Copies -----------------------------------------------------------------------------------------

def _copy_fcurve(fcurves, source, data_path):
    """A copy of F-curve `source` in the list `fcurves` (an action's), on data_path."""
    if hasattr(fcurves, "new_from_fcurve"):  # Blender 4.4+: an exact copy
        return fcurves.new_from_fcurve(source, data_path=data_path)
    group = source.group.name if source.group is not None else ""
    copy = fcurves.new(data_path, index=source.array_index, action_group=group)
    points = source.keyframe_points
    copy.keyframe_points.add(len(points))
    for attr in ("co", "handle_left", "handle_right"):
        values = [0.0] * (2 * len(points))
        points.foreach_get(attr, values)
        copy.keyframe_points.foreach_set(attr, values)
    for attr in ("interpolation", "handle_left_type", "handle_right_type", "easing", "back", "amplitude",
                 "period", "type"):
        for point, theirs in zip(copy.keyframe_points, points):
            setattr(point, attr, getattr(theirs, attr))
    for attr in ("extrapolation", "mute", "lock", "hide", "color_mode", "color", "auto_smoothing"):
        setattr(copy, attr, getattr(source, attr))
    for modifier in source.modifiers:
        theirs = copy.modifiers.new(modifier.type)
        for prop in modifier.bl_rna.properties:
            if not prop.is_readonly and prop.type != "POINTER" and prop.identifier not in ("active",):
                setattr(theirs, prop.identifier, getattr(modifier, prop.identifier))
    copy.update()
    return copy


def _entry_curves(fcurves, index):
    return [(fcurve, found[1]) for fcurve in list(fcurves)
            if (found := entry_path(fcurve.data_path)) is not None and found[0] == index]


def copy_animation(source_obj, index, target_obj, target_index):
    """Copies of the F-curves and drivers of source_obj's entry `index` onto target_obj's entry
    target_index (the same object for a Duplicate): in the same lists for a Duplicate (the action,
    each NLA strip's action, the drivers); on another object, in its action (made if it has none)
    and its drivers."""
    path = f"deformkit.entries[{target_index}]"
    anim = source_obj.animation_data
    if anim is None:
        return
    if source_obj == target_obj:
        own_actions(source_obj, lambda i: i == index)
        for fcurves in action_lists(anim):
            for fcurve, rest in _entry_curves(fcurves, index):
                _copy_fcurve(fcurves, fcurve, path + rest)
        for fcurve, rest in _entry_curves(anim.drivers, index):
            anim.drivers.from_existing(src_driver=fcurve).data_path = path + rest
        return
    keyed = _entry_curves(action_fcurves(anim.action, _slot(anim)) or [], index)
    driven = _entry_curves(anim.drivers, index)
    if not keyed and not driven:
        return
    theirs = target_obj.animation_data_create()
    if keyed:
        own_actions(target_obj, None, adding=True)
        fcurves = own_fcurves(target_obj)
        for fcurve, rest in keyed:
            _copy_fcurve(fcurves, fcurve, path + rest)
    for fcurve, rest in driven:
        theirs.drivers.from_existing(src_driver=fcurve).data_path = path + rest

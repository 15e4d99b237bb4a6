"""Keys and drivers follow their entry (entry_animation.py): after every change of entry positions
(move up, down, first, last; remove; duplicate; copy to selected; apply; add above a Subdivide
entry) each F-curve and driver drives the entry it drove before, scrubbing gives each entry its own
keyed value, a removed entry's animation goes with it, and undo brings the paths back.

The truth is each entry's own animation, written down before the change: Twist's angle keyed
linearly 0 -> 1.5 over frames 1..10, Bend's 0.4 -> -0.6, Taper's factor driven by `frame / 40`, and
an Empty elsewhere whose x is driven by the Twist's angle."""
import re

import pytest

from addon_helpers import make_object

FRAMES = (1, 4, 10)
ENTRY = re.compile(r"^deformkit\.entries\[(\d+)\]\.(\w+)$")


def twist(frame):
    return 1.5 * (frame - 1) / 9


def bend(frame):
    return 0.4 - 1.0 * (frame - 1) / 9


def taper(frame):
    return frame / 40


EXPECTED = {"Twist": ("angle", twist), "Bend": ("angle", bend), "Taper": ("factor", taper)}


def key_linear(obj, path, values):
    for frame, value in values:
        obj.path_resolve(path.rpartition(".")[0]).__setattr__(path.rpartition(".")[2], value)
        obj.keyframe_insert(path, frame=frame)
    for fcurve in fcurves_of(obj):
        for point in fcurve.keyframe_points:
            point.interpolation = "LINEAR"


def fcurves_of(obj, anim=None):
    """The F-curves animating obj through its action (or an NLA strip's), in Blender 3.4 and 5.0."""
    anim = anim or obj.animation_data
    if not hasattr(anim.action, "layers"):
        return list(anim.action.fcurves)  # Blender 3.4: one list per action
    bags = [s.channelbag(anim.action_slot) for layer in anim.action.layers for s in layer.strips]
    return [f for bag in bags if bag is not None for f in bag.fcurves]


def driven(obj, fcurves, kind):
    """{(entry name, property, kind)} of the F-curves on obj's entries; an F-curve on no entry is
    named '<none>'."""
    names = [e.name for e in obj.deformkit.entries]
    found = set()
    for fcurve in fcurves:
        m = ENTRY.match(fcurve.data_path)
        if m:
            index = int(m.group(1))
            found.add((names[index] if index < len(names) else "<none>", m.group(2), kind))
    return found


def animation(obj):
    keyed = driven(obj, fcurves_of(obj), "key") if obj.animation_data.action else set()
    return keyed | driven(obj, obj.animation_data.drivers, "driver")


def read_entry(bpy, reader_name="Reader"):
    """The entry name (and property) the Empty's driver variable reads, or None if it reads none."""
    var = bpy.data.objects[reader_name].animation_data.drivers[0].driver.variables[0]
    obj = var.targets[0].id
    m = ENTRY.match(var.targets[0].data_path)
    if not m or int(m.group(1)) >= len(obj.deformkit.entries):
        return None
    return obj.deformkit.entries[int(m.group(1))].name, m.group(2)


@pytest.fixture
def rig(scene):
    """Obj with Twist (keyed), Bend (keyed), Taper (driven), and an Empty reading the Twist's angle."""
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    api.add_entry(obj, "TWIST", deform_axis="Z")
    api.add_entry(obj, "BEND", deform_axis="Z")
    api.add_entry(obj, "TAPER", deform_axis="Z")
    key_linear(obj, "deformkit.entries[0].angle", [(1, twist(1)), (10, twist(10))])
    key_linear(obj, "deformkit.entries[1].angle", [(1, bend(1)), (10, bend(10))])
    fcurve = obj.driver_add("deformkit.entries[2].factor")
    fcurve.driver.type = "SCRIPTED"
    fcurve.driver.expression = "frame / 40"
    reader = bpy.data.objects.new("Reader", None)
    scene.collection.objects.link(reader)
    fcurve = reader.driver_add("location", 0)
    fcurve.driver.type = "SCRIPTED"
    var = fcurve.driver.variables.new()
    var.name = "angle"
    var.targets[0].id = obj
    var.targets[0].data_path = "deformkit.entries[0].angle"
    fcurve.driver.expression = "angle"
    bpy.context.view_layer.objects.active = obj
    bpy.context.view_layer.update()
    assert animation(obj) == BEFORE
    check_scrubbing(bpy, obj)
    return obj


BEFORE = {("Twist", "angle", "key"), ("Bend", "angle", "key"), ("Taper", "factor", "driver")}


def check_scrubbing(bpy, obj, expected=EXPECTED, reader=True):
    """Each entry gets its own animated value at each frame; the Empty gets the Twist's angle."""
    for frame in FRAMES:
        bpy.context.scene.frame_set(frame)
        for entry in obj.deformkit.entries:
            if entry.name in expected:
                prop, value = expected[entry.name]
                assert getattr(entry, prop) == pytest.approx(value(frame), abs=1e-6), (entry.name, frame)
        if reader:
            assert bpy.data.objects["Reader"].location.x == pytest.approx(twist(frame), abs=1e-6), frame


def undone(bpy):
    bpy.ops.ed.undo()
    obj = bpy.data.objects["Obj"]  # undo rebuilds the data: look the object up again
    bpy.context.view_layer.update()
    return obj


@pytest.mark.parametrize("move, order", [
    (("move_entry", 1, -1), ["Bend", "Twist", "Taper"]),
    (("move_entry", 0, 1), ["Bend", "Twist", "Taper"]),
    (("move_entry_to", 2, "FIRST"), ["Taper", "Twist", "Bend"]),
    (("move_entry_to", 0, "LAST"), ["Bend", "Taper", "Twist"]),
])
def test_moves_carry_keys_and_drivers(bpy_module, rig, move, order):
    bpy = bpy_module
    from deformkit_addon import api
    obj = rig
    bpy.ops.ed.undo_push(message="keyed")
    name, index, where = move
    getattr(api, name)(obj, index, where)
    bpy.ops.ed.undo_push(message="moved")
    assert [e.name for e in obj.deformkit.entries] == order
    assert animation(obj) == BEFORE
    assert read_entry(bpy) == ("Twist", "angle")
    check_scrubbing(bpy, obj)
    obj = undone(bpy)
    assert [e.name for e in obj.deformkit.entries] == ["Twist", "Bend", "Taper"]
    assert sorted(f.data_path for f in fcurves_of(obj)) == ["deformkit.entries[0].angle", "deformkit.entries[1].angle"]
    assert [f.data_path for f in obj.animation_data.drivers] == ["deformkit.entries[2].factor"]
    check_scrubbing(bpy, obj)


def test_remove_takes_its_keys_and_drivers(bpy_module, rig):
    bpy = bpy_module
    from deformkit_addon import api
    obj = rig
    bpy.ops.ed.undo_push(message="keyed")
    api.remove_entry(obj, 0)
    bpy.ops.ed.undo_push(message="removed twist")
    assert animation(obj) == {("Bend", "angle", "key"), ("Taper", "factor", "driver")}
    assert read_entry(bpy) is None  # as a driver reading a deleted modifier: it reads nothing
    check_scrubbing(bpy, obj, reader=False)
    assert not bpy.data.objects["Reader"].animation_data.drivers[0].driver.is_valid
    api.remove_entry(obj, 1)  # the driven Taper
    assert animation(obj) == {("Bend", "angle", "key")}
    api.add_entry(obj, "TWIST", angle=0.7)  # takes the index the removed entries had: not animated
    api.add_entry(obj, "TAPER", factor=-0.2)
    check_scrubbing(bpy, obj, {"Bend": EXPECTED["Bend"], "Twist": ("angle", lambda f: 0.7),
                               "Taper": ("factor", lambda f: -0.2)}, reader=False)
    bpy.ops.ed.undo_push(message="added")
    undone(bpy)
    obj = undone(bpy)
    assert [e.name for e in obj.deformkit.entries] == ["Twist", "Bend", "Taper"]
    assert animation(obj) == BEFORE
    assert read_entry(bpy) == ("Twist", "angle")
    check_scrubbing(bpy, obj)


def test_duplicate_copies_keys_and_drivers(bpy_module, rig):
    bpy = bpy_module
    from deformkit_addon import api
    obj = rig
    bpy.ops.ed.undo_push(message="keyed")
    api.duplicate_entry(obj, 0)
    api.duplicate_entry(obj, 3)  # the Taper, now fourth
    bpy.ops.ed.undo_push(message="duplicated")
    assert [e.name for e in obj.deformkit.entries] == ["Twist", "Twist.001", "Bend", "Taper", "Taper.001"]
    assert animation(obj) == BEFORE | {("Twist.001", "angle", "key"), ("Taper.001", "factor", "driver")}
    assert read_entry(bpy) == ("Twist", "angle")
    check_scrubbing(bpy, obj, {**EXPECTED, "Twist.001": EXPECTED["Twist"], "Taper.001": EXPECTED["Taper"]})
    # The copies are the copy's own: editing one leaves the other as it was.
    copy = next(f for f in fcurves_of(obj) if f.data_path == "deformkit.entries[1].angle")
    copy.keyframe_points[1].co.y = 3.0
    copy.update()
    check_scrubbing(bpy, obj)
    bpy.context.scene.frame_set(10)
    assert obj.deformkit.entries[1].angle == pytest.approx(3.0)
    obj = undone(bpy)
    assert [e.name for e in obj.deformkit.entries] == ["Twist", "Bend", "Taper"]
    assert animation(obj) == BEFORE
    assert len(fcurves_of(obj)) == 2 and len(obj.animation_data.drivers) == 1


def test_copy_to_selected_copies_keys_and_drivers(bpy_module, rig):
    """The target's own keyed Subdivide entry stays keyed as the copies go in above it; the target
    had no action: one is made."""
    bpy = bpy_module
    from deformkit_addon import api
    obj = rig
    other = make_object(bpy, "Other", location=(3, 0, 0))
    api.add_entry(other, "SUBDIVIDE", levels=1, render_levels=1)
    other.driver_add("deformkit.entries[0].render_levels").driver.expression = "1 + (frame > 5)"
    assert other.animation_data.action is None
    bpy.context.view_layer.objects.active = obj
    bpy.ops.ed.undo_push(message="keyed")
    api.copy_entry_to(obj, 0, [other])
    api.copy_entry_to(obj, 2, [other])
    api.add_entry(other, "STRETCH", factor=0.1)  # the batch and the Add menu: above the Subdivide entry too
    bpy.ops.ed.undo_push(message="copied")
    assert [e.name for e in other.deformkit.entries] == ["Twist", "Taper", "Stretch", "Subdivide"]
    assert animation(other) == {("Twist", "angle", "key"), ("Taper", "factor", "driver"),
                                ("Subdivide", "render_levels", "driver")}
    assert animation(obj) == BEFORE
    check_scrubbing(bpy, other, reader=False)
    check_scrubbing(bpy, obj)
    for frame in FRAMES:
        bpy.context.scene.frame_set(frame)
        assert other.deformkit.entries[3].render_levels == 1 + (frame > 5)
    undone(bpy)
    other = bpy.data.objects["Other"]
    assert [e.name for e in other.deformkit.entries] == ["Subdivide"]
    assert animation(other) == {("Subdivide", "render_levels", "driver")}


def test_apply_takes_its_keys_and_shifts_the_rest(bpy_module, rig):
    bpy = bpy_module
    from deformkit_addon import api
    obj = rig
    bpy.context.scene.frame_set(4)
    bpy.ops.ed.undo_push(message="keyed")
    api.apply(obj, 0)
    bpy.ops.ed.undo_push(message="applied")
    assert [e.name for e in obj.deformkit.entries] == ["Bend", "Taper"]
    assert animation(obj) == {("Bend", "angle", "key"), ("Taper", "factor", "driver")}
    assert read_entry(bpy) is None
    check_scrubbing(bpy, obj, reader=False)
    obj = undone(bpy)
    assert animation(obj) == BEFORE
    assert read_entry(bpy) == ("Twist", "angle")
    check_scrubbing(bpy, obj)


def test_nla_strip_actions_follow(bpy_module, rig):
    """The keys pushed down into an NLA strip's action follow a move, go with a removed entry and
    are copied with a duplicated one."""
    bpy = bpy_module
    from deformkit_addon import api
    obj = rig
    anim = obj.animation_data
    action = anim.action
    track = anim.nla_tracks.new()
    strip = track.strips.new("Keys", 1, action)
    anim.action = None
    assert {f.data_path for f in fcurves_of(obj, strip)} == {"deformkit.entries[0].angle", "deformkit.entries[1].angle"}
    check_scrubbing(bpy, obj)
    api.move_entry_to(obj, 0, "LAST")
    assert [e.name for e in obj.deformkit.entries] == ["Bend", "Taper", "Twist"]
    assert driven(obj, fcurves_of(obj, strip), "key") == {("Twist", "angle", "key"), ("Bend", "angle", "key")}
    check_scrubbing(bpy, obj)
    api.remove_entry(obj, 0)
    assert driven(obj, fcurves_of(obj, strip), "key") == {("Twist", "angle", "key")}
    check_scrubbing(bpy, obj, {"Twist": EXPECTED["Twist"], "Taper": EXPECTED["Taper"]})
    api.duplicate_entry(obj, 1)
    assert [e.name for e in obj.deformkit.entries] == ["Taper", "Twist", "Twist.001"]
    assert driven(obj, fcurves_of(obj, strip), "key") == {("Twist", "angle", "key"), ("Twist.001", "angle", "key")}
    check_scrubbing(bpy, obj, {"Twist": EXPECTED["Twist"], "Twist.001": EXPECTED["Twist"], "Taper": EXPECTED["Taper"]})


def test_the_operators_carry_keys_and_undo_brings_them_back(bpy_module, rig):
    """The panel's Move and Remove operators as the api (headless, their undo steps are pushed here)."""
    bpy = bpy_module
    obj = rig
    bpy.ops.ed.undo_push(message="keyed")
    assert bpy.ops.deformkit.entry_move(index=0, direction="LAST") == {"FINISHED"}
    bpy.ops.ed.undo_push(message="moved")
    assert [e.name for e in obj.deformkit.entries] == ["Bend", "Taper", "Twist"]
    assert animation(obj) == BEFORE
    check_scrubbing(bpy, obj)
    assert bpy.ops.deformkit.entry_remove(index=2) == {"FINISHED"}
    bpy.ops.ed.undo_push(message="removed")
    assert animation(obj) == {("Bend", "angle", "key"), ("Taper", "factor", "driver")}
    obj = undone(bpy)
    assert [e.name for e in obj.deformkit.entries] == ["Bend", "Taper", "Twist"]
    assert animation(obj) == BEFORE
    check_scrubbing(bpy, obj)
    obj = undone(bpy)
    assert [e.name for e in obj.deformkit.entries] == ["Twist", "Bend", "Taper"]
    assert animation(obj) == BEFORE
    check_scrubbing(bpy, obj)


def test_a_recipe_that_replaces_the_stack_takes_the_old_keys(bpy_module, rig):
    """A batch recipe with replace: the new entries at the old ones' places are not animated by
    the old entries' keys and drivers; an Empty that read the old Twist reads nothing."""
    bpy = bpy_module
    from deformkit_addon import batch
    obj = rig
    batch.apply_recipe({"objects": ["Obj"], "replace": True,
                        "deformers": [{"type": "BEND", "angle": 0.2}, {"type": "TWIST", "angle": 0.3},
                                      {"type": "TAPER", "factor": 0.4}]})
    assert animation(obj) == set()
    assert read_entry(bpy) is None
    check_scrubbing(bpy, obj, {"Bend": ("angle", lambda f: 0.2), "Twist": ("angle", lambda f: 0.3),
                               "Taper": ("factor", lambda f: 0.4)}, reader=False)


def test_an_action_shared_with_a_twin_keeps_the_twin_keyed(bpy_module, rig):
    """A twin playing the same action (a linked duplicate) keeps its keys on its own entries when
    obj's stack changes: obj gets its own copy of the action, as Make Single User."""
    bpy = bpy_module
    from deformkit_addon import api
    obj = rig
    twin = obj.copy()
    twin.name = "Twin"
    twin.animation_data.action = obj.animation_data.action
    bpy.context.scene.collection.objects.link(twin)
    shared = obj.animation_data.action
    api.move_entry_to(obj, 0, "LAST")
    api.duplicate_entry(obj, 2)
    assert [e.name for e in obj.deformkit.entries] == ["Bend", "Taper", "Twist", "Twist.001"]
    assert driven(twin, fcurves_of(twin), "key") == {("Twist", "angle", "key"), ("Bend", "angle", "key")}
    assert animation(obj) == BEFORE | {("Twist.001", "angle", "key")}
    assert twin.animation_data.action == shared and obj.animation_data.action != shared
    check_scrubbing(bpy, obj)
    check_scrubbing(bpy, twin, {"Twist": EXPECTED["Twist"], "Bend": EXPECTED["Bend"]})


def test_copy_to_a_keyed_target_whose_action_a_twin_plays(bpy_module, rig):
    """Copy to Selected onto a target with its own keys, in an action a twin of it plays too: the
    target's keys stay on its entry, the copy's go beside them, and the twin's action is unchanged."""
    bpy = bpy_module
    from deformkit_addon import api
    obj = rig
    other = make_object(bpy, "Other", location=(3, 0, 0))
    api.add_entry(other, "BEND", deform_axis="Z")
    key_linear(other, "deformkit.entries[0].angle", [(1, bend(1)), (10, bend(10))])
    twin = other.copy()
    twin.name = "OtherTwin"
    twin.animation_data.action = other.animation_data.action
    bpy.context.scene.collection.objects.link(twin)
    api.copy_entry_to(obj, 0, [other])
    assert [e.name for e in other.deformkit.entries] == ["Bend", "Twist"]
    assert animation(other) == {("Bend", "angle", "key"), ("Twist", "angle", "key")}
    assert [f.data_path for f in fcurves_of(twin)] == ["deformkit.entries[0].angle"]
    check_scrubbing(bpy, other, reader=False)
    check_scrubbing(bpy, twin, {"Bend": EXPECTED["Bend"]}, reader=False)


def test_a_linked_action_is_made_local_before_its_keys_move(bpy_module, rig, tmp_path):
    """Keys in an action linked from another file cannot be rewritten there: obj gets a local copy
    whose keys follow the move (the library's action is left as it is)."""
    bpy = bpy_module
    from deformkit_addon import api
    obj = rig
    library = tmp_path / "actions.blend"
    bpy.data.libraries.write(str(library), {obj.animation_data.action})
    with bpy.data.libraries.load(str(library), link=True) as (theirs, ours):
        ours.actions = list(theirs.actions)
    linked = ours.actions[0]
    assert linked.library is not None
    slot = getattr(obj.animation_data, "action_slot", None)
    identifier = slot.identifier if slot is not None else None
    obj.animation_data.action = linked
    if identifier is not None:
        obj.animation_data.action_slot = next(s for s in linked.slots if s.identifier == identifier)
    check_scrubbing(bpy, obj)
    api.move_entry_to(obj, 0, "LAST")
    assert obj.animation_data.action.library is None
    assert animation(obj) == BEFORE
    check_scrubbing(bpy, obj)
    anim = obj.animation_data
    anim.action = linked
    assert sorted(f.data_path for f in fcurves_of(obj)) == ["deformkit.entries[0].angle", "deformkit.entries[1].angle"]


def test_applying_the_helper_modifier_takes_the_entries_keys(bpy_module, rig):
    """Ctrl+A on the "deformkit" modifier bakes the result and removes the entries: their keys and
    drivers go too, so an entry added afterwards is not animated by them."""
    bpy = bpy_module
    from deformkit_addon import api
    obj = rig
    for o in bpy.context.view_layer.objects:
        o.select_set(o == obj)
    with bpy.context.temp_override(object=obj, active_object=obj):
        bpy.ops.object.modifier_apply(modifier="deformkit")
    bpy.context.view_layer.update()
    assert len(obj.deformkit.entries) == 0
    api.add_entry(obj, "TWIST", angle=0.7)
    assert animation(obj) == set()
    assert read_entry(bpy) is None
    check_scrubbing(bpy, obj, {"Twist": ("angle", lambda f: 0.7)}, reader=False)

"""A broken entry as Blender treats a broken modifier: it is skipped with its message shown, and the
rest of the stack still evaluates."""
import numpy as np
import pytest

from addon_helpers import (close, evaluated, make_lattice, make_object, perturb_lattice, positions,
                           twin_with_simple_deform, update)

TWIST = dict(angle=1.1, deform_axis="Z", limits=(0.1, 0.9))
BEND = dict(angle=0.7, deform_axis="X")


def simple_deform(dk, mode, angle, deform_axis, limits=(0.0, 1.0)):
    return dk.SimpleDeform(mode=mode, angle=angle, deform_axis=deform_axis, limits=limits)


def twist_then_bend(dk, points):
    """Bend(Twist(x)) computed by the deformkit module alone, with the entries' parameters."""
    return dk.Stack([simple_deform(dk, "TWIST", **TWIST), simple_deform(dk, "BEND", **BEND)]).deform(points)


@pytest.mark.parametrize("problem, message", [
    ("lattice_deleted", "lattice object 'Lattice' no longer exists"),
    ("lattice_unlinked", "lattice object 'Lattice' no longer exists"),
    ("bad_basis", "the Bezier Blocks basis needs 3k + 1 points per axis"),
])
def test_a_failing_entry_is_skipped_and_the_others_evaluate(scene, problem, message):
    import bpy
    import deformkit as dk
    from deformkit_addon import api
    obj = make_object(bpy)
    base = positions(obj.data).copy()
    lat = make_lattice(bpy, resolution=(3, 4, 2))
    perturb_lattice(lat)
    api.add_entry(obj, "TWIST", **TWIST)
    middle = api.add_entry(obj, "LATTICE", lattice=lat)
    api.add_entry(obj, "BEND", **BEND)
    assert middle.error == ""
    with_lattice = evaluated(obj).copy()
    expected = twist_then_bend(dk, base)
    assert np.abs(with_lattice - expected).max() > 1e-2  # the lattice did something while it worked
    if problem == "lattice_deleted":
        bpy.data.objects.remove(lat)
    elif problem == "lattice_unlinked":  # what deleting in the viewport does while the entry holds it
        scene.collection.objects.unlink(lat)
    else:
        middle.lattice_basis = "BEZIER"  # 3 x 4 x 2 points: not 3k + 1 on every axis
    update()  # the handlers see it by themselves
    assert message in middle.error, middle.error
    if problem != "bad_basis":  # noticed at once, and the field cleared as Blender clears a modifier's
        assert middle.lattice is None
    assert close(evaluated(obj), expected), np.abs(evaluated(obj) - expected).max()
    assert [e.error for e in obj.deformkit.entries][::2] == ["", ""]
    with pytest.raises(ValueError, match="Lattice: "):  # the api reports it, as the panel shows it
        api.evaluate(obj)
    assert message in middle.error and close(evaluated(obj), expected)
    middle.strength = middle.strength  # an evaluation with nothing changed keeps the message
    assert message in middle.error and close(evaluated(obj), expected)
    api.remove_entry(obj, 1)  # and without the broken entry: the same result
    assert close(evaluated(obj), expected) and all(e.error == "" for e in obj.deformkit.entries)


def test_new_entries_go_above_the_subdivide_entry(scene):
    """A Subdivide entry must stay last (it changes the topology), so entries added after it, by the
    api or the Add menu's operator, are inserted just above it instead of being refused below it."""
    import bpy
    import deformkit as dk
    from addon_helpers import in_blenders_order, polygons
    from deformkit_addon import api
    obj = make_object(bpy)
    base = positions(obj.data).copy()
    api.add_entry(obj, "SUBDIVIDE", levels=1, use_limit_surface=False)
    twist = api.add_entry(obj, "TWIST", **TWIST)
    assert twist.name == "Twist" and obj.deformkit.active_index == 0
    with bpy.context.temp_override(object=obj, active_object=obj):
        assert bpy.ops.deformkit.entry_add(type="BEND") == {"FINISHED"}
    stack = obj.deformkit
    assert [e.type for e in stack.entries] == ["TWIST", "BEND", "SUBDIVIDE"] and stack.active_index == 1
    api.set_params(stack.entries[1], **BEND)
    assert all(e.error == "" for e in stack.entries), [e.error for e in stack.entries]
    # The result: Bend(Twist(x)) subdivided, as dk computes it without the add-on.
    expected = dk.subdivide(twist_then_bend(dk, base).astype(np.float64), polygons(obj.data), 1,
                            limit_surface=False)
    ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    shown = positions(ev.to_mesh())
    ev.to_mesh_clear()
    expected = in_blenders_order(obj.data, expected.points, 1)  # as Blender numbers it
    assert len(shown) == len(expected) and close(shown, expected), len(shown)
    laplacian = api.add_laplacian(obj, anchors_group="Upper")  # bound at the new entry's index
    assert [e.type for e in stack.entries] == ["TWIST", "BEND", "LAPLACIAN", "SUBDIVIDE"]
    assert laplacian.name == stack.entries[2].name and laplacian.bind_id != 0 and laplacian.error == ""
    second = api.add_entry(obj, "SUBDIVIDE")  # a second one still goes last, and is refused there
    assert stack.entries[4] == second and "must be the last entry" in second.error


@pytest.mark.parametrize("how", ["removed", "deleted_in_ui"])
def test_a_deleted_origin_is_noticed_at_once_as_simple_deform_does(scene, how):
    """Blender clears a Simple Deform's origin when the object is deleted, and the modifier then
    deforms in the object's own frame; the entry does the same at the next depsgraph update (no
    parameter edit), says so, and the entries after it keep evaluating."""
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    empty = bpy.data.objects.new("Empty", None)
    scene.collection.objects.link(empty)
    empty.location, empty.rotation_euler = (0.3, 0.2, -0.4), (0.4, 0.0, 0.7)
    update()
    bend = api.add_entry(obj, "BEND", angle=1.2, deform_axis="Z", origin=empty)
    api.add_entry(obj, "TWIST", **TWIST)
    twin = twin_with_simple_deform(bpy, obj, deform_method="BEND", angle=1.2, deform_axis="Z", origin=empty)
    after = twin.modifiers.new("Twist", "SIMPLE_DEFORM")
    after.deform_method, after.angle, after.deform_axis, after.limits = "TWIST", TWIST["angle"], "Z", TWIST["limits"]
    update()
    with_origin = evaluated(obj).copy()
    assert close(with_origin, evaluated(twin))
    if how == "removed":
        bpy.data.objects.remove(empty)
        assert twin.modifiers[0].origin is None  # what Blender does to its own modifier
    else:  # the viewport's Delete: unlinked from the scene, alive only through the entry's pointer
        scene.collection.objects.unlink(empty)
        twin.modifiers[0].origin = None  # Blender's modifier holds no user: the object is freed, its field cleared
    update()  # a depsgraph update, no parameter edit
    assert bend.origin is None
    assert bend.error == ("origin object 'Empty' no longer exists: deforming in the object's own frame, as Simple "
                          "Deform does without an origin"), bend.error
    assert obj.deformkit.entries[1].error == ""
    shown = evaluated(obj)
    assert np.abs(shown - with_origin).max() > 1e-2 and close(shown, evaluated(twin))
    if how == "deleted_in_ui":
        assert "Empty" not in [o.name for o in bpy.data.objects if o.users]  # nothing holds it any more

"""deformkit entries in Blender, against Blender's own Simple Deform and the base mesh."""
import math

import numpy as np
import pytest

from addon_helpers import close, evaluated, make_object, positions, twin_with_simple_deform, update


SETTINGS = [  # (entry type, Simple Deform settings); amounts by Blender's names
    ("TWIST", dict(angle=math.radians(90), deform_axis="Z")),
    ("TWIST", dict(angle=-1.3, deform_axis="X", limits=(0.2, 0.7), lock_y=True)),
    ("BEND", dict(angle=math.radians(120), deform_axis="Z")),
    ("BEND", dict(angle=2.5, deform_axis="X", limits=(0.1, 0.9))),
    ("BEND", dict(angle=1.0, deform_axis="Y")),
    ("TAPER", dict(factor=0.6, deform_axis="Z", lock_x=True)),
    ("STRETCH", dict(factor=0.4, deform_axis="Y", limits=(0.3, 1.0))),
    ("TWIST", dict(angle=1.2, deform_axis="Z", vertex_group="Upper")),
    ("TAPER", dict(factor=-0.5, deform_axis="Z", vertex_group="Upper", invert_vertex_group=True)),
]


@pytest.mark.parametrize("kind, settings", SETTINGS, ids=[f"{k}-{i}" for i, (k, _) in enumerate(SETTINGS)])
def test_entry_equals_blenders_simple_deform(scene, kind, settings):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    base = positions(obj.data).copy()
    api.add_entry(obj, kind, **settings)
    twin = twin_with_simple_deform(bpy, obj, deform_method=kind, **settings)
    ours, theirs = evaluated(obj), evaluated(twin)
    assert np.abs(ours - base).max() > 1e-3  # something happened
    assert close(ours, theirs), np.abs(ours - theirs).max()
    np.testing.assert_array_equal(positions(obj.data), base)  # the base mesh is never written


def test_origin_object_and_parameter_changes_follow_blender(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    bpy.ops.object.empty_add(location=(0.5, 0.2, -0.3), rotation=(0.3, -0.2, 0.9))
    empty = bpy.context.active_object
    entry = api.add_entry(obj, "BEND", angle=1.1, deform_axis="X", origin=empty)
    twin = twin_with_simple_deform(bpy, obj, deform_method="BEND", angle=1.1, deform_axis="X", origin=empty)
    assert close(evaluated(obj), evaluated(twin))
    for name, value in (("angle", -0.7), ("deform_axis", "Y"), ("limits", (0.25, 0.75))):
        setattr(entry, name, value)
        setattr(twin.modifiers[0], name, value)
        assert close(evaluated(obj), evaluated(twin)), name
    empty.location = (1.0, -0.5, 0.2)  # moving the origin re-evaluates through the depsgraph handler
    bpy.context.view_layer.update()
    assert close(evaluated(obj), evaluated(twin))


def test_stack_order_and_later_blender_modifiers(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    api.add_entry(obj, "TWIST", angle=1.5, deform_axis="Z")
    api.add_entry(obj, "BEND", angle=1.0, deform_axis="X")
    obj.modifiers.new("Subdivision", "SUBSURF").levels = 1
    twin = twin_with_simple_deform(bpy, obj, deform_method="TWIST", angle=1.5, deform_axis="Z")
    bend = twin.modifiers.new("Bend", "SIMPLE_DEFORM")
    bend.deform_method, bend.angle, bend.deform_axis = "BEND", 1.0, "X"
    twin.modifiers.new("Subdivision", "SUBSURF").levels = 1
    ours, theirs = evaluated(obj), evaluated(twin)
    assert len(ours) > len(obj.data.vertices)  # the subdivision saw the deformed cage
    assert close(ours, theirs), np.abs(ours - theirs).max()
    api.move_entry(obj, 1, -1)  # bend first now: a different result
    assert not close(evaluated(obj), theirs)


def test_toggles_remove_and_bit_exact_rest(scene):
    import bpy
    from deformkit_addon import api, evaluation
    obj = make_object(bpy)
    base = evaluated(obj).copy()
    first = api.add_entry(obj, "TWIST", angle=1.0, deform_axis="Z")
    api.add_entry(obj, "TAPER", factor=0.5, deform_axis="Z")
    first.show_viewport = False
    twin = twin_with_simple_deform(bpy, obj, deform_method="TAPER", factor=0.5, deform_axis="Z")
    assert close(evaluated(obj), evaluated(twin))  # the viewport skips the hidden entry
    # Renders run both: Simple Deform's taper after its twist.
    from deformkit_addon.native import dk
    expected = dk.Stack([dk.SimpleDeform(mode="TWIST", angle=1.0, deform_axis="Z"),
                         dk.SimpleDeform(mode="TAPER", factor=0.5, deform_axis="Z")]).deform(base)
    assert close(evaluation.stored_positions(obj, "render"), expected, 2.0)
    api.remove_entry(obj, 1)
    api.remove_entry(obj, 0)
    np.testing.assert_array_equal(evaluated(obj), base)  # bit for bit
    assert "deformkit" not in obj.modifiers
    assert not any(a.name.startswith("deformkit") for a in obj.data.attributes)


def test_apply_bakes_into_the_mesh(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    api.add_entry(obj, "TWIST", angle=1.3, deform_axis="Z")
    api.add_entry(obj, "TAPER", factor=0.3, deform_axis="Z")
    before = evaluated(obj).copy()
    assert api.apply(obj, 0) == ""
    assert len(obj.deformkit.entries) == 1
    assert close(evaluated(obj), before)
    assert api.apply(obj, 0) == ""
    assert close(positions(obj.data), before)
    assert "deformkit" not in obj.modifiers
    api.add_entry(obj, "TWIST", angle=0.5, deform_axis="Z")
    api.add_entry(obj, "BEND", angle=0.5, deform_axis="X")
    assert api.apply(obj, 1) == "Applied entry was not first, result may not be as expected"


def test_keyframes_and_drivers_update_the_mesh(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    entry = api.add_entry(obj, "TWIST", angle=0.0, deform_axis="Z")
    twin = twin_with_simple_deform(bpy, obj, deform_method="TWIST", angle=0.0, deform_axis="Z")
    for frame, value in ((1, 0.0), (11, 2.0)):
        entry.angle = value
        entry.keyframe_insert("angle", frame=frame)
        twin.modifiers[0].angle = value
        twin.modifiers[0].keyframe_insert("angle", frame=frame)
    for frame in (11, 6, 1, 8):  # playback and scrubbing
        scene.frame_set(frame)
        assert close(evaluated(obj), evaluated(twin)), frame
    assert abs(obj.deformkit.entries[0].angle - twin.modifiers[0].angle) < 1e-6
    driven = api.add_entry(obj, "TAPER", factor=0.0, deform_axis="Z")
    drv = driven.driver_add("factor").driver
    drv.expression = "frame / 20"
    tdrv = twin.modifiers.new("Taper", "SIMPLE_DEFORM")
    tdrv.deform_method, tdrv.deform_axis = "TAPER", "Z"
    tdrv.driver_add("factor").driver.expression = "frame / 20"
    scene.frame_set(9)
    assert close(evaluated(obj), evaluated(twin))


def test_base_mesh_edits_are_respected(scene):
    import bmesh
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    api.add_entry(obj, "BEND", angle=1.2, deform_axis="X")
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode="EDIT")
    bm = bmesh.from_edit_mesh(obj.data)
    for v in bm.verts:
        v.co.z += 0.25 * v.co.x
    bmesh.update_edit_mesh(obj.data)
    bpy.ops.object.mode_set(mode="OBJECT")
    twin = twin_with_simple_deform(bpy, obj, deform_method="BEND", angle=1.2, deform_axis="X")
    assert close(evaluated(obj), evaluated(twin))


def test_save_reload_and_disabled_addon(scene, tmp_path, addon):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    api.add_entry(obj, "TWIST", angle=0.9, deform_axis="Z", vertex_group="Upper")
    expected = evaluated(obj).copy()
    path = str(tmp_path / "stack.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    obj = bpy.data.objects["Obj"]
    assert [e.type for e in obj.deformkit.entries] == ["TWIST"]
    assert obj.deformkit.entries[0].vertex_group == "Upper"
    assert close(evaluated(obj), expected)
    addon.unregister()
    try:
        bpy.ops.wm.open_mainfile(filepath=path)
        assert close(evaluated(bpy.data.objects["Obj"]), expected)  # still as last seen, no error
    finally:
        addon.register()


@pytest.mark.parametrize("problem", ["vertex_group", "origin", "origin_unlinked", "modifier_name", "limits"])
def test_bad_settings_leave_the_mesh_alone(scene, problem):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    bpy.ops.object.empty_add(location=(0.2, 0.0, 0.0))
    empty = bpy.context.active_object
    entry = api.add_entry(obj, "TWIST", angle=1.0, deform_axis="Z", origin=empty, vertex_group="Upper")
    before = evaluated(obj).copy()
    if problem == "vertex_group":
        obj.vertex_groups.remove(obj.vertex_groups["Upper"])
        bpy.context.view_layer.update()
        entry.angle = 2.0
        assert entry.error == "vertex group 'Upper' not found"
    elif problem in ("origin", "origin_unlinked"):
        if problem == "origin":
            bpy.data.objects.remove(empty)
        else:  # what deleting in the viewport does while we hold a reference
            bpy.context.scene.collection.objects.unlink(empty)
        entry.angle = 2.0
        update()
        assert entry.error == ("origin object 'Empty' no longer exists: deforming in the object's own frame, "
                               "as Simple Deform does without an origin")
        assert entry.origin is None  # cleared, as Blender clears its modifier's field
        # Simple Deform without an origin: what Blender's shows once its origin object is deleted.
        twin = twin_with_simple_deform(bpy, obj, deform_method="TWIST", angle=2.0, deform_axis="Z",
                                       vertex_group="Upper")
        assert close(evaluated(obj), evaluated(twin))
        return
    elif problem == "modifier_name":
        obj.modifiers.remove(obj.modifiers["deformkit"])
        obj.modifiers.new("deformkit", "SUBSURF").levels = 0
        before = evaluated(obj).copy()
        entry.angle = 2.0
        assert "modifier named 'deformkit' is in the way" in obj.deformkit.error
    else:  # limits the user inverted: Blender clamps, and so do we
        entry.limits = (0.8, 0.3)
        assert entry.error == ""
        return
    if entry.error:  # a broken entry is skipped, as Blender skips a broken modifier: here, the only one
        before = positions(obj.data)
    assert close(evaluated(obj), before)
    with pytest.raises(ValueError):
        api.evaluate(obj)


def test_scripting_api_rejects_bad_calls(scene):
    import bpy
    from deformkit_addon import api
    bpy.ops.object.empty_add()
    with pytest.raises(ValueError, match="is not a mesh"):
        api.add_entry(bpy.context.active_object, "TWIST")
    obj = make_object(bpy)
    with pytest.raises(ValueError, match="type: expected one of TWIST"):
        api.add_entry(obj, "SQUASH")
    with pytest.raises(ValueError, match="spin: not a deformkit entry parameter"):
        api.add_entry(obj, "TWIST", spin=1.0)
    with pytest.raises(IndexError):
        api.apply(obj, 5)
    empty_mesh = bpy.data.objects.new("Nothing", bpy.data.meshes.new("Nothing"))
    scene.collection.objects.link(empty_mesh)
    with pytest.raises(ValueError, match="no vertices"):
        api.add_entry(empty_mesh, "TWIST")


def test_weight_edits_are_picked_up(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    entry = api.add_entry(obj, "TWIST", angle=1.0, deform_axis="Z", vertex_group="Upper")
    entry.angle = 1.4  # a parameter edit reuses the weights read before
    twin = twin_with_simple_deform(bpy, obj, deform_method="TWIST", angle=1.4, deform_axis="Z", vertex_group="Upper")
    assert close(evaluated(obj), evaluated(twin))
    for o in (obj, twin):  # weight painting: the mesh changes, so the weights are read again
        o.vertex_groups["Upper"].add(list(range(0, len(o.data.vertices), 3)), 1.0, "REPLACE")
        o.data.update()
    bpy.context.view_layer.update()
    assert close(evaluated(obj), evaluated(twin))


def test_apply_is_refused_in_edit_mode(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    api.add_entry(obj, "TWIST", angle=1.0, deform_axis="Z")
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode="EDIT")
    with pytest.raises(ValueError, match="leave edit mode first"):
        api.apply(obj, 0)
    with bpy.context.temp_override(object=obj, active_object=obj):
        assert not bpy.ops.deformkit.entry_apply.poll()
    bpy.ops.object.mode_set(mode="OBJECT")
    assert len(obj.deformkit.entries) == 1


def test_names_and_a_users_node_group_of_the_same_name(scene):
    import bpy
    from deformkit_addon import api, evaluation, outputs
    theirs = bpy.data.node_groups.new(outputs.NODE_GROUP_NAME, "GeometryNodeTree")
    obj = make_object(bpy)
    first = api.add_entry(obj, "TWIST", angle=1.0, deform_axis="Z")
    second = api.add_entry(obj, "TWIST", angle=0.5, deform_axis="Z")
    assert (first.name, second.name) == ("Twist", "Twist.001")
    groups = len(bpy.data.node_groups)
    for angle in (0.1, 0.2, 0.3):
        first.angle = angle
    assert len(bpy.data.node_groups) == groups  # found by its marker, not re-created
    assert obj.modifiers["deformkit"].node_group != theirs


def test_frame_changes_then_base_edits(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    entry = api.add_entry(obj, "TWIST", angle=0.0, deform_axis="Z")
    entry.keyframe_insert("angle", frame=1)
    entry.angle = 1.5
    entry.keyframe_insert("angle", frame=5)
    scene.frame_set(3)
    co = positions(obj.data)
    co[:, 2] += 0.2 * co[:, 0]
    obj.data.vertices.foreach_set("co", co.ravel())
    obj.data.update()
    bpy.context.view_layer.update()
    twin = twin_with_simple_deform(bpy, obj, deform_method="TWIST", angle=obj.deformkit.entries[0].angle,
                                   deform_axis="Z")
    assert close(evaluated(obj), evaluated(twin))


def test_volume_ratio_colors(scene):
    import bpy
    from deformkit_addon import api, evaluation, native, outputs
    obj = make_object(bpy)
    api.add_entry(obj, "TAPER", factor=0.8, deform_axis="Z")
    obj.deformkit.show_volume_ratio = True
    attr = obj.data.attributes[outputs.ATTR_VOLUME]
    rgba = np.empty(len(obj.data.vertices) * 4, np.float32)
    attr.data.foreach_get("color", rgba)
    rgba = rgba.reshape(-1, 4)
    ratio = native.dk.SimpleDeform(mode="TAPER", factor=0.8, deform_axis="Z").volume_ratio(positions(obj.data))
    assert (rgba[ratio > 1.05, 2] < 0.99).all() and (rgba[ratio < 0.95, 0] < 0.99).all()


def test_operators(scene):
    import bpy
    obj = make_object(bpy)
    with bpy.context.temp_override(object=obj, active_object=obj):
        assert bpy.ops.deformkit.entry_add(type="BEND") == {"FINISHED"}
        assert bpy.ops.deformkit.entry_add(type="TWIST") == {"FINISHED"}
        assert bpy.ops.deformkit.entry_move(index=1, direction="UP") == {"FINISHED"}
        assert [e.type for e in obj.deformkit.entries] == ["TWIST", "BEND"]
        assert bpy.ops.deformkit.entry_apply(index=0) == {"FINISHED"}
        assert bpy.ops.deformkit.entry_remove(index=0) == {"FINISHED"}
        assert not bpy.ops.deformkit.entry_remove.poll()
    assert len(obj.deformkit.entries) == 0


def test_missing_module_still_loads(scene, addon):
    from deformkit_addon import api, native
    if native.available():
        pytest.skip("the compiled module is importable here; test_blender34 runs this without it")
    import bpy
    assert "make build" in native.IMPORT_ERROR
    obj = make_object(bpy)
    with pytest.raises(ValueError, match="make build"):
        api.add_entry(obj, "TWIST")
    assert not bpy.ops.deformkit.entry_add.poll()


def test_undo_and_redo(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    base = evaluated(obj).copy()
    bpy.ops.ed.undo_push(message="start")
    api.add_entry(obj, "TWIST", angle=1.0, deform_axis="Z")
    bpy.ops.ed.undo_push(message="add twist")
    after_add = evaluated(obj).copy()
    obj.deformkit.entries[0].angle = 2.0
    bpy.ops.ed.undo_push(message="angle")
    after_angle = evaluated(obj).copy()
    assert not close(after_add, after_angle)
    bpy.ops.ed.undo()
    obj = bpy.data.objects["Obj"]  # undo rebuilds the data: look the object up again
    assert abs(obj.deformkit.entries[0].angle - 1.0) < 1e-6
    assert close(evaluated(obj), after_add)
    bpy.ops.ed.undo()
    obj = bpy.data.objects["Obj"]
    assert len(obj.deformkit.entries) == 0
    np.testing.assert_array_equal(evaluated(obj), base)
    bpy.ops.ed.redo()
    bpy.ops.ed.redo()
    obj = bpy.data.objects["Obj"]
    assert close(evaluated(obj), after_angle)


def test_script_edits_of_the_base_mesh(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    entry = api.add_entry(obj, "TWIST", angle=1.1, deform_axis="Z")
    bpy.context.view_layer.update()  # the echo of the add-on's write has passed
    co = positions(obj.data)
    co[:, 1] += 0.3 * co[:, 2]
    obj.data.vertices.foreach_set("co", co.ravel())
    obj.data.update()
    bpy.context.view_layer.update()  # the handler sees a base edit and re-evaluates
    twin = twin_with_simple_deform(bpy, obj, deform_method="TWIST", angle=1.1, deform_axis="Z")
    assert close(evaluated(obj), evaluated(twin))
    entry.angle = 0.4  # a parameter edit, then a base edit before any depsgraph update:
    co[:, 0] -= 0.2 * co[:, 2]
    obj.data.vertices.foreach_set("co", co.ravel())
    obj.data.update()
    twin.modifiers[0].angle = 0.4
    twin.data.vertices.foreach_set("co", co.ravel())
    twin.data.update()
    api.evaluate(obj)  # what the documentation asks scripts to do in that case
    assert close(evaluated(obj), evaluated(twin))

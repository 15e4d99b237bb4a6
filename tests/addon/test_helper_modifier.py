"""The "deformkit" Geometry Nodes modifier that shows the result cannot be turned against the mesh:
copied, moved, applied, converted, removed, on linked duplicates or with the add-on disabled."""
import numpy as np

from addon_helpers import close, evaluated, make_object, positions, twin_with_simple_deform

TWIST = dict(deform_method="TWIST", angle=1.0, deform_axis="Z")


def twisted(bpy, name="Obj", location=(0.3, -0.2, 0.5)):
    from deformkit_addon import api
    obj = make_object(bpy, name, location)
    api.add_entry(obj, "TWIST", angle=1.0, deform_axis="Z")
    return obj


def select_only(bpy, objects, active):
    for o in bpy.context.view_layer.objects:
        o.select_set(o in objects)
    bpy.context.view_layer.objects.active = active


def test_copy_modifiers_leaves_other_meshes_as_they_are(scene):
    import bpy
    source = twisted(bpy)
    bpy.ops.mesh.primitive_cube_add(location=(3, 0, 0))
    cube = bpy.context.active_object  # another vertex count
    same = make_object(bpy, "Same", (0, 3, 0))  # the same vertex count, no offsets of its own
    for target in (cube, same):
        select_only(bpy, [source, target], source)
        bpy.ops.object.make_links_data(type="MODIFIERS")  # Copy Modifiers (Ctrl L)
        assert "deformkit" in target.modifiers
        np.testing.assert_array_equal(evaluated(target), positions(target.data))
    # The same with the per-object result (Edit Mode, shared meshes): emptied, it passes through.
    bpy.data.objects.new("Linked", source.data)
    bpy.context.scene.collection.objects.link(bpy.data.objects["Linked"])
    source.deformkit.entries[0].angle = 0.9
    assert source.modifiers["deformkit"].node_group.name == "deformkit result (object)"
    select_only(bpy, [source, same], source)
    bpy.ops.object.make_links_data(type="MODIFIERS")
    bpy.context.view_layer.update()
    np.testing.assert_array_equal(evaluated(same), positions(same.data))


def test_per_object_result_of_another_vertex_count_passes_through(scene):
    import bpy
    from deformkit_addon import api, outputs
    obj = twisted(bpy)
    bpy.data.objects.new("Linked", obj.data)  # a second user: the result goes per object
    api.evaluate(obj)
    helper = outputs.modifier_input(obj, outputs.RESULT_INPUT)
    assert helper is not None and len(helper.data.vertices) == len(obj.data.vertices)
    helper.data.vertices.add(3)  # stale: as if made for another mesh
    helper.data.update()
    bpy.context.view_layer.update()
    np.testing.assert_array_equal(evaluated(obj), positions(obj.data))


def test_moved_below_an_armature_keeps_the_rig(scene):
    import bpy
    obj = twisted(bpy)
    arm_data = bpy.data.armatures.new("Rig")
    rig = bpy.data.objects.new("Rig", arm_data)
    bpy.context.scene.collection.objects.link(rig)
    select_only(bpy, [rig], rig)
    bpy.ops.object.mode_set(mode="EDIT")
    bone = arm_data.edit_bones.new("Bone")
    bone.head, bone.tail = (0.3, -0.2, -1.5), (0.3, -0.2, 2.5)
    bpy.ops.object.mode_set(mode="OBJECT")
    group = obj.vertex_groups.new(name="Bone")
    group.add(list(range(len(obj.data.vertices))), 1.0, "REPLACE")
    armature = obj.modifiers.new("Armature", "ARMATURE")
    armature.object = rig
    rig.pose.bones["Bone"].rotation_mode = "XYZ"
    rig.pose.bones["Bone"].rotation_euler = (0.6, 0.0, 0.0)
    from deformkit_addon import evaluation, outputs
    assert obj.modifiers[0].name == "deformkit" and outputs.place_problem(obj) == ""
    with bpy.context.temp_override(object=obj, active_object=obj):
        bpy.ops.object.modifier_move_to_index(modifier="deformkit", index=1)  # below the Armature
    bpy.context.view_layer.update()
    assert "below 'Armature'" in outputs.place_problem(obj)
    # The rig's result plus the entries' offsets: the bend does not vanish.
    twin = twin_with_simple_deform(bpy, obj, **TWIST)
    twin.modifiers.remove(twin.modifiers["SimpleDeform"])
    rig_only = twin.modifiers.new("Armature", "ARMATURE")
    rig_only.object = rig
    offsets = evaluation.stored_positions(obj) - positions(obj.data)
    assert close(evaluated(obj), evaluated(twin) + offsets, 3.0)
    assert np.abs(evaluated(twin) - positions(obj.data)).max() > 0.1  # the rig does bend it


def test_applying_the_modifier_bakes_once(scene):
    import bpy
    for how in ("apply", "convert"):
        bpy.ops.wm.read_factory_settings(use_empty=True)
        obj = twisted(bpy)
        twin = twin_with_simple_deform(bpy, obj, **TWIST)
        shown = evaluated(obj).copy()
        select_only(bpy, [obj], obj)
        if how == "apply":
            with bpy.context.temp_override(object=obj, active_object=obj):
                bpy.ops.object.modifier_apply(modifier="deformkit")
        else:
            bpy.ops.object.convert(target="MESH")
        bpy.context.view_layer.update()
        assert len(obj.deformkit.entries) == 0, how  # baked: not deformed a second time
        assert "applied" in obj.deformkit.notice
        np.testing.assert_array_equal(evaluated(obj), shown)
        assert close(positions(obj.data), evaluated(twin)), how
        assert not any(a.name.startswith("deformkit_offset") for a in obj.data.attributes)


def test_removing_the_modifier_turns_the_entries_off(scene):
    import bpy
    obj = twisted(bpy)
    base = positions(obj.data)
    obj.modifiers.remove(obj.modifiers["deformkit"])
    bpy.context.view_layer.update()
    entry = obj.deformkit.entries[0]
    assert not entry.show_viewport and not entry.show_render and "removed" in obj.deformkit.notice
    np.testing.assert_array_equal(evaluated(obj), base)
    entry.show_viewport = entry.show_render = True  # back, with its modifier
    twin = twin_with_simple_deform(bpy, obj, **TWIST)
    assert close(evaluated(obj), evaluated(twin))
    assert obj.deformkit.notice == ""


def test_linked_duplicates_each_show_their_own_entries(scene):
    import bpy
    from deformkit_addon import api
    obj = twisted(bpy)
    select_only(bpy, [obj], obj)
    bpy.ops.object.duplicate(linked=True)  # Alt D: the entries come along, the mesh is shared
    dup = bpy.context.active_object
    assert dup.data == obj.data and len(dup.deformkit.entries) == 1
    dup.deformkit.entries[0].angle = -0.6
    api.add_entry(dup, "TAPER", factor=0.3, deform_axis="Z")
    bpy.context.view_layer.update()
    assert obj.deformkit.error == "" and dup.deformkit.error == ""
    from deformkit_addon.native import dk
    base = positions(obj.data)
    ours = dk.SimpleDeform(mode="TWIST", angle=1.0, deform_axis="Z").deform(base)
    theirs = dk.Stack([dk.SimpleDeform(mode="TWIST", angle=-0.6, deform_axis="Z"),
                       dk.SimpleDeform(mode="TAPER", factor=0.3, deform_axis="Z")]).deform(base)
    assert close(evaluated(obj), ours, 2.0) and close(evaluated(dup), theirs, 2.0)
    assert not any(a.name.startswith("deformkit_offset") for a in obj.data.attributes)  # none in the shared mesh
    dup.name = "Renamed"  # keeps its own result
    helpers = {o.name for o in bpy.data.objects if o.get("deformkit_result_of")}
    dup.deformkit.entries[0].angle = -0.5
    theirs = dk.Stack([dk.SimpleDeform(mode="TWIST", angle=-0.5, deform_axis="Z"),
                       dk.SimpleDeform(mode="TAPER", factor=0.3, deform_axis="Z")]).deform(base)
    assert close(evaluated(dup), theirs, 2.0) and close(evaluated(obj), ours, 2.0)
    assert {o.name for o in bpy.data.objects if o.get("deformkit_result_of")} == helpers  # none made anew
    bpy.data.objects.remove(dup)  # single user again: back in its own mesh
    obj.deformkit.entries[0].angle = 1.1
    assert close(evaluated(obj), dk.SimpleDeform(mode="TWIST", angle=1.1, deform_axis="Z").deform(base), 2.0)
    assert obj.modifiers["deformkit"].node_group.name == "deformkit result"


def test_with_the_addon_disabled_edits_still_show(scene, addon):
    import bpy
    obj = twisted(bpy)
    shown = evaluated(obj).copy()
    assert obj.modifiers["deformkit"].node_group.name.startswith("deformkit result")  # right with the add-on off too
    addon.unregister()
    try:
        co = positions(obj.data)
        top = co[:, 2] > 0.5
        co[top, 0] += 0.4
        obj.data.vertices.foreach_set("co", co.ravel())
        obj.data.update()
        bpy.context.view_layer.update()
        after = evaluated(obj)
        # The stored offsets are added to the edited mesh: the edit shows, the rest is as it was.
        assert close(after[top] - shown[top], np.array([0.4, 0.0, 0.0], np.float32), 3.0)
        np.testing.assert_array_equal(after[~top], shown[~top])
    finally:
        addon.register()


def test_volume_colors_on_a_shared_mesh_are_per_object(scene):
    import bpy
    from deformkit_addon import api, outputs
    from deformkit_addon.native import dk
    obj = make_object(bpy)
    api.add_entry(obj, "TAPER", factor=0.8, deform_axis="Z")
    other = bpy.data.objects.new("Other", obj.data)  # shares the mesh, no entries of its own
    bpy.context.scene.collection.objects.link(other)
    obj.deformkit.show_volume_ratio = True
    bpy.context.view_layer.update()
    dg = bpy.context.evaluated_depsgraph_get()
    mesh = obj.evaluated_get(dg).to_mesh()
    rgba = np.empty(len(mesh.vertices) * 4, np.float32)
    mesh.attributes[outputs.ATTR_VOLUME].data.foreach_get("color", rgba)
    obj.evaluated_get(dg).to_mesh_clear()
    ratio = dk.SimpleDeform(mode="TAPER", factor=0.8, deform_axis="Z").volume_ratio(positions(obj.data))
    np.testing.assert_allclose(rgba.reshape(-1, 4), outputs.volume_colors(ratio), atol=1e-6)
    assert outputs.ATTR_VOLUME not in obj.data.attributes  # not in the shared mesh: Other shows none
    np.testing.assert_array_equal(evaluated(other), positions(obj.data))


def _read(mesh, name):
    values = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.attributes[name].data.foreach_get("vector", values)
    return values.reshape(-1, 3)


def test_writing_the_offsets_in_place_leaves_shared_copies_alone(scene):
    """The offsets are computed straight into the attribute's memory: the undo step and the
    evaluated mesh that shared the array before keep their values, as after a foreach_set."""
    import bpy
    from deformkit_addon import errors, outputs
    obj = make_object(bpy)
    mesh, n = obj.data, len(obj.data.vertices)
    before = np.random.default_rng(3).normal(size=(n, 3)).astype(np.float32)
    outputs.write_vector_attribute(mesh, "probe", before)
    mesh.update()
    bpy.ops.ed.undo_push(message="before")
    shown = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data  # shares the array (no modifiers)
    view = outputs.vector_attribute_memory(mesh, "probe", n)
    view[:] = before + 1
    del view
    np.testing.assert_array_equal(_read(mesh, "probe"), before + 1)
    np.testing.assert_array_equal(_read(shown, "probe"), before)
    mesh.update()
    bpy.ops.ed.undo_push(message="after")
    bpy.ops.ed.undo()
    np.testing.assert_array_equal(_read(bpy.data.objects["Obj"].data, "probe"), before)
    bpy.ops.ed.redo()
    np.testing.assert_array_equal(_read(bpy.data.objects["Obj"].data, "probe"), before + 1)
    try:
        outputs.vector_attribute_memory(bpy.data.objects["Obj"].data, "probe", n + 1)
    except errors.EntryError as exc:
        assert "probe" in str(exc) and str(n) in str(exc)
    else:
        raise AssertionError("a count other than the mesh's was accepted")

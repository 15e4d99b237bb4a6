"""Edit Mode: the entries follow edits live, with Simple Deform's Edit Mode and On Cage toggles.

Edits go through bmesh and bmesh.update_edit_mesh, so the depsgraph reports them as the
transform tools' do; the truth is Blender's Simple Deform on a twin edited the same way."""
import numpy as np

from addon_helpers import close, evaluated, make_object, positions, twin_with_simple_deform


def edit(bpy, obj, moved):
    """In obj's Edit Mode, move the vertices above z = 0.5 by `moved` (what G X 0.5 does)."""
    import bmesh
    bm = bmesh.from_edit_mesh(obj.data)
    for v in bm.verts:
        if v.co.z > 0.5:
            v.co.x += moved
    bmesh.update_edit_mesh(obj.data)
    bpy.context.view_layer.update()


def enter_edit_mode(bpy, obj):
    bpy.context.view_layer.objects.active = obj
    for o in bpy.context.view_layer.objects:
        o.select_set(o == obj)
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.context.view_layer.update()


def edited_twin(bpy, obj, moved, **settings):
    """A copy of obj's mesh (as last written: in Edit Mode, without the edits) moved as `edit` moves it."""
    twin = twin_with_simple_deform(bpy, obj, **settings)
    co = positions(twin.data)
    co[co[:, 2] > 0.5, 0] += moved
    twin.data.vertices.foreach_set("co", co.ravel())
    twin.data.update()
    return twin


def test_entries_follow_edits_live(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    api.add_entry(obj, "TWIST", angle=1.0, deform_axis="Z")
    enter_edit_mode(bpy, obj)
    mod = obj.modifiers["deformkit"]
    assert mod.show_in_editmode and not mod.show_on_cage  # Simple Deform's defaults
    for step, moved in enumerate((0.2, 0.5)):  # a drag: one update per step
        edit(bpy, obj, moved - (0.2 if step else 0.0))
        twin = edited_twin(bpy, obj, moved, deform_method="TWIST", angle=1.0, deform_axis="Z")
        assert close(evaluated(obj), evaluated(twin), 2.0), moved
        bpy.data.objects.remove(twin)
        # What the handler reads: the modifier's record of its input, the edit mesh's points exactly.
        import bmesh
        from deformkit_addon import outputs
        cage = np.array([v.co[:] for v in bmesh.from_edit_mesh(obj.data).verts], np.float32)
        captured = outputs.captured_input(obj, bpy.context.evaluated_depsgraph_get(), len(cage))
        np.testing.assert_array_equal(captured, cage)
    bpy.ops.object.mode_set(mode="OBJECT")  # Tab out: the same result from the mesh, which now has the edit
    twin = edited_twin(bpy, obj, 0.0, deform_method="TWIST", angle=1.0, deform_axis="Z")
    assert close(evaluated(obj), evaluated(twin), 2.0)
    assert obj.deformkit.error == ""


def test_parameter_edits_in_edit_mode(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    entry = api.add_entry(obj, "BEND", angle=0.5, deform_axis="X")
    enter_edit_mode(bpy, obj)
    edit(bpy, obj, 0.3)
    entry.angle = 1.1
    twin = edited_twin(bpy, obj, 0.3, deform_method="BEND", angle=1.1, deform_axis="X")
    assert close(evaluated(obj), evaluated(twin), 2.0)


def test_edit_mode_and_on_cage_toggles(scene):
    import bpy
    from deformkit_addon import api
    from deformkit_addon.native import dk
    obj = make_object(bpy)
    twist = api.add_entry(obj, "TWIST", angle=1.0, deform_axis="Z")
    taper = api.add_entry(obj, "TAPER", factor=0.4, deform_axis="Z")
    enter_edit_mode(bpy, obj)
    edit(bpy, obj, 0.25)
    import bmesh
    cage = np.array([v.co[:] for v in bmesh.from_edit_mesh(obj.data).verts], np.float32)
    twist.show_in_editmode = False  # as Blender's toggle: that entry is skipped in Edit Mode only
    expected = dk.SimpleDeform(mode="TAPER", factor=0.4, deform_axis="Z").deform(cage)
    assert close(evaluated(obj), expected, 2.0)
    taper.show_in_editmode = False
    assert not obj.modifiers["deformkit"].show_in_editmode
    np.testing.assert_array_equal(evaluated(obj), cage)  # nothing runs in Edit Mode: the cage as edited
    taper.show_in_editmode = True
    taper.show_on_cage = True  # the last entry shown in Edit Mode decides: the cage is the result
    assert obj.modifiers["deformkit"].show_on_cage
    taper.show_on_cage = False
    assert not obj.modifiers["deformkit"].show_on_cage
    bpy.ops.object.mode_set(mode="OBJECT")  # Object Mode runs every entry again
    both = dk.Stack([dk.SimpleDeform(mode="TWIST", angle=1.0, deform_axis="Z"),
                     dk.SimpleDeform(mode="TAPER", factor=0.4, deform_axis="Z")]).deform(positions(obj.data))
    assert close(evaluated(obj), both, 2.0)


def test_shape_keys_in_edit_mode(scene):
    """In Edit Mode Blender's modifiers get the edit mesh (the active key's shape) unless Shape Key
    Edit Mode is on; then the mix, with the active key's points from the edit mesh."""
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    obj.shape_key_add(name="Basis")
    fat = obj.shape_key_add(name="Fat", from_mix=False)
    co = positions(obj.data)
    co[:, :2] *= 1.4
    fat.data.foreach_set("co", co.ravel())
    fat.value = 0.5
    obj.active_shape_key_index = 1
    api.add_entry(obj, "TWIST", angle=0.8, deform_axis="Z")
    twin = twin_with_simple_deform(bpy, obj, deform_method="TWIST", angle=0.8, deform_axis="Z")
    for o in (obj, twin):
        o.modifiers[0].show_in_editmode = True
    for shape_key_edit_mode in (False, True):
        for o in (obj, twin):
            o.use_shape_key_edit_mode = shape_key_edit_mode
            enter_edit_mode(bpy, o)
            edit(bpy, o, 0.2)
        ours = evaluated(obj).copy()
        bpy.ops.object.mode_set(mode="OBJECT")
        enter_edit_mode(bpy, twin)
        theirs = evaluated(twin).copy()
        bpy.ops.object.mode_set(mode="OBJECT")
        assert close(ours, theirs, 2.0), shape_key_edit_mode

"""The entry menu as a modifier's (issue 14): Move to First / Move to Last, Duplicate, Copy to
Selected, and Ctrl+A, against Blender's own Simple Deform modifiers and the Laplacian solve."""
import types

import numpy as np
import pytest

from addon_helpers import CheckingLayout, close, evaluated, make_object, make_tube, positions, twin_with_simple_deform

SETTINGS = {"TWIST": dict(angle=1.2, deform_axis="Z"), "BEND": dict(angle=0.9, deform_axis="X"),
            "TAPER": dict(factor=0.6, deform_axis="Z")}


def blender_twin(bpy, obj, order):
    first, *rest = order
    twin = twin_with_simple_deform(bpy, obj, deform_method=first, **SETTINGS[first])
    for kind in rest:
        mod = twin.modifiers.new(kind.title(), "SIMPLE_DEFORM")
        mod.deform_method = kind
        for name, value in SETTINGS[kind].items():
            setattr(mod, name, value)
    return twin


def test_move_to_first_and_last_follow_blender(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    for kind in ("TWIST", "BEND", "TAPER"):
        api.add_entry(obj, kind, **SETTINGS[kind])
    assert api.move_entry_to(obj, 2, "FIRST") == 0
    assert [e.type for e in obj.deformkit.entries] == ["TAPER", "TWIST", "BEND"]
    ours, theirs = evaluated(obj), evaluated(blender_twin(bpy, obj, ["TAPER", "TWIST", "BEND"]))
    assert close(ours, theirs), np.abs(ours - theirs).max()
    assert api.move_entry_to(obj, 0, "LAST") == 2
    assert [e.type for e in obj.deformkit.entries] == ["TWIST", "BEND", "TAPER"]
    ours, theirs = evaluated(obj), evaluated(blender_twin(bpy, obj, ["TWIST", "BEND", "TAPER"]))
    assert close(ours, theirs), np.abs(ours - theirs).max()
    assert obj.deformkit.active_index == 2


def test_move_to_last_stays_above_subdivide_and_the_operator(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    api.add_entry(obj, "TWIST", **SETTINGS["TWIST"])
    api.add_entry(obj, "BEND", **SETTINGS["BEND"])
    api.add_entry(obj, "SUBDIVIDE", levels=1)
    assert api.move_entry_to(obj, 0, "LAST") == 1  # above the Subdivide entry, which stays last
    assert [e.type for e in obj.deformkit.entries] == ["BEND", "TWIST", "SUBDIVIDE"]
    assert all(not e.error for e in obj.deformkit.entries)
    with bpy.context.temp_override(object=obj, active_object=obj):
        assert bpy.ops.deformkit.entry_move(index=1, direction="FIRST") == {"FINISHED"}
    assert [e.type for e in obj.deformkit.entries] == ["TWIST", "BEND", "SUBDIVIDE"]
    for bad, error in ((5, IndexError), (0, ValueError)):
        try:
            api.move_entry_to(obj, bad, "LAST" if error is IndexError else "MIDDLE")
        except error as e:
            assert ("index: 5" if error is IndexError else "where: expected 'FIRST' or 'LAST', got 'MIDDLE'") in str(e)
        else:
            raise AssertionError("not refused")


# ---------------------------------------------------------------------------------------------
# Duplicate

TWIST = dict(angle=1.3, deform_axis="Z", limits=(0.15, 0.8), lock_x=True, vertex_group="Upper")


def test_duplicate_is_a_second_simple_deform_below(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    api.add_entry(obj, "TWIST", **TWIST)
    api.add_entry(obj, "TAPER", **SETTINGS["TAPER"])
    copy = api.duplicate_entry(obj, 0)
    assert [e.name for e in obj.deformkit.entries] == ["Twist", "Twist.001", "Taper"]
    assert obj.deformkit.active_index == 1 and copy == obj.deformkit.entries[1]
    api.duplicate_entry(obj, 1)  # a copy of a copy is numbered on, as Blender names them
    assert obj.deformkit.entries[2].name == "Twist.002"
    twin = twin_with_simple_deform(bpy, obj, deform_method="TWIST", **TWIST)
    for name in ("Twist 2", "Twist 3", "Taper"):
        mod = twin.modifiers.new(name, "SIMPLE_DEFORM")
        settings = dict(deform_method="TAPER", **SETTINGS["TAPER"]) if name == "Taper" else \
            dict(deform_method="TWIST", **TWIST)
        for key, value in settings.items():
            setattr(mod, key, value)
    ours, theirs = evaluated(obj), evaluated(twin)
    assert close(ours, theirs), np.abs(ours - theirs).max()


def test_a_duplicated_lattice_entry_is_a_second_lattice_modifier(scene):
    """The copy is bound on its own (its binding is per entry), to the same lattice."""
    import bpy
    from deformkit_addon import api
    from addon_helpers import make_lattice, perturb_lattice, twin_with_lattice_modifier
    obj = make_object(bpy)
    lattice = make_lattice(bpy)
    perturb_lattice(lattice, amount=0.1)
    api.add_entry(obj, "LATTICE", lattice=lattice, strength=0.7, vertex_group="Upper")
    api.add_entry(obj, "TWIST", **TWIST)
    api.duplicate_entry(obj, 0)
    assert [e.type for e in obj.deformkit.entries] == ["LATTICE", "LATTICE", "TWIST"]
    twin = twin_with_lattice_modifier(bpy, obj, lattice, strength=0.7, vertex_group="Upper")
    for name, kind, settings in (("Lattice 2", "LATTICE", dict(object=lattice, strength=0.7, vertex_group="Upper")),
                                 ("Twist", "SIMPLE_DEFORM", dict(deform_method="TWIST", **TWIST))):
        mod = twin.modifiers.new(name, kind)
        for key, value in settings.items():
            setattr(mod, key, value)
    ours, theirs = evaluated(obj), evaluated(twin)
    assert close(ours, theirs, 3.0), np.abs(ours - theirs).max()


def tube_with_bound_laplacian(bpy):
    from deformkit_addon import api
    obj = make_tube(bpy)
    empty = bpy.data.objects.new("Handle", None)
    bpy.context.scene.collection.objects.link(empty)
    empty.location = (0.4, -0.3, 3.8)
    bpy.context.view_layer.update()
    api.add_laplacian(obj, anchors_group="Bottom", handles_group="Top", handle_target="OBJECT", handle_object=empty)
    empty.rotation_euler, empty.location = (0.4, -0.25, 0.6), (0.9, 0.1, 3.5)  # the handles follow it
    bpy.context.view_layer.update()
    return obj, empty


def test_a_duplicated_bind_deforms_as_the_original(scene):
    """The copy has the original's rest under its own bind id; its solver, built from that rest,
    takes the handles where the original does, so either alone gives the same mesh."""
    import bpy
    from deformkit_addon import api
    from deformkit_addon.entries import laplacian as surface
    obj, empty = tube_with_bound_laplacian(bpy)
    original = evaluated(obj).copy()
    assert not close(original, positions(obj.data))
    api.duplicate_entry(obj, 0)
    first, second = obj.deformkit.entries
    assert surface.is_bound(second) and second.bind_id != first.bind_id
    np.testing.assert_array_equal(surface.saved_rest(second), surface.saved_rest(first))
    first.show_viewport = False  # the copy alone, on the base mesh
    bpy.context.view_layer.update()
    assert close(evaluated(obj), original, 3.0)
    empty.location = (0.5, 0.4, 3.9)  # and it follows the handle object as the original would
    bpy.context.view_layer.update()
    alone = evaluated(obj).copy()
    first.show_viewport, second.show_viewport = True, False
    bpy.context.view_layer.update()
    assert close(evaluated(obj), alone, 3.0) and not close(alone, original, 3.0)


def test_a_subdivide_entry_cannot_be_duplicated(scene):
    import bpy
    from deformkit_addon import api, ui
    from deformkit_addon.operators import stack as operators
    obj = make_object(bpy)
    api.add_entry(obj, "TWIST", **TWIST)
    api.add_entry(obj, "SUBDIVIDE", levels=1)
    with pytest.raises(ValueError, match="'Subdivide' cannot be duplicated: a Subdivide entry must be the last one"):
        api.duplicate_entry(obj, 1)
    assert len(obj.deformkit.entries) == 2
    context = types.SimpleNamespace(object=obj)
    duplicate = operators.DEFORMKIT_OT_entry_duplicate
    assert "cannot be duplicated" in duplicate.description(context, types.SimpleNamespace(index=1))
    assert duplicate.description(context, types.SimpleNamespace(index=0)) == duplicate.__doc__
    for index, enabled in ((0, True), (1, False)):  # greyed out in the entry's menu, with that tooltip
        log = []
        layout = EnabledLayout(log)
        menu_context = types.SimpleNamespace(object=obj, deformkit_entry=obj.deformkit.entries[index])
        ui.DEFORMKIT_MT_entry_specials.draw(types.SimpleNamespace(layout=layout), menu_context)
        assert ("deformkit.entry_duplicate", enabled) in log
        assert ("deformkit.entry_copy_to_selected", True) in log


class EnabledLayout(CheckingLayout):
    """Records (operator, whether its layout is enabled)."""

    def row(self, **_kw):
        return EnabledLayout(self.log)

    column = box = row

    def operator(self, idname, **kw):
        settings = super().operator(idname, **kw)
        self.log[-1] = (idname, self.enabled)
        return settings


# ---------------------------------------------------------------------------------------------
# Copy to Selected

def test_copy_to_selected_matches_simple_deform_on_each_target(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    plain = make_object(bpy, name="Plain", location=(2.0, 0.0, 0.0))
    subdivided = make_object(bpy, name="Subdivided", location=(-2.0, 0.0, 0.0))
    api.add_entry(subdivided, "SUBDIVIDE", levels=1)
    api.add_entry(obj, "BEND", angle=0.7, deform_axis="X")
    api.add_entry(obj, "TWIST", **TWIST)
    copies = api.copy_entry_to(obj, 1, [plain, obj, subdivided])  # obj itself is skipped
    assert len(copies) == 2 and len(obj.deformkit.entries) == 2
    assert [e.type for e in subdivided.deformkit.entries] == ["TWIST", "SUBDIVIDE"]  # above the Subdivide
    assert subdivided.deformkit.active_index == 0 and not any(e.error for e in subdivided.deformkit.entries)
    twin = twin_with_simple_deform(bpy, plain, deform_method="TWIST", **TWIST)
    ours, theirs = evaluated(plain), evaluated(twin)
    assert close(ours, theirs), np.abs(ours - theirs).max()
    api.copy_entry_to(subdivided, 1, [obj])  # a Subdivide entry goes last
    assert [e.type for e in obj.deformkit.entries] == ["BEND", "TWIST", "SUBDIVIDE"]
    with pytest.raises(ValueError, match="^Obj already has a Subdivide entry, which must be the last one"):
        api.copy_entry_to(subdivided, 1, [plain, obj])
    assert len(plain.deformkit.entries) == 1  # refused: nothing copied
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj, plain]):
        assert bpy.ops.deformkit.entry_copy_to_selected(index=0) == {"FINISHED"}
    assert [e.type for e in plain.deformkit.entries] == ["TWIST", "BEND"]
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj]):
        assert not bpy.ops.deformkit.entry_copy_to_selected.poll()  # nothing else selected


def test_a_copied_bind_is_bound_again_on_the_target(scene):
    """A bind belongs to the mesh it was made on: the copy arrives unbound, says so, and once bound
    on its own mesh deforms it as an entry made there does."""
    import bpy
    from deformkit_addon import api
    from deformkit_addon.entries import laplacian as surface
    obj, empty = tube_with_bound_laplacian(bpy)
    other = make_tube(bpy, name="Other", location=(3.0, 0.0, 0.0))
    reference = make_tube(bpy, name="Reference", location=(3.0, 0.0, 0.0))
    copy, = api.copy_entry_to(obj, 0, [other])
    assert not surface.is_bound(copy) and copy.handle_object == empty
    assert surface.status(other, copy)[0] == "Copied unbound from 'Tube': Bind again"
    np.testing.assert_array_equal(evaluated(other), positions(other.data))  # unbound: passed through
    api.bind_laplacian(other, 0)
    assert surface.status(other, other.deformkit.entries[0])[0].startswith("Bound:")
    api.add_laplacian(reference, anchors_group="Bottom", handles_group="Top", handle_target="OBJECT",
                      handle_object=empty)
    empty.location = (3.2, 0.3, 3.9)
    bpy.context.view_layer.update()
    assert close(evaluated(other), evaluated(reference), 3.0)
    assert not close(evaluated(other), positions(other.data), 3.0)


# ---------------------------------------------------------------------------------------------
# Ctrl+A

def test_ctrl_a_in_the_properties_editor_applies_the_active_entry(scene):
    import bpy
    from deformkit_addon import api
    from deformkit_addon.operators import stack as operators
    keyconfig = bpy.context.window_manager.keyconfigs.addon
    items = [i for i in keyconfig.keymaps["Property Editor"].keymap_items if i.idname == "deformkit.entry_apply"]
    assert [(i.type, i.value, i.ctrl, i.shift, i.alt) for i in items] == [("A", "PRESS", True, False, False)]
    assert "deformkit.entry_apply" in [i.idname for _keymap, i in operators.KEYMAP_ITEMS]
    obj = make_object(bpy)
    api.add_entry(obj, "BEND", **SETTINGS["BEND"])
    api.add_entry(obj, "TWIST", **TWIST)
    with bpy.context.temp_override(object=obj, active_object=obj):
        assert bpy.ops.deformkit.entry_set_active(index=1) == {"FINISHED"}
        assert bpy.ops.deformkit.entry_apply("INVOKE_DEFAULT") == {"FINISHED"}  # as the hotkey calls it
    assert [e.type for e in obj.deformkit.entries] == ["BEND"]
    twin = twin_with_simple_deform(bpy, make_object(bpy, name="Fresh"), deform_method="TWIST", **TWIST)
    ours, theirs = positions(obj.data), evaluated(twin)  # the twist baked into the base mesh
    assert close(ours, theirs), np.abs(ours - theirs).max()
    on_material_tab = types.SimpleNamespace(object=obj, space_data=types.SimpleNamespace(type="PROPERTIES",
                                                                                         context="MATERIAL"))
    assert not operators.DEFORMKIT_OT_entry_apply.poll(on_material_tab)

"""The entry menu's Move to First / Move to Last, against Blender's own Simple Deform modifiers in
the order the move gives (issue 14: the entry menu matches a modifier's)."""
import numpy as np

from addon_helpers import close, evaluated, make_object, twin_with_simple_deform

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

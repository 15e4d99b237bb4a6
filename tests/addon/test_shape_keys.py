"""Shape keys: the entries deform the shape-key mix as Blender's own modifiers get it.

The truth is Blender itself: the mix is compared with the evaluated mesh of the object without
modifiers (Blender's key evaluation), and the entries with Blender's Simple Deform on a copy with
the same shape keys, under bpy 5.0 and in Blender 3.4 (test_blender34.py)."""
import numpy as np
import pytest

from addon_helpers import close, evaluated, make_object, twin_with_simple_deform


def add_random_keys(bpy, obj, count=4, seed=3):
    from deformkit_addon import shapekeys
    rng = np.random.default_rng(seed)
    obj.shape_key_add(name="Basis")
    for i in range(count):
        block = obj.shape_key_add(name=f"Key {i}", from_mix=False)
        co = shapekeys.block_points(block, len(obj.data.vertices))
        co += (0.15 * rng.standard_normal(co.shape)).astype(np.float32)
        block.data.foreach_set("co", co.ravel())
    return obj.data.shape_keys.key_blocks


def blenders_mix(bpy, obj):
    """Blender's own mix: the evaluated mesh of obj with its modifiers hidden."""
    hidden = [m for m in obj.modifiers if m.show_viewport]
    for m in hidden:
        m.show_viewport = False
    try:
        return evaluated(obj).copy()
    finally:
        for m in hidden:
            m.show_viewport = True


SETTINGS = {
    "relative": {},
    "muted": {"mute": True},
    "vertex_group": {"vertex_group": "Upper"},
    "relative_to_another": {"relative_to": 1},
    "negative_slider": {"slider_min": -1.0, "value": -0.6},
}


@pytest.mark.parametrize("case", sorted(SETTINGS))
def test_relative_mix_is_blenders(scene, case):
    import bpy
    from deformkit_addon import meshdata
    obj = make_object(bpy)
    blocks = add_random_keys(bpy, obj)
    for i, value in zip(range(1, 5), (0.7, 0.35, 1.0, 0.5)):
        blocks[i].value = value
    settings = dict(SETTINGS[case])
    target = blocks[3]
    if "relative_to" in settings:
        target.relative_key = blocks[settings.pop("relative_to")]
    if "slider_min" in settings:
        target.slider_min = settings.pop("slider_min")
    for name, value in settings.items():
        setattr(target, name, value)
    np.testing.assert_array_equal(meshdata.input_positions(obj), blenders_mix(bpy, obj))


def test_pinned_and_absolute_mixes_are_blenders(scene):
    import bpy
    from deformkit_addon import meshdata
    obj = make_object(bpy)
    blocks = add_random_keys(bpy, obj)
    blocks[2].value = 0.4
    obj.show_only_shape_key = True  # the pin: the active key alone, at full value
    for active, group in ((2, ""), (2, "Upper"), (3, "")):
        obj.active_shape_key_index = active
        blocks[active].vertex_group = group
        np.testing.assert_array_equal(meshdata.input_positions(obj), blenders_mix(bpy, obj), err_msg=str(active))
    blocks[3].mute = True  # a muted pinned key shows the reference key
    np.testing.assert_array_equal(meshdata.input_positions(obj), blenders_mix(bpy, obj))
    obj.show_only_shape_key = False
    key = obj.data.shape_keys
    key.use_relative = False
    for interpolation in ("KEY_LINEAR", "KEY_CARDINAL", "KEY_CATMULL_ROM", "KEY_BSPLINE"):
        for block in blocks:
            block.interpolation = interpolation
        blocks[2].interpolation = "KEY_LINEAR"  # where two kinds meet, Blender blends both
        for time in (0.0, 4.0, 10.0, 13.7, 22.5, 35.0, 40.0, 60.0):
            key.eval_time = time
            np.testing.assert_array_equal(meshdata.input_positions(obj), blenders_mix(bpy, obj),
                                          err_msg=f"{interpolation} at {time}")


def keyed_twins(bpy, **settings):
    """make_object's sphere with a Basis and a "Fat" key at value 1 and a Twist entry, and its twin
    with the same keys and Blender's Simple Deform."""
    from deformkit_addon import api
    obj = make_object(bpy)
    obj.shape_key_add(name="Basis")
    fat = obj.shape_key_add(name="Fat", from_mix=False)
    co = np.empty(len(obj.data.vertices) * 3, np.float32)
    fat.data.foreach_get("co", co)
    co = co.reshape(-1, 3)
    co[:, :2] *= 1.5
    fat.data.foreach_set("co", co.ravel())
    fat.value = 1.0
    entry = api.add_entry(obj, "TWIST", angle=1.2, deform_axis="Z", **settings)
    twin = twin_with_simple_deform(bpy, obj, deform_method="TWIST", angle=1.2, deform_axis="Z", **settings)
    return obj, entry, twin


def test_entries_deform_the_mix_as_simple_deform_does(scene):
    import bpy
    obj, entry, twin = keyed_twins(bpy, vertex_group="Upper")
    assert close(evaluated(obj), evaluated(twin), 2.0)
    assert obj.deformkit.error == "" and entry.error == ""
    for value in (0.3, 0.0, 0.8):  # the key's value, as dragged in the UI
        obj.data.shape_keys.key_blocks["Fat"].value = value
        twin.data.shape_keys.key_blocks["Fat"].value = value
        assert close(evaluated(obj), evaluated(twin), 2.0), value
    entry.angle = 0.4  # parameter edits still follow
    twin.modifiers[0].angle = 0.4
    assert close(evaluated(obj), evaluated(twin), 2.0)


def test_keyframed_and_driven_key_values(scene):
    import bpy
    obj, entry, twin = keyed_twins(bpy)
    for o in (obj, twin):
        fat = o.data.shape_keys.key_blocks["Fat"]
        for frame, value in ((1, 0.0), (11, 1.0)):
            fat.value = value
            fat.keyframe_insert("value", frame=frame)
    for frame in (11, 4, 1, 7):
        scene.frame_set(frame)
        assert close(evaluated(obj), evaluated(twin), 2.0), frame
    for o in (obj, twin):
        key = o.data.shape_keys
        key.animation_data_clear()
        key.key_blocks["Fat"].driver_add("value").driver.expression = "frame / 10"
    for frame in (3, 8):
        scene.frame_set(frame)
        assert close(evaluated(obj), evaluated(twin), 2.0), frame


def test_apply_with_shape_keys_is_refused(scene):
    import bpy
    from deformkit_addon import api
    obj, entry, _twin = keyed_twins(bpy)
    with pytest.raises(ValueError, match="shape keys"):
        api.apply(obj, 0)
    assert len(obj.deformkit.entries) == 1

"""The entry-kind registry (python_addon/entries/): one kind per entry type, using properties
that exist, taking exactly the parameters the batch recipe's own table lists for the type, and
operators that share one prefix, poll and undo."""
import pytest

from addon_helpers import make_object


def test_every_entry_type_has_exactly_one_kind(addon):
    from deformkit_addon import entries, properties
    types = [t[0] for t in properties.ENTRY_TYPES]
    assert sorted(t for kind in entries.KINDS for t in kind.TYPES) == sorted(types)
    for kind in entries.KINDS:
        for entry_type in kind.TYPES:
            assert entries.kind(entry_type) is kind
            assert set(kind.fields(entry_type)) <= set(kind.FIELDS)
        assert set(kind.FIELDS) <= set(properties.DEFORMKIT_PG_entry.__annotations__), kind.__name__
    assert sum(kind.LAST for kind in entries.KINDS) == 1  # Subdivide: the one that changes the topology


def test_each_type_takes_the_parameters_of_the_recipe_table(addon):
    """recipe_schema.TYPE_KEYS is the batch's table, read from the kinds' source without bpy: it
    must say which properties a type uses exactly as the registry does at run time (the panel shows
    exactly these)."""
    from deformkit_addon import entries, recipe_schema
    for entry_type in entries.TYPES:
        recipe = set(recipe_schema.COMMON + recipe_schema.TYPE_KEYS[entry_type]) - {"type"} - set(recipe_schema.BATCH_ONLY)
        assert set(entries.params(entry_type)) == recipe, entry_type


def test_set_params_refuses_a_parameter_of_another_kind(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    entry = api.add_entry(obj, "TWIST", angle=1.0, deform_axis="Z")
    with pytest.raises(ValueError) as refused:
        api.set_params(entry, angle=0.5, levels=2)
    message = str(refused.value)
    assert message.startswith("levels: not a parameter of a Twist entry (a Twist entry takes name, ")
    assert "angle" in message and "lock_x" in message and "factor" not in message and "levels, " not in message
    assert entry.angle == pytest.approx(1.0) and entry.levels == 1  # nothing was set
    with pytest.raises(ValueError, match="lock_x: not a parameter of a Bend entry"):
        api.add_entry(obj, "BEND", angle=0.5, lock_x=True)  # Simple Deform has no locks in Bend mode
    with pytest.raises(ValueError, match="angle: not a parameter of a Subdivide entry"):
        api.add_entry(obj, "SUBDIVIDE", angle=1.0)
    with pytest.raises(ValueError, match="^spin: not a deformkit entry parameter \\(expected one of name, "):
        api.set_params(entry, spin=1.0)
    assert len(obj.deformkit.entries) == 1  # a refused add_entry adds nothing
    api.set_params(entry, name="Kept", show_render=False, limits=(0.1, 0.9))  # every kind's and its own
    assert entry.name == "Kept" and not entry.show_render


def test_operators_share_one_prefix_poll_and_undo(addon):
    import bpy
    operators = [cls for cls in addon.classes if issubclass(cls, bpy.types.Operator)]
    # 11; issue 14: Select (unanchored parts), Set Active, Duplicate, Copy to Selected, Select Flipped;
    # issue 15: Bind and Unbind to a cage; issue 16: Bind and Unbind to an RBF entry's controls;
    # issue 17: Transfer Deformation; issue 31: Add, Select, Remove, Mirror and Guess Marker Pair(s);
    # issue 32: Convert Mesh Deform to deformkit; issue 33: Generate Cage
    assert len(operators) == 29
    for cls in operators:
        assert cls.bl_idname.startswith("deformkit."), cls.bl_idname
        assert "poll" in {name for klass in cls.__mro__[:-1] if klass is not bpy.types.Operator
                          for name in vars(klass)}, cls.__name__
        assert {"REGISTER", "UNDO"} <= cls.bl_options, cls.__name__
        module, name = cls.bl_idname.split(".")
        assert getattr(getattr(bpy.ops, module), name).get_rna_type() is not None

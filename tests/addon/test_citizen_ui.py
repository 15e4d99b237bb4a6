"""The add-on as a Blender citizen (issue 31, sections 3 and 4): no error before the user did
anything, names that read whole, Check Smoothness only where it applies, helper objects that go
with their owner and stay out of the pickers, a helper modifier that repairs itself, and entries
found in Blender's menus and F3 search."""
import types

import pytest

from addon_helpers import CheckingLayout, make_object


def draw_panel(obj):
    from deformkit_addon import ui
    log = []
    ui.DEFORMKIT_PT_stack.draw(types.SimpleNamespace(layout=CheckingLayout(log)), types.SimpleNamespace(object=obj))
    return log


def labels(log):
    return [text for what, text in log if what == "label"]


# ---------------------------------------------------------------------------------------------
# A new Cage or RBF entry: a hint, as Mesh Deform's empty Object field, not an error

@pytest.mark.parametrize("entry_type,field", [("CAGE", "cage"), ("RBF", "controls")])
def test_a_new_entry_without_its_object_is_a_hint_not_an_error(scene, entry_type, field):
    import bpy
    from deformkit_addon import api, entries
    obj = make_object(bpy)
    entry = api.add_entry(obj, entry_type)
    assert entry.error == "" and obj.deformkit.error == ""
    text = labels(draw_panel(obj))
    from deformkit_addon import panel_text
    hint = panel_text.wrap(entries.kind(entry).HINT, panel_text.box_budget())
    assert all(len(line) <= 40 for line in hint)  # 3.4 showed 39 of 44 characters and the icon in a box
    assert len(hint) > 1 and all(line in text for line in hint)  # wrapped, not cut, at the default width
    assert not any("See the message" in t or "no cage" in t or "no control" in t for t in text), text
    # Something actually wrong is still said: Bind without the object, and an object that is deleted.
    with pytest.raises(ValueError, match="no (cage|control) object set"):
        api.bind(obj, 0)
    other = make_object(bpy, "Other")
    setattr(obj.deformkit.entries[0], field, other)
    bpy.data.objects.remove(other)
    with pytest.raises(ValueError, match="no longer exists|deleted"):
        api.evaluate(obj)
    entry = obj.deformkit.entries[0]
    assert "no longer exists" in entry.error or "deleted" in entry.error, entry.error
    assert hint[0] not in labels(draw_panel(obj))


# ---------------------------------------------------------------------------------------------
# Entry names: the type's label ("RBF", not "Rbf"), read whole in the header at the default width

class HeaderLayout:
    """Records a header row as nested groups: ("align" or "row", [children]) and leaf buttons."""

    def __init__(self, align=False):
        self.align, self.items, self.alert, self.enabled, self.use_property_split = align, [], False, True, False

    def row(self, align=False, **_kw):
        child = HeaderLayout(align)
        self.items.append(child)
        return child

    column = box = row

    def context_pointer_set(self, *_args):
        pass

    def prop(self, data, name, text=None, **_kw):
        self.items.append("name" if name == "name" else "button")

    def operator(self, *_args, **_kw):
        self.items.append("button")
        return types.SimpleNamespace()

    def menu(self, *_args, **_kw):
        self.items.append("button")

    def label(self, **_kw):
        pass


# Measured in Blender 3.4's screenshots at the default width (333 px), icon buttons 20 px: main's
# header (six items, five gaps) left the name field 50 px, in which "Lapl…" (32 px) showed and
# "Laplacian" (50 px) did not; with two gaps fewer it was 66 px and "Laplacian" showed whole. So the
# row is 250 px, a gap 8 px, and a name needs its width plus Blender's text margins (2 x 8 px).
ROW_WIDTH, BUTTON, GAP, TEXT_PADDING = 250.0, 20.0, 8.0, 16.0


def fixed_width(layout):
    """(width of the buttons and gaps, number of name fields) of a recorded layout."""
    width, names = 0.0, 0
    for item in layout.items:
        if item == "name":
            names += 1
        elif item == "button":
            width += BUTTON
        else:
            inner, inner_names = fixed_width(item)
            width, names = width + inner, names + inner_names
    gaps = 0 if layout.align else len(layout.items) - 1
    return width + GAP * gaps, names


def test_new_entries_are_named_by_their_type_label(scene):
    import bpy
    from deformkit_addon import api, entries
    obj = make_object(bpy)
    for entry_type in entries.TYPES:
        api.add_entry(obj, entry_type)
    names = [e.name for e in obj.deformkit.entries]
    labels_ = [entries.LABELS[e.type] for e in obj.deformkit.entries]
    assert names == labels_ and "RBF" in names
    with pytest.raises(ValueError, match="is a RBF entry, not a Lattice entry"):
        api.entry_of_type(obj, names.index("RBF"), "LATTICE")


def test_every_type_label_reads_whole_in_an_entry_header_at_the_default_width(scene):
    import blf
    import bpy
    from deformkit_addon import api, entries, ui
    obj = make_object(bpy)
    for entry_type in entries.TYPES:
        api.add_entry(obj, entry_type).name = entries.LABELS[entry_type]
    blf.size(0, 11)
    for entry in obj.deformkit.entries:
        entry.show_expanded = False  # the header only
        box = HeaderLayout()
        ui.draw_entry(box, obj, entry)
        header = box.items[0]
        width, fields = fixed_width(header)
        assert fields == 1
        text = blf.dimensions(0, entry.name)[0]
        assert text > 0, "blf measures nothing here"
        assert text + TEXT_PADDING <= ROW_WIDTH - width, (entry.name, ROW_WIDTH - width)


def test_a_recipe_names_the_rbf_kind_as_the_panel_does():
    from deformkit_addon import recipe_schema
    problems = recipe_schema.entry_problems({"type": "rbf", "angle": 1.0}, "deformers[0]")
    assert any("(for a RBF entry)" in p for p in problems), problems


# ---------------------------------------------------------------------------------------------
# Check Smoothness under the stack only where it applies (a Subdivide entry), else in the entry's menu

def draw_entry_menu(obj, index):
    from deformkit_addon import ui
    log = []
    ui.DEFORMKIT_MT_entry_specials.draw(types.SimpleNamespace(layout=CheckingLayout(log)),
                                        types.SimpleNamespace(object=obj, deformkit_entry=obj.deformkit.entries[index]))
    return log


def test_check_smoothness_shows_where_it_applies(scene):
    import bpy
    from deformkit_addon import api
    check = ("operator", "deformkit.check_smoothness")
    obj = make_object(bpy)
    api.add_entry(obj, "TWIST")
    assert check not in draw_panel(obj)
    assert check in draw_entry_menu(obj, 0)  # still at hand
    api.add_entry(obj, "SUBDIVIDE", levels=1)
    assert draw_panel(obj).count(check) == 1
    assert check not in draw_entry_menu(obj, 0) and check not in draw_entry_menu(obj, 1)
    api.remove_entry(obj, 1)
    assert check not in draw_panel(obj)
    api.check_smoothness(obj)  # run from the menu: its figures show under the stack
    assert obj.deformkit.smoothness.checked and check in draw_panel(obj)


# ---------------------------------------------------------------------------------------------
# Enabling the add-on again evaluates every stack: edits made while it was off show at once

def test_enabling_the_addon_again_evaluates_what_changed_while_it_was_off(scene, addon):
    import bpy
    from addon_helpers import close, evaluated, positions, twin_with_simple_deform
    from deformkit_addon import api
    obj = make_object(bpy)
    api.add_entry(obj, "TWIST", angle=1.1, deform_axis="Z")
    addon.unregister()
    try:
        co = positions(obj.data)
        co[:, 0] *= 1.5  # an edit while the add-on is off: nothing re-evaluates it
        obj.data.vertices.foreach_set("co", co.ravel())
        obj.data.update()
        bpy.context.view_layer.update()
    finally:
        addon.register()
    twin = twin_with_simple_deform(bpy, obj, deform_method="TWIST", angle=1.1, deform_axis="Z")
    assert close(evaluated(obj), evaluated(twin))  # the edit shows in the result, with no other edit


# ---------------------------------------------------------------------------------------------
# Helper objects go with their owner and stay out of the object pickers

def helper_objects(bpy):
    return sorted(o.name for o in bpy.data.objects if o.get("deformkit_result_of") or o.get("deformkit_subdivision_of"))


def delete_in_the_ui(bpy, obj):
    for other in bpy.context.selected_objects:
        other.select_set(False)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.delete()
    bpy.context.view_layer.update()


def test_helper_objects_go_with_the_object_they_belong_to(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    api.add_entry(obj, "TWIST", angle=1.0)
    for other in bpy.context.selected_objects:
        other.select_set(False)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.duplicate(linked=True)  # Alt D: a shared mesh, so each shows its result through a helper
    dup = bpy.context.active_object
    api.add_entry(dup, "TAPER", factor=0.3)
    bpy.context.view_layer.update()
    assert helper_objects(bpy) == sorted([f"{obj.name} deformkit result", f"{dup.name} deformkit result"])
    delete_in_the_ui(bpy, dup)
    assert helper_objects(bpy) == []  # obj is back in its own mesh; dup's helper went with dup
    assert not [m.name for m in bpy.data.meshes if "deformkit result" in m.name]
    sub = make_object(bpy, "Sub")
    api.add_entry(sub, "SUBDIVIDE", levels=1, render_levels=2)
    assert len(helper_objects(bpy)) == 2  # viewport and render
    delete_in_the_ui(bpy, sub)
    assert helper_objects(bpy) == [] and not [m.name for m in bpy.data.meshes if "subdivided" in m.name]
    assert [o.name for o in bpy.data.objects] == [obj.name]


def test_the_object_pickers_do_not_list_helper_objects(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    mesh = make_object(bpy, "Mesh")
    sub = make_object(bpy, "Sub")
    api.add_entry(sub, "SUBDIVIDE", levels=1, render_levels=2)
    edited = make_object(bpy, "Edited")
    api.add_entry(edited, "TWIST")
    bpy.ops.object.select_all(action="DESELECT")
    edited.select_set(True)
    bpy.context.view_layer.objects.active = edited
    bpy.ops.object.mode_set(mode="EDIT")  # Edit Mode: the result is shown through a per-object helper
    api.evaluate(edited)
    helpers = [o for o in bpy.data.objects if o.get("deformkit_result_of") or o.get("deformkit_subdivision_of")]
    assert len(helpers) >= 2
    entry = api.add_entry(obj, "CAGE")
    annotations = type(entry).__annotations__
    pickers = [name for name, prop in annotations.items() if "poll" in getattr(prop, "keywords", {})]
    for name in pickers:
        poll = annotations[name].keywords["poll"]
        assert not [h.name for h in helpers if poll(entry, h)], name
        assert not poll(entry, obj), name  # nor the object itself
    assert {"cage", "controls", "rest_object", "handle_object", "origin"} <= set(pickers)
    for name in ("cage", "controls", "rest_object", "handle_object", "origin"):
        assert annotations[name].keywords["poll"](entry, mesh), name  # the user's mesh is listed


# ---------------------------------------------------------------------------------------------
# The helper modifier: a name that reads right, its plumbing hidden where Blender allows, and a
# stray edit repaired at the next evaluation

def twisted_with_twin(bpy, name="Obj"):
    from addon_helpers import twin_with_simple_deform
    from deformkit_addon import api
    obj = make_object(bpy, name)
    api.add_entry(obj, "TWIST", angle=1.1, deform_axis="Z")
    twin = twin_with_simple_deform(bpy, obj, deform_method="TWIST", angle=1.1, deform_axis="Z")
    return obj, twin


def test_the_helper_modifier_reads_right_and_hides_its_plumbing(scene):
    import bpy
    obj, _twin = twisted_with_twin(bpy)
    mod = obj.modifiers["deformkit"]
    assert mod.node_group.name == "deformkit result"
    assert "Needs" not in mod.node_group.name  # reads like an error while everything works
    if hasattr(mod, "show_group_selector"):  # Blender 4.2+ (3.4 cannot hide these)
        assert not mod.show_group_selector and not mod.show_manage_panel
    sub = make_object(bpy, "Sub")
    from deformkit_addon import api
    api.add_entry(sub, "SUBDIVIDE", levels=1)
    group = sub.modifiers["deformkit"].node_group
    assert group.name == "deformkit result (subdivided)"
    if hasattr(group, "interface"):
        inputs = [i for i in group.interface.items_tree if i.in_out == "INPUT"]
        assert {i.name for i in inputs} == {"Geometry", "Viewport", "Render", "Vertices"}
        if hasattr(inputs[0], "hide_in_modifier"):
            assert all(i.hide_in_modifier == (i.name != "Geometry") for i in inputs)


def test_a_group_of_an_older_file_is_renamed_and_still_used(scene):
    import bpy
    from addon_helpers import close, evaluated
    obj, twin = twisted_with_twin(bpy)
    group = obj.modifiers["deformkit"].node_group
    group.name = "Needs deformkit add-on"  # as saved before issue 31
    obj.deformkit.entries[0].angle = 1.1 + 1e-3
    obj.deformkit.entries[0].angle = 1.1
    bpy.context.view_layer.update()
    assert obj.modifiers["deformkit"].node_group == group and group.name == "deformkit result"
    assert close(evaluated(obj), evaluated(twin))


@pytest.mark.parametrize("breakage", ["no_group", "other_group", "link_removed", "node_removed"])
def test_a_broken_helper_modifier_repairs_itself_at_the_next_evaluation(scene, breakage):
    import bpy
    from addon_helpers import close, evaluated
    from deformkit_addon import api
    obj, twin = twisted_with_twin(bpy)
    other, _ = twisted_with_twin(bpy, "Other")  # shares the group
    mod = obj.modifiers["deformkit"]
    group = mod.node_group
    built = (len(group.nodes), len(group.links))
    if breakage == "no_group":
        mod.node_group = None
    elif breakage == "other_group":
        mod.node_group = bpy.data.node_groups.new("Some Group", "GeometryNodeTree")
    elif breakage == "link_removed":
        group.links.remove(group.links[len(group.links) // 2])
    else:
        group.nodes.remove([n for n in group.nodes if n.bl_idname == "ShaderNodeVectorMath"][0])
    api.evaluate(obj)
    mod = obj.modifiers["deformkit"]
    assert mod.node_group.get("deformkit_result") == "offsets"
    assert (len(mod.node_group.nodes), len(mod.node_group.links)) == built
    assert close(evaluated(obj), evaluated(twin))
    assert close(evaluated(other), evaluated(twin))


# ---------------------------------------------------------------------------------------------
# Entries people find: Add Modifier's Deform and Generate columns (4.2+), the Object menu (both),
# so that F3's menu search finds every kind and operator

class MenuLayout:
    """Records (operator id, text, settings) and submenus drawn into a menu."""

    def __init__(self, log):
        self.log = log

    def separator(self, **_kw):
        pass

    def column(self, **_kw):
        return self

    row = column

    def menu(self, idname, **kw):
        self.log.append(("menu", idname, kw.get("text"), {}))

    def operator(self, idname, text=None, **_kw):
        settings = {}
        self.log.append(("operator", idname, text, settings))

        class Settings:
            def __setattr__(self, key, value):
                settings[key] = value

        return Settings()


def drawn(menu_class, context):
    """What the add-on's functions appended to a menu of Blender's draw (or its own menu draws)."""
    log = []
    fake = types.SimpleNamespace(layout=MenuLayout(log))
    if menu_class.__module__.startswith("deformkit_addon"):
        menu_class.draw(fake, context)
        return log
    ours = [draw for draw in menu_class._dyn_ui_initialize() if draw.__module__.startswith("deformkit_addon")]
    for draw in ours:
        draw(fake, context)
    return log


def test_every_entry_kind_is_in_blenders_menus(scene):
    import bpy
    from deformkit_addon import entries
    obj = make_object(bpy)
    context = types.SimpleNamespace(object=obj, active_object=obj)
    deforming = [t for t in entries.TYPES if not entries.kind(t).LAST]
    generating = [t for t in entries.TYPES if entries.kind(t).LAST]
    assert generating == ["SUBDIVIDE"]
    added = lambda log: [s.get("type") for kind, idname, _t, s in log if idname == "deformkit.entry_add"]  # noqa: E731
    if hasattr(bpy.types, "OBJECT_MT_modifier_add_deform"):  # Blender 4.2+: Python menus
        assert added(drawn(bpy.types.OBJECT_MT_modifier_add_deform, context)) == deforming
        assert added(drawn(bpy.types.OBJECT_MT_modifier_add_generate, context)) == generating
        empty = types.SimpleNamespace(object=None, active_object=None)
        assert added(drawn(bpy.types.OBJECT_MT_modifier_add_deform, empty)) == []
    else:
        assert bpy.app.version < (4, 2, 0)
    # The Object menu (both versions): a deformkit submenu with every kind and every operator.
    object_menu = drawn(bpy.types.VIEW3D_MT_object, context)
    assert ("menu", "DEFORMKIT_MT_object", None, {}) in object_menu
    ours = drawn(bpy.types.DEFORMKIT_MT_object, context)
    assert added(ours) == list(entries.TYPES)
    listed = {idname for _kind, idname, _t, _s in ours}
    operators = {cls.bl_idname for cls in bpy.types.Operator.__subclasses__() if cls.__name__.startswith("DEFORMKIT_OT_")}
    assert operators - listed == {"deformkit.entry_set_active"}  # the panel's click on an entry's icon


def test_every_operator_has_a_label_and_a_description(scene):
    import bpy
    from deformkit_addon import entries
    classes = [cls for cls in bpy.types.Operator.__subclasses__() if cls.__name__.startswith("DEFORMKIT_OT_")]
    assert len(classes) > 15
    for cls in classes:
        module, name = cls.bl_idname.split(".")
        rna = getattr(getattr(bpy.ops, module), name).get_rna_type()
        assert rna.name == cls.bl_label and (rna.description or "description" in vars(cls)), cls.__name__
    add = bpy.types.DEFORMKIT_OT_entry_add
    for entry_type, _label, description, _icon, _n in entries.ENTRY_TYPES:
        assert add.description(bpy.context, types.SimpleNamespace(type=entry_type)) == description


def test_the_addon_description_names_every_family():
    import pathlib
    import re
    addon_dir = pathlib.Path(__file__).resolve().parents[2] / "python_addon"
    init = (addon_dir / "__init__.py").read_text()
    description = re.search(r'"description": ((?:"[^"]*"\s*)+)', init).group(1)
    tagline = re.search(r'^tagline = "([^"]*)"', (addon_dir / "blender_manifest.toml").read_text(), re.M).group(1)
    for text in (description, tagline):
        for family in ("Barr", "lattice", "Laplacian", "ARAP", "cage", "RBF", "subdivi", "transfer"):
            assert family.lower() in text.lower(), (family, text)
    assert len(tagline) <= 64 and not re.search(r"[.!?,;:]$", tagline)

"""The panel at Blender's default Properties width (issue 14, "The panel"): the type as a dropdown,
messages wrapped at word boundaries, tooltips and Simple Deform's angle range, the Laplacian's
unanchored parts in one line with a Select button, a compact panel without entries, and Check
Smoothness's figures with honest icons and readable angles."""
import random
import types

from addon_helpers import CheckingLayout, make_object


class KeywordLayout(CheckingLayout):
    """A CheckingLayout that also records the keywords each property is drawn with."""

    def __init__(self, log, keywords):
        super().__init__(log)
        self.keywords = keywords

    def row(self, **_kw):
        return KeywordLayout(self.log, self.keywords)

    column = box = row

    def prop(self, data, name, icon="NONE", **kw):
        super().prop(data, name, icon=icon, **kw)
        self.keywords.setdefault(name, []).append(dict(kw, icon=icon))


def draw_panel(obj, layout_type=CheckingLayout, *extra):
    from deformkit_addon import ui
    log = []
    ui.DEFORMKIT_PT_stack.draw(types.SimpleNamespace(layout=layout_type(log, *extra)),
                               types.SimpleNamespace(object=obj))
    return log


# ---------------------------------------------------------------------------------------------
# 1. The type row and wrapped messages

def test_the_type_is_a_dropdown_labelled_as_blender_does(scene):
    import bpy
    from deformkit_addon import api, entries
    obj = make_object(bpy)
    for entry_type in entries.TYPES:
        if entry_type != "SUBDIVIDE":
            api.add_entry(obj, entry_type)
    keywords = {}
    draw_panel(obj, KeywordLayout, keywords)
    drawn = keywords["type"]
    assert len(drawn) == len(obj.deformkit.entries)
    assert not any(kw.get("expand") for kw in drawn)  # a dropdown, not one button per type
    # Simple Deform names its mode property "Mode"; the Barr types are its modes.
    simple_deform_mode = bpy.types.SimpleDeformModifier.bl_rna.properties["deform_method"].name
    labels = [kw.get("text") for kw in drawn]
    assert labels == [simple_deform_mode if e.type in entries.barr.TYPES else "Type" for e in obj.deformkit.entries]


def test_wrap_keeps_every_word_whole_within_the_budget():
    from deformkit_addon import panel_text
    rng = random.Random(14)
    for _ in range(300):
        words = ["".join(rng.choice("abcdefghij'.,") for _ in range(rng.randint(1, 14)))
                 for _ in range(rng.randint(0, 30))]
        budget = rng.randint(16, 60)
        text = (" " * rng.randint(1, 2)).join(words)
        lines = panel_text.wrap(text, budget)
        assert " ".join(lines).split() == words  # every word kept, in order, none cut
        assert all(len(line) <= budget for line in lines)
        assert all(line == line.strip() and line for line in lines)
        # Greedy: the next line's first word would not have fit on the line before.
        for before, after in zip(lines, lines[1:]):
            assert len(before) + 1 + len(after.split()[0]) > budget


def test_a_word_longer_than_the_budget_gets_its_own_line_uncut():
    from deformkit_addon import panel_text
    long_word = "/very/long/path/to/a/lattice/object/name.001"
    lines = panel_text.wrap(f"object {long_word} no longer exists", 20)
    assert lines == ["object", long_word, "no longer exists"]


def test_the_budget_follows_the_region_width_and_the_ui_scale():
    from deformkit_addon import panel_text
    narrow, default, wide = (panel_text.char_budget(w) for w in (200, panel_text.DEFAULT_WIDTH, 600))
    assert narrow < default < wide
    assert panel_text.char_budget(None) == default
    # At twice the UI scale the region is twice as many pixels wide for the same characters.
    assert panel_text.char_budget(2 * panel_text.DEFAULT_WIDTH, 2.0) == default
    assert panel_text.char_budget(1) == panel_text.MIN_BUDGET


def test_a_long_entry_error_is_drawn_as_whole_lines(scene):
    import bpy
    from deformkit_addon import api, panel_text
    obj = make_object(bpy)
    entry = api.add_entry(obj, "TWIST")
    entry.error = ("origin object 'A rather long origin name for an empty' was deleted (it is in no scene), "
                   "set another origin or clear the field")
    labels = [text for kind, text in draw_panel(obj) if kind == "label"]
    lines = panel_text.wrap(entry.error, panel_text.char_budget())
    assert len(lines) > 1
    start = labels.index(lines[0])
    assert labels[start:start + len(lines)] == lines


# ---------------------------------------------------------------------------------------------
# 2. Tooltips and the angle's range, against Blender's own Simple Deform RNA

def test_the_settings_artists_hover_have_tooltips(addon):
    from deformkit_addon import properties
    rna = properties.DEFORMKIT_PG_entry.bl_rna.properties
    for name in ("type", "deform_axis", "lock_x", "lock_y", "lock_z", "vertex_group", "invert_vertex_group"):
        assert rna[name].description.strip(), name
        assert rna[name].description != rna[name].name, name
    for item in rna["deform_axis"].enum_items:
        assert item.identifier in item.description


def test_the_locks_and_invert_say_what_simple_deform_says(addon):
    import bpy
    from deformkit_addon import properties
    ours = properties.DEFORMKIT_PG_entry.bl_rna.properties
    blender = bpy.types.SimpleDeformModifier.bl_rna.properties
    for name in ("lock_x", "lock_y", "lock_z", "invert_vertex_group"):
        assert ours[name].description == blender[name].description, name


def test_the_angle_has_simple_deforms_soft_range_and_step(addon):
    import bpy
    from deformkit_addon import properties
    ours = properties.DEFORMKIT_PG_entry.bl_rna.properties["angle"]
    blender = bpy.types.SimpleDeformModifier.bl_rna.properties["angle"]
    assert abs(ours.soft_min - blender.soft_min) < 1e-6 and abs(ours.soft_max - blender.soft_max) < 1e-6
    assert ours.step == blender.step
    assert ours.subtype == blender.subtype == "ANGLE"
    # Only the UI range: values beyond it (typed, keyframed, driven) are still accepted.
    assert ours.hard_min < ours.soft_min and ours.hard_max > ours.soft_max


def test_the_saved_data_paths_keep_their_names_types_and_defaults(addon):
    import math

    from deformkit_addon import properties
    rna = properties.DEFORMKIT_PG_entry.bl_rna.properties
    assert (rna["type"].type, rna["type"].default, rna["type"].name) == ("ENUM", "TWIST", "Type")
    assert (rna["angle"].type, rna["angle"].name) == ("FLOAT", "Angle")
    assert abs(rna["angle"].default - math.radians(45.0)) < 1e-7
    assert (rna["deform_axis"].type, rna["deform_axis"].default) == ("ENUM", "X")
    assert [i.identifier for i in rna["deform_axis"].enum_items] == ["X", "Y", "Z"]
    for name in ("lock_x", "lock_y", "lock_z", "invert_vertex_group"):
        assert (rna[name].type, rna[name].default) == ("BOOLEAN", False), name
    assert (rna["vertex_group"].type, rna["vertex_group"].default) == ("STRING", "")


# ---------------------------------------------------------------------------------------------
# 3. A Laplacian entry on a mesh of many loose parts

def add_loose_parts(bpy, obj, count, anchored):
    """`count` separate quads (plus a loose vertex) off the side of the tube, the first `anchored`
    of them in the Bottom group; returns the new vertices' indices per part."""
    import bmesh
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    first = len(bm.verts)
    for k in range(count):
        quad = [bm.verts.new((3.0 + k, dx, dz)) for dx, dz in ((0, 0), (0.5, 0), (0.5, 0.5), (0, 0.5))]
        bm.faces.new(quad)
    bm.verts.new((-3.0, 0.0, 0.0))
    bm.to_mesh(obj.data)
    bm.free()
    parts = [list(range(first + 4 * k, first + 4 * k + 4)) for k in range(count)] + [[first + 4 * count]]
    obj.vertex_groups["Bottom"].add([v for part in parts[:anchored] for v in part], 1.0, "REPLACE")
    return parts


def components_by_union_find(obj):
    """The mesh's connected components through its polygons, by a plain union-find."""
    parent = list(range(len(obj.data.vertices)))

    def root(v):
        while parent[v] != v:
            parent[v] = parent[parent[v]]
            v = parent[v]
        return v

    for polygon in obj.data.polygons:
        vs = list(polygon.vertices)
        for v in vs[1:]:
            parent[root(v)] = root(vs[0])
    groups = {}
    for v in range(len(parent)):
        groups.setdefault(root(v), set()).add(v)
    return list(groups.values())


def held_vertices(obj):
    held = set()
    for name in ("Bottom", "Top"):
        index = obj.vertex_groups[name].index
        held |= {v.index for v in obj.data.vertices if any(g.group == index and g.weight > 0 for g in v.groups)}
    return held


def test_loose_parts_are_one_line_with_a_select_button(scene):
    import bpy
    from deformkit_addon import api
    from deformkit_addon.entries import laplacian
    from addon_helpers import make_tube
    obj = make_tube(bpy)
    add_loose_parts(bpy, obj, count=43, anchored=3)
    api.add_laplacian(obj, anchors_group="Bottom", handles_group="Top")
    held = held_vertices(obj)
    unheld = [c for c in components_by_union_find(obj) if not c & held]
    assert len(unheld) == 43 - 3 + 1  # the quads outside Bottom and the loose vertex
    log = draw_panel(obj)
    labels = [text for kind, text in log if kind == "label"]
    assert f"{len(unheld)} unanchored parts stay in place" in labels
    assert not any("left where it is" in text for text in labels)  # no line per part
    assert ("operator", "deformkit.laplacian_select_unanchored") in log
    # The summary counts what the solver itself warned of, one warning per part.
    solver_warnings = [w for w in laplacian.status(obj, obj.deformkit.entries[0])[1] if "left where it is" in w]
    assert len(solver_warnings) == len(unheld)


def test_one_loose_part_reads_in_the_singular(addon):
    from deformkit_addon.entries import laplacian
    warning = "component 3 (4 vertices) has no anchor or handle; it is left where it is"
    assert laplacian.summarised_warnings([warning, "something else"]) == (1, ["something else"])
    assert laplacian.unanchored_line(1) == "1 unanchored part stays in place"


def test_select_selects_exactly_the_parts_without_anchors(scene):
    import numpy as np
    import bpy
    from deformkit_addon import api
    from addon_helpers import make_tube
    obj = make_tube(bpy)
    add_loose_parts(bpy, obj, count=12, anchored=5)
    api.add_laplacian(obj, anchors_group="Bottom", handles_group="Top")
    held = held_vertices(obj)
    expected = sorted(v for c in components_by_union_find(obj) if not c & held for v in c)
    for start in ("OBJECT", "EDIT"):
        bpy.ops.object.mode_set(mode=start)
        with bpy.context.temp_override(object=obj, active_object=obj):
            assert bpy.ops.deformkit.laplacian_select_unanchored.poll()
            assert bpy.ops.deformkit.laplacian_select_unanchored(index=0) == {"FINISHED"}
        assert obj.mode == "EDIT"
        bpy.ops.object.mode_set(mode="OBJECT")
        selected = np.zeros(len(obj.data.vertices), bool)
        obj.data.vertices.foreach_get("select", selected)
        assert np.flatnonzero(selected).tolist() == expected
        faces = [p.index for p in obj.data.polygons if p.select]
        assert faces == [p.index for p in obj.data.polygons if set(p.vertices) <= set(expected)]
        assert faces  # the loose quads


def test_select_needs_a_laplacian_entry(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    api.add_entry(obj, "TWIST")
    with bpy.context.temp_override(object=obj, active_object=obj):
        assert not bpy.ops.deformkit.laplacian_select_unanchored.poll()


# ---------------------------------------------------------------------------------------------
# 4. A compact panel without entries; Check Smoothness's figures

def test_without_entries_the_panel_is_the_add_button(scene):
    import bpy
    obj = make_object(bpy)
    log = draw_panel(obj)
    assert log == []  # the Add menu only (CheckingLayout logs no menus): no toggles, no Check Smoothness
    obj.deformkit.entries.add()  # a Twist: Check Smoothness is in its menu, not under the stack (issue 31)
    assert ("operator", "deformkit.check_smoothness") not in draw_panel(obj)
    obj.deformkit.entries.add().type = "SUBDIVIDE"
    assert ("operator", "deformkit.check_smoothness") in draw_panel(obj)


def figures(**values):
    base = dict(checked=True, max_angle=0.0, max_gap=0.0, degenerate=0, flipped=0, worst_edge=(-1, -1), selected=0)
    return types.SimpleNamespace(**{**base, **values})


def test_a_flip_is_a_warning_not_a_check_mark(addon):
    from deformkit_addon import ui
    lines = ui.smoothness_lines(figures(flipped=200, max_angle=2.4e-13))
    icons = dict(lines)
    assert icons["Flipped samples: 200"] == "ERROR"
    assert "CHECKMARK" not in icons.values()
    for problem in (dict(selected=3), dict(degenerate=2)):
        assert "CHECKMARK" not in dict(ui.smoothness_lines(figures(**problem))).values()
    smooth = ui.smoothness_lines(figures(max_angle=1e-9, worst_edge=(4, 7)))
    assert "ERROR" not in dict(smooth).values() and "CHECKMARK" in dict(smooth).values()


def test_angles_read_in_degrees_without_exponents(addon):
    import math

    from deformkit_addon import panel_text
    assert panel_text.degrees(math.radians(1.35e-11)) == "< 0.001°"
    assert panel_text.degrees(0.0) == "0°"
    rng = random.Random(4)
    for _ in range(500):
        value = 10 ** rng.uniform(-3, 2.5) * rng.choice((-1, 1))
        text = panel_text.degrees(math.radians(value))
        assert "e" not in text and text.endswith("°")
        shown = float(text[:-1])
        decimals = len(text[:-1].split(".")[1])
        assert abs(shown - value) <= 0.5 * 10 ** -decimals + 1e-12
        assert abs(shown - value) <= 0.01 * abs(value) + 0.0005  # within 1 % (3 significant digits from 0.1°)


def test_the_panel_shows_the_smoothness_lines(scene):
    import bpy
    from deformkit_addon import api, ui
    obj = make_object(bpy)
    api.add_entry(obj, "SUBDIVIDE", levels=1)
    api.check_smoothness(obj)
    labels = [text for kind, text in draw_panel(obj) if kind == "label"]
    expected = [text for text, _icon in ui.smoothness_lines(obj.deformkit.smoothness)]
    assert labels[-len(expected):] == expected


# ---------------------------------------------------------------------------------------------
# Edit Mode toggles, and what the helper modifier's place and fate mean

def test_entries_have_simple_deforms_edit_mode_and_on_cage_toggles(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    entry = api.add_entry(obj, "TWIST")
    drawn = [name for kind, name in draw_panel(obj) if kind == "prop"]
    assert drawn.index("show_on_cage") < drawn.index("show_in_editmode") < drawn.index("show_viewport")
    simple_deform = bpy.types.SimpleDeformModifier.bl_rna.properties
    ours = entry.bl_rna.properties
    for name in ("show_in_editmode", "show_on_cage"):
        assert ours[name].name == simple_deform[name].name
        assert ours[name].default == bpy.data.objects[obj.name].modifiers.new("t", "SIMPLE_DEFORM").__getattribute__(name)
    entry.show_in_editmode = False  # as Blender: no On Cage without Edit Mode
    assert "show_on_cage" not in [name for kind, name in draw_panel(obj) if kind == "prop"]


def test_the_panel_says_what_a_moved_helper_does_and_moves_it_back(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    api.add_entry(obj, "TWIST")
    assert ("operator", "object.modifier_move_to_index") not in draw_panel(obj)
    obj.modifiers.new("Wave", "WAVE")
    with bpy.context.temp_override(object=obj, active_object=obj):
        bpy.ops.object.modifier_move_to_index(modifier="deformkit", index=1)
    log = draw_panel(obj)
    text = " ".join(t for kind, t in log if kind == "label")
    assert "below 'Wave'" in text and ("operator", "object.modifier_move_to_index") in log


def test_a_notice_shows_even_without_entries(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    api.add_entry(obj, "TWIST")
    obj.modifiers.remove(obj.modifiers["deformkit"])
    bpy.context.view_layer.update()
    obj.deformkit.entries.clear()
    text = " ".join(t for kind, t in draw_panel(obj) if kind == "label")
    assert "was removed" in text


def test_a_copied_modifier_without_entries_says_what_it_does(scene):
    import bpy
    from deformkit_addon import api
    source = make_object(bpy)
    api.add_entry(source, "TWIST")
    target = make_object(bpy, "Target", (0, 3, 0))
    for o in bpy.context.view_layer.objects:
        o.select_set(o in (source, target))
    bpy.context.view_layer.objects.active = source
    bpy.ops.object.make_links_data(type="MODIFIERS")
    text = " ".join(t for kind, t in draw_panel(target) if kind == "label")
    assert "no entries on this object" in text
    assert draw_panel(make_object(bpy, "Plain", (0, -3, 0))) == []  # a mesh without it: still compact

# 5. Restrictions as a collapsible subpanel; the active entry; Check Smoothness's gap and flips

def test_restrictions_fold_as_simple_deforms_subpanel(scene):
    import bpy
    from deformkit_addon import api, properties
    obj = make_object(bpy)
    api.add_entry(obj, "TWIST")
    api.add_entry(obj, "BEND")
    twist, bend = obj.deformkit.entries
    restricted = {"limits", "lock_x", "lock_y", "lock_z", "vertex_group", "invert_vertex_group"}
    keywords = {}
    drawn = {name for kind, name in draw_panel(obj, KeywordLayout, keywords) if kind == "prop"}
    assert not drawn & restricted  # closed, as a new modifier's subpanels
    assert [kw.get("icon") for kw in keywords["show_restrictions"]] == ["RIGHTARROW", "RIGHTARROW"]
    assert properties.DEFORMKIT_PG_entry.bl_rna.properties["show_restrictions"].default is False
    twist.show_restrictions = True  # per entry: the Bend entry's stays closed
    keywords = {}
    log = draw_panel(obj, KeywordLayout, keywords)
    drawn = [name for kind, name in log if kind == "prop"]
    assert restricted - {"lock_x"} <= set(drawn) and "lock_x" not in drawn  # none on the deform axis, X
    assert drawn.count("limits") == 1 and "angle" in drawn and drawn.count("angle") == 2
    assert [kw.get("icon") for kw in keywords["show_restrictions"]] == ["DOWNARROW_HLT", "RIGHTARROW"]


class OperatorLayout(CheckingLayout):
    """Records each operator drawn with its keywords."""

    def __init__(self, log, calls):
        super().__init__(log)
        self.calls = calls

    def row(self, **_kw):
        return OperatorLayout(self.log, self.calls)

    column = box = row

    def operator(self, idname, **kw):
        self.calls.append((idname, kw))
        return super().operator(idname, **kw)


def test_the_active_entry_is_shown_pressed_and_a_click_makes_another_active(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    for kind in ("TWIST", "BEND", "TAPER"):
        api.add_entry(obj, kind)
    for active in (2, 0):
        with bpy.context.temp_override(object=obj, active_object=obj):
            assert bpy.ops.deformkit.entry_set_active(index=active) == {"FINISHED"}
        calls = []
        draw_panel(obj, OperatorLayout, calls)
        pressed = [kw["depress"] for idname, kw in calls if idname == "deformkit.entry_set_active"]
        assert pressed == [i == active for i in range(3)]


def test_the_gap_reads_as_a_percentage_without_exponents(addon):
    from deformkit_addon import panel_text, ui
    assert panel_text.percent(0.0) == "0 %"
    assert panel_text.percent(3e-9) == "< 0.0001 %"
    assert panel_text.percent(1.2e-5) == "0.0012 %"
    rng = random.Random(6)
    for _ in range(500):
        fraction = 10 ** rng.uniform(-6, 0.5)
        text = panel_text.percent(fraction)
        assert "e" not in text and text.endswith(" %")
        shown = float(text[:-2])
        assert abs(shown - 100 * fraction) <= 0.05 * 100 * fraction  # two significant digits
        assert len(text[:-2].replace(".", "").lstrip("0")) >= 2 or shown >= 10
    lines = dict(ui.smoothness_lines(figures(max_gap=1.2e-5)))
    assert "Max gap: 0.0012 % of the diagonal" in lines
    assert not any("e-" in text for text in lines)


def test_select_flipped_selects_the_folded_faces(scene):
    """A Bend of 5 rad folds the sphere over: the faces with flipped samples are those of
    dk.smoothness_report run directly on the stack's result against the base mesh, and the fold is
    where the bend's Jacobian turns negative."""
    import numpy as np
    import bpy
    import deformkit as dk
    from deformkit_addon import api, ui
    from addon_helpers import polygons, positions
    obj = make_object(bpy)
    api.add_entry(obj, "BEND", angle=3.0, deform_axis="X")
    assert api.select_flipped(obj) == []  # bent, not folded
    assert ("operator", "deformkit.select_flipped") not in draw_panel(obj)
    obj.deformkit.entries[0].angle = 5.0
    base = positions(obj.data)
    cage = api.evaluated_positions(obj)
    expected = sorted(dk.smoothness_report(cage, polygons(obj.data), reference=base).flipped_faces.tolist())
    assert 0 < len(expected) < len(obj.data.polygons) // 10
    negative = dk.SimpleDeform(mode="BEND", angle=5.0, deform_axis="X").volume_ratio(base) < 0
    assert all(negative[list(obj.data.polygons[f].vertices)].any() for f in expected)
    for mode in ("OBJECT", "EDIT"):
        bpy.ops.object.mode_set(mode=mode)
        with bpy.context.temp_override(object=obj, active_object=obj):
            assert bpy.ops.deformkit.select_flipped() == {"FINISHED"}
        bpy.ops.object.mode_set(mode="OBJECT")
        assert [p.index for p in obj.data.polygons if p.select] == expected, mode
        chosen = {v for f in expected for v in obj.data.polygons[f].vertices}
        assert [v.index for v in obj.data.vertices if v.select] == sorted(chosen), mode
    assert obj.deformkit.smoothness.flipped > 0
    labels = dict(ui.smoothness_lines(obj.deformkit.smoothness))
    assert labels[f"Flipped samples: {obj.deformkit.smoothness.flipped}"] == "ERROR"
    assert ("operator", "deformkit.select_flipped") in draw_panel(obj)


# ---------------------------------------------------------------------------------------------
# 6. The type of a bound Laplacian entry: one click is undone with the bind

def test_undoing_a_type_change_gives_the_bind_back(scene):
    import numpy as np
    import bpy
    from deformkit_addon.entries import laplacian as surface
    from addon_helpers import evaluated
    from test_entry_menu import tube_with_bound_laplacian
    obj, _empty = tube_with_bound_laplacian(bpy)
    bound = evaluated(obj).copy()
    rest = surface.saved_rest(obj.deformkit.entries[0])
    bpy.ops.ed.undo_push(message="bound")
    obj.deformkit.entries[0].type = "TWIST"  # the Type dropdown, which pushes an undo step
    bpy.ops.ed.undo_push(message="type")
    assert not surface.is_bound(obj.deformkit.entries[0])
    bpy.ops.ed.undo()
    obj = bpy.data.objects["Tube"]  # undo rebuilds the data: look the object up again
    entry = obj.deformkit.entries[0]
    assert entry.type == "LAPLACIAN" and surface.is_bound(entry)
    np.testing.assert_array_equal(surface.saved_rest(entry), rest)
    np.testing.assert_array_equal(evaluated(obj), bound)  # the solver, rebuilt from the rest: the same mesh
    bpy.ops.ed.redo()
    obj = bpy.data.objects["Tube"]
    assert obj.deformkit.entries[0].type == "TWIST" and not surface.is_bound(obj.deformkit.entries[0])


# ---------------------------------------------------------------------------------------------
# 7. Every text the panel draws fits at the default width

class BudgetLayout(CheckingLayout):
    """Records every text the panel shows with where it goes: a property's label in the label
    column of a use_property_split layout (its text= or the property's name), a row's items
    (texts, and whether each is a button, which has padding), a line of its own. Splits inherit,
    as in Blender, and only properties are split: a row of labels and buttons is full width."""

    def __init__(self, log, found, split=False, row=None):
        super().__init__(log)
        self.found, self.use_property_split, self.items = found, split, row

    def _child(self, row):
        return BudgetLayout(self.log, self.found, self.use_property_split, row)

    def row(self, heading="", **_kw):
        items = dict(texts=[], split=False)
        self.found["rows"].append(items)
        if heading:
            self.found["column"].append(heading)
        return self._child(items)

    def column(self, **_kw):
        return self._child(None)

    box = column

    def _item(self, text, button, prop=False):
        if not text:
            return
        row = self.items
        if row is None:  # a line of its own
            row = dict(texts=[], split=False)
            self.found["rows"].append(row)
        row["texts"].append((text, button))
        row["split"] |= prop and self.use_property_split  # beside the label column

    def label(self, text="", icon="NONE"):
        super().label(text=text, icon=icon)
        self._item(text, False)

    def operator(self, idname, text=None, **kw):
        import bpy
        module, name = idname.split(".")
        self._item(getattr(getattr(bpy.ops, module), name).get_rna_type().name if text is None else text, True)
        return super().operator(idname, **kw)

    def menu(self, idname, text=None, **kw):
        import bpy
        super().menu(idname, **kw)
        self._item(getattr(bpy.types, idname).bl_label if text is None else text, True)

    def prop(self, data, name, text=None, icon="NONE", **kw):
        super().prop(data, name, icon=icon, **kw)
        rna = data.bl_rna.properties[name]
        text = rna.name if text is None else text
        if rna.type == "BOOLEAN":
            self._item(text, True, prop=True)  # a checkbox or toggle, beside its text
        elif self.use_property_split:
            self.found["column"].append(text)
        elif not kw.get("expand"):
            self._item(text, True, prop=True)

    def prop_search(self, data, name, search_data, search_name, text=None, **kw):
        super().prop_search(data, name, search_data, search_name, **kw)
        text = data.bl_rna.properties[name].name if text is None else text
        if self.use_property_split:
            self.found["column"].append(text)
        else:
            self._item(text, True, prop=True)


def test_every_text_fits_at_the_default_width(scene):
    import bpy
    from deformkit_addon import api, panel_text
    from addon_helpers import make_lattice, make_tube
    # The model flags what Blender 3.4 cut at the default width (issue 14).
    assert len("Boundary Smooth") > panel_text.label_column_budget()
    assert panel_text.row_characters([("Selection to Cursor", True), ("Selection to Empties", True)]) > \
        panel_text.char_budget()
    obj = make_tube(bpy)
    add_loose_parts(bpy, obj, count=43, anchored=3)
    lattice = make_lattice(bpy, scale=(6.0, 6.0, 8.0))
    for kind in ("TWIST", "BEND", "TAPER", "STRETCH"):
        api.add_entry(obj, kind, angle=5.0) if kind in ("TWIST", "BEND") else api.add_entry(obj, kind)
    api.add_entry(obj, "LATTICE", lattice=lattice)
    api.add_laplacian(obj, anchors_group="Bottom", handles_group="Top")
    api.add_entry(obj, "SUBDIVIDE", levels=1)
    for entry in obj.deformkit.entries:
        entry.show_restrictions = True
    obj.deformkit.show_volume_ratio = True
    figures = obj.deformkit.smoothness  # as a Check Smoothness of a large, folded mesh leaves them
    figures.checked, figures.max_angle, figures.max_gap, figures.worst_edge = True, 1.234, 0.0123, (123456, 654321)
    figures.flipped, figures.degenerate, figures.selected = 123456, 12345, 100000
    found = {"rows": [], "column": []}
    draw_panel(obj, BudgetLayout, found)
    column, budget = panel_text.label_column_budget(), panel_text.char_budget()
    assert len(found["column"]) > 20 and len(found["rows"]) > 40
    assert [text for text in found["column"] if len(text) > column] == []
    too_wide = [row["texts"] for row in found["rows"]
                if panel_text.row_characters(row["texts"]) > (budget - column if row["split"] else budget)]
    assert too_wide == []

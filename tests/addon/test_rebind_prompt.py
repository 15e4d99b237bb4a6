"""Rebind without pain (issue 32): an entry bound before whose mesh, cage or control object has other
vertices now says what changed, passes its input through, and offers Rebind in its panel; one
click binds it again, to the same result as a fresh bind of an entry that never was bound."""
import types

import numpy as np
import pytest

from addon_helpers import (CheckingLayout, close, evaluated, group_members, make_object, make_tube, polygons,
                           positions, update)


class ButtonLayout(CheckingLayout):
    """A CheckingLayout that also records each operator's button text and alert state."""

    def __init__(self, log, alert=False):
        super().__init__(log)
        self.alert = alert

    def row(self, **_kw):
        return ButtonLayout(self.log, self.alert)

    column = box = row

    def operator(self, idname, icon="NONE", text="", **kw):
        settings = super().operator(idname, icon=icon, **kw)
        self.log[-1] = ("operator", idname, text, self.alert)
        return settings


def panel(obj):
    from deformkit_addon import ui
    log = []
    ui.DEFORMKIT_PT_stack.draw(types.SimpleNamespace(layout=ButtonLayout(log)), types.SimpleNamespace(object=obj))
    return log


def buttons(obj, text):
    return [item[1:] for item in panel(obj) if item[0] == "operator" and item[2] == text]


def labels(obj):
    return " ".join(item[1] for item in panel(obj) if item[0] == "label")


def grouped(n):
    """8000 -> '8 000': the counts as the messages write them."""
    digits, parts = str(n), []
    while digits:
        parts.insert(0, digits[-3:])
        digits = digits[:-3]
    return " ".join(parts)


def click(bpy, obj, operator, index=0):
    with bpy.context.temp_override(object=obj, active_object=obj):
        return operator(index=index)


def assert_prompt(bpy, obj, message, bind_operator):
    """The entry's message says what changed, the entry passes its input through, and its panel
    shows the message and Rebind (the kind's Bind, alerted) beside Unbind."""
    entry = obj.deformkit.entries[0]
    assert entry.error == message, entry.error
    np.testing.assert_array_equal(evaluated(obj), positions(obj.data))  # skipped: the input passes through
    text = labels(obj)
    assert all(word in text for word in message.split()), text
    assert buttons(obj, "Rebind") == [(bind_operator, "Rebind", True)]


def assert_prompt_gone(obj):
    entry = obj.deformkit.entries[0]
    assert entry.error == "" and entry.bind_outdated == ""
    assert buttons(obj, "Rebind") == []


def test_the_counts_are_written_in_groups_of_three():
    from deformkit_addon.entries import binding
    for n in (0, 7, 321, 999, 1000, 8000, 32000, 1265, 1234567):
        assert binding.count(n).replace(" ", "") == str(n)
        assert binding.count(n) == grouped(n)


# ---------------------------------------------------------------------------------------------
# Laplacian: the mesh itself is bound

def apply_subdivision(bpy, obj):
    """A Subdivision Surface modifier added before the entries and applied: the mesh has more
    vertices (what the entries deform is the mesh before Blender's modifiers)."""
    mod = obj.modifiers.new("Subdivision", "SUBSURF")
    mod.levels = 1
    with bpy.context.temp_override(object=obj, active_object=obj):
        bpy.ops.object.modifier_move_to_index(modifier=mod.name, index=0)
        bpy.ops.object.modifier_apply(modifier=mod.name)
    update()


def laplacian_tube(bpy, name):
    from deformkit_addon import api
    obj = make_tube(bpy, name=name)
    empty = bpy.data.objects.new(name + "Handle", None)
    bpy.context.scene.collection.objects.link(empty)
    empty.location = (0.4, -0.3, 3.8)
    update()
    api.add_laplacian(obj, anchors_group="Bottom", handles_group="Top", handle_target="OBJECT", handle_object=empty,
                      method="ARAP")
    return obj, empty


def test_a_laplacian_entry_offers_rebind_when_the_mesh_changed(scene):
    import bpy
    from deformkit_addon import api, native
    obj, empty = laplacian_tube(bpy, "Tube")
    vertices, faces = len(obj.data.vertices), len(obj.data.polygons)
    apply_subdivision(bpy, obj)
    now_v, now_f = len(obj.data.vertices), len(obj.data.polygons)
    assert now_v > 3 * vertices
    assert_prompt(bpy, obj, f"bound to {vertices} vertices and {faces} faces, the mesh now has {grouped(now_v)} and "
                            f"{grouped(now_f)}: Rebind", "deformkit.laplacian_bind")
    assert click(bpy, obj, bpy.ops.deformkit.laplacian_bind) == {"FINISHED"}
    assert_prompt_gone(obj)
    assert obj.deformkit.entries[0].bind_vertices == now_v
    # A twin subdivided the same way before its entry was ever bound.
    twin = make_tube(bpy, name="Twin")
    apply_subdivision(bpy, twin)
    twin_empty = bpy.data.objects.new("TwinHandle", None)
    bpy.context.scene.collection.objects.link(twin_empty)
    twin_empty.location = empty.location
    update()
    api.add_laplacian(twin, anchors_group="Bottom", handles_group="Top", handle_target="OBJECT",
                      handle_object=twin_empty, method="ARAP")
    for handle in (empty, twin_empty):
        handle.location.x += 0.7
        handle.rotation_euler = (0.3, -0.2, 0.4)
    update()
    result = evaluated(obj)
    np.testing.assert_array_equal(result, evaluated(twin))
    # And what dk.SurfaceDeformer gives on the subdivided mesh with the handles moved as the empty.
    base = positions(obj.data).astype(np.float64)
    top = group_members(obj, "Top")
    at_rebind = np.eye(4)  # the empty's place at Rebind: its motion since then moves the handles
    at_rebind[:3, 3] = (0.4, -0.3, 3.8)
    since = np.linalg.inv(np.array(obj.matrix_world)) @ np.array(empty.matrix_world) @ np.linalg.inv(at_rebind) \
        @ np.array(obj.matrix_world)
    solver = native.dk.SurfaceDeformer(base, polygons(obj.data), anchors=group_members(obj, "Bottom"), handles=top,
                                       method="arap")
    expected = solver.deform(base[top] @ since[:3, :3].T + since[:3, 3])
    assert np.abs(result - base).max() > 0.1  # it deforms
    assert close(result, expected, float(np.ptp(base, axis=0).max()))


# ---------------------------------------------------------------------------------------------
# Cage and RBF: the object they follow was bound

def cage_around(bpy, obj, margin=0.3):
    world = np.array(obj.matrix_world)
    co = positions(obj.data).astype(np.float64) @ world[:3, :3].T + world[:3, 3]
    lo, hi = co.min(0) - margin, co.max(0) + margin
    bpy.ops.mesh.primitive_cube_add(location=(0, 0, 0))
    cage = bpy.context.active_object
    cage.name = "Cage"
    corners = np.where(positions(cage.data) > 0, hi, lo).astype(np.float32)
    cage.data.vertices.foreach_set("co", corners.ravel())
    cage.data.update()
    return cage


def evaluated_in(obj, other):
    """other's evaluated points in obj's space, and its faces."""
    import bpy
    dg = bpy.context.evaluated_depsgraph_get()
    mesh = other.evaluated_get(dg).to_mesh()
    co, faces = positions(mesh).astype(np.float64), [list(p.vertices) for p in mesh.polygons]
    other.evaluated_get(dg).to_mesh_clear()
    local = np.array(obj.matrix_world.inverted() @ other.matrix_world)
    return co @ local[:3, :3].T + local[:3, 3], faces


def lean(other, amount=0.4):
    co = positions(other.data)
    co[co[:, 2] > co[:, 2].mean(), 0] += amount
    other.data.vertices.foreach_set("co", co.ravel())
    other.data.update()
    update()


@pytest.mark.parametrize("method", ["MEAN_VALUE", "GREEN"])
def test_a_cage_entry_offers_rebind_when_the_cage_changed(scene, method):
    import bpy
    from deformkit_addon import api, native
    obj = make_object(bpy)
    cage = cage_around(bpy, obj)
    api.add_entry(obj, "CAGE", cage=cage, cage_method=method)
    api.bind_cage(obj, 0)
    subsurf = cage.modifiers.new("Subdivision", "SUBSURF")  # a level on the cage after bind
    subsurf.levels = 1
    update()
    assert_prompt(bpy, obj, "bound to 8 vertices and 6 faces, the cage now has 26 and 24: Rebind",
                  "deformkit.cage_bind")
    assert click(bpy, obj, bpy.ops.deformkit.cage_bind) == {"FINISHED"}
    assert_prompt_gone(obj)
    rest, faces = evaluated_in(obj, cage)
    lean(cage)
    classes = {"MEAN_VALUE": "MeanValueCage", "GREEN": "GreenCage"}
    deformer = getattr(native.dk, classes[method])(rest, faces)  # a fresh bind to the subdivided cage
    deformer.cage_points = evaluated_in(obj, cage)[0]
    expected = deformer.deform(positions(obj.data).astype(np.float64))
    assert np.abs(expected - positions(obj.data)).max() > 0.05
    assert close(evaluated(obj), expected, 3.0)


def test_a_cage_entry_follows_a_mesh_with_other_vertices_without_a_rebind(scene):
    """The Cage entry binds the mesh to its rest cage as the mesh comes: an edit that adds vertices
    needs no Rebind, and gives what a fresh bind of the edited mesh to the same rest gives."""
    import bpy
    from deformkit_addon import api, native
    obj = make_object(bpy)
    cage = cage_around(bpy, obj)
    api.add_entry(obj, "CAGE", cage=cage)
    api.bind_cage(obj, 0)
    rest, faces = evaluated_in(obj, cage)
    lean(cage)
    apply_subdivision(bpy, obj)
    entry = obj.deformkit.entries[0]
    assert entry.error == "" and buttons(obj, "Rebind") == []
    deformer = native.dk.MeanValueCage(rest, faces)
    deformer.cage_points = evaluated_in(obj, cage)[0]
    assert close(evaluated(obj), deformer.deform(positions(obj.data).astype(np.float64)), 3.0)


def test_an_rbf_entry_offers_rebind_when_the_control_object_changed(scene):
    import bpy
    from deformkit_addon import api, native
    obj = make_object(bpy)
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=1, radius=1.6, location=(0.3, -0.2, 0.5))
    controls = bpy.context.active_object
    controls.name = "Controls"
    controls.scale.z = 2.2
    api.add_entry(obj, "RBF", controls=controls)
    api.bind_rbf(obj, 0)
    count = len(controls.data.vertices)
    controls.modifiers.new("Subdivision", "SUBSURF").levels = 1
    update()
    now = len(evaluated_in(obj, controls)[0])
    assert_prompt(bpy, obj, f"bound to {count} vertices, the control object 'Controls' now has {now}: Rebind",
                  "deformkit.rbf_bind")
    assert click(bpy, obj, bpy.ops.deformkit.rbf_bind) == {"FINISHED"}
    assert_prompt_gone(obj)
    rest = evaluated_in(obj, controls)[0]
    lean(controls, 0.3)
    rbf = native.dk.RBF(rest, kernel="thin_plate_spline", degree=1)
    rbf.targets = evaluated_in(obj, controls)[0]
    expected = rbf.deform(positions(obj.data).astype(np.float64))
    assert np.abs(expected - positions(obj.data)).max() > 0.05
    assert close(evaluated(obj), expected, 3.0)


def test_an_entry_failing_for_another_reason_offers_no_rebind(scene):
    """Rebind is offered for a bind that no longer fits, not beside any other message."""
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    cage = cage_around(bpy, obj)
    api.add_entry(obj, "CAGE", cage=cage)
    api.bind_cage(obj, 0)
    cage.modifiers.new("Subdivision", "SUBSURF").levels = 1
    update()
    assert buttons(obj, "Rebind")
    bpy.data.objects.remove(cage)  # now the cage is gone: that is what the entry says
    update()
    entry = obj.deformkit.entries[0]
    assert "no longer exists" in entry.error
    assert buttons(obj, "Rebind") == []


def test_a_harmonic_cage_entry_offers_rebind_when_the_mesh_changed(scene):
    """Harmonic without Dynamic binds the mesh as Mesh Deform does: another vertex count asks for
    Rebind, which gives what Blender's Mesh Deform bound to the new mesh gives."""
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    cage = cage_around(bpy, obj)
    api.add_entry(obj, "CAGE", cage=cage, cage_method="HARMONIC", precision=3)
    api.bind_cage(obj, 0)
    count = len(obj.data.vertices)
    apply_subdivision(bpy, obj)
    now = len(obj.data.vertices)
    assert_prompt(bpy, obj, f"bound to {grouped(count)} vertices, the mesh now has {grouped(now)}: Rebind",
                  "deformkit.cage_bind")
    assert click(bpy, obj, bpy.ops.deformkit.cage_bind) == {"FINISHED"}
    assert_prompt_gone(obj)
    twin = bpy.data.objects.new("Twin", obj.data.copy())  # the subdivided mesh, in its order
    bpy.context.scene.collection.objects.link(twin)
    twin.matrix_world = obj.matrix_world
    mod = twin.modifiers.new("MeshDeform", "MESH_DEFORM")
    mod.object, mod.precision = cage, 3
    with bpy.context.temp_override(object=twin, active_object=twin):
        assert bpy.ops.object.meshdeform_bind(modifier=mod.name) == {"FINISHED"}
    lean(cage)
    expected = evaluated(twin).astype(np.float64)
    assert np.abs(expected - positions(twin.data)).max() > 0.05
    error = np.linalg.norm(evaluated(obj) - expected, axis=1) / np.linalg.norm(np.ptp(evaluated_in(obj, cage)[0], 0))
    assert np.quantile(error, 0.99) <= 1e-5 and error.max() <= 1e-4


def test_a_cage_entry_bound_for_another_method_offers_rebind_for_harmonic(scene):
    """Mean Value and Green share a bind; Harmonic lays its grid in the cage's frame at bind, which
    they do not record: switched to Harmonic, the entry asks for Rebind."""
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    cage = cage_around(bpy, obj)
    entry = api.add_entry(obj, "CAGE", cage=cage, cage_method="GREEN")
    api.bind_cage(obj, 0)
    entry.cage_method = "MEAN_VALUE"
    assert entry.error == ""
    entry.cage_method = "HARMONIC"
    assert_prompt(bpy, obj, "bound for another method: Rebind", "deformkit.cage_bind")
    assert click(bpy, obj, bpy.ops.deformkit.cage_bind) == {"FINISHED"}
    assert_prompt_gone(obj)
    np.testing.assert_array_equal(evaluated(obj), positions(obj.data))  # bound at rest: the identity

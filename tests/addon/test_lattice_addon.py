"""Lattice entries in Blender: against Blender's own Lattice modifier, the rest mesh, and the
FFD formulas written out in numpy."""
import numpy as np
import pytest

from addon_helpers import (CheckingLayout, close, evaluated, ffd_reference, lattice_box, lattice_points,
                           make_lattice, make_object, perturb_lattice, positions, select_vertices, to_world,
                           twin_with_lattice_modifier, twin_with_simple_deform, update)


# ---------------------------------------------------------------------------------------------
# The Blender basis is Blender's Lattice modifier

MODIFIER_CASES = {
    "bspline": dict(),
    "linear": dict(interpolation="KEY_LINEAR", resolution=(2, 2, 2)),
    "cardinal": dict(interpolation="KEY_CARDINAL", resolution=(4, 3, 5)),
    "catmull_rom": dict(interpolation="KEY_CATMULL_ROM", resolution=(5, 5, 5), strength=0.6),
    "mixed_axes": dict(axes=("KEY_LINEAR", "KEY_CATMULL_ROM", "KEY_BSPLINE"), resolution=(3, 5, 4)),
    "one_layer": dict(resolution=(1, 3, 4)),
    "vertex_group": dict(vertex_group="Upper"),
    "inverted_group": dict(vertex_group="Upper", invert_vertex_group=True, strength=0.8),
    "partly_outside": dict(scale=(1.3, 1.0, 2.0), amount=0.3),  # clamped, as Blender does
    "spaced_one_apart": dict(data_first=True),  # resized before it had an object: rest grid [-1, 1]
}


@pytest.mark.parametrize("case", list(MODIFIER_CASES))
def test_blender_basis_equals_the_lattice_modifier(scene, case):
    import bpy
    from deformkit_addon import api
    settings = dict(MODIFIER_CASES[case])
    obj = make_object(bpy)
    obj.rotation_euler, obj.scale = (0.1, 0.3, -0.2), (1.1, 0.9, 1.2)
    kwargs = {k: settings.pop(k) for k in ("resolution", "interpolation", "scale") if k in settings}
    if settings.pop("data_first", False):
        data = bpy.data.lattices.new("Lattice")
        data.points_u, data.points_v, data.points_w = 3, 3, 3
        lat = bpy.data.objects.new("Lattice", data)
        scene.collection.objects.link(lat)
        lat.location, lat.scale = (0.3, -0.2, 0.5), (1.2, 1.2, 1.8)
        update()
        assert lattice_points(lat, "co").max() == 1.0  # Blender's LT_GRID spacing
    else:
        lat = make_lattice(bpy, **kwargs)
    for axis, kind in zip("uvw", settings.pop("axes", ())):
        setattr(lat.data, f"interpolation_type_{axis}", kind)
    perturb_lattice(lat, settings.pop("amount", 0.15))
    base = positions(obj.data).copy()
    modifier_settings = ("strength", "vertex_group", "invert_vertex_group")
    api.add_entry(obj, "LATTICE", lattice=lat, **{k: settings.pop(k) for k in modifier_settings if k in settings})
    entry = obj.deformkit.entries[0]
    assert settings == {} and entry.error == "", entry.error
    twin = twin_with_lattice_modifier(bpy, obj, lat, strength=entry.strength, vertex_group=entry.vertex_group,
                                      invert_vertex_group=entry.invert_vertex_group)
    ours, theirs = evaluated(obj), evaluated(twin)
    assert np.abs(ours - base).max() > 1e-2  # something happened
    assert close(ours, theirs, 3.0), np.abs(ours - theirs).max()
    np.testing.assert_array_equal(positions(obj.data), base)  # the base mesh is never written


@pytest.mark.parametrize("basis, resolution", [("BLENDER", (3, 4, 2)), ("BERNSTEIN", (3, 4, 2)),
                                               ("BEZIER", (4, 7, 4)), ("BSPLINE", (4, 5, 6))])
def test_a_lattice_at_rest_leaves_the_mesh_bit_for_bit(scene, basis, resolution):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    before = evaluated(obj).copy()
    lat = make_lattice(bpy, resolution=resolution)
    api.add_entry(obj, "LATTICE", lattice=lat, lattice_basis=basis, strength=0.7, vertex_group="Upper")
    assert obj.deformkit.entries[0].error == ""
    np.testing.assert_array_equal(evaluated(obj), before)
    perturb_lattice(lat)
    update()
    assert not close(evaluated(obj), before)
    api.reset_lattice(lat)  # co_deform = co again
    np.testing.assert_array_equal(evaluated(obj), before)


# ---------------------------------------------------------------------------------------------
# The other bases against their formulas

@pytest.mark.parametrize("basis, resolution, scale", [("BERNSTEIN", (3, 4, 2), (3.4, 3.0, 4.8)),
                                                      ("BERNSTEIN", (6, 2, 4), (3.4, 3.0, 4.8)),
                                                      ("BEZIER", (4, 7, 4), (3.4, 3.0, 4.8)),
                                                      ("BSPLINE", (6, 6, 7), (5.5, 5.0, 7.0))])
def test_other_bases_follow_their_formulas(scene, basis, resolution, scale):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    lat = make_lattice(bpy, resolution=resolution, scale=scale)
    perturb_lattice(lat, 0.1, seed=3)
    api.add_entry(obj, "LATTICE", lattice=lat, lattice_basis=basis)
    assert obj.deformkit.entries[0].error == ""
    expected = ffd_reference(obj, lat, basis)
    ours = evaluated(obj)
    assert np.abs(expected - positions(obj.data)).max() > 1e-2
    assert np.abs(ours - expected).max() < 5e-6, np.abs(ours - expected).max()


# ---------------------------------------------------------------------------------------------
# Edits of the lattice, the object and the stack re-evaluate the entry

def test_lattice_edits_moves_and_settings_reevaluate(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    lat = make_lattice(bpy, resolution=(3, 3, 3))
    api.add_entry(obj, "LATTICE", lattice=lat)
    twin = twin_with_lattice_modifier(bpy, obj, lat)

    def check(what):
        update()
        ours, theirs = evaluated(obj), evaluated(twin)
        assert close(ours, theirs, 3.0), (what, np.abs(ours - theirs).max())
        return ours

    previous = check("rest")
    perturb_lattice(lat, seed=1)  # a script edit of co_deform
    for what, edit in [
        ("co_deform", lambda: None),
        ("lattice moved", lambda: setattr(lat, "location", (0.5, 0.0, 0.4))),
        ("lattice turned", lambda: setattr(lat, "rotation_euler", (0.5, 0.2, -0.3))),
        ("object moved through the lattice", lambda: setattr(obj.location, "x", obj.location.x + 0.4)),
        ("interpolation", lambda: setattr(lat.data, "interpolation_type_v", "KEY_CARDINAL")),
        ("resolution", lambda: setattr(lat.data, "points_u", 5)),
    ]:
        if what == "object moved through the lattice":
            twin.location.x += 0.4
        edit()
        current = check(what)
        assert not close(current, previous), what
        previous = current
    # Lattice edit mode: Blender's own tools move the points of its edit copy.
    bpy.context.view_layer.objects.active = lat
    bpy.ops.object.mode_set(mode="EDIT")
    lat.data.points[4].co_deform.z += 0.3
    lat.data.update_tag()
    current = check("edit mode")
    assert not close(current, previous)
    bpy.ops.object.mode_set(mode="OBJECT")
    check("after edit mode")


def test_edit_mode_of_a_lattice_spaced_one_apart(scene):
    """In lattice edit mode Blender's `co` is wrong; the rest grid read before edit mode is used."""
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    data = bpy.data.lattices.new("Lattice")
    data.points_u, data.points_v, data.points_w = 4, 3, 3  # no object yet: points 1 apart
    lat = bpy.data.objects.new("Lattice", data)
    scene.collection.objects.link(lat)
    lat.scale = (1.1, 1.5, 2.2)
    update()
    api.add_entry(obj, "LATTICE", lattice=lat)
    twin = twin_with_lattice_modifier(bpy, obj, lat)
    bpy.context.view_layer.objects.active = lat
    bpy.ops.object.mode_set(mode="EDIT")
    for i in (0, 7, 20):
        lat.data.points[i].co_deform.x += 0.4
    lat.data.update_tag()
    update()
    assert obj.deformkit.entries[0].error == ""
    assert not close(evaluated(obj), positions(obj.data))
    assert close(evaluated(obj), evaluated(twin), 3.0)
    bpy.ops.object.mode_set(mode="OBJECT")


def test_binding_is_kept_until_its_inputs_change(scene):
    import bpy
    from deformkit_addon import api, cache, evaluation, meshdata
    from deformkit_addon.entries import lattice as lattices
    obj = make_object(bpy)
    lat = make_lattice(bpy)
    api.add_entry(obj, "LATTICE", lattice=lat)
    key = (meshdata.cache_key(obj), 0, "viewport")
    first = cache.get("lattice", key)[2]
    perturb_lattice(lat, seed=2)
    update()
    obj.deformkit.entries[0].strength = 0.5
    assert cache.get("lattice", key)[2] is first  # new points and strength: the same binding
    lat.location.x += 0.1
    update()
    assert cache.get("lattice", key)[2] is not first  # the frame changed: bound again
    bound = api.bind_lattice(obj, 0)
    assert bound.inside == len(obj.data.vertices) and bound.outside == 0 == bound.not_placed
    assert lattices.binding_counts(meshdata.cache_key(obj), 0) == tuple(bound)
    lat.scale = (1.5, 1.5, 2.5)  # smaller than the mesh now
    update()
    bound = api.bind_lattice(obj, 0)
    assert bound.outside > 0 and bound.inside + bound.outside == len(obj.data.vertices)


def test_stacked_with_barr_entries(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    lat = make_lattice(bpy)
    perturb_lattice(lat)
    twist = api.add_entry(obj, "TWIST", angle=1.2, deform_axis="Z")
    api.add_entry(obj, "LATTICE", lattice=lat)
    api.add_entry(obj, "BEND", angle=0.6, deform_axis="X")
    twin = twin_with_simple_deform(bpy, obj, deform_method="TWIST", angle=1.2, deform_axis="Z")
    mod = twin.modifiers.new("Lattice", "LATTICE")
    mod.object = lat
    bend = twin.modifiers.new("Bend", "SIMPLE_DEFORM")
    bend.deform_method, bend.angle, bend.deform_axis = "BEND", 0.6, "X"
    assert close(evaluated(obj), evaluated(twin), 3.0)
    twist.angle = 0.4  # the lattice's input changed: bound again
    twin.modifiers[0].angle = 0.4
    assert close(evaluated(obj), evaluated(twin), 3.0)
    twist.show_viewport = False  # viewport and render differ now
    twin.modifiers[0].show_viewport = False
    assert close(evaluated(obj), evaluated(twin), 3.0)


def test_lattice_last_after_a_twist(scene):
    """The lattice last in the stack writes its result straight into the offsets' attribute."""
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    lat = make_lattice(bpy)
    perturb_lattice(lat, seed=4)
    twist = api.add_entry(obj, "TWIST", angle=0.9, deform_axis="Z")
    api.add_entry(obj, "LATTICE", lattice=lat)
    twin = twin_with_simple_deform(bpy, obj, deform_method="TWIST", angle=0.9, deform_axis="Z")
    twin.modifiers.new("Lattice", "LATTICE").object = lat
    assert close(evaluated(obj), evaluated(twin), 3.0)
    perturb_lattice(lat, seed=5)
    twist.angle = twin.modifiers[0].angle = -0.5
    update()
    assert close(evaluated(obj), evaluated(twin), 3.0)
    assert not close(evaluated(obj), positions(obj.data), 3.0)


def test_animated_lattice(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    lat = make_lattice(bpy, resolution=(3, 3, 3))
    api.add_entry(obj, "LATTICE", lattice=lat)
    twin = twin_with_lattice_modifier(bpy, obj, lat)
    rest = lattice_points(lat, "co")
    for frame, amount in ((1, 0.0), (11, 0.4)):
        for i in (0, 13, 26):
            lat.data.points[i].co_deform = rest[i] + amount * np.float32([1, -0.5, 0.8])
            lat.data.points[i].keyframe_insert("co_deform", frame=frame)
        lat.location.z = 0.6 + amount
        lat.keyframe_insert("location", frame=frame)
    results = {}
    for frame in (11, 6, 1, 8):  # playback and scrubbing
        scene.frame_set(frame)
        results[frame] = evaluated(obj).copy()
        assert close(results[frame], evaluated(twin), 3.0), frame
    assert not close(results[6], results[8])


# ---------------------------------------------------------------------------------------------
# Operators: fitted lattice, bind, reset, direct manipulation

def test_add_lattice_fits_the_bounding_box(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    obj.rotation_euler, obj.scale = (0.3, -0.2, 0.5), (1.5, 0.8, 1.1)
    update()
    before = evaluated(obj).copy()
    with bpy.context.temp_override(object=obj, active_object=obj):
        assert bpy.ops.deformkit.add_lattice(resolution=(3, 4, 5), basis="BERNSTEIN") == {"FINISHED"}
    entry = obj.deformkit.entries[0]
    lat = entry.lattice
    assert (entry.type, entry.lattice_basis, entry.error) == ("LATTICE", "BERNSTEIN", "")
    assert (lat.data.points_u, lat.data.points_v, lat.data.points_w) == (3, 4, 5)
    co = positions(obj.data)
    lo, hi = lattice_box(obj, lat)
    size = (co.max(axis=0) - co.min(axis=0)).max()
    assert np.abs(lo - co.min(axis=0)).max() < 2e-4 * size and np.abs(hi - co.max(axis=0)).max() < 2e-4 * size
    assert api.bind_lattice(obj, 0).outside == 0
    np.testing.assert_array_equal(evaluated(obj), before)  # fitted at rest: nothing moves yet
    # In edit mode: fitted to the selected vertices.
    upper = co[:, 2] > 0.6
    select_vertices(obj, np.flatnonzero(upper))
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode="EDIT")
    with bpy.context.temp_override(object=obj, active_object=obj):
        assert bpy.ops.deformkit.add_lattice(resolution=(4, 4, 4), basis="BEZIER") == {"FINISHED"}
    bpy.ops.object.mode_set(mode="OBJECT")
    lo, hi = lattice_box(obj, obj.deformkit.entries[1].lattice)
    assert np.abs(lo - co[upper].min(axis=0)).max() < 2e-4 * size
    assert np.abs(hi - co[upper].max(axis=0)).max() < 2e-4 * size
    np.testing.assert_array_equal(evaluated(obj), before)
    with pytest.raises(ValueError, match="3k \\+ 1 points per axis"):
        api.add_lattice(obj, (5, 4, 4), "BEZIER")


@pytest.mark.parametrize("basis", ["BLENDER", "BERNSTEIN", "BEZIER", "BSPLINE"])
def test_direct_manipulation_reaches_the_targets(scene, basis):
    import bpy
    obj = make_object(bpy)
    obj.rotation_euler = (0.2, 0.0, 0.4)
    lat = make_lattice(bpy, resolution=(4, 4, 4), scale=(3.0, 3.0, 4.5))
    entry_settings = dict(lattice=lat, lattice_basis=basis, strength=0.8, vertex_group="Upper")
    from deformkit_addon import api
    api.add_entry(obj, "LATTICE", **entry_settings)
    z = positions(obj.data)[:, 2]
    chosen = [int(np.argmax(z)), int(np.argmin(np.abs(z - 0.4))), int(np.argmin(np.abs(z - 1.0)))]  # weighted
    select_vertices(obj, chosen)
    before = to_world(obj, evaluated(obj)[chosen])
    scene.cursor.location = before.mean(axis=0) + np.array([0.15, -0.1, 0.2])
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj]):
        assert bpy.ops.deformkit.lattice_direct(targets="CURSOR") == {"FINISHED"}
    after = to_world(obj, evaluated(obj)[chosen])
    expected = before + (np.array(scene.cursor.location) - before.mean(axis=0))
    assert np.abs(after - expected).max() < 1e-5, np.abs(after - expected).max()
    # Empties: each pulls the nearest selected vertex to itself.
    empties = []
    for k, offset in ((0, (0.1, 0.1, -0.1)), (2, (-0.1, 0.05, 0.1))):
        empty = bpy.data.objects.new(f"Target{k}", None)
        scene.collection.objects.link(empty)
        empty.location = after[k] + np.array(offset)
        empties.append(empty)
    update()
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj, *empties]):
        assert bpy.ops.deformkit.lattice_direct(targets="EMPTIES") == {"FINISHED"}
    reached = to_world(obj, evaluated(obj)[[chosen[0], chosen[2]]])
    targets = np.array([e.location for e in empties])
    assert np.abs(reached - targets).max() < 1e-5, np.abs(reached - targets).max()


def test_direct_manipulation_api_and_errors(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    lat = make_lattice(bpy, resolution=(3, 3, 3))
    api.add_entry(obj, "TWIST", angle=0.5, deform_axis="Z")
    api.add_entry(obj, "LATTICE", lattice=lat)
    vertices = [5, 100, 250]
    targets = evaluated(obj)[vertices] + np.array([0.1, 0.0, -0.1])  # the lattice is last: its output shows
    result = api.direct_manipulation(obj, 1, vertices, targets)
    assert result.max_residual < 1e-5 and result.rank == 3  # one row of weights per vertex
    assert np.abs(evaluated(obj)[vertices] - targets).max() < 1e-5
    with pytest.raises(ValueError, match="not a Lattice entry"):
        api.direct_manipulation(obj, 0, vertices, targets)
    with pytest.raises(ValueError, match="no vertices are selected"):
        api.direct_manipulation(obj, 1, [], np.zeros((0, 3)))
    select_vertices(obj, [])
    direct = bpy.ops.deformkit.lattice_direct  # an operator's error report raises in scripts
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj]):
        with pytest.raises(RuntimeError, match="no vertices of 'Obj' are selected"):
            direct(targets="CURSOR")
        select_vertices(obj, vertices)
        with pytest.raises(RuntimeError, match="select one or more empties"):
            direct(targets="EMPTIES")
    other = make_lattice(bpy, name="Unused")
    with bpy.context.temp_override(object=other, active_object=other, selected_objects=[other]):
        assert direct.poll()
        with pytest.raises(RuntimeError, match="lattice 'Unused' is not used by any deformkit entry"):
            direct(targets="CURSOR")
    with pytest.raises(ValueError, match="not a Lattice entry"):
        api.bind_lattice(obj, 0)


def test_operators_bind_and_reset(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    before = evaluated(obj).copy()
    with bpy.context.temp_override(object=obj, active_object=obj):
        assert not bpy.ops.deformkit.lattice_bind.poll()  # no Lattice entry yet
    lat = make_lattice(bpy)
    api.add_entry(obj, "LATTICE", lattice=lat)
    perturb_lattice(lat)
    update()
    assert not close(evaluated(obj), before)
    with bpy.context.temp_override(object=obj, active_object=obj):
        assert bpy.ops.deformkit.lattice_bind() == {"FINISHED"}
        assert bpy.ops.deformkit.lattice_reset() == {"FINISHED"}
    np.testing.assert_array_equal(evaluated(obj), before)
    perturb_lattice(lat)
    update()
    with bpy.context.temp_override(object=lat, active_object=lat):  # from the lattice itself
        assert bpy.ops.deformkit.lattice_reset() == {"FINISHED"}
    np.testing.assert_array_equal(evaluated(obj), before)
    np.testing.assert_array_equal(lattice_points(lat), lattice_points(lat, "co"))


def test_apply_bakes_the_lattice(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    lat = make_lattice(bpy)
    perturb_lattice(lat)
    api.add_entry(obj, "LATTICE", lattice=lat)
    shown = evaluated(obj).copy()
    with bpy.context.temp_override(object=obj, active_object=obj):
        assert bpy.ops.deformkit.entry_apply(index=0) == {"FINISHED"}
    assert len(obj.deformkit.entries) == 0
    assert close(positions(obj.data), shown)


# ---------------------------------------------------------------------------------------------
# Undo, redo, save and reload

def test_undo_redo_save_and_reload(scene, tmp_path):
    import bpy
    from deformkit_addon import api, evaluation, meshdata
    from deformkit_addon.entries import lattice as lattices
    obj = make_object(bpy)
    lat = make_lattice(bpy)
    base = evaluated(obj).copy()
    api.add_entry(obj, "LATTICE", lattice=lat, lattice_basis="BLENDER")
    bpy.ops.ed.undo_push(message="add lattice entry")
    perturb_lattice(lat)
    update()
    bpy.ops.ed.undo_push(message="edit lattice")
    edited = evaluated(obj).copy()
    with bpy.context.temp_override(object=lat, active_object=lat):  # undo=True: push a step as the UI does
        assert bpy.ops.deformkit.lattice_reset("EXEC_DEFAULT", True) == {"FINISHED"}
    np.testing.assert_array_equal(evaluated(obj), base)
    bpy.ops.ed.undo()
    obj = bpy.data.objects["Obj"]  # undo rebuilds the data: look the objects up again
    assert close(evaluated(obj), edited)
    bpy.ops.ed.undo()
    obj = bpy.data.objects["Obj"]
    np.testing.assert_array_equal(evaluated(obj), base)
    bpy.ops.ed.redo()
    obj = bpy.data.objects["Obj"]
    assert close(evaluated(obj), edited)
    bpy.ops.object.empty_add(location=(0.4, -0.3, 0.2), rotation=(0.3, 0.1, -0.5))
    api.add_entry(obj, "BEND", angle=0.8, deform_axis="X", origin=bpy.context.active_object)
    edited = evaluated(obj).copy()
    path = str(tmp_path / "lattice.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    obj, lat = bpy.data.objects["Obj"], bpy.data.objects["Lattice"]
    assert obj.deformkit.entries[0].lattice == lat
    assert close(evaluated(obj), edited)  # the frames were read after Blender computed them
    api.evaluate(obj)
    assert close(evaluated(obj), edited)
    obj.deformkit.entries.remove(1)
    assert lattices.binding_counts(meshdata.cache_key(obj), 0) is not None  # bound again on load
    twin = twin_with_lattice_modifier(bpy, obj, lat)
    perturb_lattice(lat, seed=5)  # edits after the reload still reach the entry
    update()
    assert close(evaluated(obj), evaluated(twin), 3.0)


# ---------------------------------------------------------------------------------------------
# Bad input: a message on the entry, which is skipped (its input passes through)

PROBLEMS = {
    "no_lattice": "no lattice object set",
    "not_a_lattice": "'Empty' is not a lattice object",  # scripts can bypass the pointer's poll
    "deleted": "lattice object 'Lattice' no longer exists",
    "unlinked": "lattice object 'Lattice' no longer exists",  # the handler clears the field, as Blender's
    "bezier_resolution": "the Bezier Blocks basis needs 3k + 1 points per axis",
    "bspline_resolution": "the B-Spline basis needs at least 4 points per axis",
    "bernstein_resolution": "the Bernstein basis needs 2 to 16 points per axis",
    "extrapolate_with_blender": "Outside 'Extrapolate' is not available with the Blender basis",
    "lattice_vertex_group": "weights its points by the vertex group 'Pinned'",
    "lattice_shape_keys": "lattice 'Lattice' has shape keys",
    "lattice_modifier": "lattice 'Lattice' has modifiers (Hook)",
}


@pytest.mark.parametrize("problem", list(PROBLEMS))
def test_bad_lattice_settings_leave_the_mesh_alone(scene, problem):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    lat = make_lattice(bpy, resolution=(3, 4, 2))
    perturb_lattice(lat)
    entry = api.add_entry(obj, "LATTICE", lattice=lat)
    assert entry.error == ""
    before = evaluated(obj).copy()
    if problem == "no_lattice":
        entry.lattice = None
    elif problem == "not_a_lattice":
        empty = bpy.data.objects.new("Empty", None)
        scene.collection.objects.link(empty)
        entry.lattice = empty
    elif problem == "deleted":
        bpy.data.objects.remove(lat)
    elif problem == "unlinked":  # what deleting in the viewport does while the entry holds a reference
        scene.collection.objects.unlink(lat)
    elif problem.endswith("_resolution"):
        if problem == "bernstein_resolution":
            lat.data.points_u = 17
        entry.lattice_basis = problem.split("_")[0].upper()
    elif problem == "extrapolate_with_blender":
        entry.outside = "EXTRAPOLATE"
    elif problem == "lattice_vertex_group":
        lat.vertex_groups.new(name="Pinned")
        lat.data.vertex_group = "Pinned"
    elif problem == "lattice_shape_keys":
        lat.shape_key_add(name="Basis")
    else:
        lat.modifiers.new("Hook", "HOOK")
    update()  # handlers see the change by themselves
    assert PROBLEMS[problem] in entry.error, entry.error
    if problem in ("deleted", "unlinked"):  # noticed at once, and the field cleared as Blender clears a modifier's
        assert entry.lattice is None
    assert np.abs(before - positions(obj.data)).max() > 1e-3  # the lattice did something while it worked
    # Skipped, as Blender skips a modifier it cannot run: the only entry, so the base mesh shows.
    np.testing.assert_array_equal(evaluated(obj), positions(obj.data))
    with pytest.raises(ValueError, match="Lattice: "):
        api.evaluate(obj)


def test_other_bases_accept_extrapolate_and_unchanged(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    lat = make_lattice(bpy, resolution=(4, 4, 4), scale=(1.2, 1.2, 2.0))  # part of the mesh is outside
    perturb_lattice(lat)
    entry = api.add_entry(obj, "LATTICE", lattice=lat, lattice_basis="BERNSTEIN", outside="UNCHANGED")
    base = positions(obj.data)
    bound = api.bind_lattice(obj, 0)
    outside = np.abs(evaluated(obj) - base).max(axis=1) == 0
    assert bound.outside > 0 and outside.sum() >= bound.outside  # outside vertices stay put
    entry.outside = "EXTRAPOLATE"
    assert entry.error == ""
    assert not np.array_equal(evaluated(obj)[outside], base[outside])


def test_batch_recipe_names_the_lattice(scene):
    import bpy
    from deformkit_addon import batch
    obj = make_object(bpy)
    lat = make_lattice(bpy)
    perturb_lattice(lat)
    batch.apply_recipe({"objects": ["Obj"], "deformers": [{"type": "LATTICE", "lattice": "Lattice",
                                                           "lattice_basis": "BERNSTEIN"}]})
    assert obj.deformkit.entries[0].lattice == lat and obj.deformkit.entries[0].error == ""
    with pytest.raises(batch.BatchError, match="lattice object 'Nope' not found"):
        batch.apply_recipe({"objects": ["Obj"], "deformers": [{"type": "LATTICE", "lattice": "Nope"}]})


# ---------------------------------------------------------------------------------------------
# The panel, drawn into a layout that checks every property, operator and icon it is given

def test_panel_shows_the_lattice_entry(scene):
    import types

    import bpy
    from deformkit_addon import api, ui
    obj = make_object(bpy)
    lat = make_lattice(bpy)
    api.add_entry(obj, "TWIST", angle=0.5, deform_axis="Z")
    api.add_entry(obj, "LATTICE", lattice=lat)
    log = []
    context = types.SimpleNamespace(object=obj)
    ui.DEFORMKIT_PT_stack.draw(types.SimpleNamespace(layout=CheckingLayout(log)), context)
    ui.DEFORMKIT_MT_add.draw(types.SimpleNamespace(layout=CheckingLayout(log)), context)
    drawn = {name for kind, name in log if kind != "label"}
    assert {"lattice", "lattice_basis", "outside", "strength", "vertex_group", "deformkit.lattice_bind",
            "deformkit.lattice_reset", "deformkit.lattice_direct",
            "deformkit.add_lattice"} <= drawn
    n = len(obj.data.vertices)
    assert ("label", f"Bound: {n} vertices inside, 0 outside") in log

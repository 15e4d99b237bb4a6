"""Laplacian entries in Blender, against dk.SurfaceDeformer run directly on the same rest, faces and
targets, against rigid motions, and the bind's life: undo, save and reload, apply, batch, topology
changes and bad settings."""
import math

import numpy as np
import pytest

from addon_helpers import (CheckingLayout, close, evaluated, group_members, make_tube, polygons, positions,
                           to_world, update)

METHODS = ("ARAP", "ROTATION_INVARIANT", "LAPLACIAN")


def dk():
    from deformkit_addon import native
    return native.dk


def add_empty(bpy, name="Empty", location=(0.4, -0.3, 3.8), rotation=(0.0, 0.0, 0.0)):
    empty = bpy.data.objects.new(name, None)
    bpy.context.scene.collection.objects.link(empty)
    empty.location, empty.rotation_euler = location, rotation
    update()
    return empty


def motion(obj, empty, at_bind, obj_at_bind=None):
    """The handle object's motion since bind in obj's space, written out as Blender's Hook has it:
    obj^-1 H H_bind^-1 obj_bind (obj_bind: the object's matrix at bind, default: now)."""
    world = np.array(obj.matrix_world, np.float64)
    then = world if obj_at_bind is None else obj_at_bind
    return np.linalg.inv(world) @ np.array(empty.matrix_world, np.float64) @ np.linalg.inv(at_bind) @ then


def direct(obj, rest, targets, method="ARAP", weights="COTANGENT"):
    """dk.SurfaceDeformer on the mesh's own polygons (fanned by the core), Bottom anchored, Top moved."""
    solver = dk().SurfaceDeformer(rest.astype(np.float64), polygons(obj.data), anchors=group_members(obj, "Bottom"),
                                  handles=group_members(obj, "Top"), method=method.lower(), weights=weights.lower())
    return solver.deform(targets)


def moved(points, m):
    return points.astype(np.float64) @ m[:3, :3].T + m[:3, 3]


def size(points):
    return float(np.ptp(points, axis=0).max())


def bound_tube(bpy, **params):
    """A tube with a Laplacian entry (Bottom anchored, Top following an empty; ARAP unless given),
    bound; and the empty."""
    from deformkit_addon import api
    obj = make_tube(bpy)
    empty = add_empty(bpy)
    settings = dict(anchors_group="Bottom", handles_group="Top", handle_target="OBJECT", handle_object=empty,
                    method="ARAP")
    settings.update(params)
    entry = api.add_laplacian(obj, **settings)
    assert entry.error == "" and obj.deformkit.error == "", (entry.error, obj.deformkit.error)
    return obj, entry, empty


def turn_and_shift(empty):
    empty.rotation_euler = (0.4, -0.25, 0.6)
    empty.location = (0.9, 0.1, 3.5)
    update()


# ---------------------------------------------------------------------------------------------
# Results against dk.SurfaceDeformer and rigid motions

@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("target", ["INCOMING", "OBJECT"])
def test_bound_at_rest_gives_the_mesh_back(scene, method, target):
    import bpy
    from deformkit_addon.entries import laplacian as surface
    obj, entry, _ = bound_tube(bpy, method=method, handle_target=target)
    base = positions(obj.data)
    assert close(evaluated(obj), base, size(base))
    np.testing.assert_array_equal(surface.saved_rest(entry), base)  # the rest is what came in
    n = len(base)
    assert surface.status(obj, entry) == (f"Bound: {n} vertices, 32 anchors, 33 handles", [])
    assert not any(a.name.startswith("deformkit_rest") for a in obj.data.attributes)  # not on the mesh


@pytest.mark.parametrize("method, weights", [("ARAP", "COTANGENT"), ("ROTATION_INVARIANT", "COTANGENT"),
                                             ("LAPLACIAN", "UNIFORM"), ("ARAP", "UNIFORM")])
def test_object_targets_equal_the_surface_deformer_run_directly(scene, method, weights):
    import bpy
    obj, entry, empty = bound_tube(bpy, method=method, weights=weights)
    base = positions(obj.data).copy()
    at_bind = np.array(empty.matrix_world)
    turn_and_shift(empty)  # the depsgraph handler sees the empty move
    top = group_members(obj, "Top")
    expected = direct(obj, base, moved(base[top], motion(obj, empty, at_bind)), method, weights)
    ours = evaluated(obj)
    assert np.abs(ours - base).max() > 0.1 * size(base)  # something happened
    assert close(ours, expected, size(base)), np.abs(ours - expected).max()
    bottom = group_members(obj, "Bottom")
    np.testing.assert_array_equal(ours[bottom], base[bottom])  # anchors stay put, exactly
    np.testing.assert_array_equal(positions(obj.data), base)  # the base mesh is never written


@pytest.mark.parametrize("method", METHODS)
def test_handles_alone_follow_the_empty_rigidly(scene, method):
    """With every constrained vertex a handle, the empty's rigid motion moves the whole mesh rigidly
    in world space: ARAP and the rotation-invariant passes reproduce any rigid motion (to their
    convergence), naive editing translations only."""
    import bpy
    from deformkit_addon import api
    obj = make_tube(bpy)
    ends = obj.vertex_groups.new(name="Ends")
    ends.add([int(i) for i in np.concatenate([group_members(obj, "Bottom"), group_members(obj, "Top")])], 1.0,
             "REPLACE")
    empty = add_empty(bpy, rotation=(0.1, 0.2, 0.3))
    api.add_laplacian(obj, handles_group="Ends", handle_target="OBJECT", handle_object=empty, method=method,
                      iterations=1000)
    world_rest = to_world(obj, positions(obj.data).astype(np.float64))
    at_bind = np.array(empty.matrix_world)
    empty.location = (0.7, -0.5, 4.4)  # a translation
    update()
    rigid = np.array(empty.matrix_world) @ np.linalg.inv(at_bind)
    assert np.abs(to_world(obj, evaluated(obj)) - moved(world_rest, rigid)).max() < 2e-6 * size(world_rest)
    empty.rotation_euler = (0.9, -0.4, 1.2)  # and a turn
    update()
    rigid = np.array(empty.matrix_world) @ np.linalg.inv(at_bind)
    error = np.abs(to_world(obj, evaluated(obj)) - moved(world_rest, rigid)).max() / size(world_rest)
    if method == "ARAP":
        assert error < 2e-6, error
    elif method == "ROTATION_INVARIANT":
        assert error < 1e-6, error
    else:
        assert error > 1e-2, error  # no rotations in naive editing


def test_incoming_handles_follow_earlier_entries(scene):
    import bpy
    from deformkit_addon import api, evaluation
    obj = make_tube(bpy)
    twist = api.add_entry(obj, "TWIST", angle=0.0, deform_axis="Z")
    entry = api.add_laplacian(obj, anchors_group="Bottom", handles_group="Top", method="ARAP")
    bend = api.add_entry(obj, "BEND", angle=0.5, deform_axis="X")
    assert entry.handle_target == "INCOMING" and entry.error == ""
    base = positions(obj.data).copy()
    top = group_members(obj, "Top")
    twist.angle = 1.2
    twisted = dk().SimpleDeform(mode="TWIST", angle=1.2, deform_axis="Z").deform(base)
    laplacian = direct(obj, base, twisted[top].astype(np.float64))
    expected = dk().SimpleDeform(mode="BEND", angle=0.5, deform_axis="X").deform(laplacian.astype(np.float32))
    assert close(evaluated(obj), expected, size(base)), np.abs(evaluated(obj) - expected).max()
    # The twist hidden in the viewport only: the viewport's handles stay at rest, the render's turn.
    twist.show_viewport = False
    rest_bent = dk().SimpleDeform(mode="BEND", angle=0.5, deform_axis="X").deform(base)
    assert close(evaluated(obj), rest_bent, size(base))
    render = evaluation.stored_positions(obj, "render")
    assert close(render, expected, size(base))
    assert bend.error == ""


def test_incoming_handles_follow_edits_of_the_base_mesh(scene):
    """Like hooking the handle vertices: the base mesh's handles move, the rest of it is the bind's."""
    import bmesh
    import bpy
    from deformkit_addon import api
    obj = make_tube(bpy)
    api.add_laplacian(obj, anchors_group="Bottom", handles_group="Top", method="ARAP")
    rest = positions(obj.data).copy()
    top = group_members(obj, "Top")
    update()  # the echo of the add-on's own write has passed
    co = rest.copy()
    co[top] += np.float32([0.5, 0.0, -0.3])
    co[50] += np.float32([0.2, 0.2, 0.2])  # a free vertex: its edit is not the entry's input
    obj.data.vertices.foreach_set("co", co.ravel())
    obj.data.update()
    update()
    expected = direct(obj, rest, co[top].astype(np.float64))
    assert close(evaluated(obj), expected, size(rest)), np.abs(evaluated(obj) - expected).max()
    # In edit mode with Blender's tools (a bmesh round trip keeps the topology's fingerprint).
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode="EDIT")
    bm = bmesh.from_edit_mesh(obj.data)
    bm.verts.ensure_lookup_table()
    for i in top:
        bm.verts[i].co.y += 0.4
    bmesh.update_edit_mesh(obj.data)
    bpy.ops.object.mode_set(mode="OBJECT")
    update()
    co = positions(obj.data)
    assert obj.deformkit.entries[0].error == ""
    assert close(evaluated(obj), direct(obj, rest, co[top].astype(np.float64)), size(rest))


def test_keyframed_empty_gives_per_frame_results(scene):
    import bpy
    from deformkit_addon import cache
    from deformkit_addon.entries import laplacian as surface
    obj, entry, empty = bound_tube(bpy)
    at_bind = np.array(empty.matrix_world)
    base = positions(obj.data).copy()
    top = group_members(obj, "Top")
    for frame, (x, turn) in ((1, (0.4, 0.0)), (11, (1.2, 0.8))):
        empty.location.x, empty.rotation_euler.y = x, turn
        empty.keyframe_insert("location", frame=frame)
        empty.keyframe_insert("rotation_euler", frame=frame)
    (solver,) = [cached.deformer for cached in cache.items("laplacian").values()]
    results = {}
    for frame in (11, 6, 1, 8, 6):  # playback and scrubbing, then frame 6 again
        scene.frame_set(frame)
        ours = evaluated(obj).copy()
        expected = direct(obj, base, moved(base[top], motion(obj, empty, at_bind)))
        assert close(ours, expected, size(base)), (frame, np.abs(ours - expected).max())
        if frame in results:
            np.testing.assert_array_equal(ours, results[frame])  # the same frame, the same result
        results[frame] = ours
    assert not close(results[6], results[8])
    assert close(results[1], base, size(base))  # the empty back at its bind place
    assert [s.deformer for s in cache.items("laplacian").values()] == [solver]  # one factorisation for all frames


def test_solver_is_kept_until_what_it_depends_on_changes(scene):
    import bpy
    from deformkit_addon import api, cache
    from deformkit_addon.entries import laplacian as surface
    obj, entry, empty = bound_tube(bpy)
    api.add_entry(obj, "TWIST", angle=0.3, deform_axis="Z")  # after the Laplacian entry

    def solver():
        (cached,) = cache.items("laplacian").values()
        return cached

    first = solver().deformer
    turn_and_shift(empty)
    obj.deformkit.entries[1].angle = 0.6
    assert solver().deformer is first  # targets and other entries: no new factorisation
    for name, value, rebuilt in (("method", "LAPLACIAN", True),
                                 ("iterations", 20, False),  # naive editing does not iterate
                                 ("weights", "UNIFORM", True),
                                 ("method", "ARAP", True),
                                 ("iterations", 5, True),
                                 ("handles_group", "Top", False)):  # the same group again
        before = solver().deformer
        setattr(entry, name, value)
        assert entry.error == "", (name, entry.error)
        assert (solver().deformer is not before) == rebuilt, name
    before = solver().deformer
    obj.vertex_groups["Top"].add([40], 1.0, "REPLACE")  # weight painting: the mesh changes
    obj.data.update()
    update()
    assert solver().deformer is not before and len(solver().handles) == 34


# ---------------------------------------------------------------------------------------------
# The bind's life: unbind, undo, save and reload, apply, batch

def test_unbind_passes_the_input_through_and_forgets_the_rest(scene):
    import bpy
    from deformkit_addon import api, cache
    from deformkit_addon.entries import laplacian as surface
    obj, entry, empty = bound_tube(bpy)
    base = positions(obj.data).copy()
    turn_and_shift(empty)
    assert not close(evaluated(obj), base)
    with bpy.context.temp_override(object=obj, active_object=obj):
        assert bpy.ops.deformkit.laplacian_unbind() == {"FINISHED"}
    assert entry.get(surface.REST) is None and not surface.is_bound(entry) and cache.items("laplacian") == {}
    np.testing.assert_array_equal(evaluated(obj), base)  # bit for bit
    assert entry.error == "" and surface.status(obj, entry) == ("Not bound", [])
    twist = api.add_entry(obj, "TWIST", angle=1.0, deform_axis="Z")  # an unbound entry does not block others
    api.move_entry(obj, 1, -1)
    assert twist.error == "" and entry.error == ""
    expected = dk().SimpleDeform(mode="TWIST", angle=1.0, deform_axis="Z").deform(base)
    assert close(evaluated(obj), expected)
    entry = obj.deformkit.entries[1]
    with bpy.context.temp_override(object=obj, active_object=obj):
        assert bpy.ops.deformkit.laplacian_bind() == {"FINISHED"}
    assert close(surface.saved_rest(entry), expected)  # bound to the twisted mesh coming in
    entry.type = "TWIST"  # another type: the bind goes
    assert entry.get(surface.REST) is None and not surface.is_bound(entry) and cache.items("laplacian") == {}
    entry.type = "LAPLACIAN"
    api.bind_laplacian(obj, 1)
    api.remove_entry(obj, 0)
    assert len(cache.items("laplacian")) == 1
    api.remove_entry(obj, 0)  # the last entry: its solver goes too
    assert not any(a.name.startswith("deformkit") for a in obj.data.attributes) and cache.items("laplacian") == {}


def test_undo_and_redo_of_a_bind(scene):
    import bpy
    from deformkit_addon import api, cache
    from deformkit_addon.entries import laplacian as surface
    obj = make_tube(bpy)
    empty = add_empty(bpy)
    api.add_laplacian(obj, bind=False, anchors_group="Bottom", handles_group="Top", handle_target="OBJECT",
                      handle_object=empty)
    base = positions(obj.data).copy()
    bpy.ops.ed.undo_push(message="add")
    with bpy.context.temp_override(object=obj, active_object=obj):  # undo=True: a step as the UI pushes
        assert bpy.ops.deformkit.laplacian_bind("EXEC_DEFAULT", True) == {"FINISHED"}
    turn_and_shift(empty)
    bpy.ops.ed.undo_push(message="move")
    after_move = evaluated(obj).copy()
    assert not close(after_move, base)
    bpy.ops.ed.undo()
    bpy.ops.ed.undo()
    obj = bpy.data.objects["Tube"]  # undo rebuilds the data: look the objects up again
    entry = obj.deformkit.entries[0]
    assert not surface.is_bound(entry) and entry.get(surface.REST) is None
    np.testing.assert_array_equal(evaluated(obj), base)
    bpy.ops.ed.redo()
    bpy.ops.ed.redo()
    obj = bpy.data.objects["Tube"]
    assert surface.is_bound(obj.deformkit.entries[0]) and len(cache.items("laplacian")) == 1  # built from the saved rest
    assert close(evaluated(obj), after_move, size(base))
    api.evaluate(obj)
    assert close(evaluated(obj), after_move, size(base))


def test_save_and_reload_rebuild_the_solver(scene, tmp_path):
    import bpy
    from deformkit_addon import cache
    from deformkit_addon.entries import laplacian as surface
    obj, entry, empty = bound_tube(bpy)
    at_bind = np.array(empty.matrix_world)
    turn_and_shift(empty)
    shown = evaluated(obj).copy()
    path = str(tmp_path / "laplacian.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    cache.forget(space="laplacian")
    bpy.ops.wm.open_mainfile(filepath=path)
    obj, empty = bpy.data.objects["Tube"], bpy.data.objects["Empty"]
    entry = obj.deformkit.entries[0]
    assert entry.handle_object == empty and surface.is_bound(entry)
    assert len(cache.items("laplacian")) == 1  # rebuilt on load, from the rest saved in the file
    assert close(evaluated(obj), shown)
    np.testing.assert_allclose(np.array(entry.handle_matrix).reshape(4, 4),
                               np.linalg.inv(at_bind) @ np.array(obj.matrix_world), rtol=0, atol=1e-6)
    empty.location.z += 0.3  # edits after the reload still reach the entry
    update()
    base = positions(obj.data)
    top = group_members(obj, "Top")
    expected = direct(obj, surface.saved_rest(entry), moved(base[top], motion(obj, empty, at_bind)))
    assert close(evaluated(obj), expected, size(base))


def test_apply_bakes_the_result(scene):
    import bpy
    from deformkit_addon import api
    obj, entry, empty = bound_tube(bpy)
    turn_and_shift(empty)
    shown = evaluated(obj).copy()
    with bpy.context.temp_override(object=obj, active_object=obj):
        assert bpy.ops.deformkit.entry_apply(index=0) == {"FINISHED"}
    assert len(obj.deformkit.entries) == 0 and "deformkit" not in obj.modifiers
    assert close(positions(obj.data), shown)
    assert close(evaluated(obj), shown)
    obj, entry, empty = bound_tube(bpy)  # a second tube; its topology changes before apply
    subdivide(bpy, obj)
    with pytest.raises(ValueError, match="the mesh now has"):
        api.apply(obj, 0)
    assert len(obj.deformkit.entries) == 1


def test_batch_evaluates_a_saved_laplacian_entry(scene, tmp_path):
    import bpy
    from deformkit_addon import batch
    from deformkit_addon.entries import laplacian as surface
    obj, entry, empty = bound_tube(bpy, method="ROTATION_INVARIANT")
    at_bind = np.array(empty.matrix_world)
    empty.location.y += 0.4
    update()
    path, out = str(tmp_path / "in.blend"), str(tmp_path / "out.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    result = batch.process(path, out)
    assert result["status"] == "ok", result
    assert result["objects"][0]["entries"] == ["LAPLACIAN"]
    bpy.ops.wm.open_mainfile(filepath=out)
    obj, empty = bpy.data.objects["Tube"], bpy.data.objects["Empty"]
    base = positions(obj.data)
    top = group_members(obj, "Top")
    expected = direct(obj, surface.saved_rest(obj.deformkit.entries[0]),
                      moved(base[top], motion(obj, empty, at_bind)), "ROTATION_INVARIANT")
    assert np.abs(expected - base).max() > 0.1
    assert close(evaluated(obj), expected, size(base))


def test_batch_recipe_binds_laplacian_entries(scene):
    import bpy
    from deformkit_addon import batch
    from deformkit_addon.entries import laplacian as surface
    obj = make_tube(bpy)
    add_empty(bpy, "Handle")
    spec = {"type": "LAPLACIAN", "anchors_group": "Bottom", "handles_group": "Top", "handle_target": "OBJECT",
            "handle_object": "Handle", "bind": True}
    batch.apply_recipe({"objects": ["Tube"], "deformers": [spec]})
    entry = obj.deformkit.entries[0]
    assert surface.is_bound(entry) and entry.error == "" and entry.handle_object.name == "Handle"
    with pytest.raises(batch.BatchError, match="handle_object object 'Nope' not found"):
        batch.apply_recipe({"objects": ["Tube"], "deformers": [{**spec, "handle_object": "Nope"}]})
    with pytest.raises(batch.BatchError, match=r"deformers\[0\].bind: not a key here"):
        batch.apply_recipe({"objects": ["Tube"], "deformers": [{"type": "TWIST", "bind": True}]})


# ---------------------------------------------------------------------------------------------
# Topology changes and bad input: a message on the entry, which is skipped (its input passes through)

def subdivide(bpy, obj):
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.subdivide(number_cuts=1)
    bpy.ops.object.mode_set(mode="OBJECT")
    update()


def edit_topology(obj, change):
    import bmesh
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bm.verts.ensure_lookup_table()
    if change == "delete_vertex":
        bmesh.ops.delete(bm, geom=[bm.verts[100]], context="VERTS")
    else:  # turn an edge of the top's triangle fan: as many vertices and faces, other triangles
        top = bm.verts[len(bm.verts) - 1]
        edge = next(e for e in top.link_edges if len(e.link_faces) == 2)
        bmesh.ops.rotate_edges(bm, edges=[edge], use_ccw=False)
    bm.to_mesh(obj.data)
    bm.free()
    obj.data.update()
    update()


@pytest.mark.parametrize("change, message", [
    ("delete_vertex", "bound to 321 vertices and 321 faces, the mesh now has 320 and 317: Rebind"),
    ("subdivide", "bound to 321 vertices and 321 faces, the mesh now has 1 265 and 1 281: Rebind"),
    ("rotate_edge", "the mesh's faces connect its vertices differently than at bind (321 vertices and 321 faces, "
                    "as then): Rebind"),
])
def test_topology_changes_are_reported(scene, change, message):
    import bpy
    from deformkit_addon import api
    obj, entry, empty = bound_tube(bpy)
    turn_and_shift(empty)
    update()  # the echo of the add-on's own write has passed
    before = evaluated(obj).copy()
    assert np.abs(before - positions(obj.data)).max() > 1e-3  # the entry did something while it worked
    if change == "subdivide":
        subdivide(bpy, obj)
    else:
        edit_topology(obj, change)
    if change != "rotate_edge":
        # Seen by the handler. An edit that keeps the vertex count, made by a script within a second
        # of the add-on's own write, passes for that write's echo (evaluation.is_echo_of_own_write);
        # the next evaluation, asked for here, finds it.
        assert entry.error == message, entry.error
    with pytest.raises(ValueError, match="Laplacian: (bound to|the mesh's faces)"):
        api.evaluate(obj)
    assert entry.error == message, entry.error
    # Skipped, as Blender skips a modifier it cannot run: the only entry, so the base mesh shows.
    np.testing.assert_array_equal(evaluated(obj), positions(obj.data))
    api.unbind_laplacian(obj, 0)
    api.bind_laplacian(obj, 0)  # bound to the new mesh: fine again
    assert entry.error == "" and entry.bind_vertices == len(obj.data.vertices)
    assert close(evaluated(obj), positions(obj.data), size(positions(obj.data)))


PROBLEMS = {
    "anchors_group_removed": "anchors vertex group 'Bottom' not found",
    "handles_group_removed": "handles vertex group 'Top' not found",
    "no_groups": "no anchors and no handles: set the vertex group that stays (Anchors)",
    "zero_weights": "the anchors and handles vertex groups have no vertex with a weight above 0",
    "both_groups": "33 vertices are in both the anchors group 'Top' and the handles group 'Top'",
    "handle_object_deleted": "handle object 'Empty' no longer exists",
    "handle_object_unlinked": "handle object 'Empty' no longer exists",  # the handler clears the field
    "no_handle_object": "no handle object set",
    "nan_location": "handle object 'Empty': its transform is not finite (NaN or Inf)",
    "singular_at_bind": "the handle object's transform was singular when it was set",
}


def prepare(bpy, obj, entry, empty, problem):
    """Valid settings on the way to the problem (their results are fine, and shown)."""
    if problem in ("no_groups", "zero_weights"):
        entry.anchors_group = ""  # handles alone
        obj.vertex_groups.new(name="Zero").add([1, 2, 3], 0.0, "REPLACE")
    elif problem == "singular_at_bind":
        empty.scale = (1.0, 0.0, 1.0)  # the handles flattened
        update()
        entry.handle_object = None


def make_problem(bpy, scene, obj, entry, empty, problem):
    if problem.endswith("_group_removed"):
        obj.vertex_groups.remove(obj.vertex_groups["Bottom" if problem.startswith("anchors") else "Top"])
        entry.iterations = 11  # any edit of the entry evaluates it
    elif problem in ("no_groups", "zero_weights"):
        entry.handles_group = "" if problem == "no_groups" else "Zero"
    elif problem == "both_groups":
        entry.anchors_group = "Top"
    elif problem == "handle_object_deleted":
        bpy.data.objects.remove(empty)
    elif problem == "handle_object_unlinked":  # what deleting in the viewport does while the entry holds it
        scene.collection.objects.unlink(empty)
    elif problem == "no_handle_object":
        entry.handle_object = None
    elif problem == "nan_location":
        empty.location.x = math.nan
    else:  # a handle object picked while flat: its matrix then is recorded, and cannot be inverted
        entry.handle_object = empty
        empty.scale = (1.0, 1.0, 1.0)


@pytest.mark.parametrize("problem", list(PROBLEMS))
def test_bad_settings_leave_the_mesh_alone(scene, problem):
    import bpy
    from deformkit_addon import api
    obj, entry, empty = bound_tube(bpy)
    turn_and_shift(empty)
    prepare(bpy, obj, entry, empty, problem)
    update()
    before = evaluated(obj).copy()
    make_problem(bpy, scene, obj, entry, empty, problem)
    update()  # handlers see the change by themselves
    assert PROBLEMS[problem] in entry.error, entry.error
    if problem != "singular_at_bind":  # prepared without a handle object, that one never worked
        assert np.abs(before - positions(obj.data)).max() > 1e-3  # the entry did something while it worked
    # Skipped, as Blender skips a modifier it cannot run: the only entry, so the base mesh shows.
    np.testing.assert_array_equal(evaluated(obj), positions(obj.data))
    with pytest.raises(ValueError, match="Laplacian: "):
        api.evaluate(obj)


@pytest.mark.parametrize("problem, message", [
    ("no_groups", "no anchors and no handles"),
    ("missing_group", "handles vertex group 'Gone' not found"),
    ("flat_empty", "handle object 'Empty' has a singular or non-finite transform (scale 0?)"),
    ("no_faces", "the mesh has no faces"),
    ("edit_mode", "leave edit mode first"),
])
def test_bind_refuses_bad_settings_and_stays_unbound(scene, problem, message):
    import bmesh
    import bpy
    from deformkit_addon import api
    from deformkit_addon.entries import laplacian as surface
    obj = make_tube(bpy)
    empty = add_empty(bpy)
    settings = dict(anchors_group="Bottom", handles_group="Top", handle_target="OBJECT", handle_object=empty)
    if problem == "no_groups":
        settings.update(anchors_group="", handles_group="")
    elif problem == "missing_group":
        settings.update(handles_group="Gone")
    elif problem == "flat_empty":
        empty.scale = (0.0, 1.0, 1.0)
        update()
    elif problem == "no_faces":
        bm = bmesh.new()
        bm.from_mesh(obj.data)
        bmesh.ops.delete(bm, geom=list(bm.faces), context="FACES_ONLY")
        bm.to_mesh(obj.data)
        bm.free()
    entry = api.add_laplacian(obj, bind=False, **settings)
    if problem == "edit_mode":
        bpy.ops.object.mode_set(mode="EDIT")
    with pytest.raises(ValueError, match=message.replace("(", "\\(").replace(")", "\\)").replace("?", "\\?")):
        api.bind_laplacian(obj, 0)
    assert not surface.is_bound(entry) and entry.get(surface.REST) is None and entry.error == ""
    with bpy.context.temp_override(object=obj, active_object=obj):
        if problem == "edit_mode":
            assert not bpy.ops.deformkit.laplacian_bind.poll()
            bpy.ops.object.mode_set(mode="OBJECT")
        else:  # an operator's error report raises in scripts
            with pytest.raises(RuntimeError, match="Error: "):
                bpy.ops.deformkit.laplacian_bind()


def test_scripting_api_rejects_bad_calls(scene):
    import bpy
    from deformkit_addon import api
    obj = make_tube(bpy)
    api.add_entry(obj, "TWIST")
    with pytest.raises(ValueError, match="entry 'Twist' is a Twist entry, not a Laplacian entry"):
        api.bind_laplacian(obj, 0)
    with pytest.raises(IndexError):
        api.unbind_laplacian(obj, 3)
    with bpy.context.temp_override(object=obj, active_object=obj):
        assert not bpy.ops.deformkit.laplacian_bind.poll()  # no Laplacian entry


# ---------------------------------------------------------------------------------------------
# Volume colors and the panel

def test_volume_colors_leave_out_laplacian_entries(scene):
    import bpy
    from deformkit_addon import api, evaluation, outputs
    obj, entry, empty = bound_tube(bpy)
    at_bind = np.array(empty.matrix_world)
    turn_and_shift(empty)
    api.add_entry(obj, "TAPER", factor=0.4, deform_axis="Z")  # after the Laplacian entry: det J at its output
    obj.deformkit.show_volume_ratio = True
    assert obj.deformkit.error == "" and entry.error == ""
    base = positions(obj.data)
    top = group_members(obj, "Top")
    laplacian_out = direct(obj, base, moved(base[top], motion(obj, empty, at_bind))).astype(np.float32)
    rgba = np.empty(len(base) * 4, np.float32)
    obj.data.attributes[outputs.ATTR_VOLUME].data.foreach_get("color", rgba)
    ratio = dk().SimpleDeform(mode="TAPER", factor=0.4, deform_axis="Z").volume_ratio(laplacian_out)
    green = 1 - np.abs(np.clip(np.log2(ratio), -1, 1))  # the green channel: 1 - |log2 det J|, clamped
    assert np.abs(rgba.reshape(-1, 4)[:, 1] - green).max() < 1e-4
    assert np.ptp(green) > 0.05


def test_panel_shows_the_laplacian_entry(scene):
    import types

    import bmesh
    import bpy
    from deformkit_addon import api, panel_text, ui
    obj = make_tube(bpy)
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bm.verts.new((3.0, 0.0, 0.0))  # a loose vertex: a component without anchors or handles
    bm.to_mesh(obj.data)
    bm.free()
    entry = api.add_laplacian(obj, bind=False, anchors_group="Bottom", handles_group="Top",
                              handle_target="OBJECT", handle_object=add_empty(bpy))
    context = types.SimpleNamespace(object=obj)

    def draw():
        log = []
        ui.DEFORMKIT_PT_stack.draw(types.SimpleNamespace(layout=CheckingLayout(log)), context)
        return log

    log = draw()
    drawn = {name for kind, name in log if kind != "label"}
    assert {"method", "weights", "iterations", "anchors_group", "handles_group", "handle_target", "handle_object",
            "deformkit.laplacian_bind"} <= drawn
    assert ("label", "Not bound") in log
    api.bind_laplacian(obj, 0)
    obj.deformkit.show_volume_ratio = True
    log = draw()
    assert ("operator", "deformkit.laplacian_unbind") in log
    assert ("label", "Bound: 322 vertices, 32 anchors, 33 handles") in log
    assert ("label", "1 unanchored part stays in place") in log
    assert ("operator", "deformkit.laplacian_select_unanchored") in log
    labels = [text for kind, text in log if kind == "label"]
    note = panel_text.wrap("Volume colors leave out Laplacian entries (no Jacobian)", panel_text.char_budget())
    assert labels[labels.index(note[0]):][:len(note)] == note
    entry.anchors_group = "Missing"
    assert ("label", "anchors vertex group 'Missing' not found") in draw()
    log = []
    ui.DEFORMKIT_MT_add.draw(types.SimpleNamespace(layout=CheckingLayout(log)), context)
    assert ("operator", "deformkit.entry_add") in log


def test_moving_the_object_follows_blenders_hook(scene):
    """Handles follow the handle object as a Hook modifier would: an empty left in place while the
    mesh object moves holds the handles in the world; an empty parented to the object moves with it
    and deforms nothing."""
    import bpy
    obj, entry, empty = bound_tube(bpy)
    base = positions(obj.data)
    at_bind, obj_at_bind = np.array(empty.matrix_world), np.array(obj.matrix_world)
    top = group_members(obj, "Top")
    obj.location = (0.7, -0.4, 0.2)
    obj.rotation_euler = (0.0, 0.0, 0.5)
    update()
    m = motion(obj, empty, at_bind, obj_at_bind)
    assert np.abs(m - np.eye(4)).max() > 0.1  # the handles do move relative to the object
    targets = base[top].astype(np.float64) @ m[:3, :3].T + m[:3, 3]
    assert close(evaluated(obj), direct(obj, base, targets), size(base))
    world_top = (np.array(obj.matrix_world) @ np.c_[evaluated(obj)[top], np.ones(len(top))].T).T[:, :3]
    world_then = (obj_at_bind @ np.c_[base[top], np.ones(len(top))].T).T[:, :3]
    np.testing.assert_allclose(world_top, world_then, rtol=0, atol=1e-4)  # held in the world

    obj2, entry2, empty2 = bound_tube(bpy)
    base2 = positions(obj2.data)
    empty2.parent = obj2
    empty2.matrix_parent_inverse = obj2.matrix_world.inverted()
    update()
    obj2.location = (-1.0, 2.0, 0.5)
    obj2.rotation_euler = (0.3, 0.0, -0.4)
    update()
    assert close(evaluated(obj2), base2, size(base2))  # moved together: no deformation


def test_every_evaluation_of_a_drag_is_the_one_from_rest(scene, monkeypatch):
    """A handle dragged at one frame, in a window: each ARAP evaluation is dk.SurfaceDeformer's from
    R = I on the same targets (to float32 rounding: the add-on's targets come from float32
    matrices), whatever was evaluated before it, and so is the next frame's. (Before issue 31 the
    viewport started each from the last results, and the shown result depended on the drag.)"""
    import bpy
    from test_laplacian_determinism import as_in_a_window
    as_in_a_window(monkeypatch)
    obj, entry, empty = bound_tube(bpy, method="ARAP", iterations=2)
    at_bind = np.array(empty.matrix_world)
    base = positions(obj.data).copy()
    top = group_members(obj, "Top")
    cold = dk().SurfaceDeformer(base.astype(np.float64), polygons(obj.data), anchors=group_members(obj, "Bottom"),
                                handles=top, iterations=2)
    for step in range(1, 16):  # the empty dragged in small steps
        empty.location.x, empty.rotation_euler.y = 0.4 + 0.05 * step, 0.04 * step
        update()
        targets = moved(base[top], motion(obj, empty, at_bind))
        assert np.abs(evaluated(obj) - cold.deform(targets)).max() < 1e-5 * size(base), step
    scene.frame_set(scene.frame_current + 1)  # at another frame (playback), the handle moved
    empty.location.x += 0.05
    update()
    targets = moved(base[top], motion(obj, empty, at_bind))
    assert np.abs(evaluated(obj) - cold.deform(targets)).max() < 1e-5 * size(base)

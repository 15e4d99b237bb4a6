"""Generate Cage (Object menu, and the Cage entry's panel while no cage is set): a cage object
around the active mesh's evaluated shape in world space, as wire, set as the Cage entry's Object
and bound; its redo settings, undo, and the cage's enclosure checked by winding numbers."""
import numpy as np

from addon_helpers import evaluated, make_object, positions


def world_points(obj):
    return positions(obj.data).astype(np.float64) @ np.array(obj.matrix_world)[:3, :3].T + np.array(obj.matrix_world)[:3, 3]


def cage_arrays(cage):
    faces = [list(p.vertices) for p in cage.data.polygons]
    world = np.array(cage.matrix_world)
    return positions(cage.data).astype(np.float64) @ world[:3, :3].T + world[:3, 3], faces


def winding(points, cage_points, faces):
    """Sum of the solid angles of the fanned faces at each point over 4 pi (Van Oosterom, Strackee 1983)."""
    tri = np.array([(f[0], f[i], f[i + 1]) for f in faces for i in range(1, len(f) - 1)])
    e = cage_points[tri][None] - points[:, None, None]
    a, b, c = e[:, :, 0], e[:, :, 1], e[:, :, 2]
    la, lb, lc = (np.linalg.norm(v, axis=2) for v in (a, b, c))
    det = np.einsum("kti,kti->kt", a, np.cross(b, c))
    den = la * lb * lc + (a * b).sum(2) * lc + (b * c).sum(2) * la + (c * a).sum(2) * lb
    return 2 * np.arctan2(det, den).sum(axis=1) / (4 * np.pi)


def test_generate_cage_makes_binds_and_encloses(scene):
    import bpy
    obj = make_object(bpy)
    obj.rotation_euler = (0.3, 0.2, 0.1)
    obj.scale = (1.5, 1.0, 0.8)
    bpy.context.view_layer.update()
    rest = evaluated(obj).copy()
    assert bpy.ops.deformkit.generate_cage(max_faces=60) == {"FINISHED"}
    cage = bpy.data.objects["Obj Cage"]
    assert cage.display_type == "WIRE" and set(cage.users_collection) == set(obj.users_collection)
    points, faces = cage_arrays(cage)
    assert len(faces) <= 60
    w = winding(world_points(obj), points, faces)
    assert np.all(np.abs(w - 1) < 1e-6)  # every vertex of the world-space mesh inside
    entry = obj.deformkit.entries[0]
    assert entry.type == "CAGE" and entry.cage == cage and entry.bind_vertices == len(cage.data.vertices)
    np.testing.assert_allclose(evaluated(obj), rest, atol=1e-5)  # bound at rest: the mesh as it is
    co = positions(cage.data)
    co[:, 2] += 0.5 * (co[:, 2] > np.median(co[:, 2]))  # the cage's upper half lifted: the mesh follows
    cage.data.vertices.foreach_set("co", co.ravel())
    cage.data.update()
    bpy.context.view_layer.update()
    moved = evaluated(obj)
    assert np.all(np.isfinite(moved)) and np.abs(moved - rest).max() > 0.1


def test_redo_settings_quads_and_an_existing_cage_entry(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    api.add_entry(obj, "TWIST", angle=0.5)
    api.add_entry(obj, "CAGE")
    obj.deformkit.active_index = 0  # a Twist entry is active: the unset Cage entry gets the cage
    assert bpy.ops.deformkit.generate_cage(max_faces=40, quads=True, offset=0.05) == {"FINISHED"}
    entry = obj.deformkit.entries[1]
    cage = entry.cage
    assert cage is not None and cage.name == "Obj Cage" and len(obj.deformkit.entries) == 2
    sizes = [len(p.vertices) for p in cage.data.polygons]
    assert set(sizes) <= {3, 4} and 4 in sizes and sum(s - 2 for s in sizes) <= 40
    # The gap is the offset asked for: the cage's vertices are about 0.05 from the mesh, never closer
    # than the wrap's Steiner points (offset) nor farther than the budget's hull needs.
    mesh = world_points(obj)
    gaps = np.min(np.linalg.norm(cage_arrays(cage)[0][:, None] - mesh[None], axis=2), axis=1)
    assert gaps.min() > 0.02


def test_the_panel_offers_it_while_no_cage_is_set_and_it_is_undoable(scene):
    import bpy
    from deformkit_addon import api, entries
    obj = make_object(bpy)
    api.add_entry(obj, "CAGE")
    log = []

    class Layout:
        def __getattr__(self, name):
            return lambda *a, **k: log.append((name, a)) or Recorder()

    class Recorder(Layout):
        def __setattr__(self, key, value):
            log.append(("set", (key, value)))

    entries.kind("CAGE").draw(Layout(), obj, obj.deformkit.entries[0])
    assert ("operator", ("deformkit.generate_cage",)) in log and ("set", ("index", 0)) in log
    bpy.ops.ed.undo_push(message="start")
    assert bpy.ops.deformkit.generate_cage() == {"FINISHED"}
    bpy.ops.ed.undo_push(message="generated")
    log.clear()
    obj = bpy.data.objects["Obj"]
    entries.kind("CAGE").draw(Layout(), obj, obj.deformkit.entries[0])
    assert ("operator", ("deformkit.generate_cage",)) not in log  # a cage is set: no offer
    bpy.ops.ed.undo()
    obj = bpy.data.objects["Obj"]
    assert "Obj Cage" not in bpy.data.objects and obj.deformkit.entries[0].cage is None


def test_it_needs_a_mesh_in_object_mode(scene):
    import bpy
    bpy.ops.object.empty_add()
    assert not bpy.ops.deformkit.generate_cage.poll()
    obj = make_object(bpy)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode="EDIT")
    assert not bpy.ops.deformkit.generate_cage.poll()
    bpy.ops.object.mode_set(mode="OBJECT")
    assert bpy.ops.deformkit.generate_cage.poll()
    assert bpy.ops.deformkit.generate_cage(max_faces=2) == {"FINISHED"}  # Max Faces stops at 4
    cage = bpy.data.objects["Obj Cage"]
    assert len(cage.data.polygons) == 4
    assert np.all(np.abs(winding(world_points(obj), *cage_arrays(cage)) - 1) < 1e-6)

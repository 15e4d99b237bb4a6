"""Cage entries against dk.MeanValueCage / dk.GreenCage run directly on the same points, with the
cage driven the ways Mesh Deform's cage is: edited, in Edit Mode, shape-keyed, rigged, moved."""
import numpy as np
import pytest

from addon_helpers import close, evaluated, make_object, positions

METHODS = {"MEAN_VALUE": "MeanValueCage", "GREEN": "GreenCage"}


def cage_around(bpy, obj, name="Cage", margin=0.3):
    """A cube mesh object around obj's bounding box (outward faces), at the world origin."""
    world = np.array(obj.matrix_world)
    co = positions(obj.data).astype(np.float64) @ world[:3, :3].T + world[:3, 3]
    lo, hi = co.min(0) - margin, co.max(0) + margin
    bpy.ops.mesh.primitive_cube_add(location=(0, 0, 0))
    cage = bpy.context.active_object
    cage.name = name
    corners = positions(cage.data)
    corners = np.where(corners > 0, hi, lo).astype(np.float32)
    cage.data.vertices.foreach_set("co", corners.ravel())
    cage.data.update()
    return cage


def cage_in(obj, cage):
    """The cage's evaluated points in obj's space, and its faces."""
    import bpy
    dg = bpy.context.evaluated_depsgraph_get()
    mesh = cage.evaluated_get(dg).to_mesh()
    co = positions(mesh).astype(np.float64)
    faces = [list(p.vertices) for p in mesh.polygons]
    cage.evaluated_get(dg).to_mesh_clear()
    local = np.array(obj.matrix_world.inverted() @ cage.matrix_world)
    return co @ local[:3, :3].T + local[:3, 3], faces


def expected(obj, method, rest, faces, cage):
    from deformkit_addon.native import dk
    deformer = getattr(dk, METHODS[method])(rest, faces)
    deformer.cage_points = cage_in(obj, cage)[0]
    return deformer.deform(positions(obj.data).astype(np.float64))


def bound(bpy, method):
    from deformkit_addon import api
    obj = make_object(bpy)
    cage = cage_around(bpy, obj)
    api.add_entry(obj, "CAGE", cage=cage, cage_method=method)
    rest, faces = cage_in(obj, cage)
    assert close(evaluated(obj), positions(obj.data))  # unbound: the mesh as it is, as Mesh Deform
    api.bind_cage(obj, 0)
    np.testing.assert_array_equal(evaluated(obj), positions(obj.data))  # at rest: the identity
    return obj, cage, rest, faces


@pytest.mark.parametrize("method", sorted(METHODS))
def test_cage_edits_drive_the_mesh(scene, method):
    import bpy
    obj, cage, rest, faces = bound(bpy, method)
    co = positions(cage.data)
    co[co[:, 2] > 0, 0] += 0.5  # the cage's top leans
    cage.data.vertices.foreach_set("co", co.ravel())
    cage.data.update()
    bpy.context.view_layer.update()
    assert close(evaluated(obj), expected(obj, method, rest, faces, cage), 3.0)
    cage.location.x += 1.0  # moving the cage object moves the mesh, as with Mesh Deform
    bpy.context.view_layer.update()
    assert close(evaluated(obj), expected(obj, method, rest, faces, cage), 3.0)


def test_a_rigged_shape_keyed_cage_drives_the_mesh(scene):
    import bpy
    obj, cage, rest, faces = bound(bpy, "MEAN_VALUE")
    cage.shape_key_add(name="Basis")
    key = cage.shape_key_add(name="Wide", from_mix=False)
    co = positions(cage.data)
    co[:, 0] *= 1.3
    key.data.foreach_set("co", co.ravel())
    key.value = 0.5
    bpy.context.view_layer.update()
    assert close(evaluated(obj), expected(obj, "MEAN_VALUE", rest, faces, cage), 3.0)
    wave = cage.modifiers.new("Twist", "SIMPLE_DEFORM")  # any modifier on the cage: its evaluated mesh counts
    wave.angle = 0.4
    bpy.context.view_layer.update()
    assert close(evaluated(obj), expected(obj, "MEAN_VALUE", rest, faces, cage), 3.0)


def test_cage_in_edit_mode(scene):
    import bmesh
    import bpy
    obj, cage, rest, faces = bound(bpy, "GREEN")
    for o in bpy.context.view_layer.objects:
        o.select_set(o == cage)
    bpy.context.view_layer.objects.active = cage
    bpy.ops.object.mode_set(mode="EDIT")
    bm = bmesh.from_edit_mesh(cage.data)
    for v in bm.verts:
        if v.co.y > 0:
            v.co.y += 0.4
    bmesh.update_edit_mesh(cage.data)
    bpy.context.view_layer.update()
    assert close(evaluated(obj), expected(obj, "GREEN", rest, faces, cage), 3.0)
    bpy.ops.object.mode_set(mode="OBJECT")


def test_cage_problems_show_on_the_entry(scene):
    import bmesh
    import bpy
    from deformkit_addon import api
    from deformkit_addon.entries import cage as cages
    obj, cage, rest, faces = bound(bpy, "MEAN_VALUE")
    entry = obj.deformkit.entries[0]
    bm = bmesh.new()
    bm.from_mesh(cage.data)
    bmesh.ops.subdivide_edges(bm, edges=bm.edges[:1], cuts=1)
    bm.to_mesh(cage.data)
    bm.free()
    cage.data.update()
    bpy.context.view_layer.update()
    assert entry.error == "bound to 8 vertices, the cage now has 9: Rebind"
    np.testing.assert_array_equal(evaluated(obj), positions(obj.data))  # skipped, as a broken modifier
    api.bind_cage(obj, 0)  # bound again to 9 vertices (a rest of another length replaces the old one)
    assert entry.error == "" and len(entry[cages.REST]) == 27
    np.testing.assert_array_equal(evaluated(obj), positions(obj.data))
    bpy.data.objects.remove(cage)
    bpy.context.view_layer.update()
    assert entry.cage is None and "cage object 'Cage' no longer exists" in entry.error
    open_cage = cage_around(bpy, obj, "Open")
    bm = bmesh.new()
    bm.from_mesh(open_cage.data)
    bm.faces.ensure_lookup_table()
    bm.faces.remove(bm.faces[0])
    bm.to_mesh(open_cage.data)
    bm.free()
    entry.cage = open_cage
    with pytest.raises(ValueError, match="edge"):
        api.bind_cage(obj, 0)

"""The Subdivide entry numbers its result as Blender's Subdivision Surface modifier does: every
vertex, edge, face (with its first corner) and UV corner at the same index, so index-based tools
(Data Transfer by index, caches, shape keys on the result) see the same mesh behind either."""
import numpy as np
import pytest

from addon_helpers import bare_twin, make_object, positions, update


def mesh_object(bpy, name, points, faces):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(map(float, p)) for p in points], [], [list(map(int, f)) for f in faces])
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    obj.location = (0.2, -0.1, 0.3)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def make_cube(bpy):
    """Blender's cube (with its UV map): closed, all vertices of valence 3."""
    bpy.ops.mesh.primitive_cube_add(size=2.0, location=(0.1, 0.2, 0.3))
    return bpy.context.active_object


def make_grid(bpy):
    """An open, bumpy grid: a boundary, corners of valence 2."""
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=4, y_subdivisions=3, size=2.0)
    obj = bpy.context.active_object
    co = positions(obj.data)
    co[:, 2] = 0.3 * np.sin(2 * co[:, 0]) * np.cos(3 * co[:, 1])
    obj.data.vertices.foreach_set("co", co.ravel())
    obj.data.update()
    return obj


def make_mixed(bpy):
    """Quads, triangles and a pentagon, faces starting at various corners, edges both ways."""
    points = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0.3), (2, 1, 0), (3, 0.5, 0), (1, 2, 0),
              (0.5, 0.2, 1)]
    faces = [(0, 1, 4, 3), (5, 4, 1, 2), (2, 6, 5), (7, 3, 4), (4, 5, 6, 7, 8)]
    return mesh_object(bpy, "Mixed", points, faces)


def make_creased_sphere(bpy):
    """The add-on tests' sphere with a sharp and a semi-sharp edge and a creased vertex."""
    from test_subdivide_addon import set_creases
    obj = make_object(bpy)
    set_creases(bpy, obj.data, edges={0: 1.0, 7: 0.4}, vertices={5: 0.7})
    return obj


MESHES = {"cube": make_cube, "grid": make_grid, "mixed": make_mixed, "creased": make_creased_sphere}


def topology(bpy, obj):
    """(positions, edges (E, 2), polygons as vertex lists, per-corner UVs or None) of what Blender shows."""
    ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = ev.to_mesh()
    try:
        edges = np.empty(len(mesh.edges) * 2, np.int32)
        mesh.edges.foreach_get("vertices", edges)
        uvs = None
        if mesh.uv_layers.active is not None:
            uvs = np.empty(len(mesh.loops) * 2, np.float32)
            mesh.uv_layers.active.data.foreach_get("uv", uvs)
            uvs = uvs.reshape(-1, 2)
        faces = [tuple(p.vertices) for p in mesh.polygons]
        problems = mesh.validate(verbose=False)
        return positions(mesh), edges.reshape(-1, 2), faces, uvs, problems
    finally:
        ev.to_mesh_clear()


CASES = [(mesh, level, limit) for mesh in ("cube", "grid", "mixed", "creased") for level in (1, 2, 3)
         for limit in (False, True)]


@pytest.mark.parametrize("mesh, level, limit", CASES, ids=[f"{m}-{lv}-{'limit' if li else 'refined'}"
                                                           for m, lv, li in CASES])
def test_vertices_edges_faces_and_uvs_are_numbered_as_blenders_modifier(scene, mesh, level, limit):
    import bpy
    from deformkit_addon import api
    obj = MESHES[mesh](bpy)
    entry = api.add_entry(obj, "SUBDIVIDE", levels=level, use_limit_surface=limit)
    assert entry.error == "" and obj.deformkit.error == ""
    twin = bare_twin(bpy, obj)
    mod = twin.modifiers.new("Subdivision", "SUBSURF")
    mod.levels, mod.use_limit_surface, mod.quality = level, limit, 10
    update()
    ours, ours_edges, ours_faces, ours_uvs, problems = topology(bpy, obj)
    theirs, their_edges, their_faces, their_uvs, _ = topology(bpy, twin)
    assert not problems  # the edges written with the polygons make a valid mesh
    diagonal = float(np.linalg.norm(np.ptp(theirs, axis=0)))
    assert ours.shape == theirs.shape
    gap = float(np.linalg.norm(ours - theirs, axis=1).max())
    assert gap < 1e-5 * diagonal, gap / diagonal  # vertex i is Blender's vertex i
    np.testing.assert_array_equal(ours_edges, their_edges)  # edge i joins the same two vertices
    assert ours_faces == their_faces  # face i: the same corners from the same first corner
    assert (ours_uvs is None) == (their_uvs is None)
    if ours_uvs is not None:  # on the limit surface Blender's UVs are its own limit (2e-4 off at most here),
        # far closer than one UV step (1/64 at level 3) than the next corner's
        assert np.abs(ours_uvs - their_uvs).max() < (1e-3 if limit else 1e-5)


def test_numbering_follows_new_cages(scene):
    """New cages of the same topology (the kept refined topology and numbering) stay numbered as
    Blender's modifier numbers them."""
    import bpy
    from deformkit_addon import api
    obj = make_mixed(bpy)
    api.add_entry(obj, "SUBDIVIDE", levels=2, use_limit_surface=False)
    twin = bare_twin(bpy, obj)
    mod = twin.modifiers.new("Subdivision", "SUBSURF")
    mod.levels, mod.use_limit_surface = 2, False
    update()
    for step in range(2):
        for o in (obj, twin):
            co = positions(o.data)
            co[:, 2] += 0.2 * np.sin(co[:, 0] + step)
            o.data.vertices.foreach_set("co", co.ravel())
            o.data.update()
        update()
        ours, theirs = topology(bpy, obj), topology(bpy, twin)
        assert np.abs(ours[0] - theirs[0]).max() < 1e-5
        np.testing.assert_array_equal(ours[1], theirs[1])
        assert ours[2] == theirs[2]


def test_a_loose_edge_keeps_dks_order(scene):
    """Blender subdivides a loose edge too, dk does not: the entry then keeps dk's numbering (its
    vertices are the modifier's but for the loose edge's inner ones) and writes a valid mesh."""
    import bpy
    from deformkit_addon import api
    obj = make_grid(bpy)
    mesh = obj.data
    mesh.edges.add(1)
    mesh.edges[-1].vertices = (0, 6)  # a diagonal of the first quad: in no face
    mesh.update()
    assert len(mesh.edges) == len({k for p in mesh.polygons for k in p.edge_keys}) + 1
    entry = api.add_entry(obj, "SUBDIVIDE", levels=2, use_limit_surface=False)
    twin = bare_twin(bpy, obj)
    mod = twin.modifiers.new("Subdivision", "SUBSURF")
    mod.levels, mod.use_limit_surface = 2, False
    update()
    ours, theirs = topology(bpy, obj), topology(bpy, twin)
    assert entry.error == "" and not ours[4]
    assert len(ours[0]) == len(theirs[0]) - 3 and len(ours[2]) == len(theirs[2])


def test_apply_gives_the_mesh_blenders_apply_gives(scene):
    """Applying the entry writes the base mesh in the order applying Blender's modifier does."""
    import bpy
    from deformkit_addon import api
    ours, theirs = make_mixed(bpy), make_mixed(bpy)
    api.add_entry(ours, "SUBDIVIDE", levels=2, use_limit_surface=False)
    assert api.apply(ours, 0) == ""
    mod = theirs.modifiers.new("Subdivision", "SUBSURF")
    mod.levels, mod.use_limit_surface = 2, False
    with bpy.context.temp_override(object=theirs, active_object=theirs):
        bpy.ops.object.modifier_apply(modifier="Subdivision")
    a, b = topology(bpy, ours), topology(bpy, theirs)
    assert np.abs(a[0] - b[0]).max() < 1e-5 and not a[4]
    np.testing.assert_array_equal(a[1], b[1])
    assert a[2] == b[2]


def test_level_zero_keeps_the_meshs_own_numbering(scene):
    """Levels Viewport 0 (renders subdivided) shows the base mesh as Blender's modifier does: its
    own vertices, edges and faces, in its own order."""
    import bpy
    from deformkit_addon import api
    obj = make_cube(bpy)  # its edges are not in the order Blender would make them from its faces
    mesh = obj.data
    base_edges = np.empty(len(mesh.edges) * 2, np.int32)
    mesh.edges.foreach_get("vertices", base_edges)
    entry = api.add_entry(obj, "SUBDIVIDE", levels=0, render_levels=2, use_limit_surface=False)
    assert entry.error == "" and entry.subdivision_viewport is not None
    shown = topology(bpy, obj)
    np.testing.assert_array_equal(shown[1], base_edges.reshape(-1, 2))
    assert shown[2] == [tuple(p.vertices) for p in mesh.polygons] and not shown[4]

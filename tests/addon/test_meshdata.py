"""meshdata's corners polygon by polygon, the one reading of a mesh's polygons the add-on shares
(polygons, polygon_corners, face_components, select_vertices), checked against the polygons as
built, a plain union-find and Blender's own per-polygon vertex lists. Meshes saved before Blender
3.6 may store a polygon's corners anywhere (loop_start not ascending): the Topology below does."""
import numpy as np
import pytest

from addon_helpers import make_object


def stored_out_of_order(polys, vertices, rng):
    """A meshdata.Topology of `polys` whose corner runs are stored in a shuffled order."""
    from deformkit_addon import meshdata
    totals = np.array([len(p) for p in polys], np.int32)
    order = rng.permutation(len(polys))
    corners = np.concatenate([polys[i] for i in order]).astype(np.int32)
    starts = np.empty(len(polys), np.int32)
    starts[order] = np.cumsum(totals[order]) - totals[order]
    return meshdata.Topology(vertices, len(polys), 0, corners, starts, totals)


def random_polygons(rng, vertices, faces):
    return [rng.choice(vertices, int(k), replace=False) for k in rng.integers(3, 6, faces)]


def union_find_labels(vertices, polys):
    """Each vertex's component through the polygons, labelled by its smallest vertex."""
    parent = list(range(vertices))

    def root(v):
        while parent[v] != v:
            v = parent[v]
        return v
    for poly in polys:
        for v in poly[1:]:
            a, b = root(int(poly[0])), root(int(v))
            parent[max(a, b)] = min(a, b)
    return np.array([root(v) for v in range(vertices)])


def test_the_corners_come_polygon_by_polygon_whatever_their_storage_order(addon):
    from deformkit_addon import meshdata
    rng = np.random.default_rng(7)
    for _ in range(20):
        polys = random_polygons(rng, 12, int(rng.integers(1, 10)))
        topo = stored_out_of_order(polys, 12, rng)
        corners, starts = meshdata.polygon_corners(topo)
        for poly, start, total in zip(polys, starts, topo.totals):
            np.testing.assert_array_equal(corners[start:start + total], poly)
        got = meshdata.polygons(topo)
        assert len(got) == len(polys) and all(np.array_equal(g, p) for g, p in zip(got, polys))


def test_face_components_agree_with_a_union_find(addon):
    from deformkit_addon import meshdata
    rng = np.random.default_rng(3)
    for _ in range(20):
        vertices = int(rng.integers(6, 40))  # sparse polygons: several parts, some lone vertices
        polys = random_polygons(rng, vertices, int(rng.integers(1, 6)))
        topo = stored_out_of_order(polys, vertices, rng)
        np.testing.assert_array_equal(meshdata.face_components(topo), union_find_labels(vertices, polys))


def test_select_vertices_selects_the_edges_and_faces_between_them(scene):
    import bpy
    from deformkit_addon import meshdata
    obj = make_object(bpy)
    mesh = obj.data
    chosen = {v.index for v in mesh.vertices if v.co.z > 0.3}
    meshdata.select_vertices(mesh, sorted(chosen))
    assert {v.index for v in mesh.vertices if v.select} == chosen
    assert [e.select for e in mesh.edges] == [set(e.vertices) <= chosen for e in mesh.edges]
    faces = [set(p.vertices) <= chosen for p in mesh.polygons]
    assert [p.select for p in mesh.polygons] == faces and any(faces) and not all(faces)


def test_reading_the_edit_mesh_gives_its_points_and_leaves_it_as_it_was(scene):
    """edit_positions copies the BMesh out through a scratch mesh: the points equal the BMesh's
    own, read vertex by vertex, after moves and deletions; leaving Edit Mode afterwards writes the
    same mesh and shape keys as without the reads (the copy must not disturb the edit mesh's
    shape-key indices, which map keys onto the vertices that are left)."""
    import bmesh
    import bpy
    from deformkit_addon import meshdata

    def edit_and_leave(read):
        obj = make_object(bpy, name="Read" if read else "Plain")
        obj.shape_key_add(name="Basis")
        key = obj.shape_key_add(name="Key")
        for i, p in enumerate(key.data):
            p.co.z += 0.01 * i
        obj.active_shape_key_index = 0
        bpy.ops.object.mode_set(mode="EDIT")
        bm = bmesh.from_edit_mesh(obj.data)
        bm.verts.ensure_lookup_table()
        bmesh.ops.delete(bm, geom=[bm.verts[i] for i in (3, 40, 41, 200)], context="VERTS")
        for v in bm.verts[:50]:
            v.co.x += 0.25
        bmesh.update_edit_mesh(obj.data)
        if read:
            for _ in range(2):
                got = meshdata.edit_positions(obj.data)
                want = np.array([v.co[:] for v in bmesh.from_edit_mesh(obj.data).verts], np.float32)
                np.testing.assert_array_equal(got, want)
        bpy.ops.object.mode_set(mode="OBJECT")
        keys = [np.array([p.co[:] for p in k.data]) for k in obj.data.shape_keys.key_blocks]
        bpy.context.view_layer.objects.active = None
        return meshdata.base_positions(obj.data), keys

    plain, read = edit_and_leave(False), edit_and_leave(True)
    np.testing.assert_array_equal(read[0], plain[0])
    for a, b in zip(read[1], plain[1]):
        np.testing.assert_array_equal(a, b)
    reader = bpy.data.meshes.get(meshdata.EDIT_READER)
    assert reader is not None and reader.users == 0 and len(reader.vertices) == 0  # never saved, holds nothing


def test_affine_inverse_is_the_inverse(addon, rng):
    """Against numpy's LAPACK inverse, on random affine matrices far from and near singular; a
    singular one is refused."""
    from deformkit_addon.entries.common import affine_inverse, determinant3
    for scale in (1.0, 1e-4, 1e5):
        m = np.eye(4)
        m[:3, :3] = rng.normal(size=(3, 3)) * scale
        m[:3, 3] = rng.normal(size=3)
        np.testing.assert_allclose(affine_inverse(m), np.linalg.inv(m), rtol=1e-9, atol=1e-9 / scale)
        np.testing.assert_allclose(affine_inverse(m) @ m, np.eye(4), atol=1e-9)
        assert np.isclose(determinant3(m[:3, :3]), np.linalg.det(m[:3, :3]), rtol=1e-12)
    flat = np.eye(4)
    flat[2, 2] = 0.0
    with pytest.raises(ValueError, match="singular"):
        affine_inverse(flat)

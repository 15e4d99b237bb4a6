"""Subdivide entries and Check Smoothness in Blender: the evaluated mesh against dk.subdivide (in
Blender's order) and against Blender's own Subdivision Surface modifier (as sets of points, UVs and faces),
after deformers, through removal, apply, save and reload, undo, renders and bad settings."""
import math

import numpy as np
import pytest

from addon_helpers import CheckingLayout, bare_twin, close, evaluated, make_object, make_tube, polygons, positions, update

OWNER = "deformkit_subdivision_of"


def dk():
    from deformkit_addon import native
    return native.dk


def helpers(bpy):
    return sorted(o.name for o in bpy.data.objects if OWNER in o)


def evaluated_mesh(bpy, obj):
    """(positions, polygons, per-corner UVs or None, material index, smooth) of what Blender shows."""
    ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = ev.to_mesh()
    try:
        uvs = None
        if mesh.uv_layers.active is not None:
            uvs = np.empty(len(mesh.loops) * 2, np.float32)
            mesh.uv_layers.active.data.foreach_get("uv", uvs)
            uvs = uvs.reshape(-1, 2)
        material, smooth = np.empty(len(mesh.polygons), np.int32), np.empty(len(mesh.polygons), bool)
        mesh.polygons.foreach_get("material_index", material)
        mesh.polygons.foreach_get("use_smooth", smooth)
        return positions(mesh), polygons(mesh), uvs, material, smooth
    finally:
        ev.to_mesh_clear()


def set_distance(a, b, reach=1e-3):
    """The largest distance from a row of a to the nearest row of b, and back (a Hausdorff distance),
    where it is at most `reach`; inf where some row has no row of the other within reach. Rows are
    compared with those whose first column is within reach (sorted), so large sets stay fast."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)

    def one_way(p, q):
        q = q[np.argsort(q[:, 0])]
        lo = np.searchsorted(q[:, 0], p[:, 0] - reach, "left")
        count = np.searchsorted(q[:, 0], p[:, 0] + reach, "right") - lo
        row = np.repeat(np.arange(len(p)), count)
        candidate = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count) + np.repeat(lo, count)
        nearest = np.full(len(p), np.inf)
        np.minimum.at(nearest, row, ((p[row] - q[candidate]) ** 2).sum(axis=1))
        return math.sqrt(nearest.max())

    return max(one_way(a, b), one_way(b, a))


def corner_rows(points, faces, uvs):
    """One row per face corner: its vertex's position and its UV."""
    corners = np.concatenate([np.asarray(f) for f in faces])
    return np.hstack([points[corners], uvs])


def face_rows(points, faces, material, smooth):
    """One row per face: its centre, then its material index and smooth flag, scaled apart."""
    centres = np.array([points[f].mean(axis=0) for f in faces])
    return np.hstack([centres, 100.0 * material[:, None], 1000.0 * smooth[:, None]])


def set_creases(bpy, mesh, edges=(), vertices=()):
    """Edge and vertex creases ({index: crease}), where each Blender version keeps them."""
    if bpy.app.version >= (4, 0, 0):
        for name, domain, values, count in (("crease_edge", "EDGE", edges, len(mesh.edges)),
                                            ("crease_vert", "POINT", vertices, len(mesh.vertices))):
            attr = mesh.attributes.get(name) or mesh.attributes.new(name, "FLOAT", domain)
            data = np.zeros(count, np.float32)
            data[list(dict(values))] = list(dict(values).values())
            attr.data.foreach_set("value", data)
    else:  # Blender 3.4: MeshEdge.crease and a vertex crease layer made through BMesh
        import bmesh
        for i, c in dict(edges).items():
            mesh.edges[i].crease = c
        if vertices:
            bm = bmesh.new()
            bm.from_mesh(mesh)
            layer = bm.verts.layers.crease.verify()
            bm.verts.ensure_lookup_table()
            for i, c in dict(vertices).items():
                bm.verts[i][layer] = c
            bm.to_mesh(mesh)
            bm.free()
    mesh.update()


def twin_with_subsurf(bpy, obj, deforms=(), **settings):
    """A copy of obj's base mesh with Blender's Simple Deform modifiers (mode, settings) and then its
    Subdivision Surface modifier with these settings, without the limit surface (deformkit gives the
    refined points)."""
    twin = bare_twin(bpy, obj)
    for mode, params in deforms:
        mod = twin.modifiers.new(mode, "SIMPLE_DEFORM")
        mod.deform_method = mode
        for key, value in params.items():
            setattr(mod, key, value)
    mod = twin.modifiers.new("Subdivision", "SUBSURF")
    mod.use_limit_surface = False
    for key, value in settings.items():
        setattr(mod, key, value)
    update()
    return twin


def make_grid(bpy):
    """An open, bumpy 6 x 5 grid of quads: boundaries, corners of valence 2 and 3."""
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=6, y_subdivisions=5, size=2.0)
    obj = bpy.context.active_object
    co = positions(obj.data)
    co[:, 2] = 0.3 * np.sin(2 * co[:, 0]) * np.cos(3 * co[:, 1])
    obj.data.vertices.foreach_set("co", co.ravel())
    obj.data.update()
    return obj


def make_cube(bpy, cuts=1):
    """A cube cut into 4 quads per side: vertices of valence 3 and 4, closed."""
    bpy.ops.mesh.primitive_cube_add(size=2.0)
    obj = bpy.context.active_object
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.subdivide(number_cuts=cuts)
    bpy.ops.object.mode_set(mode="OBJECT")
    return obj


MESHES = {"sphere": make_object, "tube": make_tube, "grid": make_grid}
CASES = [  # mesh, levels, Subdivision Surface settings, creases
    ("sphere", 1, {}, False),
    ("sphere", 2, {"use_creases": True}, True),
    ("tube", 2, {}, True),
    ("tube", 1, {"use_creases": False}, True),
    ("grid", 2, {"boundary_smooth": "PRESERVE_CORNERS"}, True),
    ("grid", 3, {"boundary_smooth": "ALL"}, False),
]


@pytest.mark.parametrize("mesh, levels, settings, creased", CASES,
                         ids=[f"{m}-{lv}-{'-'.join(map(str, s.values()))}-{c}" for m, lv, s, c in CASES])
def test_subdivide_equals_dk_and_blenders_modifier(scene, mesh, levels, settings, creased):
    import bpy
    from deformkit_addon import api
    obj = MESHES[mesh](bpy)
    base = positions(obj.data).copy()
    if creased:  # semi-sharp and sharp edges, and a vertex crease, at edges of every polygon kind
        set_creases(bpy, obj.data, edges={0: 0.35, 5: 1.0, len(obj.data.edges) - 1: 0.8}, vertices={3: 0.6})
    entry = api.add_entry(obj, "SUBDIVIDE", levels=levels, use_limit_surface=False, **settings)
    assert entry.error == "" and obj.deformkit.error == ""
    ours, faces, _, _, _ = evaluated_mesh(bpy, obj)
    # dk.subdivide on the same mesh, with Blender's crease mapping written out: sharpness 10 c^2
    kwargs = {}
    if creased and settings.get("use_creases", True):
        edges = np.array([obj.data.edges[i].vertices[:] for i in (0, 5, len(obj.data.edges) - 1)])
        kwargs = dict(creases=(edges, 10 * np.float32([0.35, 1.0, 0.8]) ** 2), corners=([3], [10 * 0.6 ** 2]))
    boundary = "edge_only" if settings.get("boundary_smooth") == "ALL" else "edge_and_corner"
    s = dk().Subdivider(base, polygons(obj.data), levels, boundary=boundary, **kwargs)
    m = s.mesh()
    assert (len(ours), len(faces)) == (len(m.points), len(m.faces))
    # dk's points and faces, numbered as Blender numbers them (test_subdivide_order.py)
    vertex, face, start, _ = s.blender_order(np.array([e.vertices[:] for e in obj.data.edges]))
    assert np.abs(ours[vertex] - m.points).max() < 1e-6
    rotated = np.array([np.roll(f, -k) for f, k in zip(vertex[m.faces], start)])
    np.testing.assert_array_equal(np.array(faces)[face], rotated)
    twin = twin_with_subsurf(bpy, obj, levels=levels, **settings)
    theirs, their_faces, _, _, _ = evaluated_mesh(bpy, twin)
    assert (len(theirs), len(their_faces)) == (len(ours), len(faces))
    scale = float(np.ptp(base, axis=0).max())
    assert set_distance(ours, theirs) < 1e-5 * scale, set_distance(ours, theirs)
    np.testing.assert_array_equal(positions(obj.data), base)  # the base mesh is never written


@pytest.mark.parametrize("scheme", ["AUTO", "LOOP"])
def test_loop_on_a_triangle_mesh(scene, scheme):
    import bpy
    from deformkit_addon import api
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2)
    obj = bpy.context.active_object
    api.add_entry(obj, "TAPER", factor=0.4, deform_axis="Z")
    api.add_entry(obj, "SUBDIVIDE", levels=2, scheme=scheme, use_limit_surface=False)
    ours, faces, _, _, _ = evaluated_mesh(bpy, obj)
    cage = dk().SimpleDeform(mode="TAPER", factor=0.4, deform_axis="Z").deform(positions(obj.data))
    m = dk().subdivide(cage, polygons(obj.data), 2, scheme="loop")
    assert m.scheme == "loop" and len(faces) == 16 * len(obj.data.polygons) and {len(f) for f in faces} == {3}
    assert len(ours) == len(m.points) and np.abs(ours - m.points).max() < 1e-6
    catmull_clark = dk().subdivide(cage, polygons(obj.data), 2, scheme="catmull_clark")
    assert len(catmull_clark.points) != len(ours)  # the scheme is not Blender's: there is no twin


def test_deformers_before_it_are_applied_first(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    deforms = [("TWIST", dict(angle=1.4, deform_axis="Z")), ("BEND", dict(angle=0.8, deform_axis="X"))]
    for mode, params in deforms:
        api.add_entry(obj, mode, **params)
    api.add_entry(obj, "SUBDIVIDE", levels=2, use_limit_surface=False)
    ours = evaluated_mesh(bpy, obj)[0]
    theirs = evaluated_mesh(bpy, twin_with_subsurf(bpy, obj, deforms, levels=2))[0]
    assert set_distance(ours, theirs) < 1e-5 * 3
    plain = evaluated_mesh(bpy, twin_with_subsurf(bpy, obj, levels=2))[0]  # not deformed first: far away
    assert set_distance(ours, plain, reach=0.1) > 0.1
    # parameter edits and keyframes above it (the fast path: same topology, new cage) follow too
    twin = bpy.data.objects[obj.name + "_blender"]
    for frame, angle in ((1, -0.6), (11, 1.8)):
        for owner in (obj.deformkit.entries[0], twin.modifiers["TWIST"]):
            owner.angle = angle
            owner.keyframe_insert("angle", frame=frame)
    for frame in (11, 4, 1):
        scene.frame_set(frame)
        assert set_distance(evaluated_mesh(bpy, obj)[0], evaluated_mesh(bpy, twin)[0]) < 1e-5 * 3, frame


def test_uvs_materials_and_smooth_shading_are_carried(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)  # a UV sphere: UV seams, poles
    mesh = obj.data
    for name in ("Red", "Blue"):
        mesh.materials.append(bpy.data.materials.new(name))
    centre_z = np.array([p.center.z for p in mesh.polygons])
    mesh.polygons.foreach_set("material_index", (centre_z > 0.2).astype(np.int32))
    mesh.polygons.foreach_set("use_smooth", np.arange(len(mesh.polygons)) % 3 == 0)
    mesh.update()
    entry = api.add_entry(obj, "SUBDIVIDE", levels=2, use_limit_surface=False)
    for uv_smooth in ("PRESERVE_BOUNDARIES", "SMOOTH_ALL", "NONE"):
        entry.uv_smooth = uv_smooth
        twin = twin_with_subsurf(bpy, obj, levels=2, uv_smooth=uv_smooth)
        points, faces, uvs, material, smooth = evaluated_mesh(bpy, obj)
        t_points, t_faces, t_uvs, t_material, t_smooth = evaluated_mesh(bpy, twin)
        assert uvs is not None and len(uvs) == len(t_uvs)
        assert set_distance(corner_rows(points, faces, uvs), corner_rows(t_points, t_faces, t_uvs)) < 1e-5, uv_smooth
        assert set_distance(face_rows(points, faces, material, smooth),
                            face_rows(t_points, t_faces, t_material, t_smooth)) < 1e-5
        bpy.data.objects.remove(twin)
    assert {0, 1} <= set(material.tolist()) and smooth.any() and not smooth.all()
    ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    assert [m.name for m in ev.data.materials] == ["Red", "Blue"]


def test_removing_gives_the_mesh_back_and_deletes_the_helpers(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    base, shown = positions(obj.data).copy(), evaluated(obj).copy()
    attributes = sorted(a.name for a in obj.data.attributes)
    api.add_entry(obj, "TWIST", angle=1.0, deform_axis="Z")
    twisted = evaluated(obj).copy()
    api.add_entry(obj, "SUBDIVIDE", levels=1, render_levels=2)
    assert helpers(bpy) == ["Obj subdivided", "Obj subdivided (render)"]
    assert len(evaluated(obj)) > len(base)
    api.remove_entry(obj, 1)
    np.testing.assert_array_equal(evaluated(obj), twisted)
    assert helpers(bpy) == [] and not any("subdivided" in m.name for m in bpy.data.meshes)
    api.add_entry(obj, "SUBDIVIDE", levels=2)
    obj.deformkit.entries.clear()  # not through the API: the next evaluation still cleans up
    api.evaluate(obj)
    np.testing.assert_array_equal(evaluated(obj), shown)  # bit for bit
    assert helpers(bpy) == [] and "deformkit" not in obj.modifiers
    assert sorted(a.name for a in obj.data.attributes) == attributes
    np.testing.assert_array_equal(positions(obj.data), base)


def test_hidden_or_level_zero_and_render_levels(scene, tmp_path):
    """Hidden (or level 0) the entry gives the cage; the render levels are what renders show."""
    import bpy
    from deformkit_addon import api
    obj = make_cube(bpy, cuts=1)
    twist = api.add_entry(obj, "TWIST", angle=0.7, deform_axis="Z")
    cage = evaluated(obj).copy()
    entry = api.add_entry(obj, "SUBDIVIDE", levels=0, render_levels=3, use_limit_surface=False)
    np.testing.assert_array_equal(evaluated(obj), cage)
    entry.levels = 2
    entry.show_viewport = False
    np.testing.assert_array_equal(evaluated(obj), cage)
    entry.show_render = False
    assert helpers(bpy) == []  # subdivides nowhere: no helpers
    entry.show_viewport = entry.show_render = True
    assert len(evaluated(obj)) == len(dk().subdivide(cage, polygons(obj.data), 2).points)
    twist.angle = 0.2  # the hidden render helper follows the cage too
    entry.levels = 0
    twin = twin_with_subsurf(bpy, obj, [("TWIST", dict(angle=0.2, deform_axis="Z"))], levels=0, render_levels=3)
    # The viewport: both show the cage (Simple Deform reproduced to the add-on tests' tolerance).
    assert close(evaluated(obj), evaluated(twin))
    ours, theirs = render_alpha(bpy, obj, tmp_path), render_alpha(bpy, twin, tmp_path)
    entry.show_render = False
    cage = render_alpha(bpy, obj, tmp_path)
    assert np.abs(ours - theirs).mean() < 2e-3, np.abs(ours - theirs).mean()
    assert np.abs(ours - cage).mean() > 2e-2  # the render shows the subdivision, not the cage


def render_alpha(bpy, shown, tmp_path):
    """A workbench render's alpha with only `shown` of the meshes visible."""
    scene = bpy.context.scene
    if scene.camera is None:
        cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
        scene.collection.objects.link(cam)
        cam.location, cam.rotation_euler = (0.0, -7.0, 0.0), (math.pi / 2, 0.0, 0.0)
        cam.data.type, cam.data.ortho_scale = "ORTHO", 3.2
        scene.camera = cam
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.render.resolution_x = scene.render.resolution_y = 96
    scene.render.film_transparent = True
    for o in scene.objects:
        o.hide_render = o.type == "MESH" and o is not shown
    path = str(tmp_path / f"render{len(bpy.data.images)}.png")
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(path)
    pixels = np.empty(len(image.pixels), np.float32)
    image.pixels.foreach_get(pixels)
    bpy.data.images.remove(image)
    return pixels.reshape(-1, 4)[:, 3]


def test_save_reload_undo_and_disabled_addon(scene, tmp_path, addon):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    api.add_entry(obj, "BEND", angle=0.9, deform_axis="X")
    base = evaluated(obj).copy()
    bpy.ops.ed.undo_push(message="bend")
    entry = api.add_entry(obj, "SUBDIVIDE", levels=1)
    bpy.ops.ed.undo_push(message="subdivide")
    level1 = evaluated(obj).copy()
    entry.levels = 2
    bpy.ops.ed.undo_push(message="level 2")
    level2 = evaluated(obj).copy()
    path = str(tmp_path / "subdivided.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.ed.undo()
    obj = bpy.data.objects["Obj"]
    assert obj.deformkit.entries[1].levels == 1
    np.testing.assert_array_equal(evaluated(obj), level1)
    bpy.ops.ed.undo()
    obj = bpy.data.objects["Obj"]
    assert len(obj.deformkit.entries) == 1 and helpers(bpy) == []
    np.testing.assert_array_equal(evaluated(obj), base)
    bpy.ops.ed.redo()
    bpy.ops.ed.redo()
    np.testing.assert_array_equal(evaluated(bpy.data.objects["Obj"]), level2)
    bpy.ops.wm.open_mainfile(filepath=path)
    obj = bpy.data.objects["Obj"]
    assert [e.type for e in obj.deformkit.entries] == ["BEND", "SUBDIVIDE"] and helpers(bpy) == ["Obj subdivided"]
    np.testing.assert_array_equal(evaluated(obj), level2)
    obj.deformkit.entries[1].levels = 1  # still live after loading
    np.testing.assert_array_equal(evaluated(obj), level1)
    addon.unregister()
    try:
        bpy.ops.wm.open_mainfile(filepath=path)
        np.testing.assert_array_equal(evaluated(bpy.data.objects["Obj"]), level2)  # as last seen
    finally:
        addon.register()


def test_apply_bakes_the_subdivided_mesh_as_blender_does(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    obj.data.materials.append(bpy.data.materials.new("Only"))
    api.add_entry(obj, "TWIST", angle=1.1, deform_axis="Z")
    api.add_entry(obj, "SUBDIVIDE", levels=2, render_levels=3)
    shown = evaluated_mesh(bpy, obj)
    assert api.apply(obj, 0) == ""
    # data the subdivided mesh cannot carry: Apply refuses and leaves everything as it was
    before = positions(obj.data), polygons(obj.data), len(obj.deformkit.entries)
    obj.data.uv_layers.new(name="Second")
    with pytest.raises(ValueError, match="would lose vertex groups 'Upper'; UV maps 'Second'"):
        api.apply(obj, 0)
    assert np.array_equal(positions(obj.data), before[0]) and polygons(obj.data) == before[1]
    assert len(obj.deformkit.entries) == before[2] and [g.name for g in obj.vertex_groups] == ["Upper"]
    obj.vertex_groups.clear()
    obj.data.uv_layers.remove(obj.data.uv_layers["Second"])
    assert api.apply(obj, 0) == ""  # the Subdivide entry, now first
    assert len(obj.deformkit.entries) == 0 and helpers(bpy) == [] and "deformkit" not in obj.modifiers
    baked = positions(obj.data)
    assert len(baked) == len(shown[0]) and np.abs(baked - shown[0]).max() < 1e-6  # the viewport levels
    assert polygons(obj.data) == shown[1]
    assert obj.data.uv_layers.active is not None and [m.name for m in obj.data.materials] == ["Only"]
    other = make_object(bpy, name="Other")  # against Blender's own Apply of its modifier
    other.vertex_groups.clear()
    api.add_entry(other, "SUBDIVIDE", levels=2, use_limit_surface=False)
    api.apply(other, 0)
    twin = make_object(bpy, name="Twin")
    twin.modifiers.new("Subdivision", "SUBSURF").use_limit_surface = False
    twin.modifiers[0].levels = 2
    with bpy.context.temp_override(object=twin, active_object=twin):
        bpy.ops.object.modifier_apply(modifier="Subdivision")
    assert len(twin.data.polygons) == len(other.data.polygons)
    assert set_distance(positions(other.data), positions(twin.data)) < 3e-5


def too_many_faces(obj, level):
    """Catmull-Clark's face count: an n-gon becomes n quads, each quad then 4 per level; above 2^24."""
    faces = sum(len(p.vertices) for p in obj.data.polygons) * 4 ** (level - 1)
    assert faces > 2 ** 24
    return faces


def test_too_high_render_levels_say_which_field_to_lower(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    entry = api.add_entry(obj, "SUBDIVIDE", levels=1, render_levels=8)
    label = type(entry).bl_rna.properties["render_levels"].name
    assert entry.error == (f"level 8 would make {too_many_faces(obj, 8):,} faces, more than the {2 ** 24:,} "
                           f"deformkit allows: lower {label}"), entry.error
    assert "max_faces" not in entry.error


@pytest.mark.parametrize("problem", ["after", "non_manifold", "loop_on_quads", "too_high", "loose_vertex",
                                     "two_subdivides"])
def test_bad_settings_show_on_the_entry_and_leave_the_mesh(scene, problem):
    import bmesh
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    entry = api.add_entry(obj, "SUBDIVIDE", levels=1)
    before, made = evaluated(obj).copy(), helpers(bpy)
    if problem in ("after", "two_subdivides"):
        # A Subdivide entry has no angle: api.set_params refuses parameters of other kinds.
        if problem == "after":  # a new entry goes above the Subdivide entry: moved below it
            api.add_entry(obj, "TWIST", angle=1.0)
            api.move_entry(obj, 0, 1)
            late = obj.deformkit.entries[1]
        else:
            late = api.add_entry(obj, "SUBDIVIDE")
        assert "must be the last entry" in late.error and "Subdivide" in late.error, late.error
    elif problem == "loop_on_quads":
        entry.scheme = "LOOP"
        assert entry.error.startswith("faces: the Loop scheme needs triangles"), entry.error
    elif problem == "too_high":
        entry.levels = 8
        # In the panel's terms (max_faces is no setting there): the field to lower, by its label.
        faces = too_many_faces(obj, 8)
        assert entry.error == (f"level 8 would make {faces:,} faces, more than the {2 ** 24:,} deformkit allows: "
                               f"lower {type(entry).bl_rna.properties['levels'].name}"), entry.error
    else:
        bm = bmesh.new()
        bm.from_mesh(obj.data)
        if problem == "non_manifold":  # a third face on an edge
            edge = next(e for e in bm.edges if len(e.link_faces) == 2)
            bm.faces.new((*edge.verts, bm.verts.new((3.0, 3.0, 3.0))))
        else:
            bm.verts.new((3.0, 3.0, 3.0))
        bm.to_mesh(obj.data)
        bm.free()
        obj.data.update()
        update()  # the handler sees the edit of the base mesh
        expected = "faces: edge" if problem == "non_manifold" else "points: vertex"
        assert entry.error.startswith(expected), entry.error
    if problem in ("after", "two_subdivides"):  # the late entry is skipped: the Subdivide entry still works
        np.testing.assert_array_equal(evaluated(obj), before)
    else:  # the Subdivide entry is skipped, as Blender skips a modifier it cannot run: the cage shows
        assert len(before) > len(obj.data.vertices)
        np.testing.assert_array_equal(evaluated(obj), positions(obj.data))
    with pytest.raises(ValueError):
        api.evaluate(obj)
    assert made == ["Obj subdivided", "Obj subdivided (render)"]
    # Skipped, the entry needs no helpers (as at level 0); they come back once it works again.
    assert helpers(bpy) == (made if problem in ("after", "two_subdivides") else [])


def test_check_smoothness_of_a_smooth_twisted_cube(scene):
    import bpy
    from deformkit_addon import api
    obj = make_cube(bpy)
    api.add_entry(obj, "TWIST", angle=1.2, deform_axis="Z")
    api.add_entry(obj, "SUBDIVIDE", levels=2)
    obj.data.vertices.foreach_set("select", np.ones(len(obj.data.vertices), bool))
    with bpy.context.temp_override(object=obj, active_object=obj):
        assert bpy.ops.deformkit.check_smoothness() == {"FINISHED"}
    figures = obj.deformkit.smoothness
    assert figures.checked and figures.max_angle < 1e-9 and figures.selected == 0
    assert figures.degenerate == 0 and figures.flipped == 0
    selected = np.empty(len(obj.data.edges), bool)
    obj.data.edges.foreach_get("select", selected)
    assert not selected.any()
    cage = dk().SimpleDeform(mode="TWIST", angle=1.2, deform_axis="Z").deform(positions(obj.data))
    direct = dk().smoothness_report(cage, polygons(obj.data))
    assert abs(api.check_smoothness(obj)["max_angle"] - direct.max_angle) < 1e-12


@pytest.mark.parametrize("mode", ["OBJECT", "EDIT"])
def test_check_smoothness_finds_and_selects_a_crease(scene, mode):
    import bmesh
    import bpy
    from deformkit_addon import api
    obj = make_cube(bpy)
    mesh = obj.data
    # half of a vertical edge of the cube: the cage bends there (a crease where it is flat bends nothing)
    index, pair = next((e.index, sorted(e.vertices)) for e in mesh.edges if all(
        abs(abs(mesh.vertices[v].co.x) - 1) < 1e-6 and abs(abs(mesh.vertices[v].co.y) - 1) < 1e-6 for v in e.vertices))
    set_creases(bpy, mesh, edges={index: 1.0})
    entry = api.add_entry(obj, "SUBDIVIDE", levels=1)
    figures = api.check_smoothness(obj, select=False)
    assert figures["max_angle"] > 0.3 and figures["selected_edges"] == [index]
    assert sorted(figures["worst_edge"]) == pair
    entry.use_creases = False  # the entry's settings are what is checked
    assert api.check_smoothness(obj, select=False)["max_angle"] < 1e-9
    entry.use_creases = True
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode=mode)
    with bpy.context.temp_override(object=obj, active_object=obj):
        assert bpy.ops.deformkit.check_smoothness() == {"FINISHED"}
    assert obj.deformkit.smoothness.selected == 1
    assert math.degrees(obj.deformkit.smoothness.max_angle) > 15
    if mode == "EDIT":
        bm = bmesh.from_edit_mesh(mesh)
        chosen = [e.index for e in bm.edges if e.select]
        bpy.ops.object.mode_set(mode="OBJECT")
    else:
        chosen = [e.index for e in mesh.edges if e.select]
    assert chosen == [index]
    assert sorted(v.index for v in mesh.vertices if v.select) == pair


def test_check_smoothness_without_entries_and_errors(scene):
    import bpy
    from deformkit_addon import api
    obj = make_tube(bpy)
    figures = api.check_smoothness(obj, select=False)  # the base mesh, a new entry's settings
    direct = dk().smoothness_report(positions(obj.data), polygons(obj.data))
    assert figures["max_angle"] == pytest.approx(direct.max_angle, abs=1e-12)
    assert figures["boundary_edges"] == direct.boundary_edges == 0
    api.add_entry(obj, "SUBDIVIDE", scheme="LOOP")
    with pytest.raises(ValueError, match="Loop scheme needs triangles"):
        api.check_smoothness(obj)


def test_panel_shows_the_subdivide_entry_and_smoothness(scene):
    import types

    import bpy
    from deformkit_addon import api, ui
    obj = make_object(bpy)
    api.add_entry(obj, "SUBDIVIDE", levels=1, render_levels=2)
    api.check_smoothness(obj)
    log = []
    context = types.SimpleNamespace(object=obj)
    ui.DEFORMKIT_PT_stack.draw(types.SimpleNamespace(layout=CheckingLayout(log)), context)
    ui.DEFORMKIT_MT_add.draw(types.SimpleNamespace(layout=CheckingLayout(log)), context)
    drawn = {name for kind, name in log if kind != "label"}
    assert {"levels", "render_levels", "scheme", "use_limit_surface", "boundary_smooth", "use_creases",
            "sharpen_two_edge_vertices", "uv_smooth", "deformkit.check_smoothness",
            "deformkit.entry_add"} <= drawn
    faces = len(dk().subdivide(positions(obj.data), polygons(obj.data), 2).faces)
    assert any(kind == "label" and text.startswith("Render:") and text.endswith(f"{faces} faces")
               for kind, text in log)
    assert any(kind == "label" and text.startswith("Max normal angle") for kind, text in log)


def test_a_copy_of_the_object_gets_its_own_helpers(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    api.add_entry(obj, "SUBDIVIDE", levels=1, render_levels=1)
    shown = evaluated(obj).copy()
    copy = obj.copy()
    copy.data = obj.data.copy()
    copy.name = "Copy"
    scene.collection.objects.link(copy)
    copy.deformkit.entries[0].levels = copy.deformkit.entries[0].render_levels = 2
    assert helpers(bpy) == ["Copy subdivided", "Obj subdivided"]
    np.testing.assert_array_equal(evaluated(obj), shown)  # the original's result is its own
    assert len(evaluated(copy)) > len(shown)
    api.remove_entry(copy, 0)
    assert helpers(bpy) == ["Obj subdivided"]
    np.testing.assert_array_equal(evaluated(obj), shown)


def test_removing_the_entry_releases_its_refined_topologies(scene):
    import bpy
    from deformkit_addon import api, cache, meshdata
    obj = make_object(bpy)
    api.add_entry(obj, "TWIST", angle=0.5, deform_axis="Z")
    api.add_entry(obj, "SUBDIVIDE", levels=2, render_levels=3)
    key = meshdata.cache_key(obj)
    assert {k[0] for k in cache.items("subdivide")} == {key}
    api.remove_entry(obj, 1)
    assert not any(k[0] == key for k in cache.items("subdivide"))


def mesh_object(bpy, name, points, faces, location=(0.2, -0.1, 0.3)):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(map(float, p)) for p in points], [], [list(map(int, f)) for f in faces])
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    obj.location = location
    bpy.context.scene.collection.objects.link(obj)
    return obj


def make_plane(bpy, crease=None):
    """3 x 3 bumpy quads; with crease, every border edge creased (its corners have two edges)."""
    j, i = np.mgrid[0:4, 0:4]
    points = np.c_[i.ravel(), j.ravel(), 0.3 * np.sin(i.ravel() + 2.0 * j.ravel())] * 0.6
    k = np.arange(16).reshape(4, 4)[:3, :3].ravel()
    obj = mesh_object(bpy, "Plane", points, np.c_[k, k + 1, k + 5, k + 4])
    if crease is not None:
        mesh = obj.data
        faces_of = {}
        for p in mesh.polygons:
            for key in p.edge_keys:
                faces_of[key] = faces_of.get(key, 0) + 1
        on_border = [e.index for e in mesh.edges if faces_of[tuple(sorted(e.vertices))] == 1]
        assert len(on_border) == 12
        set_creases(bpy, mesh, edges={i: crease for i in on_border})
    return obj


def make_two_edge_cube(bpy, crease=None):
    """A cube whose bottom front edge is split by a vertex off the line: it has two edges, between
    two pentagons; with crease, both of its edges creased."""
    points = np.r_[[[x, y, z] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)], [[0.2, -1.2, -1.1]]]
    faces = [[0, 2, 3, 1, 8], [4, 5, 7, 6], [0, 8, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]]
    obj = mesh_object(bpy, "TwoEdge", points, faces)
    if crease is not None:
        pairs = {(0, 8), (1, 8)}
        set_creases(bpy, obj.data, edges={e.index: crease for e in obj.data.edges
                                          if tuple(sorted(e.vertices)) in pairs})
    return obj


def make_ico(bpy):
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2, location=(0.1, 0.2, -0.3))
    return bpy.context.active_object


TWO_EDGE_CASES = [(mesh, crease, boundary) for mesh, crease in (("plane", 1.0), ("plane", 0.5), ("cube", 1.0),
                                                                 ("cube", 0.6))
                  for boundary in ("ALL", "PRESERVE_CORNERS")]


@pytest.mark.parametrize("mesh, crease, boundary", TWO_EDGE_CASES,
                         ids=[f"{m}-{c}-{b}" for m, c, b in TWO_EDGE_CASES])
def test_creased_borders_and_two_edge_vertices_equal_blenders_modifier(scene, mesh, crease, boundary):
    """Blender gives a vertex of exactly two edges the smaller of their creases: a creased border
    keeps its corners, and so does a creased two-edge vertex between n-gons. The entry does too
    (sharpen_two_edge_vertices, on by default); without it, it is OpenSubdiv's plain rules."""
    import bpy
    from deformkit_addon import api
    obj = (make_plane if mesh == "plane" else make_two_edge_cube)(bpy, crease)
    scale = float(np.ptp(positions(obj.data), axis=0).max())
    entry = api.add_entry(obj, "SUBDIVIDE", levels=2, boundary_smooth=boundary, use_limit_surface=False)
    twin = twin_with_subsurf(bpy, obj, levels=2, boundary_smooth=boundary)
    theirs = evaluated_mesh(bpy, twin)[0]
    assert entry.error == "" and set_distance(evaluated_mesh(bpy, obj)[0], theirs) < 1e-5 * scale
    entry.sharpen_two_edge_vertices = False
    plain = evaluated_mesh(bpy, obj)[0]
    if mesh == "cube" or boundary == "ALL":  # Keep Corners makes the plane's corners sharp anyway
        assert set_distance(plain, theirs, reach=1.0) > 1e-3 * scale


LIMIT_CASES = [("sphere", {}), ("ico", {}), ("grid", {"quality": 10}), ("grid", {"boundary_smooth": "PRESERVE_CORNERS"}),
               ("plane-creased", {}), ("plane-creased", {"boundary_smooth": "PRESERVE_CORNERS"}), ("cube", {}),
               ("tube", {})]


@pytest.mark.parametrize("mesh, settings", LIMIT_CASES,
                         ids=[f"{m}-{'-'.join(map(str, s.values()))}" for m, s in LIMIT_CASES])
@pytest.mark.parametrize("levels", [1, 2])
def test_use_limit_surface_equals_blenders_modifier(scene, mesh, settings, levels):
    """With Use Limit Surface (the default, as Blender's) every vertex is on the limit surface:
    Blender's modifier at its default Quality 3 evaluates it exactly at these levels on smooth and
    infinitely sharp features. Its smooth boundary corners (Boundary Smooth All, the default) and
    semi-sharp creases are the exact limit only at a higher Quality (10 here): the entry's are exact."""
    import bpy
    from deformkit_addon import api
    make = {"sphere": make_object, "ico": make_ico, "grid": make_grid, "tube": make_tube,
            "plane-creased": lambda bpy: make_plane(bpy, 1.0), "cube": make_two_edge_cube}[mesh]
    obj = make(bpy)
    scale = float(np.ptp(positions(obj.data), axis=0).max())
    entry = api.add_entry(obj, "SUBDIVIDE", levels=levels,
                          **{k: v for k, v in settings.items() if k != "quality"})
    assert entry.use_limit_surface and entry.error == ""
    twin = twin_with_subsurf(bpy, obj, levels=levels, use_limit_surface=True, **settings)
    ours, theirs = evaluated_mesh(bpy, obj)[0], evaluated_mesh(bpy, twin)[0]
    assert len(ours) == len(theirs) and set_distance(ours, theirs) < 1e-5 * scale, set_distance(ours, theirs)
    entry.use_limit_surface = False
    refined = evaluated_mesh(bpy, obj)[0]
    assert set_distance(refined, theirs, reach=1.0) > 1e-3 * scale  # the limit is not the refined mesh


@pytest.mark.parametrize("mesh", ["sphere", "ico", "tube", "cube"])
def test_a_new_entry_equals_a_new_modifier(scene, mesh):
    """Default settings on both sides: Catmull-Clark on every mesh (all-triangle ones too), the
    limit surface, Boundary Smooth All, creases, viewport level 1 and render level 2."""
    import bpy
    from deformkit_addon import api
    obj = {"sphere": make_object, "ico": make_ico, "tube": make_tube, "cube": make_two_edge_cube}[mesh](bpy)
    if mesh == "cube":  # the creased loop around the pentagon: its two-edge vertex becomes a corner
        loop = {(0, 2), (2, 3), (1, 3), (1, 8), (0, 8)}
        set_creases(bpy, obj.data, edges={e.index: 1.0 for e in obj.data.edges if tuple(sorted(e.vertices)) in loop})
    scale = float(np.ptp(positions(obj.data), axis=0).max())
    entry = api.add_entry(obj, "SUBDIVIDE")
    assert (entry.scheme, entry.boundary_smooth, entry.uv_smooth) == ("CATMULL_CLARK", "ALL", "PRESERVE_BOUNDARIES")
    twin = bare_twin(bpy, obj)
    mod = twin.modifiers.new("Subdivision", "SUBSURF")
    assert (mod.levels, mod.render_levels, entry.levels, entry.render_levels) == (1, 2, 1, 2)
    update()
    ours, faces = evaluated_mesh(bpy, obj)[:2]
    theirs, their_faces = evaluated_mesh(bpy, twin)[:2]
    assert {len(f) for f in faces} == {4} and len(faces) == len(their_faces)
    assert set_distance(ours, theirs) < 1e-5 * scale, set_distance(ours, theirs)


def test_an_edit_mode_edit_under_a_subdivide_entry_with_uvs_evaluates(scene):
    """In Edit Mode the edit mesh holds the UVs (the mesh's UV data is empty there): the Subdivide
    entry still evaluates each edit, with no error, and shows Subdivision Surface's points, in Edit
    Mode and after it."""
    import bmesh
    import bpy
    from deformkit_addon import api, evaluation
    obj = make_object(bpy)  # a UV sphere: it has a UV map
    assert obj.data.uv_layers.active is not None
    api.add_entry(obj, "SUBDIVIDE", levels=1, use_limit_surface=False)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode="EDIT")
    edit = bmesh.from_edit_mesh(obj.data)
    for v in edit.verts:
        v.co.z += 0.2 * v.co.x
    bmesh.update_edit_mesh(obj.data)
    evaluation.evaluate(obj, evaluation.Reason.EDIT_MODE)
    assert [e.error for e in obj.deformkit.entries] == [""] and obj.deformkit.error == ""
    in_edit_mode = evaluated_mesh(bpy, obj)[0]
    bpy.ops.object.mode_set(mode="OBJECT")
    twin = twin_with_subsurf(bpy, obj, levels=1)
    expected = evaluated_mesh(bpy, twin)[0]
    scale = np.ptp(expected, axis=0).max()
    assert np.abs(in_edit_mode - expected).max() < 1e-5 * scale
    assert np.abs(evaluated_mesh(bpy, obj)[0] - expected).max() < 1e-5 * scale

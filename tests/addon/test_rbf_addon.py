"""RBF entries against dk.RBF run directly on the same controls, targets and settings, with the
control object driven the ways a rig drives one (edits, Edit Mode, shape keys, its transform, its
modifiers); which vertices and rest Bind takes; the entry's messages; and the note's clothing fit,
checked against the distance of the clothes to the body."""
import numpy as np
import pytest

from addon_helpers import close, evaluated, make_object, positions, select_vertices, update

KERNELS = {  # entry kernel -> the settings the test fits it with
    "THIN_PLATE_SPLINE": {}, "CUBIC": {}, "QUINTIC": dict(polynomial="QUADRATIC"), "LINEAR": {},
    "GAUSSIAN": dict(epsilon=0.7, polynomial="NONE"), "MULTIQUADRIC": dict(epsilon=0.8),
    "INVERSE_MULTIQUADRIC": dict(epsilon=0.6), "INVERSE_QUADRATIC": dict(epsilon=0.9, polynomial="CONSTANT"),
    "WENDLAND_C0": dict(radius=3.5, polynomial="NONE"), "WENDLAND_C2": dict(radius=3.0),
    "WENDLAND_C4": dict(radius=4.0, smoothing=0.01), "CLIP": dict(radius=3.5),
}
DEGREES = {"NONE": -1, "CONSTANT": 0, "LINEAR": 1, "QUADRATIC": 2}


def make_controls(bpy, name="Controls"):
    """A bumpy icosphere (42 vertices, not on one quadric) around make_object's sphere, turned and
    placed off the origin, with a vertex group "Top" over its upper half."""
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2, radius=1.0, location=(0.2, 0.1, 0.4),
                                          rotation=(0.3, 0.1, -0.2))
    controls = bpy.context.active_object
    controls.name = name
    controls.scale = (1.5, 1.4, 2.2)
    co = positions(controls.data).astype(np.float64)
    bump = 1 + 0.12 * np.sin(3 * co[:, 0] + 2 * co[:, 1]) * np.cos(2 * co[:, 2])
    controls.data.vertices.foreach_set("co", (co * bump[:, None]).astype(np.float32).ravel())
    controls.data.update()
    group = controls.vertex_groups.new(name="Top")
    group.add([i for i, p in enumerate(co) if p[2] > 0.2], 1.0, "REPLACE")
    update()
    return controls


def controls_in(obj, controls):
    """The control object's evaluated points in obj's space (float64, as the test computes it)."""
    import bpy
    dg = bpy.context.evaluated_depsgraph_get()
    mesh = controls.evaluated_get(dg).to_mesh()
    co = positions(mesh).astype(np.float64)
    controls.evaluated_get(dg).to_mesh_clear()
    local = np.array(obj.matrix_world.inverted() @ controls.matrix_world)
    return co @ local[:3, :3].T + local[:3, 3]


def fit_args(params):
    """dk.RBF's keywords for the entry's settings `params`."""
    kernel = params.get("kernel", "THIN_PLATE_SPLINE")
    args = dict(kernel=kernel.lower(), degree=DEGREES[params.get("polynomial", "LINEAR")],
                smoothing=params.get("smoothing", 0.0))
    if "epsilon" in params:
        args["epsilon"] = params["epsilon"]
    if "radius" in params:
        args["radius"] = params["radius"]
    return args


def expected(obj, rest, targets, params, points=None):
    from deformkit_addon.native import dk
    points = positions(obj.data).astype(np.float64) if points is None else points
    return dk.RBF(rest, targets, **fit_args(params)).deform(points)


def size(points):
    return float(np.abs(points).max())


def bound(bpy, **params):
    """make_object's sphere with an RBF entry on make_controls' icosphere, bound at its rest."""
    from deformkit_addon import api
    obj = make_object(bpy)
    controls = make_controls(bpy)
    api.add_entry(obj, "RBF", controls=controls, **params)
    np.testing.assert_array_equal(evaluated(obj), positions(obj.data))  # unbound: passes through
    rest = controls_in(obj, controls)
    count = api.bind_rbf(obj, 0)
    assert count == len(controls.data.vertices) or params.get("controls_use", "ALL") != "ALL"
    np.testing.assert_array_equal(evaluated(obj), positions(obj.data))  # at rest: the identity
    return obj, controls, rest


def move_vertices(controls, seed=0, amount=0.25):
    rng = np.random.default_rng(seed)
    co = positions(controls.data)
    co += rng.uniform(-amount, amount, co.shape).astype(np.float32)
    controls.data.vertices.foreach_set("co", co.ravel())
    controls.data.update()
    update()


@pytest.mark.parametrize("kernel", sorted(KERNELS))
def test_entry_equals_dk_rbf_for_every_kernel(scene, kernel):
    import bpy
    params = dict(kernel=kernel, **KERNELS[kernel])
    obj, controls, rest = bound(bpy, **params)
    move_vertices(controls)
    want = expected(obj, rest, controls_in(obj, controls), params)
    assert np.abs(want - positions(obj.data)).max() > 0.05
    assert close(evaluated(obj), want, 3 * size(want))


def test_minimum_degrees_are_dks(scene):
    """The panel's minimum polynomial per kernel is the one dk.RBF enforces: it refuses one less
    and fits the minimum."""
    from deformkit_addon.entries import rbf
    from deformkit_addon.native import dk
    from deformkit_addon.properties import RBF_KERNELS
    rng = np.random.default_rng(1)
    c = rng.uniform(-1, 1, (30, 3))
    for kernel, _label, _description, _n in RBF_KERNELS:
        least = rbf.MINIMUM_DEGREE.get(kernel, -1)
        extra = dict(epsilon=1.0) if kernel in rbf.SHAPED else dict(radius=2.0) if kernel in rbf.COMPACT else {}
        dk.RBF(c, c + 0.1, kernel=kernel.lower(), degree=least, **extra)
        if least >= 0:
            with pytest.raises(ValueError, match="degree"):
                dk.RBF(c, kernel=kernel.lower(), degree=least - 1, **extra)


def test_the_control_objects_evaluated_mesh_drives_the_mesh(scene):
    """A shape key, a modifier, the control object's transform and this object's own transform:
    the targets are the control object's evaluated vertices in this object's space."""
    import bpy
    obj, controls, rest = bound(bpy)
    params = {}
    controls.shape_key_add(name="Basis")
    key = controls.shape_key_add(name="Wide", from_mix=False)
    co = positions(controls.data)
    co[:, 0] *= 1.3
    co[co[:, 2] > 0, 1] += 0.2
    key.data.foreach_set("co", co.ravel())
    key.value = 0.6
    update()
    assert close(evaluated(obj), expected(obj, rest, controls_in(obj, controls), params), 6)
    displace = controls.modifiers.new("Displace", "DISPLACE")  # no texture: along the normals by strength/2
    displace.strength = 0.3
    update()
    want = expected(obj, rest, controls_in(obj, controls), params)
    assert close(evaluated(obj), want, 6)
    controls.location.x += 0.5  # the controls' transform moves the targets, as a hook's would
    controls.rotation_euler.z += 0.3
    update()
    moved = expected(obj, rest, controls_in(obj, controls), params)
    assert np.abs(moved - want).max() > 0.3
    assert close(evaluated(obj), moved, 6)
    obj.location.z += 1.0  # so does moving this object: the rest stays in its space
    update()
    assert close(evaluated(obj), expected(obj, rest, controls_in(obj, controls), params), 6)


def test_controls_in_edit_mode(scene):
    import bmesh
    import bpy
    obj, controls, rest = bound(bpy, kernel="WENDLAND_C2", radius=3.0)
    for o in bpy.context.view_layer.objects:
        o.select_set(o == controls)
    bpy.context.view_layer.objects.active = controls
    bpy.ops.object.mode_set(mode="EDIT")
    bm = bmesh.from_edit_mesh(controls.data)
    for v in bm.verts:
        if v.co.z > 0:
            v.co.x += 0.3
    bmesh.update_edit_mesh(controls.data)
    update()
    want = expected(obj, rest, controls_in(obj, controls), dict(kernel="WENDLAND_C2", radius=3.0))
    assert np.abs(want - positions(obj.data)).max() > 0.1
    assert close(evaluated(obj), want, 6)
    bpy.ops.object.mode_set(mode="OBJECT")


@pytest.mark.parametrize("use", ["SELECTED", "GROUP"])
def test_use_takes_the_selected_or_grouped_vertices_at_bind(scene, use):
    import bpy
    from addon_helpers import group_members
    from deformkit_addon import api
    obj = make_object(bpy)
    controls = make_controls(bpy)
    chosen = group_members(controls, "Top")
    if use == "SELECTED":
        select_vertices(controls, chosen)
        params = dict(controls_use="SELECTED")
    else:
        select_vertices(controls, [])
        params = dict(controls_use="GROUP", controls_group="Top")
    api.add_entry(obj, "RBF", controls=controls, **params)
    rest = controls_in(obj, controls)
    assert api.bind_rbf(obj, 0) == len(chosen) < len(controls.data.vertices)
    select_vertices(controls, range(len(controls.data.vertices)))  # read at bind only
    controls.vertex_groups["Top"].add(list(range(len(controls.data.vertices))), 1.0, "REPLACE")
    move_vertices(controls, seed=2)
    targets = controls_in(obj, controls)
    want = expected(obj, rest[chosen], targets[chosen], {})
    assert close(evaluated(obj), want, 6)
    others = np.setdiff1d(np.arange(len(controls.data.vertices)), chosen)
    co = positions(controls.data)
    co[others] += 0.5  # the vertices that are not controls do not count
    controls.data.vertices.foreach_set("co", co.ravel())
    controls.data.update()
    update()
    assert close(evaluated(obj), want, 6)


def test_rest_from_another_object_or_a_shape_key(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    controls = make_controls(bpy)
    rest_object = make_controls(bpy, "Rest")
    rest_object.location = (0.0, 0.3, 0.2)
    rest_object.scale = (1.3, 1.5, 2.0)
    update()
    api.add_entry(obj, "RBF", controls=controls, rest_from="OBJECT", rest_object=rest_object)
    api.bind_rbf(obj, 0)
    want = expected(obj, controls_in(obj, rest_object), controls_in(obj, controls), {})
    assert np.abs(want - positions(obj.data)).max() > 0.05
    assert close(evaluated(obj), want, 6)
    rest_object.location.x += 1.0  # the rest was taken at bind
    update()
    assert close(evaluated(obj), want, 6)

    controls.shape_key_add(name="Basis")
    key = controls.shape_key_add(name="Lean", from_mix=False)
    basis = controls_in(obj, controls)
    co = positions(controls.data)
    co[:, 0] += 0.4 * co[:, 2]
    key.data.foreach_set("co", co.ravel())
    key.value = 0.0
    api.remove_entry(obj, 0)
    api.add_entry(obj, "RBF", controls=controls, rest_from="SHAPE_KEY", rest_shape_key="Basis")
    api.bind_rbf(obj, 0)
    np.testing.assert_array_equal(evaluated(obj), positions(obj.data))  # the key at 0: the rest
    key.value = 1.0
    update()
    want = expected(obj, basis, controls_in(obj, controls), {})
    assert np.abs(want - positions(obj.data)).max() > 0.1
    assert close(evaluated(obj), want, 6)


def test_problems_show_on_the_entry(scene):
    import bmesh
    import bpy
    from deformkit_addon import api
    obj, controls, rest = bound(bpy)
    entry = obj.deformkit.entries[0]
    count = len(controls.data.vertices)
    bm = bmesh.new()
    bm.from_mesh(controls.data)
    bmesh.ops.subdivide_edges(bm, edges=bm.edges[:1], cuts=1)
    bm.to_mesh(controls.data)
    bm.free()
    controls.data.update()
    update()
    assert entry.error == f"bound to {count} vertices, the control object 'Controls' now has {count + 1}: Rebind"
    np.testing.assert_array_equal(evaluated(obj), positions(obj.data))  # skipped, as a broken modifier
    api.bind_rbf(obj, 0)  # bound again: fine
    assert entry.error == ""
    api.set_params(entry, kernel="QUINTIC")  # Linear is below the quintic's minimum
    assert entry.error.startswith("Polynomial: the Quintic kernel needs at least Quadratic")
    api.set_params(entry, polynomial="QUADRATIC")
    assert entry.error == ""
    api.set_params(entry, kernel="GAUSSIAN", epsilon=0.001, polynomial="NONE")  # far too flat
    assert "singular or ill-conditioned" in entry.error and "condition estimate" in entry.error
    api.set_params(entry, epsilon=1.0)
    assert entry.error == ""
    bpy.data.objects.remove(controls)
    update()
    assert entry.controls is None and "control object 'Controls' no longer exists" in entry.error

    other = make_controls(bpy, "Other")
    small = make_controls(bpy, "Small")
    bm = bmesh.new()
    bm.from_mesh(small.data)
    bm.verts.ensure_lookup_table()
    bm.verts.remove(bm.verts[0])
    bm.to_mesh(small.data)
    bm.free()
    api.set_params(entry, controls=other, rest_from="OBJECT", rest_object=small)
    with pytest.raises(ValueError, match=f"'Small' has {count - 1} vertices, the control object 'Other' {count}"):
        api.bind_rbf(obj, 0)
    api.set_params(entry, rest_from="SHAPE_KEY", rest_shape_key="Basis")
    with pytest.raises(ValueError, match="'Other' has no shape key 'Basis'"):
        api.bind_rbf(obj, 0)
    co = positions(other.data)
    co[1] = co[0]  # two controls in one place
    other.data.vertices.foreach_set("co", co.ravel())
    other.data.update()
    api.set_params(entry, rest_from="CURRENT")
    with pytest.raises(ValueError, match="coincide"):
        api.bind_rbf(obj, 0)
    api.set_params(entry, controls_use="SELECTED")
    select_vertices(other, [])
    with pytest.raises(ValueError, match="no vertex of 'Other' is selected"):
        api.bind_rbf(obj, 0)


def test_the_fit_is_kept_between_evaluations(scene):
    """Fitting factorises the system: edits of the controls only set the targets of the kept
    dk.RBF, and the mesh stays bound; the polynomial or smoothing fits again but keeps the binding
    (a compact kernel's values within the support), a kernel setting binds again. Also when the
    entry is not the first of the stack."""
    import bpy
    from deformkit_addon import api, cache
    obj, controls, rest = bound(bpy, kernel="WENDLAND_C2", radius=3.0)
    api.add_entry(obj, "TWIST", angle=0.0)
    api.move_entry_to(obj, 1, "FIRST")  # the RBF entry second: bindings are kept past the first entry too
    entry = [e for e in obj.deformkit.entries if e.type == "RBF"][0]
    move_vertices(controls, seed=3)
    fits = cache.items("rbf_deformer")
    bindings = cache.items("rbf_binding")
    assert len(fits) == 1 and len(bindings) == 1
    rbf = next(iter(fits.values()))[2]
    binding = next(iter(bindings.values()))[2]
    move_vertices(controls, seed=4)
    assert next(iter(cache.items("rbf_deformer").values()))[2] is rbf
    assert next(iter(cache.items("rbf_binding").values()))[2] is binding
    want = expected(obj, rest, controls_in(obj, controls), dict(kernel="WENDLAND_C2", radius=3.0))
    assert close(evaluated(obj), want, 6)
    api.set_params(entry, smoothing=0.01)  # a new fit, the same binding (it holds the kernel values)
    assert next(iter(cache.items("rbf_deformer").values()))[2] is not rbf
    assert next(iter(cache.items("rbf_binding").values()))[2] is binding
    api.set_params(entry, radius=2.5)
    assert next(iter(cache.items("rbf_binding").values()))[2] is not binding
    assert close(evaluated(obj), expected(obj, rest, controls_in(obj, controls),
                                          dict(kernel="WENDLAND_C2", radius=2.5, smoothing=0.01)), 6)


def test_save_and_reload_keep_the_bind(scene, tmp_path):
    import bpy
    from deformkit_addon import cache
    from deformkit_addon.entries import rbf
    obj, controls, rest = bound(bpy, controls_use="GROUP", controls_group="Top", kernel="CUBIC")
    move_vertices(controls, seed=5)
    shown = evaluated(obj).copy()
    saved_rest, indices = rbf.saved(obj.deformkit.entries[0])
    path = str(tmp_path / "rbf.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    cache.forget()
    bpy.ops.wm.open_mainfile(filepath=path)
    obj, controls = bpy.data.objects["Obj"], bpy.data.objects["Controls"]
    entry = obj.deformkit.entries[0]
    assert entry.controls == controls and rbf.is_bound(entry)
    np.testing.assert_array_equal(rbf.saved(entry)[0], saved_rest)
    np.testing.assert_array_equal(rbf.saved(entry)[1], indices)
    assert close(evaluated(obj), shown)
    move_vertices(controls, seed=6)  # edits after the reload still reach the entry
    want = expected(obj, saved_rest, controls_in(obj, controls)[indices], dict(kernel="CUBIC"))
    assert close(evaluated(obj), want, 6)


def test_batch_recipe_binds_an_rbf_entry(scene):
    import bpy
    from deformkit_addon import batch
    obj = make_object(bpy)
    controls = make_controls(bpy)
    rest = controls_in(obj, controls)
    batch.apply_recipe({"objects": ["Obj"], "deformers": [
        {"type": "RBF", "controls": "Controls", "kernel": "WENDLAND_C4", "radius": 4.0, "bind": True}]})
    entry = obj.deformkit.entries[0]
    assert entry.bind_id != 0 and entry.error == ""
    move_vertices(controls, seed=7)
    assert close(evaluated(obj), expected(obj, rest, controls_in(obj, controls),
                                          dict(kernel="WENDLAND_C4", radius=4.0)), 6)


def test_the_panel_shows_the_kernels_parameters(scene):
    import bpy
    from test_panel import draw_panel
    from deformkit_addon import api
    obj = make_object(bpy)
    controls = make_controls(bpy)
    entry = api.add_entry(obj, "RBF", controls=controls)
    for kernel, shown, hidden in (("THIN_PLATE_SPLINE", set(), {"epsilon", "radius"}),
                                  ("GAUSSIAN", {"epsilon"}, {"radius"}), ("CLIP", {"radius"}, {"epsilon"})):
        entry.kernel = kernel
        drawn = {name for kind, name in draw_panel(obj) if kind == "prop"}
        assert shown <= drawn and not hidden & drawn
        assert {"controls", "controls_use", "rest_from", "polynomial", "smoothing", "strength"} <= drawn
    log = draw_panel(obj)
    assert ("operator", "deformkit.rbf_bind") in log and ("label", "Not bound") in log
    controls.shape_key_add(name="Basis")
    for rest_from, field in (("OBJECT", "rest_object"), ("SHAPE_KEY", "rest_shape_key")):
        api.set_params(entry, controls_use="GROUP", controls_group="Top", rest_from=rest_from)
        drawn = [name for kind, name in draw_panel(obj) if kind == "prop"]
        assert field in drawn and "controls_group" in drawn
    api.set_params(entry, rest_from="CURRENT")
    api.bind_rbf(obj, 0)
    log = draw_panel(obj)
    top = len([v for v in controls.data.vertices if v.groups])
    assert ("label", f"Bound: {top} controls of {len(controls.data.vertices)} vertices") in log
    assert ("operator", "deformkit.rbf_unbind") in log


# ---------------------------------------------------------------------------------------------
# The note's clothing fit: the bodies' vertices are the controls, rest = body A, targets = body B.

BODY_AXES = np.array([0.45, 0.32, 1.0])  # an ellipsoid torso
GAP = 0.06  # the shirt's distance from body A


def body_b(co):
    """Body A's points moved to body B: a belly and a wider chest, and a lean forwards."""
    z = co[:, 2]
    out = co.copy()
    grow = 1 + 0.25 * np.exp(-((z + 0.1) / 0.35) ** 2) + 0.1 * np.exp(-((z - 0.5) / 0.3) ** 2)
    out[:, :2] *= grow[:, None]
    out[:, 1] += 0.12 * z ** 2
    return out


def make_body(bpy, name):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=24, radius=1.0)
    body = bpy.context.active_object
    body.name = name
    co = positions(body.data) * BODY_AXES.astype(np.float32)
    body.data.vertices.foreach_set("co", co.ravel())
    body.data.update()
    return body


def make_shirt(bpy):
    """An open tube around the upper part of body A, GAP from it along the ellipsoid's normals,
    its rows between the body's rings (so the shirt's vertices are not next to the controls)."""
    theta = 2 * np.pi * (np.arange(40) + 0.3) / 40
    heights = np.linspace(-0.35, 0.72, 14)
    rows = []
    for h in heights:
        scale = np.sqrt(1 - h ** 2)
        p = np.stack([BODY_AXES[0] * scale * np.cos(theta), BODY_AXES[1] * scale * np.sin(theta),
                      np.full_like(theta, h * BODY_AXES[2])], 1)
        normal = p / BODY_AXES ** 2
        rows.append(p + GAP * normal / np.linalg.norm(normal, axis=1, keepdims=True))
    co = np.vstack(rows)
    n = len(theta)
    faces = [(r * n + i, r * n + (i + 1) % n, (r + 1) * n + (i + 1) % n, (r + 1) * n + i)
             for r in range(len(heights) - 1) for i in range(n)]
    mesh = bpy.data.meshes.new("Shirt")
    mesh.from_pydata(co.tolist(), [], faces)
    mesh.update()
    shirt = bpy.data.objects.new("Shirt", mesh)
    bpy.context.scene.collection.objects.link(shirt)
    update()
    return shirt


def distance_to(body, points):
    """Each point's distance to the body's evaluated surface (Blender's BVH of its triangles), the
    points in world space."""
    import bpy
    from mathutils import Vector
    from mathutils.bvhtree import BVHTree
    dg = bpy.context.evaluated_depsgraph_get()
    tree = BVHTree.FromObject(body, dg)
    inverse = np.array(body.matrix_world.inverted())
    local = points @ inverse[:3, :3].T + inverse[:3, 3]
    return np.array([tree.find_nearest(Vector(p))[3] for p in local])


def world(obj, local):
    m = np.array(obj.matrix_world)
    return local @ m[:3, :3].T + m[:3, 3]


@pytest.mark.parametrize("rest_from", ["SHAPE_KEY", "OBJECT"])
def test_a_shirt_fitted_from_one_body_to_another_keeps_its_distance(scene, rest_from):
    """The shirt made for body A, fitted to body B by an RBF entry on the bodies' vertices (thin
    plate spline, linear), is about as far from body B as it was from body A (Blender's BVH
    distance to each body's triangles, the independent truth): the distance changes by at most
    0.0118 and by 0.0064 on average for a gap of 0.06 (measured; the gap stretches where the body
    widens by up to 25%, and the shirt moves by up to 0.118), against 0.062 and 0.042 for the
    unfitted shirt. Either way to B: body A with a shape key to B (Rest From its Basis), or A and
    B as two objects (Rest From body A, the controls body B); both equal dk.RBF."""
    import bpy
    from deformkit_addon import api
    body = make_body(bpy, "Body")
    body.location = (0.2, -0.1, 1.0)
    rest_co = positions(body.data).astype(np.float64)  # body A, in its own space
    if rest_from == "SHAPE_KEY":
        body.shape_key_add(name="Basis")
        key = body.shape_key_add(name="Body B", from_mix=False)
        key.data.foreach_set("co", body_b(rest_co).astype(np.float32).ravel())
        key.value = 0.0
        controls, params = body, dict(rest_from="SHAPE_KEY", rest_shape_key="Basis")
    else:
        controls = make_body(bpy, "Body B")
        controls.location = body.location
        controls.data.vertices.foreach_set("co", body_b(rest_co).astype(np.float32).ravel())
        controls.data.update()
        params = dict(rest_from="OBJECT", rest_object=body)
    shirt = make_shirt(bpy)
    shirt.location = (0.2, -0.1, 1.0)
    update()
    before = distance_to(body, world(shirt, positions(shirt.data).astype(np.float64)))
    assert np.abs(before - GAP).max() < 0.01  # the shirt was made GAP from body A (its flat faces)
    rest = controls_in(shirt, body)  # body A (the Basis, its key at 0)
    api.add_entry(shirt, "RBF", controls=controls, **params)
    api.bind_rbf(shirt, 0)
    if rest_from == "SHAPE_KEY":
        key.value = 1.0
        update()
    fitted = evaluated(shirt).astype(np.float64)
    assert close(fitted, expected(shirt, rest, controls_in(shirt, controls), {}), 3)
    target = controls if rest_from == "OBJECT" else body
    after = distance_to(target, world(shirt, fitted))
    unfitted = distance_to(target, world(shirt, positions(shirt.data).astype(np.float64)))
    change = np.abs(after - before)
    # Measured: at most 0.0118 and 0.0064 on average (both ways to B), against 0.062 and 0.042 unfitted.
    assert change.max() < 0.25 * GAP and change.mean() < 0.15 * GAP, (change.max(), change.mean())
    assert change.mean() < np.abs(unfitted - before).mean() / 5
    assert (after > 0.8 * GAP).all()  # nowhere closer to the body than 0.8 of the gap (measured 0.994)

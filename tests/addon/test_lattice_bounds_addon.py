"""The Lattice entry's fold warning, its Select button, the Volume figure and Preserve Volume, in
Blender: against the module's certificate on the mesh's own points, volume ratios sampled densely,
the divergence-theorem volume of the deformed lattice box and of the evaluated mesh, and the
support of each basis's weights written out."""
import numpy as np
import pytest

from addon_helpers import (CheckingLayout, evaluated, lattice_points, make_lattice, make_object, positions,
                           select_vertices, to_world, update)

CLASSES = {"BLENDER": "BlenderLattice", "BERNSTEIN": "FFD", "BEZIER": "BezierFFD", "BSPLINE": "BSplineLattice"}
# (basis, resolution, the grid index (i, j, k) of the point pulled through its neighbour along u,
# or (i,) for the whole layer i, and its new u); the smooth bases need a layer pulled to fold
FOLDS = {
    "blender_bspline": ("BLENDER", (3, 3, 3), (1,), 1.2),
    "blender_linear": ("BLENDER", (3, 3, 3), (1, 1, 1), 0.8),
    "bernstein": ("BERNSTEIN", (3, 3, 3), (1,), 1.2),
    "bezier": ("BEZIER", (4, 4, 4), (1,), 1.2),
    "bspline": ("BSPLINE", (5, 5, 5), (2,), 0.8),
    "blender_partly_outside": ("BLENDER", (4, 4, 4), (1,), 0.9),
}
# A lattice smaller than the mesh: points outside it too, clamped (their cells are Blender's outside cells).
SCALES = {"blender_partly_outside": (1.6, 1.5, 2.6)}


def dk_lattice(obj, lat, basis, strength=1.0):
    """The entry's lattice built here from the Lattice object (its frame and co_deform - co), not
    through the add-on: the rest grid spans [-1/2, 1/2] (make_lattice), so the frame is the
    lattice's placement in obj's space."""
    import deformkit as dk
    frame = np.array(obj.matrix_world.inverted() @ lat.matrix_world)
    resolution = (lat.data.points_u, lat.data.points_v, lat.data.points_w)
    kwargs = dict(frame=frame, strength=strength)
    if basis == "BLENDER":
        axes = tuple(getattr(lat.data, f"interpolation_type_{a}") for a in "uvw")
        made = dk.BlenderLattice(resolution, axes, **kwargs)
    elif basis == "BERNSTEIN":
        made = dk.FFD(tuple(n - 1 for n in resolution), **kwargs)
    elif basis == "BEZIER":
        made = dk.BezierFFD(tuple((n - 1) // 3 for n in resolution), **kwargs)
    else:
        made = dk.BSplineLattice(resolution, **kwargs)
    offsets = (lattice_points(lat) - lattice_points(lat, "co")).astype(np.float64)
    grid = offsets.reshape(*resolution[::-1], 3).transpose(2, 1, 0, 3) @ frame[:3, :3].T
    made.control_points = made.rest_control_points + grid
    return made, frame


def blender_index(resolution, i, j, k):
    return i + resolution[0] * (j + resolution[1] * k)


def pull_through(lat, resolution, point, u):
    co = lattice_points(lat, "co")
    i = np.arange(len(co)) % resolution[0]
    if len(point) == 3:
        co[blender_index(resolution, *point), 0] = u
    else:
        co[i == point[0], 0] = u
    lat.data.points.foreach_set("co_deform", co.ravel())
    lat.data.update_tag()
    update()


def setup_case(bpy, case):
    from deformkit_addon import api
    basis, resolution, _point, _u = FOLDS[case]
    obj = make_object(bpy)
    lat = make_lattice(bpy, resolution=resolution, scale=SCALES.get(case, (3.4, 3.0, 4.8)),
                       interpolation="KEY_LINEAR" if case == "blender_linear" else "KEY_BSPLINE")
    api.add_entry(obj, "LATTICE", lattice=lat, lattice_basis=basis)
    update()
    return obj, lat


def occupied_samples(dk_lat, points, resolution, per_axis=6):
    """A dense grid inside each grid interval the points occupy (in the lattice's space): every
    basis's cells are unions of these intervals."""
    frame_inv_points = dk_lat.lattice_coordinates(points)  # in [0, 1]^3
    bins = np.maximum(np.array(resolution) - 1, 1)
    inside = ((frame_inv_points >= 0) & (frame_inv_points <= 1)).all(axis=1)
    cells = np.unique(np.clip(np.floor(frame_inv_points[inside] * bins), 0, bins - 1).astype(int), axis=0)
    t = (np.arange(per_axis) + 0.5) / per_axis
    local = np.stack(np.meshgrid(t, t, t, indexing="ij"), -1).reshape(-1, 3)
    return cells, np.concatenate([(c + local) / bins for c in cells])


def panel_log(obj):
    import types

    from deformkit_addon import ui
    log = []
    ui.DEFORMKIT_PT_stack.draw(types.SimpleNamespace(layout=CheckingLayout(log)),
                               types.SimpleNamespace(object=obj))
    return log


def labels(log):
    return [text for kind, text in log if kind == "label"]


def box_surface(m, half=0.5):
    """The surface of the cube [-half, half]^3, m x m quads per face split into triangles, outward."""
    t = np.linspace(-half, half, m + 1)
    a, b = np.meshgrid(t, t, indexing="ij")
    points, triangles = [], []
    for axis in range(3):
        for side in (-0.5, 0.5):
            grid = np.zeros((m + 1, m + 1, 3))
            others = [x for x in range(3) if x != axis]
            grid[..., others[0]], grid[..., others[1]], grid[..., axis] = a, b, side * 2 * half
            base = sum(len(p) for p in points)
            points.append(grid.reshape(-1, 3))
            idx = base + np.arange((m + 1) ** 2).reshape(m + 1, m + 1)
            q = np.stack([idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]], -1).reshape(-1, 4)
            tris = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
            # (others[0], others[1], axis) is right-handed for axis 0 and 2, left-handed for 1.
            outward = (side > 0) == (axis != 1)
            triangles.append(tris if outward else tris[:, ::-1])
    return np.concatenate(points), np.concatenate(triangles)


def divergence_volume(points, triangles):
    a, b, c = (points[triangles[:, i]] for i in range(3))
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


# ---------------------------------------------------------------------------------------------
# The fold warning and Select

@pytest.mark.parametrize("case", list(FOLDS))
def test_a_folded_lattice_shows_the_warning_as_the_module_certifies(scene, case):
    import bpy
    from deformkit_addon import api, evaluation
    basis, resolution, point, u = FOLDS[case]
    obj, lat = setup_case(bpy, case)
    points = evaluation.entry_input(obj, 0).astype(np.float64)
    for state in ("rest", "folded"):
        if state == "folded":
            pull_through(lat, resolution, point, u)
        bounds = api.lattice_bounds(obj, 0)
        dk_lat, frame = dk_lattice(obj, lat, basis)
        assert np.abs(dk_lat.deform(points) - evaluated(obj)).max() < 1e-5  # the same lattice as Blender's
        certificate = dk_lat.fold_free(points)  # the module on the mesh's own points
        if case in SCALES:
            assert (dk_lat.bind(points).status == 1).sum() > 50
        cells, samples = occupied_samples(dk_lat, points, resolution)
        ratios = dk_lat.volume_ratio((samples - 0.5) @ frame[:3, :3].T + frame[:3, 3])
        ratios = np.concatenate([ratios, dk_lat.volume_ratio(points)])
        text = " ".join(labels(panel_log(obj)))  # a long message is wrapped over several labels
        shown = "lattice folds" in text or "may fold" in text
        if state == "rest":
            assert bool(certificate) and bounds.folds is False and not shown
            assert ratios.min() > 0
        else:
            assert not certificate and (ratios <= 0).any(), ratios.min()  # it folds where the mesh is
            assert bounds.folds is True and shown, (bounds, shown)
            assert bounds.lower <= ratios.min() + 1e-12  # a bound of every sampled value
            lower, _upper = dk_lat.volume_ratio_bounds(points=points)
            assert abs(bounds.lower - lower) <= 1e-9 * max(1.0, abs(lower))
            assert {c[0] for c in bounds.cells} == {tuple(c[0]) for c in certificate.cells}
            assert f"The lattice folds: volume ratio down to {bounds.lower:.2f} in {len(bounds.cells)} cell" in text
        # The warning appears exactly when a sampled value is <= 0 or the certificate fails.
        assert shown == ((ratios <= 0).any() or not certificate)


def test_the_check_runs_after_an_edit_not_during_it(scene):
    """A lattice edit schedules the check (a timer, pushed back by every update); evaluation itself
    computes nothing, and what the timer runs brings the panel up to date."""
    import bpy
    from deformkit_addon import handlers, meshdata
    from deformkit_addon.entries import lattice as lattices
    basis, resolution, point, u = FOLDS["blender_linear"]
    obj, lat = setup_case(bpy, "blender_linear")
    handlers.check_lattices()
    key = meshdata.cache_key(obj)
    rest = lattices.kept_bounds(key, 0)
    assert rest.folds is False and lattices.bounds_current(key, 0, rest)
    if bpy.app.timers.is_registered(handlers.check_lattices):
        bpy.app.timers.unregister(handlers.check_lattices)
    pull_through(lat, resolution, point, u)  # evaluates, through the depsgraph handler
    assert bpy.app.timers.is_registered(handlers.check_lattices)
    assert lattices.kept_bounds(key, 0) is rest and not lattices.bounds_current(key, 0, rest)
    assert "lattice folds" not in " ".join(labels(panel_log(obj)))  # the last result until the check
    handlers.check_lattices()  # what the timer runs
    assert lattices.kept_bounds(key, 0).folds is True
    assert "lattice folds" in " ".join(labels(panel_log(obj)))


def cell_support(basis, resolution, cell, interpolation):
    """Grid indices (i, j, k) whose weight functions are non-zero on the cell, from each basis's
    definition: Bernstein all, a Bezier block its 4, a B-spline span its 4, Blender's linear cell
    its 2 and Blender's cubic cell 4 around it, clamped to the grid."""
    ranges = []
    for n, c in zip(resolution, cell):
        if basis == "BERNSTEIN":
            r = range(n)
        elif basis == "BEZIER":
            r = range(3 * c, 3 * c + 4)
        elif basis == "BSPLINE":
            r = range(c, c + 4)
        elif interpolation == "KEY_LINEAR":
            r = {min(max(x, 0), n - 1) for x in (c, c + 1)}
        else:
            r = {min(max(x, 0), n - 1) for x in range(c - 1, c + 3)}
        ranges.append(sorted(r))
    return {(i, j, k) for i in ranges[0] for j in ranges[1] for k in ranges[2]}


@pytest.mark.parametrize("case", list(FOLDS))
def test_select_picks_the_points_of_the_folded_cells_and_undoes(scene, case):
    import bpy
    from deformkit_addon import api
    basis, resolution, point, u = FOLDS[case]
    obj, lat = setup_case(bpy, case)
    with bpy.context.temp_override(object=obj, active_object=obj):
        with pytest.raises(RuntimeError, match="does not fold where the mesh is"):
            bpy.ops.deformkit.lattice_select_folded()
    pull_through(lat, resolution, point, u)
    bounds = api.lattice_bounds(obj, 0)
    assert bounds.cells
    expected = set()
    for cell, *_rest in bounds.cells:
        expected |= cell_support(basis, resolution, cell, lat.data.interpolation_type_u)
    expected = {blender_index(resolution, *ijk) for ijk in expected}
    before = np.arange(len(lat.data.points)) % 5 == 0  # some other selection (a new lattice has all)
    lat.data.points.foreach_set("select", before)
    lat.data.update_tag()  # undo stores the data that changed
    update()
    bpy.ops.ed.undo_push(message="before select")
    with bpy.context.temp_override(object=obj, active_object=obj):
        assert bpy.ops.deformkit.lattice_select_folded("EXEC_DEFAULT", True) == {"FINISHED"}
    assert lat.mode == "EDIT" and bpy.context.view_layer.objects.active == lat
    selected = np.zeros(len(lat.data.points), bool)  # in Edit Mode: the edit copy's flags
    lat.data.points.foreach_get("select", selected)
    assert set(np.flatnonzero(selected)) == expected
    bpy.ops.ed.undo()
    lat = bpy.data.objects["Lattice"]
    assert lat.mode == "OBJECT"
    lat.data.points.foreach_get("select", selected)
    np.testing.assert_array_equal(selected, before)


# ---------------------------------------------------------------------------------------------
# The Volume figure

@pytest.mark.parametrize("case", ["blender_bspline", "bezier", "bspline"])
def test_volume_change_is_the_deformed_box_volume(scene, case):
    import bpy
    from deformkit_addon import api
    basis, resolution, _point, _u = FOLDS[case]
    obj, lat = setup_case(bpy, case)
    assert abs(api.lattice_bounds(obj, 0).volume_change) < 1e-12  # at rest
    co = lattice_points(lat, "co")
    rng = np.random.default_rng(4)
    co += rng.uniform(-0.04, 0.04, co.shape).astype(np.float32) + np.float32(0.06) * co  # a 6 % growth and noise
    lat.data.points.foreach_set("co_deform", co.ravel())
    lat.data.update_tag()
    update()
    bounds = api.lattice_bounds(obj, 0)
    dk_lat, frame = dk_lattice(obj, lat, basis)
    # The lattice's region: the box, or for the B-spline its inner part (one interval in from each side).
    half = 0.5 - (1 / (resolution[0] - 1) if basis == "BSPLINE" else 0.0)
    rest = abs(np.linalg.det(frame[:3, :3])) * (2 * half) ** 3
    surface, triangles = box_surface(96, half)
    deformed = dk_lat.deform(surface @ frame[:3, :3].T + frame[:3, 3])
    measured = divergence_volume(deformed, triangles) / rest - 1.0  # converges as h^2
    assert abs(measured) > 0.1
    assert abs(bounds.volume_change - measured) < 2e-4 * (1 + abs(measured)), (bounds.volume_change, measured)
    assert f"Volume: {100 * measured:+.1f}%" in labels(panel_log(obj))


# ---------------------------------------------------------------------------------------------
# Preserve Volume

def mesh_volume(obj, co):
    from deformkit_addon import meshdata
    triangles = meshdata.triangles(meshdata.topology(obj.data))
    return divergence_volume(co.astype(np.float64), triangles)


def test_preserve_volume_keeps_the_evaluated_volume_and_moves_the_selection(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    lat = make_lattice(bpy, resolution=(4, 4, 4), scale=(3.0, 3.0, 4.5))
    entry = api.add_entry(obj, "LATTICE", lattice=lat, lattice_basis="BSPLINE")
    z = positions(obj.data)[:, 2]
    chosen = np.flatnonzero(z > 0.7 * z.max())
    select_vertices(obj, chosen)
    start = lattice_points(lat).copy()
    before = evaluated(obj).copy()
    volume = mesh_volume(obj, before)
    cursor = to_world(obj, before[chosen]).mean(axis=0) + np.array([0.2, -0.1, 0.35])
    scene.cursor.location = cursor
    results = {}
    for preserve in (False, True):
        lat.data.points.foreach_set("co_deform", start.ravel())
        lat.data.update_tag()
        update()
        entry.preserve_volume = preserve
        with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj]):
            assert bpy.ops.deformkit.lattice_direct(targets="CURSOR") == {"FINISHED"}
        after = evaluated(obj)
        moved = to_world(obj, after[chosen]).mean(axis=0)
        results[preserve] = (mesh_volume(obj, after) / volume - 1.0, np.abs(moved - cursor).max())
    plain, kept = results[False], results[True]
    assert abs(plain[0]) > 1e-3, plain  # the plain edit changes the volume
    # Blender stores the evaluated positions and the lattice points in float32 (an ulp is 6e-8 of a
    # coordinate): rounding them alone moves a sphere's volume by a few 1e-9 (measured in float64
    # with the same lattice), so 1e-7 here; the solve itself keeps it to 1e-12 (below).
    assert abs(kept[0]) < 1e-7, kept
    assert kept[1] < 1e-4, kept  # and the selection still reaches the cursor
    result = api.direct_manipulation(obj, 0, chosen, before[chosen] + 0.1, preserve_volume=True)
    assert result.volume_residual <= 1e-9  # relative: the module's solve itself
    bpy.ops.ed.undo_push(message="before")
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj]):
        assert bpy.ops.deformkit.lattice_direct("EXEC_DEFAULT", True, targets="CURSOR") == {"FINISHED"}
    moved = lattice_points(lat).copy()
    bpy.ops.ed.undo()
    lat = bpy.data.objects["Lattice"]
    assert not np.array_equal(lattice_points(lat), moved)


def test_preserve_volume_is_saved_and_refuses_a_vertex_group(scene, tmp_path):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    lat = make_lattice(bpy, resolution=(3, 3, 3))
    api.add_entry(obj, "LATTICE", lattice=lat, preserve_volume=True, vertex_group="Upper")
    path = str(tmp_path / "preserve.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    obj, lat = bpy.data.objects["Obj"], bpy.data.objects["Lattice"]
    assert obj.deformkit.entries[0].preserve_volume
    select_vertices(obj, [int(np.argmax(positions(obj.data)[:, 2]))])
    scene = bpy.context.scene
    scene.cursor.location = (0.4, 0.0, 2.0)
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj]):
        with pytest.raises(RuntimeError, match="clear the entry's vertex group 'Upper'"):
            bpy.ops.deformkit.lattice_direct(targets="CURSOR")
    np.testing.assert_array_equal(lattice_points(lat), lattice_points(lat, "co"))


def test_preserve_volume_refuses_an_open_mesh(scene):
    import bpy
    from deformkit_addon import api
    bpy.ops.mesh.primitive_uv_sphere_add(segments=12, ring_count=8)
    obj = bpy.context.active_object
    obj.name = "Bowl"
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="DESELECT")
    bpy.ops.object.mode_set(mode="OBJECT")
    top = int(np.argmax([v.co.z for v in obj.data.vertices]))
    obj.data.vertices[top].select = True
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.delete(type="VERT")  # the pole and its 12 triangles: a hole of 12 edges
    bpy.ops.object.mode_set(mode="OBJECT")
    lat = make_lattice(bpy, resolution=(3, 3, 3), location=(0, 0, 0), rotation=(0, 0, 0), scale=(3, 3, 3))
    entry = api.add_entry(obj, "LATTICE", lattice=lat, preserve_volume=True)
    assert entry.preserve_volume
    select_vertices(obj, [0, 1])
    scene.cursor.location = (0.1, 0.2, 0.3)
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj]):
        with pytest.raises(RuntimeError, match="Preserve Volume needs a closed mesh: 'Bowl' has 12 open edges"):
            bpy.ops.deformkit.lattice_direct(targets="CURSOR")
    np.testing.assert_array_equal(lattice_points(lat), lattice_points(lat, "co"))  # nothing moved

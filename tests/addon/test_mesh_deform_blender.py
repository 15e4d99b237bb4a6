"""dk.MeshDeform against Blender's own Mesh Deform modifier (bpy 5.0 here, Blender 3.4 through
test_blender34.py): the same cage bound on the same mesh, then the cage moved (a seeded random move
of every vertex, and the cage's `_Cage_Deformed` pose of ../shared/cages); the positions agree
within 1e-5 of the cage's bounding-box diagonal for 99% of the vertices and 1e-4 for all (float32
Blender against float64 deformkit: the differences measured are about 3e-7)."""
import pathlib

import numpy as np
import pytest

import deformkit as dk

CAGES = pathlib.Path(__file__).resolve().parents[2].parent / "shared" / "cages"

# (model, precision, dynamic): precisions 3 to 6, both bind modes; Ogre has vertices outside its
# cage and rays that meet it several times (the inside test's hard cases).
CASES = [("Ogre", 3, False), ("Ogre", 4, True), ("Ogre", 5, False), ("Ogre", 6, False),
         ("ManHead", 5, True), ("FireHydrant", 4, False), ("Beast", 5, True), ("WireSphere", 4, False)]


def require_cages():
    if not CAGES.is_dir():
        pytest.skip(f"{CAGES} not found: the shared cages are not beside this checkout")


def read_obj(path):
    """Vertices and polygons as the OBJ lists them (quads kept: the cage's split is Blender's)."""
    points, faces = [], []
    for line in path.read_text().splitlines():
        if line.startswith("v "):
            points.append([float(v) for v in line.split()[1:4]])
        elif line.startswith("f "):
            faces.append([int(c.split("/")[0]) - 1 for c in line.split()[1:]])
    return np.array(points), faces


def add_object(bpy, name, points, faces):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(p) for p in points], [], faces)
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def vertex_positions(mesh):
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    return co.reshape(-1, 3).astype(np.float64)


def evaluated_positions(bpy, obj):
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = evaluated.to_mesh()
    try:
        return vertex_positions(mesh)
    finally:
        evaluated.to_mesh_clear()


def set_cage(cage, points):
    cage.data.vertices.foreach_set("co", np.asarray(points, np.float32).ravel())
    cage.data.update()


@pytest.mark.parametrize("model,precision,dynamic", CASES)
def test_mesh_deform_equals_blenders_modifier(scene, bpy_module, model, precision, dynamic):
    require_cages()
    bpy = bpy_module
    mesh_points, mesh_faces = read_obj(CAGES / f"{model}.obj")
    cage_points, cage_faces = read_obj(CAGES / f"{model}_Cage.obj")
    deformed, _ = read_obj(CAGES / f"{model}_Cage_Deformed.obj")
    obj = add_object(bpy, "Mesh", mesh_points, mesh_faces)
    cage = add_object(bpy, "Cage", cage_points, cage_faces)
    modifier = obj.modifiers.new("MeshDeform", "MESH_DEFORM")
    modifier.object = cage
    modifier.precision = precision
    modifier.use_dynamic_bind = dynamic
    bpy.context.view_layer.objects.active = obj
    with bpy.context.temp_override(object=obj, active_object=obj):
        bpy.ops.object.meshdeform_bind(modifier=modifier.name)
    assert modifier.is_bound

    # Blender's float32 coordinates, as both sides see them.
    rest = vertex_positions(obj.data)
    rest_cage = vertex_positions(cage.data)
    md = dk.MeshDeform(rest_cage, cage_faces, precision=precision, dynamic=dynamic,
                       blender_version=tuple(bpy.app.version[:2]))
    binding = md.bind(rest)
    assert np.array_equal(md.deform_bound(binding), rest)  # at rest: the identity, bit for bit
    diagonal = np.linalg.norm(rest_cage.max(0) - rest_cage.min(0))
    rng = np.random.default_rng(precision + 10 * dynamic)
    poses = {"random": rest_cage + rng.normal(scale=0.03 * diagonal, size=rest_cage.shape), "deformed": deformed}
    for pose, points in poses.items():
        set_cage(cage, points)
        expected = evaluated_positions(bpy, obj)
        md.cage_points = vertex_positions(cage.data)
        got = md.deform_bound(binding)
        error = np.linalg.norm(got - expected, axis=1) / diagonal
        moved = np.linalg.norm(expected - rest, axis=1).max() / diagonal
        assert moved > 0.02, f"{pose}: Blender's modifier barely moved the mesh ({moved:.2g})"
        assert np.quantile(error, 0.99) <= 1e-5, f"{model} p{precision} {pose}: 99th percentile {np.quantile(error, 0.99):.3g}"
        assert error.max() <= 1e-4, f"{model} p{precision} {pose}: vertex {error.argmax()} off by {error.max():.3g}"
    # The points deformkit finds outside the cage are those Blender leaves where they were.
    assert np.all(expected[~binding.inside] == rest[~binding.inside])
    assert np.all(got[~binding.inside] == rest[~binding.inside])

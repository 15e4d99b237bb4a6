"""dk.mesh_volume against trimesh's volume (an independent implementation) and invariants."""
import numpy as np
import pytest
import trimesh

import deformkit as dk


def test_matches_trimesh_on_a_sphere_and_a_box():
    for mesh in (trimesh.creation.icosphere(subdivisions=3, radius=0.7), trimesh.creation.box(extents=(1, 2, 3))):
        assert dk.mesh_volume(mesh.vertices, mesh.faces) == pytest.approx(mesh.volume, rel=1e-12)


def test_quads_are_fanned():
    box = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    # Merge the box's triangle pairs into quads: the same surface, so the same volume.
    quads = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
    v = box.vertices
    tri = np.vstack([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    assert abs(dk.mesh_volume(v, quads)) == pytest.approx(1.0, rel=1e-12)
    assert dk.mesh_volume(v, quads) == pytest.approx(dk.mesh_volume(v, tri), rel=1e-12)


def test_far_from_the_origin_and_reversed():
    mesh = trimesh.creation.icosphere(subdivisions=2)
    far = mesh.vertices + 1e6
    assert dk.mesh_volume(far, mesh.faces) == pytest.approx(mesh.volume, rel=1e-9)
    assert dk.mesh_volume(mesh.vertices, mesh.faces[:, ::-1]) == pytest.approx(-mesh.volume, rel=1e-12)


def test_twisted_volume_converges_to_the_original():
    # Twist is volume preserving (det J = 1); flat facets only approximate the twisted surface,
    # with an error that falls as h^2: four times per subdivision.
    mesh = trimesh.creation.box(extents=(0.6, 0.6, 2.0)).subdivide().subdivide()
    errors = []
    for _ in range(3):
        moved = dk.Twist(rate=1.5).deform(mesh.vertices)
        errors.append(abs(dk.mesh_volume(moved, mesh.faces) / mesh.volume - 1))
        mesh = mesh.subdivide()
    assert errors[-1] < 3e-3
    assert 3.5 < errors[0] / errors[1] < 4.5 and 3.5 < errors[1] / errors[2] < 4.5


@pytest.mark.parametrize("faces, match", [
    (np.array([[0, 1, 7]]), "faces: face 0 has corner index 7"),
    (np.array([[0, -1, 2]]), "faces: face 0 has corner index -1"),
    (np.array([[0, 1]]), "faces: expected shape"),
    (np.array([[0.0, 1.0, 2.0]]), "faces: expected integer"),
])
def test_bad_faces(faces, match):
    pts = np.random.default_rng(0).random((3, 3))
    with pytest.raises((ValueError, TypeError), match=match):
        dk.mesh_volume(pts, faces)


@pytest.mark.parametrize("faces", [np.array([[0, 1, 1]], np.int32), np.array([[0, 1, 2], [0, 2, 2]]),
                                   [[0, 1, 2], [2, 0, 1, 0]]])
def test_a_face_repeating_a_vertex_is_refused_as_everywhere(faces):
    """The same face check as every other mesh entry point (SurfaceDeformer, subdivide, the cages):
    the face is named, through each of mesh_volume's three readings of faces."""
    pts = np.random.default_rng(0).random((3, 3))
    bad = next(i for i, f in enumerate(faces) if len(set(f)) < len(f))
    with pytest.raises(ValueError, match=rf"^faces: face {bad} repeats vertex"):
        dk.mesh_volume(pts, faces)
    with pytest.raises(ValueError, match=rf"^faces: face {bad} repeats vertex"):
        dk.cotangent_laplacian(pts, faces)

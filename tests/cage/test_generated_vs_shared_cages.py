"""Generated cages against the hand-made cages of ../shared/cages, at the same number of
triangles: valid, around every vertex and edge of the model (which the hand-made cages are not
always), and at least as tight by volume and by mean one-sided distance from cage to model (all
but Bench, whose hand-made cage is tighter: its figures are in docs/benchmarks.md)."""
import numpy as np
import pytest

import deformkit as dk
from cage_files import CAGES, MODELS, load_mesh, read_polygons, require_cages
from generated_cage_checks import assert_encloses, assert_valid_cage, fan, signed_volume

WITH_MESH = [m for m in MODELS if m != "Cactus"]  # the Cactus mesh is not shared


def one_sided_distance(cage_points, cage_triangles, mesh_points):
    """Mean distance from 20,000 points spread evenly over the cage to the model's nearest vertex."""
    import trimesh
    from scipy.spatial import cKDTree
    samples, _ = trimesh.sample.sample_surface_even(trimesh.Trimesh(cage_points, cage_triangles, process=False), 20000,
                                                    seed=0)
    return cKDTree(mesh_points).query(samples)[0].mean()


@pytest.mark.parametrize("name", WITH_MESH)
def test_a_generated_cage_encloses_the_model_and_hugs_it(name, record_property):
    require_cages()
    mesh = load_mesh(name)
    points, faces = np.asarray(mesh.vertices, float), np.asarray(mesh.faces)
    hand_points, hand_faces = read_polygons(CAGES / f"{name}_Cage.obj")
    hand = fan(hand_faces)
    cp, ct = dk.generate_cage(points, faces, max_faces=len(hand))
    assert_valid_cage(cp, ct, len(hand))
    assert_encloses(cp, ct, points, faces)
    volume, hand_volume = signed_volume(cp, ct), signed_volume(hand_points, hand)
    distance, hand_distance = one_sided_distance(cp, ct, points), one_sided_distance(hand_points, hand, points)
    record_property("volume_over_hand", float(volume / hand_volume))
    record_property("distance_over_hand", float(distance / hand_distance))
    if name == "Bench":  # measured 1.62 and 1.14: the hand-made cage is tighter here
        assert volume < 1.8 * hand_volume and distance < 1.3 * hand_distance
    else:
        assert volume < hand_volume and distance < hand_distance


def test_the_enclosure_check_catches_the_hand_made_cage_that_lets_a_vertex_out():
    """The check the generated cages pass fails on ManHead's hand-made cage (one vertex outside)."""
    require_cages()
    mesh = load_mesh("ManHead")
    hand_points, hand_faces = read_polygons(CAGES / "ManHead_Cage.obj")
    with pytest.raises(AssertionError, match="1 points outside the cage"):
        assert_encloses(hand_points, fan(hand_faces), np.asarray(mesh.vertices, float), np.asarray(mesh.faces))

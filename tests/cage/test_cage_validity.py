"""Cage validity decided exactly (docs/cage.md, "Cage validity"): both cage types refuse a cage
whose faces meet anywhere but in the vertices and edges they share, touching included, and accept
a valid cage at every rigid placement. The truth is an exact rational check (rational_intersection)
and the construction of each cage."""
import re

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import deformkit as dk

from cage_files import CAGES, MODELS, read_polygons, require_cages
from rational_intersection import meeting_faces, meeting_pairs

CUBE = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
CUBE_FACES = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
TET_FACES = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]
ULP = 2.0 ** -52  # 1 + ULP is the double after 1
CAGE_TYPES = [dk.MeanValueCage, dk.GreenCage]
SELF_INTERSECTING = re.compile(r"^cage_faces: faces (\d+) and (\d+) intersect \(the cage intersects itself\)$")


def joined(a, a_faces, b, b_faces):
    return np.vstack([a, b]), a_faces + [[v + len(a) for v in f] for f in b_faces]


def tetrahedron(*corners):
    p = np.array(corners, float)
    outward = np.linalg.det(p[1:] - p[0]) > 0
    return p, [f if outward else f[::-1] for f in TET_FACES]


def assert_refused_as_exact(points, faces):
    truth = meeting_faces(points, faces)
    assert truth, "the construction was meant to touch itself"
    for cage_type in CAGE_TYPES:
        with pytest.raises(ValueError) as info:
            cage_type(points, faces)
        found = SELF_INTERSECTING.match(str(info.value))
        assert found, str(info.value)
        assert (int(found[1]), int(found[2])) in truth, (str(info.value), truth)


def assert_accepted_as_exact(points, faces, volume):
    assert meeting_faces(points, faces) == set()
    for cage_type in CAGE_TYPES:
        assert cage_type(points, faces).volume == pytest.approx(volume, rel=1e-12)


@pytest.mark.parametrize("shift", [(0.3, 0.3, 0.3), (0.9, 0.9, 0.9), (0.1, 0, 0), (0.31, 0.37, 0.43),
                                   (0.5, 0.5, 0.5), (0, 0, 0.5)])
def test_overlapping_cubes_are_refused(shift):
    # The first three cross along curves through the cubes' edges and vertices.
    assert_refused_as_exact(*joined(CUBE, CUBE_FACES, CUBE + shift, CUBE_FACES))


@pytest.mark.parametrize("touching, apart", [
    ((1, 0, 0), (1 + ULP, 0, 0)),              # face on face
    ((1, 1, 0), (1 + ULP, 1, 0)),              # edge on edge
    ((1, 1, 1), (1 + ULP, 1, 1)),              # vertex on vertex
    ((0.5, 0.5, 1), (0.5, 0.5, 1 + ULP)),      # faces overlapping in one plane
    ((0, 0.5, 1), (0, 0.5, 1 + ULP)),
])
def test_cubes_that_touch_are_refused_and_one_ulp_apart_accepted(touching, apart):
    assert_refused_as_exact(*joined(CUBE, CUBE_FACES, CUBE + touching, CUBE_FACES))
    assert_accepted_as_exact(*joined(CUBE, CUBE_FACES, CUBE + apart, CUBE_FACES), volume=2.0)


# Each tetrahedron touches the cube at one point only (all of it has z - y >= 1, or z >= 1).
CONTACTS = {
    "vertex on a face": [(0.5, 0.5, 1), (0, 0, 2), (1, 0, 2), (0.5, 1, 2)],
    "vertex on an edge": [(0.5, 0, 1), (0, -1, 2), (1, -1, 2), (0.5, 0.5, 2)],
    "edge through an edge": [(0.5, -0.5, 0.5), (0.5, 0.5, 1.5), (0, -1, 1.5), (1, -1, 1.5)],
}


@pytest.mark.parametrize("contact", CONTACTS)
def test_a_point_contact_is_refused_and_one_ulp_apart_accepted(contact):
    tet, tet_faces = tetrahedron(*CONTACTS[contact])
    assert_refused_as_exact(*joined(CUBE, CUBE_FACES, tet, tet_faces))
    lifted = tet + (0, 0, ULP)
    volume = 1 + abs(np.linalg.det(lifted[1:] - lifted[0])) / 6
    assert_accepted_as_exact(*joined(CUBE, CUBE_FACES, lifted, tet_faces), volume=volume)


def test_cubes_on_a_grid_of_contacts_agree_with_the_rational_check():
    # Shifts on a grid of quarters: faces, edges and vertices land on each other in every way.
    rng = np.random.default_rng(29)
    refused = 0
    for _ in range(24):
        shift = rng.integers(-5, 6, 3) / 4
        points, faces = joined(CUBE, CUBE_FACES, CUBE + shift, CUBE_FACES)
        if meeting_faces(points, faces):
            refused += 1
            assert_refused_as_exact(points, faces)
        else:
            assert dk.MeanValueCage(points, faces).volume == 2.0
    assert 4 <= refused <= 20  # both outcomes were exercised


def prism(ring, z0=0.0):
    k = len(ring)
    points = np.vstack([np.c_[ring, np.full(k, z0)], np.c_[ring, np.full(k, z0 + 1.0)]])
    faces = [list(range(k))[::-1], list(range(k, 2 * k))] + [[i, (i + 1) % k, k + (i + 1) % k, k + i]
                                                            for i in range(k)]
    return points, faces


def regular(k):
    a = 2 * np.pi * np.arange(k) / k
    return np.c_[np.cos(a), np.sin(a)]


def star(k):
    a = np.pi * np.arange(2 * k) / k
    r = np.where(np.arange(2 * k) % 2, 0.45, 1.0)
    return np.c_[r * np.cos(a), r * np.sin(a)]


def shoelace(ring):
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * (x @ np.roll(y, -1) - y @ np.roll(x, -1))


def test_the_hexagonal_prism_turned_19_degrees_about_x_is_accepted():
    points, faces = prism(regular(6), z0=-0.5)
    turned = points @ Rotation.from_euler("x", 19, degrees=True).as_matrix().T
    for cage_type in CAGE_TYPES:
        cage = cage_type(turned, faces)
        assert cage.volume == pytest.approx(shoelace(regular(6)), rel=1e-12)
        assert meeting_pairs(turned, cage.triangles) == []


SHAPES = [(f"{k}-gon", regular(k), -0.5) for k in range(5, 13)] + [(f"{k}-star", star(k), 0.0) for k in (3, 4, 5)]


@pytest.mark.parametrize("name, ring, z0", SHAPES, ids=[s[0] for s in SHAPES])
def test_prisms_are_accepted_at_every_rigid_placement(name, ring, z0):
    points, faces = prism(ring, z0)
    rotations = Rotation.random(40, random_state=sum(map(ord, name)))
    shifts = np.random.default_rng(len(name)).uniform(-3, 3, (40, 3))
    for r, (rotation, shift) in enumerate(zip(rotations.as_matrix(), shifts)):
        placed = points @ rotation.T + shift
        cage_type = CAGE_TYPES[r % 2]
        cage = cage_type(placed, faces)
        assert cage.volume == pytest.approx(shoelace(ring), rel=1e-12)
        assert len(cage.triangles) == 2 * (len(ring) - 2) + 2 * len(ring)
        if r < 2:  # the rational check finds no contact in the triangles the cage was checked as
            assert meeting_pairs(placed, cage.triangles) == []


@pytest.mark.parametrize("name", MODELS)
def test_the_shared_cages_are_accepted_and_touch_nowhere(name):
    require_cages()
    points, faces = read_polygons(CAGES / f"{name}_Cage.obj")
    for cage_type in CAGE_TYPES:
        cage = cage_type(points, faces)
    assert meeting_pairs(points, cage.triangles) == []


def test_solids_joined_at_a_vertex_index_are_accepted_and_at_a_copy_of_it_refused():
    # Apex to apex: sharing vertex 0 by index is a shared vertex; a second vertex at the same
    # position is a contact.
    upper, upper_faces = tetrahedron((0, 0, 0), (1, 0, 1), (0, 1, 1), (-1, -1, 1))
    lower, lower_faces = tetrahedron((0, 0, 0), (1, 0, -1), (0, 1, -1), (-1, -1, -1))
    volume = 2 * abs(np.linalg.det(upper[1:] - upper[0])) / 6
    shared = np.vstack([upper, lower[1:]])
    shared_faces = upper_faces + [[0 if v == 0 else v + 3 for v in f] for f in lower_faces]
    assert_accepted_as_exact(shared, shared_faces, volume)
    assert_refused_as_exact(*joined(upper, upper_faces, lower, lower_faces))


def test_a_polygon_that_crosses_itself_is_named_once():
    # A prism over the pentagram {5/2}: its caps' edges cross, so their triangles overlap in the plane.
    ring = regular(5)[[0, 2, 4, 1, 3]]
    points, faces = prism(ring)
    assert (0, 0) in meeting_faces(points, faces)
    for cage_type in CAGE_TYPES:
        with pytest.raises(ValueError, match=r"^cage_faces: face 0 intersects itself \(the cage intersects itself\)$"):
            cage_type(points, faces)

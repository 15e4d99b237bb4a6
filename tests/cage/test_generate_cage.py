"""dk.generate_cage: for any mesh, a closed, manifold, outward, self-intersection-free cage within
the face budget that strictly encloses the mesh, checked by code that is not the generator's
(generated_cage_checks: directed edges, rational arithmetic, winding numbers, segment crossings)."""
import numpy as np
import pytest

import deformkit as dk
from generated_cage_checks import (assert_encloses, assert_valid_cage, components, euler_characteristic, fan, signed_volume,
                                   torus, uv_sphere)


def generated(points, faces, **kwargs):
    cp, cf = dk.generate_cage(points, faces, **kwargs)
    assert cp.dtype == np.float64 and cp.shape[1] == 3
    return cp, np.asarray(cf)


def hexagon_prism():
    ring = [(np.cos(a), np.sin(a)) for a in np.arange(6) * np.pi / 3]
    pts = np.array([(x, y, z) for z in (0.0, 1.0) for x, y in ring])
    faces = [list(range(5, -1, -1)), list(range(6, 12))] + [[i, (i + 1) % 6, 6 + (i + 1) % 6, 6 + i] for i in range(6)]
    return pts, faces


def odd_meshes():
    sphere = uv_sphere()
    half = sphere[1][sphere[0][sphere[1]].min(axis=1)[:, 2] > -0.01]  # the upper half: open
    fin = (np.vstack([sphere[0], [[0, 0, 2.5]]]), np.vstack([sphere[1], [[0, 2, 2 + 12 + 1]]]))
    fin_faces = np.vstack([fin[1], [[0, 2, 2 + 12 + 1]]])  # one face twice: an edge of three faces
    two = uv_sphere(center=(0.4, 0, 0))
    crossing = (np.vstack([sphere[0], two[0]]), np.vstack([sphere[1], two[1] + len(sphere[0])]))
    grid = np.array([(x, y, 0.0) for x in range(6) for y in range(4)], float)
    flat = [[6 * 0 + 4 * x + y, 4 * (x + 1) + y, 4 * (x + 1) + y + 1, 4 * x + y + 1] for x in range(5) for y in range(3)]
    return {
        "sphere": sphere,
        "open hemisphere": (sphere[0], half),
        "non-manifold fin": (fin[0], fin_faces),
        "self-intersecting spheres": crossing,
        "quads and n-gons": hexagon_prism(),
        "flat grid": (grid, flat),
        "segment as a face": (np.array([[0, 0, 0], [1, 2, 3.0]]), [[0, 1]]),
        "points only": (np.random.default_rng(1).normal(size=(50, 3)), None),
        "one point": (np.array([[3.0, -2.0, 7.0]]), None),
        "far from the origin": (sphere[0] + 1e8, sphere[1]),
        "a needle": (np.array([[0, 0, 0], [1e-9, 0, 0], [0, 0, 10.0]]), [[0, 1, 2]]),
        "points on a line": (np.outer(np.arange(10.0), [1, 2, 3]), None),
    }


@pytest.mark.parametrize("name", list(odd_meshes()))
def test_the_cage_is_valid_and_strictly_encloses_any_mesh(name):
    points, faces = odd_meshes()[name]
    cp, ct = generated(points, faces, max_faces=60)
    assert_valid_cage(cp, ct, 60)
    tris = fan(faces) if faces is not None else None
    if tris is not None:
        tris = tris[[len(set(t)) == 3 for t in tris]]
    assert_encloses(cp, ct, points, tris)
    dk.MeanValueCage(cp, ct)  # every cage deformer accepts it
    dk.GreenCage(cp, ct)


@pytest.mark.parametrize("max_faces", [4, 6, 12, 20, 40, 200, 1000])
def test_the_face_budget_holds(max_faces):
    points, faces = torus()
    cp, ct = generated(points, faces, max_faces=max_faces)
    assert_valid_cage(cp, ct, max_faces)
    assert_encloses(cp, ct, points, fan(faces))


def test_the_torus_keeps_its_hole_and_far_parts_get_a_cage_each():
    points, faces = torus()
    cp, ct = generated(points, faces, max_faces=200)
    assert euler_characteristic(ct) == 0  # genus 1
    a, fa = uv_sphere()
    b, fb = uv_sphere(center=(100, 0, 0))
    pts, fcs = np.vstack([a, b]), np.vstack([fa, fb + len(a)])
    cp, ct = generated(pts, fcs, max_faces=100)
    assert_valid_cage(cp, ct, 100)
    assert_encloses(cp, ct, pts, fcs)
    assert components(ct) == 2
    # Each part's cage stays near it: none spans the gap.
    assert np.sum(np.abs(cp[:, 0] - 50) < 40) == 0


def test_the_gap_follows_offset_on_flat_and_degenerate_meshes():
    grid = np.array([(x, y, 0.0) for x in range(6) for y in range(4)], float)
    faces = [[4 * x + y, 4 * (x + 1) + y, 4 * (x + 1) + y + 1, 4 * x + y + 1] for x in range(5) for y in range(3)]
    for offset in (0.05, 0.2):
        cp, ct = generated(grid, faces, max_faces=100, offset=offset)
        assert_valid_cage(cp, ct, 100)
        thickness = cp[:, 2].max() - cp[:, 2].min()
        assert offset <= thickness <= 4 * offset  # a thin slab about 2 offset thick
    point = np.array([[1.0, 2.0, 3.0]])
    cp, ct = generated(point, None, offset=0.1)
    assert_valid_cage(cp, ct, 200)
    assert 0.05 <= np.abs(cp - point).max() <= 0.4


def test_quads_are_planar_pairs_that_split_back():
    points, faces = torus()
    cp, tri = generated(points, faces, max_faces=200)
    qp, polys = dk.generate_cage(points, faces, max_faces=200, quads=True)
    assert {len(f) for f in polys} <= {3, 4} and any(len(f) == 4 for f in polys)
    assert sum(len(f) - 2 for f in polys) == len(tri) and len(polys) < len(tri)
    cage = dk.MeanValueCage(qp, polys)
    np.testing.assert_array_equal(qp, cp)
    # The deformer's own split of the quads is the triangle cage: the same set of triangles.
    norm = {tuple(np.roll(t, -int(np.argmin(t)))) for t in tri.tolist()}
    for f in polys:
        if len(f) == 4:
            q = qp[f]
            n1, n2 = np.cross(q[1] - q[0], q[2] - q[0]), np.cross(q[2] - q[0], q[3] - q[0])
            assert np.dot(n1, n2) > 0
    assert abs(cage.volume - signed_volume(cp, tri)) < 1e-9 * signed_volume(cp, tri)
    assert len(norm) == len(tri)


def test_cages_deform_their_mesh_without_folds():
    points, faces = uv_sphere(n=16)
    cp, ct = generated(points, faces, max_faces=80)
    # A smooth move of the cage: a twist about z by up to 0.3 rad.
    angle = 0.3 * (cp[:, 2] - cp[:, 2].min()) / np.ptp(cp[:, 2])
    c, s = np.cos(angle), np.sin(angle)
    moved = np.column_stack([c * cp[:, 0] - s * cp[:, 1], s * cp[:, 0] + c * cp[:, 1], cp[:, 2]])
    for make in (dk.MeanValueCage, dk.GreenCage, lambda p, t: dk.MeshDeform(p, t, precision=5)):
        cage = make(cp, ct)
        b = cage.bind(points)
        cage.cage_points = moved
        out = cage.deform_bound(b)
        assert np.all(np.isfinite(out))
        assert np.all(cage.volume_ratio(points) > 0)  # no fold: every local volume keeps its sign
        assert np.abs(out - points).max() > 0.05


@pytest.mark.parametrize("kwargs, words", [
    ({"points": np.zeros((0, 3)), "faces": None}, "points: "),
    ({"points": np.array([[0, 0, np.nan]]), "faces": None}, "points: "),
    ({"points": np.array([[0, 0, np.inf], [1, 1, 1]]), "faces": [[0, 1]]}, "points: "),
    ({"max_faces": 3}, "max_faces: "),
    ({"max_faces": 0}, "max_faces: "),
    ({"offset": 0.0}, "offset: "),
    ({"offset": -1.0}, "offset: "),
    ({"offset": np.nan}, "offset: "),
    ({"alpha": 0.0}, "alpha: "),
    ({"alpha": np.inf}, "alpha: "),
    ({"alpha": 1e-9}, "alpha: expected at least"),
    ({"offset": 1e-30}, "offset: expected at least"),
    ({"faces": [[0, 1, 9]]}, "faces: "),
    ({"faces": [[0, -1, 2]]}, "faces: "),
    ({"faces": np.array([[0, 1, 2.0]])}, "faces: expected integer"),
    ({"quads": "yes"}, "quads: "),
    ({"points": [[0, 0, 0]], "faces": None}, "points: "),
    ({"points": np.zeros((4, 2))}, "points: "),
])
def test_bad_arguments_are_named(kwargs, words):
    args = {"points": np.eye(3), "faces": [[0, 1, 2]], **kwargs}
    with pytest.raises((ValueError, TypeError)) as info:
        dk.generate_cage(args.pop("points"), args.pop("faces"), **args)
    assert str(info.value).startswith(words), str(info.value)

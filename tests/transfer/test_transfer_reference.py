"""dk.DeformationTransfer against an independent solve of the energy docs/math/transfer.md documents
(tests/support/transfer_reference.py: the energy assembled pair by pair and solved with
scipy.sparse), on small cases that no target can meet exactly: non-affine poses onto targets that
are not the source, same connectivity (a tetrahedron, a subdivided sphere, a twisted bar of quads,
a mesh of two parts) and unlike meshes (a correspondence with 0 to 3 partners per target triangle,
markers, fixed vertices). Each case also shows that it sees the documented rules: the reference
with uniform instead of area weights, a unit-normal fourth vertex, or one mean term per target
triangle instead of one term per pair, lands far from the module."""
import numpy as np
import pytest
import trimesh

import deformkit as dk
from support import transfer_reference as ref

# The module and the reference solve the same well-conditioned system of a few hundred unknowns
# by different factorisations (CHOLMOD with an anchor, SuperLU on a KKT system): their rounding
# differs by about 1e-15 of the mesh size; 1e-10 is the brief's bar.
TOLERANCE = 1e-10
# A variant that drops a documented rule moves the result by far more than rounding on these cases
# (1e-3 to 1.6e-2 of the size, measured); 1e-5 separates the two by orders of magnitude.
SEES_THE_RULE = 1e-5


def size(points):
    return float(np.linalg.norm(np.ptp(points, axis=0)))


def assert_matches(module, reference, target):
    error = np.abs(module - reference).max() / size(target)
    assert error < TOLERANCE, f"module and reference differ by {error:.3g} of the target's size"
    # The case is not one where the target keeps its rest shape.
    assert np.abs(module - target).max() > 0.05 * size(target)


def assert_sees(module, reference_variant, target, rule):
    gap = np.abs(module - reference_variant).max() / size(target)
    assert gap > SEES_THE_RULE, f"this case cannot tell {rule} ({gap:.3g})"


def twist(points, turns=0.6, length=4.0, bend=0.15):
    """A twist about z growing with z, a bend in x and a swelling: no affine map."""
    angle = 2 * np.pi * turns * points[:, 2] / length
    c, s = np.cos(angle), np.sin(angle)
    swell = 1 + 0.3 * np.sin(np.pi * points[:, 2] / length)
    x = swell * (c * points[:, 0] - s * points[:, 1]) + bend * points[:, 2] ** 2
    y = swell * (s * points[:, 0] + c * points[:, 1])
    return np.column_stack([x, y, points[:, 2]])


def tetrahedron():
    s = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    t = np.array([[0.1, -0.1, 0], [1.3, 0.2, -0.1], [-0.2, 0.8, 0.3], [0.2, 0.1, 1.4]])
    pose = np.array([[0.0, 0.1, 0], [0.9, -0.3, 0.2], [0.4, 1.2, -0.1], [-0.3, 0.2, 0.7]])
    return s, f, t, pose


def sphere():
    mesh = trimesh.creation.icosphere(subdivisions=1)
    s, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    t = s + np.column_stack([0.3 * s[:, 2] ** 2, 0.1 * np.sin(3 * s[:, 0]), 0.2 * s[:, 0] * s[:, 1]])
    pose = 1.2 * s + 0.25 * np.sin(2 * s[:, [1, 2, 0]])
    return s, f, t, pose


def bar(rings=9, length=4.0):
    """A square bar along z, side and caps as quads (fanned from their first corner)."""
    square = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])
    points = np.array([[x, y, z] for z in np.linspace(0, length, rings) for x, y in square])
    faces = [[r * 4 + k, r * 4 + (k + 1) % 4, (r + 1) * 4 + (k + 1) % 4, (r + 1) * 4 + k]
             for r in range(rings - 1) for k in range(4)]
    faces += [[3, 2, 1, 0], [(rings - 1) * 4 + k for k in range(4)]]
    return points, faces


def twisted_bar():
    s, f = bar()
    t = s * (1 - 0.1 * s[:, [2]])  # tapered
    t[:, 0] += 0.2 * np.sin(s[:, 2])  # and bent
    return s, f, t, twist(s)


SAME_CONNECTIVITY = {"tetrahedron": tetrahedron, "sphere": sphere, "twisted bar": twisted_bar}


@pytest.mark.parametrize("case", SAME_CONNECTIVITY)
def test_same_connectivity_solves_the_documented_energy(case):
    s, f, t, pose = SAME_CONNECTIVITY[case]()
    out = dk.DeformationTransfer(s, f, t).transfer(pose)
    assert_matches(out, ref.transfer(s, f, t, f, pose), t)
    if case != "tetrahedron":  # four triangles of comparable area: uniform weights nearly agree
        assert_sees(out, ref.transfer(s, f, t, f, pose, area_weights=False), t, "the area weights")
    assert_sees(out, ref.transfer(s, f, t, f, pose, unit_normal=True), t, "the fourth vertex's n / sqrt|n|")
    # The projection P_t only adds a constant: G_t x is in the triangle's plane anyway.
    assert_matches(out, ref.transfer(s, f, t, f, pose, projection=False), t)


def test_fixed_vertices_hold_where_each_pose_puts_them():
    """The bar's bottom ring held at rest and its top ring given per pose, six poses in one call
    (past the module's block of four)."""
    s, f, t, _ = twisted_bar()
    fixed = np.array([0, 1, 2, 3, 32, 33, 34, 35])
    poses = np.stack([twist(s, turns=k / 10, bend=0.05 * k) for k in range(1, 7)])
    held = np.stack([np.vstack([t[:4], t[32:] + [0.1 * k, 0, -0.2 * k]]) for k in range(1, 7)])
    dt = dk.DeformationTransfer(s, f, t, fixed_vertices=fixed)
    out = dt.transfer(poses, fixed_positions=held)
    for k in range(6):
        expected = ref.transfer(s, f, t, f, poses[k], fixed_vertices=fixed, fixed_positions=held[k])
        assert_matches(out[k], expected, t)
        assert np.array_equal(out[k][fixed], held[k])


def test_each_connected_part_moves_with_its_first_vertex():
    s1, f1, t1, p1 = tetrahedron()
    s2, f2, t2, p2 = sphere()
    s = np.vstack([s1, s2 + [3.0, 0, 0]])
    t = np.vstack([t1, t2 + [3.0, 1.0, 0]])
    pose = np.vstack([p1, p2 + [2.5, 0, 0.4]])
    f = np.vstack([f1, f2 + 4])
    out = dk.DeformationTransfer(s, f, t).transfer(pose)
    assert_matches(out, ref.transfer(s, f, t, f, pose), t)


def spheres():
    """An icosphere source and a UV sphere target, bent non-affinely; a non-affine pose."""
    ico = trimesh.creation.icosphere(subdivisions=2)
    s, sf = np.asarray(ico.vertices), np.asarray(ico.faces)
    uv = trimesh.creation.uv_sphere(radius=1.05, count=[10, 12])
    t, tf = np.asarray(uv.vertices), np.asarray(uv.faces)
    t = t + 0.1 * np.sin(2 * t[:, [1, 2, 0]])
    pose = s + 0.2 * np.sin(2 * s[:, [1, 2, 0]]) + 0.1 * s * s[:, [2]]
    markers = np.array([[int(np.argmin(np.linalg.norm(s - t[g] / 1.05, axis=1))), g] for g in (0, 5, 50, len(t) - 1)])
    return s, sf, t, tf, pose, markers


def partners(s, sf, t, tf):
    """Target triangle j paired with its (j mod 4) source triangles of nearest centroid: 0 to 3
    partners, a quarter of the target unpaired."""
    sc, tc = s[sf].mean(1), t[tf].mean(1)
    pairs = [(int(i), j) for j, c in enumerate(tc) for i in np.argsort(np.linalg.norm(sc - c, axis=1))[: j % 4]]
    return np.array(pairs)


@pytest.mark.parametrize("with_markers", [True, False], ids=["markers", "centroids"])
def test_unlike_meshes_with_a_given_correspondence_solve_the_documented_energy(with_markers):
    s, sf, t, tf, pose, markers = spheres()
    pairs = partners(s, sf, t, tf)
    mk = markers if with_markers else None
    dt = dk.DeformationTransfer(s, sf, t, tf, correspondence=pairs,
                                markers=(markers[:, 0], markers[:, 1]) if with_markers else None)
    assert len(dt.unmatched_target_triangles) == len(tf) // 4
    out = dt.transfer(pose)
    assert_matches(out, ref.transfer(s, sf, t, tf, pose, pairs=pairs, markers=mk), t)
    assert_sees(out, ref.transfer(s, sf, t, tf, pose, pairs=pairs, markers=mk, mean_of_partners=True), t,
                "one term per pair (a triangle with m partners weighs m A_t)")
    assert_sees(out, ref.transfer(s, sf, t, tf, pose, pairs=pairs, markers=mk, area_weights=False), t, "the area weights")


def test_unlike_meshes_from_markers_solve_the_documented_energy_on_their_pairs():
    """The correspondence phase's pairs (a heuristic, taken as given) with fixed vertices: the fit
    on them is the documented one."""
    s, sf, t, tf, pose, markers = spheres()
    fixed = [3, 7]
    dt = dk.DeformationTransfer(s, sf, t, tf, markers=(markers[:, 0], markers[:, 1]), fixed_vertices=fixed)
    pairs = dt.correspondence
    assert np.bincount(pairs[:, 1], minlength=len(tf)).max() > 1  # some target triangles have several partners
    held = t[fixed] + [[0.1, 0.0, 0.0], [0.0, -0.1, 0.05]]
    out = dt.transfer(pose, fixed_positions=held)
    kwargs = dict(pairs=pairs, markers=markers, fixed_vertices=fixed, fixed_positions=held)
    assert_matches(out, ref.transfer(s, sf, t, tf, pose, **kwargs), t)
    assert_sees(out, ref.transfer(s, sf, t, tf, pose, mean_of_partners=True, **kwargs), t, "one term per pair")

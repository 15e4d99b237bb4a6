"""dk.smoothness_report: G1 at machine precision where the theory says so, and every kind of defect."""
import json

import numpy as np
import pytest

import deformkit as dk
from support.subdivision_meshes import CUBE_FACES, CUBE_POINTS, OCTAHEDRON_FACES, OCTAHEDRON_POINTS, grid, prism, sphere


def test_twisted_cube_is_g1_at_machine_precision():
    twisted = dk.Twist(rate=0.4).deform(CUBE_POINTS)  # every vertex valence 3: all extraordinary
    r = dk.smoothness_report(twisted, CUBE_FACES, samples_per_edge=32)
    assert len(r.edges) == 12 and r.boundary_edges == 0
    assert r.max_angle < 1e-12 and r.max_gap < 1e-14
    assert r.degenerate_samples == 0 and r.flipped_samples == 0 and r.min_regularity > 0.1
    assert r.sample_count == 12 * 32 * 2 + 6


@pytest.mark.parametrize("deformer", [dk.Twist(rate=1.5), dk.Bend(curvature=0.8, region=(-0.3, 0.3)),
                                      dk.Taper(rate=0.5)])
def test_deformed_cages_stay_g1(deformer):
    """The lecture's property: a deformed control mesh still has a smooth limit surface."""
    for points, faces in [sphere(2), prism(), (OCTAHEDRON_POINTS, OCTAHEDRON_FACES)]:
        r = dk.smoothness_report(deformer.deform(points), faces)
        assert r.max_angle < 1e-9 and r.max_gap < 1e-13


def test_ffd_deformed_cage_stays_g1():
    points, faces = sphere(2)
    lo, hi = points.min(axis=0) - 0.1, points.max(axis=0) + 0.1
    rest = dk.FFD(2, origin=lo, edges=np.diag(hi - lo))
    cp = rest.rest_control_points.copy()
    cp[1, 1, 2] += (0.3, 0.0, 0.4)
    moved = dk.FFD(2, origin=lo, edges=np.diag(hi - lo), control_points=cp).deform(points)
    assert np.abs(moved - points).max() > 0.05
    assert dk.smoothness_report(moved, faces).max_angle < 1e-9


def test_sharp_crease_is_named():
    rng = np.random.default_rng(4)
    points = CUBE_POINTS + 0.05 * rng.standard_normal(CUBE_POINTS.shape)
    r = dk.smoothness_report(points, CUBE_FACES, creases=(np.array([[0, 1], [1, 3]]), np.array([10.0, 10.0])))
    creased = {tuple(e) for e in r.edges[r.edge_angle > 0.5].tolist()}
    assert creased == {(0, 1), (1, 3)}
    assert {tuple(e) for e in r.edges[r.worst_edges[:2]].tolist()} == creased
    assert r.max_angle > 0.5 and r.max_gap < 1e-14
    assert np.sort(r.edge_angle)[-3] < 0.5 * r.edge_angle[r.worst_edges[1]]
    d = r.to_dict()
    assert json.loads(json.dumps(d))["worst_edges"][0][:2] in ([0, 1], [1, 3])


def test_semi_sharp_crease_is_smooth_at_the_limit_but_curved():
    # A finite sharpness is C1 at the limit: the crease is rounded, not a normal jump.
    r = dk.smoothness_report(CUBE_POINTS, CUBE_FACES, creases=(np.array([[0, 1]]), np.array([2.0])))
    assert r.max_angle < 1e-9


def test_folded_cage_flips_normals():
    points, faces = grid(4, bump=0.0)
    folded = points.copy()
    folded[12, 2] = 0.0
    folded[12, :2] += (2.5, 0.0)  # the middle vertex pushed over its neighbours: the surface folds
    r = dk.smoothness_report(folded, faces, reference=points)
    assert r.flipped_samples > 0 and len(r.flipped_faces) > 0
    rest = dk.smoothness_report(points, faces, reference=points)
    assert rest.flipped_samples == 0 and rest.boundary_edges == 16


def test_collapsed_face_is_degenerate():
    points, faces = grid(2)
    line = points.copy()  # everything on a line: no tangent plane anywhere
    line[:, 1] = 0.0
    r = dk.smoothness_report(line, faces)
    assert r.degenerate_samples == r.sample_count and r.min_regularity < 1e-12


def test_bend_crease_in_the_bent_surface():
    """Barr's bend is C0 where its region ends unless z = 0 there: the surface bent after
    subdivision (F(S)) has a crease; the bent cage's own limit surface does not."""
    points, faces = sphere(3)
    bend = dk.Bend(curvature=1.0, region=(-0.2, 0.2))
    bent = dk.smoothness_report(points, faces, deformer=bend)
    plain = dk.smoothness_report(points, faces, deformer=dk.Twist(rate=0.0))
    twist = dk.smoothness_report(points, faces, deformer=dk.Twist(rate=2.0))
    assert plain.max_crease < 0.01 and twist.max_crease < 0.01
    assert bent.max_crease > 10 * max(plain.max_crease, twist.max_crease)
    # the creased faces straddle the region ends y = +-0.2
    for f in bent.worst_faces[:4]:
        y = points[faces[f], 1]
        assert min(abs(y.min() - 0.2), abs(y.min() + 0.2), abs(y.max() - 0.2), abs(y.max() + 0.2)) < 0.15
        assert y.min() < 0.2 < y.max() or y.min() < -0.2 < y.max()
    # the crease is the jump of J's length column, (1 - kz) against 1: it grows with |z|
    centre = points[faces].mean(axis=1)
    ends = np.array([points[f, 1].min() < 0.2 < points[f, 1].max() for f in faces])
    near = bent.face_crease[ends & (np.abs(centre[:, 2]) < 0.1)]
    far = bent.face_crease[ends & (np.abs(centre[:, 2]) > 0.3)]
    assert len(near) and len(far) and near.max() < far.max() / 3
    half = dk.smoothness_report(points, faces, deformer=dk.Bend(curvature=0.5, region=(-0.2, 0.2)))
    assert 0.3 < half.max_crease / bent.max_crease < 0.7  # and with k
    # deform-then-subdivide smooths it: the bent cage is G1
    assert dk.smoothness_report(bend.deform(points), faces).max_angle < 1e-9
    assert bent.flipped_samples == 0 and len(bent.face_crease) == len(faces)


def test_bend_past_its_centre_folds():
    points, faces = sphere(2, center=(0, 0, 0.6))  # reaches z = 1/k = 1: det J = 1 - kz < 0
    r = dk.smoothness_report(points, faces, deformer=dk.Bend(curvature=1.0, region=(-0.3, 0.3)))
    assert r.flipped_samples > 0


def test_limit_surface_method_equals_function():
    points, faces = prism()
    moved = dk.Twist(rate=0.3).deform(points)
    a = dk.LimitSurface(points, faces).smoothness_report(moved, samples_per_edge=5, reference=points)
    b = dk.smoothness_report(moved, faces, samples_per_edge=5, reference=points)
    np.testing.assert_array_equal(a.edge_angle, b.edge_angle)
    np.testing.assert_array_equal(a.edges, b.edges)
    assert a.to_dict() == b.to_dict()


def test_large_rotations_are_not_flips():
    """Flips against the reference allow for each neighbourhood's rotation: a half turn, a strong
    twist or bend turns normals by more than 90 degrees without folding anything."""
    points, faces = sphere(3)
    half_turn = points @ np.diag([1.0, -1.0, -1.0]) + 3.0
    for moved in (half_turn, dk.Twist(rate=4.0).deform(points), dk.Bend(curvature=2.0, region=(-0.4, 0.4)).deform(points)):
        assert dk.smoothness_report(moved, faces, reference=points).flipped_samples == 0
    # a bend past its centre (z >= 1/k) does fold: det J < 0 there, and the samples flip
    folding = dk.Bend(curvature=2.5)
    assert (folding.volume_ratio(points) < 0).any()
    assert dk.smoothness_report(folding.deform(points), faces, reference=points).flipped_samples > 0
    assert dk.smoothness_report(points, faces, deformer=folding).flipped_samples > 0


@pytest.mark.parametrize("scale", [1e-200, 1e103, 1e150, 1e200, 1e300])
def test_the_report_is_scale_invariant(scale):
    """Every figure is a ratio or an angle: the same for the cage scaled by any factor (1e103 made
    the normals' squares overflow and the report said 'smooth' on NaN normals)."""
    rng = np.random.default_rng(7)
    points = CUBE_POINTS + 0.05 * rng.standard_normal(CUBE_POINTS.shape)
    flat, grid_faces = grid(4, bump=0.0)
    folded = flat.copy()
    folded[12, :2] += (2.5, 0.0)  # pushed over its neighbours: the surface folds
    creases = (np.array([[0, 1]]), np.array([10.0]))
    cases = [(points, CUBE_FACES, dict(creases=creases)), (folded, grid_faces, dict(reference=flat)),
             (folded, grid_faces, {})]
    for cage, faces, kwargs in cases:
        a = dk.smoothness_report(cage, faces, **kwargs)
        if "reference" in kwargs:
            kwargs = dict(reference=kwargs["reference"] * scale)
        b = dk.smoothness_report(cage * scale, faces, **kwargs)
        np.testing.assert_allclose(b.edge_angle, a.edge_angle, atol=1e-12)
        np.testing.assert_allclose(b.edge_gap, a.edge_gap, atol=1e-15)
        assert b.min_regularity == pytest.approx(a.min_regularity, abs=1e-12)
        assert (b.flipped_samples, b.degenerate_samples) == (a.flipped_samples, a.degenerate_samples)
    assert dk.smoothness_report(points, CUBE_FACES, creases=creases).max_angle > 0.5
    assert dk.smoothness_report(folded, grid_faces, reference=flat).flipped_samples > 0
    # with a deformer the cage is used as it is (a deformer is not scale-invariant); an empty Stack
    # is the identity at any scale, so the figures must be those of the plain surface
    c = dk.smoothness_report(points * scale, CUBE_FACES, deformer=dk.Stack([]), creases=creases)
    d = dk.smoothness_report(points, CUBE_FACES, deformer=dk.Stack([]), creases=creases)
    np.testing.assert_allclose(c.edge_angle, d.edge_angle, atol=1e-12)
    assert c.max_crease == pytest.approx(d.max_crease, abs=1e-9)

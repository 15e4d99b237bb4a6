"""A finite input gives a finite, correct result or a clear error on every output path (deform,
displacement, jacobian, volume_ratio, transform_normals), not only on deform; a deformer at rest
is exactly the identity; per-point weights, normals, mesh_volume, the cotangent Laplacian,
direct manipulation and soft constraints stay meaningful at extreme magnitudes."""
import math

import numpy as np
import pytest

import deformkit as dk

RNG = np.random.default_rng(12)
# Named by the deformer's type ("Taper: row 0 ..."), or by points where they are what is too large.
OVERFLOW = r"^[A-Za-z]+: row 0 maps to a non-finite (position|displacement|Jacobian|volume ratio)"


def ffd_stretched_along_x(strength):
    """FFD whose control points are the rest grid with x doubled: F(x) = x + strength (x0, 0, 0) inside
    the unit box, so J = diag(1 + strength, 1, 1) exactly."""
    rest = np.array(dk.FFD((2, 2, 2)).rest_control_points)
    return dk.FFD((2, 2, 2), strength=strength, control_points=rest * [2.0, 1.0, 1.0])


def bezier_extrapolating():
    rest = np.array(dk.BezierFFD(1, outside="extrapolate").rest_control_points)
    moved = rest.copy()
    moved[-1, -1, -1] += 1e306
    return dk.BezierFFD(1, outside="extrapolate", control_points=moved)


def paths(d, p):
    normals = np.zeros_like(p)
    normals[:, 2] = 1
    return {"deform": lambda: d.deform(p), "displacement": lambda: d.displacement(p),
            "jacobian": lambda: d.jacobian(p), "volume_ratio": lambda: d.volume_ratio(p),
            "transform_normals": lambda: d.transform_normals(p, normals)}


# (name, deformer, point): each overflows a double (or a float) on some path; no path may hand back
# inf or NaN instead of raising.
OVERFLOWING = [
    ("stretch at z = 1e200", dk.Stretch(factor=0.5), np.array([[1.0, 1.0, 1e200]])),
    ("taper float32 at 1e30", dk.Taper(), np.array([[1e30, 1e30, 1e30]], np.float32)),
    ("ffd strength 1e308", ffd_stretched_along_x(1e308), np.array([[0.5, 0.5, 0.5]])),
    ("profile spanning 1e308", dk.Twist(profile=([-1e308, 1e308], [-1e308, 1e308])), np.array([[1.0, 1.0, 0.3]])),
    # Extrapolated at s = 2, where sum |w| = 27^3 is within the limit (docs/lattice.md, "Far outside")
    # and the moved corner's weight 8^3 (its derivative 3 * 4 * 8^2): 5e308, 7.7e308.
    ("bezier extrapolated, corner at 1e306", bezier_extrapolating(), np.array([[2.0, 2.0, 2.0]])),
    ("twist by pi at 1e308", dk.Twist(rate=np.pi), np.array([[1e308, 1e308, 1.0]])),
]


@pytest.mark.parametrize("name, d, p", OVERFLOWING, ids=[c[0] for c in OVERFLOWING])
@pytest.mark.parametrize("path", ["deform", "displacement", "jacobian", "volume_ratio", "transform_normals"])
def test_every_path_is_finite_or_raises_the_overflow_error(name, d, p, path):
    try:
        out = paths(d, p)[path]()
    except ValueError as e:
        assert "maps to a non-finite" in str(e), e
        return
    assert np.isfinite(out).all(), (name, path, out)


@pytest.mark.parametrize("name, d, p", [OVERFLOWING[i] for i in (0, 3, 4)], ids=lambda v: v if isinstance(v, str) else "")
def test_jacobian_of_an_overflowing_point_raises(name, d, p):
    """The true Jacobian there is beyond a double: J_00 = s = 1 + k (z^2 - 1) with z = 1e200, or the
    profile's slope times 1e308, or the extrapolated cubic's derivative at s = 2 with a corner at 1e306."""
    with pytest.raises(ValueError, match=OVERFLOW):
        d.jacobian(p)


def test_volume_ratio_beyond_the_range_of_its_dtype_raises():
    # Taper r = 1 + 0.785 z: det J = r^2 ~ 6e59, beyond float32; the float64 result is exact.
    p = np.array([[1e30, 1e30, 1e30]])
    np.testing.assert_allclose(dk.Taper().volume_ratio(p), (1 + 0.785398163397448 * 1e30) ** 2, rtol=1e-12)
    with pytest.raises(ValueError, match=OVERFLOW):
        dk.Taper().volume_ratio(p.astype(np.float32))
    # J = diag(1 + 1e308, 1, 1) is finite, det J = 1e308 too; with y and z doubled, 4e308 is not.
    lattice = ffd_stretched_along_x(1e308)
    np.testing.assert_allclose(lattice.volume_ratio(np.array([[0.5, 0.5, 0.5]])), 1e308, rtol=1e-12)
    rest = np.array(dk.FFD((2, 2, 2)).rest_control_points)
    with pytest.raises(ValueError, match=OVERFLOW):
        dk.FFD((2, 2, 2), strength=1e308, control_points=rest * 2.0).volume_ratio(np.array([[0.5, 0.5, 0.5]]))


def test_normals_through_a_jacobian_of_1e308():
    # J = diag(1 + s, 1, 1): cof(J) n = (n0, (1 + s) n1, (1 + s) n2), whose entries square past a double.
    lattice = ffd_stretched_along_x(1e308)
    n = np.array([[1.0, 1.0, 1.0]])
    out = lattice.transform_normals(np.array([[0.5, 0.5, 0.5]]), n)
    np.testing.assert_allclose(out, [[0.0, np.sqrt(0.5), np.sqrt(0.5)]], rtol=0, atol=1e-15)


@pytest.mark.parametrize("scale", [1e-310, 1e-200, 1e-20, 1e20, 1e200, 1e308])
def test_normals_of_any_length_give_the_unit_result(scale):
    """N' depends on N's direction only: N * scale must give what the unit normal gives."""
    d = dk.Stack([dk.Twist(rate=1.3), dk.Bend(curvature=0.6), dk.Taper(rate=0.4)])
    p = RNG.uniform(-1, 1, (64, 3))
    n = RNG.normal(size=(64, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    reference = d.transform_normals(p, n)
    scaled = d.transform_normals(p, n * scale)
    atol = 1e-14 + 100 * 5e-324 / scale  # a denormal input carries fewer bits of its direction
    np.testing.assert_allclose(scaled, reference, rtol=0, atol=atol)
    np.testing.assert_allclose(np.linalg.norm(scaled, axis=1), 1.0, rtol=0, atol=1e-14)


def test_a_denormal_normal_keeps_its_direction():
    d = dk.Twist(rate=1.0)
    p = np.array([[0.5, 0.3, 0.2]])
    for n in ([5e-324, 0, 0], [0, -5e-324, 0], [3e-322, 4e-322, 0]):
        unit = np.array([n]) / np.abs(n).max()
        np.testing.assert_allclose(d.transform_normals(p, np.array([n])), d.transform_normals(p, unit / np.linalg.norm(unit)),
                                   rtol=0, atol=3e-3)  # 3e-322 has few significant bits


def test_a_zero_normal_gives_zero():
    """Documented: a zero normal has no direction to carry, so it stays zero (as a normal whose plane
    the map collapses); the other rows are unaffected."""
    d = dk.Bend(curvature=0.8)
    p = RNG.uniform(-1, 1, (3, 3))
    n = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    out = d.transform_normals(p, n)
    np.testing.assert_array_equal(out[1], 0.0)
    np.testing.assert_allclose(out[[0, 2]], d.transform_normals(p[[0, 2]], n[[0, 2]]), rtol=0, atol=0)


def all_deformers(weights):
    rest = np.array(dk.ExtendedFFD.prism([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [0, 0, 1.0]).rest_control_points)
    return [
        lambda: dk.Twist(weights=weights), lambda: dk.Taper(weights=weights), lambda: dk.Bend(weights=weights),
        lambda: dk.Stretch(weights=weights), lambda: dk.SimpleDeform("TWIST", weights=weights),
        lambda: dk.SimpleDeform("BEND", weights=weights),
        lambda: dk.Stack([dk.Twist()], weights=weights), lambda: dk.FFD(2, weights=weights),
        lambda: dk.BezierFFD(1, weights=weights), lambda: dk.BSplineLattice(4, weights=weights),
        lambda: dk.BlenderLattice(3, weights=weights), lambda: dk.ExtendedFFD(rest, weights=weights),
    ]


@pytest.mark.parametrize("bad", [1e308, -1e-9, 1.0 + 1e-9, -1e308, 2.0])
@pytest.mark.parametrize("make", range(12))
def test_weights_outside_blenders_range_are_refused(bad, make):
    """Blender's vertex-group weights lie in [0, 1]; x + w (F(x) - x) with w = 1e308 gave inf rows."""
    with pytest.raises(ValueError, match=r"weights: entry 1 is .*; expected a number in \[0, 1\]"):
        all_deformers([0.5, bad, 0.25])[make]()


@pytest.mark.parametrize("make", range(12))
def test_weights_at_the_ends_of_the_range_blend_exactly(make):
    p = RNG.uniform(0.05, 0.95, (3, 3))
    full = all_deformers(None)[make]().deform(p)
    out = all_deformers([0.0, 1.0, 0.5])[make]().deform(p)
    np.testing.assert_array_equal(out[0], p[0])
    np.testing.assert_allclose(out[1], full[1], rtol=0, atol=1e-15)
    np.testing.assert_allclose(out[2], 0.5 * (p[2] + full[2]), rtol=0, atol=1e-15)


def random_frame():
    q, _ = np.linalg.qr(RNG.normal(size=(3, 3)))
    m = np.eye(4)
    m[:3, :3] = q * RNG.uniform(0.5, 2.0, 3)
    m[:3, 3] = RNG.uniform(-2, 2, 3)
    return m


def at_rest():
    frame = random_frame()
    cases = []
    for axis in "xyz":
        cases += [dk.Twist(rate=0.0, axis=axis), dk.Twist(rate=0.0, axis=axis, frame=frame),
                  dk.Twist(profile=([-1.0, 0.0, 1.0], [0.0, 0.0, 0.0]), axis=axis, frame=frame),  # scalar path
                  dk.Taper(rate=0.0, axis=axis, frame=frame), dk.Stretch(factor=0.0, axis=axis, frame=frame),
                  dk.Bend(curvature=0.0, axis=axis, frame=frame),
                  dk.Taper(profile=([-1.0, 1.0], [1.0, 1.0]), axis=axis, frame=frame)]
        for mode in ("TWIST", "BEND", "TAPER", "STRETCH"):
            cases += [dk.SimpleDeform(mode, factor=0.0, deform_axis=axis.upper()),
                      dk.SimpleDeform(mode, factor=0.0, deform_axis=axis.upper(), origin=frame, lock_x=True)]
    cases += [dk.FFD(3), dk.BezierFFD(2), dk.BSplineLattice(5, frame=frame), dk.BlenderLattice((2, 3, 4)),
              dk.BlenderLattice(3, "linear", frame=frame),
              dk.ExtendedFFD.prism([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [0, 0, 1.0]), dk.Stack([dk.Twist(rate=0.0), dk.Bend(curvature=0.0)])]
    return cases


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_a_deformer_at_rest_is_exactly_the_identity(dtype):
    """Angle, curvature, factor 0 (radius 1), control points at rest: every output bit is the input's,
    in any frame, for the SIMD and the scalar kernels (n = 1001 leaves a vector tail)."""
    p = RNG.uniform(-1.5, 1.5, (1001, 3)).astype(dtype)
    for d in at_rest():
        out = d.deform(p)
        assert out.dtype == dtype
        bad = np.flatnonzero((out != p).any(axis=1))
        assert bad.size == 0, (repr(d), bad[:5], (out - p)[bad[:3]])
        np.testing.assert_array_equal(d.jacobian(p[:64].astype(np.float64)), np.broadcast_to(np.eye(3), (64, 3, 3)),
                                      err_msg=repr(d))


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_at_rest_the_input_comes_back_however_extreme(dtype):
    """Huge coordinates (beyond what any formula squares), signed zeros and denormals: a deformer
    at rest hands back the very bits it got, with weights and through a binding too."""
    big = np.finfo(dtype).max / 4
    tiny = np.finfo(dtype).smallest_subnormal
    p = np.array([[big, -big, big], [-0.0, -0.0, 0.5], [tiny, -tiny, -0.0], [1e10, 2e10, -3e10]], dtype)
    weights = np.array([0.0, 0.25, 0.5, 1.0])
    extrapolating = [dk.FFD(2, outside="extrapolate"), dk.BezierFFD(1, outside="extrapolate"),
                     dk.BSplineLattice(4, outside="extrapolate")]
    for d in at_rest() + extrapolating + [dk.Stretch(factor=0.0, weights=weights), dk.FFD(2, weights=weights),
                                          dk.Stack([dk.Twist(rate=0.0), dk.Taper(rate=0.0)], weights=weights)]:
        got = d.deform(p)
        assert got.tobytes() == p.tobytes(), (repr(d), got)
        if isinstance(d, dk.Lattice) and d.outside != "extrapolate" and d.weights is None:
            assert d.deform_bound(d.bind(p[1:])).tobytes() == p[1:].tobytes(), repr(d)


def test_direct_manipulation_honours_the_lattices_per_point_weights():
    """deform() moves a point of weight v v times as far; the solve must plan for that, and a
    point of weight 0 cannot move, which its residual must say."""
    x = np.array([[0.5, 0.5, 0.5], [0.3, 0.6, 0.4], [0.7, 0.2, 0.6]])
    t = x + [[0.1, 0.0, 0.05], [-0.05, 0.1, 0.0], [0.0, 0.0, 0.1]]
    for make in (lambda w: dk.FFD(2, weights=w), lambda w: dk.BSplineLattice(5, weights=w),
                 lambda w: dk.BezierFFD(1, weights=w), lambda w: dk.BlenderLattice(3, weights=w)):
        lat = make(np.array([0.5, 1.0, 0.0]))
        r = lat.direct_manipulation(x, t)
        lat.control_points = r.control_points
        reached = np.linalg.norm(lat.deform(x) - t, axis=1)
        np.testing.assert_allclose(r.residual, reached, atol=1e-12)
        assert reached[:2].max() < 1e-12  # reachable
        np.testing.assert_allclose(r.residual[2], np.linalg.norm(t[2] - x[2]), rtol=1e-12)  # weight 0: stays


def test_extrapolated_weights_that_overflow_are_refused():
    """Refused when bound, at rest too: the binding outlives the control points (docs/lattice.md,
    "Far outside")."""
    with pytest.raises(ValueError, match=r"^points: row 0 \(.*\) lies too far outside the lattice"):
        dk.FFD(2, outside="extrapolate").bind(np.full((1, 3), 1e154))


def test_overflow_errors_name_the_deformer_or_the_points():
    with pytest.raises(ValueError, match=r"^Taper: row 0 maps to a non-finite volume ratio"):
        dk.Taper(rate=1e300).volume_ratio(np.ones((1, 3)))
    with pytest.raises(ValueError, match=r"^Taper: row 0 maps to a non-finite position"):
        dk.Taper(rate=1e308).deform(np.full((1, 3), 10.0))
    with pytest.raises(ValueError, match=r"^points: row 0 maps to a non-finite position: its coordinates"):
        dk.Twist(rate=1.0).deform(np.full((1, 3), 3e38, np.float32))
    with pytest.raises(ValueError, match=r"^points: row 0 maps to a non-finite Jacobian: its coordinates"):
        dk.Stretch(factor=0.5).jacobian(np.full((1, 3), 1e300))
    with pytest.raises(ValueError, match=r"^deformers\[1\]: the points it receives: row 0 maps to a non-finite "
                                         r"Jacobian: its coordinates"):
        dk.Stack([dk.Twist(), dk.Stretch(factor=0.5)]).jacobian(np.full((1, 3), 1e300))


def test_direct_manipulation_residual_is_finite_or_refused():
    """Targets 1e300 away: the minimum-norm change reaches them (rank 3 per point), and the reported
    residual is what the moved lattice leaves, measured independently here."""
    p = np.array([[0.5, 0.5, 0.5], [0.2, 0.3, 0.4]])
    t = p + [[1e300, -1e300, 1e300], [-1e300, 1e300, 0.0]]
    lattice = dk.FFD(2)
    r = lattice.direct_manipulation(p, t)
    moved = dk.FFD(2, control_points=r.control_points).deform(p)
    miss = np.abs(moved - t).max(axis=1)  # independent of the solver's residual
    assert np.isfinite(r.max_residual)
    assert r.max_residual <= 1e-12 * 1e300 and miss.max() <= 1e-12 * 1e300, (r.max_residual, miss)
    for strength in (1e-300, 1e-10):
        with pytest.raises(ValueError, match="targets"):
            dk.FFD(2, strength=strength).direct_manipulation(p, t)


CUBE = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
QUADS = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
TRIS = np.vstack([QUADS[:, [0, 1, 2]], QUADS[:, [0, 2, 3]]])


@pytest.mark.parametrize("size", [(1e200, 1e200, 1e-250), (1e-200, 1e-200, 1e250), (1e150, 1e-150, 3.0),
                                  (1e102, 1e102, 1e102), (2.0 ** -1000, 1.0, 1.0)])
def test_mesh_volume_of_a_box_is_the_product_of_its_sides(size):
    """V = a b c exactly, whatever magnitudes the sides have, as long as V itself is a double."""
    mantissas, exponents = zip(*(math.frexp(s) for s in size))
    volume = math.ldexp(math.prod(mantissas), sum(exponents))  # a b c without an intermediate overflow
    np.testing.assert_allclose(dk.mesh_volume(CUBE * size, QUADS), volume, rtol=1e-14)
    np.testing.assert_allclose(dk.mesh_volume(CUBE * size + [1e3 * size[0], 0, 0], QUADS), volume, rtol=1e-12)


@pytest.mark.parametrize("scale", [1e103, 1e200, 1e300])
def test_mesh_volume_beyond_a_double_raises(scale):
    with pytest.raises(ValueError, match=r"points: the enclosed volume, about 1e\d+, overflows a double"):
        dk.mesh_volume(CUBE * scale, QUADS)


@pytest.mark.parametrize("scale", [1e-300, 1e-160, 1e103, 1e160, 1e200, 1e307])
def test_cotangent_weights_do_not_depend_on_the_scale(scale):
    """Cotangents are ratios of lengths: scaling the mesh leaves the Laplacian unchanged."""
    p = CUBE + RNG.uniform(-0.2, 0.2, CUBE.shape)
    ref = dk.cotangent_laplacian(p, TRIS)
    out = dk.cotangent_laplacian(p * scale, TRIS)
    np.testing.assert_array_equal(out[0], ref[0])
    np.testing.assert_array_equal(out[1], ref[1])
    np.testing.assert_allclose(out[2], ref[2], rtol=1e-13, atol=1e-13)


RANGE = r"constraint_weight: expected None \(hard constraints\) or a number in \[0\.0001, 1e\+08\], got "


@pytest.mark.parametrize("bad", [1e-300, 5e-324, 1e-5, 0.0, -1.0, 1.0000001e8, 1e300, np.nan, np.inf])
@pytest.mark.parametrize("method", ["laplacian", "arap", "rotation_invariant"])
def test_constraint_weight_outside_its_range_gets_one_message(bad, method):
    with pytest.raises(ValueError, match=RANGE):
        dk.SurfaceDeformer(CUBE, TRIS, handles=[0, 7], method=method, constraint_weight=bad)


@pytest.mark.parametrize("weight", [1e-4, 1e8])
@pytest.mark.parametrize("method", ["laplacian", "arap", "rotation_invariant"])
def test_constraint_weights_at_the_ends_of_the_range_work(weight, method):
    """A cube held only by two soft handles is solvable at both ends; moving both handles by t moves
    every vertex by t (translation invariance), rest targets give the rest cube. Held by w^2 alone,
    the system's condition grows as 1 / w^2: the results are good to about eps / w^2."""
    atol = max(1e-9, 1e3 * np.finfo(float).eps / weight**2)
    ed = dk.SurfaceDeformer(CUBE, TRIS, handles=[0, 7], method=method, constraint_weight=weight)
    np.testing.assert_allclose(ed.deform(CUBE[[0, 7]]), CUBE, rtol=0, atol=atol)
    t = np.array([0.1, -0.2, 0.3])
    np.testing.assert_allclose(ed.deform(CUBE[[0, 7]] + t), CUBE + t, rtol=0, atol=atol)

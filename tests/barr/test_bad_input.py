"""Bad input gets a clear error naming the argument; inputs are never modified."""

import numpy as np
import pytest

import deformkit as dk

PTS = np.random.default_rng(5).uniform(-1, 1, (50, 3))


@pytest.mark.parametrize("bad, exc, words", [
    (np.zeros((5, 2)), ValueError, "points: expected shape (n, 3), got (5, 2)"),
    (np.zeros(3), ValueError, "points: expected shape (n, 3), got (3,)"),
    (np.zeros((2, 3, 3)), ValueError, "points: expected shape (n, 3)"),
    (np.zeros((0, 3)), ValueError, "points: is empty"),
    (np.zeros((5, 3), dtype=np.int64), TypeError, "points: expected float32 or float64, got int64"),
    (np.zeros((5, 3), dtype=np.float16), TypeError, "points: expected float32 or float64, got float16"),
    ([[0.0, 0.0, 0.0]], TypeError, "points: expected a numpy array"),
])
def test_bad_points(bad, exc, words):
    for method in ("deform", "jacobian", "volume_ratio"):
        with pytest.raises(exc) as info:
            getattr(dk.Twist(), method)(bad)
        assert words in str(info.value)


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("d", [dk.Twist(), dk.Taper(), dk.Bend(), dk.Stretch(), dk.SimpleDeform(),
                               dk.Twist(profile=([0, 1], [0, 1])), dk.Stack([dk.Twist(), dk.Bend()])],
                         ids=["twist", "taper", "bend", "stretch", "simple", "profile", "stack"])
def test_non_finite_points_name_the_row(d, dtype, value):
    pts = PTS.astype(dtype)
    pts[37, 2] = value
    for call in (lambda: d.deform(pts), lambda: d.jacobian(pts), lambda: d.volume_ratio(pts)):
        with pytest.raises(ValueError, match="points: row 37 is not finite"):
            call()


def test_non_finite_normals():
    normals = np.ones_like(PTS)
    normals[3, 0] = np.nan
    with pytest.raises(ValueError, match="normals: row 3 is not finite"):
        dk.Bend().transform_normals(PTS, normals)
    with pytest.raises(ValueError, match="normals: has 49 rows but points has 50"):
        dk.Bend().transform_normals(PTS, normals[1:])


@pytest.mark.parametrize("make, words", [
    (lambda: dk.Twist(rate=np.nan), "rate: must be finite"),
    (lambda: dk.Taper(rate=np.inf), "rate: must be finite"),
    (lambda: dk.Bend(curvature=np.nan), "curvature: must be finite"),
    (lambda: dk.Bend(center=np.inf), "center: must be finite"),
    (lambda: dk.Stretch(factor=np.nan), "factor: must be finite"),
    (lambda: dk.Twist(axis="w"), "axis: expected 'x', 'y', 'z'"),
    (lambda: dk.Twist(axis=3), "axis: expected"),
    (lambda: dk.Twist(limits=(1.0, 0.0)), "limits: lo must not exceed hi"),
    (lambda: dk.Twist(limits=(np.nan, 1.0)), "limits: contains NaN"),
    (lambda: dk.Bend(region=(0.0,)), "region: expected (lo, hi)"),
    (lambda: dk.Twist(profile=([0.0], [1.0])), "profile: needs at least two samples, got 1"),
    (lambda: dk.Twist(profile=([0.0, 1.0], [1.0])), "profile: 2 positions but 1 values"),
    (lambda: dk.Twist(profile=([0.0, 0.0], [1.0, 2.0])), "profile: positions must be strictly increasing"),
    (lambda: dk.Twist(profile=([0.0, 1.0], [1.0, np.nan])), "profile: sample 1 is not finite"),
    (lambda: dk.Twist(profile=([0.0, 1.0],)), "profile: expected a pair"),
    (lambda: dk.Twist(rate=1.0, profile=([0, 1], [0, 1])), "rate: give either rate or profile"),
    (lambda: dk.Twist(profile=([0, 1], [0, 1]), extend="mirror"), "extend: expected 'constant' or 'linear'"),
    (lambda: dk.Twist(frame=np.diag([1.0, 1.0, 0.0, 1.0])), "frame: matrix is singular"),
    (lambda: dk.Twist(frame=np.eye(3)), "frame: expected a 4x4 matrix, got shape (3, 3)"),
    (lambda: dk.Twist(frame=np.full((4, 4), np.nan)), "frame: matrix contains NaN or Inf"),
    (lambda: dk.Twist(frame=np.ones((4, 4))), "frame: not an affine matrix"),
    (lambda: dk.Twist(weights=[0.5, np.nan]), "weights: entry 1 is not finite"),
    (lambda: dk.SimpleDeform(mode="SQUASH"), "mode: expected 'TWIST', 'BEND', 'TAPER' or 'STRETCH'"),
    (lambda: dk.SimpleDeform(limits=(0.8, 0.2)), "limits: lo must not exceed hi"),
    (lambda: dk.SimpleDeform(limits=(-0.1, 1.0)), "limits: both must lie in [0, 1]"),
    (lambda: dk.SimpleDeform(angle=1.0, factor=1.0), "angle: give angle or factor"),
    (lambda: dk.SimpleDeform(angle=np.nan), "angle: must be finite"),
    (lambda: dk.SimpleDeform(origin=np.zeros((4, 4))), "origin: "),
    (lambda: dk.SimpleDeform(invert_weights=True), "invert_weights: needs weights"),
    (lambda: dk.Stack([dk.Twist(), None]), ""),
])
def test_bad_parameters(make, words):
    with pytest.raises((ValueError, TypeError)) as info:
        make()
    assert words in str(info.value)


def test_weight_count_must_match_points():
    with pytest.raises(ValueError, match="weights: has 3 entries but points has 50 rows"):
        dk.Twist(weights=[1.0, 0.5, 0.0]).deform(PTS)


def test_out_argument():
    d = dk.Bend()
    expected = d.deform(PTS)
    out = np.empty_like(PTS)
    assert d.deform(PTS, out=out) is out
    np.testing.assert_array_equal(out, expected)
    in_place = PTS.copy()
    d.deform(in_place, out=in_place)
    np.testing.assert_array_equal(in_place, expected)
    with pytest.raises(TypeError, match="out: must have the dtype of points"):
        d.deform(PTS, out=np.empty((50, 3), np.float32))
    with pytest.raises(ValueError, match=r"out: expected shape \(50, 3\), got \(49, 3\)"):
        d.deform(PTS, out=np.empty((49, 3)))
    with pytest.raises(ValueError, match="out: must be a writeable C-contiguous array"):
        d.deform(PTS, out=np.empty((3, 50)).T)
    frozen = np.empty_like(PTS)
    frozen.flags.writeable = False
    with pytest.raises(ValueError, match="out: must be a writeable"):
        d.deform(PTS, out=frozen)


def test_inputs_are_not_modified_and_layouts_are_accepted():
    pts = PTS.copy()
    weights = np.linspace(0, 1, 50)
    w_copy = weights.copy()
    d = dk.Stack([dk.Twist(weights=weights), dk.Bend()])
    contiguous = d.deform(pts)
    d.jacobian(pts)
    d.transform_normals(pts, pts)
    np.testing.assert_array_equal(pts, PTS)
    np.testing.assert_array_equal(weights, w_copy)
    np.testing.assert_array_equal(d.deform(np.asfortranarray(pts)), contiguous)
    strided = np.zeros((100, 3))
    strided[::2] = pts
    np.testing.assert_array_equal(d.deform(strided[::2]), contiguous)


def test_in_place_with_a_bad_row_leaves_the_array_alone():
    pts = PTS.copy()
    pts[7, 0] = np.nan
    before = pts.copy()
    for d in (dk.Taper(), dk.Twist(weights=np.full(50, 0.5)), dk.Stack([dk.Twist(), dk.Bend()])):
        with pytest.raises(ValueError, match=r"points: row 7 is not finite \(nan"):
            d.deform(pts, out=pts)
        np.testing.assert_array_equal(pts, before)


def test_overlapping_out_is_refused():
    buf = np.random.default_rng(0).uniform(-1, 1, (41, 3))
    with pytest.raises(ValueError, match="out: overlaps points without being the same array"):
        dk.Twist().deform(buf[:-1], out=buf[1:])
    with pytest.raises(ValueError, match="out: overlaps points"):
        dk.Twist().displacement(buf[1:], out=buf[:-1])


def test_parameters_that_overflow_are_reported():
    with pytest.raises(ValueError, match="row 0 maps to a non-finite position"):
        dk.Taper(rate=1.0).deform(np.array([[1e308, 1e308, 1.0]]))
    with pytest.raises(ValueError, match="non-finite position"):
        dk.Taper(rate=1e39).deform(PTS.astype(np.float32))
    with pytest.raises(ValueError, match="limits: expected lo <= hi with lo < \\+inf"):
        dk.Twist(limits=(np.inf, np.inf))
    with pytest.raises(ValueError, match="profile: the spline through these samples overflows"):
        dk.Twist(profile=([0, 1e-320, 1], [0, 1, 0]))
    with pytest.raises(ValueError, match="weights: is empty"):
        dk.Twist(weights=[])
    with pytest.raises(TypeError, match="frame: expected float32 or float64, got complex128"):
        dk.Twist(frame=np.eye(4) * (1 + 1j))
    with pytest.raises(ValueError, match="axis: expected"):
        dk.Twist(axis=True)
    assert dk.Twist(axis=np.int64(1)).deform(PTS).shape == (50, 3)
    scaled = dk.Twist(frame=np.diag([1e-100, 1e-100, 1e-100, 1.0]), rate=1e-100)  # tiny but regular
    np.testing.assert_allclose(scaled.deform(PTS), dk.Twist(rate=1e-100 * 1e100).deform(PTS), atol=1e-12)
    np.testing.assert_array_equal(dk.Twist().deform(PTS.astype(">f8")), dk.Twist().deform(PTS))


def _deform_in_child(queue):
    pts = np.random.default_rng(1).uniform(-1, 1, (200_000, 3))
    queue.put(float(np.abs(dk.Twist().deform(pts)).max()))


def test_forked_child_does_not_hang():
    """OpenMP's thread pool does not survive fork(); a forked child must still work."""
    import multiprocessing
    dk.Twist().deform(np.random.default_rng(0).uniform(-1, 1, (200_000, 3)))  # start the pool
    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    child = ctx.Process(target=_deform_in_child, args=(queue,))
    child.start()
    child.join(timeout=60)
    if child.is_alive():
        child.kill()
        pytest.fail("the forked child hung in deform")
    assert child.exitcode == 0 and queue.get(timeout=5) > 0.5

"""SimpleDeform.bind(points): the fixed spatial map SimpleDeform.deform applies to those points.

deform() measures the extent of whatever points it is given (Blender's bounding pass), so it is
not a spatial map: chunks deform differently from the whole. The bound map measures nothing when
called, so chunking can never change a result. The truth is deform() on all the points."""
import numpy as np
import pytest

import deformkit as dk


def origin_frame():
    m = np.eye(4)
    c, s = np.cos(0.4), np.sin(0.4)
    m[:3, :3] = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ np.diag([1.2, 0.8, 1.1])
    m[:3, 3] = (0.2, -0.1, 0.3)
    return m


SETTINGS = {
    "twist": dict(mode="TWIST", angle=1.3, deform_axis="Z", limits=(0.1, 0.8)),
    "bend": dict(mode="BEND", angle=1.1, deform_axis="X", origin=origin_frame()),
    "taper": dict(mode="TAPER", factor=0.7, deform_axis="Y", lock_x=True),
    "stretch": dict(mode="STRETCH", factor=0.4, deform_axis="X", limits=(0.2, 0.9), origin=origin_frame()),
}


def points(rng, n=30_011):  # several threads' blocks and SIMD tails
    return rng.uniform(-1.0, 1.5, (n, 3)) * (1.0, 0.6, 1.4)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("name", SETTINGS)
def test_chunks_of_the_bound_map_equal_deforming_the_whole(name, dtype, rng):
    d = dk.SimpleDeform(**SETTINGS[name])
    pts = points(rng).astype(dtype)
    whole = d.deform(pts)
    bound = d.bind(pts)
    a, b = pts[:9_000], pts[9_000:]
    chunked = np.concatenate([bound.deform(a), bound.deform(b)])
    assert chunked.dtype == dtype
    assert chunked.tobytes() == whole.tobytes()
    # What bind fixes: deforming a chunk by itself measures that chunk's extent instead.
    assert not np.array_equal(d.deform(a), whole[:9_000])


@pytest.mark.parametrize("name", SETTINGS)
def test_the_bound_map_is_deform_on_the_bound_points(name, rng):
    pts = points(rng, 5_000)
    w = rng.uniform(0, 1, len(pts))
    for d in (dk.SimpleDeform(**SETTINGS[name]), dk.SimpleDeform(**SETTINGS[name], weights=w),
              dk.SimpleDeform(**SETTINGS[name], weights=w, invert_weights=True)):
        bound = d.bind(pts)
        assert isinstance(bound, dk.BarrDeformer) and isinstance(bound, dk.Deformer)
        assert bound.deform(pts).tobytes() == d.deform(pts).tobytes()
        assert bound.jacobian(pts).tobytes() == d.jacobian(pts).tobytes()
        assert bound.displacement(pts).tobytes() == d.displacement(pts).tobytes()
        if d.weights is None:
            assert bound.weights is None
        else:  # the same weights policy: the (inverted) weights travel with the map
            np.testing.assert_array_equal(bound.weights, d.weights)


def test_a_bend_blender_leaves_alone_binds_to_the_identity(rng):
    pts = points(rng, 100)
    d = dk.SimpleDeform(mode="BEND", angle=1e-9)  # |k| < 1e-6: Blender leaves the points
    np.testing.assert_array_equal(d.deform(pts), pts)
    bound = d.bind(pts)
    assert bound.deform(pts).tobytes() == pts.tobytes()
    np.testing.assert_array_equal(bound.jacobian(pts), np.broadcast_to(np.eye(3), (100, 3, 3)))


def test_bad_points_are_named_as_deform_names_them(rng):
    d = dk.SimpleDeform()
    bad = points(rng, 5)
    bad[2, 1] = np.nan
    for arg in (bad, np.ones((5, 3), np.int64), bad[:, :2], np.empty((0, 3)), [[0.0, 0.0, 0.0]]):
        with pytest.raises((TypeError, ValueError)) as deform_error:
            d.deform(arg)
        with pytest.raises(type(deform_error.value)) as bind_error:
            d.bind(arg)
        assert str(bind_error.value) == str(deform_error.value)
        assert str(bind_error.value).startswith("points: ")
    with pytest.raises(ValueError, match=r"^points: row 2 is not finite"):
        d.bind(bad)


def test_weights_must_count_the_bound_points(rng):
    d = dk.SimpleDeform(weights=np.full(4, 0.5))
    with pytest.raises(ValueError) as deform_error:
        d.deform(points(rng, 5))
    with pytest.raises(ValueError) as bind_error:
        d.bind(points(rng, 5))
    assert str(bind_error.value) == str(deform_error.value) == "weights: has 4 entries but points has 5 rows"


def test_an_extent_that_overflows_is_named():
    pts = np.array([[-1e308, 0, 0], [1e308, 0, 0]])
    with pytest.raises(ValueError, match="^points: their extent along the limit axis overflows a double"):
        dk.SimpleDeform().bind(pts)

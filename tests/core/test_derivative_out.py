"""out= of jacobian, transform_normals and volume_ratio (a viewport's buffer reused frame after
frame): the same values as a fresh result, in the caller's array, for every deformer type and
both dtypes; an unsuitable out is refused naming `out`, before anything is written, and the
inputs are never written."""
import numpy as np
import pytest

import deformkit as dk

from test_memory_safety import IDS, deformers

RNG = np.random.default_rng(31)
P64 = RNG.uniform(-1, 1, (3001, 3))
N64 = RNG.normal(size=P64.shape)


def calls(d, p, n):
    """(name, fresh result, call writing into out) for the three derivative paths."""
    return [("jacobian", d.jacobian(p), lambda out: d.jacobian(p, out=out)),
            ("transform_normals", d.transform_normals(p, n), lambda out: d.transform_normals(p, n, out=out)),
            ("volume_ratio", d.volume_ratio(p), lambda out: d.volume_ratio(p, out=out))]


@pytest.mark.parametrize("d", deformers(), ids=IDS)
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_out_holds_what_a_fresh_result_holds(d, dtype):
    p, n = P64.astype(dtype), N64.astype(dtype)
    p0, n0 = p.copy(), n.copy()
    for name, fresh, into in calls(d, p, n):
        out = np.full(fresh.shape, np.nan, dtype)
        got = into(out)
        assert got is out, name
        np.testing.assert_array_equal(out, fresh, err_msg=name)
        got = into(out)  # again into the same buffer: the same values, nothing left of the last call
        np.testing.assert_array_equal(out, fresh, err_msg=name)
    np.testing.assert_array_equal(p, p0)
    np.testing.assert_array_equal(n, n0)


def test_mixed_dtypes_follow_the_result():
    """float64 points with float32 normals give float32 normals, as without out."""
    d = dk.Twist(rate=1.0)
    p, n = P64, N64.astype(np.float32)
    fresh = d.transform_normals(p, n)
    assert fresh.dtype == np.float32
    out = np.empty_like(fresh)
    np.testing.assert_array_equal(d.transform_normals(p, n, out=out), fresh)
    with pytest.raises(TypeError, match=r"out: expected a native-order aligned float32 array \(the result's dtype\), got float64"):
        d.transform_normals(p, n, out=np.empty(fresh.shape))


@pytest.mark.parametrize("bad, error, words", [
    (lambda shape, dt: np.empty(shape, np.float32 if dt == np.float64 else np.float64), TypeError,
     r"out: expected a native-order aligned float\d\d array \(the result's dtype\), got float\d\d"),
    (lambda shape, dt: np.empty(shape, np.dtype(dt).newbyteorder(">")), TypeError, r"\(byte-swapped\)"),
    (lambda shape, dt: np.empty(shape, np.int64 if dt == np.float64 else np.int32), TypeError, r"got int"),
    (lambda shape, dt: np.empty((shape[0] + 1,) + shape[1:], dt), ValueError, r"out: expected shape \(50,.*got \(51,"),
    (lambda shape, dt: np.empty(shape[:1] + (1,) * (len(shape) - 1) + (2,), dt), ValueError, r"out: expected shape"),
    (lambda shape, dt: np.empty(shape[:-1] + (2 * shape[-1],), dt)[..., ::2], ValueError,
     r"out: must be a writeable C-contiguous array"),
    (lambda shape, dt: np.empty(shape, dt)[::-1], ValueError, r"out: must be a writeable C-contiguous array"),
    (lambda shape, dt: _read_only(np.empty(shape, dt)), ValueError, r"out: must be a writeable C-contiguous array"),
    (lambda shape, dt: list(np.zeros(shape, dt)), TypeError, r"out: expected a numpy array or None"),
])
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_unsuitable_out_is_refused_before_anything_is_written(bad, error, words, dtype):
    d = dk.FFD(2)
    p, n = P64[:50].astype(dtype), N64[:50].astype(dtype)
    for name, fresh, into in calls(d, p, n):
        out = bad(fresh.shape, dtype)
        before = np.array(out, copy=True)
        with pytest.raises(error, match=words):
            into(out)
        if isinstance(out, np.ndarray):
            np.testing.assert_array_equal(np.asarray(out), before, err_msg=name)


def _read_only(a):
    a.flags.writeable = False
    return a


def test_out_sharing_memory_with_an_input_is_refused():
    d = dk.Twist(rate=1.0)
    buf = np.zeros((100, 3))
    p, n = buf[:50], buf[50:]
    p[:] = P64[:50]
    n[:] = N64[:50]
    p0, n0 = p.copy(), n.copy()
    for out, call in ((p, lambda o: d.transform_normals(p, n, out=o)), (n, lambda o: d.transform_normals(p, n, out=o)),
                      (buf.reshape(-1)[:50], lambda o: d.volume_ratio(p, out=o))):
        with pytest.raises(ValueError, match="out: overlaps an input"):
            call(out)
    jac = np.zeros((50, 3, 3))
    with pytest.raises(ValueError, match="out: overlaps an input"):
        d.jacobian(jac.reshape(-1, 3)[:50], out=jac)
    np.testing.assert_array_equal(p, p0)
    np.testing.assert_array_equal(n, n0)

"""Memory safety where arrays cross into C++: dtypes by value, allocation failures, deep nesting,
overlapping outputs. Anything that could crash runs in a child process, so that a crash fails the
test instead of ending pytest."""
import ctypes
import pickle
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import deformkit as dk

RNG = np.random.default_rng(12)
P64 = RNG.uniform(-1, 1, (2000, 3))
P32 = P64.astype(np.float32)


def deformers():
    """One of every deformer type, each moving points visibly."""
    ffd = dk.FFD(2)
    grid = ffd.control_points
    grid[1, 1, 1] += (0.3, -0.2, 0.4)
    ffd.control_points = grid
    lattices = [ffd, dk.BezierFFD(1), dk.BSplineLattice(4), dk.BlenderLattice(3),
                dk.ExtendedFFD.cylinder(radius=2.0, height=3.0, center=(0, 0, -1.5))]
    for lat in lattices[1:]:
        g = lat.control_points
        g[..., 0] += 0.1 * g[..., 2]
        lat.control_points = g
    return [dk.Twist(rate=1.0), dk.Taper(rate=0.5), dk.Bend(curvature=0.7), dk.Stretch(factor=0.3),
            dk.SimpleDeform("BEND", angle=1.0), dk.Stack([dk.Twist(rate=0.4), dk.Bend(curvature=0.2)])] + lattices


IDS = ["twist", "taper", "bend", "stretch", "simple", "stack", "ffd", "bezier", "bspline", "blender", "effd"]


def same_meaning_variants(a):
    """Arrays equal to `a` whose dtype is not numpy's canonical dtype object, or whose bytes are swapped."""
    variants = {
        "pickled": pickle.loads(pickle.dumps(a)),
        "metadata": a.astype(np.dtype(a.dtype, metadata={"unit": "m"})),
        "explicit native order": a.astype(a.dtype.newbyteorder("<")),
        "byte-swapped": a.astype(a.dtype.newbyteorder(">")),
    }
    ctype = ctypes.c_float if a.dtype == np.float32 else ctypes.c_double
    buf = (ctype * a.size)(*a.ravel())
    variants["ctypes"] = np.ctypeslib.as_array(buf).reshape(a.shape)
    assert variants["pickled"].dtype is not a.dtype or variants["metadata"].dtype is not a.dtype
    return variants


@pytest.mark.parametrize("d", deformers(), ids=IDS)
@pytest.mark.parametrize("base", [P32, P64], ids=["float32", "float64"])
def test_dtype_compared_by_value(d, base):
    want = d.deform(base)
    want_jac = d.jacobian(base)
    want_disp = d.displacement(base)
    for name, pts in same_meaning_variants(base).items():
        got = d.deform(pts)
        assert got.dtype == base.dtype, name
        np.testing.assert_array_equal(got, want, err_msg=name)
        np.testing.assert_array_equal(d.displacement(pts), want_disp, err_msg=name)
        np.testing.assert_array_equal(d.jacobian(pts), want_jac, err_msg=name)
        np.testing.assert_array_equal(d.volume_ratio(pts), d.volume_ratio(base), err_msg=name)
        np.testing.assert_array_equal(d.transform_normals(pts, pts), d.transform_normals(base, base), err_msg=name)
        out = pickle.loads(pickle.dumps(np.zeros_like(base)))
        d.deform(pts, out=out)
        np.testing.assert_array_equal(out, want, err_msg=name)
        if isinstance(d, dk.Lattice):
            bound = d.bind(pts)
            np.testing.assert_array_equal(d.deform_bound(bound), want, err_msg=name)
            np.testing.assert_array_equal(d.lattice_coordinates(pts), d.lattice_coordinates(base), err_msg=name)


def test_pickled_float32_in_a_worker_process():
    """What multiprocessing hands a worker: the reproducer of the issue, in a child."""
    run_child("""
        import pickle, numpy as np, deformkit as dk
        a = np.random.default_rng(0).uniform(-1, 1, (1000, 3)).astype(np.float32)
        b = pickle.loads(pickle.dumps(a))
        got = dk.Twist(rate=1.0).deform(b)
        assert got.dtype == np.float32
        np.testing.assert_array_equal(got, dk.Twist(rate=1.0).deform(a))
        np.testing.assert_array_equal(b, a)
    """)


def test_unaligned_points_are_copied_not_misread():
    raw = np.zeros(P64.nbytes + 1, np.uint8)
    pts = raw[1:].view(np.float64).reshape(P64.shape)
    pts[:] = P64
    assert not pts.flags.aligned
    np.testing.assert_array_equal(dk.Twist(rate=1.0).deform(pts), dk.Twist(rate=1.0).deform(P64))


@pytest.mark.parametrize("out, words", [
    (np.zeros((2000, 3), ">f8"), "out: must be native-order"),
    (np.zeros((2000, 3), np.float32), r"out: must have the dtype of points \(float64\), got float32"),
    (np.zeros((2000, 3), np.int64), r"out: must have the dtype of points \(float64\), got int64"),
])
def test_out_dtype_checked_by_value(out, words):
    with pytest.raises(TypeError, match=words):
        dk.Twist().deform(P64, out=out)
    assert not out.any()


def test_faces_and_frames_by_value():
    """Integer and 4x4 inputs take the same by-value path."""
    cube = dk.subdivide(*unit_cube(), 1)
    faces = pickle.loads(pickle.dumps(cube.faces.astype(np.int32)))
    np.testing.assert_allclose(dk.mesh_volume(cube.points, faces), dk.mesh_volume(cube.points, cube.faces))
    frame = np.eye(4).astype(">f8")
    frame[:3, 3] = (0.2, 0.1, -0.3)
    np.testing.assert_array_equal(dk.Twist(rate=1.0, frame=frame).deform(P64),
                                  dk.Twist(rate=1.0, frame=frame.astype("<f8")).deform(P64))


def unit_cube():
    pts = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    faces = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
    return pts, faces


# -- allocation failures --------------------------------------------------------------------------

HUGE = np.broadcast_to(np.zeros((1, 3)), (4_000_000_000, 3))  # 96 GB once made contiguous


@pytest.mark.parametrize("call", [
    lambda: dk.Twist().deform(HUGE),
    lambda: dk.Twist().jacobian(HUGE),
    lambda: dk.FFD(2).deform(HUGE),
    lambda: dk.FFD(2).bind(HUGE),
    lambda: dk.BlenderLattice(2).direct_manipulation(HUGE, HUGE),
], ids=["twist", "jacobian", "ffd", "bind", "direct"])
def test_input_too_large_to_copy_is_a_memory_error(call):
    with pytest.raises(MemoryError, match=r"points: not enough memory for a contiguous float64 copy of shape "
                                          r"\(4000000000, 3\)"):
        call()


def test_allocations_under_an_address_space_limit():
    """Copies and results too large for the memory left: MemoryError naming what, no crash."""
    run_child("""
        import resource, numpy as np, deformkit as dk
        pts = np.ones((12_000_000, 3), np.float32)               # 144 MB, made before the limit
        dk.Twist().deform(np.ones((100_000, 3)))                 # OpenMP's threads exist before it too
        used = int(open('/proc/self/statm').read().split()[0]) * resource.getpagesize()
        resource.setrlimit(resource.RLIMIT_AS, (used + 600 * 2**20, used + 600 * 2**20))
        big = np.broadcast_to(np.ones((1, 3)), (40_000_000, 3))  # 960 MB once copied
        for call, words in [(lambda: dk.Twist().deform(big), "points: not enough memory for a contiguous float64"),
                            (lambda: dk.FFD(2).deform(big), "points: not enough memory for a contiguous float64"),
                            (lambda: dk.FFD(2).bind(big), "points: not enough memory for a contiguous float64"),
                            # the float64 copy (288 MB) fits; 9 doubles a row (864 MB) do not
                            (lambda: dk.Twist(rate=1.0).jacobian(pts), "not enough memory for the Jacobians"),
                            # working arrays the core allocates itself, named too
                            (lambda: dk.FFD(2).volume_ratio(pts), "the Jacobians behind the volume ratios"),
                            (lambda: dk.FFD(2).bind(pts), "not enough memory for the lattice binding"),
                            (lambda: dk.BSplineLattice(4).lattice_coordinates(pts), "the lattice binding"),
                            (lambda: dk.FFD(2).transform_normals(pts, pts), "not enough memory for")]:
            try:
                call()
            except MemoryError as e:
                assert words in str(e), str(e)
            else:
                raise AssertionError("no MemoryError: " + words)
        assert dk.Twist(rate=1.0).deform(pts[:10]).shape == (10, 3)  # and the process goes on
        # Barr's derivative lanes need no Jacobians: float32 normals of every row fit in what is left.
        assert dk.Twist(rate=1.0).transform_normals(pts, pts).dtype == np.float32
    """)


# -- deep nesting -----------------------------------------------------------------------------------

def test_nested_stacks_are_flattened():
    a, b, c = dk.Twist(rate=0.5), dk.Bend(curvature=0.4), dk.Taper(rate=0.2)
    nested = dk.Stack([dk.Stack([a, dk.Stack([b])]), c])
    assert len(nested) == 3
    np.testing.assert_array_equal(nested.deform(P64), c.deform(b.deform(a.deform(P64))))
    run_child("""
        import numpy as np, deformkit as dk
        s = dk.Twist(rate=1.0)
        for _ in range(200_000):
            s = dk.Stack([s])
        pts = np.random.default_rng(1).uniform(-1, 1, (100, 3))
        np.testing.assert_array_equal(s.deform(pts), dk.Twist(rate=1.0).deform(pts))
        assert len(s) == 1
        del s
    """)


def test_weighted_nesting_is_bounded():
    w = np.full(len(P64), 0.5)
    s = dk.Stack([dk.Twist()], weights=w)
    with pytest.raises(ValueError, match=r"deformers: weighted stacks nest 65 deep, more than 64"):
        for _ in range(100):
            s = dk.Stack([s], weights=w)
    # Within the bound, the weights still compose: each level halves the displacement.
    inner = dk.Stack([dk.Stack([dk.Twist(rate=1.0)], weights=w)], weights=w)
    t = dk.Twist(rate=1.0).deform(P64)
    np.testing.assert_allclose(inner.deform(P64), P64 + 0.25 * (t - P64), atol=1e-15)


# -- overlapping outputs ------------------------------------------------------------------------------

@pytest.mark.parametrize("d", deformers(), ids=IDS)
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_out_overlapping_a_strided_input_is_refused(d, dtype):
    buf = np.zeros((80, 3), dtype)
    buf[::2] = P64[:40]
    before = buf.copy()
    for view, out in [(buf[::2], buf[:40]), (buf[::2], buf[40:]), (buf[1::2], buf[20:60]),
                      (buf[::-2], buf[:40]), (buf[:40], buf[1:41])]:
        for method in (d.deform, d.displacement):
            with pytest.raises(ValueError, match="out: overlaps points"):
                method(view, out=out)
            np.testing.assert_array_equal(buf, before)
    # Disjoint memory is fine, and so is points itself in place.
    out = np.empty((40, 3), dtype)
    np.testing.assert_array_equal(d.deform(buf[::2], out=out), d.deform(np.ascontiguousarray(buf[::2])))
    inplace = np.ascontiguousarray(buf[::2])
    want = d.deform(inplace)
    d.deform(inplace, out=inplace)
    np.testing.assert_array_equal(inplace, want)
    with pytest.raises(ValueError, match="out: displacement cannot be written over points"):
        d.displacement(inplace, out=inplace)


def run_child(code):
    proc = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, f"child exited with {proc.returncode}\n{proc.stdout}\n{proc.stderr}"


def test_an_overflow_inside_a_stack_names_the_member():
    """The caller's finite points are not blamed for what a later member does with them."""
    pts = np.full((5, 3), 10.0)
    overflowing = dk.Taper(rate=1e308)
    for out in (None, "in place"):
        x = pts.copy()
        with pytest.raises(ValueError, match=r"^deformers\[1\]: row 0 maps to a non-finite position"):
            dk.Stack([dk.Twist(), overflowing, dk.Bend()]).deform(x, out=x if out else None)
    weighted = dk.Stack([dk.Bend(), overflowing], weights=np.ones(5))
    with pytest.raises(ValueError, match=r"^deformers\[1\]\.deformers\[1\]: row 0 maps to a non-finite"):
        dk.Stack([dk.Twist(), weighted]).deform(pts)
    bad = pts.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match=r"^points: row 3 is not finite"):
        dk.Stack([dk.Twist(), overflowing]).deform(bad)
    # A point too large for any map is the point's fault, not the parameters'.
    with pytest.raises(ValueError, match=r"^points: row 0 maps to a non-finite position: its coordinates"):
        dk.Taper(rate=1.0).deform(np.array([[1e308, 1e308, 1.0]]))


def test_float_range_checks_follow_the_dtype_by_value():
    """A float32 Jacobian that overflows float32 raises, whichever float32 dtype object it came in."""
    pts = np.array([[1.0, 1.0, 1e10]], np.float32)  # r = 1e40: beyond float32, within float64
    assert np.isfinite(dk.Taper(rate=1e30).jacobian(pts.astype(np.float64))).all()
    for variant in [pts] + list(same_meaning_variants(pts).values()):
        with pytest.raises(ValueError, match="maps to a non-finite"):
            dk.Taper(rate=1e30).jacobian(variant)

"""dk.MeshDeform's frame: displacement_bound is w (F(x) - x) of the bound points in one pass, the
harmonic coordinates' formula w sum_a w_a (c_a - c_a at bind) / sum_a w_a (docs/cage.md), exactly
zero at the rest cage, the same bits on one thread as on the pool; a float32 binding's coordinates
are Blender's floats."""
import os
import subprocess
import sys

import numpy as np
import pytest
import scipy.sparse

import deformkit as dk

CUBE = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float) * 2.0 - 1.0
FACES = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]


# Points around the cage (half of them outside: a float32 binding keeps rows) or close to it (most
# inside: it keeps blocks of 8 points too, dense, which its frame reads), the latter with a last
# block of 5 points.
SPREADS = {"rows": (3000, 1.3), "blocks": (3005, 1.05)}


def setting(dtype, dynamic, weighted, count=3000, seed=5, spread=1.3):
    """A cube cage bound at precision 4, with points inside and around it, and the cage moved."""
    rng = np.random.default_rng(seed)
    pts = rng.uniform(-spread, spread, (count, 3)).astype(dtype)
    weights = rng.uniform(0, 1, count) if weighted else None
    md = dk.MeshDeform(CUBE, FACES, precision=4, dynamic=dynamic, weights=weights)
    b = md.bind(pts)
    md.cage_points = CUBE + rng.normal(0, 0.15, CUBE.shape)
    return md, b, pts, weights


@pytest.mark.parametrize("dynamic", [False, True])
@pytest.mark.parametrize("weighted", [False, True])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("layout", sorted(SPREADS))
def test_displacement_bound_is_the_bound_offset_in_one_pass(dtype, dynamic, weighted, layout):
    count, spread = SPREADS[layout]
    md, b, pts, weights = setting(dtype, dynamic, weighted, count=count, spread=spread)
    disp, moved = md.displacement_bound(b), md.deform_bound(b)
    assert disp.dtype == dtype
    # deform_bound minus the points, to the rounding of the point's largest coordinate
    largest = np.maximum(np.abs(pts), np.abs(moved)).max(axis=1, keepdims=True)
    ulp = np.spacing(largest.astype(dtype)).astype(np.float64)
    assert (np.abs(disp - (moved.astype(np.float64) - pts)) <= 2 * ulp).all()
    # the formula, from the exported coordinates (rows summing to 1): w W (c - c at bind)
    indptr, indices, data = b.weights()
    table = scipy.sparse.csr_matrix((data, indices, indptr), shape=(len(pts), len(CUBE)))
    expected = table @ (md.cage_points - md.rest_cage_points)
    if weights is not None:
        expected *= weights[:, None]
    scale = np.abs(md.cage_points - md.rest_cage_points).max()
    np.testing.assert_allclose(disp, expected, rtol=0, atol=(1e-6 if dtype == np.float32 else 1e-12) * 4 + 1e-6 * scale)
    outside = ~b.inside
    assert outside.any() and b.inside.any()
    assert not disp[outside].any()  # Mesh Deform leaves a point outside the cage where it is
    out = np.empty_like(pts)
    assert md.displacement_bound(b, out=out) is out
    np.testing.assert_array_equal(out, disp)


@pytest.mark.parametrize("dynamic", [False, True])
def test_the_rest_cage_displaces_by_exactly_zero(dynamic):
    md, b, pts, _ = setting(np.float32, dynamic, True)
    assert md.displacement_bound(b).any()
    md.cage_points = md.rest_cage_points
    assert not md.displacement_bound(b).any()


def test_displacement_bound_refuses_what_deform_bound_refuses():
    md, b, pts, _ = setting(np.float32, False, False)
    other = dk.MeshDeform(CUBE * 1.1, FACES, precision=4)
    with pytest.raises(ValueError, match="binding: ") as refused:
        other.deform_bound(b)
    with pytest.raises(ValueError, match=refused.value.args[0].split(" (")[0]):
        other.displacement_bound(b)
    with pytest.raises(TypeError, match="out: must have dtype float32"):
        md.displacement_bound(b, out=np.empty(pts.shape, np.float64))
    with pytest.raises(TypeError, match="out: must have dtype"):
        md.displacement_bound(b, out=np.empty(pts.shape, np.float16))


def test_a_float32_binding_keeps_its_coordinates_as_blenders_floats():
    """Blender's MDefInfluence holds a float weight; a float32 binding does too (the frame reads 8
    bytes a weight), a float64 binding keeps doubles: the same coordinates, rounded or not."""
    md, b32, pts, _ = setting(np.float32, False, False)
    b64 = md.bind(pts.astype(np.float64))
    (ptr32, col32, w32), (ptr64, col64, w64) = b32.weights(), b64.weights()
    np.testing.assert_array_equal(ptr32, ptr64)
    np.testing.assert_array_equal(col32, col64)
    rounded = w64.astype(np.float32).astype(np.float64)
    np.testing.assert_array_equal(w32, rounded)
    assert not np.array_equal(rounded, w64)


# (dynamic, spread, points): rows; blocks, enough of them (8 cage vertices x 140 003 points, over
# 4 MB of weights) for the pool to take them; a dynamic bind.
CASES = ((False, 1.3, 40003), (False, 1.05, 140003), (True, 1.3, 40003))
SCRIPT = """
import sys, numpy as np
sys.path.insert(0, {here!r})
from test_mesh_deform_frame import setting, CASES
for dynamic, spread, count in CASES:
    md, b, _, _ = setting(np.float32, dynamic, True, count=count, spread=spread)
    sys.stdout.buffer.write(md.displacement_bound(b).tobytes() + md.deform_bound(b).tobytes())
"""


def test_the_same_bits_on_one_thread_as_on_the_pool():
    """Enough points for the pool to split them (rows: a second thread from 16 384 points; blocks:
    from 4 MB of weights); each point's sum is its own, in rows or in blocks."""
    here = os.path.dirname(os.path.abspath(__file__))
    env = dict(os.environ, OMP_NUM_THREADS="1")
    one = subprocess.run([sys.executable, "-c", SCRIPT.format(here=here)], env=env, capture_output=True, check=True).stdout
    pooled = b""
    for dynamic, spread, count in CASES:
        md, b, _, _ = setting(np.float32, dynamic, True, count=count, spread=spread)
        pooled += md.displacement_bound(b).tobytes() + md.deform_bound(b).tobytes()
    assert dk.build_info()["threads"] != "1" or os.cpu_count() == 1
    assert one == pooled


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("layout", sorted(SPREADS))
def test_a_bind_from_its_rows_is_the_bind(dtype, layout):
    """bind(points, rows=binding.weights(), inside=binding.inside) gives the bind without its solve:
    the same coordinates, inside flags and frames, bit for bit (rows or dense blocks alike); without
    `inside`, the points with a row are the inside ones."""
    count, spread = SPREADS[layout]
    md, b, pts, _ = setting(dtype, False, False, count=count, spread=spread)
    again = md.bind(pts, rows=b.weights(), inside=b.inside)
    implied = md.bind(pts, rows=b.weights())
    for x, y in zip(again.weights(), b.weights()):
        np.testing.assert_array_equal(x, y)
    np.testing.assert_array_equal(again.inside, b.inside)
    np.testing.assert_array_equal(implied.inside, np.diff(b.weights()[0]) > 0)
    np.testing.assert_array_equal(md.deform_bound(again), md.deform_bound(b))
    np.testing.assert_array_equal(md.displacement_bound(implied), md.displacement_bound(b))

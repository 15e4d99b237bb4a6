"""The lattices' bound path runs on the core's one bind seam (BoundDeformer): the weight count,
the per-point blend, the identity and the overflow report are those of deform(), so bound and
unbound agree bit for bit, with weights too, for every lattice family."""
import numpy as np
import pytest

import deformkit as dk

LATTICES = {
    "ffd3": lambda **k: dk.FFD(3, **k),
    "bezier": lambda **k: dk.BezierFFD((2, 1, 1), **k),
    "bspline": lambda **k: dk.BSplineLattice(5, **k),
    "blender": lambda **k: dk.BlenderLattice(4, "bspline", **k),
    "blender_unchanged": lambda **k: dk.BlenderLattice((3, 4, 2), ("linear", "cardinal", "catmull_rom"),
                                                       outside="unchanged", **k),
    "effd": lambda **k: dk.ExtendedFFD(dk.BezierFFD(1).rest_control_points, **k),
}


def moved(make, rng, **kwargs):
    lat = make(**kwargs)
    lat.control_points = lat.rest_control_points + rng.normal(0, 0.08, lat.control_points.shape)
    return lat


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("name", LATTICES)
def test_weighted_bound_equals_weighted_deform_bit_for_bit(name, dtype, rng):
    pts = rng.uniform(-0.2, 1.2, (20_003, 3)).astype(dtype)
    w = rng.uniform(0, 1, len(pts))
    w[::11] = 1.0
    w[::7] = 0.0
    lat = moved(LATTICES[name], rng, weights=w, strength=0.9)
    bound = lat.deform_bound(lat.bind(pts))
    assert bound.dtype == dtype
    assert bound.tobytes() == lat.deform(pts).tobytes()
    full = LATTICES[name](strength=0.9)  # the same lattice without weights
    full.control_points = lat.control_points
    f = full.deform_bound(full.bind(pts)).astype(np.float64)
    x = pts.astype(np.float64)
    np.testing.assert_array_equal(bound[::7], pts[::7])  # weight 0: where it was
    np.testing.assert_allclose(bound, x + w[:, None] * (f - x), rtol=0, atol=2e-6 if dtype == np.float32 else 1e-14)


@pytest.mark.parametrize("name", LATTICES)
def test_a_lattice_at_rest_hands_the_bound_points_back(name, rng):
    pts = np.array([[-0.0, 0.5, 0.5], [0.25, -0.0, 1e300], [2.0, -1e-310, 0.5]])
    lat = LATTICES[name](weights=[0.5, 0.25, 1.0], strength=3.0)
    out = lat.deform_bound(lat.bind(pts))
    assert out.tobytes() == pts.tobytes()  # not computed: -0.0 and the far point survive


def test_the_weight_count_is_checked_against_the_binding():
    lat = dk.BSplineLattice(4, weights=np.full(7, 0.5))
    with pytest.raises(ValueError) as error:
        lat.deform_bound(lat.bind(np.full((6, 3), 0.5)))
    assert str(error.value) == "weights: has 7 entries but the binding has 6 points"


def test_the_csr_weights_reproduce_the_bound_deformation(rng):
    """LatticeBinding.weights() is the core's weight table: x + strength W (P - R) is deform_bound."""
    lat = moved(LATTICES["blender_unchanged"], rng, strength=0.7)
    pts = rng.uniform(-0.3, 1.3, (5_000, 3))
    binding = lat.bind(pts)
    indptr, indices, data = binding.weights()
    assert (indptr.dtype, indices.dtype, data.dtype) == (np.int64, np.int32, np.float64)
    assert indptr[0] == 0 and len(indptr) == len(pts) + 1 and indptr[-1] == len(indices) == len(data)
    dense = np.zeros((len(pts), int(np.prod(lat.resolution))))
    np.add.at(dense, (np.repeat(np.arange(len(pts)), np.diff(indptr)), indices), data)
    offsets = (lat.control_points - lat.rest_control_points).reshape(-1, 3)
    np.testing.assert_allclose(lat.deform_bound(binding), pts + lat.strength * dense @ offsets, rtol=0, atol=1e-13)

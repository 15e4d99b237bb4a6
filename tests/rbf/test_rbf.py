"""dk.RBF against independent truths: scipy.interpolate.RBFInterpolator (the same kernels and
conventions: phi evaluated at epsilon * r, the polynomial of `degree`, smoothing on the diagonal),
interpolation at the controls, exact affine reproduction, compact support, finite differences,
and the bound path."""
import numpy as np
import pytest
from scipy.interpolate import RBFInterpolator

import deformkit as dk

SCIPY_KERNELS = [("thin_plate_spline", None), ("cubic", None), ("quintic", None), ("linear", None),
                 ("gaussian", 3.0), ("multiquadric", 3.0), ("inverse_multiquadric", 3.0), ("inverse_quadratic", 3.0)]
COMPACT = ["wendland_c0", "wendland_c2", "wendland_c4", "clip"]


def smooth_map(p):
    """A non-affine map: what the controls' targets sample."""
    return p + np.stack([0.1 * np.sin(3 * p[:, 1]), 0.08 * p[:, 2] ** 2, -0.05 * np.cos(2 * p[:, 0])], 1)


@pytest.fixture
def controls(rng):
    return rng.random((120, 3))


@pytest.mark.parametrize("kernel, epsilon", SCIPY_KERNELS)
@pytest.mark.parametrize("degree", [None, 2])
@pytest.mark.parametrize("smoothing", [0.0, 1e-3])
def test_agrees_with_scipy(controls, rng, kernel, epsilon, degree, smoothing):
    targets = smooth_map(controls)
    kw = {} if epsilon is None else {"epsilon": epsilon}
    r = dk.RBF(controls, targets, kernel=kernel, degree=degree, smoothing=smoothing, **kw)
    # scipy's default degree is 1 or the kernel's minimum, whichever is larger: as deformkit's.
    scipy_degree = r.degree if degree is None else degree
    s = RBFInterpolator(controls, targets - controls, kernel=kernel, degree=scipy_degree, smoothing=smoothing, **kw)
    x = rng.uniform(-0.3, 1.3, (2000, 3))
    got, want = r.deform(x), x + s(x)
    scale = np.abs(targets - controls).max()
    assert np.abs(got - want).max() < 1e-10 * scale  # measured: at most 1.9e-13 (condition estimates <= 2e6)


@pytest.mark.parametrize("kernel, epsilon", SCIPY_KERNELS)
def test_controls_land_on_their_targets(controls, kernel, epsilon):
    targets = smooth_map(controls)
    r = dk.RBF(controls, targets, kernel=kernel, **({} if epsilon is None else {"epsilon": epsilon}))
    assert np.abs(r.deform(controls) - targets).max() < 1e-11


@pytest.mark.parametrize("kernel", COMPACT)
def test_compact_kernels_interpolate_and_leave_far_points_bit_for_bit(controls, rng, kernel):
    targets = smooth_map(controls)
    r = dk.RBF(controls, targets, kernel=kernel, radius=0.5, degree=-1)
    assert np.abs(r.deform(controls) - targets).max() < 1e-12
    far = np.vstack([rng.uniform(1.6, 3.0, (100, 3)), rng.uniform(-3.0, -0.6, (100, 3)), [[1e15, -1e15, 0.0]]])
    assert np.array_equal(r.deform(far), far)
    near = controls[:10] + 0.01
    assert not np.array_equal(r.deform(near), near)


def test_compact_kernels_agree_with_a_dense_solve(controls, rng):
    """Wendland C2 (not in scipy): the saddle-point system solved densely with numpy, independently."""
    targets = smooth_map(controls)
    radius = 0.6
    r = dk.RBF(controls, targets, kernel="wendland_c2", radius=radius, degree=1)

    def phi(d):
        rho = np.minimum(d / radius, 1.0)
        return (1 - rho) ** 4 * (4 * rho + 1)
    m = len(controls)
    k = phi(np.linalg.norm(controls[:, None] - controls[None], axis=2))
    p = np.hstack([np.ones((m, 1)), controls])
    a = np.block([[k, p], [p.T, np.zeros((4, 4))]])
    coef = np.linalg.solve(a, np.vstack([targets - controls, np.zeros((4, 3))]))
    x = rng.uniform(-0.2, 1.2, (500, 3))
    want = x + phi(np.linalg.norm(x[:, None] - controls[None], axis=2)) @ coef[:m] + np.hstack(
        [np.ones((500, 1)), x]) @ coef[m:]
    assert np.abs(r.deform(x) - want).max() < 1e-10


@pytest.mark.parametrize("kernel, epsilon", SCIPY_KERNELS + [(k, None) for k in COMPACT])
def test_an_affine_map_of_the_controls_moves_everything_affinely(controls, rng, kernel, epsilon):
    a = np.array([[1.1, 0.2, -0.1], [0.0, 0.9, 0.3], [0.2, -0.1, 1.2]])
    b = np.array([0.3, -0.2, 0.5])
    kw = {"radius": 0.5} if kernel in COMPACT else {} if epsilon is None else {"epsilon": epsilon}
    r = dk.RBF(controls, controls @ a.T + b, kernel=kernel, degree=max(1, 2 if kernel == "quintic" else 1), **kw)
    x = rng.uniform(-1, 2, (1000, 3))
    assert np.abs(r.deform(x) - (x @ a.T + b)).max() < 1e-9


@pytest.mark.parametrize("kernel, epsilon", SCIPY_KERNELS + [(k, None) for k in COMPACT])
def test_jacobian_matches_central_differences(controls, rng, kernel, epsilon):
    kw = {"radius": 0.7} if kernel in COMPACT else {} if epsilon is None else {"epsilon": epsilon}
    r = dk.RBF(controls, smooth_map(controls), kernel=kernel, **kw)
    x = rng.uniform(0, 1, (30, 3))
    j = r.jacobian(x)
    h = 1e-6
    for c in range(3):
        e = np.zeros(3)
        e[c] = h
        fd = (r.deform(x + e) - r.deform(x - e)) / (2 * h)
        assert np.abs(j[:, :, c] - fd).max() < 1e-6 * (1 + np.abs(j).max())


def test_new_targets_equal_a_new_rbf(controls):
    first, second = smooth_map(controls), controls + 0.05 * np.cos(controls)
    r = dk.RBF(controls, first, kernel="cubic")
    r.targets = second
    x = np.random.default_rng(5).random((300, 3))
    assert np.array_equal(r.deform(x), dk.RBF(controls, second, kernel="cubic").deform(x))
    assert np.array_equal(r.targets, second)
    r.targets = controls  # back at rest: the identity, bit for bit
    assert np.array_equal(r.deform(x), x)


@pytest.mark.parametrize("kernel, kw", [("thin_plate_spline", {}), ("gaussian", {"epsilon": 3.0}),
                                        ("wendland_c2", {"radius": 0.5})])
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_bound_points_deform_as_unbound(controls, rng, kernel, kw, dtype):
    r = dk.RBF(controls, kernel=kernel, **kw)
    x = rng.uniform(-0.2, 1.2, (20000, 3)).astype(dtype)
    binding = r.bind(x)
    assert np.array_equal(r.deform_bound(binding), x)  # at rest
    r.targets = smooth_map(controls)
    got = r.deform_bound(binding)
    assert got.dtype == dtype
    tol = 1e-12 if dtype == np.float64 else 1e-6
    assert np.abs(got.astype(float) - r.deform(x).astype(float)).max() < tol
    if kernel == "wendland_c2":  # the table is phi(|x - c|) within the support
        indptr, indices, data = binding.weights()
        row = 17
        d = np.linalg.norm(x[row].astype(float) - controls, axis=1)
        inside = np.flatnonzero(d < 0.5)
        assert sorted(indices[indptr[row]:indptr[row + 1]]) == list(inside)


def test_inputs_are_not_modified(controls):
    targets = smooth_map(controls)
    c0, t0 = controls.copy(), targets.copy()
    r = dk.RBF(controls, targets)
    controls += 1.0
    targets += 1.0
    assert np.array_equal(r.control_points, c0) and np.array_equal(r.targets, t0)
    got = r.targets
    got += 1.0
    assert np.array_equal(r.targets, t0)


def test_composes_in_a_stack(controls, rng):
    r = dk.RBF(controls, smooth_map(controls))
    x = rng.random((100, 3))
    both = dk.Stack([dk.Twist(rate=0.5), r]).deform(x)
    assert np.allclose(both, r.deform(dk.Twist(rate=0.5).deform(x)), atol=1e-14)


def test_per_point_weights_blend_toward_the_input(controls, rng):
    """Blender's vertex-group blend, as every deformer: x + w (F(x) - x), on the bound path too."""
    x = rng.random((300, 3))
    w = rng.random(300)
    full = dk.RBF(controls, smooth_map(controls))
    blended = dk.RBF(controls, smooth_map(controls), weights=w)
    want = x + w[:, None] * (full.deform(x) - x)
    assert np.abs(blended.deform(x) - want).max() < 1e-14
    assert np.abs(blended.deform_bound(blended.bind(x)) - want).max() < 1e-14

"""Every set of controls the RBF cannot fit, and every bad argument, is refused with an error that
names the argument, what it got and what it accepts."""
import numpy as np
import pytest

import deformkit as dk

C = np.random.default_rng(2).random((30, 3))


def refused(*args, **kwargs):
    with pytest.raises((ValueError, TypeError)) as info:
        dk.RBF(*args, **kwargs)
    return str(info.value)


def test_kernel_parameters():
    assert refused(C, kernel="spline").startswith("kernel: expected 'thin_plate_spline', 'cubic', ")
    assert refused(C, kernel="spline").endswith("got 'spline'")
    assert refused(C, kernel="gaussian").startswith("epsilon: the gaussian kernel needs its shape parameter")
    assert refused(C, kernel="gaussian", epsilon=-2.0).startswith("epsilon: expected a positive finite number")
    assert refused(C, kernel="gaussian", epsilon=np.nan).startswith("epsilon:")
    assert refused(C, kernel="wendland_c2").startswith("radius: the wendland_c2 kernel needs its support radius")
    assert refused(C, kernel="wendland_c2", radius=0.0).startswith("radius: expected a positive finite number")
    assert refused(C, kernel="clip", epsilon=1.0).startswith("epsilon: the clip kernel has a support radius")
    assert refused(C, radius=1.0).startswith("radius: the thin_plate_spline kernel is global")
    assert refused(C, degree=3).startswith("degree:")
    assert refused(C, degree=0).startswith("degree: the thin_plate_spline kernel needs degree >= 1, got 0")
    assert refused(C, kernel="quintic", degree=1).startswith("degree: the quintic kernel needs degree >= 2")
    assert refused(C, smoothing=-1.0).startswith("smoothing: expected a finite number >= 0")
    assert refused(C, smoothing=np.inf).startswith("smoothing:")


def test_controls_that_cannot_be_fitted():
    dup = C.copy()
    dup[9] = dup[4]
    assert refused(dup).startswith("control_points: points 4 and 9 coincide")
    dk.RBF(dup, smoothing=1e-3)  # a least-squares fit instead
    flat = C.copy()
    flat[:, 2] = 0.25
    assert refused(flat).startswith("control_points: the controls span only 2 dimension(s)")
    dk.RBF(flat, degree=0, kernel="linear")  # without the affine term a plane is fine
    line = np.outer(np.linspace(0, 1, 10), [1.0, 2.0, 3.0])
    assert refused(line).startswith("control_points: the controls span only 1 dimension(s)")
    assert refused(C[:3]).startswith("control_points: degree 1 needs at least 4 controls, got 3")
    assert refused(C, kernel="gaussian", epsilon=1e-3, degree=-1).startswith(
        "epsilon: 0.001 (epsilon times the controls' extent is ")
    bad = C.copy()
    bad[7, 1] = np.nan
    assert refused(bad).startswith("control_points:")
    assert refused(C[:, :2]).startswith("control_points: expected shape (n, 3), got (30, 2)")
    assert refused(C.astype(int)).startswith("control_points: expected float32 or float64")
    assert refused(C[:0]).startswith("control_points: is empty")


def test_targets_and_points():
    assert refused(C, C[:5]).startswith("targets: expected shape (30, 3), one row per control, got (5, 3)")
    r = dk.RBF(C, C + 0.1)
    for bad, start in [(C[:4], "targets: expected shape (30, 3)"), (C * np.inf, "targets: point 0 is not finite"),
                       ("targets", "targets:")]:
        with pytest.raises((ValueError, TypeError)) as info:
            r.targets = bad
        assert str(info.value).startswith(start), info.value
    assert np.array_equal(r.targets, C + 0.1)  # a refused assignment changes nothing
    x = np.random.default_rng(3).random((5, 3))
    x[2, 0] = np.nan
    with pytest.raises(ValueError, match="^points: row 2"):
        r.deform(x)
    other = dk.RBF(C * 2.0)
    with pytest.raises(ValueError, match="^binding: was made by an RBF of other controls"):
        r.deform_bound(other.bind(C))
    with pytest.raises(TypeError, match="binding"):
        r.deform_bound(dk.MeanValueCage(np.eye(3, 3)[[0, 1, 2, 0]] + [[0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 1]],
                                        [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]).bind(C))

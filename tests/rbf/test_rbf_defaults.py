"""dk.RBF's defaults are scipy's (scipy.interpolate.RBFInterpolator, the pinned 1.14.1): a call
that gives no degree, epsilon or smoothing is the interpolant scipy gives for a call without
them, and the defaults are read from scipy itself so that a change on either side fails here."""
import inspect
import re

import numpy as np
import pytest
from scipy.interpolate import RBFInterpolator
from scipy.interpolate import _rbfinterp

import deformkit as dk

SCALE_INVARIANT = ["thin_plate_spline", "cubic", "quintic", "linear"]
SHAPED = ["gaussian", "multiquadric", "inverse_multiquadric", "inverse_quadratic"]


def smooth_map(p):
    return p + np.stack([0.1 * np.sin(3 * p[:, 1]), 0.08 * p[:, 2] ** 2, -0.05 * np.cos(2 * p[:, 0])], 1)


@pytest.mark.parametrize("kernel", SCALE_INVARIANT + SHAPED)
def test_a_call_without_degree_epsilon_or_smoothing_is_scipys(rng, kernel):
    controls = rng.random((80, 3))
    targets = smooth_map(controls)
    # The shaped kernels need epsilon in both (scipy raises without it); nothing else is given.
    kw = {"epsilon": 3.0} if kernel in SHAPED else {}
    ours = dk.RBF(controls, targets, kernel=kernel, **kw)
    theirs = RBFInterpolator(controls, targets - controls, kernel=kernel, **kw)
    x = rng.uniform(-0.3, 1.3, (1000, 3))
    assert np.abs(ours.deform(x) - (x + theirs(x))).max() < 1e-10 * np.abs(targets - controls).max()


def test_the_default_kernel_is_scipys(rng):
    controls = rng.random((40, 3))
    targets = smooth_map(controls)
    x = rng.uniform(0, 1, (200, 3))
    theirs = RBFInterpolator(controls, targets - controls)
    assert np.abs(dk.RBF(controls, targets).deform(x) - (x + theirs(x))).max() < 1e-10


def test_the_defaults_read_from_scipy():
    signature = inspect.signature(RBFInterpolator)
    doc = dk.RBF.__init__.__doc__
    assert signature.parameters["kernel"].default == "thin_plate_spline" and "kernel: str = 'thin_plate_spline'" in doc
    assert signature.parameters["smoothing"].default == 0.0 and re.search(r"smoothing: [^=]* = 0\.0,", doc)
    assert signature.parameters["degree"].default is None and signature.parameters["epsilon"].default is None
    controls = np.random.default_rng(2).random((30, 3))
    for kernel in SCALE_INVARIANT + SHAPED:
        # scipy: degree None means max(the kernel's minimum degree, 0) (its _NAME_TO_MIN_DEGREE table;
        # kernels not in it have no minimum).
        scipy_default = max(_rbfinterp._NAME_TO_MIN_DEGREE.get(kernel, -1), 0)
        kw = {"epsilon": 2.0} if kernel in SHAPED else {}
        r = dk.RBF(controls, kernel=kernel, **kw)
        assert r.degree == scipy_default, kernel
        assert r.smoothing == signature.parameters["smoothing"].default
        if kernel in _rbfinterp._SCALE_INVARIANT:
            # scipy: epsilon defaults to 1 for these kernels, and is required for the others.
            assert r.epsilon == 1.0
        else:
            with pytest.raises(ValueError):
                RBFInterpolator(controls, controls, kernel=kernel)
            with pytest.raises(ValueError, match="^epsilon:"):
                dk.RBF(controls, kernel=kernel)

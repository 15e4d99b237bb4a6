"""ARAP's Anderson acceleration (SurfaceDeformer(anderson=m)) and the drag predictor
(dk.extrapolated_start). Checked against ARAP run to convergence (the same fixed point), the
energy's monotone decrease (the safeguard), numpy's formula for the predictor, and the iteration
counts of a small-step drag."""
import numpy as np
import pytest

import deformkit as dk
from test_arap_warm_start import capsule, drag


def test_anderson_reaches_the_plain_iterations_fixed_point_monotonically():
    v, f, anchors, handles = capsule()
    targets = drag(v, handles, 30)
    plain = dk.SurfaceDeformer(v, f, anchors=anchors, handles=handles, iterations=5000, tolerance=1e-15)
    converged = plain.deform(targets)
    fast = dk.SurfaceDeformer(v, f, anchors=anchors, handles=handles, iterations=5000, tolerance=1e-15, anderson=5)
    x = fast.deform(targets)
    assert np.abs(x - converged).max() < 1e-6 * np.ptp(v)
    e = np.array(fast.energy)
    assert (np.diff(e) <= 1e-12 * e[0]).all()  # a mixed step that would raise the energy is refused
    assert len(fast.energy) < 0.5 * len(plain.energy), (len(fast.energy), len(plain.energy))
    assert abs(e[-1] - plain.energy[-1]) < 1e-9 * e[-1]


def test_anderson_is_nearer_convergence_after_the_same_iterations():
    """Measured on this capsule: the largest error 0.70 of the plain one's after 10 iterations,
    0.04 after 20, 0.018 after 30 (the window needs a few steps to fill)."""
    v, f, anchors, handles = capsule()
    targets = drag(v, handles, 30)
    truth = dk.SurfaceDeformer(v, f, anchors=anchors, handles=handles, iterations=5000, tolerance=1e-15).deform(targets)
    for k, ratio in ((10, 0.9), (20, 0.2), (30, 0.1)):
        plain = dk.SurfaceDeformer(v, f, anchors=anchors, handles=handles, iterations=k).deform(targets)
        fast = dk.SurfaceDeformer(v, f, anchors=anchors, handles=handles, iterations=k, anderson=5).deform(targets)
        assert np.abs(fast - truth).max() < ratio * np.abs(plain - truth).max(), k


def test_anderson_zero_is_the_plain_alternation_bit_for_bit():
    v, f, anchors, handles = capsule()
    targets = drag(v, handles, 10)
    a = dk.SurfaceDeformer(v, f, anchors=anchors, handles=handles, iterations=7)
    b = dk.SurfaceDeformer(v, f, anchors=anchors, handles=handles, iterations=7, anderson=0)
    assert np.array_equal(a.deform(targets), b.deform(targets)) and a.energy == b.energy


def test_extrapolated_start_is_the_projected_step():
    rng = np.random.default_rng(5)
    previous, earlier = rng.normal(size=(40, 3)), rng.normal(size=(40, 3))
    t0 = rng.normal(size=(4, 3))
    last_step = rng.normal(size=(4, 3))
    cases = {  # the present step -> the s numpy's projection gives, clipped to [0, 2]
        "along, half as far": (0.5 * last_step, 0.5),
        "along, three times as far": (3 * last_step, 2.0),
        "back": (-last_step, 0.0),
    }
    for name, (step, s) in cases.items():
        got = dk.extrapolated_start(previous, earlier, t0 + last_step + step, t0 + last_step, t0)
        np.testing.assert_allclose(got, previous + s * (previous - earlier), rtol=0, atol=1e-14, err_msg=name)
    across = np.cross(last_step, [0, 0, 1])  # orthogonal per row, so the projection is partly along
    s = np.vdot(across, last_step) / np.vdot(last_step, last_step)
    got = dk.extrapolated_start(previous, earlier, t0 + last_step + across, t0 + last_step, t0)
    np.testing.assert_allclose(got, previous + np.clip(s, 0, 2) * (previous - earlier), atol=1e-14)
    still = dk.extrapolated_start(previous, earlier, t0 + last_step, t0, t0)  # stood still last step
    assert np.array_equal(still, previous)
    x = previous.copy()
    dk.extrapolated_start(x, earlier, t0 + last_step, t0, t0)
    assert np.array_equal(x, previous)  # inputs are not modified


def test_a_drag_from_the_extrapolated_start_needs_fewer_iterations_and_lands_nearer():
    """60 steps of 1.5 degrees at tolerance 1e-3 on the capsule (2,562 vertices)."""
    v, f, anchors, handles = capsule()
    steps = [drag(v, handles, k) for k in range(61)]
    runs = {}
    for name, extrapolate in (("previous", False), ("extrapolated", True)):
        arap = dk.SurfaceDeformer(v, f, anchors=anchors, handles=handles, iterations=100, tolerance=1e-3)
        results, its = [v, v], []
        for k in range(1, 61):
            guess = results[-1]
            if extrapolate and k >= 2:
                guess = dk.extrapolated_start(results[-1], results[-2], steps[k], steps[k - 1], steps[k - 2])
            results = [results[-1], arap.deform(steps[k], initial=guess)]
            its.append(len(arap.energy))
        runs[name] = (np.mean(its), results[-1])
    truth = dk.SurfaceDeformer(v, f, anchors=anchors, handles=handles, iterations=5000,
                               tolerance=1e-15).deform(steps[60], initial=runs["extrapolated"][1])
    assert runs["extrapolated"][0] < 0.8 * runs["previous"][0], runs
    assert np.abs(runs["extrapolated"][1] - truth).max() < np.abs(runs["previous"][1] - truth).max()


def test_bad_settings_and_shapes_name_their_argument():
    v, f, anchors, handles = capsule()
    for bad in (-1, 51):
        with pytest.raises(ValueError, match="^anderson: "):
            dk.SurfaceDeformer(v, f, anchors=anchors, handles=handles, anderson=bad)
    t = v[handles]
    with pytest.raises(ValueError, match=r"^earlier: expected shape \(%d, 3\), like previous" % len(v)):
        dk.extrapolated_start(v, v[:5], t, t, t)
    with pytest.raises(ValueError, match=r"^earlier_targets: expected shape \(%d, 3\), like targets" % len(t)):
        dk.extrapolated_start(v, v, t, t, t[:2])
    bad = v.copy()
    bad[7, 2] = np.inf
    with pytest.raises(ValueError, match="^earlier: row 7 is not finite"):
        dk.extrapolated_start(v, bad, t, t, t)
    with pytest.raises(ValueError, match="^previous: row 0 extrapolated overflows"):
        dk.extrapolated_start(np.full((3, 3), 1e308), np.full((3, 3), -1e308), t + 2, t + 1, t)
    with pytest.raises(TypeError, match="^targets: expected float32 or float64, got int64"):
        dk.extrapolated_start(v, v, t.astype(np.int64), t, t)

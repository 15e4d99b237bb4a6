"""ARAP at any scale (docs/math/surface.md, "At any scale"): scaling the mesh and the targets by
2^k changes no bit of the result and scales each recorded energy by 4^k exactly, plain or
Anderson-accelerated, hard or soft; the energy is finite whenever deform returns, equals the
documented energy (a numpy evaluation) on a mesh at 1e150, and where it would pass the double
range deform refuses instead of recording inf."""
import numpy as np
import pytest

import deformkit as dk
from support.helpers import arap_energy, cot_weights, local_rotations
from test_surface_deformer import bend_case


@pytest.fixture(scope="module")
def case():
    return bend_case("tube")


@pytest.mark.parametrize("options", [{}, {"anderson": 3}, {"constraint_weight": 10.0}])
@pytest.mark.parametrize("k", [-900, -600, -300, -40, 7, 300, 480, 505, 512, 530])
def test_scaling_by_a_power_of_two_changes_no_bit(case, k, options):
    pts, tris, anchors, handles, targets = case
    ed = dk.SurfaceDeformer(pts, tris, anchors=anchors, handles=handles, iterations=5, **options)
    out, energy = ed.deform(targets), np.array(ed.energy)
    scaled = dk.SurfaceDeformer(np.ldexp(pts, k), tris, anchors=anchors, handles=handles, iterations=5, **options)
    if np.log2(energy.max()) + 2 * k >= 1024:  # past the largest double, 2^1024 (1 - 2^-53)
        with pytest.raises(ValueError, match=r"^points: the ARAP energy of the result, about 10\^3\d\d\.\d, is beyond a double"):
            scaled.deform(np.ldexp(targets, k))
        return
    np.testing.assert_array_equal(scaled.deform(np.ldexp(targets, k)), np.ldexp(out, k))
    np.testing.assert_array_equal(scaled.energy, np.ldexp(energy, 2 * k))


@pytest.mark.parametrize("scale", [1e150, 1e-150])
def test_the_energy_at_extreme_scales_is_the_documented_energy(scale):
    """B.7's E at x_k with the rotations of x_{k-1} (k + 1 iterations), in numpy on the mesh brought
    back to size 1, times scale^2."""
    pts, tris, anchors, handles, targets = bend_case("tube")
    w = cot_weights(pts, tris)
    runs = [dk.SurfaceDeformer(pts * scale, tris, anchors=anchors, handles=handles, iterations=i) for i in (1, 2, 3)]
    outs = [r.deform(targets * scale) / scale for r in runs]
    energies = runs[-1].energy
    assert np.isfinite(energies).all() and min(energies) > 0
    for i in (1, 2):
        ours = arap_energy(w, pts, outs[i], local_rotations(w, pts, outs[i - 1])) * scale ** 2
        assert abs(energies[i] - ours) <= 1e-9 * ours, (i, energies[i], ours)


def test_a_mesh_at_1e154_gets_a_finite_energy_or_a_refusal():
    """The issue's case: the energy of a mesh at 1e154 was inf while deform returned positions."""
    pts, tris, anchors, handles, targets = bend_case("tube")
    for scale in (1e153, 1e154, 3e154):
        ed = dk.SurfaceDeformer(pts * scale, tris, anchors=anchors, handles=handles, iterations=5)
        try:
            out = ed.deform(targets * scale)
        except ValueError as e:
            assert str(e).startswith("points: the ARAP energy of the result"), str(e)
            continue
        assert np.isfinite(out).all() and np.isfinite(ed.energy).all(), (scale, ed.energy)

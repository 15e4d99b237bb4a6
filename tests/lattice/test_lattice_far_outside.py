"""Extrapolating lattices far outside (docs/lattice.md, "Far outside"): a point whose weights'
magnitudes sum past 1e6 is refused on every path, naming `points`; every other point is evaluated
to 1e-9 of the lattice's size, against the polynomials evaluated exactly in rational arithmetic,
and its volume ratio is det(jacobian)."""
from fractions import Fraction
from math import comb

import numpy as np
import pytest

import deformkit as dk

LIMIT = 1e6  # docs/lattice.md, "Far outside"
ORIGIN = (-0.5, 0.25, 1.0)  # and edges diag(EDGES): powers of two, so lattice coordinates are exact
EDGES = (2.0, 1.0, 0.5)
SIZE = max(EDGES)


def bernstein_exact(d, t):
    return [comb(d, i) * t ** i * (1 - t) ** (d - i) for i in range(d + 1)]


def piece_of(g, pieces):
    """The end pieces continue outside: piece 0 below, the last above."""
    return 0 if g <= 0 else pieces - 1 if g >= pieces - 1 else int(g)


# Per axis, for a lattice coordinate s (a Fraction): [(control index, exact weight)], from the
# published formulas: Sederberg-Parry's Bernstein polynomial, cubic Bezier blocks, the uniform cubic
# B-spline on the box's inner part (rest control points span the box).
def ffd_axis(count):
    return lambda s: list(enumerate(bernstein_exact(count - 1, s)))


def bezier_axis(count):
    blocks = (count - 1) // 3

    def weights(s):
        g = s * blocks
        p = piece_of(g, blocks)
        return [(3 * p + i, w) for i, w in enumerate(bernstein_exact(3, g - p))]
    return weights


def bspline_axis(count):
    def weights(s):
        g = s * (count - 1) - 1  # (s - 1/(n-1)) / ((n-3)/(n-1)) * (n-3)
        p = piece_of(g, count - 3)
        t = g - p
        w = [(1 - t) ** 3 / 6, (3 * t ** 3 - 6 * t ** 2 + 4) / 6, (-3 * t ** 3 + 3 * t ** 2 + 3 * t + 1) / 6, t ** 3 / 6]
        return [(p + i, v) for i, v in enumerate(w)]
    return weights


def lattice_coordinates(x):
    return [(Fraction(float(x[a])) - Fraction(ORIGIN[a])) / Fraction(EDGES[a]) for a in range(3)]


def exact(axes, counts, control, x):
    """F(x) = x + sum w_ijk (P_ijk - R_ijk) in rational arithmetic, with R the box's grid, and the
    sum of |w_ijk| (the product over axes of sum |w_axis|)."""
    s = lattice_coordinates(x)
    per_axis = [axes[a](s[a]) for a in range(3)]
    out = [Fraction(float(v)) for v in x]
    for i, wi in per_axis[0]:
        for j, wj in per_axis[1]:
            for k, wk in per_axis[2]:
                w = wi * wj * wk
                for a, idx in enumerate((i, j, k)):
                    rest = Fraction(ORIGIN[a]) + Fraction(EDGES[a]) * Fraction(idx, counts[a] - 1)
                    out[a] += w * (Fraction(float(control[i, j, k, a])) - rest)
    gain = 1
    for weights in per_axis:
        gain *= sum(abs(w) for _, w in weights)
    return out, gain


LATTICES = {  # name: (make, counts, per-axis exact weights)
    "FFD(2)": (lambda **kw: dk.FFD(2, **kw), (3, 3, 3), [ffd_axis(3)] * 3),
    "FFD(1,2,3)": (lambda **kw: dk.FFD((1, 2, 3), **kw), (2, 3, 4), [ffd_axis(n) for n in (2, 3, 4)]),
    "BezierFFD(1)": (lambda **kw: dk.BezierFFD(1, **kw), (4, 4, 4), [bezier_axis(4)] * 3),
    "BezierFFD(2,1,2)": (lambda **kw: dk.BezierFFD((2, 1, 2), **kw), (7, 4, 7), [bezier_axis(n) for n in (7, 4, 7)]),
    "BSplineLattice(4)": (lambda **kw: dk.BSplineLattice(4, **kw), (4, 4, 4), [bspline_axis(4)] * 3),
    "BSplineLattice(7,9,8)": (lambda **kw: dk.BSplineLattice((7, 9, 8), **kw), (7, 9, 8),
                              [bspline_axis(n) for n in (7, 9, 8)]),
    # More cells than the lanes sort by counting: bind, deform and the derivatives go per point.
    "BSplineLattice(26,26,26)": (lambda **kw: dk.BSplineLattice(26, **kw), (26, 26, 26), [bspline_axis(26)] * 3),
}


def moved(name, seed):
    make, counts, _ = LATTICES[name]
    lat = make(origin=ORIGIN, edges=np.diag(EDGES), outside="extrapolate")
    rng = np.random.default_rng(seed)
    spacing = np.array(EDGES) / (np.array(counts) - 1)
    lat.control_points = lat.rest_control_points + 0.2 * spacing * rng.uniform(-1, 1, (*counts, 3))
    return lat


def sample_points(seed, n=120):
    """From inside the box to 1e6 box sizes out, in random directions and along single axes (where
    the Jacobian's columns grow unevenly)."""
    rng = np.random.default_rng(seed)
    centre = np.array(ORIGIN) + 0.5 * np.array(EDGES)
    direction = rng.normal(size=(n, 3))
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    direction[: n // 4] = np.eye(3)[rng.integers(0, 3, n // 4)] * rng.choice([-1.0, 1.0], (n // 4, 1))
    radius = SIZE * 10.0 ** rng.uniform(-2, 6, n)
    return centre + radius[:, None] * direction


def split(name, lat, points):
    """Points the contract accepts (exact sum |w| at most the limit) with their exact images, and
    the points it refuses; points within 1e-9 of the limit, where rounding decides, are left out."""
    _, counts, axes = LATTICES[name]
    control = lat.control_points
    accepted, images, refused = [], [], []
    for x in points:
        image, gain = exact(axes, counts, control, x)
        if abs(gain - LIMIT) <= 1e-9 * LIMIT:
            continue
        if gain <= LIMIT:
            accepted.append(x)
            images.append(image)
        else:
            refused.append(x)
    return np.array(accepted), images, np.array(refused)


def every_path(lat, p):
    normals = np.tile([0.0, 0.0, 1.0], (len(p), 1))
    return {
        "deform": lambda: lat.deform(p),
        "deform[float32]": lambda: lat.deform(p.astype(np.float32)),
        "displacement": lambda: lat.displacement(p),
        "bind": lambda: lat.bind(p),
        "lattice_coordinates": lambda: lat.lattice_coordinates(p),
        "jacobian": lambda: lat.jacobian(p),
        "transform_normals": lambda: lat.transform_normals(p, normals),
        "transform_normals[float32]": lambda: lat.transform_normals(p.astype(np.float32), normals.astype(np.float32)),
        "volume_ratio": lambda: lat.volume_ratio(p),
    }


@pytest.mark.parametrize("name", sorted(LATTICES))
def test_accepted_points_are_the_exact_polynomial_and_det_j(name):
    lat = moved(name, 1)
    accepted, images, refused = split(name, lat, sample_points(2))
    assert len(accepted) >= 20 and len(refused) >= 20, (len(accepted), len(refused))
    truth = np.array([[float(v) for v in image] for image in images])
    # Rounding in sum w (P - R) is at most about eps * sum|w| * max|P - R| <= 2.2e-10 * 0.2 spacing.
    for path, got in (("deform", lat.deform(accepted)), ("deform_bound", lat.deform_bound(lat.bind(accepted))),
                      ("displacement", accepted + lat.displacement(accepted))):
        error = np.abs(got - truth).max(axis=1)
        worst = int(np.argmax(error))
        assert error[worst] <= 1e-9 * SIZE, (name, path, accepted[worst], got[worst], truth[worst])
    jac = lat.jacobian(accepted)
    det = np.linalg.det(jac)
    ratio = lat.volume_ratio(accepted)
    worst = int(np.argmax(np.abs(ratio - det) / np.abs(det)))
    assert abs(ratio[worst] - det[worst]) <= 1e-9 * abs(det[worst]), (name, accepted[worst], ratio[worst], det[worst])
    normals = lat.transform_normals(accepted, np.tile([0.0, 0.0, 1.0], (len(accepted), 1)))
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-12)


@pytest.mark.parametrize("name", sorted(LATTICES))
def test_points_beyond_the_limit_are_refused_on_every_path_naming_them(name):
    lat = moved(name, 3)
    accepted, _, refused = split(name, lat, sample_points(4))
    for x in refused[:: max(1, len(refused) // 6)]:
        batch = np.array([accepted[0], x, accepted[1]])
        for path, call in every_path(lat, batch).items():
            with pytest.raises(ValueError) as e:
                call()
            message = str(e.value)
            assert message.startswith("points: row 1 ("), (name, path, message)
            assert "too far outside the lattice to extrapolate accurately" in message, (name, path, message)
            assert "limit 1e+06" in message, (name, path, message)
    # The accepted ones pass every path, whatever the dtype.
    for path, call in every_path(lat, accepted).items():
        assert np.isfinite(np.asarray(call() if path not in ("bind",) else call().parameters)).all(), path


@pytest.mark.parametrize("interpolation", ["linear", "cardinal", "catmull_rom", "bspline"])
def test_blender_lattices_never_extrapolate_and_accept_every_distance(interpolation):
    """Blender's index clamping keeps every weight within one cell's: nothing to refuse."""
    with pytest.raises(ValueError, match="^outside: "):
        dk.BlenderLattice(3, interpolation, outside="extrapolate")
    lat = dk.BlenderLattice((3, 4, 5), interpolation, origin=ORIGIN, edges=np.diag(EDGES))
    rng = np.random.default_rng(5)
    lat.control_points = lat.rest_control_points + 0.05 * rng.uniform(-1, 1, lat.control_points.shape)
    p = sample_points(6)
    for path, call in every_path(lat, p).items():
        out = call()
        assert np.isfinite(np.asarray(out.parameters if path == "bind" else out)).all(), path
    det = np.linalg.det(lat.jacobian(p))
    np.testing.assert_allclose(lat.volume_ratio(p), det, rtol=1e-12)

"""Every deformer class, listed from the module (a new class without a moved instance here fails
`test_every_deformer_class_is_covered`): NaN and Inf points are refused by name on every path
(deform, displacement, jacobian, transform_normals, volume_ratio, bind); points so far away that
some derivative is refused are refused by all three derivative methods alike, and wherever they are
not, transform_normals gives unit normals and volume_ratio det(jacobian).
See docs/errors.md, "Edge cases: transfer, surface and lattices"."""
import inspect
from fractions import Fraction

import numpy as np
import pytest

import deformkit as dk

CUBE = np.array([[x, y, z] for x in (-1.0, 1.0) for y in (-1.0, 1.0) for z in (-1.0, 1.0)])
CUBE_QUADS = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])


def moved(lattice, seed):
    """The lattice with its control points moved smoothly (coincident ones together)."""
    c = np.array(lattice.control_points)
    lattice.control_points = c + 0.15 * np.sin(2.0 * c[..., [1, 2, 0]] + seed)
    return lattice


def cages(kind):
    d = kind(1.2 * CUBE, CUBE_QUADS)
    d.cage_points = 1.2 * CUBE * [1.3, 0.9, 1.1] + 0.1
    return d


def rbf():
    rng = np.random.default_rng(3)
    controls = rng.uniform(-1, 1, (12, 3))
    return dk.RBF(controls, controls + 0.1 * rng.normal(size=(12, 3)))


def extended_ffd():
    prism = dk.ExtendedFFD.prism([[-1, -1, -1], [2, -1, -1], [-1, 2, -1]], [0, 0, 2.5])
    return moved(prism, 4)


# One moved (non-identity) instance per concrete class, made afresh for each test.
MOVED = {
    "Twist": lambda: dk.Twist(rate=0.7),
    "Taper": lambda: dk.Taper(rate=0.3),
    "Bend": lambda: dk.Bend(curvature=0.4),
    "Stretch": lambda: dk.Stretch(factor=0.5),
    "SimpleDeform": lambda: dk.SimpleDeform("STRETCH", factor=0.5),
    "BarrDeformer": lambda: dk.SimpleDeform("BEND", angle=0.8).bind(CUBE),
    "Stack": lambda: dk.Stack([dk.Twist(rate=0.5), dk.Bend(curvature=0.3)]),
    "FFD": lambda: moved(dk.FFD(2, origin=[-1, -1, -1], edges=np.diag([2.0, 2, 2])), 0),
    "BezierFFD": lambda: moved(dk.BezierFFD(1, origin=[-1, -1, -1], edges=np.diag([2.0, 2, 2])), 1),
    "BSplineLattice": lambda: moved(dk.BSplineLattice(5, origin=[-1, -1, -1], edges=np.diag([2.0, 2, 2])), 2),
    "BlenderLattice": lambda: moved(dk.BlenderLattice(3, origin=[-1, -1, -1], edges=np.diag([2.0, 2, 2])), 3),
    "ExtendedFFD": extended_ffd,
    "MeanValueCage": lambda: cages(dk.MeanValueCage),
    "GreenCage": lambda: cages(dk.GreenCage),
    "MeshDeform": lambda: cages(lambda p, f: dk.MeshDeform(p, f, precision=3)),
    "RBF": rbf,
}


def concrete_deformer_classes():
    classes = {n: c for n, c in vars(dk).items() if inspect.isclass(c) and issubclass(c, dk.Deformer)}
    bases = {b for c in classes.values() for b in c.__mro__[1:]}
    return sorted(n for n, c in classes.items() if c not in bases)


def test_every_deformer_class_is_covered():
    assert concrete_deformer_classes() == sorted(MOVED)


def test_every_moved_instance_moves_points():
    p = np.random.default_rng(5).uniform(-0.8, 0.8, (20, 3))
    for name, make in MOVED.items():
        assert np.abs(make().deform(p) - p).max() > 1e-3, name


# Extrapolating lattices refuse points too far out to evaluate accurately
# (docs/lattice.md, "Far outside") and are held to every rule below where they accept.
EXTRAPOLATING = {
    "FFD extrapolating": lambda: moved(dk.FFD(2, origin=[-1, -1, -1], edges=np.diag([2.0, 2, 2]), outside="extrapolate"), 0),
    "BSplineLattice extrapolating": lambda: moved(dk.BSplineLattice(5, origin=[-1, -1, -1], edges=np.diag([2.0, 2, 2]),
                                                                    outside="extrapolate"), 2),
}
EVERY = {**MOVED, **EXTRAPOLATING}


def methods(d):
    """Every call that takes points, with the dtypes it takes."""
    n = np.tile([[0.0, 0.0, 1.0]], (3, 1))
    calls = {}
    for dtype in (np.float64, np.float32):
        calls[f"deform[{dtype.__name__}]"] = lambda p, t=dtype: d.deform(p.astype(t))
        calls[f"displacement[{dtype.__name__}]"] = lambda p, t=dtype: d.displacement(p.astype(t))
        calls[f"transform_normals[{dtype.__name__}]"] = lambda p, t=dtype: d.transform_normals(p.astype(t), n.astype(t))
        if hasattr(d, "bind"):
            calls[f"bind[{dtype.__name__}]"] = lambda p, t=dtype: d.bind(p.astype(t))
    calls["jacobian"] = d.jacobian
    calls["volume_ratio"] = d.volume_ratio
    return calls


NOT_FINITE = [(np.nan, 0), (np.inf, 1), (-np.inf, 2), (np.nan, 2)]


@pytest.mark.parametrize("bad, axis", NOT_FINITE)
@pytest.mark.parametrize("name", sorted(EVERY))
def test_non_finite_points_are_refused_by_name_on_every_path(name, bad, axis):
    d = EVERY[name]()
    p = np.array([[0.1, 0.2, 0.3], [0.2, -0.1, 0.4], [-0.3, 0.1, 0.2]])
    p[1, axis] = bad
    for call, f in methods(d).items():
        try:
            f(p)
        except ValueError as e:
            assert str(e).startswith("points: row 1 is not finite ("), (call, str(e))
        else:
            pytest.fail(f"{name}.{call} accepted a non-finite point")


def far_points(seed):
    """Points from the lattice's scale to the edge of the double range, in every direction."""
    rng = np.random.default_rng(seed)
    direction = rng.normal(size=(64, 3))
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    scale = 10.0 ** rng.uniform(-1, 307, 64)
    scale[:8] = [1e200, 1e154, 1e100, 1e300, 3e307, 1e40, 1e20, 1e160]
    return direction * scale[:, None]


def outcome(f, p):
    try:
        return f(p)
    except ValueError as e:
        return e


def exact_determinant(j):
    m = [[Fraction(float(v)) for v in row] for row in j]
    return (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
            m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))


def exact_cofactor_times(j, n):
    """cof(J) n = (J_1 x J_2, J_2 x J_0, J_0 x J_1) . n (columns J_k), exactly, as Fractions."""
    c = [[Fraction(float(j[r, k])) for r in range(3)] for k in range(3)]
    m = [Fraction(float(v)) for v in n]

    def cross(a, b):
        return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    rows = [cross(c[1], c[2]), cross(c[2], c[0]), cross(c[0], c[1])]  # rows of cof(J)^T
    return [sum(rows[k][r] * m[k] for k in range(3)) for r in range(3)]


@pytest.mark.parametrize("name", sorted(EVERY))
def test_derivatives_refuse_alike_and_otherwise_give_unit_normals_and_det_j(name):
    """transform_normals refuses exactly where jacobian does, with its message; volume_ratio too, and
    where det J itself is beyond the double range. Otherwise the normal is cof(J) n normalised and
    the ratio det J, both against exact arithmetic on the J jacobian() returned, to a tolerance
    from their conditioning."""
    d = EVERY[name]()
    normals = np.random.default_rng(7).normal(size=(64, 3))
    for i, x in enumerate(far_points(8)):
        x, n = x[None], normals[i:i + 1]
        jac, ratio, turned = (outcome(f, x) for f in (d.jacobian, d.volume_ratio, lambda q: d.transform_normals(q, n)))
        if isinstance(jac, ValueError):
            assert str(turned) == str(jac) and str(ratio) == str(jac), (name, x, jac, ratio, turned)
            continue
        j = jac[0]
        biggest = np.abs(j).max(axis=0)
        norms = biggest * np.linalg.norm(j / biggest, axis=0)  # without squaring 1e200
        assert not isinstance(turned, ValueError), (name, x, j, turned)
        assert abs(np.linalg.norm(turned) - 1) < 1e-12, (name, x, turned, j)
        # The direction of cof(J) n in exact arithmetic on the J that jacobian() returned, against a
        # tolerance from its conditioning: each cofactor entry rounds by about eps |J|^2.
        exact = exact_cofactor_times(j, n[0])
        size = max(abs(v) for v in exact)
        if size > 0:
            direction = np.array([float(v / size) for v in exact])
            direction /= np.linalg.norm(direction)
            scale = Fraction(float(np.abs(j).max())) ** 2 * Fraction(float(np.abs(n).max()))
            condition = float(scale / size)
            if condition < 1e8:
                assert np.linalg.norm(turned[0] - direction) < 1e-14 * max(condition, 1.0), (name, x, turned, j)
        # det J, exactly, on the J jacobian() returned; where rounding J's entries (eps |J_k| each)
        # could move it by more than 1e-8 of itself, only Hadamard's bound |det| <= prod |J_k| holds.
        det = exact_determinant(j)
        log_hadamard = np.log(norms).sum()
        largest = Fraction(np.finfo(float).max)
        log_condition = np.inf
        if det != 0:
            log_condition = log_hadamard - (np.log(float(abs(det) / largest)) + np.log(float(largest)))
        condition = np.exp(min(log_condition, 700.0))
        if log_condition > np.log(1e8):
            assert isinstance(ratio, ValueError) or ratio[0] == 0 or np.log(abs(ratio[0])) <= log_hadamard + np.log(2.0), \
                (name, x, j, ratio)
        elif abs(det) > largest * (1 + Fraction(1, 10**6)):
            assert isinstance(ratio, ValueError), (name, x, j, ratio)
        elif abs(det) < largest * (1 - Fraction(1, 10**6)):
            assert not isinstance(ratio, ValueError), (name, x, j, ratio)
            assert abs(Fraction(float(ratio[0])) - det) <= Fraction(1e-14 * max(condition, 1.0)) * abs(det), (name, x, j, ratio)


@pytest.mark.parametrize("name", sorted(EVERY))
def test_derivatives_of_many_rows_refuse_alike_where_one_row_does(name):
    """The SIMD lanes take rows in blocks: 64 far points at once are refused by all three methods
    with jacobian's message (naming the first refused row), else each row is what it is alone."""
    d = EVERY[name]()
    p = far_points(9)
    n = np.random.default_rng(10).normal(size=p.shape)
    jac, ratio, turned = (outcome(f, p) for f in (d.jacobian, d.volume_ratio, lambda q: d.transform_normals(q, n)))
    alone = [outcome(d.jacobian, p[i:i + 1]) for i in range(len(p))]
    refused = [i for i, a in enumerate(alone) if isinstance(a, ValueError)]
    if refused:
        assert isinstance(jac, ValueError) and str(jac).startswith(f"points: row {refused[0]} ") or \
            str(jac).startswith(f"{name}: row {refused[0]} "), (name, jac, refused)
        assert str(turned) == str(jac), (name, turned, jac)
        return
    assert not isinstance(turned, ValueError), (name, turned)
    assert np.isfinite(turned).all() and np.allclose(np.linalg.norm(turned, axis=1), 1, rtol=0, atol=1e-12)
    for i in range(len(p)):
        np.testing.assert_array_equal(jac[i], alone[i][0])
        np.testing.assert_allclose(turned[i], d.transform_normals(p[i:i + 1], n[i:i + 1])[0], rtol=0, atol=1e-12)

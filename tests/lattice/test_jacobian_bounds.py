"""Certified bounds of det J, the fold certificate and the exact deformed volume of the box lattices
(docs/lattice.md and docs/math/lattice.md, "Certified volume-ratio bounds"), against independent
truths: volume_ratio sampled on grids and refitted exactly (a polynomial of degree D is determined
by D + 1 samples per axis), dense sampling plus local minimisation, the divergence-theorem volume
of the finely tessellated deformed boundary, and Gauss quadrature of volume_ratio."""
import numpy as np
import pytest
from scipy.optimize import minimize

import deformkit as dk
from support.helpers import bernstein, box_surface, gauss_box, mesh_volume

ORIGIN = np.array([0.3, -0.2, 0.5])
EDGES = np.array([[1.5, 0.2, -0.1], [0.3, 1.1, 0.2], [-0.2, 0.4, 0.9]])  # rows S, T, U
PLACE = dict(origin=ORIGIN, edges=EDGES)
INTERPOLATIONS = ["linear", "cardinal", "catmull_rom", "bspline"]

# Every box lattice kind, every Blender interpolation, mixed ones and an axis of one point.
KINDS = {
    "ffd-3": lambda **k: dk.FFD(3, **PLACE, **k),
    "ffd-213": lambda **k: dk.FFD((2, 1, 3), **PLACE, **k),
    "bezier-211": lambda **k: dk.BezierFFD((2, 1, 1), **PLACE, **k),
    "bspline-546": lambda **k: dk.BSplineLattice((5, 4, 6), **PLACE, **k),
    **{f"blender-{i}": (lambda i=i, **k: dk.BlenderLattice((3, 4, 2), i, **PLACE, **k)) for i in INTERPOLATIONS},
    "blender-mixed": lambda **k: dk.BlenderLattice((4, 3, 3), ("linear", "cardinal", "bspline"), **PLACE, **k),
    "blender-flat": lambda **k: dk.BlenderLattice((3, 1, 4), ("catmull_rom", "linear", "bspline"), **PLACE, **k),
}


def domain(lat):
    """The region in box coordinates s per axis: the spline's inner part for BSplineLattice."""
    if isinstance(lat, dk.BSplineLattice):
        n = np.array(lat.resolution, float)
        return 1 / (n - 1), (n - 2) / (n - 1)
    return np.zeros(3), np.ones(3)


def to_points(lat, cell, local):
    """World points of local coordinates (rows) in a cell of the region."""
    lo, hi = domain(lat)
    pieces = np.array(lat.cell_grid, float)
    s = lo + (np.asarray(cell, float) + np.asarray(local, float)) * (hi - lo) / pieces
    return ORIGIN + s @ EDGES


def inside_cell(local, by=1e-9):
    """Local coordinates moved toward the cell's centre: on a face the cell's own side (det J may
    jump across the faces of a C0 lattice: Blender's linear cells, Bezier blocks)."""
    local = np.asarray(local, float)
    return local + by * np.sign(0.5 - local)


def region_points(lat, n, rng, per_cell=5, with_cells=False):
    """About n random points of the region and a grid through every cell's corners, each moved
    1e-9 into its cell: det J of a C0 lattice may jump across cell faces, and Blender evaluates a
    point on the box's far face in the cell beyond it (docs/lattice.md), so each sample is
    taken on its own cell's side."""
    cells = list(np.ndindex(*lat.cell_grid))
    g = np.linspace(0, 1, per_cell + 1)
    grid = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    m = max(1, n // len(cells))
    pts, owner = [], []
    for c in cells:
        local = inside_cell(np.concatenate([grid, rng.uniform(0, 1, (m, 3))]))
        pts.append(to_points(lat, c, local))
        owner += [c] * len(local)
    return (np.concatenate(pts), owner) if with_cells else np.concatenate(pts)


def perturbed(kind, amount, seed, **k):
    lat = KINDS[kind](**k)
    rng = np.random.default_rng(seed)
    lat.control_points = lat.rest_control_points + rng.normal(0, amount, lat.rest_control_points.shape)
    return lat


def refined_extreme(lat, x0, cell, sign):
    """A local minimum (sign 1) or maximum (-1) of det J near x0, searched within its cell."""
    lo, hi = domain(lat)
    width = (hi - lo) / np.array(lat.cell_grid)
    box = [(lo[a] + (cell[a] + 1e-9) * width[a], lo[a] + (cell[a] + 1 - 1e-9) * width[a]) for a in range(3)]
    f = lambda s: sign * lat.volume_ratio((ORIGIN + s @ EDGES)[None])[0]
    s0 = np.clip((x0 - ORIGIN) @ np.linalg.inv(EDGES), [b[0] for b in box], [b[1] for b in box])
    r = minimize(f, s0, bounds=box, method="L-BFGS-B")
    return sign * min(r.fun, f(s0))


@pytest.mark.parametrize("kind", KINDS)
def test_coefficients_are_det_j_refitted_from_samples(kind):
    lat = perturbed(kind, 0.08, 1)
    rng = np.random.default_rng(2)
    for _ in range(2):
        cell = tuple(int(rng.integers(0, g)) for g in lat.cell_grid)
        coef = lat.volume_ratio_coefficients(cell)
        deg = np.array(coef.shape) - 1
        nodes = [np.linspace(0.05, 0.95, d + 1) for d in deg]
        grid = np.stack(np.meshgrid(*nodes, indexing="ij"), -1).reshape(-1, 3)
        samples = lat.volume_ratio(to_points(lat, cell, grid)).reshape(tuple(deg + 1))
        # Solve the tensor Bernstein interpolation axis by axis: samples = B0 (B1 (B2 c)).
        fit = samples
        for axis, (d, t) in enumerate(zip(deg, nodes)):
            basis = bernstein(d, t)  # (d+1 nodes, d+1 weights)
            fit = np.moveaxis(np.tensordot(np.linalg.inv(basis), np.moveaxis(fit, axis, 0), axes=1), 0, axis)
        np.testing.assert_allclose(coef, fit, atol=1e-8 * np.abs(fit).max())


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("amount", [0.02, 0.15, 0.35])
def test_bounds_enclose_every_sample_and_meet_the_tolerance(kind, amount):
    lat = perturbed(kind, amount, 3)
    rng = np.random.default_rng(4)
    tol = 1e-4
    b = lat.volume_ratio_bounds(tolerance=tol)
    assert b.converged
    x, owner = region_points(lat, 40000, rng, with_cells=True)
    v = lat.volume_ratio(x)
    slack = 1e-12 * b.scale
    assert b.lower - slack <= v.min() and v.max() <= b.upper + slack
    # minimum is a value of det J, at `where`.
    cell, local = b.where
    at = lat.volume_ratio(to_points(lat, cell, [inside_cell(local)]))[0]
    assert at == pytest.approx(b.minimum, abs=1e-6 * b.scale)
    assert b.lower <= b.minimum
    # Tolerance: lower within tol * scale of the true minimum (sampling refined by local search).
    true_min = min(refined_extreme(lat, x[np.argmin(v)], owner[np.argmin(v)], 1), b.minimum)
    true_max = refined_extreme(lat, x[np.argmax(v)], owner[np.argmax(v)], -1)
    assert true_min - tol * b.scale - 1e-9 <= b.lower <= true_min + 1e-9
    assert true_max - 1e-9 <= b.upper <= true_max + tol * b.scale + 1e-9


@pytest.mark.parametrize("kind", ["blender-linear", "blender-mixed", "blender-flat", "blender-cardinal"])
@pytest.mark.parametrize("amount", [0.02, 0.15])
def test_region_bounds_hold_on_blenders_faces(kind, amount):
    """Blender evaluates a point on the box's far face (s = 1), or one rounded just below s = 0,
    in the cell beyond the box, where a linear axis does not vary: det J jumps there (a C0 map),
    and the region's bounds cover that side of the faces too."""
    lat = perturbed(kind, amount, 3)
    b = lat.volume_ratio_bounds(tolerance=1e-4)
    g = np.linspace(0, 1, 41)
    faces = []
    for axis in range(3):
        for side in (-1e-15, 0.0, 1.0, 1.0 + 1e-15):
            s = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
            s[:, axis] = side
            faces.append(s)
    v = lat.volume_ratio(ORIGIN + np.concatenate(faces) @ EDGES)
    assert b.lower - 1e-12 * b.scale <= v.min() and v.max() <= b.upper + 1e-12 * b.scale
    assert bool(lat.fold_free()) <= bool(v.min() > 0)


@pytest.mark.parametrize("kind", ["ffd-3", "bezier-211", "bspline-546", "blender-linear", "blender-cardinal",
                                  "blender-mixed"])
def test_fold_free_is_never_true_where_sampling_finds_a_fold(kind):
    rng = np.random.default_rng(5)
    verdicts = set()
    for seed, amount in enumerate([0.03, 0.1, 0.2, 0.3, 0.4, 0.6]):
        lat = perturbed(kind, amount, 10 + seed)
        cert = lat.fold_free()
        v = lat.volume_ratio(region_points(lat, 30000, rng))
        if v.min() <= 0:
            assert not cert and cert.lower <= v.min() + 1e-12
        verdicts.add(bool(cert))
        if cert:
            assert cert.certified and cert.cells == [] and cert.lower > 0
            continue
        assert cert.cells and len(cert.folded) == len(cert.cells)
        for (cell, local, lower), folded in zip(cert.cells, cert.folded):
            assert lower <= 0
            if folded:  # the reported place folds
                assert lat.volume_ratio(to_points(lat, cell, [inside_cell(local)]))[0] <= 1e-6
    assert verdicts == {True, False}, "the sweep should hold both folded and unfolded lattices"


@pytest.mark.parametrize("c", [1 - 1e-4, 1 + 1e-4])
def test_a_nearly_folded_lattice_is_decided_and_located(c):
    """z' = z - 4c (z^2/2 - z^3/3) on the unit cube: det J = 1 - 4c z (1 - z), least (1 - c) at
    z = 1/2 inside the lattice, where the coefficients alone (down to 1 - 2c) cannot decide."""
    t = np.linspace(0, 1, 4)
    zmap = t - 4 * c * (t ** 2 / 2 - t ** 3 / 3)
    bz = np.linalg.solve(bernstein(3, t), zmap)  # Bernstein coefficients of the cubic z'(z)
    P = np.array([[[(i, j, bz[k]) for k in range(4)] for j in range(2)] for i in range(2)], float)
    lat = dk.FFD((1, 1, 3), control_points=P)
    b = lat.volume_ratio_bounds(tolerance=1e-6)
    assert b.converged and b.lower <= 1 - c <= b.lower + 1e-6 and b.upper == pytest.approx(1.0, abs=1e-6)
    assert b.where[1][2] == pytest.approx(0.5, abs=1e-2)
    cert = lat.fold_free()
    assert bool(cert) == (c < 1)
    if c > 1:
        (cell, local, lower), = cert.cells
        assert cert.folded == [True] and lower <= 1 - c
        assert lat.volume_ratio(np.array([local]))[0] <= 0


@pytest.mark.parametrize("kind", KINDS)
def test_rest_lattices_give_one_exactly_and_the_rest_volume(kind):
    lat = KINDS[kind]()
    lo, hi = domain(lat)
    rest = abs(np.linalg.det(EDGES)) * np.prod(hi - lo)
    b = lat.volume_ratio_bounds()
    assert (b.lower, b.upper) == (1.0, 1.0) and b.converged and b.minimum == 1.0
    assert lat.fold_free() and lat.fold_free().lower == 1.0
    assert lat.deformed_volume() == pytest.approx(rest, rel=1e-14)
    # A translation: P - R equal up to the rounding of the subtraction, so det J = 1 to rounding.
    moved = KINDS[kind](control_points=lat.rest_control_points + [0.3, -0.1, 0.2])
    b = moved.volume_ratio_bounds()
    assert b.lower <= 1.0 <= b.upper and b.upper - b.lower < 1e-11 and moved.fold_free()
    assert moved.deformed_volume() == pytest.approx(rest, rel=1e-13)


@pytest.mark.parametrize("degree", [8, 15])
def test_high_degree_rest_ffd_gives_one_exactly(degree):
    """det J of degree 3 * 15 - 1 = 44 per axis: its scaled coefficients (binomial products up to
    1e37) are no longer integers a double holds, yet a rest lattice is still exactly (1, 1)."""
    lat = dk.FFD(degree, **PLACE)
    assert tuple(lat.volume_ratio_bounds()) == (1.0, 1.0) and lat.fold_free().lower == 1.0
    assert lat.deformed_volume() == pytest.approx(abs(np.linalg.det(EDGES)), rel=1e-14)


def deformed_boundary_volume(lat, n):
    lo, hi = domain(lat)
    verts, faces = box_surface(n)
    x = ORIGIN + (lo + verts * (hi - lo)) @ EDGES
    sign = np.sign(np.linalg.det(EDGES))
    return sign * mesh_volume(lat.deform(x), faces)


@pytest.mark.parametrize("kind", ["ffd-3", "ffd-213", "bezier-211", "bspline-546", "blender-bspline",
                                  "blender-linear", "blender-cardinal", "blender-catmull_rom", "blender-mixed",
                                  "blender-flat"])
def test_exact_volume_matches_the_tessellated_boundary_and_quadrature(kind):
    lat = perturbed(kind, 0.06, 6)
    exact = lat.deformed_volume()
    # Divergence theorem on the deformed boundary: the error falls as h^2.
    errors = [abs(deformed_boundary_volume(lat, n) - exact) for n in (8, 16, 32)]
    assert errors[2] < 2e-3 * exact
    assert errors[1] / errors[2] > 3.0 and errors[0] / errors[1] > 3.0
    # Gauss-Legendre with k points per axis is exact for degree 2k - 1 >= 3n - 1 (n <= 3 per cell).
    lo, hi = domain(lat)
    breaks = [np.linspace(lo[a], hi[a], lat.cell_grid[a] + 1) for a in range(3)]
    s, w = gauss_box(breaks, order=5)
    quadrature = abs(np.linalg.det(EDGES)) * (w * lat.volume_ratio(ORIGIN + s @ EDGES)).sum()
    assert exact == pytest.approx(quadrature, rel=1e-12)


def test_points_limit_the_bounds_to_their_cells():
    lat = perturbed("bspline-546", 0.1, 7)
    whole = lat.volume_ratio_bounds(tolerance=1e-5)
    pts = to_points(lat, (1, 1, 2), [[0.2, 0.5, 0.5], [0.8, 0.1, 0.3]])
    b = lat.volume_ratio_bounds(tolerance=1e-5, points=pts)
    assert b.cells == 1
    assert whole.lower <= b.lower and b.upper <= whole.upper
    inside = to_points(lat, (1, 1, 2), np.random.default_rng(8).uniform(0, 1, (5000, 3)))
    v = lat.volume_ratio(inside)
    assert b.lower <= v.min() and v.max() <= b.upper
    assert bool(lat.fold_free(pts)) == (b.lower > 0)


@pytest.mark.parametrize("kind, outside", [("ffd-3", "clamp"), ("bspline-546", "clamp"), ("ffd-213", "extrapolate"),
                                           ("bspline-546", "extrapolate"), ("blender-cardinal", "clamp"),
                                           ("blender-mixed", "clamp"), ("bezier-211", "unchanged")])
def test_points_outside_the_domain_follow_the_outside_policy(kind, outside):
    lat = perturbed(kind, 0.08, 9, outside=outside)
    lo, hi = domain(lat)
    rng = np.random.default_rng(10)
    s = rng.uniform(lo - 0.3 * (hi - lo), hi + 0.3 * (hi - lo), (3000, 3))
    x = ORIGIN + s @ EDGES
    b = lat.volume_ratio_bounds(points=x)
    v = lat.volume_ratio(x)
    slack = 1e-12 * b.scale
    assert b.lower - slack <= v.min() and v.max() <= b.upper + slack
    if outside == "unchanged":
        assert b.lower <= 1.0 <= b.upper
        far = ORIGIN + np.array([[2.0, 2.0, 2.0]]) @ EDGES  # only the identity
        only = lat.volume_ratio_bounds(points=far)
        assert tuple(only) == (1.0, 1.0) and only.cells == 0 and only.where is None and lat.fold_free(far)


def test_the_result_unpacks_as_a_pair():
    lat = perturbed("ffd-3", 0.05, 11)
    b = lat.volume_ratio_bounds()
    lower, upper = b
    assert (lower, upper) == (b.lower, b.upper) == (b[0], b[1]) == (b[-2], b[-1]) == tuple(b)
    assert len(b) == 2 and lower < 1 < upper
    with pytest.raises(IndexError):
        b[2]
    assert "VolumeRatioBounds(lower=" in repr(b)


def test_cell_control_indices_are_the_points_that_move_the_cell():
    for kind in ("bspline-546", "blender-mixed", "bezier-211"):
        lat = perturbed(kind, 0.05, 12)
        cell = tuple(g // 2 for g in lat.cell_grid)
        before = lat.volume_ratio_coefficients(cell)
        listed = {tuple(i) for i in lat.cell_control_indices(cell)}
        for idx in np.ndindex(*lat.resolution):
            P = lat.control_points
            P[idx] += (0.05, -0.04, 0.03)
            moved = KINDS[kind](control_points=P)
            changed = not np.array_equal(moved.volume_ratio_coefficients(cell), before)
            assert changed == (idx in listed), (kind, idx)


def test_bad_inputs_are_named():
    lat = perturbed("ffd-3", 0.05, 13)
    for tol in (0.0, -1e-3, np.nan, np.inf):
        with pytest.raises(ValueError, match="^tolerance: "):
            lat.volume_ratio_bounds(tolerance=tol)
    for pts, msg in [(np.zeros(3), "points"), (np.zeros((2, 2)), "points"), (np.zeros((0, 3)), "points: is empty"),
                     (np.array([[0.1, np.nan, 0.2]]), "points: row 0 is not finite")]:
        for call in (lambda: lat.volume_ratio_bounds(points=pts), lambda: lat.fold_free(pts)):
            with pytest.raises(ValueError, match=f"^{msg}"):
                call()
    with pytest.raises(ValueError, match="^cell: index 1 along axis 0"):
        lat.volume_ratio_coefficients((1, 0, 0))
    with pytest.raises(ValueError, match="^cell: "):
        dk.BSplineLattice(5).cell_control_indices((0, 2, 9))
    far = dk.FFD(3, outside="extrapolate", control_points=lat.control_points, **PLACE)
    with pytest.raises(ValueError, match="^points: row 1 lies too far outside"):
        far.volume_ratio_bounds(points=np.array([[0.5, 0.5, 0.5], [1e4, 0.5, 0.5]]))


def test_strength_counts_and_per_point_weights_do_not():
    """The bounds are of volume_ratio with the lattice's strength and without per-point weights:
    strength 0 is the identity, a negative strength moves the other way (sampled), and weights
    leave the bounds as they are (docs/lattice.md)."""
    lat = perturbed("bspline-546", 0.1, 14)
    P = lat.control_points
    assert tuple(dk.BSplineLattice((5, 4, 6), **PLACE, control_points=P, strength=0.0).volume_ratio_bounds()) == (1, 1)
    neg = dk.BSplineLattice((5, 4, 6), **PLACE, control_points=P, strength=-0.7)
    b = neg.volume_ratio_bounds(tolerance=1e-5)
    v = neg.volume_ratio(region_points(neg, 20000, np.random.default_rng(15)))
    assert b.lower <= v.min() and b.upper >= v.max()
    cell, local = b.where
    at = neg.volume_ratio(to_points(neg, cell, [inside_cell(local)]))[0]
    assert at == pytest.approx(b.minimum, abs=1e-7) and b.minimum - 1e-5 * b.scale <= b.lower <= b.minimum
    weighted = dk.BSplineLattice((5, 4, 6), **PLACE, control_points=P, strength=-0.7, weights=np.full(4, 0.5))
    assert tuple(weighted.volume_ratio_bounds(tolerance=1e-5)) == tuple(b)


@pytest.mark.parametrize("kind", ["bezier-211", "bspline-546", "blender-linear"])
def test_a_tolerance_below_rounding_stops_unconverged_with_bounds_that_hold(kind):
    """1e-15 is below the coefficients' rounding allowance: the refinement stops (converged False,
    the cap's report) instead of halving pieces it cannot tighten, and the bounds still hold."""
    lat = perturbed(kind, 0.1, 16)
    b = lat.volume_ratio_bounds(tolerance=1e-15)
    assert not b.converged
    v = lat.volume_ratio(region_points(lat, 20000, np.random.default_rng(17)))
    assert b.lower <= v.min() and v.max() <= b.upper
    fine = lat.volume_ratio_bounds(tolerance=1e-6)
    assert fine.converged and abs(b.lower - fine.lower) <= 1e-6 * fine.scale
    assert abs(b.upper - fine.upper) <= 1e-6 * fine.scale

"""The Barr family through the Python module: exact Jacobians, normals, volumes, limits."""
import numpy as np
import pytest
import trimesh

import deformkit as dk
from support.helpers import fd_jacobian, random_frame


def deformers(rng):
    frame = random_frame(rng)
    return {
        "twist": dk.Twist(rate=1.3, axis="x", frame=frame),
        "twist_profile": dk.Twist(profile=([-1, 0, 0.5, 1], [0.2, -0.5, 0.9, 0.3]), axis="y"),
        "taper": dk.Taper(rate=0.4, limits=(-0.5, 0.8), frame=frame),
        "taper_profile": dk.Taper(profile=([-1, 1], [0.5, 1.5]), extend="linear", axis=1),
        "stretch": dk.Stretch(factor=0.3, limits=(-0.6, 0.6), axis="z", frame=frame),
        "bend": dk.Bend(curvature=0.9, center=0.1, region=(-0.4, 0.5), axis="z", frame=frame),
        "simple_deform": dk.SimpleDeform(mode="BEND", angle=1.2, deform_axis="Y", limits=(0.1, 0.9)),
        "stack": dk.Stack([dk.Twist(rate=0.8), dk.Bend(curvature=0.6, region=(-0.5, 0.5), frame=frame)]),
    }


@pytest.mark.parametrize("name", list(deformers(np.random.default_rng(0))))
def test_jacobian_matches_finite_differences(name, rng):
    d = deformers(np.random.default_rng(0))[name]
    pts = rng.uniform(-1, 1, (300, 3))
    if name == "simple_deform":
        # Blender measures the bounds from the input: two anchor rows fix them (limit axis z for a
        # Y bend) while the finite-difference stencil moves the other rows.
        anchors = np.array([[0.0, 0.0, -2.0], [0.0, 0.0, 2.0]])
        jac = d.jacobian(np.vstack([anchors, pts]))[2:]
        fd = fd_jacobian(lambda q: d.deform(np.vstack([anchors, q]))[2:], pts)
        np.testing.assert_allclose(jac, fd, atol=2e-6)
        return
    jac = d.jacobian(pts)
    assert jac.shape == (300, 3, 3) and jac.dtype == np.float64
    np.testing.assert_allclose(jac, fd_jacobian(d.deform, pts), atol=2e-6)


def test_jacobian_dtype_follows_points():
    pts = np.random.default_rng(1).uniform(-1, 1, (10, 3)).astype(np.float32)
    d = dk.Twist()
    assert d.jacobian(pts).dtype == np.float32
    assert d.volume_ratio(pts).dtype == np.float32
    assert d.transform_normals(pts, pts).dtype == np.float32


def facet_normal_error(d, subdivisions):
    sphere = trimesh.creation.icosphere(subdivisions=subdivisions)
    deformed = trimesh.Trimesh(d.deform(sphere.vertices), sphere.faces, process=False)
    predicted = d.transform_normals(sphere.triangles_center, sphere.face_normals)
    truth = deformed.face_normals
    angles = np.arctan2(np.linalg.norm(np.cross(predicted, truth), axis=1), np.einsum("ij,ij->i", predicted, truth))
    jac = d.jacobian(sphere.triangles_center)
    wrong = np.einsum("nij,nj->ni", jac, sphere.face_normals)  # J N: the transform for tangents, not normals
    wrong /= np.linalg.norm(wrong, axis=1)[:, None]
    wrong_angles = np.arccos(np.clip(np.einsum("ij,ij->i", wrong, truth), -1, 1))
    return angles.max(), wrong_angles.max()


# An unbounded bend: at the region ends Barr's bend has a genuine normal crease.
@pytest.mark.parametrize("d", [dk.Bend(curvature=0.8), dk.Twist(rate=1.5), dk.Taper(rate=0.5)], ids=["bend", "twist", "taper"])
def test_transformed_normals_match_the_deformed_mesh(d):
    """cof(J) N against face normals recomputed from the deformed mesh (an independent truth):
    the gap is the facets' discretisation, so it must halve as the edges halve."""
    coarse, _ = facet_normal_error(d, 4)
    fine, wrong = facet_normal_error(d, 5)
    assert fine < 0.05 and coarse / fine > 1.7, (coarse, fine)
    assert wrong > 5 * fine


def test_twist_preserves_enclosed_volume():
    sphere = trimesh.creation.icosphere(subdivisions=5)
    before = sphere.volume
    d = dk.Twist(rate=2.0)
    after = trimesh.Trimesh(d.deform(sphere.vertices), sphere.faces, process=False).volume
    assert abs(after / before - 1) < 2e-3  # det J = 1; the residual is the facet discretisation
    np.testing.assert_allclose(d.volume_ratio(sphere.vertices), 1.0, atol=1e-13)


def test_taper_volume_is_the_integral_of_r_squared():
    # Unit ball tapered by r = 1 + a z: V' = pi * (4/3 + 4 a^2 / 15).
    a = 0.5
    sphere = trimesh.creation.icosphere(subdivisions=5)
    exact_ball = sphere.volume / (4 / 3 * np.pi)  # facet loss of the ball itself
    tapered = trimesh.Trimesh(dk.Taper(rate=a).deform(sphere.vertices), sphere.faces, process=False).volume
    np.testing.assert_allclose(tapered, np.pi * (4 / 3 + 4 * a * a / 15) * exact_ball, rtol=2e-3)


def test_bend_is_continuous_across_region_ends(rng):
    d = dk.Bend(curvature=1.1, region=(-0.3, 0.4))
    for end in (-0.3, 0.4):
        pts = rng.uniform(-1, 1, (50, 3))
        below, above = pts.copy(), pts.copy()
        below[:, 1] = end - 1e-9
        above[:, 1] = end + 1e-9
        assert np.abs(d.deform(below) - d.deform(above)).max() < 1e-8


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_bend_tends_to_identity_as_curvature_vanishes(dtype, rng):
    pts = rng.uniform(-2, 2, (1000, 3)).astype(dtype)
    errors = []
    for k in (1e-2, 1e-4, 1e-8, 1e-15, 0.0):
        out = dk.Bend(curvature=k, region=(-1, 1)).deform(pts)
        assert np.isfinite(out).all()
        errors.append(np.abs(out.astype(np.float64) - pts).max())
    assert errors[0] > errors[1] > 0 and errors[-1] == 0.0
    assert errors[2] <= 1e-6  # O(k |x|^2), plus float32 rounding


def test_profile_passes_through_its_samples():
    z = np.array([-1.0, -0.2, 0.4, 1.0])
    theta = np.array([0.3, -0.6, 1.2, 0.1])
    d = dk.Twist(profile=(z, theta))
    pts = np.stack([np.ones_like(z), np.zeros_like(z), z], axis=1)
    out = d.deform(pts)
    np.testing.assert_allclose(np.arctan2(out[:, 1], out[:, 0]), theta, atol=1e-14)


def test_stack_composes_in_order(rng):
    a, b = dk.Twist(rate=0.9, axis="y"), dk.Bend(curvature=0.5, frame=random_frame(rng))
    pts = rng.uniform(-1, 1, (100, 3))
    np.testing.assert_allclose(dk.Stack([a, b]).deform(pts), b.deform(a.deform(pts)), atol=1e-14)
    np.testing.assert_allclose(dk.Stack([dk.Stack([a]), b]).deform(pts), b.deform(a.deform(pts)), atol=1e-14)
    assert len(dk.Stack([a, b])) == 2


def test_defaults_visibly_deform(rng):
    pts = rng.uniform(-1, 1, (100, 3))
    for cls in (dk.Twist, dk.Taper, dk.Bend, dk.Stretch, dk.SimpleDeform):
        assert np.abs(cls().deform(pts) - pts).max() > 0.1, cls.__name__


def test_weights_blend(rng):
    pts = rng.uniform(-1, 1, (20, 3))
    w = rng.uniform(0, 1, 20)
    full = dk.Twist().deform(pts)
    np.testing.assert_allclose(dk.Twist(weights=w).deform(pts), pts + w[:, None] * (full - pts), atol=1e-14)


def test_float32_and_float64_agree(rng):
    pts = rng.uniform(-1, 1, (10000, 3))
    for d in deformers(np.random.default_rng(0)).values():
        out32 = d.deform(pts.astype(np.float32))
        assert out32.dtype == np.float32
        np.testing.assert_allclose(out32, d.deform(pts), atol=5e-6)


def test_build_info_reports_runtime_simd():
    info = dk.build_info()
    assert info["simd_target"] and info["eigen"].startswith("3.4") and info["opensubdiv"].startswith("3.5")


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_displacement_is_deform_minus_points(dtype, rng):
    pts = rng.uniform(-1, 1, (5000, 3)).astype(dtype)
    d = dk.Stack([dk.Twist(weights=rng.uniform(0, 1, 5000)), dk.Bend()])
    disp = d.displacement(pts)
    assert disp.dtype == dtype
    np.testing.assert_allclose(disp, d.deform(pts) - pts, atol=1e-6 if dtype == np.float32 else 1e-15)
    out = np.empty_like(pts)
    assert d.displacement(pts, out=out) is out
    with pytest.raises(ValueError, match="out: displacement cannot be written over points"):
        d.displacement(pts, out=pts)


PLACED_FRAME = np.array([[0.8, -0.6, 0, 0.1], [0.6, 0.8, 0, 0.2], [0, 0, 1.5, 0.3], [0, 0, 0, 1]])


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("make", [lambda: dk.Twist(rate=1.3, limits=(-0.7, 0.8)), lambda: dk.Bend(curvature=0.9),
                                  lambda: dk.Taper(rate=0.4), lambda: dk.Stretch(factor=0.3),
                                  lambda: dk.Twist(rate=0.7, axis="x", frame=PLACED_FRAME),
                                  lambda: dk.SimpleDeform(mode="TWIST", angle=1.0)], ids=["twist", "bend", "taper", "stretch", "placed", "simple"])
def test_one_pass_displacement_is_the_offset_deform_adds(make, dtype, rng):
    """Barr's lanes write F(x) - x in one pass: points + displacement is deform bit for bit (what
    Blender's offsets attribute relies on), and the offset is F(x) - x to the rounding of x + it."""
    pts = rng.uniform(-1, 1, (100_003, 3)).astype(dtype)
    d = make()
    disp, moved = d.displacement(pts), d.deform(pts)
    np.testing.assert_array_equal(pts + disp, moved)
    ulp = np.spacing(np.maximum(np.abs(pts), np.abs(moved)))
    assert (np.abs(disp - (moved.astype(np.float64) - pts)) <= ulp).all()


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_multithreaded_results_match_the_formula(dtype, rng):
    """Large enough for both threads and every SIMD tail: against a plain numpy twist and bend."""
    n = 100_003
    pts = rng.uniform(-1, 1, (n, 3)).astype(dtype)
    x, y, z = (pts[:, i].astype(np.float64) for i in range(3))
    t = 1.3 * np.clip(z, -0.7, 0.8)
    twist = np.stack([x * np.cos(t) - y * np.sin(t), x * np.sin(t) + y * np.cos(t), z], axis=1)
    tol = 2e-6 if dtype == np.float32 else 1e-13
    np.testing.assert_allclose(dk.Twist(rate=1.3, limits=(-0.7, 0.8)).deform(pts), twist, atol=tol)
    k, yh = 0.9, np.clip(y, -0.5, 0.6)
    th = k * yh
    bend = np.stack([x, -np.sin(th) * (z - 1 / k) + np.cos(th) * (y - yh),
                     np.cos(th) * (z - 1 / k) + 1 / k + np.sin(th) * (y - yh)], axis=1)
    np.testing.assert_allclose(dk.Bend(curvature=k, region=(-0.5, 0.6)).deform(pts), bend, atol=tol)


@pytest.mark.parametrize("make", [lambda: dk.Twist(rate=1.7, limits=(-0.5, 0.9)), lambda: dk.Twist(rate=0.8, frame=PLACED_FRAME),
                                  lambda: dk.Twist(profile=([-1, 0, 1], [0, 2, -1])),
                                  lambda: dk.SimpleDeform(mode="TWIST", angle=2.0),
                                  lambda: dk.SimpleDeform(mode="TWIST", angle=2.0, lock_x=True)],
                         ids=["limits", "placed", "profile", "simple", "simple-lock-x"])
def test_twist_volume_ratio_is_det_of_its_jacobian(make, rng):
    """A twist keeps volume (det J = 1; with a locked axis it does not): against det of jacobian()."""
    pts = rng.uniform(-1, 1, (20_003, 3))
    d = make()
    np.testing.assert_allclose(d.volume_ratio(pts), np.linalg.det(d.jacobian(pts)), rtol=0, atol=1e-12)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("make", [lambda w: dk.SimpleDeform(mode="TWIST", angle=1.0, weights=w),
                                  lambda w: dk.SimpleDeform(mode="BEND", angle=0.8, deform_axis="Z", weights=w),
                                  lambda w: dk.Twist(rate=1.3, weights=w), lambda w: dk.Taper(rate=0.4, weights=w)],
                         ids=["simple-twist", "simple-bend", "twist", "taper"])
def test_weighted_displacement_is_the_blended_offset_in_one_pass(make, dtype, rng):
    """With weights the lanes write w (F(x) - x): deform's blend minus the points, to the rounding
    of the larger of the two; weight 1 gives the unweighted offset bit for bit, weight 0 nothing."""
    n = 100_003
    pts = rng.uniform(-1, 1, (n, 3)).astype(dtype)
    w = rng.uniform(0, 1, n)
    w[:1000], w[1000:2000] = 0.0, 1.0
    d = make(w)
    disp, moved = d.displacement(pts), d.deform(pts)
    ulp = np.spacing(np.maximum(np.abs(pts), np.abs(moved)).astype(dtype))
    assert (np.abs(disp - (moved.astype(np.float64) - pts)) <= 2 * ulp).all()
    assert not disp[:1000].any()
    np.testing.assert_array_equal(disp[1000:2000], make(np.ones(n)).displacement(pts)[1000:2000])


def test_replace_changes_settings_and_shares_the_weights(rng):
    """replace(...) is the SimpleDeform built afresh with those settings and the same weights."""
    pts = rng.uniform(-1, 1, (20_000, 3))
    w = rng.uniform(0, 1, len(pts))
    frame = np.array([[0.8, -0.6, 0, 0.1], [0.6, 0.8, 0, 0.2], [0, 0, 1.5, 0.3], [0, 0, 0, 1]])
    d = dk.SimpleDeform(mode="TWIST", angle=0.5, deform_axis="Z", weights=w)
    changes = dict(mode="TAPER", factor=0.7, deform_axis="Y", origin=frame, limits=(0.1, 0.8), lock_x=True)
    fresh = dk.SimpleDeform(**changes, weights=w)
    np.testing.assert_array_equal(d.replace(**changes).deform(pts), fresh.deform(pts))
    np.testing.assert_array_equal(d.replace(angle=0.9).deform(pts),
                                  dk.SimpleDeform(mode="TWIST", angle=0.9, deform_axis="Z", weights=w).deform(pts))
    np.testing.assert_array_equal(d.replace().deform(pts), d.deform(pts))
    np.testing.assert_array_equal(d.replace(angle=0.9).weights, d.weights)
    with pytest.raises(ValueError, match=r"weights: has 20000 entries but points has 10 rows"):
        d.replace(angle=0.9).deform(pts[:10])


@pytest.mark.parametrize("kwargs, error, message", [
    ({"angel": 1.0}, TypeError, r"unknown keyword argument 'angel'; did you mean 'angle'"),
    ({"angle": "x"}, TypeError, r"angle: expected a number, got 'x'"),
    ({"factor": float("nan")}, ValueError, r"factor: "),
    ({"angle": 1.0, "factor": 2.0}, ValueError, r"angle: give angle or factor"),
    ({"mode": "SPIN"}, ValueError, r"mode: .*'SPIN'"),
    ({"mode": 3}, TypeError, r"mode: expected 'TWIST', 'BEND', 'TAPER' or 'STRETCH', got 3"),
    ({"deform_axis": "W"}, ValueError, r"deform_axis: "),
    ({"limits": (0.6, 0.2)}, ValueError, r"limits: "),
    ({"origin": np.eye(3)}, ValueError, r"origin: "),
    ({"lock_y": 2}, TypeError, r"lock_y: expected True or False"),
])
def test_replace_names_the_bad_argument(kwargs, error, message):
    with pytest.raises(error, match=message):
        dk.SimpleDeform().replace(**kwargs)

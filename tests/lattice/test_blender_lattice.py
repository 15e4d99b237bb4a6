"""deformkit.BlenderLattice against Blender's own Lattice modifier, to float32 precision.

Two independent oracles, both Blender itself (see support/blender_oracle.py, started by
support/blender_runner.py):

* Blender 5.0 as the PyPI ``bpy`` module, imported lazily inside this process;
* Debian's Blender 3.4 binary (/usr/bin/blender), run once as a subprocess for all its cases.

A third, permanent cross-check is ``reference_lattice`` below: a small numpy transcription of the
per-vertex formula (docs/blender/lattice.md), built only from what each case *asked*
Blender to do. Blender must agree with it too, so a harness mistake (a lattice resized before it
had an object, a wrong point order, a matrix Blender did not take) fails on its own instead of
being copied into the deformkit comparison.

Tolerance: ``ATOL_REL`` = 1e-5 times the lattice size (the diagonal of the lattice box in the
mesh's space). Blender works in float32 throughout, and its largest error is the accumulation:
it adds the 64 weighted displacements one at a time onto the float32 coordinate itself, so each
addition may round by half an ulp of |x| (measured: up to ~12 ulp of |x|, a random walk over 64
terms). The matrices, the lattice coordinate (x - f) / d and the basis weights add well under
1e-6 of the size. Points here stay within ``MAX_EXTENT_REL`` = 3.5 lattice sizes of the mesh
origin, so Blender's error stays at or below ~2e-6 of the size (the measured maximum, in both
versions); 1e-5 leaves ~5x headroom, while a wrong basis, index or clamping rule moves points by
>= 1e-2 of the size (``MIN_MOVED_REL`` below makes sure every perturbed case really moves them
that much, so agreement is not trivial).
"""

from __future__ import annotations

import shutil
import zlib

import numpy as np
import pytest

import deformkit as dk
from support.helpers import euler_xyz, trs
from support.blender_runner import bpy_oracle, empty_scene, run_blender_binary, write_raw

ATOL_REL = 1e-5  # times the lattice size; see the module docstring
MIN_MOVED_REL = 1e-2  # a perturbed case must move points on average by this much of the lattice size
MAX_EXTENT_REL = 3.5  # |x| <= this many lattice sizes: keeps Blender's accumulation error inside ATOL_REL

LINEAR, CARDINAL, CATMULL_ROM, BSPLINE = "KEY_LINEAR", "KEY_CARDINAL", "KEY_CATMULL_ROM", "KEY_BSPLINE"
TYPES = (LINEAR, CARDINAL, CATMULL_ROM, BSPLINE)
SHORT = {LINEAR: "lin", CARDINAL: "card", CATMULL_ROM: "cr", BSPLINE: "bsp"}


# ---------------------------------------------------------------------------------------------
# Transforms and the lattice's rest grid


def apply(m, p):
    return np.asarray(p, dtype=np.float64) @ m[:3, :3].T + m[:3, 3]


def rest_grid_local(res):
    """Where Blender rests the control points, lattice-local, (nu, nv, nw, 3): evenly over
    [-0.5, 0.5] including the faces, and 0 on an axis of resolution 1."""
    axes = [np.linspace(-0.5, 0.5, n) if n > 1 else np.zeros(1) for n in res]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)


def to_blender_order(grid):
    """(nu, nv, nw, 3) -> (nu*nv*nw, 3) in Blender's point order (u fastest, then v, then w)."""
    return np.ascontiguousarray(np.asarray(grid).transpose(2, 1, 0, 3).reshape(-1, 3))


def from_blender_order(flat, res):
    nu, nv, nw = res
    return np.asarray(flat, dtype=np.float64).reshape(nw, nv, nu, 3).transpose(2, 1, 0, 3)


def box_size(frame):
    """Diagonal of the bounding box of the lattice box's 8 corners in the mesh's space."""
    corners = apply(frame, np.array(np.meshgrid(*[[-0.5, 0.5]] * 3, indexing="ij")).reshape(3, -1).T)
    return float(np.linalg.norm(corners.max(0) - corners.min(0)))


# ---------------------------------------------------------------------------------------------
# Independent reference: the per-vertex formula of docs/blender/lattice.md, in float64


def basis(t, kind):
    """The four weights for control points i-1, i, i+1, i+2 at fraction t in [0, 1)."""
    t2, t3 = t * t, t * t * t
    if kind == LINEAR:
        z = np.zeros_like(t)
        return np.stack([z, 1 - t, t, z], axis=-1)
    if kind in (CARDINAL, CATMULL_ROM):
        fc = 0.71 if kind == CARDINAL else 0.5
        return np.stack([-fc * t3 + 2 * fc * t2 - fc * t,
                         (2 - fc) * t3 + (fc - 3) * t2 + 1,
                         (fc - 2) * t3 + (3 - 2 * fc) * t2 + fc * t,
                         fc * t3 - fc * t2], axis=-1)
    if kind == BSPLINE:
        return np.stack([(1 - t) ** 3, 3 * t3 - 6 * t2 + 4, -3 * t3 + 3 * t2 + 3 * t + 1, t3], axis=-1) / 6
    raise ValueError(kind)


def axis_weights(x, n, kind):
    """Basis weights (m, 4) and clamped grid indices (m, 4) along one axis, x lattice-local."""
    if n == 1:  # Blender ignores the coordinate: the single layer carries full weight
        return np.tile([0.0, 1.0, 0.0, 0.0], (len(x), 1)), np.zeros((len(x), 4), dtype=np.int64)
    s = (x + 0.5) * (n - 1)
    i = np.floor(s)
    return basis(s - i, kind), np.clip(i.astype(np.int64)[:, None] + np.arange(-1, 3), 0, n - 1)


def reference_lattice(points, frame, res, kinds, co_local, strength, weights):
    """Blender's Lattice modifier, transcribed: points (n,3) in the mesh's space, frame maps
    lattice-local -> mesh-local, co_local the control points (nu,nv,nw,3) lattice-local,
    weights per point (already inverted if the modifier inverts) or None."""
    points = np.asarray(points, dtype=np.float64)
    local = apply(np.linalg.inv(frame), points)
    # Displacements are lattice-local vectors carried back by the 3x3 part only.
    disp = (np.asarray(co_local, dtype=np.float64) - rest_grid_local(res)) @ frame[:3, :3].T
    tu, iu = axis_weights(local[:, 0], res[0], kinds[0])
    tv, iv = axis_weights(local[:, 1], res[1], kinds[1])
    tw, iw = axis_weights(local[:, 2], res[2], kinds[2])
    acc = np.zeros_like(points)
    for a in range(4):
        for b in range(4):
            for c in range(4):
                acc += (tu[:, a] * tv[:, b] * tw[:, c])[:, None] * disp[iu[:, a], iv[:, b], iw[:, c]]
    w = np.full(len(points), float(strength)) if weights is None else float(strength) * np.asarray(weights, float)
    return points + w[:, None] * acc


# ---------------------------------------------------------------------------------------------
# Cases


LAT_M = trs(t=(0.4, -0.3, 0.2), euler=(0.5, -0.2, 0.9), s=(2.0, 1.3, 0.8))
LAT_M2 = trs(t=(2.5, -1.5, 0.7), euler=(-1.1, 0.3, 2.4), s=(0.6, 2.4, 1.5))
OBJ_M = trs(t=(-0.7, 0.5, 1.1), euler=(-0.3, 0.6, 0.2), s=(1.1, 0.9, 1.4))
OBJ_M2 = trs(t=(1.2, 2.0, -0.8), euler=(0.8, -0.4, -1.3), s=(0.7, 1.2, 1.0))


def case(cid, res, kinds, *, lattice=None, obj=None, perturb=0.12, strength=1.0, weights=False, invert=False,
         region="around"):
    """kinds: one interpolation type for all axes or a (u, v, w) tuple; perturb: standard deviation
    of the co_deform offsets (lattice-local, the box is 1 wide), 0 keeps Blender's own rest grid;
    region: 'around' (inside, near and far outside the box) or 'outside' (outside only)."""
    kinds = (kinds,) * 3 if isinstance(kinds, str) else tuple(kinds)
    return {"id": cid, "resolution": tuple(res), "interpolation": kinds, "lattice": lattice, "object": obj,
            "perturb": perturb, "strength": strength, "weights": weights, "invert": invert, "region": region}


CASES = [
    case("rest-bsp-2x2x2", (2, 2, 2), BSPLINE, perturb=0.0),
    case("rest-card-4x3x5-transformed", (4, 3, 5), CARDINAL, perturb=0.0, lattice=LAT_M, obj=OBJ_M),
    *[case(f"{SHORT[k]}-2x2x2", (2, 2, 2), k, perturb=0.2) for k in TYPES],
    *[case(f"{SHORT[k]}-4x3x5", (4, 3, 5), k) for k in TYPES],
    *[case(f"{SHORT[k]}-4x3x5-transformed", (4, 3, 5), k, lattice=LAT_M, obj=OBJ_M) for k in TYPES],
    case("mixed-lin-card-bsp-4x3x5", (4, 3, 5), (LINEAR, CARDINAL, BSPLINE)),
    case("mixed-cr-bsp-lin-5x4x3-transformed", (5, 4, 3), (CATMULL_ROM, BSPLINE, LINEAR), lattice=LAT_M2, obj=OBJ_M2),
    case("mixed-bsp-cr-card-3x6x2", (3, 6, 2), (BSPLINE, CATMULL_ROM, CARDINAL), lattice=LAT_M),
    case("res1-bsp-4x1x3", (4, 1, 3), BSPLINE),
    case("res1-card-1x3x2-transformed", (1, 3, 2), CARDINAL, lattice=LAT_M, obj=OBJ_M),
    case("res1-mixed-3x4x1", (3, 4, 1), (CATMULL_ROM, LINEAR, BSPLINE), obj=OBJ_M2),
    case("res1-1x1x1", (1, 1, 1), BSPLINE, perturb=0.3, lattice=LAT_M2),
    case("lattice-transform-only-bsp-4x4x4", (4, 4, 4), BSPLINE, lattice=LAT_M2),
    case("object-transform-only-card-3x3x3", (3, 3, 3), CARDINAL, obj=OBJ_M),
    case("outside-only-card-4x3x5-transformed", (4, 3, 5), CARDINAL, lattice=LAT_M, obj=OBJ_M, region="outside"),
    case("outside-only-bsp-2x3x2", (2, 3, 2), BSPLINE, region="outside"),
    case("strength-0.6-bsp-4x3x5", (4, 3, 5), BSPLINE, strength=0.6, lattice=LAT_M),
    case("strength-1.7-cr-3x3x4", (3, 3, 4), CATMULL_ROM, strength=1.7, obj=OBJ_M),
    case("strength-neg-lin-2x3x2", (2, 3, 2), LINEAR, strength=-0.5),
    case("weights-bsp-4x3x5-transformed", (4, 3, 5), BSPLINE, weights=True, lattice=LAT_M, obj=OBJ_M),
    case("weights-inverted-card-3x4x3", (3, 4, 3), CARDINAL, weights=True, invert=True, lattice=LAT_M2),
    case("weights-inverted-strength-0.6-mixed", (4, 2, 3), (LINEAR, BSPLINE, CATMULL_ROM), weights=True, invert=True,
         strength=0.6, lattice=LAT_M, obj=OBJ_M2),
    case("fine-bsp-8x6x7-transformed", (8, 6, 7), BSPLINE, perturb=0.05, lattice=LAT_M2, obj=OBJ_M),
]
CASE_IDS = [c["id"] for c in CASES]
assert len(set(CASE_IDS)) == len(CASE_IDS)


def requested_frame(c):
    obj = np.eye(4) if c["object"] is None else c["object"]
    lat = np.eye(4) if c["lattice"] is None else c["lattice"]
    return np.linalg.inv(obj) @ lat


def _sample_local(rng, c, n=1200):
    """Points in lattice-local coordinates (the box is [-0.5, 0.5]^3)."""
    if c["region"] == "outside":
        p = rng.uniform(-3.0, 3.0, size=(4 * n, 3))
        p = p[np.abs(p).max(1) > 0.52][:n]
    else:
        inside = rng.uniform(-0.5, 0.5, size=(n // 2, 3))
        near = rng.uniform(-1.0, 1.0, size=(n // 3, 3))
        d = rng.normal(size=(n - n // 2 - n // 3, 3))
        far = d / np.linalg.norm(d, axis=1, keepdims=True) * rng.uniform(2.0, 6.0, size=(len(d), 1))
        corners = np.array(np.meshgrid(*[[-0.5, 0.5]] * 3, indexing="ij")).reshape(3, -1).T
        nodes = rest_grid_local(c["resolution"]).reshape(-1, 3)  # knots: floor() decides the cell here
        p = np.concatenate([inside, near, far, corners, nodes])
    return p


_INPUT_CACHE: dict = {}


def case_inputs(c):
    """Deterministic inputs of a case: points float32 (n,3) in the mesh's space, co_deform float32
    (nu,nv,nw,3) lattice-local or None, raw vertex-group weights float32 or None, oracle settings."""
    if c["id"] in _INPUT_CACHE:
        return _INPUT_CACHE[c["id"]]
    rng = np.random.default_rng(zlib.crc32(c["id"].encode()))
    local = _sample_local(rng, c)
    points = apply(requested_frame(c), local).astype(np.float32)
    assert np.abs(points).max() <= MAX_EXTENT_REL * box_size(requested_frame(c)), c["id"]
    co = None
    if c["perturb"] > 0:
        rest = rest_grid_local(c["resolution"])
        co = (rest + rng.normal(scale=c["perturb"], size=rest.shape)).astype(np.float32)
    w = None
    if c["weights"]:
        x, y, z = local.T
        w = np.clip(0.5 + 0.9 * np.sin(3.0 * x + 0.4) * np.cos(2.0 * y - 0.3) + 0.3 * z, 0.0, 1.0).astype(np.float32)
    settings = {"resolution": list(c["resolution"]), "interpolation": list(c["interpolation"]),
                "strength": c["strength"], "invert_vertex_group": c["invert"]}
    if c["lattice"] is not None:
        settings["lattice_matrix_world"] = c["lattice"].tolist()
    if c["object"] is not None:
        settings["object_matrix_world"] = c["object"].tolist()
    _INPUT_CACHE[c["id"]] = (points, co, w, settings)
    return _INPUT_CACHE[c["id"]]


def effective_weights(c, w):
    """The modifier's per-vertex weight: Blender inverts in float32 (1.0f - w)."""
    if w is None:
        return None
    return (np.float32(1.0) - w if c["invert"] else w).astype(np.float64)


def deformkit_for(c, info, weights):
    """The deformkit equivalent of a case, built from what Blender actually evaluated."""
    obj_w = np.array(info["object_matrix_world"], dtype=np.float64)
    lat_w = np.array(info["lattice_matrix_world"], dtype=np.float64)
    frame = np.linalg.inv(obj_w) @ lat_w
    res = tuple(info["resolution"])
    co = from_blender_order(info["co_deform"], res)
    kw = {"resolution": res, "interpolation": tuple(info["interpolation"]), "frame": frame,
          "control_points": apply(frame, co), "strength": info["strength"]}
    if weights is not None:
        kw["weights"] = effective_weights(c, weights)
    return dk.BlenderLattice(**kw), frame


def check_harness(c, info, label):
    """Blender must have used exactly what the case asked for; otherwise the harness is wrong."""
    _points, co, _w, _settings = case_inputs(c)
    for key, m in (("object_matrix_world", c["object"]), ("lattice_matrix_world", c["lattice"])):
        np.testing.assert_allclose(np.array(info[key]), np.eye(4) if m is None else m, rtol=0, atol=1e-6,
                                   err_msg=f"{label}: Blender did not take {key}")
    assert tuple(info["resolution"]) == c["resolution"], label
    assert tuple(info["interpolation"]) == c["interpolation"], label
    assert info["strength"] == float(np.float32(c["strength"])), label
    res = c["resolution"]
    np.testing.assert_allclose(from_blender_order(info["rest_co"], res), rest_grid_local(res), rtol=0, atol=1e-6,
                               err_msg=f"{label}: Blender's rest grid is not [-0.5, 0.5] evenly spaced")
    if co is not None:
        np.testing.assert_array_equal(from_blender_order(info["co_deform"], res), co,
                                      err_msg=f"{label}: co_deform read back differs")


def _errors(a, b):
    d = np.abs(np.asarray(a, np.float64) - np.asarray(b, np.float64)).max(1)
    return float(d.max()), int(d.argmax())


def check_against_reference(c, blender, info, label):
    """Blender vs the numpy transcription, and the case must be far from trivial."""
    check_harness(c, info, label)
    points, co, w, _settings = case_inputs(c)
    frame = requested_frame(c)
    size = box_size(frame)
    atol = ATOL_REL * size
    co_local = rest_grid_local(c["resolution"]) if co is None else co
    ref = reference_lattice(points, frame, c["resolution"], c["interpolation"], co_local,
                            np.float32(c["strength"]), effective_weights(c, w))
    blender = np.asarray(blender, dtype=np.float64)
    assert blender.shape == points.shape and np.all(np.isfinite(blender))
    err, worst = _errors(ref, blender)
    moved = np.linalg.norm(blender - points, axis=1)
    print(f"[{label}] {c['id']:42s} n={len(points):5d} size={size:6.3f} mean moved={moved.mean() / size:.3f} "
          f"max moved={moved.max() / size:.3f} (x size) |reference - blender|={err:.2e} (rel {err / size:.1e})")
    assert err <= atol, (f"{label} {c['id']}: max |reference - blender| = {err:.3e} > atol {atol:.3e}; worst vertex "
                         f"{worst}: input {points[worst]}, reference {ref[worst]}, blender {blender[worst]}")
    if c["perturb"] > 0:
        assert moved.mean() > MIN_MOVED_REL * size, f"{label} {c['id']}: Blender hardly moved the points"
    else:
        assert moved.max() <= atol, f"{label} {c['id']}: a lattice at rest moved points by {moved.max():.3e}"


def check_deformkit(c, blender, info, label, bound=False):
    """deform(points), or with bound=True bind(points) + deform_bound (the add-on's path: it
    re-deforms bound points as the control points move), float32 and float64 input."""
    points, _co, w, _settings = case_inputs(c)
    lat, frame = deformkit_for(c, info, w)
    size = box_size(frame)
    atol = ATOL_REL * size
    blender = np.asarray(blender, dtype=np.float64)
    rest = apply(frame, from_blender_order(info["rest_co"], c["resolution"]))
    np.testing.assert_allclose(lat.rest_control_points, rest, rtol=0, atol=atol,
                               err_msg=f"{label} {c['id']}: rest_control_points differ from Blender's rest grid")
    errs, worst, outputs = {}, {}, {}
    for dtype in (np.float32, np.float64):
        x = points.astype(dtype)
        ours = lat.deform_bound(lat.bind(x)) if bound else lat.deform(x)
        assert ours.dtype == dtype
        outputs[np.dtype(dtype).name] = ours
        errs[np.dtype(dtype).name], worst[np.dtype(dtype).name] = _errors(ours, blender)
    path = "deform_bound" if bound else "deform"
    print(f"[{label}] {c['id']:42s} {path:12s} err32={errs['float32']:.2e} err64={errs['float64']:.2e} "
          f"(rel {max(errs.values()) / size:.1e})")
    for key, ours in outputs.items():
        i = worst[key]
        assert errs[key] <= atol, (f"{label} {c['id']} ({path}, {key} input): max |ours - blender| = {errs[key]:.3e} > "
                                   f"atol {atol:.3e} (size {size:.4g}); worst vertex {i}: input {points[i]}, "
                                   f"ours {ours[i]}, blender {blender[i]}")
    return errs


# ---------------------------------------------------------------------------------------------
# Oracle 1: Blender 5.0, the PyPI bpy module, in this process


@pytest.fixture(scope="module")
def bpy_results():
    """Every case evaluated once by Blender 5.0 (the reference and deformkit tests share it)."""
    oracle = bpy_oracle()
    import bpy  # noqa: PLC0415  (imported by bpy_oracle)
    out = {"version": bpy.app.version_string, "cases": {}}
    for c in CASES:
        points, co, w, settings = case_inputs(c)
        settings = dict(settings)
        if co is not None:
            settings["co_deform"] = to_blender_order(co)
        if w is not None:
            settings["weights"] = w.tolist()
        info = {}
        out["cases"][c["id"]] = (oracle.evaluate_lattice(points, settings, info=info), info)
        assert not (bpy.data.objects or bpy.data.meshes or bpy.data.lattices), "oracle left data behind"
    yield out
    empty_scene()


# ---------------------------------------------------------------------------------------------
# Oracle 2: Debian's Blender 3.4 binary, one subprocess for all cases


@pytest.fixture(scope="module")
def blender34_results(tmp_path_factory):
    work = tmp_path_factory.mktemp("blender34_lattice")
    spec = {"modifier": "LATTICE", "cases": []}
    for c in CASES:
        points, co, w, settings = case_inputs(c)
        entry = {"id": c["id"], "settings": settings, "points": f"{c['id']}.points.f32"}
        write_raw(work / entry["points"], points, np.float32)
        if co is not None:
            entry["co_deform"] = f"{c['id']}.co_deform.f32"
            write_raw(work / entry["co_deform"], to_blender_order(co), np.float32)
        if w is not None:
            entry["weights"] = f"{c['id']}.weights.f32"
            write_raw(work / entry["weights"], w, np.float32)
        spec["cases"].append(entry)
    yield run_blender_binary(work, spec)
    shutil.rmtree(work, ignore_errors=True)


# ---------------------------------------------------------------------------------------------
# Tests

ORACLES = {"5.0-bpy": ("bpy_results", "bpy"), "3.4-binary": ("blender34_results", "blender")}


@pytest.fixture(params=list(ORACLES))
def oracle(request):
    fixture, prefix = ORACLES[request.param]
    results = request.getfixturevalue(fixture)
    return results, f"{prefix} {results['version']}"


@pytest.mark.parametrize("c", CASES, ids=CASE_IDS)
def test_blender_matches_reference_formula(oracle, c):
    results, label = oracle
    blender, info = results["cases"][c["id"]]
    check_against_reference(c, blender, info, label)


@pytest.mark.parametrize("c", CASES, ids=CASE_IDS)
def test_deformkit_matches_blender(oracle, c):
    results, label = oracle
    blender, info = results["cases"][c["id"]]
    check_deformkit(c, blender, info, label)


@pytest.mark.parametrize("c", CASES, ids=CASE_IDS)
def test_deformkit_bound_matches_blender(oracle, c):
    results, label = oracle
    blender, info = results["cases"][c["id"]]
    check_deformkit(c, blender, info, label, bound=True)

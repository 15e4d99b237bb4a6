"""deformkit.SimpleDeform against Blender's own Simple Deform modifier, to float32 precision.

Two independent oracles, both Blender itself (see support/blender_oracle.py, started by
support/blender_runner.py):

* Blender 5.0 as the PyPI ``bpy`` module, imported lazily inside this process;
* Debian's Blender 3.4 binary (/usr/bin/blender), run once as a subprocess for all its cases.

Blender evaluates in float32, so each point gets its own tolerance, ``float32_tolerance``: a few
float32 roundings of the magnitudes its evaluation goes through (the mesh's size and the point's
own output, which the degenerate (0.5, 0.5) limits scale by ~1e6-1e7 for taper and stretch).
Each case is checked with float32 and float64 input, and must move the points by far more than
that tolerance (or, where Blender leaves the mesh alone, not at all).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

import deformkit as dk
from support.helpers import euler_xyz, trs
from support.blender_runner import bpy_oracle as load_bpy_oracle, empty_scene, run_blender_binary, write_raw

HERE = Path(__file__).resolve().parent
SHARED_MESHES = HERE.parents[2] / "shared" / "meshes"
EPS32 = float(np.finfo(np.float32).eps)
# Blender's evaluation of one point is about a dozen float32 operations (the object and origin
# transforms in and out, the angle or scale, one rotation or scaling), each rounding to half an
# EPS32 of a quantity no larger than the mesh's size or the point's output: 16 of them bound it
# (measured up to 1.6 EPS32 times that size, on Suzanne's twist).
ROUNDINGS = 16
# Cases whose Blender result is the input itself: twist and bend over limits of zero width.
IDENTITY = {"twist-Z-limits-0.5", "bend-Y-limits-0.5"}


# ---------------------------------------------------------------------------------------------
# Geometry and transforms (deterministic)


def make_torus():
    """An irregular, off-centre, rotated torus: 64 x 40 = 2560 vertices, quads and triangles."""
    nu, nv = 64, 40
    u = 2 * np.pi * np.arange(nu)[:, None] / nu
    v = 2 * np.pi * np.arange(nv)[None, :] / nv
    r = 0.35 * (1 + 0.35 * np.cos(u)) + 0.05 * np.sin(3 * v)
    big_r = 1.0 + 0.15 * np.sin(2 * u) + 0.1 * np.cos(u)
    p = np.stack([(big_r + r * np.cos(v)) * np.cos(u),
                  (big_r + r * np.cos(v)) * np.sin(u),
                  1.3 * r * np.sin(v) + 0.2 * np.cos(u)], axis=-1).reshape(-1, 3)
    p = p * (1.6, 1.0, 0.8)
    p = p @ euler_xyz(0.3, -0.5, 0.8).T + (0.7, -0.4, 1.1)
    p += np.random.default_rng(20240611).normal(scale=0.005, size=p.shape)
    faces = []
    for i in range(nu):
        for j in range(nv):
            a, b = i * nv + j, ((i + 1) % nu) * nv + j
            c, d = ((i + 1) % nu) * nv + (j + 1) % nv, i * nv + (j + 1) % nv
            if (i + j) % 5 == 0:
                faces += [(a, b, c), (a, c, d)]
            else:
                faces.append((a, b, c, d))
    return p.astype(np.float32), faces


def make_centred(points):
    """Shift so that on every axis the float32 bounds are exactly -a and +a.

    With limits (0.5, 0.5) Blender's k is angle / FLT_EPSILON (~7e6) and twist/bend use the angle
    k * L0: any rounding in L0 becomes an O(1) angle. Exactly symmetric bounds make L0 = 0 in both
    float32 and float64, so the degenerate case is well posed."""
    p = points.astype(np.float64)
    lo, hi = p.min(0), p.max(0)
    q = (p - (lo + hi) / 2).astype(np.float32)
    for ax in range(3):
        a = np.float32((hi[ax] - lo[ax]) / 2)
        q[p[:, ax] == hi[ax], ax] = a
        q[p[:, ax] == lo[ax], ax] = -a
        assert q[:, ax].min() == -a and q[:, ax].max() == a
    return q


def load_suzanne():
    path = SHARED_MESHES / "suzanne.obj"
    if not path.exists():
        pytest.skip(f"shared test mesh {path} is absent (a fresh clone without ../shared/meshes)")
    import trimesh  # noqa: PLC0415

    m = trimesh.load(str(path), process=False)
    return np.asarray(m.vertices, dtype=np.float32), [tuple(int(i) for i in f) for f in m.faces]


_MESH_CACHE: dict = {}


def get_mesh(name):
    if name not in _MESH_CACHE:
        if name == "torus":
            _MESH_CACHE[name] = make_torus()
        elif name == "torus_centred":
            p, f = get_mesh("torus")
            _MESH_CACHE[name] = (make_centred(p), f)
        elif name == "suzanne":
            _MESH_CACHE[name] = load_suzanne()
        else:
            raise KeyError(name)
    return _MESH_CACHE[name]


def smooth_weights(points):
    """Weights in [0, 1], with exact 0s and 1s from the clipping, rounded to float32 as Blender stores them."""
    x, y, z = points.astype(np.float64).T
    w = 0.5 + 0.8 * np.sin(2.1 * x + 0.7) * np.cos(1.3 * y - 0.4) + 0.2 * (z - 1.0)
    return np.clip(w, 0.0, 1.0).astype(np.float32)


# ---------------------------------------------------------------------------------------------
# Cases

ORIGIN_RT = trs(t=(0.9, -0.2, 1.3), euler=(0.4, -0.3, 0.9))
ORIGIN_RTS = trs(t=(0.5, 0.3, 0.8), euler=(-0.2, 0.5, 0.35), s=(1.3, 0.7, 1.1))
OBJECT_M = trs(t=(-1.2, 0.6, 0.4), euler=(0.25, 0.6, -0.4), s=(1.0, 1.2, 0.9))
OBJECT_M2 = trs(t=(2.0, -1.0, 0.5), euler=(-0.7, 0.1, 1.2))


def case(cid, mesh, mode, value, axis, limits=(0.0, 1.0), locks="", origin=None, obj=None,
         weights=False, invert=False):
    s = {"deform_method": mode, "deform_axis": axis, "limits": list(limits),
         "lock_x": "x" in locks, "lock_y": "y" in locks, "lock_z": "z" in locks,
         "invert_vertex_group": invert}
    s["angle" if mode in ("TWIST", "BEND") else "factor"] = value
    if origin is not None:
        s["origin_matrix_world"] = origin.tolist()
    if obj is not None:
        s["object_matrix_world"] = obj.tolist()
    return {"id": cid, "mesh": mesh, "settings": s, "weights": weights}


Q = 0.785398  # Blender's default angle, 45 degrees
CASES = [
    # TWIST
    case("twist-X", "torus", "TWIST", Q, "X"),
    case("twist-Y-limits", "torus", "TWIST", -1.3, "Y", limits=(0.2, 0.7)),
    case("twist-Z-lockx", "torus", "TWIST", Q, "Z", locks="x"),
    case("twist-Y-lockxy-limits", "torus", "TWIST", -1.3, "Y", limits=(0.2, 0.7), locks="xy"),
    case("twist-Z-origin-limits", "torus", "TWIST", Q, "Z", limits=(0.2, 0.7), origin=ORIGIN_RT),
    case("twist-X-objmat-origin", "torus", "TWIST", -1.3, "X", obj=OBJECT_M, origin=ORIGIN_RT, locks="z"),
    case("twist-Y-weights", "torus", "TWIST", Q, "Y", weights=True),
    case("twist-Z-weights-inverted", "torus", "TWIST", -1.3, "Z", limits=(0.2, 0.7), weights=True, invert=True),
    case("twist-Z-limits-0.5", "torus_centred", "TWIST", Q, "Z", limits=(0.5, 0.5)),
    case("twist-X-suzanne", "suzanne", "TWIST", Q, "X", limits=(0.2, 0.7)),
    # BEND
    case("bend-X", "torus", "BEND", Q, "X"),
    case("bend-Y-limits", "torus", "BEND", 2.5, "Y", limits=(0.2, 0.7)),
    case("bend-Z-negative", "torus", "BEND", -1.3, "Z"),
    case("bend-X-origin", "torus", "BEND", 2.5, "X", origin=ORIGIN_RT),
    case("bend-Y-objmat-origin-limits", "torus", "BEND", -1.3, "Y", limits=(0.2, 0.7), obj=OBJECT_M2,
         origin=ORIGIN_RT),
    case("bend-Z-weights", "torus", "BEND", 2.5, "Z", weights=True),
    case("bend-X-locks-ignored", "torus", "BEND", Q, "X", locks="xyz"),
    case("bend-Y-limits-0.5", "torus_centred", "BEND", 2.5, "Y", limits=(0.5, 0.5)),
    case("bend-Z-suzanne", "suzanne", "BEND", 2.5, "Z"),
    # TAPER
    case("taper-X", "torus", "TAPER", 0.4, "X"),
    case("taper-Y-negative-limits", "torus", "TAPER", -1.3, "Y", limits=(0.2, 0.7)),
    case("taper-Z-lockx", "torus", "TAPER", 0.4, "Z", locks="x"),
    case("taper-X-lockxz-limits", "torus", "TAPER", 0.4, "X", limits=(0.2, 0.7), locks="xz"),
    case("taper-Z-origin", "torus", "TAPER", 0.4, "Z", origin=ORIGIN_RT),
    case("taper-X-objmat-origin", "torus", "TAPER", 0.4, "X", obj=OBJECT_M, origin=ORIGIN_RT),
    case("taper-Y-weights-inverted", "torus", "TAPER", 0.4, "Y", weights=True, invert=True),
    case("taper-Z-limits-0.5", "torus", "TAPER", 0.4, "Z", limits=(0.5, 0.5)),
    case("taper-Y-suzanne", "suzanne", "TAPER", 0.4, "Y", limits=(0.2, 0.7)),
    # STRETCH
    case("stretch-X", "torus", "STRETCH", 0.4, "X"),
    case("stretch-Y-limits-lockz", "torus", "STRETCH", 0.4, "Y", limits=(0.2, 0.7), locks="z"),
    case("stretch-Z-lockxy", "torus", "STRETCH", 0.4, "Z", locks="xy"),
    case("stretch-Y-origin-nonuniform", "torus", "STRETCH", 0.4, "Y", origin=ORIGIN_RTS),
    case("stretch-Z-objmat-origin-nonuniform", "torus", "STRETCH", 0.4, "Z", limits=(0.2, 0.7), obj=OBJECT_M,
         origin=ORIGIN_RTS),
    case("stretch-X-weights", "torus", "STRETCH", 0.4, "X", weights=True),
    case("stretch-X-limits-0.5", "torus", "STRETCH", 0.4, "X", limits=(0.5, 0.5)),
    case("stretch-Y-suzanne", "suzanne", "STRETCH", 0.4, "Y"),
]
CASE_IDS = [c["id"] for c in CASES]
assert len(set(CASE_IDS)) == len(CASE_IDS)
assert {(c["settings"]["deform_method"], c["settings"]["deform_axis"]) for c in CASES} == {
    (m, a) for m in ("TWIST", "BEND", "TAPER", "STRETCH") for a in "XYZ"}

# invert_vertex_group with no vertex group: Blender changed semantics (see the test below).
INVERT_NO_GROUP = case("twist-Y-invert-no-group", "torus", "TWIST", Q, "Y", limits=(0.2, 0.7), invert=True)


def case_inputs(c):
    """(points float32 (n,3), faces, oracle settings incl. weights list, weights float32 or None)."""
    points, faces = get_mesh(c["mesh"])
    settings = dict(c["settings"])
    w = smooth_weights(points) if c["weights"] else None
    if w is not None:
        settings["weights"] = w.tolist()
    return points, faces, settings, w


def deformkit_for(c, info, weights):
    """The deformkit equivalent of a case, given the matrices Blender actually evaluated."""
    s = c["settings"]
    kw = {"mode": s["deform_method"], "deform_axis": s["deform_axis"], "limits": tuple(s["limits"]),
          "lock_x": s["lock_x"], "lock_y": s["lock_y"], "lock_z": s["lock_z"]}
    kw["angle" if "angle" in s else "factor"] = s.get("angle", s.get("factor"))
    if info.get("origin_matrix_world") is not None:
        obj_w = np.array(info["object_matrix_world"], dtype=np.float64)
        org_w = np.array(info["origin_matrix_world"], dtype=np.float64)
        kw["origin"] = np.linalg.inv(obj_w) @ org_w
    if weights is not None:
        kw["weights"] = weights.astype(np.float64)
        kw["invert_weights"] = s["invert_vertex_group"]
    return dk.SimpleDeform(**kw)


def bbox_diag(p):
    p = np.asarray(p, dtype=np.float64)
    return float(np.linalg.norm(p.max(0) - p.min(0)))


def float32_tolerance(points, blender):
    """Per point: ROUNDINGS float32 roundings of the mesh's size plus the point's own output."""
    return ROUNDINGS * EPS32 * (bbox_diag(points) + np.abs(np.asarray(blender, np.float64)).max(axis=1))


def check_case(c, blender, info, label):
    points, _faces, _settings, weights = case_inputs(c)
    s = c["settings"]
    # The matrices Blender used must be the ones asked for (else the harness is wrong, not the library).
    for key in ("object_matrix_world", "origin_matrix_world"):
        if s.get(key) is not None:
            np.testing.assert_allclose(np.array(info[key]), np.array(s[key]), rtol=0, atol=1e-5,
                                       err_msg=f"{label}: Blender did not take {key}")
    blender = np.asarray(blender, dtype=np.float64)
    assert blender.shape == points.shape
    assert np.all(np.isfinite(blender))
    scale = max(bbox_diag(points), bbox_diag(blender))
    tol = float32_tolerance(points, blender)
    moved = float(np.abs(blender - points).max())
    if c["id"] in IDENTITY:
        assert moved == 0.0, f"{label} {c['id']}: Blender moved the points by {moved:.3g}"
    else:  # agreement within the tolerance is not an identity passing for a deformation
        assert moved > 1000 * tol.max(), f"{label} {c['id']}: moved only {moved:.3g}, tolerance {tol.max():.3g}"
    d = deformkit_for(c, info, weights)
    errs, used = {}, 0.0
    for dtype in (np.float32, np.float64):
        ours = d.deform(points.astype(dtype))
        assert ours.dtype == dtype
        err = float(np.abs(ours.astype(np.float64) - blender).max())
        errs[np.dtype(dtype).name] = err
        off = np.abs(ours.astype(np.float64) - blender).max(1)
        worst = int((off / tol).argmax())
        used = max(used, float(off[worst] / tol[worst]))
        assert off[worst] <= tol[worst], (
            f"{label} {c['id']} ({np.dtype(dtype).name} input): |ours - blender| = {off[worst]:.3e} > its "
            f"tolerance {tol[worst]:.3e} at vertex {worst}: input {points[worst]}, ours {ours[worst]}, "
            f"blender {blender[worst]}")
    print(f"[{label}] {c['id']:38s} n={len(points):5d} moved={moved:9.3g} diag={scale:9.4g} "
          f"err32={errs['float32']:.2e} err64={errs['float64']:.2e} (rel {max(errs.values()) / scale:.1e}, "
          f"{used:.2f} of the tolerance)")
    return errs


# ---------------------------------------------------------------------------------------------
# Oracle 1: Blender 5.0, the PyPI bpy module, in this process


@pytest.fixture(scope="module")
def bpy_oracle():
    yield load_bpy_oracle()
    empty_scene()


def _bpy_evaluate(oracle, c):
    points, faces, settings, _w = case_inputs(c)
    info = {}
    out = oracle.evaluate_simple_deform(points, faces, settings, info=info)
    return out, info


@pytest.mark.parametrize("c", CASES, ids=CASE_IDS)
def test_matches_blender_5_0_bpy_module(bpy_oracle, c):
    import bpy  # noqa: PLC0415  (already imported by the fixture)

    out, info = _bpy_evaluate(bpy_oracle, c)
    assert len(bpy.data.objects) == 0 and len(bpy.data.meshes) == 0, "oracle left data behind"
    check_case(c, out, info, "bpy " + bpy.app.version_string)


# ---------------------------------------------------------------------------------------------
# Oracle 2: Debian's Blender 3.4 binary, one subprocess for all cases


@pytest.fixture(scope="module")
def blender34_results(tmp_path_factory):
    work = tmp_path_factory.mktemp("blender34")
    spec = {"modifier": "SIMPLE_DEFORM", "meshes": {}, "cases": []}
    for c in CASES + [INVERT_NO_GROUP]:
        try:
            points, faces, _settings, w = case_inputs(c)
        except pytest.skip.Exception:
            continue  # e.g. suzanne absent: that test skips with the reason itself
        name = c["mesh"]
        if name not in spec["meshes"]:
            write_raw(work / f"{name}.coords.f32", points, np.float32)
            stream = np.concatenate([[len(f), *f] for f in faces]) if faces else np.zeros(0)
            write_raw(work / f"{name}.faces.i32", stream, np.int32)
            spec["meshes"][name] = {"coords": f"{name}.coords.f32", "faces": f"{name}.faces.i32"}
        entry = {"id": c["id"], "mesh": name, "settings": c["settings"]}
        if w is not None:
            write_raw(work / f"{c['id']}.weights.f32", w, np.float32)
            entry["weights"] = f"{c['id']}.weights.f32"
        spec["cases"].append(entry)
    yield run_blender_binary(work, spec)
    shutil.rmtree(work, ignore_errors=True)


@pytest.mark.parametrize("c", CASES, ids=CASE_IDS)
def test_matches_blender_3_4_binary(blender34_results, c):
    case_inputs(c)  # skips (with its reason) when the mesh is absent
    pos, info = blender34_results["cases"][c["id"]]
    check_case(c, pos, info, "blender " + blender34_results["version"])


# ---------------------------------------------------------------------------------------------
# invert_vertex_group without a vertex group: the two Blenders disagree


@pytest.mark.parametrize("blender", ["5.0-bpy", "3.4-binary"])
def test_invert_without_vertex_group(blender, request):
    """Blender 3.4 inverts *after* the lookup (no group -> w = 1 -> inverted 0: nothing moves);
    Blender 5.0 inverts inside it (no group -> w = 1: fully deformed). deformkit refuses the
    ambiguous combination (invert_weights without weights) instead of picking one."""
    c = INVERT_NO_GROUP
    points, _faces, _settings, _w = case_inputs(c)
    if blender == "5.0-bpy":
        out, info = _bpy_evaluate(request.getfixturevalue("bpy_oracle"), c)
    else:
        out, info = request.getfixturevalue("blender34_results")["cases"][c["id"]]
    full = deformkit_for(c, info, None).deform(points.astype(np.float64))
    if blender == "5.0-bpy":
        assert np.abs(full - points).max() > 1000 * float32_tolerance(points, full).max()
        assert (np.abs(out - full).max(axis=1) <= float32_tolerance(points, out)).all(), \
            "Blender 5.0: expected full deformation"
    else:
        np.testing.assert_array_equal(out, points, err_msg="Blender 3.4: expected no deformation")
    with pytest.raises(ValueError, match="invert_weights"):
        dk.SimpleDeform(mode="TWIST", angle=Q, deform_axis="Y", invert_weights=True)

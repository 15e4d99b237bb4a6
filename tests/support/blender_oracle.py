"""Blender's own Simple Deform and Lattice modifiers as reference oracles.

Plain Python, no pytest, usable in two ways:

* imported next to the PyPI ``bpy`` module (Blender 5.x as a module):
  ``evaluate_simple_deform(coords, faces, settings)`` builds a fresh mesh object in the current
  scene, adds a SIMPLE_DEFORM modifier, evaluates the depsgraph and returns the evaluated
  object-local vertex positions; ``evaluate_lattice(coords, settings)`` builds a fresh lattice
  object and a fresh vertex-only mesh object, adds a LATTICE modifier to the mesh and does the same;
* run as a script by a Blender binary (Debian's Blender 3.4)::

      blender -b --factory-startup --python-exit-code 1 -P blender_oracle.py -- CASES.json OUTDIR

  CASES.json names the modifier and raw binary input files; one raw float32 output file per case
  and a ``results.json`` (what Blender actually used: matrices, vertex counts, for the lattice its
  rest grid, control points and strength, and the Blender version) are written to OUTDIR.
  ``blender_runner.py`` writes CASES.json, starts the binary and reads the results back.

The script path must not need numpy: Debian's ``blender`` package only *recommends*
``python3-numpy``, and the project's setup installs it with ``--no-install-recommends``. So all I/O
here is raw little-endian float32/int32 through :mod:`array`, and numpy is used only when present.

Simple Deform settings (a dict), with Blender's RNA names::

    deform_method: 'TWIST' | 'BEND' | 'TAPER' | 'STRETCH'
    angle or factor: float (one DNA value behind both names)
    deform_axis: 'X' | 'Y' | 'Z'
    limits: (lo, hi)                                 default (0, 1)
    lock_x, lock_y, lock_z: bool                     default False
    origin_matrix_world: 4x4 (rows) or None          an Empty used as the modifier's origin
    object_matrix_world: 4x4 (rows) or None          the deformed object's world matrix
    weights: n floats or None                        vertex group (every vertex is assigned)
    invert_vertex_group: bool                        default False (also allowed without weights)

Lattice settings (a dict), with Blender's RNA names where there is one::

    resolution: (points_u, points_v, points_w)        each 1..64
    interpolation: (type_u, type_v, type_w)           'KEY_LINEAR' | 'KEY_CARDINAL' |
                                                      'KEY_CATMULL_ROM' | 'KEY_BSPLINE'
    co_deform: 3*nu*nv*nw floats (u fastest, then v, then w), lattice-local, or None to keep the
               rest grid Blender builds itself
    lattice_matrix_world: 4x4 (rows) or None          the Lattice object's world matrix
    object_matrix_world: 4x4 (rows) or None           the deformed mesh object's world matrix
    strength: float                                   default 1
    weights: n floats or None                         the modifier's vertex group (every vertex
                                                      assigned); the lattice data's own vertex
                                                      group is never used
    invert_vertex_group: bool                         default False

The property names used are the same in Blender 3.4 and 5.0.
"""

from __future__ import annotations

import array
import json
import os
import sys

import bpy  # noqa: F401  (available both in the bpy module and inside the Blender binary)
from mathutils import Matrix

__all__ = ["evaluate_simple_deform", "evaluate_lattice", "blender_version", "run_cases"]

_PREFIX = "dk_oracle_"
_LATTICE_PREFIX = "dk_lattice_oracle_"


def blender_version():
    return tuple(bpy.app.version)


def _flat_f32(values):
    """(n,3) numpy array, flat sequence or array('f') -> flat array('f')."""
    if isinstance(values, array.array) and values.typecode == "f":
        return values
    try:  # numpy array: keep the exact float32 values, no Python-float round trip
        import numpy as np  # noqa: PLC0415

        if isinstance(values, np.ndarray):
            return array.array("f", np.ascontiguousarray(values, dtype=np.float32).ravel().tobytes())
    except ImportError:
        pass
    flat = []
    for v in values:
        if isinstance(v, (int, float)):
            flat.append(v)
        else:
            flat.extend(v)
    return array.array("f", flat)


def _matrix(rows):
    return Matrix([[float(v) for v in row] for row in rows])


def _rows(m):
    return [[float(m[r][c]) for c in range(4)] for r in range(4)]


def _get_f32(collection, prop, count):
    out = array.array("f", bytes(4 * count))
    collection.foreach_get(prop, out)
    return out


def _mesh_object(scene, prefix, co, faces, created_objects, created_meshes):
    """An object linked to the scene whose mesh has these vertices (exact float32 values) and
    polygons, in Blender 3.4 and 5.x."""
    n = len(co) // 3
    me = bpy.data.meshes.new(prefix + "mesh")
    created_meshes.append(me)
    faces = [tuple(int(i) for i in f) for f in faces]
    # from_pydata handles polygon offsets in both versions (loop_total is read-only in 4.x+).
    me.from_pydata([(0.0, 0.0, 0.0)] * n, [], faces)
    me.vertices.foreach_set("co", co)  # exact float32 positions, no float64 round trip
    me.update()
    if len(me.vertices) != n:
        raise RuntimeError("mesh has %d vertices, expected %d" % (len(me.vertices), n))
    obj = bpy.data.objects.new(prefix + "object", me)
    created_objects.append(obj)
    scene.collection.objects.link(obj)
    return obj


def _vertex_group(obj, md, settings, n):
    """The modifier's vertex group from settings["weights"] (every vertex assigned, weight 0
    included) and its invert flag."""
    weights = settings.get("weights")
    if weights is not None:
        weights = [float(w) for w in weights]
        if len(weights) != n:
            raise ValueError("weights: %d values for %d vertices" % (len(weights), n))
        group = obj.vertex_groups.new(name="dk_weights")
        for i, w in enumerate(weights):
            group.add([i], w, "REPLACE")
        md.vertex_group = group.name
    md.invert_vertex_group = bool(settings.get("invert_vertex_group", False))


def _evaluated_positions(obj_eval, n):
    mesh_eval = obj_eval.to_mesh()
    try:
        if len(mesh_eval.vertices) != n:
            raise RuntimeError("evaluated mesh has %d vertices, expected %d" % (len(mesh_eval.vertices), n))
        return _get_f32(mesh_eval.vertices, "co", 3 * n)
    finally:
        obj_eval.to_mesh_clear()


def _as_numpy(out, n):
    """(n,3) float32 numpy array when numpy is importable, otherwise the flat array('f')."""
    try:
        import numpy as np  # noqa: PLC0415
    except ImportError:
        return out
    return np.frombuffer(out.tobytes(), dtype=np.float32).reshape(n, 3).copy()


def _remove(created_objects, created_meshes, created_lattices=()):
    for ob in created_objects:
        bpy.data.objects.remove(ob, do_unlink=True)
    for me in created_meshes:
        bpy.data.meshes.remove(me)
    for lt in created_lattices:
        bpy.data.lattices.remove(lt)


# ---------------------------------------------------------------------------------------------
# Simple Deform


def evaluate_simple_deform(coords, faces, settings, info=None):
    """Evaluate Blender's SIMPLE_DEFORM on a fresh object; return object-local positions.

    coords: (n,3) float32 (numpy) or a flat float sequence; faces: sequence of vertex-index
    sequences (triangles/quads). Returns an (n,3) float32 numpy array when numpy is importable,
    otherwise a flat ``array('f')``. If ``info`` is a dict it receives the evaluated
    ``object_matrix_world`` / ``origin_matrix_world`` (rows) actually used by Blender.
    Everything created is removed again, also when evaluation fails.
    """
    co = _flat_f32(coords)
    n = len(co) // 3
    s = dict(settings)
    scene = bpy.context.scene
    created_objects, created_meshes = [], []
    try:
        obj = _mesh_object(scene, _PREFIX, co, faces, created_objects, created_meshes)
        if s.get("object_matrix_world") is not None:
            obj.matrix_world = _matrix(s["object_matrix_world"])

        origin = None
        if s.get("origin_matrix_world") is not None:
            origin = bpy.data.objects.new(_PREFIX + "origin", None)  # an Empty
            created_objects.append(origin)
            scene.collection.objects.link(origin)
            origin.matrix_world = _matrix(s["origin_matrix_world"])

        md = obj.modifiers.new(name="SimpleDeform", type="SIMPLE_DEFORM")
        md.deform_method = s["deform_method"]
        if s.get("angle") is not None and s.get("factor") is not None:
            raise ValueError("give angle or factor, not both")
        if s.get("angle") is not None:
            md.angle = float(s["angle"])
        elif s.get("factor") is not None:
            md.factor = float(s["factor"])
        md.deform_axis = s.get("deform_axis", "X")
        lo, hi = s.get("limits", (0.0, 1.0))
        md.limits = (float(lo), float(hi))
        md.lock_x = bool(s.get("lock_x", False))
        md.lock_y = bool(s.get("lock_y", False))
        md.lock_z = bool(s.get("lock_z", False))
        if origin is not None:
            md.origin = origin
        _vertex_group(obj, md, s, n)

        depsgraph = bpy.context.evaluated_depsgraph_get()
        depsgraph.update()
        obj_eval = obj.evaluated_get(depsgraph)
        if info is not None:
            info["object_matrix_world"] = _rows(obj_eval.matrix_world)
            info["origin_matrix_world"] = (
                _rows(origin.evaluated_get(depsgraph).matrix_world) if origin is not None else None)
            info["blender_version"] = list(bpy.app.version)
        out = _evaluated_positions(obj_eval, n)
    finally:
        _remove(created_objects, created_meshes)
    return _as_numpy(out, n)


# ---------------------------------------------------------------------------------------------
# Lattice


def _build_lattice(scene, s, created_objects, created_lattices):
    lt = bpy.data.lattices.new(_LATTICE_PREFIX + "lattice")
    created_lattices.append(lt)
    lat_ob = bpy.data.objects.new(_LATTICE_PREFIX + "lattice", lt)
    created_objects.append(lat_ob)
    scene.collection.objects.link(lat_ob)
    # The object must exist before resizing: only then does Blender respan the grid over
    # [-0.5, 0.5]; a lattice without an object keeps a spacing of 1 (span res - 1).
    nu, nv, nw = (int(r) for r in s["resolution"])
    lt.points_u, lt.points_v, lt.points_w = nu, nv, nw
    if (lt.points_u, lt.points_v, lt.points_w) != (nu, nv, nw):
        raise RuntimeError("lattice resolution %r, asked for %r" % ((lt.points_u, lt.points_v, lt.points_w),
                                                                    (nu, nv, nw)))
    tu, tv, tw = s["interpolation"]
    lt.interpolation_type_u, lt.interpolation_type_v, lt.interpolation_type_w = tu, tv, tw
    if s.get("co_deform") is not None:
        co = _flat_f32(s["co_deform"])
        if len(co) != 3 * nu * nv * nw:
            raise ValueError("co_deform: %d values for %d points" % (len(co), nu * nv * nw))
        lt.points.foreach_set("co_deform", co)
    lt.update_tag()  # foreach_set bypasses RNA updates
    if s.get("lattice_matrix_world") is not None:
        lat_ob.matrix_world = _matrix(s["lattice_matrix_world"])
    return lat_ob


def evaluate_lattice(coords, settings, info=None):
    """Evaluate Blender's LATTICE modifier on fresh objects; return mesh-local positions.

    coords: (n,3) float32 (numpy) or a flat float sequence. Returns an (n,3) float32 numpy array
    when numpy is importable, otherwise a flat ``array('f')``. If ``info`` is a dict it receives
    what the evaluated scene actually used: ``object_matrix_world``, ``lattice_matrix_world``
    (rows), ``rest_co`` and ``co_deform`` (flat lists, u fastest), ``resolution``,
    ``interpolation``, ``strength`` and ``blender_version``.
    Everything created is removed again, also when evaluation fails.
    """
    co = _flat_f32(coords)
    n = len(co) // 3
    s = dict(settings)
    scene = bpy.context.scene
    created_objects, created_meshes, created_lattices = [], [], []
    try:
        lat_ob = _build_lattice(scene, s, created_objects, created_lattices)
        # vertices only: the modifier needs no faces
        obj = _mesh_object(scene, _LATTICE_PREFIX, co, [], created_objects, created_meshes)
        if s.get("object_matrix_world") is not None:
            obj.matrix_world = _matrix(s["object_matrix_world"])

        md = obj.modifiers.new(name="Lattice", type="LATTICE")
        md.object = lat_ob
        md.strength = float(s.get("strength", 1.0))
        _vertex_group(obj, md, s, n)

        depsgraph = bpy.context.evaluated_depsgraph_get()
        depsgraph.update()
        obj_eval = obj.evaluated_get(depsgraph)
        if info is not None:
            lat_eval = lat_ob.evaluated_get(depsgraph)
            lt = lat_eval.data
            count = 3 * len(lt.points)
            info["object_matrix_world"] = _rows(obj_eval.matrix_world)
            info["lattice_matrix_world"] = _rows(lat_eval.matrix_world)
            info["rest_co"] = _get_f32(lt.points, "co", count).tolist()
            info["co_deform"] = _get_f32(lt.points, "co_deform", count).tolist()
            info["resolution"] = [lt.points_u, lt.points_v, lt.points_w]
            info["interpolation"] = [lt.interpolation_type_u, lt.interpolation_type_v,
                                     lt.interpolation_type_w]
            info["strength"] = float(md.strength)
            info["blender_version"] = list(bpy.app.version)
        out = _evaluated_positions(obj_eval, n)
    finally:
        _remove(created_objects, created_meshes, created_lattices)
    return _as_numpy(out, n)


# ---------------------------------------------------------------------------------------------
# Script mode (Blender binary): raw binary in, raw binary out, numpy not required.


def _read_raw(path, typecode):
    a = array.array(typecode)
    with open(path, "rb") as f:
        a.frombytes(f.read())
    if sys.byteorder != "little":
        a.byteswap()
    return a


def _read_faces(path):
    """int32 stream: for each face, its vertex count followed by the indices."""
    data = _read_raw(path, "i")
    faces, i = [], 0
    while i < len(data):
        k = data[i]
        faces.append(tuple(data[i + 1:i + 1 + k]))
        i += 1 + k
    return faces


def _simple_deform_cases(spec, base):
    """{"meshes": {name: {"coords": path (float32 raw), "faces": path (int32 raw)}},
    "cases": [{"id", "mesh", "settings", optional "weights": path (float32 raw)}]}."""
    meshes = {}
    for name, m in spec["meshes"].items():
        meshes[name] = (_read_raw(os.path.join(base, m["coords"]), "f"),
                        _read_faces(os.path.join(base, m["faces"])))
    for case in spec["cases"]:
        co, faces = meshes[case["mesh"]]
        settings = dict(case["settings"])
        if case.get("weights"):
            settings["weights"] = _read_raw(os.path.join(base, case["weights"]), "f").tolist()
        yield case["id"], co, lambda info, co=co, faces=faces, s=settings: evaluate_simple_deform(co, faces, s, info)


def _lattice_cases(spec, base):
    """{"cases": [{"id", "settings", "points": path, optional "co_deform": path,
    optional "weights": path}]}, raw little-endian float32."""
    for case in spec["cases"]:
        co = _read_raw(os.path.join(base, case["points"]), "f")
        settings = dict(case["settings"])
        if case.get("co_deform"):
            settings["co_deform"] = _read_raw(os.path.join(base, case["co_deform"]), "f")
        if case.get("weights"):
            settings["weights"] = _read_raw(os.path.join(base, case["weights"]), "f").tolist()
        yield case["id"], co, lambda info, co=co, s=settings: evaluate_lattice(co, s, info)


_CASE_READERS = {"SIMPLE_DEFORM": _simple_deform_cases, "LATTICE": _lattice_cases}


def run_cases(cases_json, out_dir):
    """cases_json: {"modifier": "SIMPLE_DEFORM" | "LATTICE", ...} with the cases in the layout its
    reader (_simple_deform_cases, _lattice_cases) describes; paths relative to the JSON file."""
    with open(cases_json) as f:
        spec = json.load(f)
    base = os.path.dirname(os.path.abspath(cases_json))
    os.makedirs(out_dir, exist_ok=True)
    results = {"blender_version": list(bpy.app.version), "cases": {}}
    for case_id, co, evaluate in _CASE_READERS[spec["modifier"]](spec, base):
        info = {}
        out = evaluate(info)
        if not isinstance(out, array.array):  # numpy happened to be importable
            out = array.array("f", out.astype("<f4").tobytes())
        elif sys.byteorder != "little":
            out.byteswap()
        fname = "out_%s.f32" % case_id
        with open(os.path.join(out_dir, fname), "wb") as f:
            f.write(out.tobytes())
        info["positions"] = fname
        info["n"] = len(co) // 3
        results["cases"][case_id] = info
    with open(os.path.join(out_dir, "results.json"), "w") as f:
        json.dump(results, f)
    return results


def _main(argv):
    args = argv[argv.index("--") + 1:] if "--" in argv else []
    if len(args) != 2:
        raise SystemExit("usage: blender -b --factory-startup --python-exit-code 1 -P blender_oracle.py -- "
                         "CASES.json OUT_DIR")
    res = run_cases(args[0], args[1])
    print("blender_oracle: %d cases evaluated with Blender %s" % (len(res["cases"]), bpy.app.version_string))


if __name__ == "__main__":
    _main(sys.argv)

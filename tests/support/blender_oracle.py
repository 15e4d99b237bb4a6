"""Blender's own Simple Deform modifier as a reference oracle.

Plain Python, no pytest, usable in two ways:

* imported next to the PyPI ``bpy`` module (Blender 5.x as a module):
  ``evaluate_simple_deform(coords, faces, settings)`` builds a fresh mesh object in the current
  scene, adds a SIMPLE_DEFORM modifier, evaluates the depsgraph and returns the evaluated
  object-local vertex positions;
* run as a script by a Blender binary (Debian's Blender 3.4)::

      blender -b --factory-startup --python-exit-code 1 -P blender_oracle.py -- CASES.json OUTDIR

  CASES.json names raw binary input files; one raw float32 output file per case and a
  ``results.json`` (matrices actually used, vertex counts, Blender version) are written to OUTDIR.

The script path must not need numpy: Debian's ``blender`` package only *recommends*
``python3-numpy``, and the project's setup installs it with ``--no-install-recommends``. So all I/O
here is raw little-endian float32/int32 through :mod:`array`, and numpy is used only when present.

Settings (a dict), with Blender's RNA names::

    deform_method: 'TWIST' | 'BEND' | 'TAPER' | 'STRETCH'
    angle or factor: float (one DNA value behind both names)
    deform_axis: 'X' | 'Y' | 'Z'
    limits: (lo, hi)                                 default (0, 1)
    lock_x, lock_y, lock_z: bool                     default False
    origin_matrix_world: 4x4 (rows) or None          an Empty used as the modifier's origin
    object_matrix_world: 4x4 (rows) or None          the deformed object's world matrix
    weights: n floats or None                        vertex group (every vertex is assigned)
    invert_vertex_group: bool                        default False (also allowed without weights)

The property names used (deform_method, angle, factor, deform_axis, limits, lock_x/y/z, origin,
vertex_group, invert_vertex_group) are the same in Blender 3.4 and 5.0.
"""

from __future__ import annotations

import array
import json
import os
import sys

import bpy  # noqa: F401  (available both in the bpy module and inside the Blender binary)
from mathutils import Matrix

__all__ = ["evaluate_simple_deform", "blender_version", "run_cases"]

_PREFIX = "dk_oracle_"


def blender_version():
    return tuple(bpy.app.version)


def _flat_f32(coords):
    """coords (n,3) numpy array, flat sequence or array('f') -> array('f') of length 3n."""
    if isinstance(coords, array.array) and coords.typecode == "f":
        return coords
    try:  # numpy array: exact float32 values, no Python-float round trip
        import numpy as np  # noqa: PLC0415

        if isinstance(coords, np.ndarray):
            return array.array("f", np.ascontiguousarray(coords, dtype=np.float32).ravel().tobytes())
    except ImportError:
        pass
    flat = []
    for c in coords:
        if isinstance(c, (int, float)):
            flat.append(c)
        else:
            flat.extend(c)
    return array.array("f", flat)


def _matrix(rows):
    return Matrix([[float(v) for v in row] for row in rows])


def _rows(m):
    return [[float(m[r][c]) for c in range(4)] for r in range(4)]


def _build_mesh(name, co, faces):
    """A mesh with these vertices (exact float32 values) and polygons, in Blender 3.4 and 5.x."""
    n = len(co) // 3
    me = bpy.data.meshes.new(name)
    faces = [tuple(int(i) for i in f) for f in faces]
    # from_pydata handles polygon offsets in both versions (loop_total is read-only in 4.x+).
    me.from_pydata([(0.0, 0.0, 0.0)] * n, [], faces)
    me.vertices.foreach_set("co", co)  # exact float32 positions, no float64 round trip
    me.update()
    if len(me.vertices) != n:
        raise RuntimeError("mesh has %d vertices, expected %d" % (len(me.vertices), n))
    return me


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
        me = _build_mesh(_PREFIX + "mesh", co, faces)
        created_meshes.append(me)
        obj = bpy.data.objects.new(_PREFIX + "object", me)
        created_objects.append(obj)
        scene.collection.objects.link(obj)
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

        weights = s.get("weights")
        if weights is not None:
            weights = [float(w) for w in weights]
            if len(weights) != n:
                raise ValueError("weights: %d values for %d vertices" % (len(weights), n))
            group = obj.vertex_groups.new(name="dk_weights")
            for i, w in enumerate(weights):  # every vertex is assigned, weight 0 included
                group.add([i], w, "REPLACE")
            md.vertex_group = group.name
        md.invert_vertex_group = bool(s.get("invert_vertex_group", False))

        depsgraph = bpy.context.evaluated_depsgraph_get()
        depsgraph.update()
        obj_eval = obj.evaluated_get(depsgraph)
        if info is not None:
            info["object_matrix_world"] = _rows(obj_eval.matrix_world)
            info["origin_matrix_world"] = (
                _rows(origin.evaluated_get(depsgraph).matrix_world) if origin is not None else None)
            info["blender_version"] = list(bpy.app.version)
        mesh_eval = obj_eval.to_mesh()
        try:
            if len(mesh_eval.vertices) != n:
                raise RuntimeError("evaluated mesh has %d vertices, expected %d" % (len(mesh_eval.vertices), n))
            out = array.array("f", bytes(4 * 3 * n))
            mesh_eval.vertices.foreach_get("co", out)
        finally:
            obj_eval.to_mesh_clear()
    finally:
        for ob in created_objects:
            bpy.data.objects.remove(ob, do_unlink=True)
        for me in created_meshes:
            bpy.data.meshes.remove(me)

    try:
        import numpy as np  # noqa: PLC0415
    except ImportError:
        return out
    return np.frombuffer(out.tobytes(), dtype=np.float32).reshape(n, 3).copy()


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


def run_cases(cases_json, out_dir):
    """cases_json: {"meshes": {name: {"coords": path (float32 raw), "faces": path (int32 raw)}},
    "cases": [{"id", "mesh", "settings", optional "weights": path (float32 raw)}]}."""
    with open(cases_json) as f:
        spec = json.load(f)
    base = os.path.dirname(os.path.abspath(cases_json))
    meshes = {}
    for name, m in spec["meshes"].items():
        meshes[name] = (_read_raw(os.path.join(base, m["coords"]), "f"),
                        _read_faces(os.path.join(base, m["faces"])))
    os.makedirs(out_dir, exist_ok=True)
    results = {"blender_version": list(bpy.app.version), "cases": {}}
    for case in spec["cases"]:
        co, faces = meshes[case["mesh"]]
        settings = dict(case["settings"])
        if case.get("weights"):
            settings["weights"] = _read_raw(os.path.join(base, case["weights"]), "f").tolist()
        info = {}
        out = evaluate_simple_deform(co, faces, settings, info=info)
        if not isinstance(out, array.array):  # numpy happened to be importable
            out = array.array("f", out.astype("<f4").tobytes())
        elif sys.byteorder != "little":
            out.byteswap()
        fname = "out_%s.f32" % case["id"]
        with open(os.path.join(out_dir, fname), "wb") as f:
            f.write(out.tobytes())
        info["positions"] = fname
        info["n"] = len(co) // 3
        results["cases"][case["id"]] = info
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

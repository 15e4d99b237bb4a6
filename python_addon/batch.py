"""Batch work inside Blender: apply a recipe (or re-evaluate saved stacks) to the open file, save the
result under a temporary name and rename it, and describe what happened. Plain functions, so the
CLI worker and the tests call the same code; `cli.py` runs this in one Blender per input file."""
import json
import os
import sys
import time

import bpy
import numpy as np

from . import api, evaluation, subdivision


class BatchError(Exception):
    """A per-file failure with a message for the report."""


def resolve_objects(selectors):
    """Objects named in the recipe; "*" means every mesh object but Subdivide entries' helpers. A
    missing name is an error."""
    found = []
    for name in selectors:
        if name == "*":
            found += [o for o in bpy.data.objects if o.type == "MESH" and subdivision.OWNER not in o]
            continue
        obj = bpy.data.objects.get(name)
        if obj is None:
            raise BatchError(f"object '{name}' not found in the file")
        found.append(obj)
    return list(dict.fromkeys(found))


def apply_recipe(recipe):
    """Add the recipe's deformers to its objects and evaluate them; returns the objects."""
    objects = resolve_objects(recipe.get("objects", ["*"]))
    for obj in objects:
        if recipe.get("replace", False):
            obj.deformkit.entries.clear()
        for spec in recipe.get("deformers", []):
            spec = dict(spec)
            kind = spec.pop("type", None)
            if kind is None:
                raise BatchError("recipe: every deformer needs a 'type'")
            for prop in ("origin", "lattice", "handle_object"):  # objects are named in the recipe
                if prop in spec:
                    found = bpy.data.objects.get(spec[prop])
                    if found is None:
                        raise BatchError(f"recipe: {prop} object '{spec[prop]}' not found")
                    spec[prop] = found
            # A Laplacian entry does nothing until bound: "bind": true binds it to what comes in.
            bind = str(kind).upper() == "LAPLACIAN" and bool(spec.pop("bind", False))
            try:
                api.add_entry(obj, kind, **spec)
                if bind:
                    api.bind_laplacian(obj, len(obj.deformkit.entries) - 1)
            except (ValueError, TypeError) as exc:
                raise BatchError(f"{obj.name}: {exc}") from exc
    return objects


def evaluate_saved():
    return [o for o in bpy.data.objects if o.type == "MESH" and len(o.deformkit.entries) > 0]


def describe(obj, seconds, smoothness=False):
    """The object's line in the report; with smoothness, api.check_smoothness's figures too (the
    selection is left alone)."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    evaluated = obj.evaluated_get(depsgraph)
    found = {"name": obj.name, "vertices": len(obj.data.vertices), "evaluated_vertices": len(evaluated.data.vertices),
             "evaluated_faces": len(evaluated.data.polygons), "entries": [e.type for e in obj.deformkit.entries],
             "seconds": round(seconds, 4)}
    if smoothness:
        found["smoothness"] = api.check_smoothness(obj, select=False)
    return found


def save_atomically(path):
    """Save a copy of the open file as `path`: written under a temporary name, then renamed."""
    tmp = f"{path}.tmp{os.getpid()}.blend"
    try:
        bpy.ops.wm.save_as_mainfile(filepath=tmp, copy=True)
        if not os.path.exists(tmp):
            raise BatchError(f"Blender did not write {tmp}")
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def export_preview(objects, path):
    """World-space positions before/after and triangles of each object, for the CLI's picture."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    before, after, faces, offset = [], [], [], 0
    for obj in objects:
        mesh = obj.data
        if len(mesh.polygons) == 0:
            continue
        mesh.calc_loop_triangles()
        tris = np.empty(len(mesh.loop_triangles) * 3, np.int32)
        mesh.loop_triangles.foreach_get("vertices", tris)
        world = np.array(obj.matrix_world)
        base = evaluation.base_positions(mesh).astype(np.float64)
        deformed = evaluation.evaluated_positions(obj, depsgraph).astype(np.float64)
        if len(deformed) != len(base):  # a later modifier changed the topology: show the cage
            deformed = _stored_positions(mesh, base)
        before.append(base @ world[:3, :3].T + world[:3, 3])
        after.append(deformed @ world[:3, :3].T + world[:3, 3])
        faces.append(tris.reshape(-1, 3) + offset)
        offset += len(base)
    if before:
        np.savez(path, before=np.vstack(before), after=np.vstack(after), faces=np.vstack(faces))


def _stored_positions(mesh, base):
    attr = mesh.attributes.get(evaluation.ATTR_VIEWPORT)
    if attr is None:
        return base
    values = np.empty(len(mesh.vertices) * 3, np.float32)
    attr.data.foreach_get("vector", values)
    return values.reshape(-1, 3).astype(np.float64)


def process(input_path, output_path, recipe=None, preview_path=None, smoothness=False):
    """Open `input_path`, run the recipe (or the saved stacks), save to `output_path`. With
    smoothness (or a recipe's "smoothness": true) the report has each object's smoothness figures."""
    t0 = time.perf_counter()
    result = {"file": input_path, "output": output_path, "status": "failed", "error": "", "objects": []}
    try:
        if os.path.realpath(input_path) == os.path.realpath(output_path) or (
                os.path.exists(output_path) and os.path.samefile(input_path, output_path)):
            raise BatchError("the output would overwrite the input")
        try:
            bpy.ops.wm.open_mainfile(filepath=input_path, load_ui=False)
        except RuntimeError as exc:
            raise BatchError(f"cannot open as a .blend file: {str(exc).strip()}") from exc
        objects = apply_recipe(recipe) if recipe else evaluate_saved()
        smoothness = smoothness or bool(recipe and recipe.get("smoothness", False))
        for obj in objects:
            t = time.perf_counter()
            api.evaluate(obj)
            result["objects"].append(describe(obj, time.perf_counter() - t, smoothness))
        save_atomically(output_path)
        if preview_path:
            export_preview(objects, preview_path)
        result["status"] = "ok"
    except (BatchError, ValueError) as exc:
        result["error"] = str(exc)
    result["seconds"] = round(time.perf_counter() - t0, 4)
    return result


def worker_main(argv=None):
    """Entry point inside Blender: args after `--` are INPUT OUTPUT RESULT_JSON [RECIPE_JSON] [PREVIEW]
    [SMOOTHNESS] (non-empty: add the smoothness figures)."""
    argv = sys.argv[sys.argv.index("--") + 1:] if argv is None else argv
    input_path, output_path, result_path = argv[:3]
    recipe = json.loads(argv[3]) if len(argv) > 3 and argv[3] else None
    preview = argv[4] if len(argv) > 4 and argv[4] else None
    smoothness = len(argv) > 5 and bool(argv[5])
    result = process(input_path, output_path, recipe, preview, smoothness)
    result["blender"] = bpy.app.version_string
    with open(result_path + ".tmp", "w") as fh:
        json.dump(result, fh)
    os.replace(result_path + ".tmp", result_path)
    return 0 if result["status"] == "ok" else 1

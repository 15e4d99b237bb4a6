"""Batch work inside Blender: apply a recipe (or re-evaluate saved stacks) to the open file, save the
result under a temporary name and rename it, and describe what happened. Plain functions, so the
worker and the tests call the same code; the launcher (`python -m deformkit.batch`, no bpy) runs
`worker_main` in one Blender per input file, on that file's job (deformkit.batch.job.BatchJob).

Whatever goes wrong is caught here and written to the result file as a structured record (the
exception's type and message, the stage, the object and the recipe entry it was on), so that the
launcher's report says what happened instead of "Blender exited with status 1"."""
import json
import os
import time

import bpy
import numpy as np

from . import api, batch_checks, entries, entry_animation, evaluation, meshdata, recipe_schema, transfer
from .entries import common


class BatchError(Exception):
    """A per-file failure with a message for the report."""


def resolve_objects(selectors):
    """Objects named in the recipe; "*" means every mesh object but Subdivide entries' helpers. A
    missing name is an error."""
    found = []
    for name in selectors:
        if name == "*":
            found += [o for o in bpy.data.objects if o.type == "MESH" and not entries.is_helper(o)]
            continue
        obj = bpy.data.objects.get(name)
        if obj is None:
            raise BatchError(f"object '{name}' not found in the file")
        found.append(obj)
    return list(dict.fromkeys(found))


def checked_recipe(recipe):
    try:
        return recipe_schema.validate(recipe)
    except recipe_schema.RecipeError as exc:
        raise BatchError(f"recipe: {exc}") from exc


def apply_recipe(recipe, objects=None, where=None):
    """Add the recipe's deformers to its objects (default: those it names) and evaluate them;
    returns the objects. `where` (a dict) follows the object and entry being worked on."""
    recipe = checked_recipe(recipe)
    where = {} if where is None else where
    recipe_entries = where.setdefault("recipe_entries", {})
    objects = resolve_objects(recipe["objects"]) if objects is None else objects
    for obj in objects:
        where["object"] = obj.name
        if recipe.get("replace", False):
            entry_animation.cleared(obj)
            obj.deformkit.entries.clear()
        for i, spec in enumerate(recipe.get("deformers", [])):
            where["entry"] = f"deformers[{i}]"
            spec = dict(spec)
            kind = spec.pop("type")
            for prop in common.POINTERS:  # objects are named in the recipe
                if prop in spec:
                    found = bpy.data.objects.get(spec[prop])
                    if found is None:
                        raise BatchError(f"recipe: {prop} object '{spec[prop]}' not found")
                    spec[prop] = found
            # Laplacian, Cage and RBF entries do nothing until bound: "bind": true binds a Laplacian
            # entry to what comes in, a Cage entry to its cage's current shape, an RBF entry to its
            # controls' rest (Rest From).
            bind = spec.pop("bind", False)
            api.add_entry(obj, kind, **spec)
            index = obj.deformkit.active_index  # the new entry: above a saved Subdivide entry, if any
            recipe_entries[(obj.name, index)] = where["entry"]
            if bind:
                api.bind(obj, index)
        where["entry"] = None
    return objects


def transfer_object(spec, key, i):
    name = spec[key]
    obj = bpy.data.objects.get(name)
    if obj is None:
        raise BatchError(f"recipe: transfers[{i}].{key}: object '{name}' not found in the file")
    return obj


def run_transfers(recipe, where=None):
    """The recipe's transfers, in order, through the operator's own functions (transfer/): each
    table's source shape keys (or, with "mode": "ANIMATION", its frames) onto its target. Returns
    one report line per transfer. `where` (a dict) follows the transfer being worked on."""
    where = {} if where is None else where
    done = []
    for i, spec in enumerate(checked_recipe(recipe).get("transfers", [])):
        where["entry"] = f"transfers[{i}]"
        source, target = transfer_object(spec, "source", i), transfer_object(spec, "target", i)
        where["object"] = target.name
        options = dict(replace=spec.get("replace", False),
                       marker_prefix=spec.get("marker_prefix", transfer.DEFAULT_PREFIX))
        if spec.get("mode", "SHAPE_KEYS") == "ANIMATION":
            scene = bpy.context.scene
            result = transfer.transfer_animation(source, target, spec.get("frame_start", scene.frame_start),
                                                 spec.get("frame_end", scene.frame_end), scene, **options)
        else:
            result = transfer.transfer_shape_keys(source, target, **options)
        done.append({"source": source.name, "target": target.name, "keys": result.keys, "direct": result.direct,
                     "reused_correspondence": result.reused_correspondence,
                     "unmatched_target_triangles": result.unmatched, "seconds": round(result.seconds, 4)})
    where["entry"] = where["object"] = None
    return done


def failing_entry(obj, recipe_entries):
    """The recipe path (or, for a saved entry, the stack position and name) of obj's first entry
    with an error."""
    for i, entry in enumerate(obj.deformkit.entries):
        if entry.error:
            return recipe_entries.get((obj.name, i), f"stack entry {i} '{entry.name}'")
    return None


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


def save_atomically(path, token=None):
    """Save a copy of the open file as `path`: written under a name unique to this run (`token`),
    then renamed. Only that run's own temporaries are ever removed."""
    # Imported here: the add-on loads (and says why it cannot run) without the compiled module.
    from deformkit.batch import shared as batch_io
    token = token or batch_io.new_run_token()
    tmp, blender_tmp = batch_io.run_temporaries(path, token)
    try:
        try:
            bpy.ops.wm.save_as_mainfile(filepath=tmp, copy=True)
        except RuntimeError as exc:  # Blender's message alone can be a stale errno: add the facts
            raise RuntimeError(f"cannot save {path}: {str(exc).strip()} ({save_conditions(path)})") from exc
        if not os.path.exists(tmp):
            raise BatchError(f"Blender did not write {tmp}")
        pause_point_for_tests()
        os.replace(tmp, path)
    finally:
        for leftover in (tmp, blender_tmp):
            if os.path.exists(leftover):
                os.unlink(leftover)


# A test hook, off unless this variable names a folder holding two FIFOs, "paused" and "resume":
# the worker then announces on "paused" that its temporary is written and waits for a line (or
# the end) on "resume", so that a test can act while the temporary exists, or hold a run
# unfinished, without racing the save (tests/addon/test_batch_faults.py). Unset, it costs one lookup.
PAUSE_BEFORE_RENAME = "DEFORMKIT_TEST_PAUSE_BEFORE_RENAME"


def pause_point_for_tests():
    folder = os.environ.get(PAUSE_BEFORE_RENAME)
    if not folder:
        return
    with open(os.path.join(folder, "resume"), encoding="utf-8") as resume:  # first: its writer is the test
        with open(os.path.join(folder, "paused"), "w", encoding="utf-8") as paused:
            paused.write(f"{os.getpid()}\n")
        resume.readline()  # until the test writes a line or closes its end


def save_conditions(path):
    """What can stop a save: the folder's free space and write access, a file-size limit."""
    folder = os.path.dirname(path) or "."
    facts = []
    try:
        free = os.statvfs(folder)
        facts.append(f"{free.f_bavail * free.f_frsize / 1e6:.1f} MB free in {folder}")
    except OSError as exc:
        facts.append(f"{folder}: {exc.strerror}")
    if not os.access(folder, os.W_OK):
        facts.append("the folder is not writable")
    try:
        import resource
        limit = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
        if limit != resource.RLIM_INFINITY:
            facts.append(f"file-size limit (ulimit -f) {limit} bytes")
    except ImportError:
        pass
    return "; ".join(facts)


def open_blend(path):
    """Open `path`; returns what Blender said while reading it (warnings), raises BatchError if it
    cannot."""
    with batch_checks.captured_output() as lines:
        try:
            bpy.ops.wm.open_mainfile(filepath=path, load_ui=False)
        except RuntimeError as exc:
            raise BatchError(f"cannot open as a .blend file: {str(exc).strip()}") from exc
    return batch_checks.reading_messages(lines)


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
        base = meshdata.base_positions(mesh).astype(np.float64)
        deformed = evaluation.evaluated_positions(obj, depsgraph).astype(np.float64)
        if len(deformed) != len(base):  # a later modifier changed the topology: show the cage
            deformed = _stored_positions(obj, base)
        before.append(base @ world[:3, :3].T + world[:3, 3])
        after.append(deformed @ world[:3, :3].T + world[:3, 3])
        faces.append(tris.reshape(-1, 3) + offset)
        offset += len(base)
    if before:
        np.savez(path, before=np.vstack(before), after=np.vstack(after), faces=np.vstack(faces))


def _stored_positions(obj, base):
    stored = evaluation.stored_positions(obj)
    return base if stored is None else stored.astype(np.float64)


def process(input_path, output_path, recipe=None, preview_path=None, smoothness=False, token=None,
            on_stage=None):
    """Open `input_path`, run the recipe (or the saved stacks), save to `output_path`. With
    smoothness (or a recipe's "smoothness": true) the report has each object's smoothness figures.
    Never raises: a failure is the result's "error" (one line) and "exception" (type, message,
    stage, object, entry). on_stage(result, where) is called as the work moves on."""
    # Imported here: the add-on loads (and says why it cannot run) without the compiled module.
    from deformkit.batch import shared as batch_io
    t0 = time.perf_counter()
    result = batch_io.file_row(input_path, output_path)
    where = {"stage": "open", "object": None, "entry": None, "recipe_entries": {}}

    def stage(name):
        where.update(stage=name, object=None, entry=None)
        if on_stage:
            on_stage(result, where)

    try:
        if os.path.realpath(input_path) == os.path.realpath(output_path) or (
                os.path.exists(output_path) and os.path.samefile(input_path, output_path)):
            raise BatchError("the output would overwrite the input")
        stage("open")
        result["warnings"] += open_blend(input_path)
        stage("recipe" if recipe else "evaluate")
        if recipe:
            recipe = checked_recipe(recipe)
            objects = resolve_objects(recipe["objects"])
        else:
            objects = evaluate_saved()
        result["warnings"] += batch_checks.damage_warnings(objects)
        if recipe and recipe.get("transfers"):
            stage("transfer")  # on the file as it was saved, before the recipe's deformers are added
            result["transfers"] = run_transfers(recipe, where)
            stage("recipe")
        if recipe:
            apply_recipe(recipe, objects, where)
        smoothness = smoothness or bool(recipe and recipe.get("smoothness", False))
        stage("evaluate")
        for obj in objects:
            where["object"] = obj.name
            t = time.perf_counter()
            try:
                api.evaluate(obj)
            except ValueError:
                where["entry"] = failing_entry(obj, where["recipe_entries"])
                raise
            result["objects"].append(describe(obj, time.perf_counter() - t, smoothness))
        stage("save")
        save_atomically(output_path, token)
        saved = os.stat(output_path)  # what a retry checks to know this very file is in place
        result["output_stat"] = {"bytes": saved.st_size, "mtime_ns": saved.st_mtime_ns}
        if preview_path:
            stage("preview")
            export_preview(objects, preview_path)
        result["status"] = "ok"
    except Exception as exc:  # any of them: the report must say what it was and where
        result["exception"] = batch_io.exception_record(exc, where["stage"], where["object"], where["entry"])
        result["error"] = batch_io.describe_failure(result["exception"])
    result["seconds"] = round(time.perf_counter() - t0, 4)
    return result


def worker_main(job_path):
    """Entry point inside Blender: the job file (a BatchJob as JSON, written by the launcher)
    names the input, the output, the recipe, whether to leave the positions for a preview,
    smoothness and the run's token; the result file (job.result_path) is rewritten at every
    stage, so that if Blender dies the launcher knows where."""
    # Imported here: the add-on loads (and says why it cannot run) without the compiled module.
    from deformkit.batch import shared as batch_io
    from deformkit.batch import job as batch_job
    text = batch_io.read_regular_file(job_path, batch_io.STATE_FILE_LIMIT).decode("utf-8")
    job = batch_job.BatchJob.from_json(text)

    def write(result, where=None):
        progress = {**result, "blender": bpy.app.version_string}
        if where is not None:
            progress.update(status="running", stage={k: where[k] for k in ("stage", "object", "entry")})
        batch_io.write_json_atomically(job.result_path, progress, job.token)

    def progress(result, where):
        try:
            write(result, where)
        except (OSError, ValueError, TypeError):
            pass  # only a hint for a crash; the final result says what happened

    try:
        result = process(job.input, job.output, job.recipe, job.preview_path, job.smoothness, job.token,
                         on_stage=progress)
    except Exception as exc:  # a bug of ours: still a result, with its traceback's last frames
        record = batch_io.exception_record(exc, "worker")
        result = batch_io.file_row(job.input, job.output, exception=record)
    try:
        write(result)
    except OSError as exc:  # e.g. a full disk: the launcher reads this line from stdout instead
        print(batch_io.RESULT_LINE + json.dumps({**result, "result_file_error": str(exc)}, default=str), flush=True)
    return 0 if result["status"] == "ok" else 1

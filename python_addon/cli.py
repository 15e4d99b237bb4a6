"""deformkit-batch: run deformkit stacks over many .blend files without a window.

    deformkit-batch INPUT... --out DIR [--recipe FILE | --evaluate-saved] [--jobs N]
                    [--blender PATH] [--report PATH] [--preview] [--smoothness] [--timeout SECONDS]

Each input runs in its own `blender -b --factory-startup` process with the add-on enabled. Outputs
go to DIR/<name>.blend (written under a temporary name, then renamed; an input is never
overwritten), with a JSON report (per file: objects, vertex counts, time, status, error) and, with
--preview, a before/after PNG per file. A failed file does not stop the others; the exit status
is 1 if any failed. With --smoothness (or "smoothness": true in the recipe) each object's report
also has the smoothness figures of its cage (largest normal angle, gap, degenerate and flipped
samples, worst edges). Recipes are JSON or TOML:

    {"objects": ["Suzanne"], "deformers": [{"type": "TWIST", "angle": 1.57, "deform_axis": "Z"},
                                           {"type": "SUBDIVIDE", "levels": 2}]}

This module needs no bpy: it only starts Blender. Run it with the project's Python
(`scripts/deformkit-batch`), which also has matplotlib for the pictures.
"""
import argparse
import concurrent.futures
import datetime
import glob
import json
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time

ADDON_DIR = os.path.dirname(os.path.abspath(__file__))
BLEND_MAGIC = (b"BLENDER", b"\x1f\x8b", b"\x28\xb5\x2f\xfd")  # plain, gzip, zstd
WORKER = """
import sys
sys.path[:0] = {paths!r}
import deformkit_addon
deformkit_addon.register()
from deformkit_addon import batch
sys.exit(batch.worker_main())
"""


def expand_inputs(patterns):
    paths = []
    for pattern in patterns:
        matches = sorted(glob.glob(pattern)) if glob.has_magic(pattern) else [pattern]
        paths += matches or [pattern]  # an unmatched glob is reported as missing
    return list(dict.fromkeys(os.path.abspath(p) for p in paths))


def same_file(a, b):
    """True when a and b are the same file, through symbolic links and hard links too."""
    try:
        return os.path.samefile(a, b)
    except OSError:  # one does not exist (yet): compare the resolved paths
        return os.path.realpath(a) == os.path.realpath(b)


def input_problem(path):
    if not os.path.exists(path):
        return "file not found"
    if not os.path.isfile(path):
        return "not a file"
    with open(path, "rb") as fh:
        head = fh.read(8)
    if not head.startswith(BLEND_MAGIC):
        return "not a .blend file (no BLENDER header)"
    return ""


def load_recipe(path):
    with open(path, "rb") as fh:
        data = fh.read()
    try:
        if path.endswith(".toml"):
            import tomllib
            recipe = tomllib.loads(data.decode())
        else:
            recipe = json.loads(data)
    except ValueError as exc:
        raise SystemExit(f"deformkit-batch: recipe {path}: {exc}")
    if not isinstance(recipe, dict) or not isinstance(recipe.get("deformers"), list) or not recipe["deformers"]:
        raise SystemExit(f"deformkit-batch: recipe {path}: needs a non-empty 'deformers' list")
    for i, spec in enumerate(recipe["deformers"]):
        if not isinstance(spec, dict) or "type" not in spec:
            raise SystemExit(f"deformkit-batch: recipe {path}: deformer {i} needs a 'type'")
    objects = recipe.setdefault("objects", ["*"])
    if not isinstance(objects, list) or not all(isinstance(o, str) for o in objects):
        raise SystemExit(f"deformkit-batch: recipe {path}: 'objects' must be a list of names")
    return recipe


def output_names(inputs, out_dir):
    """DIR/<stem>.blend for each input, made unique when two inputs share a name."""
    taken, outputs = set(), []
    for path in inputs:
        stem = os.path.splitext(os.path.basename(path))[0]
        name, i = stem, 1
        while name in taken:
            name, i = f"{stem}_{i}", i + 1
        taken.add(name)
        outputs.append(os.path.join(out_dir, name + ".blend"))
    return outputs


def staging_paths(tmp):
    """A folder with the add-on under its package name and one with only the deformkit module."""
    addons, lib = os.path.join(tmp, "addons"), os.path.join(tmp, "lib")
    os.makedirs(addons)
    os.makedirs(lib)
    os.symlink(ADDON_DIR, os.path.join(addons, "deformkit_addon"))
    try:
        import deformkit
        os.symlink(os.path.dirname(deformkit.__file__), os.path.join(lib, "deformkit"))
    except ImportError:
        pass  # the add-on then reports the missing module for every file
    return [addons, lib]


def run_one(blender, paths, src, dst, recipe, preview, timeout, work, smoothness=False):
    result_path = os.path.join(work, os.path.basename(dst) + ".json")
    problem = input_problem(src)
    if problem:
        return {"file": src, "output": dst, "status": "failed", "error": problem, "objects": [], "seconds": 0.0}
    cmd = [blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python-expr",
           WORKER.format(paths=paths), "--", src, dst, result_path, json.dumps(recipe) if recipe else "",
           preview or "", "1" if smoothness else ""]
    t0 = time.perf_counter()
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"file": src, "output": dst, "status": "failed", "error": f"timed out after {timeout} s",
                "objects": [], "seconds": round(time.perf_counter() - t0, 3)}
    try:
        with open(result_path) as fh:
            result = json.load(fh)
        result["process_seconds"] = round(time.perf_counter() - t0, 3)  # Blender start-up included
        return result
    except (OSError, ValueError):
        tail = (proc.stderr or proc.stdout).strip().splitlines()[-5:]
        return {"file": src, "output": dst, "status": "failed", "objects": [], "seconds": round(time.perf_counter() - t0, 3),
                "error": f"Blender exited with status {proc.returncode}: " + " | ".join(tail)}


def render_preview(npz_path, png_path, title):
    import numpy as np
    from deformkit.preview import Z_UP, render_before_after
    data = np.load(npz_path)
    render_before_after(png_path, data["before"], data["after"], data["faces"], title, to_plot=Z_UP)


def write_json(path, data):
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w") as fh:
        json.dump(data, fh, indent=2)
    os.replace(tmp, path)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="deformkit-batch", description=__doc__.splitlines()[0])
    ap.add_argument("inputs", nargs="+", help=".blend files or glob patterns")
    ap.add_argument("--out", required=True, help="output folder (created if missing)")
    how = ap.add_mutually_exclusive_group(required=True)
    how.add_argument("--recipe", help="JSON or TOML recipe: objects and deformers to add")
    how.add_argument("--evaluate-saved", action="store_true", help="re-evaluate the stacks saved in the files")
    ap.add_argument("--jobs", type=int, default=1, help="files processed in parallel (default 1)")
    ap.add_argument("--blender", default=os.environ.get("DEFORMKIT_BLENDER", "blender"))
    ap.add_argument("--report", help="report path (default OUT/report.json)")
    ap.add_argument("--preview", action="store_true", help="write a before/after PNG per file")
    ap.add_argument("--smoothness", action="store_true",
                    help="add each object's smoothness figures (dk.smoothness_report of its cage) to the report")
    ap.add_argument("--timeout", type=float, default=600.0, help="seconds per file")
    args = ap.parse_args(argv)
    if args.jobs < 1:
        ap.error("--jobs must be at least 1")
    blender = shutil.which(args.blender) or (args.blender if os.path.isfile(args.blender) else None)
    if blender is None:
        ap.error(f"--blender: '{args.blender}' not found (install Blender or pass its path)")
    recipe = load_recipe(args.recipe) if args.recipe else None
    inputs = expand_inputs(args.inputs)
    out_dir = os.path.abspath(args.out)
    os.makedirs(out_dir, exist_ok=True)
    outputs = output_names(inputs, out_dir)
    report_path = args.report or os.path.join(out_dir, "report.json")
    if any(same_file(report_path, p) for p in inputs):
        ap.error(f"--report: {report_path} is one of the inputs")

    started = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    results, lock, done = [None] * len(inputs), threading.Lock(), [0]
    with tempfile.TemporaryDirectory(prefix="deformkit_batch_") as work:
        paths = staging_paths(work)

        def job(i):
            src, dst = inputs[i], outputs[i]
            preview = os.path.join(work, f"{i}.npz") if args.preview else None
            if any(same_file(dst, other) for other in inputs):
                result = {"file": src, "output": dst, "status": "failed", "objects": [], "seconds": 0.0,
                          "error": f"refusing to write {dst}: it is one of the inputs"}
            else:
                result = run_one(blender, paths, src, dst, recipe, preview, args.timeout, work, args.smoothness)
            if result["status"] != "ok":  # a Blender killed mid-save leaves its temporary file
                for leftover in glob.glob(glob.escape(dst) + ".tmp*") + glob.glob(glob.escape(dst) + "@"):
                    os.unlink(leftover)
            if result["status"] == "ok" and preview and os.path.exists(preview):
                png = os.path.splitext(dst)[0] + ".png"
                try:
                    names = "; ".join(f"{o['name']} ({' then '.join(e.lower() for e in o['entries'])})"
                                      for o in result["objects"])
                    render_preview(preview, png, f"{os.path.basename(src)}: {names}")
                    result["preview"] = png
                except Exception as exc:  # a picture is a bonus; report, don't fail the file
                    result["preview_error"] = str(exc)
            with lock:
                done[0] += 1
                status = "ok" if result["status"] == "ok" else "FAILED: " + result["error"]
                print(f"[{done[0]}/{len(inputs)}] {os.path.basename(src)}: {status} "
                      f"({len(result['objects'])} objects, {result['seconds']:.2f} s)", flush=True)
            results[i] = result

        with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
            list(pool.map(job, range(len(inputs))))

    failed = sum(r["status"] != "ok" for r in results)
    write_json(report_path, {"started": started, "blender": blender, "recipe": recipe,
                             "evaluate_saved": args.evaluate_saved, "smoothness": args.smoothness,
                             "ok": len(results) - failed,
                             "failed": failed, "files": results})
    print(f"deformkit-batch: {len(results) - failed} ok, {failed} failed; report: {report_path}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

"""deformkit-batch: run deformkit stacks over many .blend files without a window.

    deformkit-batch INPUT... --out DIR [--recipe FILE | --evaluate-saved] [--jobs N]
                    [--blender PATH] [--report PATH] [--preview] [--smoothness] [--timeout SECONDS]

Each input runs in its own `blender -b --factory-startup` process with the add-on enabled. Outputs
go to DIR/<name>.blend (written under a temporary name unique to the run, then renamed; an input
is never overwritten), with a JSON report (per file: objects, vertex counts, time, status, error,
the exception's type, message, stage, object and recipe entry, and warnings such as what Blender
said while reading a damaged file) and, with --preview, a before/after PNG per file. The report is
rewritten (atomically) after every file, so a run that is killed leaves one of what finished. A
failed file does not stop the others; the exit status is 1 if any failed, 2 for a bad command
line or recipe (one line naming the argument, before any file is opened). With --smoothness (or
"smoothness": true in the recipe) each object's report also has the smoothness figures of its
cage. Recipes are JSON or TOML, checked against the add-on's own property ranges:

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
import math
import os
import shutil
import sys
import tempfile
import threading

import batch_io
import batch_launch
import recipe_schema


class Parser(argparse.ArgumentParser):
    def error(self, message):
        """One line, as the issue asks of every bad command line, then exit status 2."""
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def seconds_per_file(text):
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got {text!r}") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"expected a finite number of seconds above 0, got {text!r}")
    return value


def job_count(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number of files at a time, got {text!r}") from None
    if not 1 <= value <= 256:
        raise argparse.ArgumentTypeError(f"expected 1..256 files at a time, got {text!r}")
    return value


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


def without_duplicates(pairs):
    keys = [k for k, _ in pairs]
    twice = sorted({k for k in keys if keys.count(k) > 1})
    if twice:  # json keeps the last silently; TOML refuses, and so do we
        raise ValueError(f"key {twice[0]!r} given twice in one table")
    return dict(pairs)


def parse_recipe(path, data):
    try:
        if path.endswith(".toml"):
            import tomllib
            return tomllib.loads(data.decode("utf-8"))
        return json.loads(data, object_pairs_hook=without_duplicates)
    except RecursionError:  # the parsers recurse per level; a recipe needs four
        raise ValueError("nested too deeply (a recipe needs four levels: recipe, deformers, entry, limits)")
    except UnicodeDecodeError as exc:
        raise ValueError(f"not UTF-8 text ({exc.reason} at byte {exc.start})")
    except ValueError as exc:
        raise ValueError(f"not valid {'TOML' if path.endswith('.toml') else 'JSON'}: {exc}")


def load_recipe(ap, path):
    """The checked recipe, or a one-line error naming --recipe and every bad key path."""
    if not os.path.exists(path):
        ap.error(f"--recipe: {path} not found")
    if os.path.isdir(path):
        ap.error(f"--recipe: {path} is a folder, not a recipe file")
    try:
        with open(path, "rb") as fh:
            data = fh.read()
        return recipe_schema.validate(parse_recipe(path, data))
    except OSError as exc:
        ap.error(f"--recipe: cannot read {path}: {exc.strerror}")
    except ValueError as exc:  # RecipeError included
        ap.error(f"--recipe: {path}: {exc}")


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


def check_out_folder(ap, out):
    if os.path.exists(out) and not os.path.isdir(out):
        ap.error(f"--out: {out} is a file, not a folder")
    try:
        os.makedirs(out, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".deformkit-probe-", dir=out)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        ap.error(f"--out: cannot write in {out}: {exc.strerror}")


def check_report_path(ap, report, inputs, outputs, recipe_path):
    if os.path.isdir(report):
        ap.error(f"--report: {report} is a folder; give a file name")
    if not os.path.isdir(os.path.dirname(report)):
        ap.error(f"--report: folder {os.path.dirname(report)} does not exist")
    for kind, paths in (("input", inputs), ("output", outputs), ("recipe", [recipe_path] if recipe_path else [])):
        for path in paths:
            if same_file(report, path):
                ap.error(f"--report: {report} is the {kind} {path}; the report would overwrite it")


def render_preview(npz_path, png_path, title):
    import numpy as np
    from deformkit.preview import Z_UP, render_before_after
    data = np.load(npz_path)
    render_before_after(png_path, data["before"], data["after"], data["faces"], title, to_plot=Z_UP)


class Report:
    """The report file, rewritten atomically after every file: files not done yet are "pending"."""

    def __init__(self, path, token, header, inputs, outputs):
        self.path, self.token, self.header, self.lock, self.problem = path, token, header, threading.Lock(), ""
        self.rows = [{"file": s, "output": d, "status": "pending", "error": "", "objects": [], "warnings": []}
                     for s, d in zip(inputs, outputs)]
        self.write()  # before any file: a report that cannot be written is a bad --report

    def write(self, complete=False):
        done = [r for r in self.rows if r["status"] != "pending"]
        failed = sum(r["status"] != "ok" for r in done)
        batch_io.write_json_atomically(self.path, {
            **self.header, "complete": complete, "ok": len(done) - failed, "failed": failed,
            "pending": len(self.rows) - len(done), "files": self.rows}, self.token)

    def record(self, i, row, complete=False):
        with self.lock:
            if row is not None:
                self.rows[i] = row
            try:
                self.write(complete)
                self.problem = ""
            except OSError as exc:  # e.g. the disk filled up: keep going, say so at the end
                self.problem = f"cannot write the report {self.path}: {exc.strerror or exc}"


def run_file(i, ctx):
    src, dst = ctx["inputs"][i], ctx["outputs"][i]
    args, work = ctx["args"], ctx["work"]
    preview = os.path.join(work, f"{i}.npz") if args.preview else None
    if any(same_file(dst, other) for other in ctx["inputs"]):
        return batch_launch.failed_row(src, dst, "InputError", f"refusing to write {dst}: it is one of the inputs")
    job = {"input": src, "output": dst, "result": os.path.join(work, f"{i}.json"), "recipe": ctx["recipe"],
           "preview": preview, "smoothness": args.smoothness, "token": ctx["token"]}
    result = batch_launch.run_one(ctx["blender"], ctx["env"], ctx["paths"], job, args.timeout)
    if result["status"] == "ok" and preview and os.path.exists(preview):
        png = os.path.splitext(dst)[0] + ".png"
        try:
            names = "; ".join(f"{o['name']} ({' then '.join(e.lower() for e in o['entries'])})"
                              for o in result["objects"])
            render_preview(preview, png, f"{os.path.basename(src)}: {names}")
            result["preview"] = png
        except Exception as exc:  # a picture is a bonus; report, don't fail the file
            result["preview_error"] = f"{type(exc).__name__}: {exc}"
    return result


def console_line(n, total, result):
    status = "ok" if result["status"] == "ok" else "FAILED: " + result["error"]
    warned = f", {len(result['warnings'])} warnings" if result.get("warnings") else ""
    return (f"[{n}/{total}] {os.path.basename(result['file'])}: {status} "
            f"({len(result['objects'])} objects, {result.get('seconds', 0.0):.2f} s{warned})")


def arguments(argv):
    ap = Parser(prog="deformkit-batch", description=__doc__.splitlines()[0])
    ap.add_argument("inputs", nargs="+", help=".blend files or glob patterns")
    ap.add_argument("--out", required=True, help="output folder (created if missing)")
    how = ap.add_mutually_exclusive_group(required=True)
    how.add_argument("--recipe", help="JSON or TOML recipe: objects and deformers to add")
    how.add_argument("--evaluate-saved", action="store_true", help="re-evaluate the stacks saved in the files")
    ap.add_argument("--jobs", type=job_count, default=1, help="files processed in parallel (default 1)")
    ap.add_argument("--blender", default=os.environ.get("DEFORMKIT_BLENDER", "blender"))
    ap.add_argument("--report", help="report path (default OUT/report.json); its folder must exist")
    ap.add_argument("--preview", action="store_true", help="write a before/after PNG per file")
    ap.add_argument("--smoothness", action="store_true",
                    help="add each object's smoothness figures (dk.smoothness_report of its cage) to the report")
    ap.add_argument("--timeout", type=seconds_per_file, default=600.0, help="seconds per file (finite, above 0)")
    return ap, ap.parse_args(argv)


def main(argv=None):
    ap, args = arguments(argv)
    blender = shutil.which(args.blender) or (args.blender if os.path.isfile(args.blender) else None)
    if blender is None:
        ap.error(f"--blender: '{args.blender}' not found (install Blender or pass its path)")
    recipe = load_recipe(ap, args.recipe) if args.recipe else None
    inputs = expand_inputs(args.inputs)
    out_dir = os.path.abspath(args.out)
    check_out_folder(ap, out_dir)
    outputs = output_names(inputs, out_dir)
    report_path = os.path.abspath(args.report or os.path.join(out_dir, "report.json"))
    check_report_path(ap, report_path, inputs, outputs, args.recipe)

    token = batch_io.new_run_token()
    env, dropped = batch_launch.blender_environment(blender)
    header = {"started": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
              "blender": blender, "recipe": recipe, "evaluate_saved": args.evaluate_saved,
              "smoothness": args.smoothness, "path_left_out_for_blender": dropped}
    with batch_launch.runs_locked():
        batch_launch.clean_stale_staging()
        for staging, other in batch_launch.live_runs().items():
            if other == os.path.realpath(report_path):
                ap.error(f"--report: {report_path} is the report of a run in progress ({staging}); "
                         "give this run its own --report")
        work, paths = batch_launch.make_staging(token, report_path)
    try:
        try:
            report = Report(report_path, token, header, inputs, outputs)
        except OSError as exc:
            ap.error(f"--report: cannot write {report_path}: {exc.strerror or exc}")
        ctx = {"inputs": inputs, "outputs": outputs, "args": args, "work": work, "recipe": recipe,
               "blender": blender, "env": env, "paths": paths, "token": token}
        done = [0]

        def job(i):
            try:
                result = run_file(i, ctx)
            except Exception as exc:  # the launcher's own trouble with this file still gets a row
                result = batch_launch.failed_row(inputs[i], outputs[i], type(exc).__name__, str(exc), "launch")
            with report.lock:
                done[0] += 1
                print(console_line(done[0], len(inputs), result), flush=True)
            report.record(i, result)

        with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
            list(pool.map(job, range(len(inputs))))
        report.header["finished"] = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
        report.record(0, None, complete=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    failed = sum(r["status"] != "ok" for r in report.rows)
    if report.problem:
        print(f"deformkit-batch: {report.problem}", file=sys.stderr)
        return 1
    print(f"deformkit-batch: {len(inputs) - failed} ok, {failed} failed; report: {report_path}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

"""deformkit-batch: run deformkit stacks over many .blend files without a window.

    deformkit-batch INPUT... --out DIR [--recipe FILE | --evaluate-saved] [--jobs N]
                    [--blender PATH] [--addon PATH] [--report PATH] [--preview] [--smoothness]
                    [--timeout SECONDS] [--scheduler tls://HOST:PORT --tls-ca-file CA --tls-cert CERT
                    --tls-key KEY | --scheduler tcp://HOST:PORT | --executor dask-local
                    [--workers N] [--blender-per-worker N]] [--retries N] [--redo-complete]

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

On a Dask cluster (`--scheduler tls://HOST:PORT` with the cluster's CA and this launcher's
certificate, tcp:// on one machine only, or `--executor dask-local --workers N` for a
LocalCluster on this machine; options in cluster_cli.py) each input is one task on the worker that
picks it, with inputs and outputs by path on storage all workers share, retries when a worker dies
(`--retries`, attempts.py) and per file the worker, the attempts and the queue time in the report.
Local processes or a cluster, main goes through one interface (places.py) in named stages.

This package needs no bpy: it only starts Blender, on one job file per input (BatchJob, run by
run_job on an executor: local processes, --jobs at a time, or Dask tasks). Run it with the project's Python
(`scripts/deformkit-batch`, or `python -m deformkit.batch`), which also has matplotlib for the
pictures. The add-on Blender runs is --addon (default: $DEFORMKIT_ADDON, else an importable
deformkit_addon, else the python_addon/ folder of the checkout this package is in); the recipe is
checked against that add-on's own property definitions (its recipe_schema.py).
"""
import argparse
import glob
import importlib.util
import itertools
import json
import math
import os
import shutil
import sys
import tempfile
from typing import NamedTuple

from . import cluster_cli, places, shared, staging
from .job import BatchJob
from .report import Report, console_line, utc_now
from .run import blender_environment, same_file

# A source checkout: python/deformkit/batch/cli.py, beside python_addon/.
CHECKOUT_ADDON = os.path.join(os.path.dirname(os.path.abspath(__file__)), *[os.pardir] * 3, "python_addon")


RECIPE_LIMIT = 4 * 1024 * 1024  # bytes; a recipe of every entry kind with long object lists is a few KB


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


def without_duplicates(pairs):
    keys = [k for k, _ in pairs]
    twice = sorted({k for k in keys if keys.count(k) > 1})
    if twice:  # json keeps the last silently; TOML refuses, and so do we
        raise ValueError(f"key {twice[0]!r} given twice in one table")
    return dict(pairs)


def parse_recipe(path, data):
    try:
        text = data.decode("utf-8")  # not json's guess among UTF-8, -16 and -32: a recipe is UTF-8
        if path.endswith(".toml"):
            import tomllib
            return tomllib.loads(text)
        return json.loads(text, object_pairs_hook=without_duplicates)
    except RecursionError:  # the parsers recurse per level; a recipe needs four
        raise ValueError("nested too deeply (a recipe needs four levels: recipe, deformers, entry, limits)")
    except UnicodeDecodeError as exc:
        raise ValueError(f"not UTF-8 text ({exc.reason} at byte {exc.start})")
    except ValueError as exc:
        raise ValueError(f"not valid {'TOML' if path.endswith('.toml') else 'JSON'}: {exc}")


def addon_folder(ap, given):
    """The add-on's folder (python_addon/, holding __init__.py and recipe_schema.py), or a
    one-line error naming --addon."""
    if given is None:
        spec = importlib.util.find_spec("deformkit_addon")
        if spec is not None and spec.submodule_search_locations:
            given = list(spec.submodule_search_locations)[0]
        elif os.path.isfile(os.path.join(CHECKOUT_ADDON, "recipe_schema.py")):
            given = CHECKOUT_ADDON
        else:
            ap.error("--addon: the deformkit add-on was not found (pass its folder, python_addon/ in the "
                     "repository, or set DEFORMKIT_ADDON)")
    folder = os.path.realpath(given)
    for name in ("__init__.py", "recipe_schema.py"):
        if not os.path.isfile(os.path.join(folder, name)):
            ap.error(f"--addon: {given} is not the deformkit add-on (no {name})")
    return folder


def load_recipe_schema(addon):
    """The add-on's recipe_schema, from its file: it reads the add-on's property definitions, and
    needs no bpy (the add-on package itself would)."""
    spec = importlib.util.spec_from_file_location("deformkit_addon_recipe_schema",
                                                  os.path.join(addon, "recipe_schema.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def load_recipe(ap, path, recipe_schema):
    """The checked recipe, or a one-line error naming --recipe and every bad key path. Only a
    regular file (after links) of at most RECIPE_LIMIT bytes is read: a FIFO, a device or a socket
    would block or never end (docs/errors.md, "Files the batch command reads")."""
    if not os.path.exists(path):
        ap.error(f"--recipe: {path} not found")
    if os.path.isdir(path):
        ap.error(f"--recipe: {path} is a folder, not a recipe file")
    try:
        data = shared.read_regular_file(path, RECIPE_LIMIT)
    except shared.FileRefused as exc:
        ap.error(f"--recipe: {path} {exc}")
    except OSError as exc:
        ap.error(f"--recipe: cannot read {path}: {exc.strerror or exc}")
    try:
        return recipe_schema.validate(parse_recipe(path, data))
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


class RunFiles(NamedTuple):
    """The run's files, as absolute paths: the inputs, the output folder, the output of each input
    in it, and the report."""

    inputs: list
    out_dir: str
    outputs: list
    report: str


def run_files(ap, args):
    """The inputs (patterns expanded), the output folder (made, and written in once), the outputs'
    names and the report's path (neither a folder nor any input, output or the recipe)."""
    inputs = expand_inputs(args.inputs)
    out_dir = os.path.abspath(args.out)
    check_out_folder(ap, out_dir)
    outputs = output_names(inputs, out_dir)
    report = os.path.abspath(args.report or os.path.join(out_dir, "report.json"))
    check_report_path(ap, report, inputs, outputs, args.recipe)
    return RunFiles(inputs, out_dir, outputs, report)


def staged_run(ap, place, token, files, addon):
    """(work folder, sys paths, staged code) of the run's staging folder (places.Place.stage),
    made under the lock on the runs of this machine, after removing the stale ones; a report
    that a live run writes is refused."""
    with staging.runs_locked():
        staging.clean_stale_staging()
        for folder, other in staging.live_runs().items():
            if other == os.path.realpath(files.report):
                ap.error(f"--report: {files.report} is the report of a run in progress ({folder}); "
                         "give this run its own --report")
        return place.stage(token, files.report, addon, files.out_dir)


def build_jobs(files, work, blender, paths, token, recipe, args, staged=None):
    """One BatchJob per input, in the report's order; `staged`: a cluster run's staged code."""
    return [BatchJob(index=i, input=src, output=dst, work=work, blender=blender, token=token,
                     sys_paths=tuple(paths), recipe=recipe, preview=args.preview, smoothness=args.smoothness,
                     timeout=args.timeout, never_write=tuple(files.inputs), staged=staged)
            for i, (src, dst) in enumerate(zip(files.inputs, files.outputs))]


def report_header(blender, recipe, args, place):
    _, dropped = blender_environment(blender)
    return {"started": utc_now(), "blender": blender, "recipe": recipe, "evaluate_saved": args.evaluate_saved,
            "smoothness": args.smoothness, "path_left_out_for_blender": dropped, "executor": place.describe()}


def open_report(ap, files, token, header):
    try:
        return Report(files.report, token, header, files.inputs, files.outputs)
    except OSError as exc:
        ap.error(f"--report: cannot write {files.report}: {exc.strerror or exc}")


def shown_and_recorded(place, report, total):
    """run_all's on_row: each finished file's console line (through the place: a cluster's
    progress line) and its row in the report, in the order the files finish."""
    done = itertools.count(1)

    def on_row(job, row):
        place.show(job, console_line(next(done), total, row), row)
        report.record(job.index, row)
    return on_row


def summary(report, files):
    """The last line, and the exit status: 1 if any file failed or the report could not be written."""
    failed = sum(r["status"] != "ok" for r in report.rows)
    if report.problem:
        print(f"deformkit-batch: {report.problem}", file=sys.stderr)
        return 1
    print(f"deformkit-batch: {len(files.inputs) - failed} ok, {failed} failed; report: {files.report}")
    return 1 if failed else 0


def arguments(argv):
    ap = Parser(prog="deformkit-batch", description=__doc__.splitlines()[0])
    ap.add_argument("inputs", nargs="+", help=".blend files or glob patterns")
    ap.add_argument("--out", required=True, help="output folder (created if missing)")
    how = ap.add_mutually_exclusive_group(required=True)
    how.add_argument("--recipe", help="JSON or TOML recipe: objects and deformers to add")
    how.add_argument("--evaluate-saved", action="store_true", help="re-evaluate the stacks saved in the files")
    ap.add_argument("--jobs", type=job_count, help="files processed in parallel on this machine (default 1)")
    ap.add_argument("--blender", default=os.environ.get("DEFORMKIT_BLENDER", "blender"))
    ap.add_argument("--addon", default=os.environ.get("DEFORMKIT_ADDON"),
                    help="the deformkit add-on's folder (python_addon/ in the repository)")
    ap.add_argument("--report", help="report path (default OUT/report.json); its folder must exist")
    ap.add_argument("--preview", action="store_true", help="write a before/after PNG per file")
    ap.add_argument("--smoothness", action="store_true",
                    help="add each object's smoothness figures (dk.smoothness_report of its cage) to the report")
    ap.add_argument("--timeout", type=seconds_per_file, default=600.0, help="seconds per file (finite, above 0)")
    cluster_cli.add_arguments(ap, seconds_per_file)
    return ap, ap.parse_args(argv)


def find_blender(ap, given, here):
    """--blender's path; `here` (places.Place.blender_here): it must be found on this machine,
    else each worker of a scheduler's cluster must find it (checked there)."""
    found = shutil.which(given) or (given if os.path.isfile(given) else None)
    if found is None and here:
        ap.error(f"--blender: '{given}' not found (install Blender or pass its path)")
    return found or given


def main(argv=None, client=None):
    """The command; 0 when every file went well, 1 if any failed, 2 for a bad command line.
    `client` (Python only): a distributed.Client, or a scheduler's address, for code that drives
    its own Dask cluster; the run goes there as with --scheduler, and the client stays open."""
    ap, args = arguments(argv)
    place = places.chosen(ap, args, client)
    blender = find_blender(ap, args.blender, place.blender_here)
    addon = addon_folder(ap, args.addon)
    recipe = load_recipe(ap, args.recipe, load_recipe_schema(addon)) if args.recipe else None
    files = run_files(ap, args)
    place.open(ap)
    token, work = shared.new_run_token(), None
    try:
        header = report_header(blender, recipe, args, place)
        work, paths, staged = staged_run(ap, place, token, files, addon)
        jobs = build_jobs(files, work, blender, paths, token, recipe, args, staged)
        place.check(ap, jobs)
        report = open_report(ap, files, token, header)
        place.run(jobs, shown_and_recorded(place, report, len(jobs)))
        report.finish()
    finally:
        place.close(files.outputs, token)
        if work is not None:
            staging.remove_staging(work)
    return summary(report, files)


if __name__ == "__main__":
    sys.exit(main())

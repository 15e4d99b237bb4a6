"""deformkit-batch: run deformkit stacks over many .blend files without a window.

    deformkit-batch INPUT... --out DIR [--recipe FILE | --evaluate-saved] [--jobs N]
                    [--blender PATH] [--addon PATH] [--report PATH] [--preview] [--smoothness]
                    [--timeout SECONDS]

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

This package needs no bpy: it only starts Blender, on one job file per input (BatchJob, run by
run_job on an executor: local processes, --jobs at a time). Run it with the project's Python
(`scripts/deformkit-batch`, or `python -m deformkit.batch`), which also has matplotlib for the
pictures. The add-on Blender runs is --addon (default: $DEFORMKIT_ADDON, else an importable
deformkit_addon, else the python_addon/ folder of the checkout this package is in); the recipe is
checked against that add-on's own property definitions (its recipe_schema.py).
"""
import argparse
import datetime
import glob
import importlib.util
import json
import math
import os
import re
import shutil
import sys
import tempfile

from . import shared, staging
from .executors import LocalProcessExecutor, run_all
from .job import BatchJob
from .report import Progress, Report, console_line
from .run import blender_environment, input_problem, same_file

# A source checkout: python/deformkit/batch/cli.py, beside python_addon/.
CHECKOUT_ADDON = os.path.join(os.path.dirname(os.path.abspath(__file__)), *[os.pardir] * 3, "python_addon")


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


def scheduler_address(text):
    if not re.fullmatch(r"(tcp|tls)://[^\s/:]+:\d{1,5}", text):
        raise argparse.ArgumentTypeError(f"expected a scheduler address tcp://HOST:PORT, got {text!r}")
    return text


def count_of(what, least, most):
    def parse(text):
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number of {what}, got {text!r}") from None
        if not least <= value <= most:
            raise argparse.ArgumentTypeError(f"expected {least}..{most} {what}, got {text!r}")
        return value
    return parse


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


def build_jobs(inputs, outputs, work, blender, paths, token, recipe, args):
    """One BatchJob per input, in the report's order."""
    return [BatchJob(index=i, input=src, output=dst, work=work, blender=blender, token=token,
                     sys_paths=tuple(paths), recipe=recipe, preview=args.preview, smoothness=args.smoothness,
                     timeout=args.timeout, never_write=tuple(inputs))
            for i, (src, dst) in enumerate(zip(inputs, outputs))]


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
    dask = ap.add_argument_group("on a Dask cluster (docs/batch.md)")
    dask.add_argument("--scheduler", type=scheduler_address,
                      help="run every file as a task on the Dask scheduler at tcp://HOST:PORT")
    dask.add_argument("--executor", choices=("local", "dask-local"),
                      help="local: processes of this machine (the default); dask-local: a Dask LocalCluster")
    dask.add_argument("--workers", type=count_of("workers", 1, 256), help="dask-local: worker processes (default 2)")
    dask.add_argument("--blender-per-worker", type=count_of("Blenders per worker", 1, 64),
                      help="dask-local: files each worker runs at a time (threads and blender resource; default 1)")
    dask.add_argument("--retries", type=count_of("retries", 0, 100),
                      help="times a file is sent again when the worker running it dies (default 2)")
    dask.add_argument("--redo-complete", action="store_true",
                      help="redo a file an earlier attempt of this run had completed before its worker died")
    dask.add_argument("--connect-timeout", type=seconds_per_file,
                      help="seconds to reach the scheduler and for a worker to join (default 30)")
    return ap, ap.parse_args(argv)


DASK_ONLY = ("retries", "redo_complete")
LOCAL_CLUSTER_ONLY = ("workers", "blender_per_worker")


def option(name):
    return "--" + name.replace("_", "-")


def executor_kind(ap, args, client):
    """"local", "dask-local" or "dask" (a scheduler: --scheduler, or the client or address of the
    Python API), or a one-line error naming the argument that does not fit."""
    if client is not None and (args.scheduler or args.executor):
        ap.error(f"{'--scheduler' if args.scheduler else '--executor'}: the run already has a Dask client "
                 "(main(..., client=...)); give one or the other")
    if args.scheduler and args.executor:
        ap.error(f"--executor: {args.executor} cannot be combined with --scheduler (a scheduler's cluster runs "
                 "the files)")
    kind = "dask" if args.scheduler or client is not None else args.executor or "local"
    if kind != "local" and args.jobs is not None:
        ap.error("--jobs: for local processes only; on Dask each worker runs as many files as it has units of "
                 "the blender resource (--blender-per-worker with dask-local)")
    wrong = [n for n in DASK_ONLY if getattr(args, n) not in (None, False)] if kind == "local" else []
    wrong += [n for n in LOCAL_CLUSTER_ONLY if getattr(args, n) is not None] if kind != "dask-local" else []
    if wrong:
        where = "--executor dask-local" if wrong[0] in LOCAL_CLUSTER_ONLY else "--scheduler or --executor dask-local"
        ap.error(f"{option(wrong[0])}: only with {where}")
    if kind != "dask" and args.connect_timeout is not None:
        ap.error("--connect-timeout: only with --scheduler (a LocalCluster is started here)")
    if kind != "local":
        from .dask_executor import PINS, dask_installed
        if not dask_installed():
            ap.error(f"{'--executor dask-local' if kind == 'dask-local' else '--scheduler'}: needs dask and "
                     f"distributed, which are not installed here; install {PINS}")
    return kind


def find_blender(ap, given, kind):
    found = shutil.which(given) or (given if os.path.isfile(given) else None)
    if found is None and kind != "dask":  # on a scheduler's cluster, each worker must find it (checked there)
        ap.error(f"--blender: '{given}' not found (install Blender or pass its path)")
    return found or given


def open_cluster(ap, args, kind, client):
    """The Dask cluster of the run (dask_executor.Cluster), or a one-line error."""
    from . import dask_executor
    timeout = args.connect_timeout or 30.0
    try:
        if kind == "dask-local":
            return dask_executor.Cluster.start_local(args.workers or 2, args.blender_per_worker or 1)
        if client is None or isinstance(client, str):
            return dask_executor.Cluster.connect(args.scheduler or client, timeout)
        return dask_executor.Cluster(client, wait=timeout)
    except dask_executor.ClusterError as exc:
        ap.error(str(exc))


def check_cluster(ap, cluster, jobs):
    """Every worker must read the inputs the launcher reads, write the output folder, see the
    staging folder and find Blender; else one line naming the worker and the path (exit 2)."""
    from . import dask_executor
    readable = [j.input for j in jobs if not input_problem(j.input)]
    try:
        dask_executor.check_workers(cluster.client, cluster.workers, readable, os.path.dirname(jobs[0].output),
                                    jobs[0].work, jobs[0].blender)
    except dask_executor.ClusterError as exc:
        ap.error(str(exc))


def run_on_cluster(cluster, args, jobs, on_row):
    """The jobs as tasks on the Dask cluster, with the live progress line."""
    from . import attempts, dask_executor
    retries = 2 if args.retries is None else args.retries
    plan = attempts.AttemptPlan(staging=jobs[0].work, token=jobs[0].token, max_attempts=retries + 1,
                                redo_complete=args.redo_complete)
    progress = Progress(len(jobs))
    topic = f"deformkit-batch-{plan.token}"
    cluster.client.subscribe_topic(topic, lambda event: progress.event(event[1]))
    try:
        with dask_executor.DaskExecutor(cluster.client, plan) as executor:
            run_all(executor, jobs, lambda job, row: on_row(job, row, progress))
    finally:
        cluster.client.unsubscribe_topic(topic)
        progress.close()


def main(argv=None, client=None):
    """The command; 0 when every file went well, 1 if any failed, 2 for a bad command line.
    `client` (Python only): a distributed.Client, or a scheduler's address, for code that drives
    its own Dask cluster; the run goes there as with --scheduler, and the client stays open."""
    ap, args = arguments(argv)
    kind = executor_kind(ap, args, client)
    blender = find_blender(ap, args.blender, kind)
    addon = addon_folder(ap, args.addon)
    recipe = load_recipe(ap, args.recipe, load_recipe_schema(addon)) if args.recipe else None
    inputs = expand_inputs(args.inputs)
    out_dir = os.path.abspath(args.out)
    check_out_folder(ap, out_dir)
    outputs = output_names(inputs, out_dir)
    report_path = os.path.abspath(args.report or os.path.join(out_dir, "report.json"))
    check_report_path(ap, report_path, inputs, outputs, args.recipe)
    cluster = open_cluster(ap, args, kind, client) if kind != "local" else None

    token = shared.new_run_token()
    _, dropped = blender_environment(blender)
    header = {"started": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
              "blender": blender, "recipe": recipe, "evaluate_saved": args.evaluate_saved,
              "smoothness": args.smoothness, "path_left_out_for_blender": dropped,
              "executor": describe_executor(kind, args, cluster)}
    work = None
    try:
        with staging.runs_locked():
            staging.clean_stale_staging()
            for folder, other in staging.live_runs().items():
                if other == os.path.realpath(report_path):
                    ap.error(f"--report: {report_path} is the report of a run in progress ({folder}); "
                             "give this run its own --report")
            if cluster is None:
                work, paths = staging.make_staging(token, report_path, addon)
            else:  # on storage the workers share: OUT/.deformkit-batch-<token>
                staging.clean_stale_shared_staging(out_dir)
                work, paths = staging.make_shared_staging(token, report_path, addon, out_dir)
        jobs = build_jobs(inputs, outputs, work, blender, paths, token, recipe, args)
        if cluster is not None and jobs:
            check_cluster(ap, cluster, jobs)
            where = f"the Dask scheduler {cluster.address}" if kind == "dask" else "a Dask LocalCluster"
            print(f"deformkit-batch: {len(jobs)} files on {where}: {len(cluster.workers)} workers, "
                  f"{cluster.slots} files at a time; dashboard: {cluster.dashboard or 'none (needs bokeh beside the scheduler)'}",
                  flush=True)
        try:
            report = Report(report_path, token, header, inputs, outputs)
        except OSError as exc:
            ap.error(f"--report: cannot write {report_path}: {exc.strerror or exc}")
        done = [0]

        def on_row(job, row, progress=None):
            done[0] += 1
            line = console_line(done[0], len(inputs), row)
            if progress is None:
                print(line, flush=True)
            else:
                tried = len(row.get("attempts") or [])
                progress.finished(job.index, line + (f" on {row.get('worker')}" if row.get("worker") else "")
                                  + (f", {tried} attempts" if tried > 1 else ""), row)
            report.record(job.index, row)

        if cluster is None:
            with LocalProcessExecutor(args.jobs or 1) as executor:
                run_all(executor, jobs, on_row, window=args.jobs or 1)
        elif jobs:
            run_on_cluster(cluster, args, jobs, on_row)
        report.header["finished"] = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
        report.record(0, None, complete=True)
    finally:
        if work is not None:
            shutil.rmtree(work, ignore_errors=True)
        if cluster is not None:
            remove_attempt_temporaries(outputs, token)
            cluster.close()
    failed = sum(r["status"] != "ok" for r in report.rows)
    if report.problem:
        print(f"deformkit-batch: {report.problem}", file=sys.stderr)
        return 1
    print(f"deformkit-batch: {len(inputs) - failed} ok, {failed} failed; report: {report_path}")
    return 1 if failed else 0


def remove_attempt_temporaries(outputs, token):
    """A lost attempt's half file, should a worker have left one after all: its names carry the
    run token (attempts.attempt_id)."""
    for output in outputs:
        for leftover in glob.glob(glob.escape(output + shared.TEMP_MARK + token) + "-f*"):
            try:
                os.unlink(leftover)
            except FileNotFoundError:
                pass


def describe_executor(kind, args, cluster):
    if cluster is None:
        return {"kind": "local", "jobs": args.jobs or 1}
    return {"kind": kind, "scheduler": cluster.address, "workers": cluster.workers, "dashboard": cluster.dashboard,
            "retries": 2 if args.retries is None else args.retries, "redo_complete": args.redo_complete}


if __name__ == "__main__":
    sys.exit(main())

"""The command line's Dask side: the options of a run on a cluster, which combinations make sense,
opening the cluster, the workers' check and the run itself (dask_executor.py), with the live
progress line. Dask is imported only through dask_executor, when a run asks for it."""
import argparse
import glob
import os
import re

from . import shared
from .executors import run_all
from .report import Progress
from .run import input_problem


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


def add_arguments(ap, seconds):
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
    dask.add_argument("--connect-timeout", type=seconds,
                      help="seconds to reach the scheduler and for a worker to join (default 30)")


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
    progress = Progress([os.path.basename(j.input) for j in jobs])
    try:
        with dask_executor.DaskExecutor(cluster.client, plan, on_event=progress.event) as executor:
            run_all(executor, jobs, lambda job, row: on_row(job, row, progress))
    finally:
        progress.close()


def remove_attempt_temporaries(outputs, token):
    """A lost attempt's half file, should a worker have left one after all: its names carry the
    run token (attempts.attempt_id)."""
    for output in outputs:
        for leftover in glob.glob(glob.escape(output + shared.TEMP_MARK + token) + "-f*"):
            try:
                os.unlink(leftover)
            except FileNotFoundError:
                pass


def opening_line(cluster, kind, files):
    where = f"the Dask scheduler {cluster.address}" if kind == "dask" else "a Dask LocalCluster"
    shown = cluster.dashboard or "none (needs bokeh beside the scheduler)"
    return (f"deformkit-batch: {files} files on {where}: {len(cluster.workers)} workers, {cluster.slots} files at a "
            f"time; dashboard: {shown}")


def describe_executor(kind, args, cluster):
    if cluster is None:
        return {"kind": "local", "jobs": args.jobs or 1}
    return {"kind": kind, "scheduler": cluster.address, "workers": cluster.workers, "dashboard": cluster.dashboard,
            "retries": 2 if args.retries is None else args.retries, "redo_complete": args.redo_complete}

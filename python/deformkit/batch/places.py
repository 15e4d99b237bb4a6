"""Where a run's jobs run: processes of this machine (`LocalProcesses`, --jobs at a time, the
default) or a Dask cluster (`DaskCluster`: --executor dask-local, --scheduler, or the client or
address given to cli.main). Both offer one interface, `Place`, which cli.main goes through in
order; what differs between them stays here, so main never asks which one it has. No Dask is
imported unless a DaskCluster is opened (cluster.py)."""
import glob
import os
import sys
from typing import Protocol

from . import attempts, cluster_cli, shared, staging
from .cluster import Cluster, ClusterError
from .dask_executor import DaskExecutor
from .executors import LocalProcessExecutor, run_all
from .preflight import check_workers
from .report import Progress
from .run import input_problem


class Place(Protocol):
    """Where the jobs run. cli.main calls open, describe (the report's "executor"), stage (under
    the staging lock), check, run (calling show for each finished file's console line) and, at
    the end whatever happened after open, close. A bad setting or an unfit place is `ap.error`:
    one line naming the argument, exit status 2."""

    blender_here: bool  # --blender must be found on this machine (not only on a cluster's workers)

    def open(self, ap) -> None: ...

    def describe(self) -> dict: ...

    def stage(self, token: str, report_path: str, addon: str, out_dir: str) -> tuple: ...

    def check(self, ap, jobs: list) -> None: ...

    def run(self, jobs: list, on_row) -> None: ...

    def show(self, job, line: str, row: dict) -> None: ...

    def close(self, outputs: list, token: str) -> None: ...


def chosen(ap, args, client=None):
    """The place the command line (and main's `client`) asks for, or a one-line error naming the
    option that does not fit; a plain tcp:// scheduler off this machine gets its warning line."""
    kind = cluster_cli.executor_kind(ap, args, client)
    if kind == "local":
        return LocalProcesses(args.jobs or 1)
    address = args.scheduler or (client if isinstance(client, str) else None)
    warning = cluster_cli.plain_tcp_warning(address) if address else None
    if warning:
        print(warning, file=sys.stderr, flush=True)
    return DaskCluster(kind, args, client)


class LocalProcesses:
    """`jobs` processes of this machine (executors.LocalProcessExecutor), with the staging folder
    in the system's temporary folder."""

    blender_here = True

    def __init__(self, jobs):
        self.jobs = jobs

    def open(self, ap):
        pass

    def describe(self):
        return {"kind": "local", "jobs": self.jobs}

    def stage(self, token, report_path, addon, out_dir):
        work, paths = staging.make_staging(token, report_path, addon)
        return work, paths, None

    def check(self, ap, jobs):
        pass

    def run(self, jobs, on_row):
        with LocalProcessExecutor(self.jobs) as executor:
            run_all(executor, jobs, on_row, window=self.jobs)

    def show(self, job, line, row):
        print(line, flush=True)

    def close(self, outputs, token):
        pass


class DaskCluster:
    """A Dask cluster: a LocalCluster started here (kind "dask-local") or a scheduler's ("dask"),
    each file one task (dask_executor.DaskExecutor) with retries when a worker dies, the staging
    folder on the storage the workers share, and a live progress line."""

    def __init__(self, kind, args, client=None):
        self.kind, self.args, self.given, self.cluster, self.progress = kind, args, client, None, None
        self.retries = 2 if args.retries is None else args.retries
        # On a scheduler's cluster each worker must find --blender (checked there), not the launcher.
        self.blender_here = kind == "dask-local"

    def open(self, ap):
        """The Dask cluster of the run (cluster.Cluster), or a one-line error."""
        args, timeout = self.args, self.args.connect_timeout or 30.0
        try:
            if self.kind == "dask-local":
                self.cluster = Cluster.start_local(args.workers or 2, args.blender_per_worker or 1)
            elif self.given is None or isinstance(self.given, str):
                address = args.scheduler or self.given
                self.cluster = Cluster.connect(address, timeout, cluster_cli.tls_security(ap, args, address))
            else:
                self.cluster = Cluster(self.given, wait=timeout)
        except ClusterError as exc:
            ap.error(str(exc))

    def describe(self):
        cluster = self.cluster
        return {"kind": self.kind, "scheduler": cluster.address, "workers": cluster.workers,
                "dashboard": cluster.dashboard, "retries": self.retries, "redo_complete": self.args.redo_complete}

    def stage(self, token, report_path, addon, out_dir):
        """On storage the workers share: OUT/.deformkit-batch-<token>."""
        staging.clean_stale_shared_staging(out_dir)
        return staging.make_shared_staging(token, report_path, addon, out_dir)

    def check(self, ap, jobs):
        """Every worker must read the inputs the launcher reads, write the output folder, see the
        staging folder and find Blender; else one line naming the worker and the path (exit 2).
        Then the run's opening line."""
        readable = [j.input for j in jobs if not input_problem(j.input)]
        try:
            check_workers(self.cluster.client, self.cluster.workers, readable, os.path.dirname(jobs[0].output),
                          jobs[0].work, jobs[0].blender)
        except ClusterError as exc:
            ap.error(str(exc))
        print(self.opening_line(len(jobs)), flush=True)

    def opening_line(self, files):
        cluster = self.cluster
        where = f"the Dask scheduler {cluster.address}" if self.kind == "dask" else "a Dask LocalCluster"
        shown = cluster.dashboard or "none (needs bokeh beside the scheduler)"
        return (f"deformkit-batch: {files} files on {where}: {len(cluster.workers)} workers, {cluster.slots} files "
                f"at a time; dashboard: {shown}")

    def run(self, jobs, on_row):
        """The jobs as tasks on the Dask cluster, with the live progress line."""
        plan = attempts.AttemptPlan(staging=jobs[0].work, token=jobs[0].token, max_attempts=self.retries + 1,
                                    redo_complete=self.args.redo_complete)
        self.progress = Progress([os.path.basename(j.input) for j in jobs])
        try:
            with DaskExecutor(self.cluster.client, plan, on_event=self.progress.event) as executor:
                run_all(executor, jobs, on_row)
        finally:
            self.progress.close()

    def show(self, job, line, row):
        tried = len(row.get("attempts") or [])
        self.progress.finished(job.index, line + (f" on {row.get('worker')}" if row.get("worker") else "")
                               + (f", {tried} attempts" if tried > 1 else ""), row)

    def close(self, outputs, token):
        """A LocalCluster's workers stop here: nothing writes in the staging folder after."""
        self.cluster.close()
        remove_attempt_temporaries(outputs, token)


def remove_attempt_temporaries(outputs, token):
    """A lost attempt's half file, should a worker have left one after all: its names carry the
    run token (attempts.attempt_id)."""
    for output in outputs:
        for leftover in glob.glob(glob.escape(output + shared.TEMP_MARK + token) + "-f*"):
            try:
                os.unlink(leftover)
            except FileNotFoundError:
                pass

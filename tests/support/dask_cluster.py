"""A real Dask cluster for the batch tests: a `dask scheduler` and `dask worker` processes of the
project's .venv on 127.0.0.1 (ports chosen by the scheduler, its address read from its scheduler
file), each worker with one thread and the resource blender=1, as docs/batch.md tells users to
start them. Each process runs in its own session, so that stop() kills its whole process group
(a worker's Blenders included) whatever state the test left it in. Their HTTP servers (dashboard,
/health) listen on 127.0.0.1 only. With `tls` (tls_certificates.make_certificates' files) the
cluster is tls:// with the commands docs/batch.md shows.

    with DaskCluster(tmp_path / "cluster", workers=2) as cluster:
        cluster.address, cluster.worker_pids()  # {worker address: pid}
"""
import json
import os
import pathlib
import signal
import subprocess
import sys
import time

# This very Python, not the `dask` script beside it: a script names the interpreter it was installed
# with, which is another checkout's when a .venv is copied (the workers would then import its deformkit).
DASK = (sys.executable, "-m", "dask")
START_SECONDS = 90.0


class DaskCluster:
    """`workers` workers without a nanny (a killed worker stays dead, as a lost machine does) or
    with one (`nanny=True`: the nanny starts a new worker process). `allowed_failures`: the
    scheduler's distributed.scheduler.allowed-failures (how often it re-runs a task whose worker
    died before it raises KilledWorker; Dask's default 3). `worker_prefix`: a command the worker
    is started through (e.g. one that mounts the output folder read-only for it). `slots`: the
    threads and units of the blender resource of each worker (how many files it runs at once)."""

    def __init__(self, folder, workers=2, nanny=False, allowed_failures=None, worker_prefix=(), tls=None, slots=1):
        self.tls = tls
        self.folder = pathlib.Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.n_workers, self.nanny, self.worker_prefix = workers, nanny, list(worker_prefix)
        self.allowed_failures, self.slots = allowed_failures, slots
        self.processes, self.address, self._client = [], None, None

    def _start(self, args, log, env=None):
        proc = subprocess.Popen([*map(str, args)], stdout=open(self.folder / log, "w"), stderr=subprocess.STDOUT,
                                start_new_session=True, env={**os.environ, **(env or {})})
        self.processes.append(proc)
        return proc

    def start(self):
        scheduler_file = self.folder / "scheduler.json"
        scheduler_file.unlink(missing_ok=True)  # an earlier cluster's in this folder would name a dead one
        env = {}
        if self.allowed_failures is not None:
            env["DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES"] = str(self.allowed_failures)
        scheduler = self._start([*DASK, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                                 "--dashboard-address", "127.0.0.1:0", *self._tls_options("scheduler"),
                                 "--scheduler-file", scheduler_file], "scheduler.log", env)
        deadline = time.monotonic() + START_SECONDS
        while self.address is None:
            try:  # the scheduler writes the file in place: it may be there and not complete yet
                self.address = json.loads(scheduler_file.read_text())["address"]
            except (OSError, ValueError, KeyError):
                if scheduler.poll() is not None or time.monotonic() > deadline:
                    raise RuntimeError(f"dask scheduler did not start: {(self.folder / 'scheduler.log').read_text()}")
                time.sleep(0.05)
        for i in range(self.n_workers):
            self.start_worker(f"w{i}")
        if self.n_workers:
            self.client().wait_for_workers(self.n_workers, timeout=START_SECONDS)
        return self

    def _tls_options(self, role):
        if self.tls is None:
            return []
        return ["--protocol", "tls", "--tls-ca-file", self.tls["ca"], "--tls-cert", self.tls[role],
                "--tls-key", self.tls[role + "_key"]]

    def start_worker(self, name):
        args = [*self.worker_prefix, *DASK, "worker", self.address, "--host", "127.0.0.1", "--nthreads", self.slots,
                "--resources", f"blender={self.slots}", "--no-dashboard", "--dashboard-address", "127.0.0.1:0",
                *self._tls_options("worker"), "--name", name, "--nanny" if self.nanny else "--no-nanny",
                "--local-directory", self.folder / name]
        return self._start(args, f"worker-{name}.log")

    def security(self):
        """The distributed.Security of a client with the launcher's certificate (None without TLS)."""
        if self.tls is None:
            return None
        import distributed
        return distributed.Security(tls_ca_file=str(self.tls["ca"]), tls_client_cert=str(self.tls["client"]),
                                    tls_client_key=str(self.tls["client_key"]), require_encryption=True)

    def client(self):
        if self._client is None:
            import distributed
            self._client = distributed.Client(self.address, timeout=30, set_as_default=False,
                                              security=self.security())
        return self._client

    def worker_pids(self):
        """{worker address: pid of the process that runs its tasks}."""
        return self.client().run(os.getpid)

    def tasks_on_scheduler(self):
        """How many tasks the scheduler holds (none once a run's futures are released or cancelled)."""
        return self.client().run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks))  # sent by value

    def logs(self):
        return "\n".join(f"--- {p.name}\n{p.read_text()[-3000:]}" for p in sorted(self.folder.glob("*.log")))

    def stop(self):
        if self._client is not None:
            try:
                self._client.close(timeout=5)
            except Exception:
                pass
        for proc in self.processes:
            try:
                os.killpg(proc.pid, signal.SIGKILL)  # the process and whatever it started (Blenders)
            except ProcessLookupError:
                pass
        for proc in self.processes:
            proc.wait(timeout=30)

    def __enter__(self):
        try:
            return self.start()
        except BaseException:
            self.stop()
            raise

    def __exit__(self, *exc):
        self.stop()


def fake_inputs(folder, modes):
    """One input per mode, `<i>_<mode>.blend`, whose bytes tell tests/batch/fake_blender.py what to do."""
    folder.mkdir(exist_ok=True)
    paths = []
    for i, mode in enumerate(modes):
        path = folder / f"{i}_{mode}.blend"
        path.write_bytes(b"BLENDER" + mode.encode())
        paths.append(path)
    return paths

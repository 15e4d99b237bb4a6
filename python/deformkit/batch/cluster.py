"""The Dask cluster a run uses: a Client on an existing scheduler (bounded connect) or on a
LocalCluster of this machine, the workers offering the blender resource, and the dashboard. Dask
is imported here (and in the modules the cluster run uses) only when a run asks for it: the
package and the local executor need none.

- `Cluster.connect(address, timeout)` / `Cluster.start_local(workers, blender_per_worker)`: a
  Client on an existing scheduler or on a LocalCluster, and the workers offering the blender
  resource; `close()` closes what was opened here only;
- `distributed_module()` / `dask_installed()`: Dask, or why not.
"""
import importlib.metadata
import logging
import signal
import time

RESOURCE = "blender"
PINS = "dask==2025.12.0 and distributed==2025.12.0 (requirements-dev.txt)"
# The scheduler's HTTP server (the dashboard, or /health and /metrics without bokeh): this
# machine's loopback only, a free port; ":0" would listen on every interface.
LOOPBACK_DASHBOARD = "127.0.0.1:0"


class DaskMissing(ImportError):
    pass


class ClusterError(RuntimeError):
    """The cluster cannot run this batch: the message names the argument, the worker and the path."""


def distributed_module():
    try:
        import distributed
    except ImportError as exc:
        raise DaskMissing(f"dask and distributed are not installed ({exc}); install {PINS}") from None
    return distributed


def dask_installed():
    try:
        import dask  # noqa: F401
        import distributed  # noqa: F401
    except ImportError:
        return False
    return True


def _ignore_ctrl_c():
    """A worker plugin: Ctrl+C in the terminal reaches a LocalCluster's worker processes (they are
    in the launcher's process group); they let it pass, as the local pool's processes do, through
    a handler that Blender's exec resets, so that the Blenders still get it. The launcher decides.
    (Made here, as distributed is imported only here; cloudpickle sends the class by value.)"""
    from distributed.diagnostics.plugin import WorkerPlugin

    class IgnoreCtrlC(WorkerPlugin):
        name = "deformkit-batch-ignore-ctrl-c"

        def setup(self, worker):
            signal.signal(signal.SIGINT, lambda signum, frame: None)

    return IgnoreCtrlC()


class Cluster:
    """The Dask client a run uses, what it was opened on, and the workers that can run a file
    ({address: units of the blender resource}). close() closes what was opened here only."""

    def __init__(self, client, local=None, owns_client=False, wait=30.0):
        self.client, self.local, self.owns_client = client, local, owns_client
        try:
            self.address = client.scheduler.address
            self.workers = blender_workers(client, wait)
            self.dashboard = dashboard(client)
        except BaseException:
            self.close()
            raise

    @classmethod
    def connect(cls, address, timeout, security=None):
        """On the scheduler at `address` (with `security`, a distributed.Security, for tls://):
        ClusterError within about `timeout` seconds when it cannot be reached (or refuses this
        client's certificate), or when no worker with the blender resource joins in that time."""
        distributed = distributed_module()
        try:
            client = distributed.Client(address, timeout=timeout, set_as_default=False, security=security)
        except (OSError, TimeoutError, ValueError) as exc:
            hint = ("; is --tls-cert signed by the CA the scheduler trusts, and the scheduler's by --tls-ca-file?"
                    if address.startswith("tls://") else "")
            raise ClusterError(f"--scheduler: cannot reach the Dask scheduler {address} within {timeout:g} s "
                               f"({exc}){hint}") from None
        return cls(client, owns_client=True, wait=timeout)

    @classmethod
    def start_local(cls, workers, blender_per_worker):
        """A LocalCluster: `workers` processes of this machine on 127.0.0.1 (under nannies, which
        restart a worker that dies), each with `blender_per_worker` threads and as many units of
        the blender resource."""
        distributed = distributed_module()
        import dask
        # Dask's nanny sets OMP/MKL/OpenBLAS threads to 1 and a low malloc trim threshold in its
        # workers (for numpy tasks); none here, so that the Blenders get the local executor's
        # environment. Nor the workers' statistical profiler (a stack sample every 10 ms, 1.5% of a
        # core per worker here): a task that waits for its Blender has nothing to show in it.
        with dask.config.set({"distributed.nanny.pre-spawn-environ": {}, "distributed.worker.profile.enabled": False}):
            local = distributed.LocalCluster(
                n_workers=workers, threads_per_worker=blender_per_worker, processes=True, host="127.0.0.1",
                resources={RESOURCE: blender_per_worker}, dashboard_address=LOOPBACK_DASHBOARD,
                silence_logs=logging.ERROR)
        try:
            client = distributed.Client(local, set_as_default=False)
            client.register_plugin(_ignore_ctrl_c())
        except BaseException:
            local.close()
            raise
        return cls(client, local=local, owns_client=True)

    @property
    def slots(self):
        return int(sum(self.workers.values()))

    def close(self):
        if self.owns_client:
            self.client.close()
        if self.local is not None:
            self.local.close()


def dashboard(client):
    """The dashboard's address, or None: the scheduler serves one when bokeh is installed beside it."""
    if "dashboard" not in client.scheduler_info().get("services", {}):
        return None
    try:
        client.run_on_scheduler(importlib.metadata.version, "bokeh")
    except Exception:  # bokeh missing there (PackageNotFoundError), or run_on_scheduler refused
        return None
    return client.dashboard_link


def blender_workers(client, timeout):
    """{address: units of the blender resource} of the workers that can run a file; waits up to
    `timeout` seconds for the first one to join."""
    deadline = time.monotonic() + timeout
    address = client.scheduler.address
    while True:
        joined = client.scheduler_info()["workers"]
        found = {a: w.get("resources", {}).get(RESOURCE, 0) for a, w in joined.items()}
        found = {a: n for a, n in found.items() if n > 0}
        if found:
            return found
        if time.monotonic() > deadline:
            seen = f"{len(joined)} worker(s) joined, none with it" if joined else "no worker joined"
            raise ClusterError(f"--scheduler: no worker of {address} offers the resource '{RESOURCE}' after "
                               f"{timeout:g} s ({seen}); start workers with "
                               f"`dask worker {address} --resources {RESOURCE}=1 --nthreads 1`")
        time.sleep(0.2)

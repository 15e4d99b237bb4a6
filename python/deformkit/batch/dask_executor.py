"""The batch's concurrent.futures executor on a Dask cluster (cluster.py opens it): each file one
task (`run_job` in one `blender -b`, on the worker that picked it), inputs and outputs by path on
storage every worker shares.

- `DaskExecutor`: concurrent.futures' submit/shutdown for run_all. Tasks ask for the resource
  `blender=1`; each runs as attempts.run_attempt, and a task whose worker died (KilledWorker) is
  sent again while attempts are left (attempts.py: nothing lost, nothing doubled);
- `interrupt_run`: the worker's side of stopping a run (Ctrl+C on the launcher): no Blender of
  the run starts any more, and those running get Ctrl+C as at a terminal.
"""
import concurrent.futures
import dataclasses
import signal
import threading
import time

from . import attempts
from .cluster import RESOURCE
from .run import BLENDERS, failed_row

# What a task whose worker died (or whose result died with it) raises on the client.
WORKER_LOST = ("KilledWorker", "CommClosedError", "CommError", "StreamClosedError")


def connected(client):
    """Whether the client still talks to its scheduler: after the scheduler dies it is
    "connecting" (for its timeout), then "closed"; a task sent meanwhile waits for that."""
    return getattr(client, "status", "running") == "running"


def interrupt_run(staging, grace=5.0):
    """Runs on each worker (client.run): no Blender of the run starts here any more, and those
    this worker started for it (their jobs' work folders are under `staging`; their job files may
    be elsewhere, in the worker's private copy of the staged code) get Ctrl+C twice, as a user at
    a terminal would press it (Blender takes the first SIGINT as a break event, the second ends
    it), then SIGKILL if still there after `grace` seconds. Returns their pids."""
    mine = BLENDERS.stop(staging)
    for proc in mine:
        proc.send_signal(signal.SIGINT)  # nothing once reaped: the thread that started it reads why it ended
    if mine:
        time.sleep(0.3)
    for proc in mine:
        proc.send_signal(signal.SIGINT)
    deadline = time.monotonic() + grace
    alive = [p for p in mine if p.poll() is None]
    while alive and time.monotonic() < deadline:
        time.sleep(0.1)
        alive = [p for p in alive if p.poll() is None]
    for proc in alive:
        proc.kill()
    return [p.pid for p in mine]


class DaskExecutor(concurrent.futures.Executor):
    """A concurrent.futures-style executor on a Dask client: submit(fn, job) runs fn(job) as one
    task asking for `blender=1`, wrapped in attempts.run_attempt under `plan` (staging folder on
    shared storage, run token, retries). The future it returns gets the row of the attempt that
    finished the file; a task whose worker died is sent again while attempts are left, and gets
    a "WorkerLost" row after the last. A future is running from its attempt's start (the workers
    announce it on the run's event topic, also passed to `on_event`). As with the local pool,
    cancelling the futures (run_all does on Ctrl+C) drops the files not started, and the running
    ones get their rows: the first cancel stops the run on the cluster (no Blender starts any
    more, the tasks not started are cancelled, the running Blenders get SIGINT)."""

    def __init__(self, client, plan, on_event=None):
        self.client, self.plan, self.on_event = client, plan, on_event
        self._tasks, self._lock, self._cancelled, self._sent = {}, threading.Lock(), False, 0
        self._sends, self._by_index, self._stopping = {}, {}, None  # sends: a bound on resending a file
        self.topic = f"deformkit-batch-{plan.token}"
        client.subscribe_topic(self.topic, self._event)

    def submit(self, fn, job, /):
        future = concurrent.futures.Future()
        future.add_done_callback(self._on_done)
        with self._lock:
            self._by_index[job.index] = future
        self._send(future, fn, job)
        return future

    def _send(self, future, fn, job):
        if not connected(self.client):  # it would wait for a scheduler that is gone
            return _settle(future, attempts.lost_row(job, self.plan, f"the client is {self.client.status}",
                                                      scheduler_lost=True))
        with self._lock:
            self._sent += 1
            self._sends[job.index] = self._sends.get(job.index, 0) + 1
            key = f"deformkit-batch-{self.plan.token}-{job.index}-{self._sent}"
        plan = dataclasses.replace(self.plan, submitted=time.time())
        task = self.client.submit(attempts.run_attempt, fn, job, plan, key=key, pure=False,
                                  resources={RESOURCE: 1}, priority=-job.index)  # in the inputs' order
        with self._lock:
            self._tasks[future] = task
        task.add_done_callback(lambda t: self._landed(future, fn, job, t))

    def _event(self, event):
        """In the client's event loop: an attempt starts (its future is running) or ends."""
        message = event[1] if isinstance(event, (tuple, list)) and len(event) == 2 else event
        future = self._by_index.get(message.get("index")) if isinstance(message, dict) else None
        if future is not None and message.get("event") == "start":
            try:
                if not future.running() and not future.done():
                    future.set_running_or_notify_cancel()
            except RuntimeError:  # cancelled or finished meanwhile
                pass
        if self.on_event is not None and isinstance(message, dict):
            self.on_event(message)

    def _landed(self, future, fn, job, task):
        """In Dask's callback thread: the task's row to the future, or the task sent again when
        its worker was lost and attempts are left."""
        if future.done():
            return
        try:
            if task.status == "cancelled":
                if not self._cancelled:  # not ours: the scheduler died or restarted, or our connection to it broke
                    _settle(future, attempts.lost_row(job, self.plan, "the task was cancelled", scheduler_lost=True))
                elif future.running():  # started just before the run was stopped: not to be waited for
                    _settle(future, failed_row(job.input, job.output, "Cancelled",
                                               "the run was stopped as this file started"))
                return
            try:
                return _settle(future, task.result())
            except Exception as exc:
                if type(exc).__name__ not in WORKER_LOST:
                    raise
                lost = f"{type(exc).__name__}: {exc}"
            attempts.note_lost(self.plan.staging, job.index, lost, self.plan.token)
            if not connected(self.client):  # the result was lost with the scheduler, not with a worker
                return _settle(future, attempts.lost_row(job, self.plan, lost, scheduler_lost=True))
            made = len(attempts.attempt_numbers(self.plan.staging, job.index))
            sends = self._sends.get(job.index, 0)
            if made < self.plan.max_attempts and sends < 3 * self.plan.max_attempts and not self._cancelled:
                return self._send(future, fn, job)
            _settle(future, attempts.lost_row(job, self.plan, lost))
        except Exception as exc:  # e.g. the job did not unpickle on the worker: run_all makes a row of it
            if not future.done():
                try:
                    future.set_exception(exc)
                except concurrent.futures.InvalidStateError:
                    pass

    def _on_done(self, future):
        if not future.cancelled():
            return
        future.set_running_or_notify_cancel()  # as a pool's worker would: wait() and as_completed() see it done
        with self._lock:
            first, self._cancelled = not self._cancelled, True
        if first:  # in a thread: cancel() returns at once, and run_all cancels the other futures meanwhile
            self._stopping = threading.Thread(target=self._stop, name="deformkit-batch-stop", daemon=True)
            self._stopping.start()

    def _stop(self):
        """Stop the run on the cluster: no attempt starts Blender any more (the staging folder's
        mark), the tasks of the files not started are cancelled, the Blenders running for the
        run are interrupted (their tasks then give their rows)."""
        try:
            attempts.mark_cancelled(self.plan.staging)
        except OSError:
            pass
        with self._lock:
            waiting = [t for f, t in self._tasks.items() if not f.running() and not f.done() or f.cancelled()]
        if waiting:
            self.client.cancel(waiting, force=True)
        # Once a worker has run this, it starts no Blender for the run (run.BLENDERS): an attempt
        # that read no mark just before it was made is refused there, not raced.
        self.client.run(interrupt_run, self.plan.staging, on_error="return")

    def cancel_all(self):
        """Stop the run and drop every file not done: all futures not done are cancelled."""
        with self._lock:
            futures = list(self._tasks)
        for future in futures:
            future.cancel()
        if self._stopping is not None:
            self._stopping.join()
        with self._lock:
            tasks = [t for f, t in self._tasks.items() if not f.done() or f.cancelled()]
        if tasks:
            self.client.cancel(tasks, force=True)

    def wait_for_attempts(self, seconds=15.0):
        """Until the attempts that live workers still run have ended (a cancelled task's thread
        runs on until its Blender is gone), at most `seconds`: the staging folder is removed next."""
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline and connected(self.client):
            live = set(self.client.scheduler_info()["workers"])
            if not any(r.get("worker") in live for r in attempts.open_attempts(self.plan.staging)):
                return True
            time.sleep(0.1)
        return False

    def shutdown(self, wait=True, *, cancel_futures=False):
        """After a cancel (run_all's on Ctrl+C) or with cancel_futures: the run stopped on the
        cluster, its attempts waited for (at most 15 s); else wait for the files. The client stays
        open: it is the caller's."""
        try:
            if cancel_futures:
                self.cancel_all()
            if self._cancelled:
                if self._stopping is not None:
                    self._stopping.join()
                with self._lock:
                    tasks = [t for f, t in self._tasks.items() if not f.done() or f.cancelled()]
                if tasks:  # the running ones too: run_all has stopped waiting for them
                    self.client.cancel(tasks, force=True)
                self.wait_for_attempts()
            elif wait:
                concurrent.futures.wait(list(self._tasks))
        finally:
            try:
                self.client.unsubscribe_topic(self.topic)
            except Exception:  # a closed client refuses to send: its scheduler, and the topic, are gone
                if connected(self.client):
                    raise


def _settle(future, row):
    if not future.done():
        try:
            future.set_result(row)
        except concurrent.futures.InvalidStateError:  # cancelled meanwhile
            pass

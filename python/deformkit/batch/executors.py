"""What runs the jobs. An executor is anything with concurrent.futures' `submit(fn, *args)` (giving
a concurrent.futures.Future) and `shutdown(wait)`: this module's in-process and local-process
executors, a ThreadPoolExecutor, or a Dask client's `get_executor()`. `run_all` drives one over a
run's jobs and owns what the batch promises whatever the executor: every job gets a row, reported
as it finishes; a job whose process died or could not be sent still gets one; Ctrl-C drops the
jobs not started and reports the running ones before it propagates.
"""
import concurrent.futures
import multiprocessing
import os
import signal
from typing import Any, Callable, Protocol

from . import shared
from .run import failed_row, run_job


class Executor(Protocol):
    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> concurrent.futures.Future: ...

    def shutdown(self, wait: bool = True) -> None: ...


class InProcessExecutor(concurrent.futures.Executor):
    """Runs each job in the calling process when it is submitted: the simplest executor, for tests
    and for debugging a job."""

    def submit(self, fn, /, *args, **kwargs):
        future = concurrent.futures.Future()
        future.set_running_or_notify_cancel()
        try:
            future.set_result(fn(*args, **kwargs))
        except Exception as exc:
            future.set_exception(exc)
        return future


def _pool_process_start(launcher_pid):
    """In each pool process. A SIGKILLed launcher takes its pool processes with it (and they their
    Blenders). Ctrl-C in the terminal reaches the whole process group: a pool process ignores it
    through a handler, not SIG_IGN, because a handler is reset when Blender is exec'd, so that
    Blender gets Ctrl-C exactly as when the launcher started it itself; the launcher decides what
    happens to the run."""
    shared.prepare_worker(launcher_pid)
    signal.signal(signal.SIGINT, lambda signum, frame: None)


class LocalProcessExecutor(concurrent.futures.Executor):
    """Jobs in `max_workers` processes of this machine (spawned: nothing of the launcher's state
    is inherited, jobs and results pass pickled, as they would to a remote executor)."""

    def __init__(self, max_workers=1):
        self.max_workers = max_workers
        self._pool = concurrent.futures.ProcessPoolExecutor(
            max_workers, mp_context=multiprocessing.get_context("spawn"), initializer=_pool_process_start,
            initargs=(os.getpid(),))

    def submit(self, fn, /, *args, **kwargs):
        return self._pool.submit(fn, *args, **kwargs)

    def shutdown(self, wait=True, *, cancel_futures=False):
        self._pool.shutdown(wait, cancel_futures=cancel_futures)


def _row(job, future):
    try:
        return future.result()
    except Exception as exc:  # the job's process died, or the job did not pickle
        return failed_row(job.input, job.output, type(exc).__name__, str(exc) or repr(exc), "launch")


def run_all(executor, jobs, on_row, fn=run_job, window=None):
    """fn(job) for every job on `executor`, at most `window` at a time (default: all submitted at
    once), calling on_row(job, row) as each finishes. On KeyboardInterrupt the jobs not started
    are dropped, the running ones are waited for and reported, and the interrupt propagates."""
    waiting, running = list(jobs)[::-1], {}

    def top_up():
        while waiting and (window is None or len(running) < window):
            job = waiting.pop()
            try:
                running[executor.submit(fn, job)] = job
            except Exception as exc:  # e.g. a broken pool: this job, and the next, still get rows
                on_row(job, failed_row(job.input, job.output, type(exc).__name__, str(exc) or repr(exc), "launch"))

    try:
        top_up()
        while running:
            done, _ = concurrent.futures.wait(running, return_when=concurrent.futures.FIRST_COMPLETED)
            for future in done:
                job = running.pop(future)
                on_row(job, _row(job, future))
            top_up()
    except KeyboardInterrupt:
        waiting.clear()
        for future in running:
            future.cancel()
        for future in concurrent.futures.as_completed(running):
            if not future.cancelled():
                on_row(running[future], _row(running[future], future))
        raise

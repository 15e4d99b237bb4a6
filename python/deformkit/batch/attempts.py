"""Attempts of one file on a cluster, where a worker can die in the middle of a file and its task
run again elsewhere: nothing lost, nothing doubled.

Every run of a file's task is one attempt, numbered by the folder it creates under the run's
staging folder, `attempts/<index>/<n>/` (mkdir is atomic, on a shared file system too, so two
runs of the same task never share a number whoever restarted it: the launcher after a
KilledWorker, or the scheduler itself). That folder is the job's `work` folder for the attempt
(job, progress and result files), and the attempt id `<run token>-f<index>-a<n>` is the job's
token, so Blender's temporary output `OUTPUT.deformkit-<attempt id>.tmp.blend` is the attempt's
own: a killed attempt's half file is never renamed into place, and the next attempt removes it.
An attempt's record (record.json: worker, start, end, outcome, error) says what became of it; one
with no end was lost with its worker. A later attempt that finds an earlier one's result file
saying "ok", for the very output file now in place (same size and modification time), returns
that row instead of writing the output again, unless asked to redo it.

No Dask here: the task function runs on a Dask worker, but only asks it its own address.
"""
import dataclasses
import datetime
import inspect
import os
import shutil
import socket
import time

from . import shared
from .run import attach_preview, failed_row

ATTEMPTS = "attempts"
RECORD = "record.json"
ROW = "row.json"  # an ended attempt's row, for a rerun of its task whose result never arrived
CANCELLED = "cancelled"  # the launcher's mark: the run was stopped, start no Blender
LOST = "lost.json"  # the launcher's word on an attempt whose worker died (KilledWorker's message)


@dataclasses.dataclass(frozen=True)
class AttemptPlan:
    """What every attempt of a run shares: the staging folder on shared storage, the run token,
    how many attempts a file may have (retries + 1), whether a complete earlier attempt is
    redone, and when the launcher submitted the task (for queue_seconds, on the launcher's
    clock)."""

    staging: str
    token: str
    max_attempts: int = 3
    redo_complete: bool = False
    submitted: float = 0.0


def attempt_id(token, index, attempt):
    return f"{token}-f{index}-a{attempt}"


def file_folder(staging, index):
    return os.path.join(staging, ATTEMPTS, str(index))


def attempt_folder(staging, index, attempt):
    return os.path.join(file_folder(staging, index), str(attempt))


def attempt_numbers(staging, index):
    """The numbers of the attempts made so far for file `index`, in order."""
    try:
        names = os.listdir(file_folder(staging, index))
    except FileNotFoundError:
        return []
    return sorted(int(n) for n in names if n.isdigit())


def mark_cancelled(staging):
    """The launcher stops the run (Ctrl+C): an attempt that has not started its Blender won't."""
    with open(os.path.join(staging, CANCELLED), "w", encoding="utf-8"):
        pass


def claim(staging, index, limit):
    """The number of a new attempt at file `index`, its folder created; None when `limit`
    attempts were made already. The staging folder itself must exist (a task that runs after
    its run ended must not make it again)."""
    if not os.path.isdir(staging):
        raise FileNotFoundError(f"the run's staging folder {staging} is gone: the run has ended")
    os.makedirs(file_folder(staging, index), exist_ok=True)
    for n in range(1, limit + 1):
        try:
            os.mkdir(attempt_folder(staging, index, n))
            return n
        except FileExistsError:
            continue
    return None


def _read(path):
    try:  # on shared storage: a regular file of bounded size only (docs/errors.md)
        found = shared.read_json_file(path, shared.STATE_FILE_LIMIT)
    except (OSError, ValueError):
        return None
    return found if isinstance(found, dict) else None


def _iso(seconds):
    return datetime.datetime.fromtimestamp(seconds, datetime.timezone.utc).isoformat(timespec="milliseconds")


def write_record(staging, index, record):
    shared.write_json_atomically(os.path.join(attempt_folder(staging, index, record["attempt"]), RECORD), record,
                                 record["id"])


def note_lost(staging, index, message, token):
    """The launcher's reason for the latest attempt of `index` that has no end (a KilledWorker's
    message), for the report; nothing when no attempt is open."""
    for n in reversed(attempt_numbers(staging, index)):
        record = _read(os.path.join(attempt_folder(staging, index, n), RECORD)) or {}
        if record.get("end") is None:
            shared.write_json_atomically(os.path.join(attempt_folder(staging, index, n), LOST), {"error": message},
                                         token)
            return n
    return None


def _stage_of(folder, index):
    return ((_read(os.path.join(folder, f"{index}.json")) or {}).get("stage") or {}).get("stage")


def history(staging, index, before=None):
    """The records of the attempts at file `index` (those numbered below `before`): one with no
    end is "lost", its error saying on which worker and at which stage."""
    records = []
    for n in attempt_numbers(staging, index):
        if before is not None and n >= before:
            break
        folder = attempt_folder(staging, index, n)
        record = _read(os.path.join(folder, RECORD)) or {"attempt": n, "id": None, "worker": None, "start": None}
        if record.get("end") is None:
            progress = _read(os.path.join(folder, f"{index}.json")) or {}
            stage = (progress.get("stage") or {}).get("stage")
            if progress.get("status") == "ok":
                when = ", after its Blender had finished the file"
            else:
                when = (f" during stage '{stage}'" if stage else "") + ", with no result"
            lost = (_read(os.path.join(folder, LOST)) or {}).get("error")
            record = {**record, "end": None, "outcome": "lost",
                      "error": f"worker {record.get('worker')} (pid {record.get('pid')} on {record.get('host')}) "
                               f"died or lost the scheduler{when}" + (f" ({lost})" if lost else "")}
        records.append(record)
    return records


def open_attempts(staging):
    """The records of the run's attempts that have started and not ended (running, or lost)."""
    found = []
    try:
        indices = os.listdir(os.path.join(staging, ATTEMPTS))
    except FileNotFoundError:
        return found
    for index in filter(str.isdigit, indices):
        for n in attempt_numbers(staging, int(index)):
            record = _read(os.path.join(attempt_folder(staging, int(index), n), RECORD))
            if record is not None and record.get("end") is None:
                found.append(record)
    return found


def output_matches(output, stat):
    """True when `output` is the very file an attempt's result recorded (size and mtime)."""
    if not isinstance(stat, dict):
        return False
    try:
        now = os.stat(output)
    except OSError:
        return False
    return (now.st_size, now.st_mtime_ns) == (stat.get("bytes"), stat.get("mtime_ns"))


def completed_earlier(staging, index, output, before):
    """(attempt number, its result row) of an earlier attempt whose Blender finished the file,
    proved by its result file and the output in place being the one it wrote; else None."""
    for n in reversed(range(1, before)):
        result = _read(os.path.join(attempt_folder(staging, index, n), f"{index}.json"))
        if result and result.get("status") == "ok" and output_matches(output, result.get("output_stat")):
            return n, result
    return None


def remove_temporaries(output, token, index, before):
    """The temporary outputs earlier attempts of this file may have left (a killed one's half file)."""
    for n in range(1, before):
        for leftover in shared.run_temporaries(output, attempt_id(token, index, n)):
            if os.path.exists(leftover):
                os.unlink(leftover)


def worker_identity():
    """{"worker": the Dask worker's address (else host:pid), "host", "pid"} of this process."""
    found = {"worker": f"{socket.gethostname()}:{os.getpid()}", "host": socket.gethostname(), "pid": os.getpid()}
    try:
        from distributed import get_worker
        found["worker"] = get_worker().address
    except (ImportError, ValueError):
        pass
    return found


def blender_environ():
    """This worker's environment without what Dask's nanny put in it for numpy tasks (one OpenMP
    thread, a low malloc trim threshold: distributed.nanny.pre-spawn-environ): Blender gets the
    environment it would get from the local executor on this machine."""
    environ = dict(os.environ)
    try:
        import dask
        injected = dask.config.get("distributed.nanny.pre-spawn-environ", {}) or {}
    except ImportError:
        return environ
    for key, value in injected.items():
        if environ.get(key) == str(value):
            del environ[key]
    return environ


def _call(fn, job):
    """fn(job), with the worker's environment for Blender when fn takes one (run_job does)."""
    try:
        takes = "environ" in inspect.signature(fn).parameters
    except (TypeError, ValueError):
        takes = False
    return fn(job, environ=blender_environ()) if takes else fn(job)


def announce(token, event, **data):
    """Tell the launcher (Dask's event topic of the run) that an attempt starts or ends: its live
    progress line. Best effort: the report does not depend on it."""
    try:
        from distributed import get_worker
        get_worker().log_event(f"deformkit-batch-{token}", {"event": event, **data})
    except Exception:  # not on a worker, or the scheduler is out of reach: only the progress line misses it
        pass


def lost_row(job, plan, reason="", scheduler_lost=False):
    """The row of a file that may have no attempt left: an earlier attempt's if one completed
    it (and the plan does not redo it), else a failure saying every worker that ran it was lost
    (or the scheduler, with `scheduler_lost`)."""
    staging, max_attempts = plan.staging, plan.max_attempts
    done = None if plan.redo_complete else completed_earlier(staging, job.index, job.output, max_attempts + 1)
    if done:
        k, row = done
        row = attach_preview(dataclasses.replace(job, work=attempt_folder(staging, job.index, k)), row)
        records = history(staging, job.index)
        worker = next((r.get("worker") for r in records if r["attempt"] == k), None)
        return {**row, "worker": worker, "attempts": records, "queue_seconds": None}
    records = history(staging, job.index)
    ended = next((r for r in reversed(records) if r.get("end") is not None), None)
    row = _read(os.path.join(attempt_folder(staging, job.index, ended["attempt"]), ROW)) if ended else None
    if row is not None:  # its task ended, and its result was lost on the way (the worker died just after)
        return {**row, "attempts": records}
    if scheduler_lost:
        row = failed_row(job.input, job.output, "SchedulerLost", "the connection to the Dask scheduler was lost "
                         f"before the file was done ({reason}); a new run does it again")
        return {**row, "worker": None, "attempts": records, "queue_seconds": None}
    last = next((r for r in reversed(records) if r["outcome"] == "lost"), None)
    stage = _stage_of(attempt_folder(staging, job.index, last["attempt"]), job.index) if last else None
    message = (f"the worker running it was lost in {sum(r['outcome'] == 'lost' for r in records)} of "
               f"{len(records)} attempts, and no attempt is left (at most {max_attempts})")
    row = failed_row(job.input, job.output, "WorkerLost", message + (f"; last: {reason}" if reason else ""),
                     stage or "start")
    return {**row, "worker": last.get("worker") if last else None, "attempts": records, "queue_seconds": None}


def run_attempt(fn, job, plan):
    """One attempt at `job` on the worker that runs this (a Dask task): claim an attempt number,
    clean up after earlier attempts, return an earlier complete attempt's row or run fn(job) in
    this attempt's folder under this attempt's token; the row gains the worker, the attempts
    and the seconds the task queued."""
    started = time.time()
    me = worker_identity()
    n = claim(plan.staging, job.index, plan.max_attempts)
    if n is None:
        return lost_row(job, plan)
    aid, folder = attempt_id(plan.token, job.index, n), attempt_folder(plan.staging, job.index, n)
    record = {"attempt": n, "id": aid, **me, "start": _iso(started), "end": None, "outcome": "running", "error": ""}
    write_record(plan.staging, job.index, record)
    announce(plan.token, "start", index=job.index, attempt=n, worker=me["worker"])
    earlier = history(plan.staging, job.index, before=n)
    try:
        remove_temporaries(job.output, plan.token, job.index, n)
        done = None if plan.redo_complete else completed_earlier(plan.staging, job.index, job.output, n)
        if done:
            k, row = done
            row = attach_preview(dataclasses.replace(job, work=attempt_folder(plan.staging, job.index, k)), row)
            record.update(outcome="reused", error=f"attempt {k} had completed the file; not redone")
        elif os.path.exists(os.path.join(plan.staging, CANCELLED)):
            row = failed_row(job.input, job.output, "Cancelled", "the run was stopped before this file started")
            record.update(outcome="cancelled", error=row["error"])
        else:
            here = dataclasses.replace(job, work=folder, token=aid, blender=shutil.which(job.blender) or job.blender)
            row = _call(fn, here)
            record.update(outcome=row["status"], error=row.get("error", ""))
    except Exception as exc:  # our own trouble with the attempt: still a row, and a record
        row = failed_row(job.input, job.output, type(exc).__name__, str(exc) or repr(exc), "launch")
        record.update(outcome="failed", error=row["error"])
    record["end"] = _iso(time.time())
    row = {**row, "worker": me["worker"], "attempts": earlier + [record],
           "queue_seconds": round(started - plan.submitted, 3) if plan.submitted else None}
    try:
        shared.write_json_atomically(os.path.join(folder, ROW), row, aid)
        write_record(plan.staging, job.index, record)
    except OSError:
        pass  # the staging folder went away (the run was interrupted); the row still says it
    announce(plan.token, "end", index=job.index, attempt=n, worker=me["worker"], status=row["status"])
    return row

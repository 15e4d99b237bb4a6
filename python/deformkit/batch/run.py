"""One file, start to end, on the machine that runs it: the environment Blender runs in, the
Blender process on the job file and what it left behind (its result file, or why there is none),
and the picture. No bpy; `run_job` is the whole of it, for any executor."""
import dataclasses
import json
import os
import re
import shutil
import signal
import stat
import subprocess
import tempfile
import threading
import time

from . import shared, staged_code

BLEND_MAGIC = (b"BLENDER", b"\x1f\x8b", b"\x28\xb5\x2f\xfd")  # plain, gzip, zstd
PYTHON_NAME = re.compile(r"python3(\.\d+)?$")
# Runs in Blender, beside this file: reads the job file named after `--`.
IN_BLENDER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "in_blender.py")


def hijacking_python(folder):
    """True when `folder` holds a python3.N that Blender's Python would take its sys.prefix from
    (Blender looks for python3.N on PATH, and CPython derives the prefix from where that
    executable lives: a pyvenv.cfg beside it or above, or a lib/python3.N/os.py above)."""
    try:
        names = [n for n in os.listdir(folder) if PYTHON_NAME.match(n)]
    except OSError:
        return False
    for name in names:
        for exe in {os.path.join(folder, name), os.path.realpath(os.path.join(folder, name))}:
            home = os.path.dirname(exe)
            if any(os.path.exists(os.path.join(d, "pyvenv.cfg")) for d in (home, os.path.dirname(home))):
                return True
            up = home
            while up != os.path.dirname(up):
                up = os.path.dirname(up)
                if any(os.path.exists(os.path.join(up, "lib", n, "os.py")) for n in names if "." in n):
                    return True
    return False


def blender_environment(blender, environ=None):
    """(environment, PATH folders left out) for Blender: no PYTHON* variables (Blender honours
    PYTHONHOME), and a PATH on which the only Python Blender can adopt is the one beside it."""
    environ = os.environ if environ is None else environ
    env = {k: v for k, v in environ.items() if not k.startswith("PYTHON")}
    own = os.path.dirname(os.path.realpath(blender))
    kept, dropped = [], []
    for folder in environ.get("PATH", "").split(os.pathsep):
        if folder and os.path.realpath(folder) != own and hijacking_python(folder):
            dropped.append(folder)
        elif folder:
            kept.append(folder)
    env["PATH"] = os.pathsep.join(kept)
    return env, dropped


def same_file(a, b):
    """True when a and b are the same file, through symbolic links and hard links too."""
    try:
        return os.path.samefile(a, b)
    except OSError:  # one does not exist (yet): compare the resolved paths
        return os.path.realpath(a) == os.path.realpath(b)


def input_problem(path):
    if not os.path.exists(path):
        return "file not found"
    if not os.path.isfile(path):
        return "not a file"
    try:  # non-blocking: a FIFO swapped in after the check above cannot hang the run
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
        try:
            if not stat.S_ISREG(os.fstat(fd).st_mode):
                return "not a file"
            head = os.read(fd, 8)
        finally:
            os.close(fd)
    except OSError as exc:
        return f"cannot read it: {exc.strerror}"
    if not head.startswith(BLEND_MAGIC):
        return "not a .blend file (no BLENDER header)"
    return ""


def failed_row(src, dst, kind, message, stage="start", seconds=0.0, obj=None, entry=None, **extra):
    """The row of a file that failed outside Blender's worker (or whose worker gave no result):
    an exception `kind` with `message`, at `stage` (and `obj`, `entry`, when known)."""
    error = {"type": kind, "message": message, "stage": stage, "object": obj, "entry": entry}
    return shared.file_row(src, dst, exception=error, seconds=seconds, **extra)


def _read_result(path, stdout):
    """The worker's final result: from its result file, else from the line it prints when it
    cannot write that file (the file may then still hold a progress record, which is returned
    only when there is nothing better: it says at which stage the worker was)."""
    try:  # in the staging folder, which others may write on a cluster: bounded, never blocking
        found = shared.read_json_file(path, shared.STATE_FILE_LIMIT)
    except (OSError, ValueError):
        found = None
    if not isinstance(found, dict):
        found = None
    if found is not None and found.get("status") in ("ok", "failed"):
        return found
    for line in reversed(stdout.splitlines()):
        if line.startswith(shared.RESULT_LINE):
            try:
                return json.loads(line[len(shared.RESULT_LINE):])
            except ValueError:
                break
    return found


def _death(returncode):
    if returncode < 0:
        try:
            return f"Blender was killed by {signal.Signals(-returncode).name}"
        except ValueError:
            return f"Blender was killed by signal {-returncode}"
    return f"Blender exited with status {returncode} without a result"


def _unfinished(src, dst, progress, message, kind, seconds, output):
    where = (progress or {}).get("stage") or {"stage": "start"}
    return failed_row(src, dst, kind, f"{message} during stage '{where.get('stage')}'", where.get("stage"),
                      seconds, where.get("object"), where.get("entry"),
                      warnings=(progress or {}).get("warnings", []), blender_output=output[-20:])


class BlenderRegistry:
    """The Blenders this process has started and not yet reaped, by their job's work folder, so
    that stopping a run on a worker (Ctrl+C on a cluster's launcher: dask_executor.interrupt_run)
    reaches every Blender of the run, wherever its job file lies, and none starts after it: the
    check and the start are one step under the lock."""

    def __init__(self):
        self._lock = threading.Lock()
        self._running = {}  # Popen -> the job's work folder
        self._stopped = set()  # folders (a run's staging folder) under which no Blender starts

    def _stopped_under(self, work):
        return any(work == folder or work.startswith(folder.rstrip(os.sep) + os.sep) for folder in self._stopped)

    def start(self, work, argv, **options):
        """subprocess.Popen(argv, **options), or None when the run of `work` was stopped."""
        with self._lock:
            if self._stopped_under(work):
                return None
            proc = subprocess.Popen(argv, **options)
            self._running[proc] = work
            return proc

    def reaped(self, proc):
        with self._lock:
            self._running.pop(proc, None)

    def stop(self, folder):
        """No Blender starts under `folder` any more; the Popens of those running under it (their
        starting threads reap them: Popen's own lock makes poll() and send_signal() safe here)."""
        with self._lock:
            self._stopped.add(folder)
            return [p for p, work in self._running.items()
                    if work == folder or work.startswith(folder.rstrip(os.sep) + os.sep)]


BLENDERS = BlenderRegistry()


def blender_command(blender, job_path):
    # -noaudio: a batch needs no sound, and the audio client maps 64 MB of shared memory at start-up
    return [blender, "-b", "--factory-startup", "-noaudio", "--python-exit-code", "1", "--python", IN_BLENDER,
            "--", job_path]


def run_blender(job, environ=None):
    """Run the job's file in its own Blender; the worker's result row, or a row saying why there
    is none (timed out, killed, exited without a result, and at which stage). A job with staged
    code (a cluster's) runs on a checked private copy of it, or fails naming the altered file."""
    src, dst = job.input, job.output
    problem = input_problem(src)
    if problem:
        return failed_row(src, dst, "InputError", problem)
    job = dataclasses.replace(job, parent_pid=os.getpid())  # Blender dies with this process
    if job.staged is None:
        return _run_blender(job, job.job_path, environ)
    private = tempfile.mkdtemp(prefix="deformkit-batch-checked-")  # 0700: this worker's user only
    try:
        try:
            staged_code.verified_copy(job.staged, private)
            job = dataclasses.replace(job, sys_paths=tuple(staged_code.private_paths(job.sys_paths, job.staged,
                                                                                     private)))
        except staged_code.StagedFileAltered as exc:
            return failed_row(src, dst, "StagedFileAltered", f"{exc}; it was changed after the launcher staged it, "
                              "and this file was not run (nothing of the staged code was imported)", "verify")
        return _run_blender(job, os.path.join(private, f"{job.index}.job.json"), environ)
    finally:
        shutil.rmtree(private, ignore_errors=True)


def _run_blender(job, job_path, environ):
    src, dst = job.input, job.output
    shared.write_json_atomically(job_path, job.to_dict(), job.token)
    env, _ = blender_environment(job.blender, environ)
    t0 = time.perf_counter()
    proc = BLENDERS.start(job.work, blender_command(job.blender, job_path), stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, text=True, errors="replace", env=env)
    if proc is None:
        return failed_row(src, dst, "Cancelled", "the run was stopped before this file started")
    try:
        with proc:  # as subprocess.run: killed on any exception, reaped on the way out
            try:
                stdout, stderr = proc.communicate(timeout=job.timeout)
                outcome = None
            except subprocess.TimeoutExpired as exc:
                proc.kill()
                proc.wait()
                stdout, stderr, outcome = exc.stdout, exc.stderr, f"timed out after {job.timeout:g} s"
            except BaseException:
                proc.kill()
                raise
    finally:
        BLENDERS.reaped(proc)
        for leftover in shared.run_temporaries(dst, job.token):  # only this run's
            if os.path.exists(leftover):
                os.unlink(leftover)
    seconds = round(time.perf_counter() - t0, 3)
    stdout = stdout if isinstance(stdout, str) else (stdout or b"").decode("utf-8", "replace")
    stderr = stderr if isinstance(stderr, str) else (stderr or b"").decode("utf-8", "replace")
    output = (stderr + stdout).strip().splitlines()
    result = _read_result(job.result_path, stdout)
    if outcome is None and result is not None and result.get("status") in ("ok", "failed"):
        # A row of this file even from a worker that could not read its job file (in_blender.py
        # then prints a result without the file); process_seconds: Blender's start-up included.
        return {**shared.file_row(src, dst), **result, "process_seconds": seconds}
    if outcome is not None:
        return _unfinished(src, dst, result, outcome, "TimeoutExpired", seconds, output)
    return _unfinished(src, dst, result, _death(proc.returncode), "BlenderDied", seconds, output)


def render_preview(npz_path, png_path, title):
    import numpy as np
    from deformkit.preview import Z_UP, render_before_after
    data = np.load(npz_path)
    render_before_after(png_path, data["before"], data["after"], data["faces"], title, to_plot=Z_UP)


def attach_preview(job, result):
    """`result` with the before/after PNG beside the output, drawn from the positions the worker
    left in the job's work folder (with --preview, for a file that went well)."""
    preview = job.preview_path
    if result["status"] == "ok" and preview and os.path.exists(preview) and "preview" not in result:
        png = os.path.splitext(job.output)[0] + ".png"
        try:
            names = "; ".join(f"{o['name']} ({' then '.join(e.lower() for e in o['entries'])})"
                              for o in result["objects"])
            render_preview(preview, png, f"{os.path.basename(job.input)}: {names}")
            result["preview"] = png
        except Exception as exc:  # a picture is a bonus; report, don't fail the file
            result["preview_error"] = f"{type(exc).__name__}: {exc}"
    return result


def run_job(job, environ=None):
    """The report row of one job (a BatchJob): refuse an output that is one of the run's inputs,
    run Blender on the job file with the job's timeout, collect the result, and with a preview
    draw the before/after PNG beside the output. Never raises for the file's own trouble: that is
    the row's "error". `environ` (default: this process's) is what Blender's environment is made
    from, on the machine that runs the job."""
    src, dst = job.input, job.output
    try:
        if any(same_file(dst, other) for other in job.never_write):
            return failed_row(src, dst, "InputError", f"refusing to write {dst}: it is one of the inputs")
        return attach_preview(job, run_blender(job, environ))
    except Exception as exc:  # the launcher's own trouble with this file still gets a row
        return failed_row(src, dst, type(exc).__name__, str(exc), "launch")

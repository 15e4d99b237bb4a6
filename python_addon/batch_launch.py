"""The launcher's side of one file: the environment Blender runs in, the run's staging folder, the
Blender process and what it left behind (its result file, or why there is none). No bpy."""
import contextlib
import json
import os
import re
import shutil
import signal
import subprocess
import tempfile
import time

import batch_io

ADDON_DIR = os.path.dirname(os.path.abspath(__file__))
BLEND_MAGIC = (b"BLENDER", b"\x1f\x8b", b"\x28\xb5\x2f\xfd")  # plain, gzip, zstd
PYTHON_NAME = re.compile(r"python3(\.\d+)?$")
STAGING = re.compile(re.escape(batch_io.STAGING_PREFIX) + r"(\d+)-[0-9a-f]+$")
# Runs in Blender: nothing here may fail without a result file, not even importing the add-on.
WORKER = """
import importlib.util, json, os, sys
spec = importlib.util.spec_from_file_location("deformkit_batch_io", {batch_io!r})
io = importlib.util.module_from_spec(spec)
spec.loader.exec_module(io)
io.prepare_worker({launcher!r})
sys.path[:0] = {paths!r}
job = {job!r}
try:
    import deformkit_addon
    deformkit_addon.register()
    from deformkit_addon import batch
except Exception as exc:
    record = io.exception_record(exc, "start")
    record["message"] += (" (Blender's Python: sys.prefix " + sys.prefix + ", sys.executable "
                          + str(sys.executable) + ")")
    with open(job) as fh:
        paths = json.load(fh)
    io.write_json_atomically(paths["result"], {{"file": paths["input"], "output": paths["output"],
        "status": "failed", "error": io.describe_failure(record), "exception": record, "objects": [],
        "warnings": [], "python_prefix": sys.prefix}}, paths["token"])
    sys.exit(1)
sys.exit(batch.worker_main(job))
"""


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


def pid_alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # someone else's process
    return True


@contextlib.contextmanager
def runs_locked(folder=None):
    """Serialise the runs' start-up (clean stale staging, check reports, make staging) on one
    lock file in the system temp folder, so that two runs starting together see each other."""
    path = os.path.join(folder or tempfile.gettempdir(), batch_io.STAGING_PREFIX + "startup.lock")
    try:
        import fcntl
    except ImportError:  # no flock: the checks still run, only not atomically
        yield
        return
    with open(path, "a") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def live_runs(folder=None):
    """{staging folder: report path} of the runs in progress."""
    folder = folder or tempfile.gettempdir()
    runs = {}
    for name in os.listdir(folder):
        match = STAGING.match(name)
        if match and pid_alive(int(match.group(1))):
            try:
                with open(os.path.join(folder, name, "report-path"), encoding="utf-8") as fh:
                    runs[os.path.join(folder, name)] = fh.read()
            except OSError:
                pass
    return runs


def clean_stale_staging(folder=None):
    """Remove the staging folders of runs whose launcher is gone (killed, so it could not clean
    up); those of live runs are left alone. Returns the folders removed."""
    folder = folder or tempfile.gettempdir()
    removed = []
    for name in os.listdir(folder):
        match = STAGING.match(name)
        if match and not pid_alive(int(match.group(1))):
            shutil.rmtree(os.path.join(folder, name), ignore_errors=True)
            removed.append(name)
    return removed


def make_staging(token, report_path):
    """This run's folder in the system temp folder: the add-on under its package name and the
    deformkit module (symbolic links), the report's path (for runs starting later), and the
    workers' job and result files."""
    work = os.path.join(tempfile.gettempdir(), batch_io.STAGING_PREFIX + token)
    addons, lib = os.path.join(work, "addons"), os.path.join(work, "lib")
    os.makedirs(addons)
    os.makedirs(lib)
    with open(os.path.join(work, "report-path"), "w", encoding="utf-8") as fh:
        fh.write(os.path.realpath(report_path))
    os.symlink(ADDON_DIR, os.path.join(addons, "deformkit_addon"))
    try:
        import deformkit
        os.symlink(os.path.dirname(deformkit.__file__), os.path.join(lib, "deformkit"))
    except ImportError:
        pass  # the add-on then reports the missing module for every file
    return work, [addons, lib]


def input_problem(path):
    if not os.path.exists(path):
        return "file not found"
    if not os.path.isfile(path):
        return "not a file"
    try:
        with open(path, "rb") as fh:
            head = fh.read(8)
    except OSError as exc:
        return f"cannot read it: {exc.strerror}"
    if not head.startswith(BLEND_MAGIC):
        return "not a .blend file (no BLENDER header)"
    return ""


def failed_row(src, dst, kind, message, stage="start", seconds=0.0, **extra):
    error = {"type": kind, "message": message, "stage": stage, "object": None, "entry": None}
    return {"file": src, "output": dst, "status": "failed", "error": batch_io.describe_failure(error),
            "exception": error, "objects": [], "warnings": [], "seconds": seconds, **extra}


def _read_result(path, stdout):
    try:
        with open(path, encoding="utf-8") as fh:
            return json.load(fh)
    except (OSError, ValueError):
        pass
    for line in reversed(stdout.splitlines()):
        if line.startswith(batch_io.RESULT_LINE):
            try:
                return json.loads(line[len(batch_io.RESULT_LINE):])
            except ValueError:
                break
    return None


def _death(returncode):
    if returncode < 0:
        try:
            return f"Blender was killed by {signal.Signals(-returncode).name}"
        except ValueError:
            return f"Blender was killed by signal {-returncode}"
    return f"Blender exited with status {returncode} without a result"


def _unfinished(src, dst, progress, message, kind, seconds, output):
    where = (progress or {}).get("stage") or {"stage": "start"}
    row = failed_row(src, dst, kind, f"{message} during stage '{where.get('stage')}'", where.get("stage"),
                     seconds, blender_output=output[-20:])
    row["exception"].update(object=where.get("object"), entry=where.get("entry"))
    row["error"] = batch_io.describe_failure(row["exception"])
    row["warnings"] = (progress or {}).get("warnings", [])
    return row


def run_one(blender, env, paths, job, timeout):
    """Run one file's job (a dict: input, output, result, ...) in its own Blender; the report row."""
    src, dst = job["input"], job["output"]
    problem = input_problem(src)
    if problem:
        return failed_row(src, dst, "InputError", problem)
    job_path = job["result"][:-len(".json")] + ".job.json"
    batch_io.write_json_atomically(job_path, job, job["token"])
    script = job["result"][:-len(".json")] + ".worker.py"  # a file: Blender echoes a failed --python-expr
    with open(script, "w", encoding="utf-8") as fh:
        fh.write(WORKER.format(batch_io=os.path.join(ADDON_DIR, "batch_io.py"), launcher=os.getpid(),
                               paths=paths, job=job_path))
    # -noaudio: a batch needs no sound, and the audio client maps 64 MB of shared memory at start-up
    cmd = [blender, "-b", "--factory-startup", "-noaudio", "--python-exit-code", "1", "--python", script]
    t0 = time.perf_counter()
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, errors="replace", timeout=timeout, env=env)
        outcome = None
    except subprocess.TimeoutExpired as exc:
        proc, outcome = exc, f"timed out after {timeout:g} s"
    finally:
        for leftover in batch_io.run_temporaries(dst, job["token"]):  # only this run's
            if os.path.exists(leftover):
                os.unlink(leftover)
    seconds = round(time.perf_counter() - t0, 3)
    stdout = proc.stdout if isinstance(proc.stdout, str) else (proc.stdout or b"").decode("utf-8", "replace")
    stderr = proc.stderr if isinstance(proc.stderr, str) else (proc.stderr or b"").decode("utf-8", "replace")
    output = (stderr + stdout).strip().splitlines()
    result = _read_result(job["result"], stdout)
    if outcome is None and result is not None and result.get("status") in ("ok", "failed"):
        result["process_seconds"] = seconds  # Blender start-up included
        return result
    if outcome is not None:
        return _unfinished(src, dst, result, outcome, "TimeoutExpired", seconds, output)
    return _unfinished(src, dst, result, _death(proc.returncode), "BlenderDied", seconds, output)

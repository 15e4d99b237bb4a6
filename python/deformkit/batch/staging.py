"""A run's staging folder in the system temp folder, and how runs see each other: the lock their
start-ups share, which runs are alive, and the clean-up of those whose launcher was killed. A run
on a Dask cluster stages in the output folder instead (shared storage: workers may be on other
machines), with copies of the add-on and the module rather than links into this machine."""
import contextlib
import glob
import json
import os
import re
import shutil
import socket
import tempfile
import time

from . import shared, staged_code

STAGING = re.compile(re.escape(shared.STAGING_PREFIX) + r"(\d+)-[0-9a-f]+$")
SHARED_PREFIX = ".deformkit-batch-"  # OUT/.deformkit-batch-<run token>: a cluster run's staging folder
SHARED = re.compile(re.escape(SHARED_PREFIX) + r"(\d+)-[0-9a-f]+$")


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
    path = os.path.join(folder or tempfile.gettempdir(), shared.STAGING_PREFIX + "startup.lock")
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
            try:  # in the system temp folder, where anyone may put a FIFO under that name
                data = shared.read_regular_file(os.path.join(folder, name, "report-path"), 64 * 1024)
                runs[os.path.join(folder, name)] = data.decode("utf-8")
            except (OSError, ValueError):
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


def make_staging(token, report_path, addon_dir):
    """This run's folder in the system temp folder: the add-on (from `addon_dir`) under its package
    name and the deformkit module (symbolic links), the report's path (for runs starting later),
    and the workers' job and result files. Returns (folder, the paths for Blender's sys.path)."""
    work = os.path.join(tempfile.gettempdir(), shared.STAGING_PREFIX + token)
    addons, lib = os.path.join(work, "addons"), os.path.join(work, "lib")
    os.makedirs(addons)
    os.makedirs(lib)
    with open(os.path.join(work, "report-path"), "w", encoding="utf-8") as fh:
        fh.write(os.path.realpath(report_path))
    os.symlink(addon_dir, os.path.join(addons, "deformkit_addon"))
    os.symlink(_package_folder(), os.path.join(lib, "deformkit"))
    return work, [addons, lib]


def _package_folder():
    """This package's deformkit folder: the launcher and the workers run the same deformkit."""
    return os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def make_shared_staging(token, report_path, addon_dir, out_dir):
    """A cluster run's folder, OUT/.deformkit-batch-<token>: copies of the add-on (under its
    package name) and of the deformkit module, which every worker's Blender imports, the report's
    path, the launcher's host and pid (for clean_stale_shared_staging) and the attempts' folders.
    Returns (folder, the paths for Blender's sys.path, the staged code's hashes for the jobs:
    staged_code.py)."""
    work = os.path.join(out_dir, SHARED_PREFIX + token)
    addons, lib = os.path.join(work, "addons"), os.path.join(work, "lib")
    os.makedirs(work)
    try:
        files = staged_code.stage_tree(addon_dir, work, os.path.join("addons", "deformkit_addon"))
        files.update(staged_code.stage_tree(_package_folder(), work, os.path.join("lib", "deformkit")))
        with open(os.path.join(work, "report-path"), "w", encoding="utf-8") as fh:
            fh.write(os.path.realpath(report_path))
        with open(os.path.join(work, "launcher.json"), "w", encoding="utf-8") as fh:
            json.dump({"host": socket.gethostname(), "pid": os.getpid()}, fh)
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)
        raise
    return work, [addons, lib], {"folder": work, "files": files}


def clean_stale_shared_staging(out_dir):
    """Remove the cluster staging folders in `out_dir` left by launchers of this machine that are
    gone (killed), and their attempts' temporary outputs; those of other machines' launchers,
    which cannot be checked, are left alone."""
    removed = []
    for name in os.listdir(out_dir):
        if not SHARED.match(name):
            continue
        try:
            launcher = shared.read_json_file(os.path.join(out_dir, name, "launcher.json"), 64 * 1024)
        except (OSError, ValueError):
            continue
        if not isinstance(launcher, dict):
            continue
        pid = launcher.get("pid")
        if launcher.get("host") == socket.gethostname() and isinstance(pid, int) and pid > 0 and not pid_alive(pid):
            token = name[len(SHARED_PREFIX):]  # its attempts' half files carry it (attempts.attempt_id)
            for leftover in glob.glob(os.path.join(glob.escape(out_dir), f"*{shared.TEMP_MARK}{token}-f*")):
                os.unlink(leftover)
            shutil.rmtree(os.path.join(out_dir, name), ignore_errors=True)
            removed.append(name)
    return removed


def remove_staging(work, tries=5):
    """Remove a run's staging folder, again if something still wrote in it meanwhile (a cluster's
    cancelled attempt recording its end)."""
    for _ in range(tries):
        shutil.rmtree(work, ignore_errors=True)
        if not os.path.exists(work):
            return True
        time.sleep(0.2)
    return False

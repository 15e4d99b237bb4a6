"""The batch on a real Dask cluster (tests/support/dask_cluster.py: a `dask scheduler` and `dask
worker` processes on 127.0.0.1) with the fake Blender: the rows and outputs the local executor
gives; a worker SIGKILLed in the middle of a file, whose file another worker finishes, its
Blender dead with it and its half file never renamed; retries bounded; a complete earlier
attempt not redone unless asked; workers that cannot write the output folder; a scheduler out of
reach; Ctrl+C on the launcher; the local executor without Dask installed."""
import contextlib
import json
import os
import pathlib
import pty
import re
import signal
import socket
import subprocess
import sys
import threading
import time

import pytest

from support.dask_cluster import DaskCluster, fake_inputs as inputs

REPO = pathlib.Path(__file__).resolve().parents[2]
ADDON = str(REPO / "python_addon")
RUN_SECONDS = 180
VOLATILE = ("seconds", "process_seconds", "pid", "parent", "job_seen", "output_stat", "worker", "attempts",
            "queue_seconds")


def comparable(row, out):
    """A row without its times, pids and Dask fields, its output named relative to `out`."""
    kept = {k: v for k, v in row.items() if k not in VOLATILE}
    return {**kept, "output": os.path.relpath(row["output"], out)}


def command(blender, paths, out, *options):
    return [sys.executable, "-m", "deformkit.batch", "--addon", ADDON, "--blender", blender, *map(str, paths),
            "--evaluate-saved", "--out", str(out), *map(str, options)]


def batch(blender, paths, out, *options):
    return subprocess.run(command(blender, paths, out, *options), capture_output=True, text=True,
                          timeout=RUN_SECONDS)


def start(blender, paths, out, *options):
    return subprocess.Popen(command(blender, paths, out, *options), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)


class Terminal:
    """The launcher's stdout on a pseudo-terminal (its progress line is then redrawn at every
    attempt's start as well as at every file's end), read by a thread until the launcher closes it."""

    def __init__(self):
        self.master, self.slave = pty.openpty()
        self.text, self.changed = "", threading.Condition()
        self.reader = threading.Thread(target=self._read, daemon=True)

    def _read(self):
        while True:
            try:
                data = os.read(self.master, 4096)
            except OSError:  # EIO: every writer has closed the terminal
                data = b""
            with self.changed:
                if not data:
                    self.changed.notify_all()
                    return
                self.text += data.decode("utf-8", "replace")
                self.changed.notify_all()

    def wait_for(self, pattern, process, seconds=120.0):
        """Until `pattern` appears in what was written; the timeout only guards against a hang."""
        with self.changed:
            found = self.changed.wait_for(lambda: pattern.search(self.text) or process.poll() is not None
                                          or not self.reader.is_alive(), seconds)
        assert found and pattern.search(self.text), f"never saw {pattern.pattern!r} in:\n{self.text[-3000:]}"

    def wait_until(self, condition, process, seconds=120.0):
        """Until condition() holds, tried after each read and every 0.1 s (it may look at files
        too); the timeout only guards against a hang."""
        deadline = time.monotonic() + seconds
        with self.changed:
            while not condition():
                assert process.poll() is None and time.monotonic() < deadline, \
                    f"the run never came to rest; the launcher wrote:\n{self.text[-3000:]}"
                self.changed.wait(0.1)

    def close(self):
        self.reader.join(timeout=30)
        os.close(self.master)


def start_on_a_terminal(blender, paths, out, *options):
    terminal = Terminal()
    launcher = subprocess.Popen(command(blender, paths, out, *options), stdout=terminal.slave,
                                stderr=subprocess.PIPE, text=True, start_new_session=True,
                                env={**os.environ, "COLUMNS": "400"})
    os.close(terminal.slave)
    terminal.reader.start()
    return launcher, terminal


def report_of(out):
    return json.loads((pathlib.Path(out) / "report.json").read_text())


def wait_for(condition, seconds=60.0, what="a condition"):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.05)
    raise AssertionError(f"timed out after {seconds} s waiting for {what}")


def alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # a zombie is dead: it only waits for its parent to read its status
        return pathlib.Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


def started_attempt(out, index=0):
    """(attempt folder, its record, the fake Blender's progress) of the first attempt at file
    `index` once its fake Blender hangs."""
    marks = list(pathlib.Path(out).glob(f".deformkit-batch-*/attempts/{index}/1/{index}.started"))
    if not marks:
        return None
    folder = marks[0].parent
    return folder, json.loads((folder / "record.json").read_text()), json.loads((folder / f"{index}.json").read_text())


def runs(path):
    """The fake Blender's runs of an input: one line each (pid, work folder)."""
    runs_file = pathlib.Path(f"{path}.runs")
    return runs_file.read_text().splitlines() if runs_file.exists() else []


@pytest.fixture
def cluster(tmp_path):
    with DaskCluster(tmp_path / "cluster", workers=2) as running:
        yield running


def test_rows_and_outputs_are_the_local_executors(cluster, fake_blender, tmp_path):
    """Good, failing, crashing and unreadable files: each row is the local executor's (but for
    times, pids and the Dask fields), each output the same bytes; each file done once, on one of
    the cluster's workers (which worker is the scheduler's choice, not asserted); a stale staging
    folder of a dead launcher of this machine is removed."""
    paths = inputs(tmp_path / "in", ["ok", "fail", "ok", "segv", "stdout", "exit", "ok", "ok"])
    (tmp_path / "in" / "notes.blend").write_text("not a blend file")
    paths += [tmp_path / "in" / "notes.blend", tmp_path / "in" / "missing.blend"]
    local = batch(fake_blender, paths, tmp_path / "local", "--jobs", 2)
    out = tmp_path / "dask"
    stale, foreign = out / ".deformkit-batch-999999999-0badc0de", out / ".deformkit-batch-1-0badc0de"
    for folder, host in ((stale, socket.gethostname()), (foreign, "another-machine")):
        folder.mkdir(parents=True)
        (folder / "launcher.json").write_text(json.dumps({"host": host, "pid": 999999999}))
    dask = batch(fake_blender, paths, out, "--scheduler", cluster.address)
    assert local.returncode == dask.returncode == 1, dask.stdout + dask.stderr + cluster.logs()
    ours, theirs = report_of(out), report_of(tmp_path / "local")
    assert ours["complete"] and (ours["ok"], ours["failed"]) == (theirs["ok"], theirs["failed"]) == (5, 5)
    for row, twin in zip(ours["files"], theirs["files"]):
        assert comparable(row, out) == comparable(twin, tmp_path / "local"), row["file"]
    assert all(r["attempts"] for r in ours["files"])  # every file is a task: unreadable ones fail in it
    workers = set(cluster.worker_pids())
    for row in ours["files"]:
        assert row["worker"] in workers and isinstance(row["queue_seconds"], float)
        assert [(a["attempt"], a["outcome"], a["worker"]) for a in row["attempts"]] == \
               [(1, row["status"], row["worker"])]
    assert all(len(runs(p)) == 2 for p in paths[:8])  # once for the local run, once on the cluster
    written = sorted(p.name for p in out.iterdir())
    assert written == sorted([p.name for p in (tmp_path / "local").iterdir()] + [foreign.name])
    for name in written:
        if name.endswith(".blend"):
            assert (out / name).read_bytes() == (tmp_path / "local" / name).read_bytes()
    assert ours["executor"]["kind"] == "dask" and ours["executor"]["workers"] == {w: 1.0 for w in workers}
    assert "dashboard: none" in dask.stdout and "progress: 10/10 done (5 failed), 0 running" in dask.stdout


@pytest.mark.parametrize("allowed_failures", [3, 0], ids=["scheduler-reruns", "launcher-resubmits"])
def test_a_worker_killed_mid_file(tmp_path, fake_blender, allowed_failures):
    """SIGKILL of the worker whose Blender is saving file 0: its Blender dies with it, the other
    worker does the file again (rerun by the scheduler, or, once it gives up with KilledWorker,
    sent again by the launcher), the half file of the first attempt is never renamed into place,
    and the row lists both attempts, the first lost on the killed worker."""
    with DaskCluster(tmp_path / "cluster", workers=2, allowed_failures=allowed_failures) as cluster:
        paths = inputs(tmp_path / "in", ["hang-once", "ok", "ok", "ok"])
        out = tmp_path / "out"
        launcher = start(fake_blender, paths, out, "--scheduler", cluster.address)
        folder, record, progress = wait_for(lambda: started_attempt(out), what="file 0 to hang")
        half = out / f"0_hang-once.blend.deformkit-{record['id']}.tmp.blend"
        assert half.read_bytes() == b"BLENDER half a file" and alive(progress["pid"])
        os.kill(record["pid"], signal.SIGKILL)
        wait_for(lambda: not alive(progress["pid"]), 20, "the killed worker's Blender to die")
        stdout, stderr = launcher.communicate(timeout=RUN_SECONDS)
        assert launcher.returncode == 0, stdout + stderr + cluster.logs()
    report = report_of(out)
    row = report["files"][0]
    survivor = next(w for w in report["executor"]["workers"] if w != record["worker"])
    assert row["status"] == "ok" and row["worker"] == survivor
    first, second = row["attempts"]
    assert (first["attempt"], first["outcome"], first["worker"], first["end"]) == (1, "lost", record["worker"], None)
    assert f"worker {record['worker']} (pid {record['pid']}" in first["error"]
    assert "during stage 'save', with no result" in first["error"]
    if allowed_failures == 0:
        assert "KilledWorker" in first["error"]
    assert (second["attempt"], second["outcome"], second["worker"]) == (2, "ok", survivor)
    assert len(runs(paths[0])) == 2 and all(len(runs(p)) == 1 for p in paths[1:])
    assert (out / "0_hang-once.blend").read_bytes() == b"BLENDER output of 0_hang-once.blend"
    assert sorted(p.name for p in out.iterdir()) == sorted([p.name for p in paths] + ["report.json"])
    assert "[4/4]" in stdout and "2 attempts" in stdout and "0_hang-once.blend: attempt 2 on" in stdout


def test_workers_under_nannies(tmp_path, fake_blender):
    """Workers as `dask worker` starts them by default, under a nanny: the Blenders get the
    environment the local executor gives them (not the nanny's one-thread settings for numpy
    tasks), and a worker killed mid-file is replaced by its nanny while the file is done again."""
    paths = inputs(tmp_path / "in", ["hang-once", "ok", "ok"])
    with DaskCluster(tmp_path / "cluster", workers=2, nanny=True) as cluster:
        nanny_env = cluster.client().run(lambda: os.environ.get("OMP_NUM_THREADS"))
        out = tmp_path / "out"
        launcher = start(fake_blender, paths, out, "--scheduler", cluster.address)
        _, record, _ = wait_for(lambda: started_attempt(out), what="file 0 to hang")
        os.kill(record["pid"], signal.SIGKILL)
        stdout, stderr = launcher.communicate(timeout=RUN_SECONDS)
        assert launcher.returncode == 0, stdout + stderr + cluster.logs()
        wait_for(lambda: len(cluster.worker_pids()) == 2, 60, "the nanny to start a new worker")
        assert record["pid"] not in cluster.worker_pids().values()
    assert set(nanny_env.values()) == {"1"}  # what the nanny gives its workers
    local = batch(fake_blender, paths[1:], tmp_path / "local")
    assert local.returncode == 0, local.stdout + local.stderr
    expected = report_of(tmp_path / "local")["files"][0]["environment"]
    files = report_of(out)["files"]
    assert [f["status"] for f in files] == ["ok"] * 3 and [len(f["attempts"]) for f in files] == [2, 1, 1]
    assert all(f["environment"] == expected for f in files)


def test_retries_are_bounded(cluster, fake_blender, tmp_path):
    """--retries 0: the file whose worker died is not run again (though the scheduler sends its
    task again), and its row says it was lost; the other files are done."""
    paths = inputs(tmp_path / "in", ["hang-once", "ok", "ok"])
    out = tmp_path / "out"
    launcher = start(fake_blender, paths, out, "--scheduler", cluster.address, "--retries", 0)
    _, record, _ = wait_for(lambda: started_attempt(out), what="file 0 to hang")
    os.kill(record["pid"], signal.SIGKILL)
    stdout, stderr = launcher.communicate(timeout=RUN_SECONDS)
    assert launcher.returncode == 1, stdout + stderr
    report = report_of(out)
    row = report["files"][0]
    assert row["status"] == "failed" and row["exception"]["type"] == "WorkerLost"
    assert row["error"].startswith("WorkerLost: the worker running it was lost in 1 of 1 attempts, and no attempt "
                                   "is left (at most 1)")
    assert [a["outcome"] for a in row["attempts"]] == ["lost"] and len(runs(paths[0])) == 1
    assert [r["status"] for r in report["files"][1:]] == ["ok", "ok"] and report["executor"]["retries"] == 0
    assert sorted(p.name for p in out.iterdir()) == ["1_ok.blend", "2_ok.blend", "report.json"]


@pytest.mark.parametrize("redo", [False, True], ids=["kept", "redo-complete"])
def test_a_complete_attempt_is_not_redone(cluster, fake_blender, tmp_path, redo):
    """The worker dies after its Blender wrote the output and its result: the retry finds that
    result, and the very output it names in place, and reuses it; --redo-complete runs it again."""
    paths = inputs(tmp_path / "in", ["done-then-hang-once", "ok"])
    out = tmp_path / "out"
    launcher = start(fake_blender, paths, out, "--scheduler", cluster.address, *(["--redo-complete"] if redo else []))
    _, record, progress = wait_for(lambda: started_attempt(out), what="file 0 to finish and hang")
    written = (out / "0_done-then-hang-once.blend").stat().st_mtime_ns
    assert progress["status"] == "ok"
    os.kill(record["pid"], signal.SIGKILL)
    stdout, stderr = launcher.communicate(timeout=RUN_SECONDS)
    assert launcher.returncode == 0, stdout + stderr
    row = report_of(out)["files"][0]
    first, second = row["attempts"]
    assert first["outcome"] == "lost" and "after its Blender had finished the file" in first["error"]
    assert len(runs(paths[0])) == (2 if redo else 1)
    if redo:
        assert second["outcome"] == "ok" and row["job_seen"]["token"].endswith("-f0-a2")
        assert (out / "0_done-then-hang-once.blend").stat().st_mtime_ns != written
    else:
        assert (second["outcome"], second["error"]) == ("reused", "attempt 1 had completed the file; not redone")
        assert row["job_seen"]["token"].endswith("-f0-a1") and row["worker"] == second["worker"]
        assert (out / "0_done-then-hang-once.blend").stat().st_mtime_ns == written
    assert (out / "0_done-then-hang-once.blend").read_bytes() == b"BLENDER output of 0_done-then-hang-once.blend"


@pytest.mark.parametrize("view", ["output-read-only", "inputs-hidden"])
def test_workers_that_do_not_share_the_storage(tmp_path, fake_blender, view):
    """The workers see the storage otherwise than the launcher (their own mount namespace): the
    output folder mounted read-only for them (a share exported read-only to some machines), or
    the inputs' folder hidden under an empty file system (a share not mounted there). The run
    stops before any file with one line naming the argument, a worker and the path, and leaves
    nothing behind."""
    out, folder = tmp_path / "out", tmp_path / "in"
    out.mkdir()
    paths = inputs(folder, ["ok", "ok"])
    mount = {"output-read-only": 'mount --bind "$0" "$0" && mount -o remount,bind,ro "$0"',
             "inputs-hidden": 'mount -t tmpfs none "$0"'}[view]
    prefix = ["unshare", "--mount", "--propagation", "private", "sh", "-c", mount + ' && exec "$@"',
              str(out if view == "output-read-only" else folder)]
    with DaskCluster(tmp_path / "cluster", workers=2, worker_prefix=prefix) as cluster:
        proc = batch(fake_blender, paths, out, "--scheduler", cluster.address)
        workers = set(cluster.worker_pids())
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
    if view == "output-read-only":
        assert proc.stderr.startswith("deformkit-batch: error: --out: worker tcp://127.0.0.1:"), proc.stderr
        assert f": {out}: cannot write in it: Read-only file system" in proc.stderr
    else:
        assert proc.stderr.startswith("deformkit-batch: error: inputs: worker tcp://127.0.0.1:"), proc.stderr
        assert f": {paths[0]}: file not found (and 1 more problems)" in proc.stderr
    assert any(w in proc.stderr for w in workers) and "(shared storage)" in proc.stderr
    assert os.listdir(out) == [] and not any(runs(p) for p in paths)


def test_blender_missing_on_the_workers(cluster, fake_blender, tmp_path):
    """With --scheduler the launcher needs no Blender; the workers do, at the path given."""
    paths = inputs(tmp_path / "in", ["ok"])
    proc = batch(str(tmp_path / "nowhere" / "blender"), paths, tmp_path / "out", "--scheduler", cluster.address)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
    assert proc.stderr.startswith("deformkit-batch: error: --blender: worker tcp://127.0.0.1:"), proc.stderr
    assert f": {tmp_path / 'nowhere' / 'blender'}: not found or not executable on this worker" in proc.stderr
    assert os.listdir(tmp_path / "out") == []


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_scheduler_out_of_reach_or_without_workers(tmp_path, fake_blender):
    paths = inputs(tmp_path / "in", ["ok"])
    address = f"tcp://127.0.0.1:{free_port()}"
    proc = batch(fake_blender, paths, tmp_path / "out", "--scheduler", address, "--connect-timeout", 2)
    assert proc.returncode == 2, proc.stderr  # the 2 s bound given is the one applied: the message says so
    assert proc.stderr.startswith(f"deformkit-batch: error: --scheduler: cannot reach the Dask scheduler {address} "
                                  "within 2 s"), proc.stderr
    assert proc.stderr.count("\n") == 1 and not (tmp_path / "out" / "report.json").exists()
    with DaskCluster(tmp_path / "cluster", workers=0) as cluster:
        proc = batch(fake_blender, paths, tmp_path / "out", "--scheduler", cluster.address, "--connect-timeout", 2)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
    assert f"--scheduler: no worker of {cluster.address} offers the resource 'blender' after 2 s" in proc.stderr
    assert "--resources blender=1 --nthreads 1" in proc.stderr and os.listdir(tmp_path / "out") == []


@pytest.mark.parametrize("where", ["scheduler", "dask-local"])
def test_ctrl_c_on_the_launcher(fake_blender, tmp_path, where):
    """Ctrl+C: SIGINT to the launcher alone (its cluster's worker is elsewhere), or to its whole
    process group as a terminal sends it (a LocalCluster's worker and its Blenders are in it).
    As with the local executor, the files not started are dropped (pending) and the running ones
    reported, their Blenders killed by SIGINT in the stage they were in (their job files are in the
    worker's private copy of the staged code, not in the staging folder); the tasks are gone from
    the cluster, the staging folder is removed, and the launcher ends with KeyboardInterrupt.
    One worker running two files at a time holds every task: it runs them in the inputs' order,
    so the run comes to rest in one known state whatever the scheduler does (file 0 done, both
    "sleep" files hanging, the "ok" files after them waiting for a free slot)."""
    paths = inputs(tmp_path / "in", ["ok", "sleep", "sleep", "ok", "ok", "ok"])
    out = tmp_path / "out"
    with contextlib.ExitStack() as stack:
        if where == "scheduler":
            cluster = stack.enter_context(DaskCluster(tmp_path / "cluster", workers=1, slots=2))
            options = ["--scheduler", cluster.address]
        else:
            options = ["--executor", "dask-local", "--workers", "1", "--blender-per-worker", "2"]
        launcher, terminal = start_on_a_terminal(fake_blender, paths, out, *options)
        # At rest, and the launcher knows what runs (its progress line, redrawn at each start on a
        # terminal, says 2 running); both fake Blenders have reached their stage 'evaluate' (their
        # marks), so Ctrl+C does not find them still starting.
        terminal.wait_until(lambda: "progress: 1/6 done (0 failed), 2 running" in terminal.text.rsplit("\r", 1)[-1]
                            and started_attempt(out, 1) and started_attempt(out, 2), launcher)
        os.killpg(launcher.pid, signal.SIGINT)
        _, stderr = launcher.communicate(timeout=60)  # a guard against a hang: the launcher ends at once
        terminal.close()
        assert launcher.returncode != 0 and "KeyboardInterrupt" in stderr, stderr
        if where == "scheduler":
            wait_for(lambda: cluster.tasks_on_scheduler() == 0, 30, "the scheduler to drop the run's tasks")
        blenders = [int(line.split()[0]) for p in paths for line in runs(p)]
        for pid in blenders:
            wait_for(lambda: not alive(pid), 20, f"Blender {pid} to stop")
        # Nothing can start a file any more: the launcher (and a LocalCluster's scheduler in it) has
        # exited, the scheduler holds none of the run's tasks, the Blenders it started are gone.
    report = report_of(out)
    assert not report["complete"] and report["ok"] >= 1 and report["pending"] >= 1
    assert [r["status"] for r in report["files"]] == ["ok", "failed", "failed", "pending", "pending", "pending"]
    for row in report["files"][1:3]:
        assert row["error"] == "BlenderDied: Blender was killed by SIGINT during stage 'evaluate' (object Fake)", row
    assert [len(runs(p)) for p in paths] == [1, 1, 1, 0, 0, 0]
    for row, path in zip(report["files"], paths):
        output = out / path.name
        assert output.exists() == (row["status"] == "ok"), row
        if row["status"] == "ok":
            assert output.read_bytes() == f"BLENDER output of {path.name}".encode()
    names = sorted(p.name for p in out.iterdir())
    assert names == sorted(["report.json"] + [p.name for p, r in zip(paths, report["files"]) if r["status"] == "ok"])


def test_a_killed_launcher_takes_its_local_cluster_along(fake_blender, tmp_path):
    """SIGKILL of a dask-local launcher: its workers and their Blenders die with it; it leaves its
    report, staging folder and a half file, which the next cluster run into that folder removes."""
    paths = inputs(tmp_path / "in", ["hang-once", "ok"])
    out = tmp_path / "out"
    launcher = start(fake_blender, paths, out, "--executor", "dask-local", "--workers", "1")
    _, record, progress = wait_for(lambda: started_attempt(out), what="file 0 to hang")
    launcher.kill()
    launcher.communicate(timeout=60)
    for pid in (record["pid"], progress["pid"]):
        wait_for(lambda: not alive(pid), 20, f"process {pid} (worker, then Blender) to die")
    left = sorted(p.name for p in out.iterdir())
    assert len([n for n in left if n.startswith(".deformkit-batch-")]) == 1 and "report.json" in left
    assert any(".tmp.blend" in n for n in left), left
    proc = batch(fake_blender, paths[1:], out, "--executor", "dask-local", "--workers", "1")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert sorted(p.name for p in out.iterdir()) == ["1_ok.blend", "report.json"]


def test_the_scheduler_dies_mid_run(tmp_path, fake_blender):
    """The scheduler SIGKILLed while a file runs: the launcher does not hang; every file not done
    gets a SchedulerLost row, the report is complete, exit status 1. (Found under load: a file
    whose result was on its way when the scheduler died is reported lost although its worker
    renames its output into place.)"""
    paths = inputs(tmp_path / "in", ["ok", "sleep", "ok", "ok", "ok", "ok"])
    out = tmp_path / "out"
    with DaskCluster(tmp_path / "cluster", workers=2) as cluster:
        launcher = start(fake_blender, paths, out, "--scheduler", cluster.address)
        wait_for(lambda: started_attempt(out, 1), what="file 1 to hang")
        os.killpg(cluster.processes[0].pid, signal.SIGKILL)  # the scheduler: the first process started
        stdout, stderr = launcher.communicate(timeout=120)
    assert launcher.returncode == 1, stdout + stderr
    report = report_of(out)
    assert report["complete"] and report["pending"] == 0 and report["files"][1]["status"] == "failed", \
        (report, stdout, stderr)
    for row in report["files"]:
        assert row["status"] == "ok" or row["error"].startswith(
            "SchedulerLost: the connection to the Dask scheduler was lost before the file was done"), row
        # A lost file's worker outlives the scheduler and may still finish it after the launcher
        # has given up: its output may then exist, whole (renamed into place); an ok file's must.
        if row["status"] == "ok":
            assert (out / os.path.basename(row["output"])).exists(), row


BLOCK_DASK = """
import importlib.abc, sys
class NoDask(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in ("dask", "distributed"):
            raise ModuleNotFoundError(f"No module named {name!r} (blocked by the test)")
sys.meta_path.insert(0, NoDask())
from deformkit.batch import main
code = main(sys.argv[1:])
assert not any(m.split(".")[0] in ("dask", "distributed") for m in sys.modules), "dask was imported"
sys.exit(code)
"""


def test_without_dask_the_local_executor_still_works(fake_blender, tmp_path):
    paths = inputs(tmp_path / "in", ["ok", "fail"])
    base = [sys.executable, "-c", BLOCK_DASK, "--addon", ADDON, "--blender", fake_blender, *map(str, paths),
            "--evaluate-saved"]
    proc = subprocess.run(base + ["--out", str(tmp_path / "local"), "--jobs", "2"], capture_output=True, text=True,
                          timeout=RUN_SECONDS)
    assert proc.returncode == 1 and "1 ok, 1 failed" in proc.stdout, proc.stdout + proc.stderr
    assert report_of(tmp_path / "local")["executor"] == {"kind": "local", "jobs": 2}
    for extra, argument in ((["--executor", "dask-local"], "--executor dask-local"),
                            (["--scheduler", "tcp://127.0.0.1:8786"], "--scheduler")):
        proc = subprocess.run(base + ["--out", str(tmp_path / "dask"), *extra], capture_output=True, text=True,
                              timeout=RUN_SECONDS)
        assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
        assert proc.stderr.startswith(f"deformkit-batch: error: {argument}: needs dask and distributed, which are "
                                      "not installed here; install dask==2025.12.0 and distributed==2025.12.0")
    assert not (tmp_path / "dask").exists()


@pytest.mark.parametrize("options, message", [
    (["--scheduler", "tcp://127.0.0.1:8786", "--jobs", "2"], "--jobs: for local processes only"),
    (["--scheduler", "tcp://127.0.0.1:8786", "--executor", "dask-local"],
     "--executor: dask-local cannot be combined with --scheduler"),
    (["--scheduler", "tcp://127.0.0.1:8786", "--workers", "2"], "--workers: only with --executor dask-local"),
    (["--blender-per-worker", "2"], "--blender-per-worker: only with --executor dask-local"),
    (["--retries", "1"], "--retries: only with --scheduler or --executor dask-local"),
    (["--redo-complete"], "--redo-complete: only with --scheduler or --executor dask-local"),
    (["--executor", "dask-local", "--connect-timeout", "5"], "--connect-timeout: only with --scheduler"),
    (["--scheduler", "localhost"],
     "argument --scheduler: expected a scheduler address tcp://HOST:PORT, got 'localhost'"),
    (["--executor", "dask-local", "--workers", "0"], "argument --workers: expected 1..256 workers, got '0'"),
    (["--scheduler", "tcp://127.0.0.1:8786", "--retries", "-1"], "argument --retries: expected 0..100 retries"),
])
def test_bad_combinations_are_one_line_errors(fake_blender, tmp_path, options, message):
    paths = inputs(tmp_path / "in", ["ok"])
    proc = subprocess.run(command(fake_blender, paths, tmp_path / "out", *options), capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
    assert proc.stderr.startswith(f"deformkit-batch: error: {message}"), proc.stderr
    assert not any(runs(p) for p in paths)


def test_a_local_cluster_with_two_blenders_per_worker(fake_blender, tmp_path):
    """--executor dask-local --workers 1 --blender-per-worker 2: one worker process runs two
    files at once (each "meet" file finishes only once the other has started), and the report
    says so."""
    paths = inputs(tmp_path / "in", ["meet", "meet"])
    proc = batch(fake_blender, paths, tmp_path / "out", "--executor", "dask-local", "--workers", 1,
                 "--blender-per-worker", 2)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    report = report_of(tmp_path / "out")
    assert list(report["executor"]["workers"].values()) == [2] and report["executor"]["kind"] == "dask-local"
    (a,), (b,) = (r["attempts"] for r in report["files"])
    assert a["worker"] == b["worker"] and [r["status"] for r in report["files"]] == ["ok", "ok"]
    assert "a Dask LocalCluster: 1 workers, 2 files at a time" in proc.stdout


def test_python_api_takes_a_client_or_an_address(cluster, fake_blender, tmp_path):
    """main(argv, client=...) runs on the caller's cluster and leaves the caller's client open."""
    from deformkit.batch import main
    paths = inputs(tmp_path / "in", ["ok", "fail"])
    client = cluster.client()
    for given, out in ((client, tmp_path / "a"), (cluster.address, tmp_path / "b")):
        argv = ["--addon", ADDON, "--blender", fake_blender, *map(str, paths), "--evaluate-saved", "--out", str(out)]
        assert main(argv, client=given) == 1
        report = report_of(out)
        assert [r["status"] for r in report["files"]] == ["ok", "failed"]
        assert report["executor"]["scheduler"] == cluster.address
    assert client.status == "running" and client.submit(sum, [1, 2]).result(timeout=30) == 3

"""The batch command under faults: bad command lines, a report that would overwrite a file, full
disks and unwritable folders, errors inside Blender, a killed launcher, two runs in one folder,
damaged .blend files and a foreign Python on PATH. Each must leave a report that says what went
wrong (or a one-line error before anything ran), and never lose a result."""
import json
import os
import pathlib
import resource
import select
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from addon_helpers import IN_BLENDER_BINARY, REPO

pytestmark = pytest.mark.skipif(IN_BLENDER_BINARY, reason="the batch tests start Blender themselves")
BLENDER = "/usr/bin/blender"
CLI = [sys.executable, "-m", "deformkit.batch", "--addon", str(REPO / "python_addon"), "--blender", BLENDER]
TWIST = {"objects": ["*"], "deformers": [{"type": "TWIST", "angle": 1.2, "deform_axis": "Z"}]}


def batch(*args, **kw):
    return subprocess.run([*CLI, *map(str, args)], capture_output=True, text=True, timeout=300, **kw)


def start(*args, **kw):
    return subprocess.Popen([*CLI, *map(str, args)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


def report_of(path):
    return json.loads(pathlib.Path(path).read_text())


def row(report, name):
    return next(f for f in report["files"] if os.path.basename(f["file"]) == name)


def assert_one_line_error(proc, argument):
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert proc.stderr.startswith(f"deformkit-batch: error: {argument}"), proc.stderr
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr, proc.stderr


@pytest.fixture
def recipe(tmp_path):
    path = tmp_path / "twist.json"
    path.write_text(json.dumps(TWIST))
    return path


@pytest.fixture
def column(fixtures, tmp_path):
    (tmp_path / "in").mkdir(exist_ok=True)
    return pathlib.Path(shutil.copy(fixtures / "column.blend", tmp_path / "in"))


def test_report_never_overwrites_an_input_output_or_recipe(column, recipe, tmp_path):
    out = tmp_path / "out"
    (tmp_path / "to_output.json").symlink_to(out / "column.blend")  # dangling until the output exists
    os.link(column, tmp_path / "hard_link.json")
    for report, kind in ((out / "column.blend", "output"), (tmp_path / "to_output.json", "output"),
                         (tmp_path / "hard_link.json", "input"), (column, "input"), (recipe, "recipe")):
        before = column.read_bytes()
        proc = batch(column, "--recipe", recipe, "--out", out, "--report", report)
        assert_one_line_error(proc, "--report")
        assert f"is the {kind}" in proc.stderr
        assert column.read_bytes() == before and not (out / "column.blend").exists()


@pytest.mark.parametrize("case, argument, message", [
    ("out_is_a_file", "--out", "is a file, not a folder"),
    ("missing_recipe", "--recipe", "not found"),
    ("recipe_is_a_folder", "--recipe", "is a folder, not a recipe file"),
    ("report_in_missing_folder", "--report", "does not exist"),
    ("timeout_nan", "argument --timeout", "finite number of seconds above 0, got 'nan'"),
    ("timeout_inf", "argument --timeout", "finite number of seconds above 0, got 'inf'"),
    ("timeout_0", "argument --timeout", "finite number of seconds above 0, got '0'"),
    ("timeout_negative", "argument --timeout", "finite number of seconds above 0, got '-5'"),
    ("timeout_text", "argument --timeout", "expected a number of seconds, got 'soon'"),
    ("jobs_0", "argument --jobs", "expected 1..256 files at a time, got '0'"),
])
def test_bad_command_lines_are_one_line_errors(column, recipe, tmp_path, case, argument, message):
    (tmp_path / "a_file").write_text("x")
    args = {"out": tmp_path / "out", "recipe": recipe, "report": None, "timeout": "600", "jobs": "1"}
    args.update({"out_is_a_file": {"out": tmp_path / "a_file"},
                 "missing_recipe": {"recipe": tmp_path / "nope.json"},
                 "recipe_is_a_folder": {"recipe": tmp_path},
                 "report_in_missing_folder": {"report": tmp_path / "no" / "such" / "report.json"},
                 "timeout_nan": {"timeout": "nan"}, "timeout_inf": {"timeout": "inf"},
                 "timeout_0": {"timeout": "0"}, "timeout_negative": {"timeout": "-5"},
                 "timeout_text": {"timeout": "soon"}, "jobs_0": {"jobs": "0"}}[case])
    flags = [f"--{k}={v}" for k, v in args.items() if v is not None]
    proc = batch(column, *flags)
    assert_one_line_error(proc, argument)
    assert message in proc.stderr
    assert not (tmp_path / "out" / "column.blend").exists()


def make_unwritable(folder):
    """A folder nobody can create files in, root included (CI runs as root, where chmod does not
    stop writes): chmod for other users, the immutable attribute for root. Returns the undo."""
    if os.geteuid() != 0:
        folder.chmod(0o555)
        return lambda: folder.chmod(0o755)
    subprocess.run(["chattr", "+i", str(folder)], check=True, capture_output=True)
    return lambda: subprocess.run(["chattr", "-i", str(folder)], check=True)


def test_unwritable_output_folder(column, recipe, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    undo = make_unwritable(out)
    try:
        probe = out / "probe"
        with pytest.raises(OSError):  # the folder really refuses this process's writes
            probe.write_text("x")
        proc = batch(column, "--recipe", recipe, "--out", out, "--report", tmp_path / "report.json")
    finally:
        undo()
    assert_one_line_error(proc, "--out")
    assert "cannot write in" in proc.stderr and not (tmp_path / "report.json").exists()


def limit_file_size(limit):
    def apply():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return apply


def test_full_disk_every_file_reported(fixtures, recipe, tmp_path):
    """A file-size limit (ulimit -f) makes every write past 256 KB fail with EFBIG, as a full disk
    fails with ENOSPC: every file is attempted, each fails at its save with Blender's error and the
    conditions, and the report (small) is written; no temporary is left behind."""
    out = tmp_path / "out"
    limit = 256 * 1024
    assert (fixtures / "monkey.blend").stat().st_size > limit  # each output is larger
    proc = batch(fixtures / "monkey.blend", fixtures / "torus.blend", "--recipe", recipe, "--out", out,
                 "--jobs", 2, preexec_fn=limit_file_size(limit))
    assert proc.returncode == 1, proc.stdout + proc.stderr
    report = report_of(out / "report.json")
    assert report["complete"] and report["failed"] == 2
    for name in ("monkey.blend", "torus.blend"):
        failure = row(report, name)["exception"]
        assert failure["type"] == "RuntimeError" and failure["stage"] == "save", failure
        assert "cannot save" in failure["message"] and f"file-size limit (ulimit -f) {limit} bytes" in failure["message"]
        assert "Blender exited" not in row(report, name)["error"]
    assert sorted(p.name for p in out.iterdir()) == ["report.json"]


def test_worker_exceptions_name_the_object_and_entry(fixtures, tmp_path):
    recipe = tmp_path / "r.json"
    recipe.write_text(json.dumps({"objects": ["Suzanne"], "deformers": [
        {"type": "TWIST", "angle": 0.5}, {"type": "LATTICE", "lattice": "Suzanne"}]}))
    proc = batch(fixtures / "monkey.blend", "--recipe", recipe, "--out", tmp_path / "out")
    assert proc.returncode == 1
    failure = row(report_of(tmp_path / "out/report.json"), "monkey.blend")["exception"]
    assert failure["type"] == "ValueError" and "'Suzanne' is not a lattice object" in failure["message"]
    assert (failure["object"], failure["entry"], failure["stage"]) == ("Suzanne", "deformers[1]", "evaluate")


def test_deleted_temporary_file_is_reported(fixtures, tmp_path, scene, monkeypatch):
    """Someone deletes the worker's temporary between Blender's save and the rename: the result
    says FileNotFoundError at the save, it does not escape the worker."""
    from deformkit_addon import batch as worker
    real_replace = os.replace

    def delete_then_replace(src, dst):
        os.unlink(src)
        return real_replace(src, dst)

    monkeypatch.setattr(worker.os, "replace", delete_then_replace)
    result = worker.process(str(fixtures / "column.blend"), str(tmp_path / "column.blend"), TWIST)
    monkeypatch.undo()
    assert result["status"] == "failed" and result["exception"]["type"] == "FileNotFoundError"
    assert result["exception"]["stage"] == "save" and "tmp.blend" in result["exception"]["message"]
    assert os.listdir(tmp_path) == []


def processes_using(text):
    found = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            if text.encode() in pathlib.Path(f"/proc/{pid}/cmdline").read_bytes():
                found.append(int(pid))
        except OSError:
            pass
    return found


def wait_for(condition, seconds=120.0):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.02)
    raise AssertionError("timed out waiting")


class SaveGate:
    """The two FIFOs of the worker's pause point (python_addon/batch.py, pause_point_for_tests):
    `env` turns it on for a run; each worker then stops between its save and the rename until
    release() (one file) or close() (all)."""

    def __init__(self, folder):
        from deformkit_addon.batch import PAUSE_BEFORE_RENAME
        folder.mkdir()
        os.mkfifo(folder / "paused")
        os.mkfifo(folder / "resume")
        self.env = {PAUSE_BEFORE_RENAME: str(folder)}
        self.paused = os.open(folder / "paused", os.O_RDONLY | os.O_NONBLOCK)
        self.resume = os.open(folder / "resume", os.O_RDWR)  # the writer the workers wait on, open before they start

    def wait_paused(self, run, seconds=300.0):
        """Until a worker of `run` says its temporary is written; `run` ending first is a failure.
        The timeout only guards against a hang."""
        deadline = time.monotonic() + seconds
        while run.poll() is None and time.monotonic() < deadline:
            if select.select([self.paused], [], [], 1.0)[0]:
                return os.read(self.paused, 100)
        raise AssertionError(f"the run never paused in its save: exit status {run.poll()}")

    def release(self):
        os.write(self.resume, b"go\n")

    def close(self):
        os.close(self.resume)
        os.close(self.paused)


def test_killed_launcher_leaves_a_report_and_the_next_run_cleans_up(fixtures, recipe, tmp_path):
    """The first file is let through its save, the second held in its own: the launcher is killed
    with one file done, one running and two pending, whatever the machine's load."""
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    env = {**os.environ, "TMPDIR": str(tmp)}
    inputs = [fixtures / f"{n}.blend" for n in ("column", "monkey", "torus", "saved_stack")]
    out = tmp_path / "out"
    gate = SaveGate(tmp_path / "gate")
    try:
        launcher = start(*inputs, "--recipe", recipe, "--out", out, env={**env, **gate.env})
        gate.wait_paused(launcher)
        gate.release()

        def finished_one():
            try:
                return report_of(out / "report.json")["ok"] >= 1
            except (OSError, ValueError):
                return False

        wait_for(finished_one)
        gate.wait_paused(launcher)  # the second file, held until the launcher is gone
        assert launcher.poll() is None, "the report appeared only when the run was over"
        launcher.send_signal(signal.SIGKILL)
        launcher.wait()
    finally:
        gate.close()
    report = report_of(out / "report.json")  # valid JSON: replaced atomically, never torn
    assert not report["complete"] and report["ok"] >= 1 and report["pending"] >= 1
    for done in (f for f in report["files"] if f["status"] == "ok"):
        assert pathlib.Path(done["output"]).read_bytes()[:7] == b"BLENDER"
    staging = [p for p in tmp.iterdir() if p.name.startswith(f"deformkit-batch-run-{launcher.pid}-")]
    assert len(staging) == 1
    wait_for(lambda: not processes_using(str(staging[0])), 20)  # its Blender died with it
    live = tmp / f"deformkit-batch-run-{os.getpid()}-0123abcd"  # a run in progress: left alone
    live.mkdir()
    proc = batch(tmp_path / "missing.blend", "--recipe", recipe, "--out", tmp_path / "out2", env=env)
    assert proc.returncode == 1 and "file not found" in proc.stdout
    assert not staging[0].exists() and live.exists()


def test_two_runs_into_one_folder(fixtures, tmp_path, recipe):
    """Run A is held by the worker's pause point while its temporary output exists; run B, writing
    the same output name into the same folder, fails and cleans up: A's temporary (and any other
    run's) survives, A finishes with its output, and a run that would share A's report is refused."""
    out = tmp_path / "out"
    out.mkdir()
    others = [out / "monkey.blend.tmp4242.blend", out / "monkey.blend.deformkit-4242-0badc0de.tmp.blend"]
    for other in others:  # other runs' temporaries, in the old and the current naming
        other.write_bytes(b"another run's file in progress")
    (tmp_path / "b").mkdir()
    shutil.copy(fixtures / "monkey.blend", tmp_path / "b")
    missing = tmp_path / "missing_object.json"
    missing.write_text(json.dumps({**TWIST, "objects": ["Nope"]}))
    gate = SaveGate(tmp_path / "gate")
    try:
        a = start(fixtures / "monkey.blend", "--recipe", recipe, "--out", out, "--report", tmp_path / "a.json",
                  env={**os.environ, **gate.env})
        gate.wait_paused(a)
        planted = {o.name for o in others}
        assert [e.name for e in os.scandir(out) if e.name not in planted and e.name.startswith("monkey.blend.")], \
            "A paused without its temporary"
        b = batch(tmp_path / "b/monkey.blend", "--recipe", missing, "--out", out, "--report", tmp_path / "b.json")
        shared = batch(tmp_path / "b/monkey.blend", "--recipe", recipe, "--out", tmp_path / "c",
                       "--report", tmp_path / "a.json")
    finally:
        gate.close()  # A's worker goes on and renames
    assert a.wait(timeout=300) == 0, a.stdout.read() + a.stderr.read()
    assert b.returncode == 1 and "object 'Nope' not found" in b.stdout
    assert_one_line_error(shared, "--report")
    assert "run in progress" in shared.stderr
    assert row(report_of(tmp_path / "a.json"), "monkey.blend")["status"] == "ok"
    assert (out / "monkey.blend").read_bytes()[:7] == b"BLENDER"
    assert all(o.read_bytes() == b"another run's file in progress" for o in others)
    assert sorted(p.name for p in out.iterdir()) == sorted(["monkey.blend"] + [o.name for o in others])


def damaged_copy(source, target, fraction, seed):
    data = bytearray(source.read_bytes())
    at = int(len(data) * fraction)
    data[at:at + 4096] = np.random.default_rng(seed).bytes(4096)
    target.write_bytes(bytes(data))


def test_damaged_files_carry_warnings(fixtures, recipe, tmp_path):
    """4 KB overwritten in the middle: Blender reads such files without a word, but what it reads
    is damaged. The row says so (warnings), and an intact file in the same run has none."""
    (tmp_path / "in").mkdir()
    damaged = []
    for name, seed in (("monkey", 0), ("torus", 1), ("saved_stack", 2)):
        target = tmp_path / "in" / f"{name}_damaged.blend"
        damaged_copy(fixtures / f"{name}.blend", target, 0.5, seed)
        damaged.append(target)
    proc = batch(*damaged, fixtures / "monkey.blend", "--recipe", recipe, "--out", tmp_path / "out", "--jobs", 2)
    report = report_of(tmp_path / "out/report.json")
    assert row(report, "monkey.blend")["status"] == "ok" and row(report, "monkey.blend")["warnings"] == []
    for path in damaged:
        found = row(report, path.name)
        assert found["warnings"], found
        assert all("may be damaged" in w or w.startswith("Blender while reading") for w in found["warnings"])
        assert found["status"] == "ok" or found["exception"]["type"] in ("ValueError", "BatchError")
    assert "warnings)" in proc.stdout


def test_foreign_python_first_on_path(column, recipe, tmp_path):
    """A Python without numpy first on PATH and in PYTHONHOME hijacks Debian's Blender (it takes
    its sys.prefix from there: no numpy, or not even the standard library); Blender started with the launcher's environment is not hijacked,
    and a whole run with that PATH succeeds."""
    from deformkit.batch import run as batch_launch
    foreign = tmp_path / "foreign"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(foreign)], check=True)
    hijacked = {**os.environ, "PATH": f"{foreign / 'bin'}{os.pathsep}{os.environ['PATH']}",
                "PYTHONHOME": str(foreign), "PYTHONPATH": str(foreign)}
    probe = [BLENDER, "-b", "--factory-startup", "-noaudio", "--python-exit-code", "1", "--python-expr",
             "import sys, numpy; print('PREFIX', sys.prefix)"]
    raw = subprocess.run(probe, capture_output=True, text=True, env=hijacked, timeout=120)
    assert raw.returncode != 0 and "No module named" in raw.stdout + raw.stderr  # the hijack is real
    env, dropped = batch_launch.blender_environment(BLENDER, hijacked)
    assert str(foreign / "bin") in dropped and not any(k.startswith("PYTHON") for k in env)
    clean = subprocess.run(probe, capture_output=True, text=True, env=env, timeout=120)
    assert clean.returncode == 0 and f"PREFIX {foreign}" not in clean.stdout, clean.stdout + clean.stderr
    del hijacked["PYTHONHOME"]  # the launcher itself is a Python: it needs its own home
    proc = batch(column, "--recipe", recipe, "--out", tmp_path / "out", env=hijacked)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert str(foreign / "bin") in report_of(tmp_path / "out/report.json")["path_left_out_for_blender"]

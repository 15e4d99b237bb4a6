"""Files the batch command reads from the user (docs/errors.md, "Files the batch command reads"):
a --recipe that is not a regular file (a FIFO without a writer, which would block open() forever;
/dev/zero and a link to /dev/urandom, which never end; a folder; a socket), one over the size
limit, or one that is not UTF-8, is refused before any file is opened: exit status 2 and one line
naming --recipe, never a hang, a MemoryError or a traceback. Every command runs under a timeout,
so a regression fails here instead of hanging the suite."""
import json
import os
import pathlib
import socket
import subprocess
import sys
import threading

import pytest

from deformkit.batch import cli, shared

REPO = pathlib.Path(__file__).resolve().parents[2]
GUARD_SECONDS = 120  # a hang fails the test (TimeoutExpired) instead of blocking the suite
RECIPE = {"objects": ["*"], "deformers": [{"type": "TWIST", "angle": 1.2, "deform_axis": "Z"}]}


def batch(recipe, tmp_path):
    command = [sys.executable, "-m", "deformkit.batch", str(tmp_path / "missing.blend"), "--recipe", str(recipe),
               "--out", str(tmp_path / "out"), "--addon", str(REPO / "python_addon"), "--blender", sys.executable]
    return subprocess.run(command, capture_output=True, text=True, timeout=GUARD_SECONDS, stdin=subprocess.DEVNULL)


def guarded(fn):
    """fn() in a daemon thread: its result or its exception, or a failure when it has not returned
    within GUARD_SECONDS (a blocked open() must fail the test, not hang the suite)."""
    outcome = {}

    def run():
        try:
            outcome["value"] = fn()
        except BaseException as exc:  # handed to the test
            outcome["error"] = exc
    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(GUARD_SECONDS)
    assert not thread.is_alive(), f"{fn} still blocked after {GUARD_SECONDS} s"
    if "error" in outcome:
        raise outcome["error"]
    return outcome["value"]


def assert_refused(proc, message):
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert proc.stderr.startswith("deformkit-batch: error: --recipe: "), proc.stderr
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert message in proc.stderr, proc.stderr


def test_a_fifo_without_a_writer_is_refused_not_waited_for(tmp_path):
    fifo = tmp_path / "recipe.json"
    os.mkfifo(fifo)
    assert_refused(batch(fifo, tmp_path), f"{fifo} is a FIFO (named pipe), not a regular file")


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/urandom"])
def test_an_endless_device_is_refused_directly_or_through_a_json_link(tmp_path, device):
    link = tmp_path / "recipe.json"
    link.symlink_to(device)
    for recipe in (device, link):
        assert_refused(batch(recipe, tmp_path), f"{recipe} is a character device, not a regular file")


def test_a_folder_and_a_socket_are_refused(tmp_path):
    assert_refused(batch(tmp_path, tmp_path), f"{tmp_path} is a folder, not a recipe file")
    path = tmp_path / "recipe.json"
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as listening:
        listening.bind(str(path))
        listening.listen(1)
        assert_refused(batch(path, tmp_path), f"{path} is a socket, not a regular file")


def padded_recipe(size):
    """A valid recipe of exactly `size` bytes (JSON allows trailing white space)."""
    text = json.dumps(RECIPE).encode()
    return text + b" " * (size - len(text))


def test_the_size_limit_is_exact(tmp_path):
    at_limit, over = tmp_path / "at_limit.json", tmp_path / "over.json"
    at_limit.write_bytes(padded_recipe(cli.RECIPE_LIMIT))
    over.write_bytes(padded_recipe(cli.RECIPE_LIMIT + 1))
    assert_refused(batch(over, tmp_path), f"{over} is {cli.RECIPE_LIMIT + 1} bytes, more than the "
                                          f"{cli.RECIPE_LIMIT} bytes allowed")
    proc = batch(at_limit, tmp_path)  # read and accepted: the run goes on to the (missing) input
    assert proc.returncode == 1 and "--recipe" not in proc.stderr, proc.stdout + proc.stderr
    assert json.loads((tmp_path / "out" / "report.json").read_text())["recipe"] == RECIPE


@pytest.mark.parametrize("name", ["recipe.json", "recipe.toml"])
def test_bytes_that_are_not_utf8_are_one_line(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(b'{"objects": ["\xff\xfe"]}' if name.endswith(".json") else b'objects = ["\xff\xfe"]\n')
    assert_refused(batch(path, tmp_path), f"{path}: not UTF-8 text (invalid start byte at byte 14)"
                   if name.endswith(".json") else f"{path}: not UTF-8 text (invalid start byte at byte 12)")


def test_utf16_json_is_not_guessed(tmp_path):
    """json.loads(bytes) would take this for UTF-16 (its byte-order mark); a recipe is UTF-8."""
    path = tmp_path / "recipe.json"
    path.write_bytes(json.dumps(RECIPE).encode("utf-16"))
    assert_refused(batch(path, tmp_path), f"{path}: not UTF-8 text (invalid start byte at byte 0)")


def test_a_fifo_swapped_in_after_the_check_does_not_block(tmp_path, monkeypatch):
    """The race the non-blocking open closes: the path passes the kind check as a regular file,
    then is a FIFO when it is opened (injected by a hook on os.stat, deterministically)."""
    fifo = tmp_path / "recipe.json"
    os.mkfifo(fifo)
    regular = os.stat(__file__)
    real_stat = os.stat
    monkeypatch.setattr(shared.os, "stat", lambda path, *a, **k: regular if str(path) == str(fifo)
                        else real_stat(path, *a, **k))
    with pytest.raises(shared.FileRefused, match=r"is a FIFO \(named pipe\), not a regular file"):
        guarded(lambda: shared.read_regular_file(str(fifo), 100))


def test_a_file_that_grows_past_the_limit_while_read_is_refused(tmp_path, monkeypatch):
    """st_size says 10 bytes, the read finds more (a file appended to meanwhile): still refused,
    after at most limit + 1 bytes."""
    path = tmp_path / "recipe.json"
    path.write_bytes(b"x" * 1000)
    reads = []
    real_read = os.read
    real_fstat = os.fstat

    class Small:
        def __init__(self, info):
            self.st_mode, self.st_size = info.st_mode, 10

    monkeypatch.setattr(shared.os, "fstat", lambda fd: Small(real_fstat(fd)))
    monkeypatch.setattr(shared.os, "read", lambda fd, n: reads.append(n) or real_read(fd, n))
    with pytest.raises(shared.FileRefused, match="more than the 100 bytes allowed"):
        guarded(lambda: shared.read_regular_file(str(path), 100))
    assert sum(reads) == 101


def test_the_runs_state_files_are_read_the_same_way(tmp_path):
    """The other files the command and its workers read where someone else may have put something
    (the system temp folder, the shared staging folder): a FIFO or a device there is skipped as
    unreadable, never waited for or read without end."""
    from deformkit.batch import attempts, run, staging
    fifo = tmp_path / "0.json"
    os.mkfifo(fifo)
    assert guarded(lambda: (run._read_result(str(fifo), ""), attempts._read(str(fifo)))) == (None, None)
    assert guarded(lambda: run.input_problem(str(fifo))) == "not a file"
    (tmp_path / "zero.json").symlink_to("/dev/zero")
    assert guarded(lambda: attempts._read(str(tmp_path / "zero.json"))) is None
    live = tmp_path / f"{shared.STAGING_PREFIX}{os.getpid()}-0123abcd"  # a live run's name, with a FIFO
    live.mkdir()
    os.mkfifo(live / "report-path")
    assert guarded(lambda: staging.live_runs(str(tmp_path))) == {}
    (live / "report-path").unlink()
    (live / "report-path").write_text("/some/report.json")  # the control: a regular one is read
    assert staging.live_runs(str(tmp_path)) == {str(live): "/some/report.json"}

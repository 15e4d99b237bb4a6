"""run_job with a fake Blender: what it hands Blender (one job file, nothing positional), and the
rules that never lose a result: every outcome is a row saying what happened and where, a failed
Blender leaves neither its temporary nor a changed output, and an input is never written."""
import dataclasses
import os
import pathlib
import pickle
import select
import subprocess
import sys


from deformkit.batch import shared
from deformkit.batch.job import BatchJob
from deformkit.batch.report import console_line
from deformkit.batch.run import IN_BLENDER, run_job


def test_a_good_job_hands_blender_one_job_file_and_returns_its_row(make_job):
    job = make_job("ok")
    row = run_job(job)
    assert row["status"] == "ok", row
    assert row["objects"] == [{"name": "Fake", "entries": ["TWIST"], "vertices": 3}] and row["process_seconds"] > 0
    # The job file is the job itself, with the pid Blender must die with: the process that ran it.
    assert BatchJob.from_dict(row["job_seen"]) == dataclasses.replace(job, parent_pid=os.getpid())
    assert row["job_seen"]["parent_pid"] == os.getpid() == row["parent"]
    assert pathlib.Path(job.output).read_bytes() == b"BLENDER output of 0_ok.blend"
    assert os.path.exists(IN_BLENDER) and "preview" not in row
    assert sorted(os.listdir(job.work)) == ["0.job.json", "0.json"]


def test_the_environment_comes_from_the_machine_that_runs_the_job(make_job):
    row = run_job(make_job("ok"), environ={"PATH": os.environ["PATH"], "PYTHONHOME": "/nowhere"})
    assert row["status"] == "ok", row  # Blender never sees PYTHON* variables (it honours PYTHONHOME)


def test_preview_picture_beside_the_output(make_job):
    job = make_job("ok", preview=True)
    row = run_job(job)
    png = pathlib.Path(job.output).with_suffix(".png")
    assert row["preview"] == str(png) and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_failure_reported_by_the_worker_is_its_row(make_job):
    job = make_job("fail")
    row = run_job(job)
    assert (row["status"], row["error"]) == ("failed", "object 'X' not found in the file")
    assert not os.path.exists(job.output)


def test_a_result_on_stdout_when_the_file_could_not_be_written(make_job):
    row = run_job(make_job("stdout"))
    assert row["status"] == "ok" and row["objects"][0]["name"] == "Fake"


def test_a_blender_that_cannot_read_its_job_file_still_gives_this_files_row(make_job, tmp_path):
    """in_blender.py, unable to read its job file, prints its failure for the launcher without the
    file it was for: the row is still this job's, and its console line can be printed."""
    blender = tmp_path / "bin" / "blender-without-job"
    blender.write_text(f'#!/bin/sh\nexec "{sys.executable}" "{IN_BLENDER}" -- "{tmp_path / "no-such.job.json"}"\n')
    blender.chmod(0o755)
    job = make_job("ok", blender=str(blender))
    row = run_job(job)
    assert (row["file"], row["output"], row["status"]) == (job.input, job.output, "failed")
    assert (row["exception"]["type"], row["exception"]["stage"]) == ("FileNotFoundError", "start")
    assert console_line(1, 1, row).startswith("[1/1] 0_ok.blend: FAILED: FileNotFoundError: ")
    assert not os.path.exists(job.output)


def test_timeout_names_the_stage(make_job, monkeypatch):
    """The fake Blender reports stage 'evaluate', then hangs. Its job's timeout starts once it has
    said so (Blender is started through a Popen that returns only then: the fake opens
    `<index>.started`, a FIFO here, after its progress is written), so that a slow start on a
    loaded machine cannot leave the stage at 'open'; the timeout itself is subprocess.run's, as
    run_job uses it."""
    job = make_job("sleep", timeout=1.5)
    started = pathlib.Path(job.work, "0.started")
    os.mkfifo(started)
    reader = os.open(started, os.O_RDONLY | os.O_NONBLOCK)

    class StartedPopen(subprocess.Popen):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            for _ in range(120):  # seconds: only a guard against a hang
                if select.select([reader], [], [], 1.0)[0] or self.poll() is not None:
                    break

    monkeypatch.setattr(subprocess, "Popen", StartedPopen)
    try:
        row = run_job(job)
    finally:
        os.close(reader)
    assert row["exception"]["type"] == "TimeoutExpired"
    assert row["error"] == "TimeoutExpired: timed out after 1.5 s during stage 'evaluate' (object Fake)"
    assert row["warnings"] == ["a warning seen while reading"] and row["seconds"] >= 1.5


def test_crash_during_save_keeps_the_old_output_and_removes_the_temporary(make_job):
    job = make_job("segv")
    pathlib.Path(job.output).write_bytes(b"BLENDER an earlier run's output")
    row = run_job(job)
    assert row["error"] == "BlenderDied: Blender was killed by SIGSEGV during stage 'save' (object Fake)"
    assert row["exception"]["stage"] == "save"
    assert pathlib.Path(job.output).read_bytes() == b"BLENDER an earlier run's output"
    assert not any(os.path.exists(p) for p in shared.run_temporaries(job.output, job.token))


def test_exit_without_a_result(make_job):
    row = run_job(make_job("exit"))
    assert row["error"] == "BlenderDied: Blender exited with status 1 without a result during stage 'open' (object Fake)"


def test_inputs_are_never_written_and_bad_inputs_never_start_blender(make_job, tmp_path):
    job = make_job("ok")
    other = make_job("ok", index=1)
    row = run_job(dataclasses.replace(job, output=other.input, never_write=(job.input, other.input)))
    assert row["error"] == f"refusing to write {other.input}: it is one of the inputs"
    assert pathlib.Path(other.input).read_bytes() == b"BLENDERok"
    missing = run_job(dataclasses.replace(job, input=str(tmp_path / "missing.blend")))
    text = tmp_path / "notes.blend"
    text.write_text("notes")
    not_blend = run_job(dataclasses.replace(job, input=str(text)))
    assert (missing["error"], not_blend["error"]) == ("file not found", "not a .blend file (no BLENDER header)")
    assert os.listdir(job.work) == []  # Blender was never started: no job file


def test_launcher_trouble_is_a_row_too(make_job):
    job = make_job("ok", blender="/nonexistent/blender")
    row = run_job(job)
    assert row["status"] == "failed" and row["exception"]["stage"] == "launch"
    assert row["exception"]["type"] == "FileNotFoundError" and row["file"] == job.input


def test_run_job_is_picklable_by_reference():
    assert pickle.loads(pickle.dumps(run_job)) is run_job

"""The executor interface: run_all on the in-process executor, the local-process one and a plain
concurrent.futures pool gives every job exactly one row, the row run_job itself gives; a job
that raises or whose process dies still gets a row; Ctrl-C drops the jobs not started and
reports the running ones."""
import concurrent.futures
import functools
import json
import multiprocessing
import os
import pathlib
import signal
import subprocess
import sys
import time

import pytest

from deformkit.batch import InProcessExecutor, LocalProcessExecutor, run_all, run_job

REPO = pathlib.Path(__file__).resolve().parents[2]


def collect(executor, jobs, fn=run_job, window=None):
    rows = {}

    def on_row(job, row):
        assert job.index not in rows, "a job reported twice"
        rows[job.index] = row

    run_all(executor, jobs, on_row, fn=fn, window=window)
    return rows


def comparable(row):
    volatile = ("seconds", "process_seconds", "pid", "parent", "job_seen", "output_stat")
    return {k: v for k, v in row.items() if k not in volatile}


MODES = ("ok", "fail", "exit", "ok", "segv")


@pytest.mark.parametrize("make_executor", [InProcessExecutor, lambda: LocalProcessExecutor(2),
                                           lambda: concurrent.futures.ThreadPoolExecutor(2)],
                         ids=["in-process", "local-process", "thread-pool"])
def test_every_job_gets_the_row_run_job_gives(make_job, make_executor):
    jobs = [make_job(mode, index=i) for i, mode in enumerate(MODES)]
    with make_executor() as executor:
        rows = collect(executor, jobs, window=2)
    assert sorted(rows) == list(range(len(MODES)))
    for job in jobs:  # run again, directly: same row (outputs are rewritten the same way)
        assert comparable(rows[job.index]) == comparable(run_job(job)), job.input
    assert [rows[i]["status"] for i in range(len(MODES))] == ["ok", "failed", "failed", "ok", "failed"]


def test_local_processes_run_blender_from_their_own_process(make_job):
    """The pool process, not the launcher, starts Blender: the job file names it as the parent."""
    with LocalProcessExecutor(1) as executor:
        rows = collect(executor, [make_job("ok")])
        mapped = list(executor.map(run_job, [make_job("ok"), make_job("fail", index=1)]))  # concurrent.futures' map
    assert rows[0]["job_seen"]["parent_pid"] == rows[0]["parent"] != os.getpid()
    assert [r["status"] for r in mapped] == ["ok", "failed"] and mapped[0]["parent"] == rows[0]["parent"]


def explode(job):
    raise RuntimeError(f"no luck with {os.path.basename(job.input)}")


def test_a_job_that_raises_still_gets_a_row(make_job):
    rows = collect(InProcessExecutor(), [make_job("ok")], fn=explode)
    assert rows[0]["status"] == "failed" and rows[0]["exception"]["stage"] == "launch"
    assert rows[0]["error"] == "RuntimeError: no luck with 0_ok.blend"


def die(job):
    os._exit(3)


def test_a_crashed_pool_process_still_gives_every_job_a_row(make_job):
    jobs = [make_job("ok", index=i) for i in range(4)]
    with LocalProcessExecutor(2) as executor:
        rows = collect(executor, jobs, fn=die, window=2)
    assert sorted(rows) == [0, 1, 2, 3]
    assert {rows[i]["exception"]["type"] for i in rows} == {"BrokenProcessPool"}


def mark_after(release, job):
    """Job 0 ends only once `release` (an Event shared with the test) is set; the others at once."""
    if job.index == 0:
        assert release.wait(120), "job 0 was never released"  # the timeout only guards a hang
    pathlib.Path(job.work, f"{job.index}.ran").touch()
    return {"file": job.input, "status": "ok"}


def test_ctrl_c_drops_jobs_not_started_and_reports_the_running_ones(make_job):
    """Job 0 cannot finish before job 1 is reported: Ctrl-C, raised there, finds job 0 running."""
    jobs = [make_job("ok", index=i) for i in range(5)]
    rows = {}
    with multiprocessing.Manager() as manager:
        release = manager.Event()

        def on_row(job, row):
            rows[job.index] = row
            if job.index == 1:
                release.set()  # job 0 may end now; run_all is still in this call, so it is not reported yet
                raise KeyboardInterrupt  # as Ctrl-C arrives while job 0 still runs

        with LocalProcessExecutor(2) as executor:
            with pytest.raises(KeyboardInterrupt):
                run_all(executor, jobs, on_row, fn=functools.partial(mark_after, release), window=2)
    assert sorted(rows) == [0, 1] and rows[0]["status"] == "ok"  # job 0 finished and was reported
    assert sorted(p.name for p in pathlib.Path(jobs[0].work).glob("*.ran")) == ["0.ran", "1.ran"]


def test_ctrl_c_on_the_command_line(make_job, tmp_path):
    """SIGINT to the whole process group, as the terminal sends it: the running Blender dies of it
    and its row says so, the files not started stay pending, the staging folder is removed."""
    jobs = [make_job("wait-for-ctrl-c", index=0), make_job("ok", index=1)]
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    proc = subprocess.Popen([sys.executable, "-m", "deformkit.batch", "--addon", str(REPO / "python_addon"),
                             "--blender", jobs[0].blender, jobs[0].input, jobs[1].input, "--evaluate-saved",
                             "--out", str(tmp_path / "batch")], start_new_session=True,
                            env={**os.environ, "TMPDIR": str(tmp)}, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    deadline = time.monotonic() + 60
    while not list(tmp.glob("deformkit-batch-run-*/0.started")):
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode != 0 and "KeyboardInterrupt" in err
    report = json.loads((tmp_path / "batch" / "report.json").read_text())
    assert not report["complete"] and report["pending"] == 1 and report["failed"] == 1
    assert report["files"][0]["error"].startswith("BlenderDied: Blender was killed by SIGINT during stage 'evaluate'")
    assert [p.name for p in tmp.iterdir()] == ["deformkit-batch-run-startup.lock"]

"""The command line around run_job: scripts/deformkit-batch and `python -m deformkit.batch` take
the same options, find the add-on, and report every file (here with the fake Blender)."""
import json
import os
import pathlib
import subprocess
import sys

REPO = pathlib.Path(__file__).resolve().parents[2]


def test_the_script_runs_the_package_with_this_checkouts_addon(make_job, tmp_path):
    jobs = [make_job("ok", index=0), make_job("fail", index=1)]
    env = {k: v for k, v in os.environ.items() if k != "DEFORMKIT_ADDON"}
    proc = subprocess.run([str(REPO / "scripts/deformkit-batch"), jobs[0].input, jobs[1].input,
                           str(tmp_path / "missing.blend"), "--evaluate-saved", "--out", str(tmp_path / "batch"),
                           "--jobs", "2", "--blender", jobs[0].blender], capture_output=True, text=True, env=env,
                          timeout=120)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    report = json.loads((tmp_path / "batch/report.json").read_text())
    assert report["complete"] and (report["ok"], report["failed"], report["pending"]) == (1, 2, 0)
    assert [f["error"] for f in report["files"]] == ["", "object 'X' not found in the file", "file not found"]
    assert [f["file"] for f in report["files"]] == [jobs[0].input, jobs[1].input, str(tmp_path / "missing.blend")]
    assert "[3/3]" in proc.stdout and "1 ok, 2 failed" in proc.stdout
    assert sorted(p.name for p in (tmp_path / "batch").iterdir()) == ["0_ok.blend", "report.json"]


def test_an_addon_that_is_not_found_is_a_one_line_error(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "DEFORMKIT_ADDON"}
    base = [sys.executable, "-m", "deformkit.batch", "x.blend", "--evaluate-saved", "--out", str(tmp_path / "o"),
            "--blender", sys.executable]
    for extra, message in (([], "--addon: the deformkit add-on was not found"),
                           (["--addon", str(tmp_path)], f"--addon: {tmp_path} is not the deformkit add-on")):
        proc = subprocess.run(base + extra, capture_output=True, text=True, env=env, cwd=tmp_path, timeout=60)
        assert proc.returncode == 2 and proc.stderr.startswith(f"deformkit-batch: error: {message}"), proc.stderr
        assert proc.stderr.count("\n") == 1 and not (tmp_path / "o").exists()

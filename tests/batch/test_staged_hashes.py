"""The staged code of a cluster run is checked before Blender imports it
(docs/batch.md, "Staged code"): the launcher's hashes are SHA-256 of its own installed files
(hashlib on the sources, an independent reading); a staged file changed after staging (at any
byte, at the same size or not), removed, or replaced by a FIFO fails the file whose task finds
it, naming the staged file, and its Blender never starts; a file planted in the staging folder is
never imported; and on a real (TLS) cluster an alteration made at a deterministic point, for one
file's task only, fails that file and nothing else."""
import hashlib
import json
import os
import pathlib
import threading

import pytest

from deformkit.batch import cli, run, staged_code, staging
from deformkit.batch.job import BatchJob, JobError
from support.tls_certificates import make_certificates

REPO = pathlib.Path(__file__).resolve().parents[2]
ADDON = REPO / "python_addon"
GUARD_SECONDS = 120


@pytest.fixture
def staged(tmp_path):
    """A real cluster staging folder (the add-on and this deformkit), as the launcher makes it."""
    out = tmp_path / "out"
    out.mkdir()
    work, paths, manifest = staging.make_shared_staging("1-0123abcd", str(out / "report.json"), str(ADDON),
                                                        str(out))
    return work, paths, manifest


def test_the_hashes_are_those_of_the_launchers_own_files(staged):
    work, _, manifest = staged
    package = pathlib.Path(staging._package_folder())
    sources = {os.path.join("addons", "deformkit_addon", str(p.relative_to(ADDON))): p
               for p in ADDON.rglob("*") if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".pyc"}
    sources.update({os.path.join("lib", "deformkit", str(p.relative_to(package))): p
                    for p in package.rglob("*") if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".pyc"})
    assert manifest["folder"] == work and set(manifest["files"]) == set(sources)
    assert any(name.endswith(".so") for name in sources)  # the compiled core is among them
    for rel, source in sources.items():
        data = source.read_bytes()
        assert manifest["files"][rel] == {"bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}, rel
        assert (pathlib.Path(work) / rel).read_bytes() == data


def flip_a_byte(path):
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 1
    path.write_bytes(bytes(data))


@pytest.mark.parametrize("change, problem", [
    (flip_a_byte, "is not the one the launcher staged (SHA-256 "),
    (lambda p: p.write_bytes(p.read_bytes() + b"\nimport os; os.system('id')\n"), "bytes allowed (the launcher staged"),
    (lambda p: p.write_bytes(p.read_bytes()[:-1]), "is not the one the launcher staged"),
    (lambda p: p.unlink(), "is missing"),
    (lambda p: (p.unlink(), os.mkfifo(p)), "is a FIFO (named pipe), not a regular file"),
])
def test_an_altered_staged_file_is_named_and_nothing_is_copied_past_it(staged, tmp_path, change, problem):
    work, paths, manifest = staged
    victim = pathlib.Path(work) / "addons" / "deformkit_addon" / "batch.py"
    change(victim)
    into = tmp_path / "private"
    into.mkdir()
    done = {}
    thread = threading.Thread(target=lambda: done.update(
        outcome=pytest.raises(staged_code.StagedFileAltered, staged_code.verified_copy, manifest, str(into))),
        daemon=True)
    thread.start()
    thread.join(GUARD_SECONDS)  # a FIFO must not block the check
    assert not thread.is_alive()
    message = str(done["outcome"].value)
    assert message.startswith(f"the staged file {victim} ") and problem in message, message
    assert not (into / "addons" / "deformkit_addon" / "batch.py").exists()


def test_a_clean_copy_is_exact_private_and_leaves_planted_files_behind(staged, tmp_path):
    work, paths, manifest = staged
    planted = pathlib.Path(work) / "lib" / "numpy" / "__init__.py"  # would shadow Blender's numpy
    planted.parent.mkdir()
    planted.write_text("raise SystemExit('planted')\n")
    cache = pathlib.Path(work) / "lib" / "deformkit" / "batch" / "__pycache__"
    cache.mkdir()
    (cache / "job.cpython-311.pyc").write_bytes(b"planted bytecode")
    into = tmp_path / "private"
    into.mkdir(mode=0o700)
    staged_code.verified_copy(manifest, str(into))
    copied = {str(p.relative_to(into)) for p in into.rglob("*") if p.is_file()}
    assert copied == set(manifest["files"])
    for rel in copied:
        assert (into / rel).read_bytes() == (pathlib.Path(work) / rel).read_bytes()
        assert (into / rel).stat().st_mode & 0o077 == 0
    assert staged_code.private_paths(paths, manifest, str(into)) == [str(into / "addons"), str(into / "lib")]


def test_a_job_carries_its_hashes_and_refuses_paths_outside_the_staging_folder(staged):
    work, paths, manifest = staged
    job = BatchJob(index=0, input="/i.blend", output="/o.blend", work=work, blender="blender", token="1-0123abcd",
                   sys_paths=tuple(paths), staged=manifest)
    assert BatchJob.from_json(job.to_json()) == job and BatchJob.from_json(job.to_json()).staged == manifest
    for rel in ("../evil.py", "/etc/passwd", "a/../../b"):
        with pytest.raises(JobError, match=r"job field 'staged.files': expected paths inside the staging folder"):
            BatchJob(**{**job.__dict__, "staged": {"folder": work, "files": {rel: {"bytes": 1, "sha256": "0" * 64}}}})


def test_run_job_never_starts_blender_on_altered_code(staged, make_job, tmp_path):
    work, paths, manifest = staged
    clean = make_job("ok", index=0, sys_paths=tuple(paths), staged=manifest)
    row = run.run_job(clean)
    assert row["status"] == "ok", row
    seen = row["job_seen"]["sys_paths"]  # Blender imported from the checked private copy, now removed
    assert all(not p.startswith(work) and "deformkit-batch-checked-" in p for p in seen)
    assert not any(os.path.exists(p) for p in seen)
    victim = pathlib.Path(work) / "lib" / "deformkit" / "batch" / "in_blender.py"
    flip_a_byte(victim)
    altered = make_job("ok", index=1, sys_paths=tuple(paths), staged=manifest)
    row = run.run_job(altered)
    assert (row["status"], row["exception"]["type"], row["exception"]["stage"]) == \
           ("failed", "StagedFileAltered", "verify")
    assert row["error"].startswith(f"StagedFileAltered: the staged file {victim} is not the one the launcher staged")
    assert not os.path.exists(altered.input + ".runs") and not os.path.exists(altered.output)


def test_on_a_tls_cluster_the_altered_file_fails_its_file_and_nothing_else(fake_blender, tmp_path, monkeypatch):
    """An in-process TLS LocalCluster, one worker thread (one file at a time): a hook around the
    worker's run_blender alters a staged file for file 1's task only, just before its check, and
    restores it after. Files 0 and 2 go through; file 1 fails naming the file; the run ends."""
    import distributed

    tls = make_certificates(tmp_path / "tls")
    security = distributed.Security(
        tls_ca_file=str(tls["ca"]), tls_scheduler_cert=str(tls["scheduler"]), tls_scheduler_key=str(tls["scheduler_key"]),
        tls_worker_cert=str(tls["worker"]), tls_worker_key=str(tls["worker_key"]), tls_client_cert=str(tls["client"]),
        tls_client_key=str(tls["client_key"]), require_encryption=True)
    seen, real = [], run.run_blender

    def altering(job, environ=None):
        if job.index != 1:
            return real(job, environ)
        victim = pathlib.Path(job.staged["folder"]) / "addons" / "deformkit_addon" / "__init__.py"
        before = victim.read_bytes()
        altered = before.replace(b"def register", b"def Register", 1)  # the same size: only the hash tells
        assert altered != before and len(altered) == len(before)
        victim.write_bytes(altered)
        seen.append(str(victim))
        try:
            return real(job, environ)
        finally:
            victim.write_bytes(before)

    monkeypatch.setattr(run, "run_blender", altering)
    inputs = []
    for i in range(3):
        path = tmp_path / "in" / f"{i}_ok.blend"
        path.parent.mkdir(exist_ok=True)
        path.write_bytes(b"BLENDERok")
        inputs.append(str(path))
    out = tmp_path / "out"
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tls://",
                                  host="127.0.0.1", security=security, resources={"blender": 1},
                                  dashboard_address="127.0.0.1:0") as cluster, \
            distributed.Client(cluster, security=security, set_as_default=False) as client:
        assert cluster.scheduler_address.startswith("tls://127.0.0.1:")
        status = cli.main([*inputs, "--evaluate-saved", "--out", str(out), "--addon", str(ADDON),
                           "--blender", fake_blender], client=client)
        assert client.run(os.getpid)  # the worker is still there
    report = json.loads((out / "report.json").read_text())
    assert status == 1 and report["complete"]
    assert [r["status"] for r in report["files"]] == ["ok", "failed", "ok"]
    failed = report["files"][1]
    assert failed["exception"]["type"] == "StagedFileAltered" and len(seen) == 1
    assert failed["error"].startswith(f"StagedFileAltered: the staged file {seen[0]} is not the one the launcher staged")
    assert sorted(p.name for p in out.iterdir()) == ["0_ok.blend", "2_ok.blend", "report.json"]
    assert not os.path.exists(inputs[1] + ".runs")  # its Blender never started

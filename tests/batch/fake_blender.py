"""Stands in for `blender` in the batch tests: called exactly as run_job calls Blender, it reads the
job file after `--` and does what the input file asks for after its BLENDER header, as a Blender
worker would (or as one that hangs, crashes, or exits without a word; "hang-once" and
"done-then-hang-once" hang the first time only, before and after finishing the file, for the
worker a test kills; "meet" finishes only once another "meet" file has started beside it). Like the real one it dies with the process that started it."""
import json
import os
import signal
import sys
import importlib.util
import time


def load_shared():
    """deformkit/batch/shared.py by its path, as in_blender.py loads it: importing it through the
    package would import the compiled core and numpy first, and a Ctrl+C during numpy's import
    ends in an ImportError (exit status 1) instead of the SIGINT a starting Blender dies of."""
    package = importlib.util.find_spec("deformkit").submodule_search_locations[0]
    spec = importlib.util.spec_from_file_location("fake_blender_shared", os.path.join(package, "batch", "shared.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


shared = load_shared()


def meet_another(path):
    """For "meet" files: say this one has started, then wait until another "meet" file of the same
    folder has too (at most 120 s: a guard against a hang), so that they finish only if they ran
    at the same time."""
    open(path + ".met", "w").close()
    folder = os.path.dirname(path)
    for _ in range(2400):
        if any(name.endswith("_meet.blend.met") and name != os.path.basename(path) + ".met"
               for name in os.listdir(folder)):
            return True
        time.sleep(0.05)
    return False


def main(argv):
    at = argv.index("--")
    assert len(argv) == at + 2, f"expected only `-- JOB.json` after the options, got {argv[at:]}"
    assert argv[at - 2] == "--python" and argv[at - 1].endswith("in_blender.py"), argv
    with open(argv[at + 1], encoding="utf-8") as fh:
        job = json.load(fh)
    shared.prepare_worker(job["parent_pid"])  # as in_blender.py does: die with the process that started it
    with open(job["input"] + ".runs", "a") as fh:  # how many times this input was run, and where
        fh.write(f"{os.getpid()} {job['work']}\n")
    result_path = os.path.join(job["work"], f"{job['index']}.json")
    with open(job["input"], "rb") as fh:
        mode = fh.read()[len(b"BLENDER"):].decode().strip()
    row = {"file": job["input"], "output": job["output"], "status": "running", "error": "", "objects": [],
           "warnings": ["a warning seen while reading"], "job_seen": job, "pid": os.getpid(),
           "parent": os.getppid(),
           "environment": {k: os.environ.get(k) for k in ("OMP_NUM_THREADS", "MALLOC_TRIM_THRESHOLD_")}}

    def progress(stage):
        shared.write_json_atomically(result_path, {**row, "stage": {"stage": stage, "object": "Fake", "entry": None}},
                                     job["token"])

    progress("open")
    first = not os.path.exists(job["input"] + ".hung")
    if mode == "hang-once" and first:  # a worker killed in the middle of the save, the first time only
        open(job["input"] + ".hung", "w").close()
        progress("save")
        with open(shared.output_temporary(job["output"], job["token"]), "wb") as fh:
            fh.write(b"BLENDER half a file")
        open(os.path.join(job["work"], f"{job['index']}.started"), "w").close()
        time.sleep(120)
        return 1
    if mode == "exit":
        return 1
    if mode == "meet" and not meet_another(job["input"]):
        return 1
    if mode in ("sleep", "wait-for-ctrl-c"):
        progress("evaluate")
        open(os.path.join(job["work"], f"{job['index']}.started"), "w").close()
        time.sleep(120)
        return 1
    if mode == "segv":
        progress("save")
        with open(shared.output_temporary(job["output"], job["token"]), "wb") as fh:
            fh.write(b"BLENDER half a file")
        os.kill(os.getpid(), signal.SIGSEGV)
    if mode == "fail":
        shared.write_json_atomically(result_path, {**row, "status": "failed", "error": "object 'X' not found in the file"},
                                     job["token"])
        return 1
    tmp = shared.output_temporary(job["output"], job["token"])
    with open(tmp, "wb") as fh:
        fh.write(b"BLENDER output of " + os.path.basename(job["input"]).encode())
    os.replace(tmp, job["output"])
    saved = os.stat(job["output"])
    row["output_stat"] = {"bytes": saved.st_size, "mtime_ns": saved.st_mtime_ns}
    if job["preview"]:
        import numpy as np  # here only, for the same reason
        tri = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
        np.savez(os.path.join(job["work"], f"{job['index']}.npz"), before=tri, after=tri + [0, 0, 0.5],
                 faces=np.array([[0, 1, 2]]))
    done = {**row, "status": "ok", "objects": [{"name": "Fake", "entries": ["TWIST"], "vertices": 3}]}
    if mode == "stdout":
        print(shared.RESULT_LINE + json.dumps(done), flush=True)
        return 0
    shared.write_json_atomically(result_path, done, job["token"])
    if mode == "done-then-hang-once" and first:  # finished, then its worker dies before it can say so
        open(job["input"] + ".hung", "w").close()
        open(os.path.join(job["work"], f"{job['index']}.started"), "w").close()
        time.sleep(120)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

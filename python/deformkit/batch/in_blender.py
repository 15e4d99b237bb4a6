"""Blender's side of one job, started by run_job as

    blender -b --factory-startup -noaudio --python-exit-code 1 --python in_blender.py -- JOB.json

Nothing here may fail without a result file, not even importing the add-on or the compiled core:
so the job and the shared helpers are loaded from their files beside this one (importing them
through the deformkit package would import the compiled core first), and any failure before the
add-on's worker runs is written as the job's result.
"""
import importlib.util
import json
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))


def load_beside(name):
    spec = importlib.util.spec_from_file_location(f"deformkit_batch_{name}", os.path.join(HERE, f"{name}.py"))
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while the class is made
    spec.loader.exec_module(module)
    return module


def start_failure(shared, exc, job_path):
    """Write the failure to start as the job's result, or, when even the job file is unreadable,
    print it for the launcher."""
    record = shared.exception_record(exc, "start")
    record["message"] += (" (Blender's Python: sys.prefix " + sys.prefix + ", sys.executable "
                          + str(sys.executable) + ")")
    try:
        job = shared.read_json_file(job_path, shared.STATE_FILE_LIMIT)
        result = shared.file_row(job["input"], job["output"], exception=record, python_prefix=sys.prefix)
        path = os.path.join(job["work"], f"{job['index']}.json")
        shared.write_json_atomically(path, result, job["token"])
    except Exception:
        print(shared.RESULT_LINE + json.dumps({"status": "failed", "error": shared.describe_failure(record),
                                               "exception": record, "objects": [], "warnings": []}), flush=True)
    return 1


def main(argv):
    shared = load_beside("shared")
    job_path = argv[argv.index("--") + 1] if "--" in argv and argv.index("--") + 1 < len(argv) else ""
    try:
        text = shared.read_regular_file(job_path, shared.STATE_FILE_LIMIT).decode("utf-8")
        job = load_beside("job").BatchJob.from_json(text)
        shared.prepare_worker(job.parent_pid)
        sys.path[:0] = job.sys_paths
        import deformkit_addon
        deformkit_addon.register()
        from deformkit_addon import batch
    except Exception as exc:
        return start_failure(shared, exc, job_path)
    return batch.worker_main(job_path)


if __name__ == "__main__":
    sys.exit(main(sys.argv))

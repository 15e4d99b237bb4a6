"""Before any file of a cluster run: every worker reads the inputs, writes the output folder, sees
the staging folder and finds Blender, or the run stops with one line naming the worker and the
path. `worker_problems` runs on each worker (client.run); no Dask imported here."""
import os
import tempfile

from .cluster import ClusterError
from .run import input_problem


def worker_problems(inputs, out_dir, staging, blender):
    """Runs on each worker (client.run): what it cannot do of what the run needs, as
    (argument, path, problem) triples."""
    import shutil
    problems = [("inputs", path, problem) for path in inputs for problem in [input_problem(path)] if problem]
    try:
        fd, probe = tempfile.mkstemp(prefix=".deformkit-probe-", dir=out_dir)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        problems.append(("--out", out_dir, f"cannot write in it: {exc.strerror or exc}"))
    for name in ("addons/deformkit_addon/__init__.py", "lib/deformkit/batch/job.py"):
        if not os.path.isfile(os.path.join(staging, name)):
            problems.append(("--out", os.path.join(staging, name), "cannot see the run's staging folder"))
    found = shutil.which(blender) or (blender if os.path.isfile(blender) else None)
    if found is None or not os.access(found, os.X_OK):
        problems.append(("--blender", blender, "not found or not executable on this worker"))
    return problems


def check_workers(client, workers, inputs, out_dir, staging, blender):
    """ClusterError naming the first worker and path that fails the run's needs (shared storage,
    Blender). `inputs` are those the launcher itself can read: a worker must read them too."""
    answers = client.run(worker_problems, inputs, out_dir, staging, blender, workers=list(workers),
                         on_error="return")
    for worker, found in sorted(answers.items()):
        if isinstance(found, BaseException):
            hint = " (is deformkit installed in the workers' Python?)" if isinstance(found, ImportError) else ""
            raise ClusterError(f"--scheduler: worker {worker} could not check the run's files: "
                               f"{type(found).__name__}: {found}{hint}")
        for argument, path, problem in found[:1]:
            more = f" (and {len(found) - 1} more problems)" if len(found) > 1 else ""
            raise ClusterError(f"{argument}: worker {worker}: {path}: {problem}{more}; every worker must see the "
                               "inputs and the output folder at the same paths (shared storage)")

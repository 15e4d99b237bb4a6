"""Headless batch processing of .blend files: the launcher, which needs no bpy.

- :class:`BatchJob` (job.py): one file's job, picklable and one JSON job file for Blender;
- :func:`run_job` (run.py): runs one job in its own Blender and returns its report row;
- executors (executors.py): :class:`LocalProcessExecutor` (processes of this machine),
  :class:`InProcessExecutor`, or any concurrent.futures-style executor, driven by :func:`run_all`;
  on a Dask cluster (cluster.py opens it, preflight.py checks its workers; Dask is imported only
  when asked for), ``DaskExecutor`` (dask_executor.py) runs each file as a task whose attempts
  attempts.py keeps apart;
- the command line (cli.py, ``python -m deformkit.batch`` or ``scripts/deformkit-batch``; in
  Python :func:`main`, which also takes a ``distributed.Client`` or an address), where its jobs
  run (places.py: local processes or a Dask cluster, one interface), the report (report.py) and
  the run's staging folder (staging.py).

Inside Blender, in_blender.py starts the add-on's worker (python_addon/batch.py) on a job file;
shared.py and job.py are standard library only, as that start needs.
"""
from .cli import main
from .executors import Executor, InProcessExecutor, LocalProcessExecutor, run_all
from .job import BatchJob, JobError
from .run import run_job

__all__ = ["BatchJob", "Executor", "InProcessExecutor", "JobError", "LocalProcessExecutor", "main", "run_all",
           "run_job"]

"""run_job with the real Blender on a fixture, outside the command line: a job built by hand in a
staging folder, run directly and on the local-process executor, writes the deformed file that
dk.Stack gives for the same deformers, and its preview."""
import dataclasses
import json
import pathlib
import shutil

import numpy as np
import pytest

from addon_helpers import IN_BLENDER_BINARY, REPO, positions

pytestmark = pytest.mark.skipif(IN_BLENDER_BINARY, reason="the batch tests start Blender themselves")
BLENDER = "/usr/bin/blender"
RECIPE = {"objects": ["Column"], "deformers": [{"type": "TWIST", "angle": 1.2, "deform_axis": "Z"},
                                               {"type": "BEND", "angle": 0.9, "deform_axis": "X"}]}


@pytest.fixture
def column_job(fixtures, tmp_path):
    from deformkit.batch import shared, staging
    from deformkit.batch.job import BatchJob
    token = shared.new_run_token()
    work, paths = staging.make_staging(token, str(tmp_path / "report.json"), str(REPO / "python_addon"))
    (tmp_path / "out").mkdir()
    src = str(fixtures / "column.blend")
    yield BatchJob(index=0, input=src, output=str(tmp_path / "out" / "column.blend"), work=work, blender=BLENDER,
                   token=token, sys_paths=tuple(paths), recipe=RECIPE, never_write=(src,))
    shutil.rmtree(work)


def check_output(path):
    import bpy
    from deformkit_addon import api
    import deformkit as dk
    bpy.ops.wm.open_mainfile(filepath=str(path))
    obj = bpy.data.objects["Column"]
    expected = dk.Stack([dk.SimpleDeform(mode=d["type"], angle=d["angle"], deform_axis=d["deform_axis"])
                         for d in RECIPE["deformers"]]).deform(positions(obj.data))
    assert np.abs(api.evaluated_positions(obj) - expected).max() < 1e-5


def test_run_job_in_blender(column_job, scene):
    from deformkit.batch import run_job
    row = run_job(dataclasses.replace(column_job, preview=True))
    assert row["status"] == "ok", row
    assert [o["entries"] for o in row["objects"]] == [["TWIST", "BEND"]] and row["warnings"] == []
    assert pathlib.Path(row["preview"]).read_bytes()[:4] == b"\x89PNG"
    job_file = json.loads(pathlib.Path(column_job.job_path).read_text())
    assert job_file["recipe"] == RECIPE and job_file["input"] == column_job.input
    check_output(column_job.output)


def test_run_job_on_local_processes(column_job, scene):
    from deformkit.batch import LocalProcessExecutor, run_all
    rows = []
    with LocalProcessExecutor(1) as executor:
        run_all(executor, [column_job], lambda job, row: rows.append(row))
    assert [r["status"] for r in rows] == ["ok"], rows
    check_output(column_job.output)

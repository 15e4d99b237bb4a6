"""The batch with the real Blender 3.4 on a real Dask cluster (a `dask scheduler` and two `dask
worker` processes, tests/support/dask_cluster.py): `make demo`'s fixtures and recipe, with a
corrupt file among them, give the local executor's report and outputs whose meshes, as Blender
reads them back without the add-on, are bit for bit the local executor's."""
import json
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

from addon_helpers import IN_BLENDER_BINARY, REPO
from support.dask_cluster import DaskCluster

pytestmark = pytest.mark.skipif(IN_BLENDER_BINARY, reason="the batch tests start Blender themselves")
BLENDER = "/usr/bin/blender"
RECIPE = REPO / "blend_fixtures" / "demo_recipe.json"
READ_BACK = """
import bpy, sys, numpy as np
out = {}
result, *paths = sys.argv[sys.argv.index("--") + 1:]
for n, path in enumerate(paths):
    bpy.ops.wm.open_mainfile(filepath=path)
    dg = bpy.context.evaluated_depsgraph_get()
    for o in bpy.data.objects:
        if o.type != "MESH":
            continue
        me = o.evaluated_get(dg).to_mesh()
        ev = np.empty(len(me.vertices) * 3, np.float32); me.vertices.foreach_get("co", ev)
        base = np.empty(len(o.data.vertices) * 3, np.float32); o.data.vertices.foreach_get("co", base)
        out[f"{n}/{o.name}/evaluated"], out[f"{n}/{o.name}/base"] = ev.reshape(-1, 3), base.reshape(-1, 3)
        out[f"{n}/{o.name}/faces"] = np.array([len(me.polygons)])
print("ADDON", hasattr(bpy.types.Object, "deformkit"))
np.savez(result, **out)
"""


def run_batch(*args):
    return subprocess.run([sys.executable, "-m", "deformkit.batch", "--addon", str(REPO / "python_addon"),
                           "--blender", BLENDER, *map(str, args)], capture_output=True, text=True, timeout=900)


def meshes(paths, tmp_path, name):
    """{file number/object/what: array} of the files, as Blender 3.4 without the add-on reads them."""
    script, result = tmp_path / "read_back.py", tmp_path / f"{name}.npz"
    script.write_text(READ_BACK)
    proc = subprocess.run([BLENDER, "-b", "--factory-startup", "--python-exit-code", "1", "-P", str(script),
                           "--", str(result), *map(str, paths)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0 and "ADDON False" in proc.stdout, proc.stdout[-3000:] + proc.stderr[-3000:]
    return dict(np.load(result))


def test_fixtures_on_a_cluster_equal_the_local_run(fixtures, tmp_path):
    inputs = tmp_path / "in"
    inputs.mkdir()
    for blend in sorted(fixtures.glob("*.blend")):
        shutil.copy(blend, inputs)
    (inputs / "corrupt.blend").write_bytes(b"BLENDER-v304RENDH" + os.urandom(4000))
    local = run_batch(inputs / "*.blend", "--recipe", RECIPE, "--out", tmp_path / "local", "--jobs", 2)
    with DaskCluster(tmp_path / "cluster", workers=2) as cluster:
        dask = run_batch(inputs / "*.blend", "--recipe", RECIPE, "--out", tmp_path / "dask", "--scheduler",
                         cluster.address)
        workers = set(cluster.worker_pids())
        logs = cluster.logs()
    assert local.returncode == dask.returncode == 1, dask.stdout + dask.stderr + logs
    ours, theirs = (json.loads((tmp_path / d / "report.json").read_text()) for d in ("dask", "local"))
    status = [(os.path.basename(r["file"]), r["status"], r["error"]) for r in ours["files"]]
    assert status == [(os.path.basename(r["file"]), r["status"], r["error"]) for r in theirs["files"]]
    assert [(n, s) for n, s, _ in status if s != "ok"] == [("corrupt.blend", "failed")]
    assert "cannot open" in {n: e for n, _, e in status}["corrupt.blend"]
    assert len(status) >= 7 and {r["worker"] for r in ours["files"]} <= workers  # which ones: the scheduler's choice
    assert all(len(r["attempts"]) == 1 for r in ours["files"])
    for row, twin in zip(ours["files"], theirs["files"]):
        assert [(o["name"], o["vertices"], o["entries"]) for o in row["objects"]] == \
               [(o["name"], o["vertices"], o["entries"]) for o in twin["objects"]]
    names = [os.path.basename(r["output"]) for r in ours["files"] if r["status"] == "ok"]
    assert sorted(p.name for p in (tmp_path / "dask").iterdir()) == sorted(names + ["report.json"])
    ours_read = meshes([tmp_path / "dask" / n for n in names], tmp_path, "dask")
    theirs_read = meshes([tmp_path / "local" / n for n in names], tmp_path, "local")
    assert sorted(ours_read) == sorted(theirs_read) and len(ours_read) >= 3 * len(names)
    for key, value in theirs_read.items():
        assert ours_read[key].dtype == value.dtype and np.array_equal(ours_read[key], value), key
    done = [r for r in theirs["files"] if r["status"] == "ok"]
    for n, row in enumerate(done):  # every object the recipe worked on moved: the comparison is of real work
        for name in (o["name"] for o in row["objects"]):
            base, evaluated = theirs_read[f"{n}/{name}/base"], theirs_read[f"{n}/{name}/evaluated"]
            assert base.shape != evaluated.shape or np.abs(base - evaluated).max() > 0.1, (row["file"], name)

"""The batch command on good and broken files: outputs, report, exit status, inputs untouched."""
import hashlib
import json
import os
import pathlib
import shutil
import subprocess
import sys

import numpy as np
import pytest

from addon_helpers import IN_BLENDER_BINARY, REPO, positions

pytestmark = pytest.mark.skipif(IN_BLENDER_BINARY, reason="the batch tests start Blender themselves")
BLENDER = "/usr/bin/blender"
RECIPE = {"objects": ["*"], "deformers": [{"type": "TWIST", "angle": 1.2, "deform_axis": "Z"},
                                          {"type": "BEND", "angle": 0.9, "deform_axis": "X"}]}


def run_batch(*args):
    proc = subprocess.run([sys.executable, "-m", "deformkit.batch", "--addon", str(REPO / "python_addon"), "--blender", BLENDER, *map(str, args)],
                          capture_output=True, text=True, timeout=600)
    return proc


def digest(path):
    return hashlib.sha256(pathlib.Path(path).read_bytes()).hexdigest()


def test_good_and_broken_files(fixtures, tmp_path):
    inputs = tmp_path / "in"
    inputs.mkdir()
    for name in ("monkey", "column", "torus"):
        shutil.copy(fixtures / f"{name}.blend", inputs)
    (inputs / "corrupt.blend").write_bytes(b"BLENDER-v304RENDH" + os.urandom(4000))
    (inputs / "notes.blend").write_text("not a blend file at all")
    recipe = tmp_path / "recipe.json"
    recipe.write_text(json.dumps({**RECIPE, "objects": ["Suzanne"]}))  # only monkey.blend has it
    before = {p.name: digest(p) for p in inputs.iterdir()}
    out = tmp_path / "out"
    proc = run_batch(inputs / "*.blend", inputs / "missing.blend", "--recipe", recipe, "--out", out,
                     "--jobs", 2, "--preview")
    assert proc.returncode == 1, proc.stdout + proc.stderr
    report = json.loads((out / "report.json").read_text())
    status = {pathlib.Path(f["file"]).name: (f["status"], f["error"]) for f in report["files"]}
    assert status["monkey.blend"] == ("ok", "")
    assert status["column.blend"] == ("failed", "object 'Suzanne' not found in the file")
    assert status["torus.blend"][1] == "object 'Suzanne' not found in the file"
    assert status["corrupt.blend"][0] == "failed" and "cannot open" in status["corrupt.blend"][1]
    assert status["notes.blend"] == ("failed", "not a .blend file (no BLENDER header)")
    assert status["missing.blend"] == ("failed", "file not found")
    assert report["ok"] == 1 and report["failed"] == 5
    assert sorted(p.name for p in out.iterdir()) == ["monkey.blend", "monkey.png", "report.json"]  # no temp files
    assert {p.name: digest(p) for p in inputs.iterdir()} == before  # inputs untouched
    monkey = next(f for f in report["files"] if f["file"].endswith("monkey.blend"))
    assert monkey["objects"][0]["name"] == "Suzanne" and monkey["objects"][0]["vertices"] > 1000
    assert "[6/6]" in proc.stdout and "1 ok, 5 failed" in proc.stdout


def test_outputs_hold_the_deformed_meshes(fixtures, tmp_path, scene):
    import bpy
    from deformkit_addon import api
    import deformkit as dk
    recipe = tmp_path / "recipe.toml"
    recipe.write_text('objects = ["*"]\n[[deformers]]\ntype = "TWIST"\nangle = 1.2\ndeform_axis = "Z"\n'
                      '[[deformers]]\ntype = "BEND"\nangle = 0.9\ndeform_axis = "X"\n')
    proc = run_batch(fixtures / "column.blend", fixtures / "saved_stack.blend", "--recipe", recipe,
                     "--out", tmp_path / "out", "--jobs", 1)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "out" / "column.blend"))
    obj = bpy.data.objects["Column"]
    base = positions(obj.data)
    expected = dk.Stack([dk.SimpleDeform(mode="TWIST", angle=1.2, deform_axis="Z"),
                         dk.SimpleDeform(mode="BEND", angle=0.9, deform_axis="X")]).deform(base)
    assert np.abs(api.evaluated_positions(obj) - expected).max() < 1e-5
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "out" / "saved_stack.blend"))  # saved stack + recipe
    assert [e.type for e in bpy.data.objects["Twisted"].deformkit.entries] == ["TWIST", "TAPER", "TWIST", "BEND"]


def test_evaluate_saved_and_never_overwrite(fixtures, tmp_path, scene):
    import bpy
    from deformkit_addon import api
    import deformkit as dk
    work = tmp_path / "work"
    work.mkdir()
    shutil.copy(fixtures / "saved_stack.blend", work)
    original = digest(work / "saved_stack.blend")
    proc = run_batch(work / "saved_stack.blend", "--evaluate-saved", "--out", work)  # output == input
    assert proc.returncode == 1 and "refusing to write" in proc.stdout
    assert digest(work / "saved_stack.blend") == original
    proc = run_batch(work / "saved_stack.blend", "--evaluate-saved", "--out", tmp_path / "out")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "out" / "saved_stack.blend"))
    obj = bpy.data.objects["Twisted"]
    expected = dk.Stack([dk.SimpleDeform(mode="TWIST", angle=2.0, deform_axis="Z"),
                         dk.SimpleDeform(mode="TAPER", factor=-0.5, deform_axis="Z")]).deform(positions(obj.data))
    assert np.abs(api.evaluated_positions(obj) - expected).max() < 1e-5


def shown_without_addon(blend, name, tmp_path):
    """(evaluated, base) positions of object `name` as Blender 3.4 without the add-on shows them:
    what the file itself holds."""
    script = tmp_path / "read.py"
    script.write_text(
        "import bpy, sys, numpy as np\n"
        "o = bpy.data.objects[sys.argv[-2]]\n"
        "dg = bpy.context.evaluated_depsgraph_get()\n"
        "me = o.evaluated_get(dg).to_mesh()\n"
        "ev = np.empty(len(me.vertices) * 3, np.float32); me.vertices.foreach_get('co', ev)\n"
        "base = np.empty(len(o.data.vertices) * 3, np.float32); o.data.vertices.foreach_get('co', base)\n"
        "np.save(sys.argv[-1] + '_ev.npy', ev.reshape(-1, 3)); np.save(sys.argv[-1] + '_base.npy', base.reshape(-1, 3))\n"
        "print('ADDON', hasattr(bpy.types.Object, 'deformkit'))\n")
    out = subprocess.run([BLENDER, "-b", "--factory-startup", str(blend), "--python-exit-code", "1", "-P", str(script),
                          "--", name, str(tmp_path / "r")], capture_output=True, text=True, timeout=120)
    assert "ADDON False" in out.stdout, out.stdout[-2000:] + out.stderr[-2000:]
    return np.load(tmp_path / "r_ev.npy"), np.load(tmp_path / "r_base.npy")


def test_saved_results_show_without_the_addon(fixtures, tmp_path):
    """The output file itself holds the result: Blender 3.4 without the add-on shows it."""
    import deformkit as dk
    (tmp_path / "r.json").write_text(json.dumps(RECIPE))
    proc = run_batch(fixtures / "column.blend", "--recipe", tmp_path / "r.json", "--out", tmp_path / "out")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    ev, base = shown_without_addon(tmp_path / "out" / "column.blend", "Column", tmp_path)
    expected = dk.Stack([dk.SimpleDeform(mode=d["type"], angle=d["angle"], deform_axis=d["deform_axis"])
                         for d in RECIPE["deformers"]]).deform(base)
    assert np.abs(ev - expected).max() < 1e-5 and np.abs(ev - base).max() > 0.1


def test_saved_laplacian_entry_is_evaluated_again(fixtures, tmp_path, scene):
    """A bound Laplacian entry saved by Blender 3.4: the batch builds its solver from the saved rest
    and writes the result that dk.SurfaceDeformer gives for the rest, the groups and the empty's
    motion since bind."""
    import bpy
    from addon_helpers import group_members, polygons
    from deformkit_addon.entries import laplacian as surface
    import deformkit as dk
    proc = run_batch(fixtures / "laplacian_arm.blend", "--evaluate-saved", "--out", tmp_path / "out")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    out = tmp_path / "out" / "laplacian_arm.blend"
    written, base = shown_without_addon(out, "Arm", tmp_path)
    bpy.ops.wm.open_mainfile(filepath=str(out))
    obj, hand = bpy.data.objects["Arm"], bpy.data.objects["HandTarget"]
    entry = obj.deformkit.entries[0]
    at_bind = np.eye(4)
    at_bind[2, 3] = 1.5  # where make_fixtures put the empty when it bound the entry
    # kept as Blender's Hook keeps it: H(bind)^-1 obj(bind); the arm never moved
    np.testing.assert_array_equal(np.array(entry.handle_matrix).reshape(4, 4),
                                  np.linalg.inv(at_bind) @ np.array(obj.matrix_world))
    rest = surface.saved_rest(entry)
    np.testing.assert_array_equal(rest, base)  # bound first in the stack: the rest is the base mesh
    world = np.array(obj.matrix_world)
    motion = np.linalg.inv(world) @ np.array(hand.matrix_world) @ np.linalg.inv(at_bind) @ world
    handles = group_members(obj, "Hand")
    targets = rest[handles].astype(np.float64) @ motion[:3, :3].T + motion[:3, 3]
    expected = dk.SurfaceDeformer(rest, polygons(obj.data), anchors=group_members(obj, "Shoulder"),
                                  handles=handles, method=entry.method.lower()).deform(targets)
    assert np.abs(expected - base).max() > 0.5  # the arm bends
    assert np.abs(written - expected).max() < 1e-5, np.abs(written - expected).max()


def test_symlinked_output_folder_cannot_overwrite_inputs(fixtures, tmp_path):
    (tmp_path / "in").mkdir()
    shutil.copy(fixtures / "column.blend", tmp_path / "in")
    (tmp_path / "out").symlink_to(tmp_path / "in", target_is_directory=True)
    original = digest(tmp_path / "in" / "column.blend")
    proc = run_batch(tmp_path / "in" / "column.blend", "--evaluate-saved", "--out", tmp_path / "out")
    assert proc.returncode == 1 and "refusing to write" in proc.stdout
    assert digest(tmp_path / "in" / "column.blend") == original


def test_bad_command_lines(tmp_path):
    assert run_batch("x.blend", "--out", tmp_path).returncode == 2  # neither --recipe nor --evaluate-saved
    bad = tmp_path / "bad.json"
    bad.write_text('{"deformers": []}')
    proc = run_batch("x.blend", "--recipe", bad, "--out", tmp_path)
    assert proc.returncode == 2 and "deformers: expected a non-empty list of tables" in proc.stderr
    proc = subprocess.run([sys.executable, "-m", "deformkit.batch", "--addon", str(REPO / "python_addon"), "x.blend", "--evaluate-saved",
                           "--out", str(tmp_path), "--blender", "/nonexistent/blender"], capture_output=True, text=True)
    assert proc.returncode == 2 and "not found" in proc.stderr


def test_smoothness_figures_in_the_report(fixtures, tmp_path, scene):
    """--smoothness (or the recipe's "smoothness": true) puts each object's figures in the report:
    those of dk.smoothness_report on its cage, the base mesh twisted, here recomputed from the
    output file; the Subdivide entry's evaluated mesh has dk.subdivide's counts."""
    import bpy
    from addon_helpers import polygons
    import deformkit as dk
    recipe = {"objects": ["Column"], "deformers": [{"type": "TWIST", "angle": 1.2, "deform_axis": "Z"},
                                                   {"type": "SUBDIVIDE", "levels": 1}]}
    (tmp_path / "r.json").write_text(json.dumps(recipe))
    (tmp_path / "s.json").write_text(json.dumps({**recipe, "smoothness": True}))
    runs = ((["--recipe", tmp_path / "r.json", "--smoothness"], "a"), (["--recipe", tmp_path / "s.json"], "b"),
            (["--recipe", tmp_path / "r.json"], "c"))
    for flags, out in runs:
        proc = run_batch(fixtures / "column.blend", *flags, "--out", tmp_path / out)
        assert proc.returncode == 0, proc.stdout + proc.stderr
    reports = [json.loads((tmp_path / out / "report.json").read_text()) for out in "abc"]
    assert reports[0]["smoothness"] and not reports[1]["smoothness"]
    figures = [r["files"][0]["objects"][0] for r in reports]
    assert "smoothness" not in figures[2]
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "a" / "column.blend"))
    obj = bpy.data.objects["Column"]
    cage = dk.SimpleDeform(mode="TWIST", angle=1.2, deform_axis="Z").deform(positions(obj.data))
    direct = dk.smoothness_report(cage, polygons(obj.data))
    counts = dk.subdivide(cage, polygons(obj.data), 1)
    for found in figures[:2]:
        assert found["entries"] == ["TWIST", "SUBDIVIDE"]
        assert (found["evaluated_vertices"], found["evaluated_faces"]) == (len(counts.points), len(counts.faces))
        smooth = found["smoothness"]
        assert abs(smooth["max_angle"] - direct.max_angle) < 1e-12 and smooth["max_angle"] < 1e-9
        assert smooth["degenerate_samples"] == direct.degenerate_samples
        assert smooth["flipped_samples"] == direct.flipped_samples
        assert smooth["interior_edges"] == len(direct.edges) and smooth["selected_edges"] == []
        assert len(smooth["worst_edges"]) == 10

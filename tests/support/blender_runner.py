"""The two ways the tests ask Blender itself for reference results (blender_oracle.py):

* ``bpy_oracle()``: the oracle module under Blender 5.0 (the PyPI ``bpy`` module) in this process;
* ``run_blender_binary(work, spec)``: every case of ``spec`` evaluated by Debian's Blender 3.4
  binary in one subprocess.

A pinned dependency that is missing (bpy, /usr/bin/blender) fails the tests; it never skips them.
"""
from __future__ import annotations

import importlib.util
import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

ORACLE_PATH = Path(__file__).resolve().with_name("blender_oracle.py")
BLENDER_BIN = "/usr/bin/blender"
BLENDER_TIMEOUT = 300  # seconds, for the one Blender 3.4 subprocess


def empty_scene():
    import bpy  # noqa: PLC0415  (lazy: ~1 s, only for the oracle tests)
    bpy.ops.wm.read_factory_settings(use_empty=True)


def bpy_oracle():
    """blender_oracle.py imported under bpy 5.0, on an empty scene."""
    try:
        import bpy  # noqa: PLC0415  (lazy: ~1 s, only for these tests)
    except ImportError as e:  # a pinned dependency (requirements-dev.txt): fail, do not skip
        pytest.fail(f"cannot import the bpy module (bpy==5.0.1 in requirements-dev.txt): {e}")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert tuple(bpy.app.version[:2]) == (5, 0), f"expected bpy 5.0.x, got {bpy.app.version_string}"
    spec = importlib.util.spec_from_file_location("blender_oracle", ORACLE_PATH)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def write_raw(path, arr, dtype):
    """Little-endian raw binary, what the oracle reads without numpy."""
    np.ascontiguousarray(arr, dtype=np.dtype(dtype).newbyteorder("<")).tofile(path)


def run_blender_binary(work, spec):
    """Evaluate every case of ``spec`` (blender_oracle.run_cases' layout, input paths relative to
    ``work``) in Debian's Blender 3.4: {"version": "3.4.1", "cases": {id: (positions (n, 3)
    float32, info)}}."""
    if not os.path.exists(BLENDER_BIN):
        pytest.fail(f"{BLENDER_BIN} is missing: Debian's blender 3.4.1 is a required test dependency "
                    "(scripts/setup.sh installs it)")
    work = Path(work)
    (work / "cases.json").write_text(json.dumps(spec))
    out_dir = work / "out"
    # A foreign PYTHONPATH or PYTHONHOME would replace Blender's own Python.
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "PYTHONSTARTUP")}
    cmd = [BLENDER_BIN, "-b", "--factory-startup", "--python-exit-code", "1", "-P", str(ORACLE_PATH), "--",
           str(work / "cases.json"), str(out_dir)]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=BLENDER_TIMEOUT, env=env,
                              stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired as e:
        pytest.fail(f"Blender 3.4 oracle timed out after {BLENDER_TIMEOUT} s: {e.stdout!r} {e.stderr!r}")
    log = f"exit code {proc.returncode}\nstdout:\n{proc.stdout[-4000:]}\nstderr:\n{proc.stderr[-4000:]}"
    assert proc.returncode == 0, f"Blender 3.4 oracle failed: {log}"
    res_path = out_dir / "results.json"
    assert res_path.exists(), f"Blender 3.4 oracle wrote no results: {log}"
    res = json.loads(res_path.read_text())
    assert tuple(res["blender_version"][:2]) == (3, 4), f"{BLENDER_BIN} is Blender {res['blender_version']}, not 3.4"
    out = {"version": ".".join(map(str, res["blender_version"])), "cases": {}}
    for case in spec["cases"]:
        info = res["cases"][case["id"]]
        pos = np.fromfile(out_dir / info["positions"], dtype="<f4").reshape(info["n"], 3)
        out["cases"][case["id"]] = (pos, info)
    return out

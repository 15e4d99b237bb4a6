"""Runs this folder's tests inside Debian's Blender 3.4 binary, from the pytest of the project."""
import json
import os
import pathlib
import re
import subprocess
import tempfile

import pytest

from addon_helpers import IN_BLENDER_BINARY, REPO

BLENDER = "/usr/bin/blender"
pytestmark = pytest.mark.skipif(IN_BLENDER_BINARY, reason="already inside Blender")


# Why a test of this folder may skip inside Blender 3.4: it starts Blender (or the launcher) itself,
# or the shared data is not beside the checkout. Any other reason fails the run.
EXPECTED_SKIPS = ("the batch tests start Blender themselves", "runs the launcher, not Blender",
                  "starts its own Blender 3.4 window, from outside Blender", "already inside Blender")
SHARED_DATA_MISSING = re.compile(r"not found: the shared [a-z ]+ (is|are) not beside this checkout$")


def run_blender(libdir, *pytest_args, timeout=600, env=None):
    if not os.path.exists(BLENDER):
        pytest.fail(f"{BLENDER} is missing: `make test` installs Debian's blender package")
    cmd = [BLENDER, "-b", "--factory-startup", "--python-exit-code", "1",
           "-P", str(REPO / "tests/addon/run_in_blender.py"), "--", libdir, *pytest_args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=REPO,
                          env={**os.environ, **(env or {})})


def deformkit_lib():
    """A folder holding only the built deformkit package: Blender 3.4 keeps its own numpy."""
    import deformkit
    lib = pathlib.Path(tempfile.mkdtemp(prefix="deformkit_lib_"))
    (lib / "deformkit").symlink_to(pathlib.Path(deformkit.__file__).parent, target_is_directory=True)
    return str(lib)


def test_addon_suite_passes_in_blender_3_4(tmp_path, capsys):
    """The add-on suite inside Blender 3.4; each test it skipped is listed with its reason, and a
    reason not in EXPECTED_SKIPS (nor missing shared data) fails the run."""
    log = tmp_path / "skips.json"
    proc = run_blender(deformkit_lib(), "-q", "tests/addon", "-k", "not missing_module",
                       env={"DEFORMKIT_SKIP_LOG": str(log)})
    tail = (proc.stdout + proc.stderr)[-6000:]
    assert proc.returncode == 0, tail
    assert " passed" in proc.stdout and "Blender 3.4" in proc.stdout + proc.stderr, tail
    skips = json.loads(log.read_text())
    with capsys.disabled():
        print(f"\nBlender 3.4: {len(skips)} skipped")
        for skip in skips:
            print(f"  SKIPPED {skip['test']}: {skip['reason']}")
    unexpected = [s for s in skips if s["reason"] not in EXPECTED_SKIPS and not SHARED_DATA_MISSING.search(s["reason"])]
    assert not unexpected, "unexpected skips in Blender 3.4:\n" + "\n".join(f"{s['test']}: {s['reason']}" for s in unexpected)


def test_missing_module_in_blender_3_4():
    proc = run_blender("", "-q", "tests/addon/test_addon.py", "-k", "missing_module", "-rs")
    tail = (proc.stdout + proc.stderr)[-6000:]
    assert proc.returncode == 0 and "1 passed" in proc.stdout, tail

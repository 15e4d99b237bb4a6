"""Runs this folder's tests inside Debian's Blender 3.4 binary, from the pytest of the project."""
import os
import pathlib
import subprocess
import tempfile

import pytest

from addon_helpers import IN_BLENDER_BINARY, REPO

BLENDER = "/usr/bin/blender"
pytestmark = pytest.mark.skipif(IN_BLENDER_BINARY, reason="already inside Blender")


def run_blender(libdir, *pytest_args, timeout=600):
    if not os.path.exists(BLENDER):
        pytest.fail(f"{BLENDER} is missing: `make test` installs Debian's blender package")
    cmd = [BLENDER, "-b", "--factory-startup", "--python-exit-code", "1",
           "-P", str(REPO / "tests/addon/run_in_blender.py"), "--", libdir, *pytest_args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=REPO)


def deformkit_lib():
    """A folder holding only the built deformkit package: Blender 3.4 keeps its own numpy."""
    import deformkit
    lib = pathlib.Path(tempfile.mkdtemp(prefix="deformkit_lib_"))
    (lib / "deformkit").symlink_to(pathlib.Path(deformkit.__file__).parent, target_is_directory=True)
    return str(lib)


def test_addon_suite_passes_in_blender_3_4():
    proc = run_blender(deformkit_lib(), "-q", "tests/addon", "-k", "not missing_module")
    tail = (proc.stdout + proc.stderr)[-6000:]
    assert proc.returncode == 0, tail
    assert " passed" in proc.stdout and "Blender 3.4" in proc.stdout + proc.stderr, tail


def test_missing_module_in_blender_3_4():
    proc = run_blender("", "-q", "tests/addon/test_addon.py", "-k", "missing_module", "-rs")
    tail = (proc.stdout + proc.stderr)[-6000:]
    assert proc.returncode == 0 and "1 passed" in proc.stdout, tail

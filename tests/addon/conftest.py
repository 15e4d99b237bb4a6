"""The add-on tests run twice: in this process under the PyPI bpy module (Blender 5.0), and inside
Debian's Blender 3.4 binary (test_blender34.py starts it with run_in_blender.py)."""
import pathlib
import subprocess
import sys
import tempfile

import pytest

from addon_helpers import REPO

# The add-on is installed under the package name users get: deformkit_addon.
_addons = pathlib.Path(tempfile.mkdtemp(prefix="deformkit_addons_"))
(_addons / "deformkit_addon").symlink_to(REPO / "python_addon", target_is_directory=True)
sys.path.insert(0, str(_addons))


@pytest.fixture(scope="session")
def bpy_module():
    import bpy
    return bpy


@pytest.fixture(scope="session")
def addon(bpy_module):
    import deformkit_addon
    if not hasattr(bpy_module.types.Object, "deformkit"):
        deformkit_addon.register()
    yield deformkit_addon


@pytest.fixture
def scene(bpy_module, addon):
    """An empty scene for each test."""
    bpy_module.ops.wm.read_factory_settings(use_empty=True)
    if not hasattr(bpy_module.types.Object, "deformkit"):
        addon.register()
    yield bpy_module.context.scene


@pytest.fixture(scope="session")
def fixtures(tmp_path_factory):
    """The .blend fixtures (blend_fixtures/make_fixtures.py, in Blender 3.4), made once per session
    for the batch tests."""
    out = tmp_path_factory.mktemp("fixtures")
    proc = subprocess.run(["/usr/bin/blender", "-b", "--factory-startup", "--python-exit-code", "1", "-P",
                           str(REPO / "blend_fixtures/make_fixtures.py"), "--", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return out

"""The installable archives: a Blender 4.2+ extension (tried in bpy 5.0) and a legacy add-on zip
(tried in Blender 3.4), each bringing its own compiled module."""
import glob
import pathlib
import re
import subprocess
import sys
import textwrap
import tomllib
import zipfile

import pytest

from addon_helpers import IN_BLENDER_BINARY, REPO

pytestmark = pytest.mark.skipif(IN_BLENDER_BINARY, reason="builds archives and starts Blender itself")


@pytest.fixture(scope="module")
def archives(tmp_path_factory):
    out = tmp_path_factory.mktemp("dist")
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-build-isolation", "--no-deps",
                           "-w", str(out), str(REPO)], capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    wheel = glob.glob(str(out / "deformkit-*.whl"))[0]
    proc = subprocess.run([sys.executable, str(REPO / "scripts/package_addon.py"), wheel, str(out)],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    extension, legacy = proc.stdout.split()
    return pathlib.Path(extension), pathlib.Path(legacy)


def test_manifest_follows_the_extension_rules(archives):
    with zipfile.ZipFile(archives[0]) as zf:
        manifest = tomllib.loads(zf.read("blender_manifest.toml").decode())
        names = zf.namelist()
    for key in ("schema_version", "id", "name", "tagline", "version", "type", "maintainer",
                "blender_version_min", "license"):
        assert key in manifest, key
    assert manifest["id"].isidentifier() and manifest["type"] == "add-on"
    assert len(manifest["tagline"]) <= 64 and not re.search(r"[.!?,;:]$", manifest["tagline"])
    for wheel in manifest["wheels"]:
        assert wheel.removeprefix("./") in names
    assert "__init__.py" in names and not any("__pycache__" in n for n in names)


def run(cmd, **kw):
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300, **kw)


def test_extension_installs_in_blender_5(archives, tmp_path):
    script = tmp_path / "install.py"
    script.write_text(textwrap.dedent(f"""
        import glob, os, sys
        for var, sub in (("EXTENSIONS", "ext"), ("CONFIG", "config"), ("SCRIPTS", "scripts")):
            os.environ["BLENDER_USER_" + var] = {str(tmp_path)!r} + "/" + sub
        import bpy
        assert bpy.ops.extensions.package_install_files(
            filepath={str(archives[0])!r}, repo="user_default", enable_on_install=True) == {{"FINISHED"}}
        mod = sys.modules["bl_ext.user_default.deformkit"]
        assert glob.glob({str(tmp_path)!r} + "/ext/**/site-packages/deformkit/_core*.so", recursive=True, include_hidden=True)
        assert mod.native.available(), mod.native.IMPORT_ERROR
        bpy.ops.mesh.primitive_monkey_add()
        entry = mod.api.add_entry(bpy.context.active_object, "TWIST", angle=1.0)
        assert entry.error == "" and "deformkit" in bpy.context.active_object.modifiers
        print("EXTENSION OK")
    """))
    proc = run([sys.executable, str(script)])
    assert "EXTENSION OK" in proc.stdout, proc.stdout[-2000:] + proc.stderr[-2000:]


def test_legacy_zip_installs_in_blender_3_4(archives, tmp_path):
    script = tmp_path / "install.py"
    script.write_text(textwrap.dedent(f"""
        import sys, addon_utils, bpy
        bpy.ops.preferences.addon_install(filepath={str(archives[1])!r})
        addon_utils.enable("deformkit_addon", default_set=True)
        mod = sys.modules["deformkit_addon"]
        assert mod.native.available(), mod.native.IMPORT_ERROR
        assert mod.native.dk.__file__.startswith({str(tmp_path)!r}), mod.native.dk.__file__
        bpy.ops.mesh.primitive_monkey_add()
        entry = mod.api.add_entry(bpy.context.active_object, "BEND", angle=1.0)
        assert entry.error == "" and "deformkit" in bpy.context.active_object.modifiers
        print("LEGACY OK", bpy.app.version_string)
    """))
    env = {"BLENDER_USER_SCRIPTS": str(tmp_path / "scripts"), "BLENDER_USER_CONFIG": str(tmp_path / "config"),
           "PATH": "/usr/bin:/bin", "HOME": str(tmp_path)}
    proc = run(["/usr/bin/blender", "-b", "--factory-startup", "--python-exit-code", "1", "-P", str(script)], env=env)
    assert "LEGACY OK 3.4" in proc.stdout, proc.stdout[-2000:] + proc.stderr[-2000:]

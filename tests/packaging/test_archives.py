"""The installable archives (issue 20): a Blender 4.2+ extension (tried in bpy 5.0) and a legacy
add-on zip (tried in Blender 3.4), each bringing the repaired module and its libraries, loaded with
nothing of the project's .venv reachable; and the panel's message when the module cannot load."""
import json
import os
import pathlib
import platform
import re
import shutil
import subprocess
import sysconfig
import textwrap
import tomllib
import zipfile

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]
SITE = pathlib.Path(sysconfig.get_paths()["purelib"])
# bpy 5.0 and numpy (all it needs to install and run an extension): the only part of .venv the bpy
# process sees, through symlinks in a folder of its own (no .venv path is on its sys.path, and
# deformkit's development install is not reachable).
BPY_PARTS = ("bpy", "numpy", "numpy.libs")
# The base interpreter of .venv (bpy 5.0 is built for CPython 3.11), without site-packages.
BASE_PYTHON = pathlib.Path(sysconfig.get_config_var("BINDIR")) / "python3"

# What a script prints about the process it runs in: where the bundled libraries were mapped from,
# and any Debian libhwy (bpy 5.0 loads none of its own; Debian's Blender 3.4 does, through its
# image libraries, beside the add-on's bundled copy).
MAPPED = """
import re
maps = open("/proc/self/maps").read()
print("MAPPED", sorted({m for m in re.findall(r"(/\\S+/deformkit\\.libs/\\S+)", maps)}))
print("SYSTEM_HWY", sorted({m for m in re.findall(r"(/\\S*/libhwy\\.so\\S*)", maps)}))
"""


def run(cmd, **kw):
    return subprocess.run(cmd, capture_output=True, text=True, timeout=600, **kw)


def test_manifest_follows_the_extension_rules(shipped):
    wheel, extension, _, _ = shipped
    with zipfile.ZipFile(extension) as zf:
        manifest = tomllib.loads(zf.read("blender_manifest.toml").decode())
        names = zf.namelist()
    for key in ("schema_version", "id", "name", "tagline", "version", "type", "maintainer",
                "blender_version_min", "license"):
        assert key in manifest, key
    assert manifest["id"].isidentifier() and manifest["type"] == "add-on"
    assert len(manifest["tagline"]) <= 64 and not re.search(r"[.!?,;:]$", manifest["tagline"])
    assert manifest["platforms"] == ["linux-x64"] and manifest["wheels"] == [f"./wheels/{wheel.name}"]
    assert manifest["license"] == ["SPDX:GPL-3.0-or-later"]  # what the wheel inside is conveyed under
    for entry in manifest["wheels"]:
        assert entry.removeprefix("./") in names
    assert {"__init__.py", "THIRD_PARTY_LICENSES", "LICENSE", "build_target.json"} <= set(names)
    assert not any("__pycache__" in n for n in names)


def test_legacy_zip_unpacks_the_whole_wheel(shipped):
    wheel, _, legacy, _ = shipped
    with zipfile.ZipFile(wheel) as whl, zipfile.ZipFile(legacy) as zf:
        want = {n for n in whl.namelist() if n.startswith(("deformkit/", "deformkit.libs/")) and not n.endswith("/")}
        have = {n.removeprefix("deformkit_addon/lib/") for n in zf.namelist() if n.startswith("deformkit_addon/lib/")}
        assert have == want and any(n.startswith("deformkit.libs/libcholmod") for n in have)
        assert zf.read("deformkit_addon/THIRD_PARTY_LICENSES") == whl.read(
            next(n for n in whl.namelist() if n.endswith("licenses/THIRD_PARTY_LICENSES")))


def bpy_only_path(tmp_path):
    folder = tmp_path / "bpy_only"
    folder.mkdir()
    for name in BPY_PARTS:
        (folder / name).symlink_to(SITE / name, target_is_directory=True)
    return folder


def test_extension_installs_in_blender_5_without_the_venv(shipped, tmp_path):
    script = tmp_path / "install.py"
    script.write_text(textwrap.dedent(f"""
        import glob, importlib.util, os, sys
        sys.path.insert(0, {str(bpy_only_path(tmp_path))!r})
        assert not any(p.startswith({str(REPO)!r}) for p in sys.path), sys.path
        assert importlib.util.find_spec("deformkit") is None  # only the extension can bring it
        for var, sub in (("EXTENSIONS", "ext"), ("CONFIG", "config"), ("SCRIPTS", "scripts")):
            os.environ["BLENDER_USER_" + var] = {str(tmp_path)!r} + "/" + sub
        import bpy
        assert bpy.ops.extensions.package_install_files(
            filepath={str(shipped[1])!r}, repo="user_default", enable_on_install=True) == {{"FINISHED"}}
        mod = sys.modules["bl_ext.user_default.deformkit"]
        assert mod.native.available(), mod.native.IMPORT_ERROR
        assert mod.native.dk.__file__.startswith({str(tmp_path)!r} + "/ext/"), mod.native.dk.__file__
    """) + deforms_a_monkey("TWIST") + 'print("EXTENSION OK")\n' + MAPPED)
    env = {"PATH": "/usr/bin:/bin", "LD_LIBRARY_PATH": "", "HOME": str(tmp_path)}
    proc = run([str(BASE_PYTHON), "-I", "-S", str(script)], env=env, cwd=tmp_path)
    print(proc.stdout[-3000:])
    assert "EXTENSION OK" in proc.stdout, proc.stdout[-2000:] + proc.stderr[-3000:]
    mapped = json.loads(re.search(r"^MAPPED (.*)$", proc.stdout, re.M).group(1).replace("'", '"'))
    assert any("/libcholmod-" in m for m in mapped) and all(m.startswith(str(tmp_path / "ext")) for m in mapped), mapped
    assert re.search(r"^SYSTEM_HWY \[\]$", proc.stdout, re.M)  # Debian's libhwy is not loaded at all


def deforms_a_monkey(kind):
    """Script lines (for a Blender with the add-on as `mod`): a monkey given a `kind` entry moves."""
    return textwrap.dedent(f"""
        bpy.ops.mesh.primitive_monkey_add()
        obj = bpy.context.active_object
        entry = mod.api.add_entry(obj, "{kind}", angle=1.0)
        assert entry.error == "" and "deformkit" in obj.modifiers
        rest = [v.co.copy() for v in obj.data.vertices]
        deformed = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data.vertices
        assert max((a.co - b).length for a, b in zip(deformed, rest)) > 1e-2  # the mesh did move
    """)


def legacy_script(zip_path, tmp_path, body):
    script = tmp_path / "install.py"
    script.write_text(textwrap.dedent(f"""
        import sys, addon_utils, bpy
        assert not any(p.startswith({str(REPO)!r}) for p in sys.path), sys.path
        bpy.ops.preferences.addon_install(filepath={str(zip_path)!r})
        addon_utils.enable("deformkit_addon", default_set=True)
        mod = sys.modules["deformkit_addon"]
    """) + textwrap.dedent(body) + MAPPED)
    env = {"BLENDER_USER_SCRIPTS": str(tmp_path / "scripts"), "BLENDER_USER_CONFIG": str(tmp_path / "config"),
           "PATH": "/usr/bin:/bin", "HOME": str(tmp_path), "LD_LIBRARY_PATH": ""}
    return run(["/usr/bin/blender", "-b", "--factory-startup", "--python-exit-code", "1", "-P", str(script)],
               env=env, cwd=tmp_path)


def test_legacy_zip_installs_in_blender_3_4(shipped, tmp_path):
    proc = legacy_script(shipped[2], tmp_path, textwrap.dedent(f"""
        assert mod.native.available(), mod.native.IMPORT_ERROR
        assert mod.native.dk.__file__.startswith({str(tmp_path)!r}), mod.native.dk.__file__
    """) + deforms_a_monkey("BEND") + 'print("LEGACY OK", bpy.app.version_string)\n')
    print(proc.stdout[-3000:])
    assert "LEGACY OK 3.4" in proc.stdout, proc.stdout[-2000:] + proc.stderr[-2000:]
    mapped = json.loads(re.search(r"^MAPPED (.*)$", proc.stdout, re.M).group(1).replace("'", '"'))
    assert any("/libcholmod-" in m for m in mapped) and all(m.startswith(str(tmp_path)) for m in mapped), mapped


def test_the_panel_says_what_the_package_was_built_for(shipped, tmp_path):
    """A legacy zip made for another Python (CPython 3.12: the module's file name and
    build_target.json as such a build writes them) in Blender 3.4 (CPython 3.11): the add-on loads,
    and its panel names both the package's target and the running Blender's."""
    other = tmp_path / "deformkit_addon-other-python.zip"
    with zipfile.ZipFile(shipped[2]) as src, zipfile.ZipFile(other, "w", zipfile.ZIP_DEFLATED) as dst:
        for name in src.namelist():
            data = src.read(name)
            if name.endswith("build_target.json"):
                target = json.loads(data)
                target.update(python="3.12", soabi="cpython-312-x86_64-linux-gnu")
                data = json.dumps(target).encode()
            dst.writestr(name.replace("cpython-311-", "cpython-312-"), data)
    proc = legacy_script(other, tmp_path, """
        import platform, sysconfig, types
        assert not mod.native.available()
        print("ERROR", mod.native.IMPORT_ERROR)
        print("RUNNING", platform.python_version(), sysconfig.get_config_var("SOABI"), platform.machine())
        class Layout:
            lines = []
            def column(self, **kw): return self
            def label(self, text="", icon="NONE"): self.lines.append(text)
        bpy.ops.mesh.primitive_cube_add()
        layout = Layout()
        mod.ui.DEFORMKIT_PT_stack.draw(types.SimpleNamespace(layout=layout), bpy.context)
        print("PANEL", " ".join(layout.lines))
    """)
    print(proc.stdout[-3000:])
    error = re.search(r"^ERROR (.*)$", proc.stdout, re.M)
    assert error, proc.stdout[-2000:] + proc.stderr[-2000:]
    error = error.group(1)
    version, soabi, machine = re.search(r"^RUNNING (.*)$", proc.stdout, re.M).group(1).split()
    assert "built for CPython 3.12 (cpython-312-x86_64-linux-gnu) on linux x86_64" in error, error
    assert f"this Blender runs CPython {version} ({soabi}) on linux {machine}" in error, error
    assert "built for this Blender's Python" in error
    panel = re.search(r"^PANEL (.*)$", proc.stdout, re.M).group(1)
    assert panel.split() == error.split()  # all of it, wrapped to the panel's width

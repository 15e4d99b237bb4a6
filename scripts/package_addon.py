"""Build the installable add-on archives from the add-on tree and the deformkit wheel.

    python scripts/package_addon.py WHEEL OUT_DIR

- deformkit-<version>-extension.zip: a Blender 4.2+ extension (blender_manifest.toml at the root,
  the wheel in wheels/), installed with Preferences > Get Extensions > Install from Disk;
- deformkit_addon-<version>-legacy.zip: a legacy add-on for Blender 3.x (Install... in
  Preferences > Add-ons), with the wheel unpacked in deformkit_addon/lib/ (the package and the
  libraries auditwheel bundled beside it, deformkit.libs/).
WHEEL must be the repaired one (`make wheel`: a manylinux tag), so that both archives are
self-contained. Each also gets, at the add-on's root, the wheel's THIRD_PARTY_LICENSES, the
project's LICENSE, and build_target.json (what the module was built for, with the wheel's platform
tag), which python_addon/native.py reads when the module cannot be loaded.
Archives are written under a temporary name and renamed. The version is pyproject.toml's (the one
place it is written): the wheel must carry it, bl_info must equal it, and the extension's manifest
gets it, with the wheel's name, here.
"""
import ast
import json
import os
import sys
import tomllib
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ADDON = os.path.join(ROOT, "python_addon")


def addon_files():
    for folder, dirs, files in os.walk(ADDON):
        dirs[:] = [d for d in dirs if d != "__pycache__"]
        for name in sorted(files):
            if not name.endswith((".pyc", ".tmp")):
                path = os.path.join(folder, name)
                yield path, os.path.relpath(path, ADDON)


def project_version():
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as fh:
        return tomllib.load(fh)["project"]["version"]


def bl_info_version():
    """bl_info["version"] read as Blender's legacy loader reads it: from the syntax tree, unexecuted."""
    with open(os.path.join(ADDON, "__init__.py")) as fh:
        tree = ast.parse(fh.read())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "bl_info" for t in node.targets):
            return ".".join(str(part) for part in ast.literal_eval(node.value)["version"])
    return None


def packaged_manifest(source, version, wheel_name):
    """The source manifest with the release's version and wheel, as top-level keys (placed before
    the first table, where TOML keeps them top-level)."""
    if {"version", "wheels"} & tomllib.loads(source).keys():
        raise ValueError("blender_manifest.toml: version and wheels are written by package_addon.py, "
                         "not in the source")
    lines = source.splitlines()
    first_table = next((i for i, line in enumerate(lines) if line.lstrip().startswith("[")), len(lines))
    while first_table > 0 and not lines[first_table - 1].strip():
        first_table -= 1
    added = [f'version = "{version}"', f'wheels = ["./wheels/{wheel_name}"]']
    return "\n".join(lines[:first_table] + added + lines[first_table:]) + "\n"


def write_zip(path, entries):
    tmp = f"{path}.{os.getpid()}.tmp"  # run-unique, beside the archive: the rename is atomic
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zf:
        for arcname, data in entries:
            zf.writestr(arcname, data)
    os.replace(tmp, path)


def wheel_extras(whl, wheel_platform):
    """The files every archive carries at the add-on's root, from the wheel."""
    names = whl.namelist()
    licences = [n for n in names if n.endswith(".dist-info/licenses/THIRD_PARTY_LICENSES")]
    if not licences:
        sys.exit("package_addon: the wheel has no THIRD_PARTY_LICENSES: build it with `make wheel`")
    target = json.loads(whl.read("deformkit/build_target.json"))
    target["wheel_platform"] = wheel_platform
    with open(os.path.join(ROOT, "LICENSE"), "rb") as fh:
        licence = fh.read()
    return [("THIRD_PARTY_LICENSES", whl.read(licences[0])), ("LICENSE", licence),
            ("build_target.json", (json.dumps(target, indent=2) + "\n").encode())]


def main(wheel, out_dir):
    version, wheel_name = project_version(), os.path.basename(wheel)
    wheel_version = wheel_name.split("-")[1] if wheel_name.count("-") >= 4 else None
    if wheel_version != version:
        sys.exit(f"package_addon: {wheel_name} is not a deformkit {version} wheel (pyproject.toml's version)")
    wheel_platform = wheel_name.removesuffix(".whl").split("-")[-1]
    if "manylinux" not in wheel_platform:
        sys.exit(f"package_addon: {wheel_name} is not repaired (platform {wheel_platform}, not manylinux): "
                 "its libraries are not inside it; build it with `make wheel`")
    if bl_info_version() != version:
        sys.exit(f"package_addon: python_addon/__init__.py bl_info version {bl_info_version()} is not "
                 f"pyproject.toml's {version}")
    with open(os.path.join(ADDON, "blender_manifest.toml")) as fh:
        manifest = packaged_manifest(fh.read(), version, wheel_name)
    os.makedirs(out_dir, exist_ok=True)
    files = [(rel, open(path, "rb").read()) for path, rel in addon_files()]
    with zipfile.ZipFile(wheel) as whl:
        files += wheel_extras(whl, wheel_platform)
        module = [(f"deformkit_addon/lib/{n}", whl.read(n)) for n in whl.namelist()
                  if n.startswith(("deformkit/", "deformkit.libs/"))]
    extension = os.path.join(out_dir, f"deformkit-{version}-extension.zip")
    write_zip(extension, [(rel, manifest.encode() if rel == "blender_manifest.toml" else data) for rel, data in files]
              + [(f"wheels/{wheel_name}", open(wheel, "rb").read())])
    legacy = os.path.join(out_dir, f"deformkit_addon-{version}-legacy.zip")
    write_zip(legacy, [(f"deformkit_addon/{rel}", data) for rel, data in files
                       if rel != "blender_manifest.toml"] + module)
    print(extension)
    print(legacy)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])

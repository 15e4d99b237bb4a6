"""Build the installable add-on archives from the add-on tree and the deformkit wheel.

    python scripts/package_addon.py WHEEL OUT_DIR

- deformkit-<version>-extension.zip: a Blender 4.2+ extension (blender_manifest.toml at the root,
  the wheel in wheels/), installed with Preferences > Get Extensions > Install from Disk;
- deformkit_addon-<version>-legacy.zip: a legacy add-on for Blender 3.x (Install... in
  Preferences > Add-ons), with the compiled module unpacked in deformkit_addon/lib/.
Archives are written under a temporary name and renamed.
"""
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


def write_zip(path, entries):
    tmp = path + ".tmp"
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zf:
        for arcname, data in entries:
            zf.writestr(arcname, data)
    os.replace(tmp, path)


def main(wheel, out_dir):
    with open(os.path.join(ADDON, "blender_manifest.toml"), "rb") as fh:
        manifest = tomllib.load(fh)
    listed = [os.path.basename(w) for w in manifest.get("wheels", [])]
    if os.path.basename(wheel) not in listed:
        sys.exit(f"package_addon: {os.path.basename(wheel)} is not listed in blender_manifest.toml wheels {listed}")
    version = manifest["version"]
    os.makedirs(out_dir, exist_ok=True)
    files = [(rel, open(path, "rb").read()) for path, rel in addon_files()]
    extension = os.path.join(out_dir, f"deformkit-{version}-extension.zip")
    write_zip(extension, files + [(f"wheels/{os.path.basename(wheel)}", open(wheel, "rb").read())])
    with zipfile.ZipFile(wheel) as whl:
        module = [(f"deformkit_addon/lib/{n}", whl.read(n)) for n in whl.namelist() if n.startswith("deformkit/")]
    legacy = os.path.join(out_dir, f"deformkit_addon-{version}-legacy.zip")
    write_zip(legacy, [(f"deformkit_addon/{rel}", data) for rel, data in files
                       if rel != "blender_manifest.toml"] + module)
    print(extension)
    print(legacy)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])

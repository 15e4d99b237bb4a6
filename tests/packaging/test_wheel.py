"""The repaired wheel (issue 20): it installs into a fresh virtual environment and works there with
the system's library search path restricted to what the manylinux policy allows; its licences
follow what it contains."""
import email.parser
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys
import sysconfig
import textwrap
import zipfile

import pytest

import auditwheel

# What a manylinux wheel may load from the system (PEP 600: glibc's libraries, the C++ runtime).
SYSTEM = {"libc.so.6", "libm.so.6", "libpthread.so.0", "libdl.so.2", "librt.so.1", "libstdc++.so.6",
          "libgcc_s.so.1", "ld-linux-x86-64.so.2", "linux-vdso.so.1"}
SITE = pathlib.Path(sysconfig.get_paths()["purelib"])  # .venv's, where numpy comes from
REPO = pathlib.Path(__file__).resolve().parents[2]


def platform_tag(show):
    m = re.search(r'consistent\s+with\s+the\s+following\s+platform\s+tag:\s*"([^"]+)"', show)
    assert m, show
    return m.group(1)


def test_the_wheel_carries_the_tag_auditwheel_show_reports(shipped):
    wheel, _, _, show = shipped
    tag = platform_tag(show)
    assert tag.startswith("manylinux_") and wheel.name.endswith(f"-cp311-cp311-{tag}.whl"), (wheel.name, tag)
    with zipfile.ZipFile(wheel) as zf:
        info = next(n for n in zf.namelist() if n.endswith(".dist-info/WHEEL"))
        assert f"Tag: cp311-cp311-{tag}" in zf.read(info).decode().splitlines()


def test_the_allowed_libraries_are_within_the_policy(shipped):
    """SYSTEM, which the next tests accept from /usr/lib, is no wider than auditwheel's policy for
    the wheel's tag."""
    tag = platform_tag(shipped[3])
    policies = json.loads((pathlib.Path(auditwheel.__file__).parent / "policy" / "manylinux-policy.json").read_text())
    policy = next(p for p in policies if p["name"] == tag.removesuffix("_x86_64"))
    assert SYSTEM - {"linux-vdso.so.1", "ld-linux-x86-64.so.2"} <= set(policy["lib_whitelist"])


@pytest.fixture(scope="module")
def fresh_venv(shipped, tmp_path_factory):
    """A new virtual environment with the wheel installed by pip, offline, and numpy copied from
    .venv's site-packages (nothing else of .venv is reachable from it)."""
    root = tmp_path_factory.mktemp("venv")
    venv = root / "env"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    python = venv / "bin" / "python"
    site = pathlib.Path(subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                                       capture_output=True, text=True, check=True).stdout.strip())
    for name in os.listdir(SITE):
        if name == "numpy" or name == "numpy.libs" or re.match(r"numpy-[\d.]+\.dist-info$", name):
            shutil.copytree(SITE / name, site / name)
    proc = subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install", "-q", "--no-index",
                           "--no-deps", "--disable-pip-version-check", str(shipped[0])],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return python, site


def restricted_env():
    return {"PATH": "/usr/bin:/bin", "LD_LIBRARY_PATH": "", "HOME": os.environ.get("HOME", "/root")}


def test_the_wheel_works_in_a_fresh_venv_with_no_library_path(fresh_venv, tmp_path):
    python, site = fresh_venv
    script = tmp_path / "check.py"
    script.write_text(textwrap.dedent(f"""
        import sys
        import numpy as np
        import deformkit as dk
        assert dk.__file__.startswith({str(site)!r}), dk.__file__
        assert not any(p.startswith({str(REPO)!r}) for p in sys.path), sys.path  # no .venv, no python/
        # Twist about z (Barr 1984, eq. 5): a point turns by rate * z about the axis.
        rng = np.random.default_rng(20)
        p = rng.uniform(-1, 1, (500, 3))
        q = dk.Twist(rate=0.7, axis="z").deform(p)
        a = 0.7 * p[:, 2]
        want = np.stack([p[:, 0] * np.cos(a) - p[:, 1] * np.sin(a), p[:, 0] * np.sin(a) + p[:, 1] * np.cos(a), p[:, 2]], 1)
        assert np.abs(q - want).max() < 1e-12, np.abs(q - want).max()
        # Laplacian editing (CHOLMOD, statically linked, on OpenBLAS): a translation of every
        # constraint translates the whole mesh, the Laplacian of a translation being zero.
        n = 12
        x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
        pts = np.stack([x.ravel(), y.ravel(), 0.2 * np.sin(3 * x.ravel()) * y.ravel()], 1)
        ids = np.arange(n * n).reshape(n, n)
        tris = np.concatenate([np.stack([ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:]], -1).reshape(-1, 3),
                               np.stack([ids[:-1, :-1], ids[1:, 1:], ids[:-1, 1:]], -1).reshape(-1, 3)])
        handles = np.concatenate([ids[:, 0], ids[:, -1]])
        shift = pts + [0.3, -0.2, 0.5]
        out = dk.SurfaceDeformer(pts, tris, handles=handles, method="laplacian").deform(shift[handles])
        assert np.abs(out - shift).max() < 1e-10, np.abs(out - shift).max()
        lifted = pts[handles] + np.array([[0, 0, 0.3]] * n + [[0, 0, 0]] * n)  # one side raised
        bent = dk.SurfaceDeformer(pts, tris, handles=handles, method="laplacian").deform(lifted)
        assert np.abs(bent - pts).max() > 0.1  # a real solve, not the rest shape
        # Catmull-Clark (OpenSubdiv): a cube refined twice has 6 * 4^2 quads and, being a closed
        # genus-0 quad mesh (V - E + F = 2, E = 2F), F + 2 points, inside the cube (convex hull).
        cube = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
        faces = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
        m = dk.subdivide(cube, faces, 2)
        assert len(m.faces) == 96 and len(m.points) == 98, (len(m.faces), len(m.points))
        assert np.all((m.points > 0) & (m.points < 1))
        # None of the bundled libraries' Debian originals (libhwy.so.1, libcholmod.so.3, ...) is in
        # the process: each was loaded from deformkit.libs under its hashed name.
        import os, re
        bundled = {{re.sub(r"-[0-9a-f]{{8}}$", "", n.split(".")[0]) for n in os.listdir({str(site)!r} + "/deformkit.libs")}}
        mapped = set(re.findall(r"(/\\S+\\.so[.\\d]*)$", open("/proc/self/maps").read(), re.M))
        outside = [p for p in mapped if not p.startswith({str(site)!r})]
        assert not [p for p in outside if os.path.basename(p).split(".")[0] in bundled], outside
        assert [p for p in mapped if "/deformkit.libs/libcholmod-" in p], mapped
        print("FRESH VENV OK")
    """))
    proc = subprocess.run([str(python), str(script)], capture_output=True, text=True, timeout=300,
                          env=restricted_env(), cwd=tmp_path)
    assert "FRESH VENV OK" in proc.stdout, proc.stdout[-2000:] + proc.stderr[-3000:]


def ldd(path):
    proc = subprocess.run(["ldd", str(path)], capture_output=True, text=True, env=restricted_env())
    assert proc.returncode == 0, proc.stderr
    rows = []
    for line in proc.stdout.splitlines():
        m = re.match(r"\s*(\S+)(?: => (\S+|not found))?", line)
        if m and m.group(1) != "statically":  # the loader is listed by its path: named by its file
            rows.append((os.path.basename(m.group(1)), m.group(2) or m.group(1)))
    return rows


def test_ldd_resolves_only_policy_libraries_outside_the_wheel(fresh_venv):
    _, site = fresh_venv
    objects = sorted(site.glob("deformkit/_core*.so")) + sorted(site.glob("deformkit.libs/*.so*"))
    assert len(objects) >= 2, objects
    bundled = {p.name for p in site.glob("deformkit.libs/*")}
    for obj in objects:
        for soname, resolved in ldd(obj):
            assert resolved != "not found", (obj.name, soname)
            if soname in bundled:
                assert pathlib.Path(resolved).resolve().parent == (site / "deformkit.libs").resolve(), (obj.name, soname, resolved)
            else:
                assert soname in SYSTEM, f"{obj.name} loads {soname} from {resolved}, outside the wheel and the policy"
                assert resolved.startswith(("/lib", "/usr/lib")) or soname == "linux-vdso.so.1", resolved


def test_licences_declared_follow_what_is_linked(shipped, tmp_path):
    """CHOLMOD's supernodal factorisation (GPL-2.0-or-later) is in the bundled libcholmod, so the
    wheel declares GPL; every bundled library has its copyright text in THIRD_PARTY_LICENSES."""
    with zipfile.ZipFile(shipped[0]) as zf:
        names = zf.namelist()
        dist_info = next(n.split("/")[0] for n in names if ".dist-info/" in n)
        metadata = email.parser.Parser().parsestr(zf.read(f"{dist_info}/METADATA").decode())
        third_party = zf.read(f"{dist_info}/licenses/THIRD_PARTY_LICENSES").decode()
        assert f"{dist_info}/licenses/LICENSE" in names
        cholmod = next(n for n in names if re.match(r"deformkit\.libs/libcholmod-.*\.so", n))
        zf.extract(cholmod, tmp_path)
    symbols = subprocess.run(["nm", "-D", "--defined-only", str(tmp_path / cholmod)], capture_output=True,
                             text=True, check=True).stdout
    assert re.search(r" T cholmod_l_super_numeric$", symbols, re.M), "the supernodal module is not shipped"
    expression = metadata["License-Expression"]
    assert "GPL-2.0-or-later" in expression.split(" AND ") and "MIT" in expression.split(" AND ")
    assert set(metadata.get_all("License-File")) >= {"LICENSE", "THIRD_PARTY_LICENSES"}
    for lib in (n for n in names if n.startswith("deformkit.libs/")):
        assert lib in third_party, lib
    for package in re.findall(r"^- (\S+): ", third_party, re.M):
        assert f"# {package} (" in third_party  # its copyright text follows the list

"""The shipped artefacts, built once per test session by the Makefile's own targets (the wheel
repaired by auditwheel, then both add-on zips), into dist/ as a user gets them."""
import glob
import pathlib
import subprocess
import time

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def shipped():
    """(wheel, extension zip, legacy zip, `auditwheel show` text). An incremental CMake build in
    build/dist-wheel: about a minute when the module is up to date, a full build otherwise."""
    start = time.monotonic()
    proc = subprocess.run(["make", "-s", "addon-zips"], cwd=REPO, capture_output=True, text=True, timeout=3000)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    print(f"make addon-zips: {time.monotonic() - start:.0f} s")
    (wheel,) = glob.glob(str(REPO / "dist" / "deformkit-*-manylinux_*.whl"))
    (extension,) = glob.glob(str(REPO / "dist" / "deformkit-*-extension.zip"))
    (legacy,) = glob.glob(str(REPO / "dist" / "deformkit_addon-*-legacy.zip"))
    show = (REPO / "dist" / "auditwheel-show.txt").read_text()
    return pathlib.Path(wheel), pathlib.Path(extension), pathlib.Path(legacy), show

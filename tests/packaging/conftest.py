"""The shipped artefacts, built once per test session by the Makefile's own targets (the wheel
repaired by auditwheel, then both add-on zips), into dist/ as a user gets them."""
import fcntl
import glob
import os
import pathlib
import subprocess
import time

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


def build_once_per_run():
    """`make addon-zips`, once per test run however many xdist workers ask: the others wait on the
    lock, then find the run's stamp. Two workers once built at the same time, one removing
    build/wheel-raw while the other read the wheel in it."""
    run = os.environ.get("PYTEST_XDIST_TESTRUNUID")  # the same in every worker of a run; None without xdist
    lock, stamp = REPO / "build" / ".addon-zips.lock", REPO / "build" / ".addon-zips.run"
    lock.parent.mkdir(exist_ok=True)
    with open(lock, "w") as held:
        fcntl.flock(held, fcntl.LOCK_EX)
        if run is not None and stamp.exists() and stamp.read_text() == run:
            return
        proc = subprocess.run(["make", "-s", "addon-zips"], cwd=REPO, capture_output=True, text=True, timeout=3000)
        assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
        if run is not None:
            stamp.write_text(run)


@pytest.fixture(scope="session")
def shipped():
    """(wheel, extension zip, legacy zip, `auditwheel show` text). An incremental CMake build in
    build/dist-wheel: about a minute when the module is up to date, a full build otherwise."""
    start = time.monotonic()
    build_once_per_run()
    print(f"make addon-zips (or waiting for the worker that ran it): {time.monotonic() - start:.0f} s")
    (wheel,) = glob.glob(str(REPO / "dist" / "deformkit-*-manylinux_*.whl"))
    (extension,) = glob.glob(str(REPO / "dist" / "deformkit-*-extension.zip"))
    (legacy,) = glob.glob(str(REPO / "dist" / "deformkit_addon-*-legacy.zip"))
    show = (REPO / "dist" / "auditwheel-show.txt").read_text()
    return pathlib.Path(wheel), pathlib.Path(extension), pathlib.Path(legacy), show

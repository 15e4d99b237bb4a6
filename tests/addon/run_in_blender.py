"""Run the add-on tests inside a Blender binary:
    blender -b --factory-startup --python-exit-code 1 -P tests/addon/run_in_blender.py -- LIBDIR [pytest args]
LIBDIR holds the deformkit package (or nothing, to test the missing-module path)."""
import os
import sys

argv = sys.argv[sys.argv.index("--") + 1:]
libdir, pytest_args = argv[0], argv[1:]
if libdir:
    sys.path.insert(0, libdir)
os.environ["DEFORMKIT_IN_BLENDER"] = "1"

import json  # noqa: E402

import pytest  # noqa: E402  (Debian's python3-pytest, in Blender's Python)


class SkipLog:
    """Each skipped test and its reason, written as JSON to the file DEFORMKIT_SKIP_LOG names
    (test_blender34.py lists them and refuses a reason it does not expect)."""

    def __init__(self):
        self.skips = []

    def pytest_runtest_logreport(self, report):
        if report.skipped and not hasattr(report, "wasxfail"):
            reason = report.longrepr[2] if isinstance(report.longrepr, tuple) else str(report.longrepr)
            self.skips.append({"test": report.nodeid, "reason": reason.removeprefix("Skipped: ")})


log = SkipLog()
status = pytest.main(["-p", "no:cacheprovider", *pytest_args], plugins=[log])
if os.environ.get("DEFORMKIT_SKIP_LOG"):
    with open(os.environ["DEFORMKIT_SKIP_LOG"], "w", encoding="utf-8") as fh:
        json.dump(log.skips, fh, indent=1)
sys.exit(status)

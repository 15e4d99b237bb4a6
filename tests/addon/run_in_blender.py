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

import pytest  # noqa: E402  (Debian's python3-pytest, in Blender's Python)

sys.exit(pytest.main(["-p", "no:cacheprovider", *pytest_args]))

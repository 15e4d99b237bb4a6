"""The one module that imports the compiled deformkit core.

Everything else asks this module for `dk`; when the core is missing the add-on still loads and
every panel and operator shows `IMPORT_ERROR` instead of a traceback.
"""
import os
import sys

BUILD_HINT = "run `make build` in the deformkit repository, or install the deformkit extension zip"

dk = None
IMPORT_ERROR = ""


def _load():
    global dk, IMPORT_ERROR
    here = os.path.dirname(os.path.abspath(__file__))
    bundled = os.path.join(here, "lib")  # the legacy add-on zip ships the module here
    if os.path.isdir(bundled) and bundled not in sys.path:
        sys.path.append(bundled)
    try:
        import deformkit
    except ImportError as exc:  # not built, or built for another Python
        dk = None
        IMPORT_ERROR = f"deformkit's compiled core could not be imported ({exc}): {BUILD_HINT}"
        print(f"deformkit add-on: {IMPORT_ERROR}", file=sys.stderr)
    else:
        dk = deformkit
        IMPORT_ERROR = ""


_load()


def available():
    return dk is not None

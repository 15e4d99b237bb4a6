"""The one module that imports the compiled deformkit core.

Everything else asks this module for `dk`; when the core is missing the add-on still loads and
every panel and operator shows `IMPORT_ERROR` instead of a traceback. The message says what the
packaged module was built for (build_target.json, written by the build and copied into the add-on
archives by scripts/package_addon.py) and what the running Blender is, so that a wrong platform or
Python reads as such.
"""
import importlib.util
import json
import os
import platform
import sys
import sysconfig

BUILD_HINT = "run `make build` in the deformkit repository, or install the deformkit extension zip"
MISMATCH_HINT = "install the deformkit package built for this Blender's Python and platform"
TARGET_FILE = "build_target.json"

dk = None
IMPORT_ERROR = ""
BUILT_FOR = None  # the packaged module's build_target.json, when one is found


def running_target():
    """The running interpreter, in build_target.json's terms."""
    return {"python": f"{sys.version_info.major}.{sys.version_info.minor}",
            "soabi": sysconfig.get_config_var("SOABI") or "",
            "system": platform.system().lower(), "machine": platform.machine(),
            "glibc": platform.libc_ver()[1]}


def describe(target, full_version=None):
    """'CPython 3.11 (cpython-311-x86_64-linux-gnu) on linux x86_64' and then the glibc: the wheel's
    manylinux tag for a package (it says the oldest glibc it loads on), the glibc of a running one."""
    text = f"CPython {full_version or target.get('python', '?')}"
    if target.get("soabi"):
        text += f" ({target['soabi']})"
    text += f" on {target.get('system', '?')} {target.get('machine', '?')}"
    if target.get("wheel_platform"):
        text += f" (wheel tag {target['wheel_platform']})"
    elif target.get("glibc"):
        text += f", glibc {target['glibc']}"
    return text


def _target_files(here):
    yield os.path.join(here, TARGET_FILE)  # the archives' copy, readable whatever went wrong
    yield os.path.join(here, "lib", "deformkit", TARGET_FILE)
    try:  # found, not imported: the package's __init__ is what fails
        spec = importlib.util.find_spec("deformkit")
    except (ImportError, ValueError):
        spec = None
    for folder in (spec.submodule_search_locations or []) if spec else []:
        yield os.path.join(folder, TARGET_FILE)


def built_for(here):
    for path in _target_files(here):
        try:
            with open(path) as fh:
                return json.load(fh)
        except (OSError, ValueError):
            continue
    return None


def import_error_message(exc, target, running):
    """What the panel says when `import deformkit` raised `exc`."""
    now = describe(running, platform.python_version())
    if target is None:
        return f"deformkit's compiled core could not be imported ({exc}); this Blender runs {now}: {BUILD_HINT}"
    mismatch = any(target.get(k) and target.get(k) != running.get(k) for k in ("python", "soabi", "system", "machine"))
    return (f"deformkit's compiled core could not be imported ({exc}). The package was built for "
            f"{describe(target)}; this Blender runs {now}: {MISMATCH_HINT if mismatch else BUILD_HINT}")


def _load():
    global dk, IMPORT_ERROR, BUILT_FOR
    here = os.path.dirname(os.path.abspath(__file__))
    bundled = os.path.join(here, "lib")  # the legacy add-on zip ships the module here
    if os.path.isdir(bundled) and bundled not in sys.path:
        sys.path.append(bundled)
    BUILT_FOR = built_for(here)
    try:
        import deformkit
    except ImportError as exc:  # not built, built for another Python or platform, a library missing
        dk = None
        IMPORT_ERROR = import_error_message(exc, BUILT_FOR, running_target())
        print(f"deformkit add-on: {IMPORT_ERROR}", file=sys.stderr)
    else:
        dk = deformkit
        IMPORT_ERROR = ""


_load()


def available():
    return dk is not None

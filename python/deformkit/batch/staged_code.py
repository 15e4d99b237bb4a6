"""The code a cluster run stages on shared storage, which every worker's Blender imports (the
add-on and the deformkit module), and its check on the worker (docs/batch.md, "Staged code").

The launcher hashes each file as it copies it into the staging folder (SHA-256 of the bytes it
read from its own install) and sends the hashes with every task, through the scheduler. Before
Blender starts, the worker reads each staged file once, checks its size and hash, and writes those
very bytes into a folder of its own (mode 0700, on the worker's machine) that Blender imports
from. So whoever can write in the shared folder cannot run code on the farm: a file changed,
removed or replaced after staging fails the task that finds it, naming the file; nothing else in
the shared folder is ever imported (no file that was not staged, no bytecode cache someone put
there), and there is no moment between the check and the import where the file could change.
Standard library only.
"""
import hashlib
import os
import shutil
import stat

from . import shared

SKIPPED_DIRS = ("__pycache__",)
SKIPPED_SUFFIXES = (".pyc",)


class StagedFileAltered(Exception):
    """A staged file that is not the one the launcher staged; the message names it."""


def stage_tree(source, staging, relative):
    """Copy the files of `source` into `staging`/`relative` (following links, without bytecode
    caches) and return {path relative to `staging`: {"bytes": n, "sha256": hex}} of the bytes
    read from `source`, the ones written."""
    files = {}
    for folder, dirs, names in os.walk(source, followlinks=True):
        dirs[:] = sorted(d for d in dirs if d not in SKIPPED_DIRS)
        inside = os.path.relpath(folder, source)
        os.makedirs(os.path.join(staging, relative, inside), exist_ok=True)
        for name in sorted(n for n in names if not n.endswith(SKIPPED_SUFFIXES)):
            rel = os.path.normpath(os.path.join(relative, inside, name))
            with open(os.path.join(folder, name), "rb") as fh:
                data = fh.read()
            target = os.path.join(staging, rel)
            with open(target, "wb") as fh:
                fh.write(data)
            shutil.copymode(os.path.join(folder, name), target)
            files[rel] = {"bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}
    return files


def safe_relative(rel):
    """True for a path that stays inside the folder it is relative to."""
    return (isinstance(rel, str) and rel != "" and not os.path.isabs(rel) and os.path.normpath(rel) == rel
            and ".." not in rel.split(os.sep) and "\x00" not in rel)


def verified_copy(staged, into):
    """Each file of `staged` ({"folder", "files"}, as the launcher sent it) read once from the
    staging folder, checked against its size and SHA-256 and written under `into`;
    StagedFileAltered, naming the first file that differs, is missing or is not a regular file."""
    folder = staged["folder"]
    for rel, expected in sorted(staged["files"].items()):
        path = os.path.join(folder, rel)
        try:
            data = shared.read_regular_file(path, expected["bytes"])
        except FileNotFoundError:
            raise StagedFileAltered(f"the staged file {path} is missing") from None
        except shared.FileRefused as exc:
            raise StagedFileAltered(f"the staged file {path} {exc} (the launcher staged "
                                    f"{expected['bytes']} bytes)") from None
        except OSError as exc:
            raise StagedFileAltered(f"the staged file {path} cannot be read: {exc.strerror or exc}") from None
        found = hashlib.sha256(data).hexdigest()
        if found != expected["sha256"]:
            raise StagedFileAltered(f"the staged file {path} is not the one the launcher staged (SHA-256 {found}, "
                                    f"expected {expected['sha256']})")
        target = os.path.join(into, rel)
        os.makedirs(os.path.dirname(target), mode=0o700, exist_ok=True)
        fd = os.open(target, os.O_WRONLY | os.O_CREAT | os.O_EXCL, stat.S_IRUSR | stat.S_IWUSR)
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)


def private_paths(sys_paths, staged, into):
    """The job's sys.path entries (in the staging folder) mapped to the same places under `into`."""
    mapped = []
    for path in sys_paths:
        rel = os.path.relpath(path, staged["folder"])
        if not safe_relative(rel):
            raise StagedFileAltered(f"the job's sys.path entry {path} is outside the staging folder "
                                    f"{staged['folder']}")
        mapped.append(os.path.join(into, rel))
    return mapped

"""What the batch launcher and its Blender workers share, without bpy: atomic JSON files, the
structured record of an exception, and the names that tie temporaries to the run that made them.
Standard library only: Blender's worker loads this file by its path before anything else, so that
even a failure to import the add-on or the compiled core leaves a result file."""
import ctypes
import json
import math
import os
import secrets
import signal
import stat
import traceback

STAGING_PREFIX = "deformkit-batch-run-"  # + "<launcher pid>-<random>": the system temp folder's
TEMP_MARK = ".deformkit-"                # OUTPUT + ".deformkit-<run token>.tmp.blend"
RESULT_LINE = "DEFORMKIT-BATCH-RESULT "  # a worker that cannot write its result file prints it
PR_SET_PDEATHSIG = 1
# Job, result and record files: a job holds a recipe of at most 4 MiB (cli.RECIPE_LIMIT), re-indented.
STATE_FILE_LIMIT = 64 * 1024 * 1024
NOT_REGULAR = {stat.S_IFDIR: "a folder", stat.S_IFIFO: "a FIFO (named pipe)", stat.S_IFCHR: "a character device",
               stat.S_IFBLK: "a block device", stat.S_IFSOCK: "a socket"}


class FileRefused(ValueError):
    """A file the batch does not read: not a regular file, or larger than its limit. The message
    says what it is, after the path."""


def _refuse_unless_regular(mode):
    kind = NOT_REGULAR.get(stat.S_IFMT(mode))
    if kind is not None:
        raise FileRefused(f"is {kind}, not a regular file")


def read_regular_file(path, limit):
    """The bytes of `path`, which must be a regular file (after symbolic links) of at most `limit`
    bytes; else FileRefused (or the OSError of a missing or unreadable file). Nothing here can
    block or read without bound: the kind is checked before opening, the open is non-blocking (a
    FIFO put there meanwhile cannot hang it) and checked again on what was opened, and at most
    limit + 1 bytes are read (a file that grows while it is read is refused too)."""
    _refuse_unless_regular(os.stat(path).st_mode)
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0))
    try:
        opened = os.fstat(fd)
        _refuse_unless_regular(opened.st_mode)
        if opened.st_size > limit:
            raise FileRefused(f"is {opened.st_size} bytes, more than the {limit} bytes allowed")
        chunks, size = [], 0
        while size <= limit:
            chunk = os.read(fd, min(1 << 20, limit + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
        if size > limit:
            raise FileRefused(f"is more than the {limit} bytes allowed (it grew while it was read)")
        return b"".join(chunks)
    finally:
        os.close(fd)


def read_json_file(path, limit):
    """The JSON value in `path` (a regular file of at most `limit` bytes, UTF-8): ValueError for
    what is not, OSError for what cannot be read."""
    return json.loads(read_regular_file(path, limit).decode("utf-8"))


def new_run_token():
    """Unique to this run: the pid tells the next run whether its owner is still alive, the random
    part keeps two runs apart even when a pid is reused."""
    return f"{os.getpid()}-{secrets.token_hex(4)}"


def output_temporary(output, token):
    return f"{output}{TEMP_MARK}{token}.tmp.blend"


def run_temporaries(output, token):
    """The files a run's worker may leave beside `output`: its temporary and Blender's own
    `<file>@` (Blender writes there first, then renames)."""
    tmp = output_temporary(output, token)
    return [tmp, tmp + "@"]


def finite(data):
    """`data` with non-finite floats as None: the report stays standard JSON."""
    if isinstance(data, float):
        return data if math.isfinite(data) else None
    if isinstance(data, dict):
        return {k: finite(v) for k, v in data.items()}
    if isinstance(data, (list, tuple)):
        return [finite(v) for v in data]
    return data


def write_json_atomically(path, data, token):
    """Write `data` to a name unique to this run, then rename it over `path`: a reader (or a run
    killed half-way) sees the previous version or the new one, never a torn file."""
    tmp = f"{path}{TEMP_MARK}{token}.tmp"
    try:
        with open(tmp, "w", encoding="utf-8") as fh:
            json.dump(finite(data), fh, indent=1, allow_nan=False, default=str)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def exception_record(exc, stage, obj=None, entry=None):
    """The report's view of an exception: its type, its message, where the worker was."""
    frames = traceback.extract_tb(exc.__traceback__)[-3:]
    return {"type": type(exc).__name__, "message": str(exc).strip() or repr(exc), "stage": stage,
            "object": obj, "entry": entry,
            "where": [f"{os.path.basename(f.filename)}:{f.lineno} in {f.name}" for f in frames]}


def file_row(src, dst, status="failed", exception=None, objects=None, warnings=None, **extra):
    """One file's row of report.json, as the launcher and Blender's worker both make it: the
    input and output, the status ("pending", "failed" or "ok"), the one-line error of
    `exception` (a record as exception_record gives) and the record itself when there is one,
    the objects and the warnings, then `extra` (seconds, python_prefix, ...), in this order."""
    row = {"file": src, "output": dst, "status": status,
           "error": "" if exception is None else describe_failure(exception)}
    if exception is not None:
        row["exception"] = exception
    row.update(objects=[] if objects is None else objects, warnings=[] if warnings is None else warnings, **extra)
    return row


def describe_failure(error):
    """One line for the console and the report's "error": the message, then where it happened."""
    where = ", ".join(f"{k} {error[k]}" for k in ("object", "entry") if error.get(k) is not None)
    kind = "" if error["type"] in ("BatchError", "InputError") else f"{error['type']}: "
    return f"{kind}{error['message']}" + (f" ({where})" if where else "")


def prepare_worker(parent_pid):
    """Under a file-size limit (ulimit -f) a write must fail with EFBIG, which the worker reports
    as it reports a full disk, rather than SIGXFSZ killing Blender without a word. And ask Linux
    to kill this process when its parent dies (a SIGKILLed launcher must not leave Blenders
    running); exit at once if the parent is already gone."""
    if hasattr(signal, "SIGXFSZ"):
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    if parent_pid is None:  # started by hand, not by a launcher: nothing to die with
        return
    try:
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    except (OSError, AttributeError):
        return
    if os.getppid() != parent_pid:
        os._exit(1)

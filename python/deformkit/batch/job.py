"""One file's job: everything the Blender worker needs, as a value that pickles (for any executor)
and round-trips through one JSON job file (for Blender: `blender ... -- JOB.json`, no positional
options). Standard library only: Blender's worker loads this file by its path.
"""
from __future__ import annotations

import dataclasses
import json
import math
import os
from typing import Any

FORMAT = "deformkit-batch-job/1"  # the job file's "format": a worker refuses a file of another layout


class JobError(ValueError):
    """A job that does not match the schema; the message names the field."""


def _text(name, value):
    if not isinstance(value, str) or not value or "\x00" in value:
        raise JobError(f"job field '{name}': expected a non-empty string, got {value!r}")
    return value


def _texts(name, value):
    if not isinstance(value, (list, tuple)):
        raise JobError(f"job field '{name}': expected a list of strings, got {value!r}")
    for i, item in enumerate(value):
        _text(f"{name}[{i}]", item)
    return tuple(value)


def _flag(name, value):
    if not isinstance(value, bool):
        raise JobError(f"job field '{name}': expected true or false, got {value!r}")
    return value


def _whole(name, value, least, optional=False):
    if optional and value is None:
        return value
    if not isinstance(value, int) or isinstance(value, bool) or value < least:
        raise JobError(f"job field '{name}': expected a whole number >= {least}"
                       f"{' or null' if optional else ''}, got {value!r}")
    return value


def _seconds(name, value):
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value) or value <= 0:
        raise JobError(f"job field '{name}': expected a finite number of seconds above 0, got {value!r}")
    return float(value)


def _staged(name, value):
    """None, or {"folder": the staging folder, "files": {relative path: {"bytes", "sha256"}}}."""
    if value is None:
        return value
    if not isinstance(value, dict) or set(value) != {"folder", "files"} or not isinstance(value["files"], dict):
        raise JobError(f"job field '{name}': expected null or a table of 'folder' and 'files', got {value!r}")
    _text(f"{name}.folder", value["folder"])
    for rel, entry in value["files"].items():
        inside = isinstance(rel, str) and rel and not os.path.isabs(rel) and os.path.normpath(rel) == rel
        if not inside or ".." in rel.split(os.sep):
            raise JobError(f"job field '{name}.files': expected paths inside the staging folder, got {rel!r}")
        good = isinstance(entry, dict) and set(entry) == {"bytes", "sha256"}
        if good:
            _whole(f"{name}.files[{rel!r}].bytes", entry["bytes"], 0)
            digest = entry["sha256"]
            good = isinstance(digest, str) and len(digest) == 64 and all(c in "0123456789abcdef" for c in digest)
        if not good:
            raise JobError(f"job field '{name}.files[{rel!r}]': expected {{'bytes': n, 'sha256': 64 hex digits}}, "
                           f"got {entry!r}")
    return value


def _recipe(name, value):
    if value is not None and not isinstance(value, dict):
        raise JobError(f"job field '{name}': expected a recipe table or null, got {value!r}")
    return value


@dataclasses.dataclass(frozen=True)
class BatchJob:
    """One input file of a run. The recipe is the one the launcher checked (None: re-evaluate the
    stacks saved in the file); `work` is the run's staging folder, where the job, result and
    preview files of this job live under its `index`."""

    index: int
    input: str
    output: str
    work: str
    blender: str
    token: str
    sys_paths: tuple[str, ...] = ()  # put first on Blender's sys.path: the add-on and the module
    recipe: dict[str, Any] | None = dataclasses.field(default=None, hash=False)
    preview: bool = False
    smoothness: bool = False
    timeout: float = 600.0
    never_write: tuple[str, ...] = ()  # the run's inputs: no output may be one of them
    parent_pid: int | None = None  # the process that starts Blender (set by run_job, where it runs)
    # On a cluster: the staged add-on and module, hashed by the launcher (staged_code.py).
    staged: dict[str, Any] | None = dataclasses.field(default=None, hash=False)

    def __post_init__(self):
        for field in dataclasses.fields(self):
            object.__setattr__(self, field.name, _CHECKS[field.name](field.name, getattr(self, field.name)))

    @property
    def job_path(self):
        return os.path.join(self.work, f"{self.index}.job.json")

    @property
    def result_path(self):
        return os.path.join(self.work, f"{self.index}.json")

    @property
    def preview_path(self):
        """Where the worker leaves the positions for the picture (.npz), or None without --preview."""
        return os.path.join(self.work, f"{self.index}.npz") if self.preview else None

    def to_dict(self):
        data = {"format": FORMAT, **dataclasses.asdict(self)}
        return {k: list(v) if isinstance(v, tuple) else v for k, v in data.items()}

    @classmethod
    def from_dict(cls, data):
        if not isinstance(data, dict):
            raise JobError(f"job: expected a table, got {type(data).__name__}")
        if data.get("format") != FORMAT:
            raise JobError(f"job field 'format': expected {FORMAT!r}, got {data.get('format')!r}")
        fields = {f.name: f for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - set(fields) - {"format"})
        if unknown:
            raise JobError(f"job field '{unknown[0]}': not a field of a job; fields: {', '.join(fields)}")
        missing = [name for name, f in fields.items() if name not in data and f.default is dataclasses.MISSING
                   and f.default_factory is dataclasses.MISSING]
        if missing:
            raise JobError(f"job field '{missing[0]}': missing")
        return cls(**{k: v for k, v in data.items() if k != "format"})

    def to_json(self):
        return json.dumps(self.to_dict(), indent=1, allow_nan=False)

    @classmethod
    def from_json(cls, text):
        try:
            data = json.loads(text)
        except ValueError as exc:
            raise JobError(f"job: not valid JSON: {exc}") from None
        return cls.from_dict(data)


_CHECKS = {
    "index": lambda n, v: _whole(n, v, 0), "input": _text, "output": _text, "work": _text, "blender": _text,
    "token": _text, "sys_paths": _texts, "recipe": _recipe, "preview": _flag, "smoothness": _flag,
    "timeout": _seconds, "never_write": _texts, "parent_pid": lambda n, v: _whole(n, v, 1, optional=True),
    "staged": _staged,
}

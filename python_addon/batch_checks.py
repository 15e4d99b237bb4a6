"""What a batch worker notices about a file besides errors: Blender's own messages while it reads
the file, and the signs of a damaged file that Blender reads without a word.

A .blend has no checksums: bytes overwritten inside a data block load silently. Blender's
Mesh.validate finds what breaks a mesh's invariants (indices out of range, non-finite vertex
coordinates, bad weights); random bytes read as 32-bit floats also give non-finite or absurdly
large values (a random exponent is above 1e30 one time in ten), which no real UV map or
attribute holds. Each finding becomes one warning line in the report; the file's status stays
"ok" when everything else worked, since the output is what Blender itself would make of it.
"""
import contextlib
import ctypes
import os
import sys
import tempfile

import numpy as np

import bpy

ABSURD = 1e30  # larger magnitudes in coordinates, UVs or float attributes: damaged data
ROUTINE = ("Read blend:",)  # what Blender prints on every successful read


def _flush_c_stdio():
    try:
        ctypes.CDLL(None).fflush(None)  # Blender's own printf output is buffered in C stdio
    except (OSError, AttributeError):
        pass


@contextlib.contextmanager
def captured_output():
    """Yields a list that receives the lines Blender (C and Python) writes to stdout and stderr
    inside the block. The lines go to a temporary file, not a pipe (a pipe fills and blocks); if
    even that cannot be made (a full disk), nothing is captured."""
    lines = []
    sys.stdout.flush()
    sys.stderr.flush()
    _flush_c_stdio()
    try:
        sink = tempfile.TemporaryFile()
    except OSError:
        yield lines
        return
    saved = os.dup(1), os.dup(2)
    try:
        os.dup2(sink.fileno(), 1)
        os.dup2(sink.fileno(), 2)
        yield lines
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        _flush_c_stdio()
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        os.close(saved[0])
        os.close(saved[1])
        sink.seek(0)
        lines += [line.strip() for line in sink.read().decode("utf-8", "replace").splitlines() if line.strip()]
        sink.close()
        for line in lines:  # still shown on the console, after the fact
            print(line, flush=True)


def reading_messages(lines):
    return [f"Blender while reading the file: {line}" for line in lines if not line.startswith(ROUTINE)]


def _values(collection, attribute, width, count):
    values = np.empty(count * width, np.float32)
    collection.foreach_get(attribute, values)
    return values


def _implausible(values):
    return int(np.count_nonzero(~np.isfinite(values) | (np.abs(values) > ABSURD)))


def _float_layers(mesh):
    """(label, collection, attribute, width, count) of every float layer worth checking."""
    yield "vertex coordinates", mesh.vertices, "co", 3, len(mesh.vertices)
    for uv in mesh.uv_layers:
        yield f"UV map '{uv.name}'", uv.data, "uv", 2, len(uv.data)
    widths = {"FLOAT": ("value", 1), "FLOAT2": ("vector", 2), "FLOAT_VECTOR": ("vector", 3),
              "FLOAT_COLOR": ("color", 4)}
    for attr in mesh.attributes:
        if attr.data_type in widths and not attr.name.startswith(".") and attr.name != "position":
            yield f"attribute '{attr.name}'", attr.data, *widths[attr.data_type], len(attr.data)


def mesh_warnings(mesh):
    """Signs of damage in one mesh: Mesh.validate's findings (on a copy: the file is not
    changed) and float layers with non-finite or absurd values."""
    found = []
    copy = mesh.copy()
    try:
        with captured_output() as lines:
            changed = copy.validate(verbose=True)
    finally:
        bpy.data.meshes.remove(copy)
    if changed:
        details = [line.split("\t")[-1].strip() for line in lines if line][:5]  # drop the source location
        found.append(f"mesh '{mesh.name}': Blender's Mesh.validate finds invalid data (the file may be damaged)"
                     + (": " + " | ".join(details) if details else ""))
    for label, collection, attribute, width, count in _float_layers(mesh):
        bad = _implausible(_values(collection, attribute, width, count)) if count else 0
        if bad:
            found.append(f"mesh '{mesh.name}': {label} has {bad} non-finite or absurd (> {ABSURD:g}) values "
                         "(the file may be damaged)")
    return found


def damage_warnings(objects):
    meshes = list(dict.fromkeys(o.data for o in objects if o.type == "MESH"))
    return [warning for mesh in meshes for warning in mesh_warnings(mesh)]

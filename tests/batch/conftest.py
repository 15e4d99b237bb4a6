"""A fake Blender (fake_blender.py behind a shell wrapper, called exactly as Blender is) and jobs
for it, so that run_job and the executors are tested without starting Blender."""
import pathlib
import sys

import pytest

from deformkit.batch.job import BatchJob

HERE = pathlib.Path(__file__).resolve().parent


@pytest.fixture
def fake_blender(tmp_path):
    path = tmp_path / "bin" / "blender"
    path.parent.mkdir()
    path.write_text(f'#!/bin/sh\nexec "{sys.executable}" "{HERE / "fake_blender.py"}" "$@"\n')
    path.chmod(0o755)
    return str(path)


@pytest.fixture
def make_job(tmp_path, fake_blender):
    """make_job(mode, index=0, **fields): a job whose input asks the fake Blender for `mode`."""
    work, inputs, out = tmp_path / "work", tmp_path / "in", tmp_path / "out"
    for folder in (work, inputs, out):
        folder.mkdir(exist_ok=True)

    def make(mode, index=0, **fields):
        src = inputs / f"{index}_{mode}.blend"
        src.write_bytes(b"BLENDER" + mode.encode())
        values = dict(index=index, input=str(src), output=str(out / src.name), work=str(work), blender=fake_blender,
                      token="1-0123abcd", timeout=60.0, never_write=(str(src),))
        return BatchJob(**{**values, **fields})
    return make

"""The Shape Keys mode: each shape key of the source (its key block's points as a pose) becomes a
shape key of the target, with the source key's settings and driver."""
import time

import numpy as np

from .correspondence import DEFAULT_PREFIX
from .keys import (block_points_of, copy_driver, copy_key_settings, ensure_basis, output_block, source_key_blocks,
                   write_points)
from .similarity import applied
from .system import report_progress, require_mesh, result_of, transfer_system, transferred


def transfer_shape_keys(source, target, replace=False, marker_prefix=DEFAULT_PREFIX, progress=None):
    """One shape key on the target per shape key of the source (its key block's points as a pose),
    with the source key's name, slider range, value, mute, vertex group, relative key and driver.
    progress(done, total), if given, is called as the work goes on. EntryError on a problem,
    before anything is written."""
    t0 = time.perf_counter()
    require_mesh(source, "source")
    require_mesh(target, "target")
    key, blocks = source_key_blocks(source)
    total = len(blocks) + 2
    system = transfer_system(source, target, marker_prefix)
    report_progress(progress, 1, total)
    count = len(source.data.vertices)
    poses = np.stack([applied(system.align, block_points_of(b, count)) for b in blocks])
    out = transferred(system.dt, poses, [f"shape key '{b.name}'" for b in blocks], progress, 1, total)
    if system.store is not None:
        system.store()
    ensure_basis(target)
    names = {}
    for block, points in zip(blocks, out):
        written = output_block(target, block.name, replace)
        write_points(written, points)
        copy_key_settings(block, written, target)
        names[block.name] = written.name
    tkey = target.data.shape_keys
    for block in blocks:
        relative = block.relative_key
        partner = tkey.reference_key if relative is None or relative == key.reference_key else \
            tkey.key_blocks.get(names.get(relative.name, relative.name))
        tkey.key_blocks[names[block.name]].relative_key = partner if partner is not None else tkey.reference_key
    for block in blocks:
        copy_driver(source, target, block.name, names[block.name])
    target.data.update()
    report_progress(progress, total, total)
    return result_of(target, list(names.values()), system, t0)

"""The Animation mode: the source's evaluated deformation (e.g. from an Armature) at each frame of
a range becomes a shape key of the target ("Transfer 0012"), keyed to play on its frame."""
import time

import bpy
import numpy as np

from .. import meshdata
from ..errors import EntryError
from .correspondence import DEFAULT_PREFIX
from .keys import block_path, ensure_basis, fcurves, output_block, write_points
from .similarity import applied
from .system import report_progress, require_mesh, result_of, transfer_system, transferred

FRAME_KEY = "Transfer {:04d}"


def evaluated_poses(source, scene, frames, progress=None, total=1):
    """The source's evaluated vertex positions (its modifiers, e.g. an Armature, and shape keys) at
    each frame, float64 (k, n, 3) in its own space; the scene's frame is put back."""
    count = len(source.data.vertices)
    kept = scene.frame_current, scene.frame_subframe
    poses = np.empty((len(frames), count, 3))
    try:
        for i, frame in enumerate(frames):
            scene.frame_set(frame)
            evaluated = source.evaluated_get(bpy.context.evaluated_depsgraph_get())
            mesh = evaluated.to_mesh()
            try:
                if len(mesh.vertices) != count:
                    raise EntryError(f"the source '{source.name}' has {len(mesh.vertices)} vertices at frame {frame} "
                                     f"after its modifiers, {count} at rest: only deforming modifiers can be "
                                     "transferred")
                poses[i] = meshdata.base_positions(mesh)
            finally:
                evaluated.to_mesh_clear()
            report_progress(progress, i + 1, total)
    finally:
        scene.frame_set(kept[0], subframe=kept[1])
    return poses


def keyed_to_its_frame(target, block, frame):
    """The baked key plays on its frame only: 0 on the frames either side, 1 on its own, linear in
    between (a subframe blends the two neighbouring frames' keys)."""
    for f, value in ((frame - 1, 0.0), (frame, 1.0), (frame + 1, 0.0)):
        block.value = value
        block.keyframe_insert("value", frame=f)
    curves = fcurves(target.data.shape_keys.animation_data)
    curve = None if curves is None else curves.find(block_path(block.name) + ".value")
    if curve is not None:
        for point in curve.keyframe_points:
            if frame - 1 <= point.co[0] <= frame + 1:
                point.interpolation = "LINEAR"
    block.value = 0.0


def transfer_animation(source, target, frame_start, frame_end, scene=None, replace=False,
                       marker_prefix=DEFAULT_PREFIX, progress=None):
    """One shape key on the target per frame of [frame_start, frame_end], named "Transfer 0012",
    the source's evaluated deformation at that frame transferred, keyframed to 1 on its frame and
    0 on the frames either side. EntryError on a problem, before anything is written."""
    t0 = time.perf_counter()
    scene = scene or bpy.context.scene
    require_mesh(source, "source")
    require_mesh(target, "target")
    if frame_end < frame_start:
        raise EntryError(f"frame_end: {frame_end} is before frame_start {frame_start}")
    frames = list(range(frame_start, frame_end + 1))
    total = 2 * len(frames) + 1
    system = transfer_system(source, target, marker_prefix)
    poses = applied(system.align, evaluated_poses(source, scene, frames, progress, total).reshape(-1, 3)).reshape(
        len(frames), -1, 3)
    out = transferred(system.dt, poses, [f"frame {f}" for f in frames], progress, len(frames), total)
    if system.store is not None:
        system.store()
    ensure_basis(target)
    names = []
    for frame, points in zip(frames, out):
        block = output_block(target, FRAME_KEY.format(frame), replace)
        write_points(block, points)
        block.relative_key = target.data.shape_keys.reference_key
        keyed_to_its_frame(target, block, frame)
        names.append(block.name)
    target.data.update()
    report_progress(progress, total, total)
    return result_of(target, names, system, t0)

"""The shape-key mix that Blender's modifiers deform, so the entries deform the same points.

Blender puts the shape keys before every modifier (a virtual modifier at the top of the stack,
blenkernel/intern/key.cc: BKE_key_evaluate_object_ex). This module computes that mix from the key
blocks, in float32 and in Blender's order of operations (see docs/blender_addon.md, "Shape keys"):

* relative keys: the reference key, then for each key block that is not muted, has a value other
  than 0 and as many points, in order: out -= w * (relative_key - block), with w = value, times
  the block's vertex-group weight where it has a group;
* "Shape Key Lock" (the pin, Object.show_only_shape_key): the active block alone at full value
  (through its vertex group), the reference key when the active block is muted;
* absolute keys: the blocks around Evaluation Time / 100 (each block's frame), blended with the
  interpolation of the block at or before it (linear, cardinal, Catmull-Rom or B-spline weights of
  four blocks; where two types meet, both, interpolated).
In Edit Mode the mix applies only with "Shape Key Edit Mode" (use_shape_key_edit_mode) on, and
only for relative keys, as in Blender; the active block's points are then the edit mesh's.
"""
import numpy as np

from .errors import EntryError

_F = np.float32


def block_points(block, count):
    co = np.empty(count * 3, _F)
    block.data.foreach_get("co", co)
    return co.reshape(-1, 3)


def _curve_weights(t, kind):
    """key_curve_position_weights: the four blocks' weights at t in [0, 1]."""
    t = _F(t)
    if kind == "KEY_LINEAR":
        return [_F(0), _F(1) - t, t, _F(0)]
    t2, t3 = t * t, t * t * t
    if kind == "KEY_BSPLINE":
        return [_F(-0.16666666) * t3 + _F(0.5) * t2 - _F(0.5) * t + _F(0.16666666),
                _F(0.5) * t3 - t2 + _F(0.66666666),
                _F(-0.5) * t3 + _F(0.5) * t2 + _F(0.5) * t + _F(0.16666666),
                _F(0.16666666) * t3]
    fc = _F(0.71) if kind == "KEY_CARDINAL" else _F(0.5)  # Catmull-Rom: the cardinal spline at 0.5
    return [-fc * t3 + _F(2) * fc * t2 - fc * t,
            (_F(2) - fc) * t3 + (fc - _F(3)) * t2 + _F(1),
            (fc - _F(2)) * t3 + (_F(3) - _F(2) * fc) * t2 + fc * t,
            fc * t3 - fc * t2]


def absolute_blocks(positions, kinds, time):
    """(indices of four blocks, their weights), or (index, None) where one block is the result:
    Blender's setkeys, not cyclic. positions: each block's position (frame / 100, as
    stored), in list order; time: Evaluation Time / 100."""
    last = len(positions) - 1
    fac = min(max(time, positions[0]), positions[last])
    if last == 0:
        return 0, None
    k = [0, 0, 1, min(2, last)]
    t = [positions[0], positions[0], positions[1], positions[k[3]]]
    nxt = k[3]
    while t[2] < fac:
        if nxt == last:
            if t[2] == t[3]:
                break
        else:
            nxt += 1
        k = [k[1], k[2], k[3], nxt]
        t = [t[1], t[2], t[3], positions[nxt]]
    bspline = "KEY_BSPLINE" in (kinds[k[1]], kinds[k[2]])
    if not bspline:
        if fac <= t[1]:
            return k[1], None
        if fac >= t[2]:
            return k[2], None
    elif fac > t[2]:
        fac, k[3], t[3] = t[2], k[2], t[2]
    d = t[2] - t[1]
    if d == 0:
        if not bspline:
            return k[2], None
    else:
        d = (_F(fac) - _F(t[1])) / _F(d)
    w = _curve_weights(d, kinds[k[1]])
    if kinds[k[1]] != kinds[k[2]]:
        other = _curve_weights(d, kinds[k[2]])
        w = [(_F(1) - _F(d)) * a + _F(d) * b for a, b in zip(w, other)]  # interp_v4_v4v4
    return k, w


def mix(obj, weights_of, edit_points=None):
    """The points Blender's first modifier gets from obj's shape keys, float32 (n, 3).

    weights_of(name): the vertex group's weights (float, per vertex), or None when there is no such
    group (Blender then applies the block in full). edit_points: the edit mesh's points in Edit Mode
    (then the active block's points are these)."""
    mesh = obj.data
    key = mesh.shape_keys
    blocks = list(key.key_blocks)
    count = len(mesh.vertices) if edit_points is None else len(edit_points)
    active = obj.active_shape_key_index if 0 <= obj.active_shape_key_index < len(blocks) else None
    cache = {}

    def points(i, as_stored=False):
        if edit_points is not None and i == active and not as_stored:
            return edit_points
        if i not in cache:
            if len(blocks[i].data) != count:
                return None
            cache[i] = block_points(blocks[i], count)
        return cache[i]

    def group(block):
        weights = weights_of(block.vertex_group) if block.vertex_group else None
        return None if weights is None else np.asarray(weights, _F)

    if edit_points is not None and not (obj.use_shape_key_edit_mode and key.use_relative):
        return np.array(edit_points, _F)
    reference = blocks.index(key.reference_key)
    if points(reference) is None:  # vertices added in Edit Mode: the blocks are written on leaving it
        return np.array(edit_points, _F)
    if obj.show_only_shape_key:
        i = active if active is not None else 0
        if blocks[i].mute:
            i = reference
        ref, own, w = points(reference), points(i), group(blocks[i])
        if w is None:
            return own.copy()
        out = ref.copy()
        moved = w != 0
        out[moved] -= w[moved, None] * (ref[moved] - own[moved])
        return out
    if not key.use_relative:
        kinds = [b.interpolation for b in blocks]
        k, w = absolute_blocks([_F(b.frame) / _F(100) for b in blocks], kinds, _F(key.eval_time) / _F(100))
        if w is None:
            return points(k).copy()
        if any(points(i) is None for i in k):
            raise EntryError("the absolute shape keys have another vertex count than the mesh")
        return (w[0] * points(k[0]) + w[1] * points(k[1]) + w[2] * points(k[2]) + w[3] * points(k[3])).astype(_F)
    out = points(reference).copy()
    for i, block in enumerate(blocks):
        value = _F(block.value)
        if i == reference or block.mute or value == 0 or points(i) is None:
            continue
        relative = blocks.index(block.relative_key) if block.relative_key is not None else reference
        w = group(block)
        factor = value if w is None else (w * value)[:, None]
        # Blender reads the relative key's stored points, even for the active key in Edit Mode.
        out -= factor * (points(relative, as_stored=True) - points(i))
    return out

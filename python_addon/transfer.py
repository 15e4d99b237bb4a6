"""Transfer Deformation (issue 17): a source mesh's shape keys, or its animation baked frame by
frame, carried onto a target mesh as shape keys by deformation transfer (dk.DeformationTransfer,
docs/transfer.md). Plain functions, called by the operator, the batch and the tests alike; the
operator class only gathers its settings and reports.

* Same vertex count and faces: direct (vertex i of one is vertex i of the other).
* Otherwise marker pairs: vertex groups named alike on both meshes with a common prefix ("dt_" by
  default); each group's marker is its member of highest weight (the first of equals). The
  correspondence (Sumner and Popovic 2004, section 5) is computed once and stored on the target
  (ID property STORE) with a fingerprint of both rests, faces and the markers, so a later run
  reuses it and an edit of either mesh recomputes it.
* Both rests are brought into one frame first (see docs/blender_addon.md, "Transfer Deformation"):
  the source is placed on the target by the best-fitting similarity (Umeyama 1991), since a
  deformation gradient is carried in the frame it was measured in.
Nothing is written before every pose has been transferred: a refusal leaves the target as it was.
The target's base mesh (its vertex positions) is never written.
"""
import hashlib
import re
import time
from collections import namedtuple

import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, IntProperty, StringProperty

from . import meshdata, native
from .errors import EntryError

STORE = "deformkit_transfer"  # the target's ID property group: the stored correspondence
DEFAULT_PREFIX = "dt_"
# A similarity needs three points off one line; fewer markers leave the source's turn undetermined.
MIN_MARKERS = 3
CHUNK = 32  # poses per dk.DeformationTransfer.transfer call: (k, n, 3) float64 arrays stay bounded
FRAME_KEY = "Transfer {:04d}"

MeshData = namedtuple("MeshData", "rest polygons topology")  # rest: float64 (n, 3), object space
Markers = namedtuple("Markers", "names source target")  # group names, source and target vertex indices
Similarity = namedtuple("Similarity", "scale rotation translation")
# keys: the target's shape-key names written, in source order; direct: same connectivity;
# reused_correspondence: a stored correspondence was used; unmatched, distance: the
# correspondence's quality (None when direct); seconds: the whole run.
Result = namedtuple("Result", "keys direct reused_correspondence unmatched distance seconds")


def _report(progress, done, total):
    if progress is not None:
        progress(done, total)


def require_mesh(obj, role):
    if obj is None:
        raise EntryError(f"no {role} object: select the source mesh and make the target active")
    if obj.type != "MESH":
        raise EntryError(f"the {role} '{obj.name}' is not a mesh object")
    if obj.mode == "EDIT":
        raise EntryError(f"the {role} '{obj.name}' is in Edit Mode: leave it first (its shape keys are "
                         "written on leaving)")
    if len(obj.data.vertices) == 0 or len(obj.data.polygons) == 0:
        raise EntryError(f"the {role} '{obj.name}' has no faces")


def rest_points(obj):
    """The rest the poses are measured from: the reference key (Basis) where there are shape keys,
    else the vertices; float64 (n, 3) in the object's space."""
    key = obj.data.shape_keys
    if key is not None and key.reference_key is not None:
        from .shapekeys import block_points
        return block_points(key.reference_key, len(obj.data.vertices)).astype(np.float64)
    return meshdata.base_positions(obj.data).astype(np.float64)


def mesh_data(obj):
    topo = meshdata.topology(obj.data)
    return MeshData(rest_points(obj), meshdata.polygons(topo), topo)


def ordered_corners(topo):
    order = meshdata.corner_order(topo)
    return topo.corners if order is None else topo.corners[order]


def same_connectivity(source, target):
    a, b = source.topology, target.topology
    return (a.vertices == b.vertices and a.faces == b.faces and np.array_equal(a.totals, b.totals)
            and np.array_equal(ordered_corners(a), ordered_corners(b)))


def group_peaks(obj, names):
    """{group name: the member vertex of highest weight (the first of equals)} for the groups of
    obj named in `names` that have members; one pass over the vertices."""
    index_of = {obj.vertex_groups[n].index: n for n in names}
    best = {}
    for v in obj.data.vertices:
        for g in v.groups:
            name = index_of.get(g.group)
            if name is not None and (name not in best or g.weight > best[name][1]):
                best[name] = (v.index, g.weight)
    return {name: vertex for name, (vertex, _w) in best.items()}


def marker_pairs(source, target, prefix=DEFAULT_PREFIX):
    """The marker pairs of the vertex groups named alike on both objects, starting with prefix;
    EntryError naming the group and the object where one is missing or empty, or when there are
    fewer than MIN_MARKERS pairs."""
    if not prefix:
        raise EntryError("marker_prefix: empty; the marker vertex groups need a common prefix, e.g. 'dt_'")
    named = [sorted(g.name for g in obj.vertex_groups if g.name.startswith(prefix)) for obj in (source, target)]
    for here, there, obj, other in ((named[0], named[1], target, source), (named[1], named[0], source, target)):
        missing = [n for n in here if n not in there]
        if missing:
            raise EntryError(f"marker vertex group '{missing[0]}' of '{other.name}' is missing on '{obj.name}' "
                             f"(markers are vertex groups named alike on both meshes, starting with '{prefix}')")
    names = named[0]
    peaks = [group_peaks(obj, names) for obj in (source, target)]
    for obj, found in zip((source, target), peaks):
        empty = [n for n in names if n not in found]
        if empty:
            raise EntryError(f"marker vertex group '{empty[0]}' on '{obj.name}' is empty: assign the marker vertex")
    if len(names) < MIN_MARKERS:
        listed = f" ({', '.join(names)})" if names else ""
        raise EntryError(f"'{source.name}' ({len(source.data.vertices)} vertices) and '{target.name}' "
                         f"({len(target.data.vertices)}) differ in their meshes: the transfer needs at least "
                         f"{MIN_MARKERS} marker pairs, vertex groups named alike on both starting with '{prefix}'; "
                         f"found {len(names)}{listed}")
    return Markers(tuple(names), np.array([peaks[0][n] for n in names], np.int32),
                   np.array([peaks[1][n] for n in names], np.int32))


def fitted_similarity(points, onto):
    """The rotation R, uniform scale s and translation t minimising sum |s R p + t - q|^2 over
    the pairs (p, q) (Umeyama 1991, "Least-squares estimation of transformation parameters
    between two point patterns", eqs. 40-42): the reflection is excluded."""
    p, q = np.asarray(points, np.float64), np.asarray(onto, np.float64)
    mp, mq = p.mean(0), q.mean(0)
    pc, qc = p - mp, q - mq
    u, d, vt = np.linalg.svd(qc.T @ pc / len(p))
    sign = np.ones(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        sign[2] = -1.0
    rotation = (u * sign) @ vt
    spread = (pc ** 2).sum() / len(p)
    scale = float((d * sign).sum() / spread) if spread > 0 else 1.0
    return Similarity(scale, rotation, mq - scale * rotation @ mp)


def applied(similarity, points):
    return similarity.scale * np.asarray(points, np.float64) @ similarity.rotation.T + similarity.translation


def fingerprint(source, target, markers):
    """What a stored correspondence depends on: both rests, both meshes' polygons and the markers."""
    h = hashlib.sha1()
    for mesh in (source, target):
        h.update(np.ascontiguousarray(mesh.rest, np.float32).tobytes())
        h.update(np.ascontiguousarray(ordered_corners(mesh.topology), np.int32).tobytes())
        h.update(np.ascontiguousarray(mesh.topology.totals, np.int32).tobytes())
    h.update(markers.source.tobytes() + b"|" + markers.target.tobytes())
    return h.hexdigest()


def stored_correspondence(target, source_name, digest):
    """The (m, 2) int32 pairs stored on the target for this source and fingerprint, else None."""
    stored = target.get(STORE)
    if stored is None or stored.get("source") != source_name or stored.get("fingerprint") != digest:
        return None
    pairs = np.asarray(stored.get("pairs", ()), np.int32)
    return pairs.reshape(-1, 2) if pairs.size % 2 == 0 and pairs.size else None


def store_correspondence(target, source_name, source, dt, digest):
    """Keep the correspondence on the target as int32 arrays (see entries/common.py store_array:
    the old group goes first)."""
    if STORE in target:
        del target[STORE]
    target[STORE] = {"source": source_name, "fingerprint": digest,
                     "source_vertices": int(source.topology.vertices), "source_faces": int(source.topology.faces),
                     "pairs": np.ascontiguousarray(dt.correspondence, np.int32).ravel(),
                     "unmatched": np.ascontiguousarray(dt.unmatched_target_triangles, np.int32),
                     "distance": mean_distance(dt.correspondence_distance)}


def mean_distance(distance):
    """The correspondence phase's mean distance: dk gives (mean, max)."""
    return float(np.ravel(distance)[0]) if distance is not None else float("nan")


# dt: dk.DeformationTransfer from the aligned source; align: the Similarity placing the source on the
# target; direct: same connectivity; reused: from a stored correspondence; store(): keeps a newly
# computed correspondence on the target (None when direct or reused).
System = namedtuple("System", "dt align direct reused store")


def transfer_system(source_obj, target_obj, marker_prefix=DEFAULT_PREFIX):
    """The transfer from source_obj onto target_obj, ready for poses. Writes nothing."""
    if native.dk is None:
        raise EntryError(native.IMPORT_ERROR)
    if source_obj == target_obj:
        raise EntryError(f"the source and the target are one object, '{source_obj.name}': pick two meshes")
    if source_obj.data == target_obj.data:  # linked duplicates: the keys would land on the source too
        raise EntryError(f"'{source_obj.name}' and '{target_obj.name}' share one mesh ('{source_obj.data.name}'), "
                         "so they share their shape keys: give the target its own mesh (Object > Relations > "
                         "Make Single User)")
    source, target = mesh_data(source_obj), mesh_data(target_obj)
    dk = native.dk
    if same_connectivity(source, target):
        align = fitted_similarity(source.rest, target.rest)
        dt = _built(lambda: dk.DeformationTransfer(applied(align, source.rest), source.polygons, target.rest))
        return System(dt, align, True, False, None)
    markers = marker_pairs(source_obj, target_obj, marker_prefix)
    marked = source.rest[markers.source]
    spread = np.linalg.svd(marked - marked.mean(0), compute_uv=False)
    if spread[1] <= 1e-6 * spread[0]:
        raise EntryError(f"the marker vertices on '{source_obj.name}' lie on one line ({', '.join(markers.names)}): "
                         "place at least one off it")
    align = fitted_similarity(marked, target.rest[markers.target])
    digest = fingerprint(source, target, markers)
    pairs = stored_correspondence(target_obj, source_obj.name, digest)
    # With stored pairs the markers still go along: they fix the translation as on the first run.
    dt = _built(lambda: dk.DeformationTransfer(applied(align, source.rest), source.polygons, target.rest,
                                               target.polygons, markers=(markers.source, markers.target),
                                               correspondence=pairs))
    if pairs is not None:
        return System(dt, align, False, True, None)
    return System(dt, align, False, False, lambda: store_correspondence(target_obj, source_obj.name, source, dt, digest))


def _built(make):
    try:
        return make()
    except (ValueError, TypeError) as exc:
        raise EntryError(str(exc)) from exc


def transferred(dt, poses, labels, progress=None, done=0, total=1):
    """dt.transfer of the (k, n, 3) poses in chunks, float32 (k, n_t, 3); a refusal names the pose
    by its label (the shape key or the frame) as well as by its index."""
    out = []
    for start in range(0, len(poses), CHUNK):
        try:
            out.append(np.asarray(dt.transfer(poses[start:start + CHUNK]), np.float32))
        except (ValueError, TypeError) as exc:
            message = re.sub(r"\bpose (\d+)", lambda m: f"pose {start + int(m.group(1))} "
                             f"({labels[start + int(m.group(1))]})", str(exc), count=1)
            raise EntryError(message) from exc
        _report(progress, done + min(start + CHUNK, len(poses)), total)
    return np.concatenate(out)


def source_key_blocks(obj):
    """The source's shape keys to transfer: every key block but the reference key."""
    key = obj.data.shape_keys
    blocks = [] if key is None else [b for b in key.key_blocks if b != key.reference_key]
    if not blocks:
        raise EntryError(f"the source '{obj.name}' has no shape keys to transfer (besides its basis)")
    return key, blocks


def ensure_basis(obj):
    """The target's shape keys, with a Basis made from the mesh when it has none (its vertex
    positions stay as they are)."""
    if obj.data.shape_keys is None:
        obj.shape_key_add(name="Basis", from_mix=False)
    return obj.data.shape_keys


def output_block(target, name, replace):
    """The target's key block to write `name` into: the one of that name with replace (never the
    reference key), else a new one (Blender makes its name unique: "Smile.001")."""
    key = target.data.shape_keys
    existing = key.key_blocks.get(name)
    if existing is not None and replace and existing != key.reference_key:
        return existing
    return target.shape_key_add(name=name, from_mix=False)


def write_points(block, points):
    block.data.foreach_set("co", np.ascontiguousarray(points, np.float32).ravel())


def _fcurves(anim_data):
    """The F-curves of an ID's action: Action.fcurves up to Blender 4.x, the assigned slot's
    channel bag from 4.4 (layered actions; 5.0 has only that)."""
    action = anim_data.action if anim_data is not None else None
    if action is None:
        return None
    if hasattr(action, "fcurves"):
        return action.fcurves
    for layer in action.layers:  # as bpy_extras.anim_utils.action_get_channelbag_for_slot
        for strip in layer.strips:
            bag = strip.channelbag(anim_data.action_slot)
            if bag is not None:
                return bag.fcurves
    return None


def block_path(name):
    return f'key_blocks["{_escaped(name)}"]'


def _escaped(name):
    return name.replace("\\", "\\\\").replace('"', '\\"')


def remove_driver(key, name):
    ad = key.animation_data
    if ad is not None and ad.drivers.find(block_path(name) + ".value") is not None:
        key.driver_remove(block_path(name) + ".value")


def retargeted(id_, path, source, target):
    """A driver variable's (ID, data path) with the source's own shape keys replaced by the
    target's (the Key, the object's data.shape_keys, the mesh's shape_keys), key names kept."""
    if id_ is None:
        return id_, path
    key = source.data.shape_keys
    if id_ == key:
        return target.data.shape_keys, path
    if id_ == source and path.startswith("data.shape_keys"):
        return target, path
    if id_ == source.data and path.startswith("shape_keys"):
        return target.data, path
    return id_, path


def copy_driver(source, target, source_name, target_name):
    """The source key's value driver, if any, onto the target key: type, expression, variables
    (retargeted), the F-curve's points and modifiers. Returns True when there was one."""
    ad = source.data.shape_keys.animation_data
    fcurve = None if ad is None else ad.drivers.find(block_path(source_name) + ".value")
    tkey = target.data.shape_keys
    remove_driver(tkey, target_name)
    if fcurve is None:
        return False
    copy = tkey.key_blocks[target_name].driver_add("value")
    driver, given = copy.driver, fcurve.driver
    driver.type, driver.use_self = given.type, given.use_self
    driver.expression = given.expression
    for var in given.variables:
        new = driver.variables.new()
        new.name, new.type = var.name, var.type
        for i, t in enumerate(var.targets):
            out = new.targets[i]
            if var.type == "SINGLE_PROP":
                out.id_type = t.id_type
            id_, path = retargeted(t.id, t.data_path, source, target)
            out.id = id_
            out.data_path = path
            for attr in ("bone_target", "transform_type", "transform_space", "rotation_mode", "context_property"):
                if hasattr(t, attr):
                    setattr(out, attr, getattr(t, attr))
    for mod in list(copy.modifiers):
        copy.modifiers.remove(mod)
    for mod in fcurve.modifiers:
        if mod.type == "GENERATOR":
            new = copy.modifiers.new("GENERATOR")
            new.mode, new.use_additive, new.poly_order = mod.mode, mod.use_additive, mod.poly_order
            new.coefficients = tuple(mod.coefficients)
    for point in fcurve.keyframe_points:
        new = copy.keyframe_points.insert(point.co[0], point.co[1])
        new.interpolation = point.interpolation
        new.handle_left_type, new.handle_right_type = point.handle_left_type, point.handle_right_type
        new.handle_left, new.handle_right = point.handle_left, point.handle_right
    return True


def copy_key_settings(source_block, block, target):
    """Slider range, value, mute, interpolation and vertex group (where the target has one of that
    name) of the source key; the relative key is set once every key exists."""
    block.slider_min, block.slider_max = source_block.slider_min, source_block.slider_max
    block.value = source_block.value
    block.mute = source_block.mute
    block.interpolation = source_block.interpolation
    group = source_block.vertex_group
    block.vertex_group = group if group and target.vertex_groups.get(group) is not None else ""


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
    _report(progress, 1, total)
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
    _report(progress, total, total)
    return _result(target, list(names.values()), system, t0)


def block_points_of(block, count):
    from .shapekeys import block_points
    return block_points(block, count).astype(np.float64)


def _result(target, keys, system, t0):
    """The run's Result; the correspondence's quality as stored on the target (unlike meshes)."""
    group = None if system.direct else target.get(STORE)
    unmatched = None if group is None else len(group.get("unmatched", ()))
    distance = None if group is None else float(group.get("distance", 0.0))
    return Result(keys, system.direct, system.reused, unmatched, distance, time.perf_counter() - t0)


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
            _report(progress, i + 1, total)
    finally:
        scene.frame_set(kept[0], subframe=kept[1])
    return poses


def keyed_to_its_frame(target, block, frame):
    """The baked key plays on its frame only: 0 on the frames either side, 1 on its own, linear in
    between (a subframe blends the two neighbouring frames' keys)."""
    for f, value in ((frame - 1, 0.0), (frame, 1.0), (frame + 1, 0.0)):
        block.value = value
        block.keyframe_insert("value", frame=f)
    fcurves = _fcurves(target.data.shape_keys.animation_data)
    curve = None if fcurves is None else fcurves.find(block_path(block.name) + ".value")
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
    _report(progress, total, total)
    return _result(target, names, system, t0)


MODES = [("SHAPE_KEYS", "Shape Keys", "Each shape key of the source (its points) becomes a shape key of the target"),
         ("ANIMATION", "Animation", "The source's evaluated deformation (e.g. from an Armature) at each frame of the "
          "range becomes a shape key of the target, keyed to play on its frame")]


def selected_source(context, target):
    """The other selected mesh when exactly one is selected besides the target (as Blender's
    Transfer Shape Key takes it), else None."""
    others = [o for o in getattr(context, "selected_objects", ()) if o != target and o.type == "MESH"]
    return others[0] if len(others) == 1 else None


class DEFORMKIT_OT_transfer_deformation(bpy.types.Operator):
    """Transfer the source mesh's shape keys, or its animation baked per frame, onto the target as shape \
keys (deformation transfer: also between different meshes, through marker vertex groups)"""
    bl_idname = "deformkit.transfer_deformation"
    bl_label = "Transfer Deformation"
    bl_options = {"REGISTER", "UNDO"}

    source: StringProperty(name="Source", description="The mesh whose deformation is transferred (empty: the other "
                           "selected mesh)")
    target: StringProperty(name="Target", description="The mesh that receives the shape keys (empty: the active "
                           "object)")
    mode: EnumProperty(name="Mode", items=MODES, default="SHAPE_KEYS")
    use_scene_range: BoolProperty(name="Scene Frame Range", default=True,
                                  description="Bake the scene's frame range (else Start and End)")
    frame_start: IntProperty(name="Start", default=1, description="The first frame to bake")
    frame_end: IntProperty(name="End", default=250, description="The last frame to bake")
    marker_prefix: StringProperty(name="Marker Prefix", default=DEFAULT_PREFIX,
                                  description="Between different meshes: the vertex groups named alike on both, "
                                  "starting with this, mark corresponding points (each group's vertex of highest "
                                  "weight)")
    replace: BoolProperty(name="Replace Existing", default=False,
                          description="Overwrite the target's shape keys of the same names (else new, unique names)")

    @classmethod
    def poll(cls, context):
        if not native.available():
            cls.poll_message_set(native.IMPORT_ERROR)
            return False
        obj = context.object
        if obj is None or obj.type != "MESH":
            cls.poll_message_set("Needs an active mesh object, the target")
            return False
        if obj.mode != "OBJECT":
            cls.poll_message_set("Leave Edit Mode first")
            return False
        return True

    def invoke(self, context, event):
        if not self.source:
            found = selected_source(context, context.object)
            self.source = found.name if found is not None else ""
        return context.window_manager.invoke_props_dialog(self)

    def draw(self, context):
        col = self.layout.column()
        col.use_property_split = True
        col.prop_search(self, "source", bpy.data, "objects")
        col.prop_search(self, "target", bpy.data, "objects")
        col.prop(self, "mode")
        if self.mode == "ANIMATION":
            col.prop(self, "use_scene_range")
            sub = col.column(align=True)
            sub.active = not self.use_scene_range
            sub.prop(self, "frame_start")
            sub.prop(self, "frame_end")
        col.prop(self, "marker_prefix")
        col.prop(self, "replace")

    def objects(self, context):
        target = bpy.data.objects.get(self.target) if self.target else context.object
        if self.target and target is None:
            raise EntryError(f"target: no object named '{self.target}'")
        if self.source:
            source = bpy.data.objects.get(self.source)
            if source is None:
                raise EntryError(f"source: no object named '{self.source}'")
        else:
            source = selected_source(context, target)
            if source is None:
                raise EntryError("no source object: select the source mesh and the target (active), or name the "
                                 "Source")
        return source, target

    def execute(self, context):
        wm = context.window_manager
        wm.progress_begin(0, 1)

        def progress(done, total):
            wm.progress_update(done / max(total, 1))

        try:
            source, target = self.objects(context)
            if self.mode == "SHAPE_KEYS":
                result = transfer_shape_keys(source, target, self.replace, self.marker_prefix, progress)
            else:
                scene = context.scene
                start, end = ((scene.frame_start, scene.frame_end) if self.use_scene_range
                              else (self.frame_start, self.frame_end))
                result = transfer_animation(source, target, start, end, scene, self.replace, self.marker_prefix,
                                            progress)
        except (ValueError, TypeError) as exc:  # EntryError is a ValueError, as the module's own
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        finally:
            wm.progress_end()
        self.report({"INFO"}, summary(source, target, result))
        return {"FINISHED"}


def summary(source, target, result):
    how = "same mesh, direct" if result.direct else (
        ("stored correspondence" if result.reused_correspondence else "correspondence computed")
        + f", {result.unmatched} target triangles unmatched")
    return (f"Transferred {len(result.keys)} shape key{'s' if len(result.keys) != 1 else ''} from "
            f"'{source.name}' to '{target.name}' ({how}) in {result.seconds:.2f} s")


def draw_menu_item(self, context):
    self.layout.separator()
    self.layout.operator(DEFORMKIT_OT_transfer_deformation.bl_idname, icon="MOD_DATA_TRANSFER")


def register():
    """Beside Blender's Transfer Shape Key (object.shape_key_transfer), in the shape-key specials."""
    bpy.types.MESH_MT_shape_key_context_menu.append(draw_menu_item)


def unregister():
    bpy.types.MESH_MT_shape_key_context_menu.remove(draw_menu_item)


classes = (DEFORMKIT_OT_transfer_deformation,)

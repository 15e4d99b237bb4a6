"""The transfer between two mesh objects: their rests and polygons read, the source placed on the
target (similarity.py), dk.DeformationTransfer built directly (same connectivity) or through
marker pairs and a stored or new correspondence, then run on the poses in chunks. Writes nothing:
the modes (shape_keys.py, bake.py) write once every pose has been transferred."""
import re
import time
from collections import namedtuple

import numpy as np

from .. import meshdata, native
from ..errors import EntryError
from ..shapekeys import block_points
from .correspondence import DEFAULT_PREFIX, marker_pairs, off_one_line
from .similarity import applied, fitted_similarity
from .storage import fingerprint, store_correspondence, stored_correspondence, stored_quality

CHUNK = 32  # poses per dk.DeformationTransfer.transfer call: (k, n, 3) float64 arrays stay bounded

MeshData = namedtuple("MeshData", "rest polygons topology")  # rest: float64 (n, 3), object space
# dt: dk.DeformationTransfer from the aligned source; align: the Similarity placing the source on the
# target; direct: same connectivity; reused: from a stored correspondence; store(): keeps a newly
# computed correspondence on the target (None when direct or reused).
System = namedtuple("System", "dt align direct reused store")
# keys: the target's shape-key names written, in source order; direct: same connectivity;
# reused_correspondence: a stored correspondence was used; unmatched, distance: the
# correspondence's quality (None when direct); seconds: the whole run.
Result = namedtuple("Result", "keys direct reused_correspondence unmatched distance seconds")


def report_progress(progress, done, total):
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
        return block_points(key.reference_key, len(obj.data.vertices)).astype(np.float64)
    return meshdata.base_positions(obj.data).astype(np.float64)


def mesh_data(obj):
    topo = meshdata.topology(obj.data)
    return MeshData(rest_points(obj), meshdata.polygons(topo), topo)


def same_connectivity(source, target):
    a, b = source.topology, target.topology
    return (a.vertices == b.vertices and a.faces == b.faces and np.array_equal(a.totals, b.totals)
            and np.array_equal(meshdata.polygon_corners(a).vertices, meshdata.polygon_corners(b).vertices))


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
    off_one_line(source_obj, source.rest, markers)
    align = fitted_similarity(source.rest[markers.source], target.rest[markers.target])
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
        report_progress(progress, done + min(start + CHUNK, len(poses)), total)
    return np.concatenate(out)


def result_of(target, keys, system, t0):
    """The run's Result; the correspondence's quality as stored on the target (unlike meshes)."""
    unmatched, distance = (None, None) if system.direct else stored_quality(target)
    return Result(keys, system.direct, system.reused, unmatched, distance, time.perf_counter() - t0)

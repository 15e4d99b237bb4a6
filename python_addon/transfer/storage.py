"""The correspondence kept on the target (ID property STORE) with a fingerprint of both rests,
faces and the markers, so a later run reuses it and an edit of either mesh recomputes it."""
import hashlib

import numpy as np

from .. import meshdata

STORE = "deformkit_transfer"  # the target's ID property group: the stored correspondence


def fingerprint(source, target, markers):
    """What a stored correspondence depends on: both rests, both meshes' polygons and the markers."""
    h = hashlib.sha1()
    for mesh in (source, target):
        h.update(np.ascontiguousarray(mesh.rest, np.float32).tobytes())
        h.update(np.ascontiguousarray(meshdata.polygon_corners(mesh.topology).vertices, np.int32).tobytes())
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


def stored_quality(target):
    """(unmatched target triangles, mean distance) of the correspondence stored on the target."""
    group = target.get(STORE)
    if group is None:
        return None, None
    return len(group.get("unmatched", ())), float(group.get("distance", 0.0))

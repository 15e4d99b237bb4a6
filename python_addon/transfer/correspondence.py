"""Which points of two unlike meshes correspond: marker pairs, vertex groups named alike on both
meshes with a common prefix ("dt_" by default); each group's marker is its member of highest
weight (the first of equals). dk.DeformationTransfer's correspondence phase (Sumner and Popovic
2004, section 5) pairs the triangles from them."""
from collections import namedtuple

import numpy as np

from ..errors import EntryError

DEFAULT_PREFIX = "dt_"
# A similarity needs three points off one line; fewer markers leave the source's turn undetermined.
MIN_MARKERS = 3

Markers = namedtuple("Markers", "names source target")  # group names, source and target vertex indices


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


def off_one_line(source_obj, rest, markers):
    """EntryError when the source's marker vertices lie on one line (the similarity's turn about
    it would be undetermined)."""
    marked = rest[markers.source]
    spread = np.linalg.svd(marked - marked.mean(0), compute_uv=False)
    if spread[1] <= 1e-6 * spread[0]:
        raise EntryError(f"the marker vertices on '{source_obj.name}' lie on one line ({', '.join(markers.names)}): "
                         "place at least one off it")

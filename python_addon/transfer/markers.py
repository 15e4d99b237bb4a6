"""Making marker pairs (correspondence.py reads them): a pair is one vertex group of the same
numbered name on each mesh ("dt_001"), holding its one marker vertex with weight 1. Plain
functions on two mesh objects, in Object Mode or in (multi-object) Edit Mode, whose copy of the
mesh (bmesh) is what the user sees and what leaving Edit Mode writes; the operators
(operators/markers.py) and the tests call them alike."""
import re

import bmesh
import numpy as np
from mathutils.kdtree import KDTree

from ..errors import EntryError
from .correspondence import DEFAULT_PREFIX
from .similarity import Similarity, applied, fitted_similarity

MIRROR_TOLERANCE = 0.01  # of the mesh's bounding-box diagonal
ICP_SAMPLES = 2000  # points per side in the first guess's fit: enough to place, few enough to be quick
ICP_STEPS = 40


class Vertices:
    """One mesh object's vertices, read and written through bmesh in Edit Mode, else the mesh."""

    def __init__(self, obj):
        if obj is None or obj.type != "MESH":
            raise EntryError(f"'{getattr(obj, 'name', obj)}' is not a mesh object: markers are vertices of meshes")
        self.obj = obj
        self.bm = None
        if obj.mode == "EDIT":
            self.bm = bmesh.from_edit_mesh(obj.data)
            self.bm.verts.ensure_lookup_table()
            self.bm.verts.index_update()  # the indices leaving Edit Mode will give
            self.deform = self.bm.verts.layers.deform.active  # None until a vertex has a group

    def __len__(self):
        return len(self.bm.verts) if self.bm is not None else len(self.obj.data.vertices)

    def positions(self):
        """float64 (n, 3), in the object's space."""
        if self.bm is not None:
            return np.array([v.co for v in self.bm.verts], np.float64).reshape(-1, 3)
        co = np.empty(len(self.obj.data.vertices) * 3, np.float32)
        self.obj.data.vertices.foreach_get("co", co)
        return co.reshape(-1, 3).astype(np.float64)

    def co(self, vertex):
        return tuple((self.bm.verts if self.bm is not None else self.obj.data.vertices)[vertex].co)

    def selected(self):
        if self.bm is not None:
            return [v.index for v in self.bm.verts if v.select and not v.hide]
        return [v.index for v in self.obj.data.vertices if v.select]

    def marker(self, name):
        """The group's member of highest weight (the first of equals), as marker_pairs reads it;
        None when the group is missing or empty."""
        return self.markers([name]).get(name)

    def markers(self, names):
        """{name: marker vertex} of the named groups that have members; one pass over the vertices."""
        index_of = {self.obj.vertex_groups[n].index: n for n in names if self.obj.vertex_groups.get(n) is not None}
        best = {}
        if not index_of or (self.bm is not None and self.deform is None):
            return best
        if self.bm is not None:
            weights = ((v.index, v[self.deform].items()) for v in self.bm.verts)
        else:
            weights = ((v.index, [(g.group, g.weight) for g in v.groups]) for v in self.obj.data.vertices)
        for vertex, groups in weights:
            for group, weight in groups:
                name = index_of.get(group)
                if name is not None and (name not in best or weight > best[name][1]):
                    best[name] = (vertex, weight)
        return {name: vertex for name, (vertex, _w) in best.items()}

    def assign(self, name, vertex):
        """A new group `name` holding `vertex` alone, weight 1."""
        group = self.obj.vertex_groups.new(name=name)
        if self.bm is not None:
            self.deform = self.bm.verts.layers.deform.verify()
            self.bm.verts[vertex][self.deform][group.index] = 1.0
        else:
            group.add([int(vertex)], 1.0, "REPLACE")

    def select_only(self, vertex):
        if self.bm is not None:
            for items in (self.bm.faces, self.bm.edges, self.bm.verts):
                for item in items:
                    item.select = False
            self.bm.verts[vertex].select = True
            self.bm.select_flush_mode()
        else:
            mesh = self.obj.data
            for items in (mesh.polygons, mesh.edges, mesh.vertices):
                items.foreach_set("select", np.zeros(len(items), bool))
            mesh.vertices[vertex].select = True

    def done(self):
        if self.bm is not None:
            bmesh.update_edit_mesh(self.obj.data)
        else:
            self.obj.data.update()


def numbered(prefix):
    return re.compile(re.escape(prefix) + r"(\d+)$")


def next_pair_name(objects, prefix=DEFAULT_PREFIX):
    """prefix + the next number (three digits at least) after every numbered marker group on
    either object: "dt_001", "dt_002", ..."""
    pattern = numbered(prefix)
    used = [int(m.group(1)) for obj in objects for g in obj.vertex_groups if (m := pattern.match(g.name))]
    return f"{prefix}{max(used, default=0) + 1:03d}"


def pair_names(source, target, prefix=DEFAULT_PREFIX):
    """The names of the marker groups on both objects (the pairs), sorted."""
    there = {g.name for g in target.vertex_groups}
    return sorted(g.name for g in source.vertex_groups if g.name.startswith(prefix) and g.name in there)


def check_prefix(prefix):
    if not prefix:
        raise EntryError("prefix: empty; the marker vertex groups need a common prefix, e.g. 'dt_'")


def add_pair(source, source_vertex, target, target_vertex, prefix=DEFAULT_PREFIX):
    """A new numbered pair marking source_vertex on source and target_vertex on target; returns its
    name. Refused (EntryError naming the pair) when either vertex already marks a pair."""
    check_prefix(prefix)
    sides = [(Vertices(source), int(source_vertex)), (Vertices(target), int(target_vertex))]
    names = pair_names(source, target, prefix)
    for side, vertex in sides:
        if not 0 <= vertex < len(side):
            raise EntryError(f"vertex {vertex} of '{side.obj.name}': out of range (it has {len(side)} vertices)")
        taken = next((n for n, v in side.markers(names).items() if v == vertex), None)
        if taken is not None:
            raise EntryError(f"vertex {vertex} of '{side.obj.name}' already marks the pair '{taken}': "
                             "remove that pair first, or pick another vertex")
    return written_pair(sides, prefix)


def written_pair(sides, prefix):
    name = next_pair_name([side.obj for side, _vertex in sides], prefix)
    for side, vertex in sides:
        side.assign(name, vertex)
        side.done()
    return name


def the_selected_vertex(obj):
    selected = Vertices(obj).selected()
    if len(selected) != 1:
        got = "none" if not selected else f"{len(selected)} vertices"
        raise EntryError(f"'{obj.name}' has {got} selected: select exactly one vertex on each mesh "
                         "(Add Marker Pair marks the one selected vertex of each)")
    return selected[0]


def add_selected_pair(source, target, prefix=DEFAULT_PREFIX):
    """Add Marker Pair: the one selected vertex of each mesh (in Edit Mode) becomes a pair."""
    for obj in (source, target):
        if obj.mode != "EDIT":
            raise EntryError(f"'{obj.name}' is not in Edit Mode: select both meshes, enter Edit Mode with both "
                             "and select one vertex on each")
    return add_pair(source, the_selected_vertex(source), target, the_selected_vertex(target), prefix)


def pair_objects(active, others):
    """(source, target): the active mesh is the target (as in Transfer Deformation), the one other
    mesh the source; EntryError naming what is there otherwise."""
    if active is None or active.type != "MESH":
        raise EntryError("no active mesh: make the target mesh active and select the source mesh too")
    meshes = [o for o in others if o != active and o.type == "MESH"]
    if len(meshes) != 1:
        listed = ", ".join(f"'{o.name}'" for o in meshes) or "none"
        raise EntryError(f"marker pairs need exactly two meshes, the target '{active.name}' (active) and one "
                         f"source; the other meshes selected (or in Edit Mode) are: {listed}")
    return meshes[0], active


def existing_pair(source, target, name, prefix=DEFAULT_PREFIX):
    if name not in pair_names(source, target, prefix):
        where = [o.name for o in (source, target) if o.vertex_groups.get(name) is not None]
        found = f"only on '{where[0]}'" if len(where) == 1 else "on neither"
        raise EntryError(f"pair '{name}': no marker group of that name on both '{source.name}' and "
                         f"'{target.name}' ({found})")


def select_pair(source, target, name, prefix=DEFAULT_PREFIX):
    """Selects the pair's marker vertex on each mesh, and nothing else."""
    existing_pair(source, target, name, prefix)
    for obj in (source, target):
        side = Vertices(obj)
        vertex = side.marker(name)
        if vertex is None:
            raise EntryError(f"marker vertex group '{name}' on '{obj.name}' is empty: assign the marker vertex")
        side.select_only(vertex)
        side.done()


def remove_pair(source, target, name, prefix=DEFAULT_PREFIX):
    """Removes the pair's group from both meshes."""
    existing_pair(source, target, name, prefix)
    for obj in (source, target):
        side = Vertices(obj)
        obj.vertex_groups.remove(obj.vertex_groups[name])
        side.done()


def nearest_vertex(points, point):
    distance = np.linalg.norm(points - point, axis=1)
    index = int(np.argmin(distance))
    return index, float(distance[index])


def mirror_all(source, target, tolerance=MIRROR_TOLERANCE, prefix=DEFAULT_PREFIX):
    """mirror_pair on every pair there is now; returns (the new pairs' names, {pair: why it was
    skipped}) (on the plane, mirrored already, no vertex near the image)."""
    made, skipped = [], {}
    for name in pair_names(source, target, prefix):
        try:
            made.append(mirror_pair(source, target, name, tolerance, prefix))
        except EntryError as exc:
            skipped[name] = str(exc)
    return made, skipped


def mirror_pair(source, target, name, tolerance=MIRROR_TOLERANCE, prefix=DEFAULT_PREFIX):
    """The X-mirrored pair of `name` (x -> -x in each object's own space, as Blender's mesh X
    mirror): on each mesh the vertex nearest the marker's mirrored position, which must lie within
    tolerance (a fraction of the mesh's bounding-box diagonal) of it. Returns the new pair's name."""
    existing_pair(source, target, name, prefix)
    if not tolerance > 0:
        raise EntryError(f"tolerance: {tolerance}; expected a fraction of the mesh's size above 0, e.g. 0.01")
    found = []
    for obj in (source, target):
        side = Vertices(obj)
        points = side.positions()
        vertex = side.marker(name)
        if vertex is None:
            raise EntryError(f"marker vertex group '{name}' on '{obj.name}' is empty: assign the marker vertex")
        mirrored = points[vertex] * (-1.0, 1.0, 1.0)
        index, distance = nearest_vertex(points, mirrored)
        allowed = tolerance * float(np.linalg.norm(points.max(0) - points.min(0)))
        if distance > allowed:
            raise EntryError(f"'{obj.name}' has no vertex within {allowed:.4g} (tolerance {tolerance:g} of its size) "
                             f"of the X mirror of '{name}' (vertex {vertex}) at ({mirrored[0]:.4g}, "
                             f"{mirrored[1]:.4g}, {mirrored[2]:.4g}): the nearest, vertex {index}, is {distance:.4g} "
                             "away; the mesh is not symmetric about its own X = 0 there")
        found.append((vertex, index))
    if all(vertex == index for vertex, index in found):
        raise EntryError(f"pair '{name}' lies on the mirror plane (X = 0) of both meshes: its mirror is itself")
    return add_pair(source, found[0][1], target, found[1][1], prefix)


def spread_vertices(points, count, first):
    """`count` well-spread vertices: farthest-point sampling from `first` (each next vertex the
    farthest from those taken)."""
    taken = [first]
    distance = np.linalg.norm(points - points[first], axis=1)
    for _ in range(count - 1):
        taken.append(int(np.argmax(distance)))
        distance = np.minimum(distance, np.linalg.norm(points - points[taken[-1]], axis=1))
    return taken


def kd_tree(points):
    tree = KDTree(len(points))
    for index, point in enumerate(points):
        tree.insert(point, index)
    tree.balance()
    return tree


def nearest_indices(tree, points):
    return np.array([tree.find(p)[1] for p in points], np.int64)


def principal_starts(source, target):
    """The four proper similarities taking source's principal axes onto target's (the axes' signs
    are undetermined, up to a rotation), scaled by the ratio of their spreads."""
    frames = []
    for points in (source, target):
        centred = points - points.mean(0)
        _values, axes = np.linalg.eigh(centred.T @ centred)
        frames.append((points.mean(0), axes[:, ::-1], np.sqrt((centred ** 2).sum(1).mean())))
    (ms, axes_s, spread_s), (mt, axes_t, spread_t) = frames
    starts = []
    for signs in ((1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1)):
        rotation = (axes_t * signs) @ axes_s.T
        if np.linalg.det(rotation) < 0:
            rotation = (axes_t * np.array(signs) * (1, 1, -1)) @ axes_s.T
        scale = spread_t / spread_s
        starts.append(Similarity(scale, rotation, mt - scale * rotation @ ms))
    return starts


def fitted_to(source, target, start):
    """Iterative closest points with a similarity (Besl and McKay 1992, with Umeyama's fit), both
    ways (source samples to their nearest target points and back) so the scale cannot shrink onto
    a part of the target; returns (similarity, mean squared distance of both ways)."""
    fit = start
    target_tree = kd_tree(target)
    for _ in range(ICP_STEPS):
        moved = applied(fit, source)
        forward = nearest_indices(target_tree, moved)
        backward = nearest_indices(kd_tree(moved), target)
        fit = fitted_similarity(np.vstack([source, source[backward]]), np.vstack([target[forward], target]))
    moved = applied(fit, source)
    residual = (((moved - target[nearest_indices(target_tree, moved)]) ** 2).sum(1).mean()
                + ((target - moved[nearest_indices(kd_tree(moved), target)]) ** 2).sum(1).mean())
    return fit, residual


def samples(points, limit=ICP_SAMPLES):
    return points[:: max(1, len(points) // limit)]


def similarity_fit(source, target, prefix=DEFAULT_PREFIX):
    """The similarity placing source's vertices on target's: from the pairs already made when there
    are three or more, else from the best of the principal-axis starts; refined by closest points."""
    src, tgt = Vertices(source), Vertices(target)
    a, b = samples(src.positions()), samples(tgt.positions())
    names = pair_names(source, target, prefix)
    ms, mt = src.markers(names), tgt.markers(names)
    marked = [(ms[n], mt[n]) for n in names if n in ms and n in mt]
    if len(marked) >= 3:
        s, t = np.array(marked).T
        starts = [fitted_similarity(src.positions()[s], tgt.positions()[t])]
    else:
        starts = principal_starts(a, b)
    return min((fitted_to(a, b, start) for start in starts), key=lambda fit: fit[1])[0]


def guess_pairs(source, target, count, prefix=DEFAULT_PREFIX):
    """A first guess of `count` pairs for the user to correct: well-spread source vertices (not
    already markers) each paired with the target vertex nearest its place under the similarity
    fit of the two meshes (similarity_fit). Returns the new pairs' names; a source vertex whose
    nearest target vertex is already taken is skipped."""
    check_prefix(prefix)
    src, tgt = Vertices(source), Vertices(target)
    if not isinstance(count, int) or not 1 <= count <= len(src):
        raise EntryError(f"count: {count!r}; expected a whole number from 1 to the source's {len(src)} vertices")
    if len(src) < 3 or len(tgt) < 3:
        raise EntryError(f"'{source.name}' and '{target.name}' need three vertices each for a similarity fit")
    fit = similarity_fit(source, target, prefix)
    points, onto = src.positions(), tgt.positions()
    names = pair_names(source, target, prefix)
    taken_s, taken_t = set(src.markers(names).values()), set(tgt.markers(names).values())
    centre = points.mean(0)
    first = int(np.argmax(np.linalg.norm(points - centre, axis=1)))
    candidates = [v for v in spread_vertices(points, min(len(points), count + len(taken_s)), first)
                  if v not in taken_s][:count]
    tree = kd_tree(onto)
    made = []
    for vertex in candidates:
        match = tree.find(applied(fit, points[vertex][None])[0])[1]
        if match in taken_t:
            continue
        taken_t.add(match)
        made.append(written_pair([(src, vertex), (tgt, match)], prefix))
    return made


def marker_points(source, target, prefix=DEFAULT_PREFIX):
    """What the viewport draws: for each mesh, (object, pair names, its marker vertices in world
    space (k, 3) float64) of the pairs on both meshes that have a marker vertex on both."""
    names = pair_names(source, target, prefix)
    if not names:
        return [(obj, [], np.zeros((0, 3))) for obj in (source, target)]
    sides = [Vertices(obj) for obj in (source, target)]
    found = [side.markers(names) for side in sides]
    names = [n for n in names if all(n in f for f in found)]
    out = []
    for side, marked in zip(sides, found):
        matrix = np.array(side.obj.matrix_world, np.float64)
        local = np.array([side.co(marked[n]) for n in names], np.float64).reshape(-1, 3)
        out.append((side.obj, names, local @ matrix[:3, :3].T + matrix[:3, 3]))
    return out

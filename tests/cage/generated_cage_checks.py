"""Independent checks of a generated cage (none of them uses the generator's code): closedness,
manifoldness and orientation by counting directed edges, self-intersection in rational arithmetic,
enclosure by winding numbers and by segment-triangle crossings both ways, and test meshes."""
import math

import numpy as np

from cage_files import winding_numbers
from rational_intersection import meeting_pairs


def signed_volume(points, triangles):
    points = np.asarray(points, float)
    p = (points - points.mean(axis=0))[np.asarray(triangles)]  # about the centroid: no cancellation
    return np.einsum("ti,ti->t", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6


def assert_closed_manifold_oriented(points, triangles):
    """Every directed edge once and its reverse once (closed, manifold at edges, consistently
    oriented), every vertex's faces one fan (manifold at vertices), and positive volume (outward)."""
    t = np.asarray(triangles)
    directed = {}
    for f in t:
        for k in range(3):
            e = (int(f[k]), int(f[(k + 1) % 3]))
            assert e not in directed, f"directed edge {e} used twice"
            directed[e] = True
    for a, b in directed:
        assert (b, a) in directed, f"edge {(a, b)} has one face"
    # Around each vertex the faces form a single cycle: follow next edges from one of them.
    nxt = {}
    for f in t:
        for k in range(3):
            nxt.setdefault(int(f[k]), {})[int(f[(k + 1) % 3])] = int(f[(k + 2) % 3])
    for v, ring in nxt.items():
        start = next(iter(ring))
        w, steps = start, 0
        while True:
            w = ring[w]
            steps += 1
            if w == start:
                break
        assert steps == len(ring), f"vertex {v} is non-manifold ({len(ring)} faces, a fan of {steps})"
    assert signed_volume(points, t) > 0


def euler_characteristic(triangles):
    t = np.asarray(triangles)
    edges = {tuple(sorted((int(f[k]), int(f[(k + 1) % 3])))) for f in t for k in range(3)}
    return len(np.unique(t)) - len(edges) + len(t)


def components(triangles):
    t = np.asarray(triangles)
    parent = {int(v): int(v) for v in np.unique(t)}

    def root(v):
        while parent[v] != v:
            parent[v] = parent[parent[v]]
            v = parent[v]
        return v
    for f in t:
        for k in (1, 2):
            parent[root(int(f[0]))] = root(int(f[k]))
    return len({root(v) for v in parent})


def _hits(o, d, tri):
    """Moller-Trumbore on pairs: segment o + t d, t in [0, 1], against triangle tri (closed)."""
    v0, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    p = np.cross(d, e2)
    det = (e1 * p).sum(-1)
    ok = np.abs(det) > 1e-300
    inv = np.where(ok, 1 / np.where(ok, det, 1), 0)
    tv = o - v0
    u = (tv * p).sum(-1) * inv
    q = np.cross(tv, e1)
    v = (d * q).sum(-1) * inv
    w = (e2 * q).sum(-1) * inv
    return ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (w >= 0) & (w <= 1)


def segments_cross_triangles(seg_a, seg_b, tri, block=64):
    """Whether any segment [seg_a, seg_b] meets any triangle (closed: touching counts), in floating
    point (the gaps tested here are far above rounding); only pairs whose boxes overlap are tested."""
    seg_a, seg_b, tri = (np.asarray(x, float) for x in (seg_a, seg_b, tri))
    s_lo, s_hi = np.minimum(seg_a, seg_b), np.maximum(seg_a, seg_b)
    t_lo, t_hi = tri.min(axis=1), tri.max(axis=1)
    if len(tri) <= len(seg_a):  # blocks of the smaller set against all of the other
        for b in range(0, len(tri), block):
            overlap = np.all((t_lo[b:b + block, None] <= s_hi[None]) & (s_lo[None] <= t_hi[b:b + block, None]), axis=2)
            ti, si = np.nonzero(overlap)
            if len(ti) and _hits(seg_a[si], seg_b[si] - seg_a[si], tri[b + ti]).any():
                return True
        return False
    for b in range(0, len(seg_a), block):
        overlap = np.all((s_lo[b:b + block, None] <= t_hi[None]) & (t_lo[None] <= s_hi[b:b + block, None]), axis=2)
        si, ti = np.nonzero(overlap)
        if len(si) and _hits(seg_a[b + si], seg_b[b + si] - seg_a[b + si], tri[ti]).any():
            return True
    return False


def fan(faces):
    return np.array([(f[0], f[i], f[i + 1]) for f in faces for i in range(1, len(f) - 1)], dtype=np.int64).reshape(-1, 3)


def edges_of(triangles):
    t = np.asarray(triangles)
    e = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    return np.unique(np.sort(e, axis=1), axis=0)


def assert_encloses(cage_points, cage_triangles, points, triangles=None):
    """Every point inside (winding number 1), no mesh edge across a cage triangle and no cage
    edge across a mesh triangle."""
    cp, ct = np.asarray(cage_points, float), np.asarray(cage_triangles)
    w = winding_numbers(np.asarray(points, float), cp, ct)
    assert np.all(np.abs(w - 1) < 1e-6), f"{np.sum(np.abs(w - 1) >= 1e-6)} points outside the cage"
    if triangles is None or len(triangles) == 0:
        return
    p, t = np.asarray(points, float), np.asarray(triangles)
    e = edges_of(t)
    e = e[e[:, 0] != e[:, 1]]
    assert not segments_cross_triangles(p[e[:, 0]], p[e[:, 1]], cp[ct]), "a mesh edge crosses the cage"
    ce = edges_of(ct)
    assert not segments_cross_triangles(cp[ce[:, 0]], cp[ce[:, 1]], p[t]), "a cage edge crosses the mesh"


def assert_valid_cage(cage_points, cage_triangles, max_faces):
    assert 4 <= len(cage_triangles) <= max_faces
    assert np.all(np.isfinite(cage_points))
    assert_closed_manifold_oriented(cage_points, cage_triangles)
    assert meeting_pairs(np.asarray(cage_points, float).tolist(), np.asarray(cage_triangles).tolist()) == []


def uv_sphere(n=12, radius=1.0, center=(0, 0, 0)):
    pts = [(0, 0, 1), (0, 0, -1)]
    for i in range(1, n):
        th = math.pi * i / n
        pts += [(math.sin(th) * math.cos(2 * math.pi * j / (2 * n)), math.sin(th) * math.sin(2 * math.pi * j / (2 * n)),
                 math.cos(th)) for j in range(2 * n)]
    ring, faces = 2 * n, []
    for j in range(ring):
        faces.append((0, 2 + j, 2 + (j + 1) % ring))
        last = 2 + (n - 2) * ring
        faces.append((1, last + (j + 1) % ring, last + j))
    for i in range(n - 2):
        for j in range(ring):
            a, b = 2 + i * ring + j, 2 + i * ring + (j + 1) % ring
            c, d = a + ring, b + ring
            faces += [(a, c, b), (b, c, d)]
    return np.array(pts) * radius + np.asarray(center, float), np.array(faces)


def torus(major=1.0, minor=0.35, n=24, m=12):
    pts = [((major + minor * math.cos(2 * math.pi * j / m)) * math.cos(2 * math.pi * i / n),
            (major + minor * math.cos(2 * math.pi * j / m)) * math.sin(2 * math.pi * i / n),
            minor * math.sin(2 * math.pi * j / m)) for i in range(n) for j in range(m)]
    quads = [(i * m + j, ((i + 1) % n) * m + j, ((i + 1) % n) * m + (j + 1) % m, i * m + (j + 1) % m)
             for i in range(n) for j in range(m)]
    return np.array(pts), quads

"""An independent, exact answer to "does this triangulated cage touch itself?": rational arithmetic
(fractions.Fraction holds every double exactly) and constructions, where the library uses CGAL's
predicates. T1 ∩ T2 is T1 clipped (Sutherland-Hodgman) by T2's plane from both sides and by the
three half-spaces through T2's edges along its normal; two triangles meet beyond what they share
when a corner of that convex piece lies outside the vertices and edge they share by index (any
contact counts, touching included; the same triangle twice always meets itself)."""
from fractions import Fraction


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _clip(polygon, f):
    """The convex polygon (a corner list, possibly degenerate) cut to f >= 0, f affine."""
    out = []
    for i, p in enumerate(polygon):
        q = polygon[(i + 1) % len(polygon)]
        fp, fq = f(p), f(q)
        if fp >= 0:
            out.append(p)
        if (fp < 0 < fq) or (fq < 0 < fp):
            t = fp / (fp - fq)
            out.append(tuple(p[k] + t * (q[k] - p[k]) for k in range(3)))
    return out


def _on_segment(x, u, w):
    d = _sub(w, u)
    if any(_cross(_sub(x, u), d)):
        return False
    t = _dot(_sub(x, u), d)
    return 0 <= t <= _dot(d, d)


def triangles_meet(points, a, b):
    """Whether triangles a and b (vertex index triples into the Fraction points) meet anywhere but
    in the vertices and the edge they share."""
    shared = sorted(set(a) & set(b))
    if len(shared) == 3:
        return True
    ta, tb = [points[v] for v in a], [points[v] for v in b]
    n = _cross(_sub(tb[1], tb[0]), _sub(tb[2], tb[0]))
    piece = _clip(ta, lambda x: _dot(n, _sub(x, tb[0])))
    piece = _clip(piece, lambda x: -_dot(n, _sub(x, tb[0])))
    for i in range(3):
        p, q = tb[i], tb[(i + 1) % 3]
        piece = _clip(piece, lambda x, p=p, q=q: _dot(_cross(_sub(q, p), _sub(x, p)), n))
    if not shared:
        return bool(piece)
    if len(shared) == 1:
        return any(x != points[shared[0]] for x in piece)
    return any(not _on_segment(x, points[shared[0]], points[shared[1]]) for x in piece)


def exact_points(points):
    return [tuple(Fraction(float(c)) for c in p) for p in points]


def meeting_pairs(points, triangles):
    """Every pair (i, j), i < j, of triangles that meet beyond what they share. Bounding boxes are
    compared on the doubles themselves (exact: no arithmetic), closed, so touching boxes are kept."""
    exact = exact_points(points)
    boxes = []
    for t in triangles:
        corners = [points[v] for v in t]
        boxes.append(([min(c[k] for c in corners) for k in range(3)], [max(c[k] for c in corners) for k in range(3)]))
    pairs = []
    for i in range(len(triangles)):
        for j in range(i + 1, len(triangles)):
            (lo_i, hi_i), (lo_j, hi_j) = boxes[i], boxes[j]
            if any(lo_i[k] > hi_j[k] or lo_j[k] > hi_i[k] for k in range(3)):
                continue
            if triangles_meet(exact, list(triangles[i]), list(triangles[j])):
                pairs.append((i, j))
    return pairs


def meeting_faces(points, faces):
    """The pairs of faces (f, g), f <= g, that meet beyond what they share, for planar convex faces:
    each is fanned from its first corner (any split of such a face covers the same points)."""
    triangles, owner = [], []
    for f, face in enumerate(faces):
        for k in range(1, len(face) - 1):
            triangles.append((face[0], face[k], face[k + 1]))
            owner.append(f)
    return {(owner[i], owner[j]) for i, j in meeting_pairs(points, triangles)}

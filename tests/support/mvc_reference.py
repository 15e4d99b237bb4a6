"""An independent numpy transcription of mean value coordinates for closed triangle meshes: the
stable pseudo-code of Ju, Schaefer and Warren 2005 ("Mean value coordinates for closed triangular
meshes", section 3.3 and its figure), not the determinant form deformkit computes (Thiery, Memari,
Boubekeur 2018), and the polygon split docs/math/cage.md documents (shortest-diagonal ear cutting),
transcribed from the docs.

Ju's pseudo-code per point x and triangle (p_1, p_2, p_3), indices mod 3, u_i = (p_i - x) / d_i:
    theta_i = 2 asin(|u_i+1 - u_i-1| / 2),  h = (theta_1 + theta_2 + theta_3) / 2
    if pi - h < eps: x is on the triangle, return its barycentric coordinates
        (sin theta_i d_i-1 d_i+1, normalised)
    c_i = 2 sin h sin(h - theta_i) / (sin theta_i+1 sin theta_i-1) - 1
    s_i = sign(det[u_1, u_2, u_3]) sqrt(1 - c_i^2)
    if some |s_i| <= eps: x is in the triangle's plane beside it: skip the triangle
    w_i += (theta_i - c_i+1 theta_i-1 - c_i-1 theta_i+1) / (d_i sin theta_i+1 s_i-1)
then the weights are normalised to sum 1.

Two places of the pseudo-code lose precision in floating point, and the reference offers their
exact-arithmetic equivalents, chosen by argument:
- near a triangle's plane c_i tends to -1 or 1 and sqrt(1 - c_i^2) loses all but eps / s_i^2 of
  its relative accuracy; `sine="law_of_sines"` uses s_i = det[u_1, u_2, u_3] / (sin theta_i+1
  sin theta_i-1) instead (the spherical law of sines; the same value in exact arithmetic), whose
  rounding is a factor common to the triangle's three weights;
- near an edge theta tends to pi and asin(l / 2) loses precision (l / 2 near 1);
  `arc="atan2"` uses theta_i = 2 atan2(|u_i+1 - u_i-1|, |u_i+1 + u_i-1|), again the same value.
The arithmetic is numpy's long double (x87 extended, 64-bit mantissa on x86-64) by default:
float64 inputs are exact in it, and its rounding is 2^-11 of float64's."""
import numpy as np


def polygon_vector_area(points, ring):
    p = points[ring]
    return np.cross(p, np.roll(p, -1, axis=0)).sum(axis=0)


def _nondegenerate(a, b, c, tiny=1e-12):
    longest = max(np.dot(b - a, b - a), np.dot(c - b, c - b), np.dot(a - c, a - c))
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a)) > tiny * longest


def _holds(a, b, c, q, area):
    """q inside or on the triangle (a, b, c), seen along `area`."""
    return (np.dot(np.cross(b - a, q - a), area) >= 0 and np.dot(np.cross(c - b, q - b), area) >= 0
            and np.dot(np.cross(a - c, q - c), area) >= 0)


def split_polygon(points, face):
    """docs/math/cage.md, "Splitting polygons into triangles": cut ears, each time the one whose
    closing diagonal is shortest (ties: the smaller sorted vertex pair); each triangle starts at
    its smallest index; the polygon's triangles sorted."""
    ring = [int(v) for v in face]
    area = polygon_vector_area(points, ring)
    out = []
    while len(ring) > 3:
        n = len(ring)
        best = None
        for i in range(n):
            ia, ib, ic = ring[i - 1], ring[i], ring[(i + 1) % n]
            a, b, c = points[ia], points[ib], points[ic]
            if not _nondegenerate(a, b, c) or not np.dot(np.cross(b - a, c - b), area) > 0:
                continue
            if any(_holds(a, b, c, points[v], area) for v in ring if v not in (ia, ib, ic)):
                continue
            key = (float(np.dot(c - a, c - a)), min(ia, ic), max(ia, ic))
            if best is None or key < best[0]:
                best = (key, i)
        assert best is not None, f"face {face} has no ear"
        i = best[1]
        out.append((ring[i - 1], ring[i], ring[(i + 1) % n]))
        del ring[i]
    out.append(tuple(ring))
    rotated = []
    for t in out:
        k = int(np.argmin(t))
        rotated.append(t[k:] + t[:k])
    return sorted(rotated)


def split_cage(points, faces):
    """Every face split by the documented rule, in face order: (t, 3)."""
    return np.array([t for face in faces for t in split_polygon(points, face)], dtype=np.int64)


def mean_value_coordinates(cage, triangles, x, *, eps=1e-13, sine="law_of_sines", arc="atan2", dtype=np.longdouble):
    """Ju, Schaefer, Warren 2005's pseudo-code at the points x (n, 3): (n, m) weights, in float64.

    eps: Ju's epsilon, relative (distances to vertices relative to the cage's bounding-box
    diagonal; pi - h and |s_i| as they are)."""
    cage = np.asarray(cage, dtype=dtype)
    tri = np.asarray(triangles)
    x = np.asarray(x, dtype=dtype).reshape(-1, 3)
    scale = np.linalg.norm(np.ptp(np.asarray(cage, float), axis=0))
    pi = dtype(np.pi) if dtype is not np.longdouble else np.arccos(dtype(-1))
    out = np.zeros((len(x), len(cage)))
    for n, point in enumerate(x):
        e = cage - point
        d = np.sqrt((e * e).sum(axis=1))
        if d.min() < eps * scale:
            out[n, int(np.argmin(d))] = 1.0
            continue
        u = e / d[:, None]
        ut, dt = u[tri], d[tri]  # (t, 3, 3), (t, 3)
        nxt, prv = ut[:, [1, 2, 0]], ut[:, [2, 0, 1]]  # u_i+1, u_i-1
        chord = np.sqrt(((nxt - prv) ** 2).sum(axis=2))
        if arc == "atan2":
            theta = 2 * np.arctan2(chord, np.sqrt(((nxt + prv) ** 2).sum(axis=2)))
        else:
            theta = 2 * np.arcsin(np.minimum(chord / 2, dtype(1)))
        h = theta.sum(axis=1) / 2
        on = np.flatnonzero(pi - h < eps)
        if len(on):  # on a triangle: its barycentric coordinates
            k = on[0]
            w = np.sin(theta[k]) * dt[k, [2, 0, 1]] * dt[k, [1, 2, 0]]
            out[n, tri[k]] = (w / w.sum()).astype(float)
            continue
        sin_t = np.sin(theta)
        sin_next, sin_prev = sin_t[:, [1, 2, 0]], sin_t[:, [2, 0, 1]]
        c = 2 * np.sin(h)[:, None] * np.sin(h[:, None] - theta) / (sin_next * sin_prev) - 1
        det = np.einsum("ti,ti->t", ut[:, 0], np.cross(ut[:, 1], ut[:, 2]))
        if sine == "law_of_sines":
            s = det[:, None] / (sin_next * sin_prev)
        else:
            s = np.sign(det)[:, None] * np.sqrt(np.maximum(1 - c * c, 0))
        keep = np.all(np.abs(s) > eps, axis=1)  # else x is in the plane beside the triangle
        c_next, c_prev = c[:, [1, 2, 0]], c[:, [2, 0, 1]]
        t_next, t_prev = theta[:, [1, 2, 0]], theta[:, [2, 0, 1]]
        s_prev = s[:, [2, 0, 1]]
        w = (theta - c_next * t_prev - c_prev * t_next) / (dt * sin_next * s_prev)
        total = np.zeros(len(cage), dtype=dtype)
        np.add.at(total, tri[keep].ravel(), w[keep].ravel())
        out[n] = (total / total.sum()).astype(float)
    return out

"""Thin triangles in dk.DeformationTransfer, generated: a corner moved onto (or near) its opposite
edge, at every scale from a well-shaped triangle down to one whose area is rounding. A triangle whose
area is under 1e-8 of its longest edge squared is refused, naming the mesh and the triangle; every
mesh accepted transfers its rest pose onto the target rest exactly and a twist to finite positions
(docs/math/transfer.md, "Thin triangles")."""
import numpy as np
import pytest

import deformkit as dk
from support.helpers import random_frame
from support.subdivision_meshes import grid

THINNEST = 1e-8


def shapes(points, triangles):
    """Area over longest edge squared, per triangle, in numpy (edges scaled to 1 first)."""
    a, b, c = (points[triangles[:, k]] for k in range(3))
    e = np.stack([b - a, c - b, a - c], 1)
    scale = np.abs(e).max(axis=(1, 2))[:, None, None]
    e = e / np.where(scale > 0, scale, 1)
    area = 0.5 * np.linalg.norm(np.cross(e[:, 0], -e[:, 2]), axis=1)
    return area / (e ** 2).sum(2).max(1)


def twist(points):
    centre = points.mean(0)
    p = points - centre
    size = np.abs(p).max()
    angle = 1.5 * p[:, 2] / size + 0.4 * p[:, 0] / size
    c, s = np.cos(angle), np.sin(angle)
    return centre + np.c_[c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1], p[:, 2]]


def thinned(points, triangles, rng):
    """points with one triangle's corner moved to its opposite edge, off it by 10^-u of the edge (u up
    to 17, or exactly on the line's rounded point)."""
    out = points.copy()
    j, corner = rng.integers(len(triangles)), rng.integers(3)
    v, a, b = (triangles[j][(corner + k) % 3] for k in range(3))
    edge = out[b] - out[a]
    side = np.cross(edge, rng.normal(size=3))
    side *= np.linalg.norm(edge) / np.linalg.norm(side)
    u = rng.choice([np.inf, *range(0, 18)])
    out[v] = out[a] + rng.uniform(0.2, 0.8) * edge + (0.0 if np.isinf(u) else 10.0 ** -u) * side
    return out


def case(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(3, 6))
    p, quads = grid(n, bump=0.3)
    triangles = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    frame = random_frame(rng)
    scale = 10.0 ** rng.uniform(-3, 3)
    source = (p / n) @ frame[:3, :3].T * scale + rng.normal(size=3) * scale
    target = source * [1.3, 0.8, 1.1] + 0.1 * scale * np.sin(3 * source[:, [1, 2, 0]] / scale)
    which = rng.choice(["source", "target"])
    while True:  # no triangle so near the threshold that rounding of its shape could decide
        moved = thinned(source if which == "source" else target, triangles, rng)
        q = shapes(moved, triangles)
        if not np.any((q > THINNEST / 4) & (q < THINNEST * 4)):
            break
    source, target = (moved, target) if which == "source" else (source, moved)
    unlike = bool(rng.integers(2))
    return source, target, triangles, which, unlike


@pytest.mark.parametrize("seed", range(60))
def test_thin_triangles_are_refused_by_name_and_the_rest_pose_lands_on_the_target_rest(seed):
    source, target, triangles, which, unlike = case(seed)
    q = shapes(source if which == "source" else target, triangles)
    # Unlike meshes: the target's own faces (the same triangles listed backwards) and four markers.
    kwargs = {"markers": ([0, 1, 2, 3], [0, 1, 2, 3])} if unlike else {}
    target_faces = triangles[::-1].copy() if unlike else None
    thin = np.flatnonzero(q < THINNEST)
    if len(thin):
        j = thin[0]
        tri = triangles[::-1] if which == "target" and unlike else triangles
        if which == "target" and unlike:
            j = np.flatnonzero(shapes(target, tri) < THINNEST)[0]
        v = tri[j]
        with pytest.raises(ValueError, match=rf"^{which}_faces: triangle {j} \(vertices {v[0]}, {v[1]}, {v[2]}\) "
                                             r"(has zero area|is a sliver: its area is \S+ of its longest edge squared)"):
            dk.DeformationTransfer(source, triangles, target, target_faces, **kwargs)
        return
    dt = dk.DeformationTransfer(source, triangles, target, target_faces, **kwargs)
    assert np.array_equal(dt.transfer(source), target)  # docs/transfer.md: "exactly"
    assert np.isfinite(dt.transfer(twist(source))).all()


def test_the_generated_cases_cover_refused_and_accepted_meshes_of_both_sides():
    """The parametrised cases above are not all one kind."""
    kinds = set()
    for seed in range(60):
        source, target, triangles, which, unlike = case(seed)
        thin = shapes(source if which == "source" else target, triangles).min() < THINNEST
        kinds.add((which, thin, unlike))
    assert len(kinds) == 8, kinds

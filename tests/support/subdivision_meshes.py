"""Small control meshes for the subdivision tests, built here so the tests need no files."""
import numpy as np

CUBE_POINTS = np.array([[x, y, z] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)], float)
CUBE_FACES = np.array([[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]])
OCTAHEDRON_POINTS = np.array([[1, 0, 0], [-1, 0, 0], [0, 1.2, 0], [0, -1, 0], [0, 0, 0.8], [0, 0, -1]], float)
OCTAHEDRON_FACES = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])


def grid(n=4, m=None, bump=0.0):
    """An open n x m grid of quads in z = 0 (bumped), vertices row by row."""
    m = n if m is None else m
    j, i = np.mgrid[0:m + 1, 0:n + 1]
    points = np.c_[i.ravel(), j.ravel(), bump * np.sin(i.ravel() + 2.0 * j.ravel())].astype(float)
    k = np.arange((n + 1) * m).reshape(m, n + 1)[:, :n].ravel()
    return points, np.c_[k, k + 1, k + n + 2, k + n + 1]


def prism(sides=5):
    """A closed prism: two n-gons (split into sub-quads by Catmull-Clark) and n quads."""
    a = 2 * np.pi * np.arange(sides) / sides
    points = np.r_[np.c_[np.cos(a), np.sin(a), np.zeros(sides)], np.c_[1.2 * np.cos(a), np.sin(a), np.full(sides, 1.5)]]
    faces = [list(range(sides))[::-1], list(range(sides, 2 * sides))]
    faces += [[i, (i + 1) % sides, sides + (i + 1) % sides, sides + i] for i in range(sides)]
    return points, faces


def sphere(level=3, radius=0.5, center=(0, 0, 0)):
    """A cube cage subdivided `level` times and projected to a sphere: all quads, smooth."""
    import deformkit as dk
    m = dk.subdivide(CUBE_POINTS, CUBE_FACES, level)
    return m.points / np.linalg.norm(m.points, axis=1)[:, None] * radius + center, m.faces


def edges_of(faces):
    """Undirected edges (a < b) of polygons, sorted, and how many faces use each."""
    pairs = np.array([(f[i], f[(i + 1) % len(f)]) for f in faces for i in range(len(f))])
    return np.unique(np.sort(pairs, axis=1), axis=0, return_counts=True)


def signed_volume(points, faces):
    tri = np.array([[f[0], f[i], f[i + 1]] for f in faces for i in range(1, len(f) - 1)])
    a, b, c = points[tri[:, 0]], points[tri[:, 1]], points[tri[:, 2]]
    return np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6

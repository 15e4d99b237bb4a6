"""The shared cages of ../shared/cages (Thiery, Memari, Boubekeur 2018's models): each cage's
polygons as the OBJ lists them, and the winding number that tells the model's vertices inside it."""
import pathlib

import numpy as np
import pytest

CAGES = pathlib.Path(__file__).resolve().parents[2].parent / "shared" / "cages"
MODELS = ["Beast", "Bench", "Cactus", "FireHydrant", "ManHead", "Ogre", "SpikyBox", "WireSphere"]


def require_cages():
    if not CAGES.is_dir():
        pytest.skip(f"{CAGES} not found: the shared cages are not beside this checkout")


def read_polygons(path):
    """Vertices and polygons of an OBJ file. trimesh (the project's mesh reader) triangulates quads
    on load, which would replace the cage's own split rule, so the `f` lines are read as they are."""
    points, faces = [], []
    for line in path.read_text().splitlines():
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v":
            points.append([float(v) for v in parts[1:4]])
        elif parts[0] == "f":
            faces.append([int(c.split("/")[0]) - 1 for c in parts[1:]])
    return np.array(points), faces


def load_mesh(name):
    import trimesh  # noqa: PLC0415
    return trimesh.load(CAGES / f"{name}.obj", process=False, force="mesh")


def winding_numbers(points, vertices, triangles, chunk=2048):
    """Sum over the triangles of their solid angle at each point over 4 pi (Van Oosterom and Strackee
    1983: tan(omega / 2) = det[a, b, c] / (abc + (a.b) c + (b.c) a + (c.a) b)): 1 inside a closed
    outward mesh, 0 outside."""
    out = np.empty(len(points))
    tri = vertices[triangles]
    for s in range(0, len(points), chunk):
        e = tri[None] - points[s:s + chunk, None, None]  # (k, t, 3, 3)
        a, b, c = e[:, :, 0], e[:, :, 1], e[:, :, 2]
        la, lb, lc = (np.linalg.norm(v, axis=2) for v in (a, b, c))
        det = np.einsum("kti,kti->kt", a, np.cross(b, c))
        den = la * lb * lc + (a * b).sum(2) * lc + (b * c).sum(2) * la + (c * a).sum(2) * lb
        out[s:s + chunk] = 2 * np.arctan2(det, den).sum(axis=1) / (4 * np.pi)
    return out

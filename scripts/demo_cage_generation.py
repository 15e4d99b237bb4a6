"""A cage made by deformkit around a real mesh, and the mesh deformed by it.

    .venv/bin/python scripts/demo_cage_generation.py --out demo_out/cage_generation [--max-faces 120]

With ../shared/meshes present: Homer (12,000 triangles); without it a built-in torus stands in.
dk.generate_cage makes the cage (docs/cage.md, "Generated cages"); the cage's upper half is then
bent forward and dk.GreenCage carries the mesh with it. Writes <out>/cage_generation.png (the mesh,
its cage, the bent cage, the bent mesh) and prints the time, the cage's faces, its volume over the
mesh's, and that every vertex is inside it (winding numbers).
"""
import argparse
import pathlib
import time

import numpy as np

import deformkit as dk
from deformkit.preview import AFTER_COLOR, BEFORE_COLOR, render_panels

ROOT = pathlib.Path(__file__).resolve().parent.parent
MESH = (ROOT.parent / "shared" / "meshes" / "homer.obj").resolve()
CAGE_COLOR = (0.55, 0.65, 0.85)


def mesh_or_torus():
    if MESH.is_file():
        import trimesh
        mesh = trimesh.load(MESH, process=False, force="mesh")
        return "Homer", np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64)
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 48, endpoint=False), np.linspace(0, 2 * np.pi, 24, endpoint=False))
    pts = np.column_stack([((1 + 0.35 * np.cos(v)) * np.cos(u)).ravel(), (0.35 * np.sin(v)).ravel(),
                           ((1 + 0.35 * np.cos(v)) * np.sin(u)).ravel()])
    n, m = 48, 24
    idx = lambda i, j: (j % m) * n + (i % n)  # noqa: E731
    faces = [[idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)] for i in range(n) for j in range(m)]
    faces += [[idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)] for i in range(n) for j in range(m)]
    return "a torus", pts, np.array(faces)


def winding_numbers(points, vertices, triangles):
    """The solid angle of the cage at each point over 4 pi (Van Oosterom and Strackee 1983): 1 inside."""
    out = np.empty(len(points))
    for s in range(0, len(points), 512):
        e = vertices[triangles][None] - points[s:s + 512, None, None]
        a, b, c = e[:, :, 0], e[:, :, 1], e[:, :, 2]
        la, lb, lc = (np.linalg.norm(x, axis=2) for x in (a, b, c))
        det = np.einsum("kti,kti->kt", a, np.cross(b, c))
        den = la * lb * lc + (a * b).sum(2) * lc + (b * c).sum(2) * la + (c * a).sum(2) * lb
        out[s:s + 512] = 2 * np.arctan2(det, den).sum(axis=1) / (4 * np.pi)
    return out


def bent(points, lo, hi, degrees=35.0):
    """The part above the middle (y up) turned about x, by an angle growing from 0 to `degrees`."""
    mid = (lo + hi) / 2
    t = np.clip((points[:, 1] - mid) / (hi - mid), 0, 1)
    a = np.radians(degrees) * t
    y, z = points[:, 1] - mid, points[:, 2]
    out = points.copy()
    out[:, 1] = mid + np.cos(a) * y - np.sin(a) * z
    out[:, 2] = np.sin(a) * y + np.cos(a) * z
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="demo_out/cage_generation")
    parser.add_argument("--max-faces", type=int, default=120)
    args = parser.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    name, points, faces = mesh_or_torus()
    start = time.perf_counter()
    cage_points, cage_faces = dk.generate_cage(points, faces, max_faces=args.max_faces)
    seconds = time.perf_counter() - start
    inside = winding_numbers(points, cage_points, cage_faces)
    ratio = dk.mesh_volume(cage_points, cage_faces) / dk.mesh_volume(points, faces)
    print(f"{name}: {len(faces):,} triangles; cage of {len(cage_faces)} faces in {seconds:.2f} s, "
          f"volume {ratio:.2f} x the mesh's, {int(np.sum(inside > 0.5)):,} of {len(points):,} vertices inside")
    lo, hi = cage_points[:, 1].min(), cage_points[:, 1].max()
    moved_cage = bent(cage_points, lo, hi)
    cage = dk.GreenCage(cage_points, cage_faces)
    binding = cage.bind(points)
    cage.cage_points = moved_cage
    moved = cage.deform_bound(binding)
    path = out / "cage_generation.png"
    render_panels(path, [points, cage_points, moved_cage, moved], faces,
                  f"dk.generate_cage around {name} ({len(cage_faces)} faces, {seconds:.2f} s), "
                  f"then the cage bent and the mesh following it (GreenCage)",
                  ["the mesh", f"its generated cage ({len(cage_faces)} faces)", "the cage bent", "the mesh, deformed"],
                  panel_faces=[None, cage_faces, cage_faces, None],
                  colors=[BEFORE_COLOR, CAGE_COLOR, CAGE_COLOR, AFTER_COLOR], azim=-30.0)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()

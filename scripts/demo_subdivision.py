"""Subdivide a deformed control mesh with OpenSubdiv and check that its limit surface is smooth.

    .venv/bin/python scripts/demo_subdivision.py --out demo_out/subdivision [--mesh PATH] [--level N]

The cage is ../shared/meshes/beast.obj (quads) when present, else a built-in cage (a cube
subdivided twice and waisted). It is twisted about its longest axis, then Catmull-Clark
subdivided; <out>/<name>_twist_subdivided.obj and .png (cage before, subdivided after) are written,
and <out>/smoothness.json holds the reports: the twisted cage's limit surface (G1), the same with
edges across the middle tagged infinitely sharp (a crease), and the built-in cage's limit surface
bent by Barr's bend and not bent (the bend's crease where its region ends).
"""
import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
import trimesh

import deformkit as dk
from deformkit.preview import atomic_write, render_before_after

ROOT = Path(__file__).resolve().parent.parent
SHARED = (ROOT.parent / "shared").resolve()
CUBE = (np.array([[x, y, z] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)], float),
        [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]])


def builtin_cage():
    """A cube subdivided twice and waisted a little: a smooth, not round, all-quad cage."""
    m = dk.subdivide(*CUBE, 2)
    return m.points * (1.0 + 0.15 * np.cos(3 * m.points[:, [2]])), m.faces


def load_cage(path):
    """(points, faces as a list of polygons, name, note); polygons kept as they are in the file."""
    if path is None and (SHARED / "meshes" / "beast.obj").is_file():
        path = SHARED / "meshes" / "beast.obj"
    if path is not None:
        loaded = trimesh.load(path, process=False, force="mesh", maintain_order=True, skip_materials=True)
        polygons = _obj_polygons(Path(path)) if str(path).endswith(".obj") else loaded.faces.tolist()
        return np.asarray(loaded.vertices, float), polygons, Path(path).stem, None
    points, faces = builtin_cage()
    return points, faces, "cube", f"{SHARED / 'meshes'} not found: using a built-in cage"


def _obj_polygons(path):
    """The OBJ's faces as written (trimesh would triangulate them)."""
    faces = []
    for line in path.read_text().splitlines():
        if line.startswith("f "):
            faces.append([int(t.split("/")[0]) - 1 for t in line.split()[1:]])
    return faces


def triangles(faces):
    return np.array([[f[0], f[i], f[i + 1]] for f in faces for i in range(1, len(f) - 1)])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="demo_out/subdivision")
    ap.add_argument("--mesh", help="a polygon cage instead of ../shared/meshes/beast.obj")
    ap.add_argument("--level", type=int, default=2)
    args = ap.parse_args()
    out = Path(args.out).resolve()
    if out == SHARED or SHARED in out.parents:
        sys.exit(f"demo: refusing to write into {SHARED}; choose another --out")
    out.mkdir(parents=True, exist_ok=True)
    points, faces, name, note = load_cage(args.mesh)
    if note:
        print("note:", note)
    lo, hi = points.min(axis=0), points.max(axis=0)
    axis = int(np.argmax(hi - lo))
    frame = np.eye(4)
    frame[:3, :3] = np.roll(np.eye(3), 2 - axis, axis=1)  # the twist axis (local z) = the longest axis
    frame[:3, 3] = (lo + hi) / 2
    twist = dk.Twist(rate=math.radians(120) / (hi - lo)[axis], frame=frame)
    cage = twist.deform(points)

    t0 = time.perf_counter()
    sub = dk.subdivide(cage, faces, args.level)
    t_sub = time.perf_counter() - t0
    t0 = time.perf_counter()
    smooth = dk.smoothness_report(cage, faces, reference=points)
    t_check = time.perf_counter() - t0
    loop = [e for e in dk.smoothness_report(points, faces, worst=0).edges.tolist()
            if abs(points[e[0], axis] - points[e[1], axis]) < 1e-9 * (hi - lo)[axis]
            and abs(points[e[0], axis] - np.median(points[:, axis])) < 0.1 * (hi - lo)[axis]][:64]
    creased = dk.smoothness_report(cage, faces, creases=(np.array(loop).reshape(-1, 2), np.full(len(loop), 10.0)))
    # The bend's crease lives in F(S), the rest surface bent (subdivide, then deform); on the
    # built-in cage, whose own limit surface has no near-singular points to mask it.
    round_points, round_faces = builtin_cage()
    bend = dk.Bend(curvature=0.5, region=(-0.4, 0.4))
    bent = dk.smoothness_report(round_points, round_faces, deformer=bend)
    unbent = dk.smoothness_report(round_points, round_faces, deformer=dk.Twist(rate=0.0))

    stem = f"{name}_twist_subdivided"
    mesh = trimesh.Trimesh(sub.points, triangles(sub.faces), process=False)
    text = trimesh.exchange.obj.export_obj(mesh, include_normals=False, include_texture=False,
                                           header=f"deformkit demo: {name} twisted, Catmull-Clark level {args.level}")
    atomic_write(out / f"{stem}.obj", lambda fh: fh.write(text.encode()))
    render_before_after(out / f"{stem}.png", points, sub.points, triangles(faces),
                        f"{name}: twist 120 deg, then OpenSubdiv level {args.level}",
                        (f"cage ({len(points):,} vertices)", f"subdivided ({len(sub.points):,} vertices)"),
                        after_faces=triangles(sub.faces))
    reports = {"twisted_cage": smooth.to_dict(), "twisted_cage_with_sharp_loop": creased.to_dict(),
               "builtin_cage_bent": bent.to_dict(), "builtin_cage_not_bent": unbent.to_dict(),
               "sharp_loop_edges": len(loop)}
    atomic_write(out / "smoothness.json", lambda fh: fh.write(json.dumps(reports, indent=1).encode()))
    deg = math.degrees
    print(f"cage:        {name}: {len(points):,} vertices, {len(faces):,} faces")
    print(f"subdivide:   level {args.level}: {len(sub.points):,} vertices, {len(sub.faces):,} quads in {t_sub:.2f} s")
    print(f"twisted:     max normal angle {smooth.max_angle:.2e} rad, max gap {smooth.max_gap:.1e} "
          f"({smooth.sample_count:,} samples, {t_check:.2f} s), {smooth.flipped_samples} flipped, "
          f"{smooth.degenerate_samples} degenerate")
    print(f"sharp loop:  {len(loop)} edges tagged sharpness 10: max normal angle {deg(creased.max_angle):.1f} deg")
    y = round_points[np.asarray(round_faces)[bent.worst_faces[0]], 1]
    print(f"bend crease: built-in cage, Bend(curvature=0.5, region=(-0.4, 0.4)) after subdividing: max normal "
          f"jump inside a face {deg(bent.max_crease):.1f} deg (face across y = {y.min():.2f}..{y.max():.2f}); "
          f"not bent {deg(unbent.max_crease):.2f} deg")
    print(f"wrote:       {out / (stem + '.obj')}\n             {out / (stem + '.png')}\n             {out / 'smoothness.json'}")


if __name__ == "__main__":
    main()

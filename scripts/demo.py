"""Deform a real mesh with a twist followed by a bend, headlessly, and show the result.

    .venv/bin/python scripts/demo.py --out demo_out [--mesh PATH]

Writes <out>/<name>_twist_bend.obj (deformed positions, normals carried through the map by
transform_normals, same vertex order as loaded) and <out>/<name>_twist_bend.png (before and after
side by side), and prints a summary. Then a lattice: a B-spline lattice fitted to the mesh whose
control points are solved by direct manipulation so that the top vertex leans sideways while the
bottom stays put, written as <out>/<name>_lattice.obj and .png. Then a cage: a box cage around the
mesh whose upper part is turned and widened, the mesh deformed by mean value and by Green coordinates,
side by side in <out>/<name>_cage.png. Then RBF (the RBF note's noise-driven variants): a few dozen
of the mesh's vertices as controls moved by smooth noise, four seeds, thin plate spline, and one
Wendland C2 variant that moves the top only, its far part staying put, in <out>/<name>_rbf.png.
The mesh defaults to ../shared/meshes/ogre.obj (else spot.obj)
from the repository root; without that folder a subdivided square bar is generated instead.
"""
import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
import trimesh

import deformkit as dk
from deformkit.preview import AFTER_COLOR, BEFORE_COLOR, Y_UP, atomic_write, render_before_after, render_panels

ROOT = Path(__file__).resolve().parent.parent
SHARED = (ROOT.parent / "shared").resolve()
MESHES = SHARED / "meshes"
PREFERRED = ("ogre.obj", "spot.obj")  # the ogre shows a twist and a bend best
TWIST_DEG, BEND_DEG = 90.0, 100.0  # over the mesh's length; the bend is capped to avoid folds
MIN_DET = 0.35  # the bend's curvature is limited so that det J = 1 - k z stays above this


def load_mesh(path):
    """(mesh, path or name, note). process=False keeps the file's vertices and their order."""
    if path is not None:
        return trimesh.load(path, process=False, force="mesh"), Path(path), None
    for name in PREFERRED:
        if (MESHES / name).is_file():
            return trimesh.load(MESHES / name, process=False, force="mesh"), MESHES / name, None
    # No shared meshes (a fresh clone): a square bar along y, finely subdivided so it bends smoothly.
    bar = trimesh.creation.box(extents=(0.5, 3.0, 0.5))
    for _ in range(5):
        bar = bar.subdivide()
    return bar, Path("bar"), f"{MESHES} not found: using a generated bar (trimesh.creation.box, subdivided 5 times)"


def welded(mesh):
    """Positions merged across UV seams: for closedness, volume and smooth normals."""
    uniq, inverse = np.unique(mesh.vertices, axis=0, return_inverse=True)
    return trimesh.Trimesh(uniq, inverse.reshape(-1)[mesh.faces], process=False), inverse.reshape(-1)


def welded_positions(moved, weld, count):
    """Deformed positions of the welded mesh's vertices (all copies of a vertex move alike)."""
    pos = np.empty((count, 3))
    pos[weld] = moved
    return pos


def vertex_normals(mesh):
    """trimesh's angle-weighted vertex normals (Trimesh.vertex_normals), summed with numpy: without
    scipy (not in the project's requirements) trimesh falls back to a loop that is O(vertices * faces)."""
    acc = np.zeros((len(mesh.vertices), 3))
    np.add.at(acc, mesh.faces, mesh.face_angles[:, :, None] * mesh.face_normals[:, None, :])
    return acc / np.maximum(np.linalg.norm(acc, axis=1, keepdims=True), 1e-300)


def placement(vertices):
    """Frame at the bounding-box centre: local y = the longest axis (twist and bend length), local z =
    the bend direction (up, y, unless y is the longest axis; then the thinner of the other two)."""
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    ext = hi - lo
    a = int(np.argmax(ext))
    b = 1 if a != 1 else min((i for i in range(3) if i != a), key=lambda i: ext[i])
    c = 3 - a - b
    cols = np.eye(3)[:, [c, a, b]]
    if np.linalg.det(cols) < 0:
        cols[:, 0] *= -1
    frame = np.eye(4)
    frame[:3, :3], frame[:3, 3] = cols, (lo + hi) / 2
    return frame, a, b, ext[a] / 2


def camera(frame):
    """Elevation and azimuth of a three-quarter view: mostly along the bend's kept axis (where the
    bend shows best), turned toward the front (+z in OBJ's convention, else the bend direction)
    and a little from above (+y)."""
    c, b = np.abs(frame[:3, 0]), frame[:3, 2]
    v = c + 0.6 * (np.array([0, 0, 1.0]) if c[2] < 0.5 else b) + 0.4 * np.array([0, 1.0, 0]) * (c[1] < 0.5)
    v = Y_UP @ (v / np.linalg.norm(v))
    return math.degrees(math.asin(v[2])), math.degrees(math.atan2(v[1], v[0]))


def build_stack(vertices):
    """Twist about the long axis, then bend along it, both over the whole length (local y in +-h)."""
    frame, long_axis, bend_axis, h = placement(vertices)
    rate = math.radians(TWIST_DEG) / (2 * h)
    twist = dk.Twist(rate=rate, axis="y", limits=(-h, h), frame=frame)
    # Bend (axis='x': keeps local x, bends local y toward local z). det J = 1 - k z, so the largest
    # local z of the twisted points bounds the curvature before the surface would fold over.
    z_top = ((twist.deform(vertices) - frame[:3, 3]) @ frame[:3, 2]).max()
    k = min(math.radians(BEND_DEG) / (2 * h), (1 - MIN_DET) / max(z_top, 1e-12))
    bend = dk.Bend(curvature=k, center=0.0, region=(-h, h), axis="x", frame=frame)
    pm, deg = "\N{PLUS-MINUS SIGN}", "\N{DEGREE SIGN}"
    desc = (f"Twist {TWIST_DEG:.0f}{deg} about {'xyz'[long_axis]} (rate {rate:.3g}/unit, limits {pm}{h:.3g}) "
            f"then Bend {math.degrees(2 * h * k):.0f}{deg} toward +{'xyz'[bend_axis]} "
            f"(curvature {k:.3g}, radius {1 / k:.3g}, region {pm}{h:.3g})")
    return dk.Stack([twist, bend]), desc, frame


def lattice_demo(points, mesh, solid, weld, out, stem, name):
    """Direct manipulation of a B-spline lattice: lean the top of the mesh, pin its bottom."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    pad = 0.02 * (hi - lo)
    lat = dk.BSplineLattice(6, origin=lo - 2 * pad, edges=np.diag(hi - lo + 4 * pad))
    up = 1  # OBJ convention: +y is up
    side = 0 if np.ptp(points[:, 0]) >= np.ptp(points[:, 2]) else 2
    top = points[np.argsort(points[:, up])[-20:]]
    bottom = points[np.argsort(points[:, up])[:200]]
    lean = np.zeros(3)
    lean[side] = 0.3 * np.ptp(points[:, up])
    handles, targets = np.vstack([top, bottom]), np.vstack([top + lean, bottom])
    solved = lat.direct_manipulation(handles, targets)
    lat.control_points = solved.control_points
    t0 = time.perf_counter()
    binding = lat.bind(points)
    t_bind = time.perf_counter() - t0
    t0 = time.perf_counter()
    moved = lat.deform_bound(binding)
    t_deform = time.perf_counter() - t0
    ratio = lat.volume_ratio(points)
    result = trimesh.Trimesh(moved, mesh.faces, process=False)
    obj_path, png_path = out / f"{stem}_lattice.obj", out / f"{stem}_lattice.png"
    text = trimesh.exchange.obj.export_obj(result, include_normals=False, include_texture=False,
                                           header="deformkit demo: B-spline lattice, direct manipulation")
    atomic_write(obj_path, lambda fh: fh.write(text.encode()))
    render_before_after(png_path, points, moved, mesh.faces,
                        "deformkit BSplineLattice 6x6x6, control points by direct manipulation",
                        (f"before: {name}", f"after: top leans {'xyz'[side]}, bottom pinned"), 15.0, -60.0)
    after = trimesh.Trimesh(welded_positions(moved, weld, len(solid.vertices)), solid.faces, process=False)
    top_err = np.linalg.norm(lat.deform(top) - (top + lean), axis=1).max()
    print(f"lattice:       BSplineLattice 6x6x6 on the bounding box; direct manipulation of {len(handles)} "
          f"points (rank {solved.rank}): top moved to within {top_err:.2e}, largest residual "
          f"{solved.max_residual:.2e} (least squares: pinned and moved points share control points)")
    print(f"               bind {t_bind * 1e3:.2f} ms, deform_bound {t_deform * 1e3:.2f} ms; det J min "
          f"{ratio.min():.3f}, max {ratio.max():.3f}; volume x{after.volume / solid.volume:.4f}")
    print(f"wrote:         {obj_path}\n               {png_path}")


def box_cage(lo, hi, n=2):
    """A closed box of n x n quads per side, faces outward: (points, quads)."""
    t = np.linspace(0.0, 1.0, n + 1)
    points, faces, index = [], [], {}

    def vertex(p):
        key = tuple(np.round(p, 12))
        if key not in index:
            index[key] = len(points)
            points.append(p)
        return index[key]
    for axis in range(3):
        for side in (0.0, 1.0):
            u, v = [a for a in range(3) if a != axis]
            if side == 0.0:
                u, v = v, u  # keep the faces outward on both sides
            for i in range(n):
                for j in range(n):
                    corners = []
                    for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        p = np.empty(3)
                        p[axis], p[u], p[v] = side, t[i + di], t[j + dj]
                        corners.append(vertex(lo + p * (hi - lo)))
                    faces.append(corners if axis != 1 else corners[::-1])
    return np.array(points), np.array(faces)


def cage_demo(points, mesh, out, stem, name):
    """A box cage turned and widened at the top: mean value vs Green coordinates."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    pad = 0.05 * (hi - lo)
    rest, quads = box_cage(lo - pad, hi + pad)
    up = 1  # OBJ convention: +y is up
    height = (rest[:, up] - rest[:, up].min()) / np.ptp(rest[:, up])
    center = (lo + hi) / 2
    angle = np.radians(35.0) * height
    c, s_ = np.cos(angle), np.sin(angle)
    rel = rest - center
    moved = rest.copy()
    moved[:, 0] = center[0] + (1 + 0.4 * height) * (c * rel[:, 0] - s_ * rel[:, 2])
    moved[:, 2] = center[2] + (1 + 0.4 * height) * (s_ * rel[:, 0] + c * rel[:, 2])
    results, lines = {}, []
    for label, kind in (("mean value", dk.MeanValueCage), ("Green", dk.GreenCage)):
        cage = kind(rest, quads)
        if cage.flipped:
            raise SystemExit("demo: the box cage came out inward")
        t0 = time.perf_counter()
        binding = cage.bind(points)
        t_bind = time.perf_counter() - t0
        cage.cage_points = moved
        t0 = time.perf_counter()
        results[label] = cage.deform_bound(binding)
        t_deform = time.perf_counter() - t0
        lines.append(f"{label}: bind {t_bind:.2f} s, deform_bound {t_deform * 1e3:.2f} ms, "
                     f"mean angle change {angle_change(points, results[label], mesh.faces):.2f} deg")
    png_path = out / f"{stem}_cage.png"
    render_before_after(png_path, results["mean value"], results["Green"], mesh.faces,
                        f"deformkit cage of {len(rest)} vertices, top turned 35 deg and widened 40%",
                        (f"MeanValueCage: {name}", "GreenCage (quasi-conformal)"), 15.0, -60.0)
    print("cage:          " + "\n               ".join(lines))
    print(f"wrote:         {png_path}")


def farthest_points(points, count, seed):
    """Indices of `count` points, each the farthest from those before: spread-out controls, no two
    nearly coinciding (which would make the RBF system ill-conditioned, docs/math/rbf.md, "Conditioning")."""
    index = [int(np.random.default_rng(seed).integers(len(points)))]
    dist = np.linalg.norm(points - points[index[0]], axis=1)
    for _ in range(count - 1):
        index.append(int(np.argmax(dist)))
        dist = np.minimum(dist, np.linalg.norm(points - points[index[-1]], axis=1))
    return np.array(index)


def smooth_noise(points, amplitude, wavelength, seed, modes=6):
    """A smooth random displacement field at `points`: a sum of plane waves of about `wavelength`
    in random directions and phases, each coordinate its own sum, scaled to an RMS of `amplitude`."""
    rng = np.random.default_rng(seed)
    directions = rng.normal(size=(3, modes, 3))
    k = 2 * np.pi / wavelength * directions / np.linalg.norm(directions, axis=2, keepdims=True)
    phase = rng.uniform(0, 2 * np.pi, (3, modes))
    field = np.stack([np.sin(points @ k[c].T + phase[c]).sum(1) for c in range(3)], axis=1)
    return amplitude * field / np.sqrt((field ** 2).mean())


RBF_CONTROLS, RBF_VARIANTS = 40, 4
COMPACT_COLOR = (0.45, 0.75, 0.5)  # the vertices the compact variant moves


def rbf_demo(points, mesh, out, stem, name):
    """The RBF note's variants: controls moved by smooth noise (thin plate spline, four seeds), and a
    Wendland C2 variant that moves the top's controls only, so the far part stays put bit for bit."""
    up = 1  # OBJ convention: +y is up
    height = float(np.ptp(points[:, up]))
    controls = points[farthest_points(points, RBF_CONTROLS, seed=5)]
    variants, lines = [], []
    for seed in range(1, RBF_VARIANTS + 1):
        targets = controls + smooth_noise(controls, 0.04 * height, 0.8 * height, seed)
        t0 = time.perf_counter()
        rbf = dk.RBF(controls, targets, kernel="thin_plate_spline")
        t_fit = time.perf_counter() - t0
        t0 = time.perf_counter()
        variants.append(rbf.deform(points))
        t_deform = time.perf_counter() - t0
        landed = float(np.abs(rbf.deform(controls) - targets).max())
        lines.append(f"seed {seed}: fit {t_fit * 1e3:.2f} ms, deform {t_deform * 1e3:.2f} ms, controls on their "
                     f"targets to {landed:.1e}")
    # Compact support: the controls of the top fifth only (no polynomial, degree -1), so a vertex
    # farther than the radius from all of them cannot move (docs/rbf.md, "Compact kernels").
    top = points[points[:, up] > points[:, up].max() - 0.2 * height]
    head = top[farthest_points(top, RBF_CONTROLS, seed=6)]
    radius = 0.15 * height
    head_targets = head + smooth_noise(head, 0.03 * height, 0.3 * height, seed=7)
    compact = dk.RBF(head, head_targets, kernel="wendland_c2", radius=radius, degree=-1)
    local = compact.deform(points)
    still = np.all(local == points, axis=1)
    far = (np.linalg.norm(points[:, None, :] - head[None], axis=2) >= radius).all(axis=1)
    if not still[far].all():
        raise SystemExit("demo: a vertex beyond the Wendland kernel's support moved")
    lines.append(f"wendland_c2 (radius {radius:.3g}, {len(head)} controls in the top fifth, degree -1): "
                 f"{still.sum():,} of {len(points):,} vertices unmoved bit for bit, all {far.sum():,} beyond the "
                 "radius among them")
    moved_in_green = np.where(still[:, None], BEFORE_COLOR, COMPACT_COLOR)
    png_path = out / f"{stem}_rbf.png"
    render_panels(png_path, [points, *variants, local], mesh.faces,
                  f"deformkit RBF: {RBF_CONTROLS} vertices as controls, moved by smooth noise (RMS 4% of the height), "
                  f"thin plate spline, {RBF_VARIANTS} seeds; last: Wendland C2 moving the top only",
                  [f"rest: {name}"] + [f"thin plate spline, noise seed {s}" for s in range(1, RBF_VARIANTS + 1)]
                  + [f"wendland_c2: the top's {len(head)} controls moved (green);\n"
                     f"{still.mean():.0%} of the vertices unmoved bit for bit (blue)"],
                  15.0, -60.0, colors=[BEFORE_COLOR] + [AFTER_COLOR] * RBF_VARIANTS + [moved_in_green], columns=3)
    print("rbf:           " + "\n               ".join(lines))
    print(f"wrote:         {png_path}")


def angle_change(before, after, faces):
    """Mean change of the triangles' angles, in degrees."""
    def angles(p):
        a, b, c = p[faces[:, 0]], p[faces[:, 1]], p[faces[:, 2]]
        def angle(u, v):
            return np.arctan2(np.linalg.norm(np.cross(u, v), axis=1), (u * v).sum(1))
        return np.stack([angle(b - a, c - a), angle(a - b, c - b), angle(a - c, b - c)], 1)
    return float(np.degrees(np.abs(angles(after) - angles(before))).mean())


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="demo_out", help="output directory (created if missing)")
    ap.add_argument("--mesh", help="mesh file to deform instead of ../shared/meshes/ogre.obj")
    args = ap.parse_args()
    out = Path(args.out).resolve()
    if out == SHARED or SHARED in out.parents:
        sys.exit(f"demo: refusing to write into {SHARED} (shared, read-only data); choose another --out")
    out.mkdir(parents=True, exist_ok=True)

    mesh, source, note = load_mesh(args.mesh)
    name = source.name
    if note:
        print("note:", note)
    solid, weld = welded(mesh)
    uses = np.unique(solid.edges_sorted, axis=0, return_counts=True)[1]
    closed = solid.is_watertight and solid.is_winding_consistent
    why = f"{(uses == 1).sum()} boundary, {(uses > 2).sum()} non-manifold edges" + (
        "" if solid.is_winding_consistent else ", inconsistent winding")
    points = np.ascontiguousarray(mesh.vertices, dtype=np.float64)
    stack, desc, frame = build_stack(points)

    t0 = time.perf_counter()
    moved = stack.deform(points)
    t_deform = time.perf_counter() - t0
    # Smooth normals of the original surface (welded across UV seams), carried through the map.
    normals = stack.transform_normals(points, vertex_normals(solid)[weld])
    ratio = stack.volume_ratio(points)

    result = trimesh.Trimesh(moved, mesh.faces, process=False)
    result.vertex_normals = normals  # stored in the cache; export writes these, not recomputed ones
    stem = source.stem
    obj_path, png_path = out / f"{stem}_twist_bend.obj", out / f"{stem}_twist_bend.png"
    text = trimesh.exchange.obj.export_obj(result, include_normals=True, include_texture=False,
                                           header=f"deformkit demo: {desc}")
    atomic_write(obj_path, lambda fh: fh.write(text.encode()))
    t0 = time.perf_counter()
    render_before_after(png_path, points, moved, mesh.faces, "deformkit Stack: " + desc.replace(" then ", "\nthen "),
                        (f"before: {name} ({len(points):,} vertices)", "after: twist, then bend"), *camera(frame))
    t_render = time.perf_counter() - t0

    # Check of the written file and of transform_normals against normals of the deformed surface.
    back = trimesh.load(obj_path, process=False, force="mesh")
    assert np.allclose(back.vertices, moved, atol=1e-6) and np.array_equal(back.faces, mesh.faces)
    written = np.array([line.split()[1:] for line in text.splitlines() if line.startswith("vn ")], dtype=float)
    assert np.allclose(written, normals, atol=1e-6), "the OBJ's vn lines are not the transformed normals"
    solid_after = trimesh.Trimesh(welded_positions(moved, weld, len(solid.vertices)), solid.faces, process=False)
    recomputed = vertex_normals(solid_after)[weld]
    angle = np.degrees(np.arccos(np.clip(np.sum(normals * recomputed, axis=1), -1, 1)))

    print(f"mesh:          {source}: {len(points):,} vertices, {len(mesh.faces):,} faces, "
          + ("closed" if closed else f"not closed ({why})")
          + f", extents {np.round(np.ptp(points, axis=0), 3).tolist()}")
    print(f"deformers:     {desc}")
    print(f"deform:        {t_deform * 1e3:.2f} ms for {len(points):,} points (float64, one call)")
    v0, v1 = solid.volume, solid_after.volume
    print(f"volume:        before {v0:.6g}, after {v1:.6g} (x{v1 / v0:.4f})"
          + ("" if closed else "  [approximate: the mesh is not closed]"))
    print(f"volume_ratio:  det J at the vertices: min {ratio.min():.4f}, max {ratio.max():.4f}")
    print(f"normals:       transform_normals vs normals recomputed on the deformed mesh: "
          f"median {np.median(angle):.2f} deg, 99th percentile {np.percentile(angle, 99):.2f} deg")
    print(f"render:        {t_render:.1f} s")
    print(f"wrote:         {obj_path}\n               {png_path}")
    lattice_demo(points, mesh, solid, weld, out, stem, name)
    cage_demo(points, mesh, out, stem, name)
    rbf_demo(points, mesh, out, stem, name)


if __name__ == "__main__":
    main()

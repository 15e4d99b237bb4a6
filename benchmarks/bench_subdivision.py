"""Subdivision speed (issue 6): deformkit's OpenSubdiv subdivision and limit evaluation next to
Blender's own Subdivision Surface modifier, in one process.

    .venv/bin/python benchmarks/bench_subdivision.py [--mesh PATH] [--level L] [--samples N] [--repeats R]
                                                     [--skip-blender]

Mesh: ../shared/meshes/beast.obj (32,311 vertices, 32,364 faces: 32,228 quads, 124 triangles, 12
n-gons; polygons read as written), skipped with a message when that folder is absent.

deformkit:
  subdivide     dk.subdivide(points, faces, L): topology refinement + interpolation + output arrays
  Subdivider    building dk.Subdivider (the refined topology, faces, face origins) once
  re-subdivide  Subdivider.subdivide(new cage): interpolation only, what an animated cage pays per frame
  limit build   dk.LimitSurface (adaptive patches, Gregory end caps, patch points)
  limit grid    LimitSurface.evaluate at the (2^L + 1)^2 grid of every ptex face (Blender's workload:
                its limit-surface mesh evaluates the patches at such grids), positions
  limit N       LimitSurface.evaluate of N random (ptex, u, v) samples (seed 0): positions only, then
                with du, dv and normals; on both cores and on one (libgomp's omp_set_num_threads)
Blender (PyPI bpy, this process): the mesh made with from_pydata, a Subdivision Surface modifier at
levels = render levels = L, Catmull-Clark, quality 3; one evaluation = tagging the mesh changed
(a vertex moved 1e-4), evaluated_depsgraph_get() and evaluated_get().to_mesh() (the face count is
checked against deformkit's), so it includes Blender building its Mesh. "first" is the first
evaluation after adding the modifier (Blender builds its OpenSubdiv topology then); "again" the
median of the following ones (Blender keeps its topology refiner, as Subdivider does). Run with
use_limit_surface off (the refined points, as dk.subdivide) and on (Blender's default: points
evaluated on the limit surface, i.e. 2M limit samples at level 3).
Each figure is the median of --repeats runs after one warm-up; ratios are Blender / deformkit
from the same run.
"""
import argparse
import pathlib
import statistics
import sys
import time

import numpy as np

import deformkit as dk
from bench_common import OtherLoad, cpu_busy, omp_threads, timings

MESHES = pathlib.Path(__file__).resolve().parents[2] / "shared" / "meshes"


def read_polygons(path):
    """Vertices and polygons of an OBJ file as written (no triangulation)."""
    points, faces = [], []
    for line in pathlib.Path(path).read_text().splitlines():
        if line.startswith("v "):
            points.append([float(x) for x in line.split()[1:4]])
        elif line.startswith("f "):
            faces.append([int(t.split("/")[0]) - 1 for t in line.split()[1:]])
    return np.array(points), faces


def median(ts):
    return statistics.median(ts)


def bench_deformkit(points, faces, level, samples, repeats):
    rows = {}
    rng = np.random.default_rng(0)
    moved = dk.Twist(rate=0.3).deform(points)
    rows["subdivide"] = median(timings(lambda: dk.subdivide(points, faces, level), repeats))
    rows["Subdivider"] = median(timings(lambda: dk.Subdivider(points, faces, level), repeats))
    sd = dk.Subdivider(points, faces, level)
    rows["re-subdivide"] = median(timings(lambda: sd.subdivide(moved), repeats))
    rows["limit build"] = median(timings(lambda: dk.LimitSurface(points, faces), repeats))
    surface = dk.LimitSurface(points, faces)
    ptex = rng.integers(0, surface.ptex_count, samples)
    uv = rng.random((samples, 2))
    if surface.scheme == "loop":
        uv[uv.sum(axis=1) > 1] = 1 - uv[uv.sum(axis=1) > 1]
    # Blender's workload: the (2^L + 1)^2 grid of every ptex face, face after face.
    g = 2 ** level
    u, v = np.meshgrid(np.arange(g + 1) / g, np.arange(g + 1) / g)
    grid_uv = np.tile(np.c_[u.ravel(), v.ravel()], (surface.ptex_count, 1))
    grid_ptex = np.repeat(np.arange(surface.ptex_count), (g + 1) ** 2)
    rows[f"limit grid {len(grid_ptex):,} positions"] = median(
        timings(lambda: surface.evaluate(grid_ptex, grid_uv, derivatives=0), repeats))
    rows["_grid_samples"] = len(grid_ptex)
    for derivatives, name in ((0, "positions"), (1, "+ du, dv, normal")):
        rows[f"limit {samples:,} {name}"] = median(timings(lambda: surface.evaluate(ptex, uv, derivatives=derivatives), repeats))
        with omp_threads(1) as limited:
            if limited:
                rows[f"limit {samples:,} {name}, 1 core"] = median(
                    timings(lambda: surface.evaluate(ptex, uv, derivatives=derivatives), repeats))
    return rows, sd


def bench_blender(points, faces, level, repeats, expected_faces):
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mesh = bpy.data.meshes.new("beast")
    mesh.from_pydata(points.tolist(), [], faces)
    mesh.update()
    obj = bpy.data.objects.new("beast", mesh)
    bpy.context.scene.collection.objects.link(obj)
    # One evaluation without the modifier, so that "first" holds only the modifier's own set-up.
    obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
    obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh_clear()
    out = {}
    for limit in (False, True):
        for m in list(obj.modifiers):
            obj.modifiers.remove(m)
        mod = obj.modifiers.new("Subdivision", "SUBSURF")
        mod.levels = mod.render_levels = level
        mod.use_limit_surface = limit
        times = []
        for _ in range(repeats + 1):
            mesh.vertices[0].co.x += 1e-4
            mesh.update()
            t0 = time.perf_counter()
            evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
            result = evaluated.to_mesh()
            count = len(result.polygons)
            evaluated.to_mesh_clear()
            times.append(time.perf_counter() - t0)
            if count != expected_faces:
                sys.exit(f"Blender made {count} faces, deformkit {expected_faces}: not the same subdivision")
        out[limit] = (times[0], median(times[1:]))
    return out, bpy.app.version_string


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mesh", help="a polygon OBJ instead of ../shared/meshes/beast.obj")
    ap.add_argument("--level", type=int, default=3)
    ap.add_argument("--samples", type=int, default=1_000_000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--skip-blender", action="store_true")
    args = ap.parse_args()
    path = pathlib.Path(args.mesh) if args.mesh else MESHES / "beast.obj"
    if not path.is_file():
        print(f"skipped: {path} not found (the benchmark uses ../shared/meshes/beast.obj)")
        return
    points, faces = read_polygons(path)
    print(f"mesh: {path.name}: {len(points):,} vertices, {len(faces):,} faces; level {args.level}; "
          f"machine busy {cpu_busy():.0%} before the run")
    with OtherLoad() as load:
        rows, sd = bench_deformkit(points, faces, args.level, args.samples, args.repeats)
    print(f"\ndeformkit {dk.__version__} ({len(sd.faces):,} faces, {sd.vertex_count:,} vertices at level {args.level})")
    grid_samples = rows.pop("_grid_samples")
    for name, t in rows.items():
        print(f"  {name:<40} {t * 1e3:9.1f} ms")
    print(load.report())
    if args.skip_blender:
        return
    with OtherLoad() as load:
        blender, version = bench_blender(points, faces, args.level, args.repeats, len(sd.faces))
    print(f"\nBlender {version} Subdivision Surface modifier, levels {args.level} (evaluation + to_mesh)")
    for limit, (first, again) in blender.items():
        what = "limit surface on " if limit else "limit surface off"
        print(f"  {what}: first {first * 1e3:8.1f} ms, again {again * 1e3:8.1f} ms")
    print(load.report())
    off_first, off_again = blender[False]
    on_first, on_again = blender[True]
    print("\nratios (Blender / deformkit, higher is better for deformkit)")
    print(f"  first subdivision: Blender (limit off) / dk.subdivide        {off_first / rows['subdivide']:6.2f}x")
    print(f"  first subdivision: Blender (limit on)  / dk.subdivide        {on_first / rows['subdivide']:6.2f}x")
    print(f"  again:             Blender (limit off) / Subdivider.subdivide {off_again / rows['re-subdivide']:6.2f}x")
    per_million_blender = on_again / (sd.vertex_count / 1e6)
    for key, count, what in ((f"limit {args.samples:,} positions", args.samples, "random samples"),
                             (f"limit grid {grid_samples:,} positions", grid_samples, "grid samples")):
        per_million_dk = rows[key] / (count / 1e6)
        print(f"  limit points:      Blender (limit on, again) {per_million_blender * 1e3:.0f} ms per million "
              f"vertices, dk {per_million_dk * 1e3:.0f} ms per million {what}: {per_million_blender / per_million_dk:.2f}x")


if __name__ == "__main__":
    main()

"""Each entry against its floor and Blender's modifier, per edit, in one bpy process.

    .venv/bin/python benchmarks/bench_entry_floor.py [--vertices N] [--repeats R] [--warmup W]
                                                     [--cases twist,twist_group,lattice,lattice_group]
                                                     [--addon DIR]

Per case, two copies of one displaced grid: A with a deformkit entry, B with Blender's modifier
doing the same (Simple Deform TWIST / Lattice on a rotated 5x5x5 B-spline lattice; the "_group"
cases weight both by the same vertex group). Each edit (a new angle on both / new co_deform on
each lattice), alternating which side goes first: time = the edit (for A the add-on's property
callback) + depsgraph update + a read of the evaluated positions. A's evaluate() is broken down
into plan / run / publish (evaluation.py), or a drag's frame (follow.py), by timers around them.

The floor of an entry: what no entry handing its offsets to the Geometry Nodes modifier can beat,
measured in the same run: the depsgraph update minus the add-on's evaluate() (the modifier adding
the offsets, and Blender's rest), plus the deformer alone on the same points into a kept array
(SimpleDeform.deform(out=), BlenderLattice.deform_bound(out=)), plus the same read of the
evaluated positions that the total includes. Medians of R edits after W warm-up ones.
"""
import argparse
import collections
import pathlib
import statistics
import time

import numpy as np

from bench_common import OtherLoad, blender_with_addon, cpu_busy, displaced_grid_pair

ap = argparse.ArgumentParser()
ap.add_argument("--vertices", type=int, default=1_000_000)
ap.add_argument("--repeats", type=int, default=21)
ap.add_argument("--warmup", type=int, default=3)
ap.add_argument("--cases", default="twist,twist_group,lattice,lattice_group")
ap.add_argument("--addon", default=str(pathlib.Path(__file__).resolve().parents[1] / "python_addon"))
args = ap.parse_args()

busy = cpu_busy()
blender_with_addon(args.addon)
import bpy  # noqa: E402
from deformkit_addon import api, evaluation, follow, native, stack_run  # noqa: E402

dk = native.dk
parts = collections.defaultdict(float)


def timed(owner, name, label):
    fn = getattr(owner, name)

    def wrapper(*a, **k):
        t0 = time.perf_counter()
        try:
            return fn(*a, **k)
        finally:
            parts[label] += time.perf_counter() - t0
    setattr(owner, name, wrapper)


for owner, name, label in ((evaluation, "evaluate", "evaluate"), (evaluation, "_plan", "plan"),
                           (stack_run, "run", "run"), (evaluation, "_publish", "publish"),
                           (follow, "step", "follow")):
    timed(owner, name, label)


def read(obj, out):
    dg = bpy.context.evaluated_depsgraph_get()
    obj.evaluated_get(dg).data.attributes["position"].data.foreach_get("vector", out)
    return out


def group(obj, co):
    """A vertex group weighting the points by height in 8 bands (0 below, 1 at the top)."""
    vg = obj.vertex_groups.new(name="influence")
    band = np.clip(((co[:, 1] + 1.0) * 4).astype(int), 0, 7)
    for b in range(8):
        vg.add(np.flatnonzero(band == b).tolist(), b / 7, "REPLACE")
    return vg.name


def lattice_object(name):
    data = bpy.data.lattices.new(name)
    lat = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(lat)
    data.points_u = data.points_v = data.points_w = 5
    for axis in "uvw":
        setattr(data, f"interpolation_type_{axis}", "KEY_BSPLINE")
    lat.location, lat.rotation_euler, lat.scale = (0.15, -0.1, 0.02), (0.15, -0.1, 0.5), (1.9, 1.8, 0.9)
    return lat


def case(kind, with_group):
    """(edit(i, side) -> None, deformer alone (base, out) -> None, A, B) for one case."""
    a, b, co = displaced_grid_pair(args.vertices)
    names = {}
    if with_group:
        names["vertex_group"] = group(a, co)
        group(b, co)
    if kind == "twist":
        entry = api.add_entry(a, "TWIST", angle=0.5, deform_axis="Z", **names)
        mod = b.modifiers.new("SimpleDeform", "SIMPLE_DEFORM")
        mod.deform_method, mod.deform_axis, mod.angle = "TWIST", "Z", 0.5
        mod.vertex_group = names.get("vertex_group", "")
        angles = 0.5 + 0.3 * np.sin(np.arange(1000))

        def edit(i, side):
            if side == "deformkit":
                entry.angle = angles[i]
            else:
                mod.angle = angles[i]
        alone = dk.SimpleDeform(mode="TWIST", angle=0.5, deform_axis="Z",
                                weights=None if not with_group else np.linspace(0, 1, len(co)))
        return edit, lambda base, out: alone.deform(base, out=out), a, b
    lattices = {"deformkit": lattice_object("dk_lattice"), "blender": lattice_object("bl_lattice")}
    api.add_entry(a, "LATTICE", lattice=lattices["deformkit"], **names)
    mod = b.modifiers.new("Lattice", "LATTICE")
    mod.object, mod.vertex_group = lattices["blender"], names.get("vertex_group", "")
    rest = np.empty(125 * 3, np.float32)
    lattices["blender"].data.points.foreach_get("co_deform", rest)
    rng = np.random.default_rng(5)
    co_sets = [rest + rng.normal(0, 0.05, rest.shape).astype(np.float32) for _ in range(args.warmup + args.repeats)]

    def edit(i, side):
        data = lattices[side].data
        data.points.foreach_set("co_deform", co_sets[i])
        data.update_tag()
    frame = np.array(a.matrix_world.inverted() @ lattices["deformkit"].matrix_world)
    alone = dk.BlenderLattice((5, 5, 5), ("KEY_BSPLINE",) * 3, frame=frame)
    alone.control_points = alone.rest_control_points + rng.normal(0, 0.05, alone.rest_control_points.shape)
    binding = alone.bind(np.ascontiguousarray(co))
    return edit, lambda base, out: alone.deform_bound(binding, out=out), a, b


def run_case(name):
    kind, with_group = name.split("_")[0], name.endswith("_group")
    edit, alone, a, b = case(kind, with_group)
    api.evaluate(a)
    bpy.context.evaluated_depsgraph_get().update()
    n = len(a.data.vertices)
    buf = {"deformkit": np.empty(n * 3, np.float32), "blender": np.empty(n * 3, np.float32)}
    runs = {"deformkit": [], "blender": []}
    for i in range(args.warmup + args.repeats):
        for side in (("deformkit", "blender") if i % 2 == 0 else ("blender", "deformkit")):
            parts.clear()
            t0 = time.perf_counter()
            edit(i, side)
            dg = bpy.context.evaluated_depsgraph_get()
            dg.update()
            t1 = time.perf_counter()
            read(a if side == "deformkit" else b, buf[side])
            t2 = time.perf_counter()
            if i >= args.warmup:
                runs[side].append({"total": t2 - t0, "update": t1 - t0, "read": t2 - t1, **parts})
    size = float(np.ptp(buf["blender"].reshape(-1, 3), axis=0).max())
    diff = float(np.abs(buf["deformkit"] - buf["blender"]).max())
    assert diff < 1e-4 * size, f"{name}: the entry and Blender's modifier disagree by {diff:.3g}"
    base = np.empty((n, 3), np.float32)
    a.data.attributes["position"].data.foreach_get("vector", base.ravel())
    out = np.empty_like(base)
    alone_t = []
    for _ in range(args.warmup + args.repeats):
        t0 = time.perf_counter()
        alone(base, out)
        alone_t.append(time.perf_counter() - t0)
    med = lambda side, key: statistics.median(r.get(key, 0.0) for r in runs[side])  # noqa: E731
    gn = statistics.median(r["update"] - r.get("evaluate", 0.0) for r in runs["deformkit"])
    floor = gn + statistics.median(alone_t[args.warmup:]) + med("deformkit", "read")
    total, blender = med("deformkit", "total"), med("blender", "total")
    print(f"{name:14s}{total * 1e3:9.2f}{floor * 1e3:9.2f}{total / floor:9.2f}{blender * 1e3:10.2f}"
          f"{blender / total:9.2f}x{med('deformkit', 'plan') * 1e3:8.2f}{med('deformkit', 'run') * 1e3:8.2f}"
          f"{med('deformkit', 'publish') * 1e3:9.2f}{med('deformkit', 'follow') * 1e3:8.2f}{gn * 1e3:8.2f}"
          f"   |diff| {diff:.1e}")
    for obj in (a, b):
        bpy.data.objects.remove(obj)


print(f"deformkit {dk.build_info()} | bpy {bpy.app.version_string} | add-on {args.addon}")
print(f"{args.vertices:,} vertices, median of {args.repeats} edits per side after {args.warmup}; "
      f"CPU busy before the run: {busy:.0%}")
print(f"{'case':14s}{'entry ms':>9s}{'floor':>9s}{'/floor':>9s}{'Blender':>10s}{'Bl/entry':>10s}"
      f"{'plan':>8s}{'run':>8s}{'publish':>9s}{'follow':>8s}{'GN+rest':>8s}")
with OtherLoad() as load:
    for name in args.cases.split(","):
        run_case(name)
print(load.report())
print("entry: edit + depsgraph update + read; floor: GN+rest (update minus evaluate) + the deformer alone + "
      "the same read; plan / run / publish: a full evaluation's stages, follow: a drag's frame (follow.py) instead")

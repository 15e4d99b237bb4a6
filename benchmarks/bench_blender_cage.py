"""Cage edit -> evaluated mesh: the add-on's Cage entry (Mean Value, Green) vs Blender's Mesh Deform.

    .venv/bin/python benchmarks/bench_blender_cage.py [--models Ogre,FireHydrant,Beast,WireSphere]
        [--repeats R] [--precision P] [--no-shape-key] [--addon DIR]

One bpy 5.0 process, per model of ../shared/cages: four copies of the model, each with its own copy
of the rest cage at the same place: one with a deformkit Cage entry of Method Mean Value, one with
Method Green, one with Method Harmonic (Mesh Deform) at the same precision as the modifier (all
bound by api.bind_cage, what the entry's Bind button runs), and one with Blender's Mesh Deform
modifier (Precision 5, the default, bound by its Bind operator). Bind times: the call and
the depsgraph update that shows its result (Mesh Deform binds in that evaluation).

A frame: set the cage mesh's positions to the provided deformed cage, or back to the rest cage
(foreach_set + mesh.update(), as a script or an Edit Mode edit does), depsgraph update (for the
entries: the add-on's depsgraph handler deforms and writes its offsets, and Blender evaluates again
in the same update), and foreach_get of the evaluated model's positions. The steps alternate deformed
and rest, the three models in turns (the order rotates), one warm-up step first; the figures are the
medians of the R steps to the deformed cage (the ratio to Mesh Deform is of these) and of the R steps
back to the rest cage, reported apart because a deformkit cage at rest is the identity, given without
a product. A second setup drives each cage by an object-level shape key (Basis = rest,
"Deformed" = the deformed cage) instead, the frame switching the key's value between 1 and 0, as a
shape-keyed or rigged cage does in production (--no-shape-key skips it).

Checked in the run (exit 1 otherwise): after every step each entry's evaluated positions equal
dk.MeanValueCage / dk.GreenCage of the rest cage, its cage_points set to the cage shown, deforming
the model's points, to 1e-4 (or 64 float32 steps at the largest coordinate, if more: the mesh is
float32), and Mesh Deform's deformed frames move the model. Skips with a message when ../shared/cages is absent.
"""
import argparse
import pathlib
import statistics
import sys
import time

import numpy as np

from bench_common import OtherLoad, blender_with_addon, cage_model, cpu_busy, mesh_deform_bind, set_positions, \
    shared_cages_or_exit, twin

ap = argparse.ArgumentParser()
ap.add_argument("--models", default="Ogre,FireHydrant,Beast,WireSphere")
ap.add_argument("--repeats", type=int, default=9)
ap.add_argument("--precision", type=int, default=5)
ap.add_argument("--no-shape-key", action="store_true")
ap.add_argument("--addon", default=str(pathlib.Path(__file__).resolve().parents[1] / "python_addon"))
args = ap.parse_args()
CAGES = shared_cages_or_exit("bench_blender_cage")

busy = cpu_busy()
addon = blender_with_addon(args.addon)
import bpy  # noqa: E402
from deformkit_addon import api, native  # noqa: E402
dk = native.dk

ENTRIES = (("Cage entry Mean Value", "MEAN_VALUE", "MeanValueCage"), ("Cage entry Green", "GREEN", "GreenCage"),
           ("Cage entry Harmonic", "HARMONIC", "MeshDeform"))
MESH_DEFORM = "Blender Mesh Deform"


class Side:
    """One model and the cage that drives it; `expected` maps "moved"/"rest" to its correct result
    (None: Mesh Deform's, which only has to move)."""

    def __init__(self, label, model, cage, expected):
        self.label, self.model, self.cage, self.expected = label, model, cage, expected
        self.buf = np.empty(len(model.data.vertices) * 3, np.float32)
        self.bind = float("nan")
        self.frames = {}  # (setup, "moved" / "rest") -> [seconds]
        self.error = 0.0  # largest |evaluated - expected| seen


def harmonic(cls):
    """Mesh Deform's settings for the Harmonic method (its class), none for the others."""
    return {"precision": args.precision} if cls == "MeshDeform" else {}


def expected_results(cls, m):
    extra = dict(harmonic(cls), blender_version=tuple(bpy.app.version[:2])) if harmonic(cls) else {}
    deformer = getattr(dk, cls)(m.rest, m.cage_faces, **extra)
    deformer.cage_points = m.moved
    return {"moved": deformer.deform(m.points), "rest": m.points}


def timed_bind(fn):
    t0 = time.perf_counter()
    fn()
    bpy.context.evaluated_depsgraph_get().update()
    return time.perf_counter() - t0


def sides_of(m):
    sides = []
    for label, method, cls in ENTRIES:  # the twins first: m.model then gets Mesh Deform
        model, cage = twin(m.model, label), twin(m.cage, label + " cage")
        api.add_entry(model, "CAGE", cage=cage, cage_method=method, **harmonic(cls))
        side = Side(label, model, cage, expected_results(cls, m))
        side.bind = timed_bind(lambda: api.bind_cage(model, 0))
        sides.append(side)
    side = Side(MESH_DEFORM, m.model, m.cage, None)
    _, side.bind = mesh_deform_bind(m.model, m.cage, args.precision)
    return [side] + sides


def mesh_edit(side, target, m):
    set_positions(side.cage.data, m.moved if target == "moved" else m.rest)


def shape_key(side, target, m):
    side.cage.data.shape_keys.key_blocks["Deformed"].value = 1.0 if target == "moved" else 0.0


def add_shape_keys(sides, m):
    for side in sides:
        set_positions(side.cage.data, m.rest)
        side.cage.shape_key_add(name="Basis")
        key = side.cage.shape_key_add(name="Deformed", from_mix=False)
        key.data.foreach_set("co", m.moved.astype(np.float32).ravel())
        key.value = 0.0
    bpy.context.evaluated_depsgraph_get().update()


def step(side, drive, target, m):
    """Seconds from the cage edit to the evaluated model's positions in side.buf."""
    t0 = time.perf_counter()
    drive(side, target, m)
    dg = bpy.context.evaluated_depsgraph_get()
    dg.update()
    side.model.evaluated_get(dg).data.attributes["position"].data.foreach_get("vector", side.buf)
    return time.perf_counter() - t0


def check(side, target, m, tol):
    got = side.buf.reshape(-1, 3).astype(np.float64)
    if side.expected is not None:
        side.error = max(side.error, float(np.abs(got - side.expected[target]).max()))
        return side.error <= tol
    moved = float(np.abs(got - m.points).max())
    return moved > 1e3 * tol if target == "moved" else moved <= tol


def run(sides, setup, drive, m, tol):
    for i in range(2 * args.repeats + 1):
        target = "moved" if i % 2 == 0 else "rest"
        turn = sides[i % len(sides):] + sides[:i % len(sides)]
        for side in turn:
            seconds = step(side, drive, target, m)
            if not check(side, target, m, tol):
                problem = (f"|evaluated - dk| up to {side.error:.2e} (allowed {tol:.1e})" if side.expected is not None
                           else "did not move the model" if target == "moved" else "did not give the model back")
                print(f"FAILED: {m.name}, {setup}, {side.label} at the {target} cage: {problem}")
                sys.exit(1)
            if i:
                side.frames.setdefault((setup, target), []).append(seconds)


print(f"deformkit {dk.build_info()}  |  bpy {bpy.app.version_string}  |  Mesh Deform precision {args.precision}"
      f"  |  CPUs busy before the run {busy:.0%}")
print(f"frame = cage edit + depsgraph update + foreach_get of the evaluated positions; medians of {args.repeats} "
      "steps to the deformed cage and of as many back to the rest cage, alternating, after 1 warm-up")
print(f"{'model':18s}{'cage driven by':16s}{'side':24s}{'bind s':>8s}{'deformed ms':>13s}{'min ms':>9s}"
      f"{'/ MD':>7s}{'rest ms':>9s}{'|x - dk| max':>14s}")
for name in args.models.split(","):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if not hasattr(bpy.types.Object, "deformkit"):
        addon.register()
    with OtherLoad() as load:
        m = cage_model(CAGES, name)
        # 1e-4, or 64 float32 steps at the largest coordinate on a larger model: the mesh, the cage and
        # the entry's offsets are float32.
        tol = max(1e-4, 64 * float(np.finfo(np.float32).eps) * float(np.abs(m.points).max()))
        sides = sides_of(m)
        setups = [("cage mesh edit", mesh_edit)]
        run(sides, *setups[0], m, tol)
        if not args.no_shape_key:
            add_shape_keys(sides, m)
            setups.append(("cage shape key", shape_key))
            run(sides, *setups[1], m, tol)
    label = f"{name} {len(m.points) // 1000}k/{len(m.rest)}"
    for s, (setup, _) in enumerate(setups):
        md = statistics.median(sides[0].frames[setup, "moved"])
        for k, side in enumerate(sides):
            frame, rest = (statistics.median(side.frames[setup, target]) for target in ("moved", "rest"))
            bind = f"{side.bind:8.3f}" if s == 0 else f"{'':8s}"
            error = f"{side.error:14.1e}" if side.expected is not None else f"{'':14s}"
            print(f"{label if s == 0 and k == 0 else '':18s}{setup if k == 0 else '':16s}{side.label:24s}{bind}"
                  f"{frame * 1e3:13.2f}{min(side.frames[setup, 'moved']) * 1e3:9.2f}{frame / md:7.2f}"
                  f"{rest * 1e3:9.2f}{error}")
    print(load.report())

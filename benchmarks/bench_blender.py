"""Parameter change -> updated evaluated mesh: a deformkit Twist entry vs Blender's Simple Deform.

    .venv/bin/python benchmarks/bench_blender.py [--vertices N] [--repeats R] [--json PATH] [--addon DIR]

One Blender (bpy) process, two identical displaced grids: A has a deformkit Twist entry (Z axis),
B a Simple Deform modifier (TWIST, Z). Each iteration sets a new angle on both, alternating which
goes first: time = set the angle (deformkit: the add-on's update callback) + depsgraph update +
evaluated vertex count; "+read" adds a foreach_get of the evaluated positions on both sides. The
deformkit side is broken down by timers monkeypatched around the add-on's functions ("set" is the
property callback; "depsgraph" includes the add-on's depsgraph handler re-check). --addon DIR runs
a (patched) copy of the add-on instead. Then (bridge_alternatives.py, --no-alternatives skips it) the
ways of handing the result to Blender side by side: Geometry Nodes trees and write paths.
"""
import argparse, json, pathlib, statistics, time, types
import numpy as np

import bridge_alternatives
from bench_common import blender_with_addon, displaced_grid_pair

ap = argparse.ArgumentParser()
for option, default in (("--vertices", 1_000_000), ("--repeats", 15), ("--warmup", 3)):
    ap.add_argument(option, type=int, default=default)
ap.add_argument("--json")
ap.add_argument("--no-alternatives", action="store_true")
ap.add_argument("--addon", default=str(pathlib.Path(__file__).resolve().parents[1] / "python_addon"))
args = ap.parse_args()


def cpu_ticks():  # (total, idle + iowait) from /proc/stat
    v = list(map(int, open("/proc/stat").readline().split()[1:]))
    return sum(v), v[3] + v[4]


def eval_positions(obj, dg, out):  # the position attribute: ~20x faster than vertices.foreach_get("co")
    obj.evaluated_get(dg).data.attributes["position"].data.foreach_get("vector", out)
    return out


def timed(name, fn):  # accumulate into T under "<phase>:<name>"
    def wrapper(*a, **k):
        t0 = time.perf_counter()
        try:
            return fn(*a, **k)
        finally:
            T[f"{phase[0]}:{name}"] = T.get(f"{phase[0]}:{name}", 0.0) + time.perf_counter() - t0
    return wrapper


def timed_stack(deformers):
    stack = dk.Stack(deformers)
    return types.SimpleNamespace(deform=timed("deform", stack.deform), volume_ratio=stack.volume_ratio,
                                 displacement=timed("displacement", stack.displacement))


def stat(side, key):
    v = [r.get(key, 0.0) * 1e3 for r in runs[side]]
    return statistics.median(v), min(v)


(c0, i0), _, (c1, i1) = cpu_ticks(), time.sleep(0.5), cpu_ticks()
busy = 1 - (i1 - i0) / max(c1 - c0, 1)  # CPU busy fraction before the run
blender_with_addon(args.addon)
import bpy  # noqa: E402
from deformkit_addon import api, evaluation, native, outputs, stack_run  # noqa: E402
dk = native.dk
A, B, co = displaced_grid_pair(args.vertices)
nverts, size = len(co), float(np.ptp(co, axis=0).max())
mod = B.modifiers.new("SimpleDeform", "SIMPLE_DEFORM")
mod.deform_method, mod.deform_axis, mod.angle = "TWIST", "Z", 0.5
api.add_entry(A, "TWIST", angle=0.5, deform_axis="Z")

# Apples to apples: same evaluated positions (and the evaluated mesh is not the base mesh).
dg = bpy.context.evaluated_depsgraph_get()
buf = np.empty(nverts * 3, np.float32)
pa, pb = eval_positions(A, dg, buf.copy()), eval_positions(B, dg, buf.copy())
diff, moved = float(np.abs(pa - pb).max()), float(np.abs(pa - co.ravel()).max())
via_to_mesh = float(np.abs(api.evaluated_positions(A, dg).ravel() - pa).max())
assert diff < 1e-4 * size and moved > 1e-3 * size and via_to_mesh == 0, (diff, moved, via_to_mesh)

# Timers around the add-on's internals, keyed by phase ("set" = property callback, "dg" = depsgraph).
T, phase = {}, ["set"]
for owner, name, label in ((evaluation, "evaluate", "evaluate"), (evaluation, "input_positions", "input_positions"),
                           (evaluation, "_write_own_mesh", "_write_own_mesh"), (stack_run, "deformed", "_deformed"),
                           (evaluation, "is_echo_of_own_write", "is_echo_of_own_write")):
    setattr(owner, name, timed(label, getattr(owner, name)))
outputs.ensure_modifier = timed("ensure_modifier", outputs.ensure_modifier)
native.dk = types.SimpleNamespace(**{**{n: getattr(dk, n) for n in dir(dk) if n[0] != "_"}, "Stack": timed_stack})

runs = {"deformkit": [], "blender": []}
for i in range(args.warmup + args.repeats):
    angle = 0.3 + 0.0137 * i  # a new angle every iteration: nothing can be cached
    for side in (("deformkit", "blender") if i % 2 == 0 else ("blender", "deformkit")):
        obj = A if side == "deformkit" else B
        T.clear()
        phase[0] = "set"
        t0 = time.perf_counter()
        if side == "deformkit":
            obj.deformkit.entries[0].angle = angle
        else:
            obj.modifiers["SimpleDeform"].angle = angle
        t1 = time.perf_counter()
        phase[0] = "dg"
        (dg := bpy.context.evaluated_depsgraph_get()).update()
        t2 = time.perf_counter()
        assert len(obj.evaluated_get(dg).data.vertices) == nverts
        t3 = time.perf_counter()
        eval_positions(obj, dg, buf)
        t4 = time.perf_counter()
        if i >= args.warmup:
            runs[side].append({"total": t3 - t0, "set": t1 - t0, "depsgraph": t2 - t1, "count": t3 - t2,
                               "read": t4 - t3, "total+read": t4 - t0, **T})
dg = bpy.context.evaluated_depsgraph_get()  # after the last change both sides must still agree
final_diff = float(np.abs(eval_positions(A, dg, buf.copy()) - eval_positions(B, dg, buf.copy())).max())
assert final_diff < 1e-4 * size, final_diff
for r in runs["deformkit"]:  # derived parts
    parts = ("input_positions", "_deformed", "_write_own_mesh", "ensure_modifier")
    r["set:other"] = r["set"] - sum(r.get(f"set:{k}", 0) for k in parts)
    r["dg:GN+rest"] = r["depsgraph"] - r.get("dg:evaluate", 0) - r.get("dg:is_echo_of_own_write", 0)
ROWS = [(side, key, label) for side, rows in (
    ("deformkit", [("total", "deformkit total (set + depsgraph + count)"),
                   ("set", "  set angle: property callback -> evaluate()"),
                   ("set:input_positions", "    input_positions (foreach_get)"),
                   ("set:_deformed", "    entries -> offsets in the attribute's memory"),
                   ("set:deform", "      of which dk.Stack.deform"),
                   ("set:_write_own_mesh", "    _write_own_mesh (other attributes, mesh.update())"),
                   ("set:ensure_modifier", "    ensure_modifier"),
                   ("set:other", "    other (fingerprint, mesh.update())"),
                   ("depsgraph", "  depsgraph update"),
                   ("dg:is_echo_of_own_write", "    handler: echo check (vertex count)"),
                   ("dg:evaluate", "    handler re-check: evaluate()"),
                   ("dg:GN+rest", "    Geometry Nodes modifier + rest"), ("count", "  evaluated vertex count")]),
    ("blender", [("total", "Blender total (set + depsgraph + count)"), ("set", "  set angle"),
                 ("depsgraph", "  depsgraph update (Simple Deform)"), ("count", "  evaluated vertex count")]),
    ("deformkit", [("total+read", "deformkit total + read evaluated positions")]),
    ("blender", [("total+read", "Blender total + read evaluated positions")])) for key, label in rows]
summary = {f"{side}:{key}": dict(zip(("median_ms", "min_ms"), stat(side, key))) for side, key, _ in ROWS}
print(f"deformkit {dk.build_info()}  |  bpy {bpy.app.version_string}  |  add-on {args.addon}")
print(f"CPU busy before run: {busy:.0%} (2 cores: > ~10% means the numbers are noisy)")
print(f"mesh: {nverts:,} vertices, extent {size:.3f}; |A - B| max {diff:.2e} at start, {final_diff:.2e} "
      f"at end (tolerance {1e-4 * size:.1e}); {args.repeats} changes per side after {args.warmup} warm-up")
print(f"\n{'':50s}{'median ms':>11s}{'min ms':>10s}")
for side, key, label in ROWS:
    print(f"{label:50s}{stat(side, key)[0]:11.2f}{stat(side, key)[1]:10.2f}")
for key in ("total", "total+read"):
    (dm, dn), (bm, bn) = stat("deformkit", key), stat("blender", key)
    summary[f"ratio:{key}"] = {"median": dm / bm, "min": dn / bn}
    print(f"ratio deformkit / Blender ({key}): median {dm / bm:.2f}, min {dn / bn:.2f}  (issue 19 target <= 0.6)")
alternatives = None if args.no_alternatives else bridge_alternatives.report(
    bpy, outputs, dk, B, co, args.repeats)
(c0, i0), _, (c1, i1) = cpu_ticks(), time.sleep(0.5), cpu_ticks()
print(f"CPU busy after run: {1 - (i1 - i0) / max(c1 - c0, 1):.0%}")
if args.json:
    pathlib.Path(args.json).write_text(json.dumps({
        "build_info": dk.build_info(), "blender": bpy.app.version_string, "cpu_busy": busy, "vertices": nverts,
        "max_abs_diff": [diff, final_diff], "summary": summary, "runs": runs, "alternatives": alternatives}, indent=1))

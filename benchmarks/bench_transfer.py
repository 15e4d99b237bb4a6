"""Deformation transfer: Sumner's horse poses onto the camel, onto another horse, and against Blender.

    .venv/bin/python benchmarks/bench_transfer.py [--repeats R] [--correspondence-repeats C]
        [--blender-repeats B] [--blender-large {all,offset,none}] [--no-blender]

One process, three parts, each with the share of the CPUs other processes used while it ran:

1. Horse -> camel (unlike meshes), dk.DeformationTransfer of ../shared/transfer's horse_ref onto
   camel_ref with the 107 markers of horse_camel.cons: construction with markers (Sumner's
   correspondence phase, then the factorisation; median of C), construction with the resulting
   correspondence= given (the factorisation alone; median of R), their difference (the
   correspondence phase), one pose and the ten poses at once (medians of R). The two constructions
   must transfer alike (checked). Against the issue's targets: per pose <= 20 ms on the camel
   (43,814 triangles), the correspondence phase <= 10 s.
2. Same connectivity: the horse onto a second character on the horse's mesh (a smooth non-affine
   reshaping, as tests/transfer uses), and the same pair refined by dk.subdivide (Loop) to 270k
   triangles: construction (one), one pose and ten poses (medians of R). Target: per pose <= 100 ms
   at 200k triangles.
3. Blender's Transfer Shape Key (bpy.ops.object.shape_key_transfer, bpy 5.0) on part 2's meshes:
   the horse with its ten poses as shape keys, the other horse as the target (with a Basis key, as
   a character has). The operator copies the source's active key onto the target, one key per call;
   timed: the call for one key (median of B; the key it adds is removed between calls, untimed),
   and ten calls for the ten keys (median of B), in each of its modes:
     OFFSET         target + (key - source basis) per vertex (use_clamp has no effect here);
     RELATIVE_FACE  per face corner, the key's point carried from the source's rest corner triangle
                    to the target's (mathutils barycentric_transform), averaged over the corners;
     RELATIVE_EDGE  the same per edge, on a triangle of the edge and a normal-offset point.
   All three are per-vertex offsets in rest-pose frames, written in Python; none rotates the offsets
   with the pose. deformkit fits each pose's per-triangle deformation gradients (rotation and
   stretch) on the target in least squares (docs/math/transfer.md), one prefactored solve. Beside
   them: deformkit's per-pose time from part 2 and the same plus writing the result as a new shape
   key (shape_key_add + foreach_set), what a Blender operator of deformkit does on top. Checked: the
   OFFSET key equals target + (pose - rest) to float32 rounding. Shown: each key's mean and largest
   distance to deformkit's transfer of the same pose, over the target's bounding-box diagonal.
   --blender-large offset times only OFFSET at 270k triangles (the other modes take seconds per
   key there), none skips that mesh.

Skips with a message when ../shared/transfer is absent.
"""
import argparse
import pathlib
import sys
import time

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from bench_common import OtherLoad, blender_mesh, cpu_busy, timings  # noqa: E402

TRANSFER = pathlib.Path(__file__).resolve().parents[1].parent / "shared" / "transfer"
CAMEL_POSE_MS, CORRESPONDENCE_S, LARGE_POSE_MS, LARGE_TRIANGLES = 20, 10, 100, 200_000
BLENDER_MODES = ("OFFSET", "RELATIVE_FACE", "RELATIVE_EDGE")

ap = argparse.ArgumentParser()
ap.add_argument("--repeats", type=int, default=7)
ap.add_argument("--correspondence-repeats", type=int, default=3)
ap.add_argument("--blender-repeats", type=int, default=3)
ap.add_argument("--blender-large", choices=("all", "offset", "none"), default="all")
ap.add_argument("--no-blender", action="store_true")
args = ap.parse_args()
if not TRANSFER.is_dir():
    print(f"bench_transfer: {TRANSFER} is absent (the project's test data); nothing to measure")
    sys.exit(0)

import trimesh  # noqa: E402

import deformkit as dk  # noqa: E402


def load(name):
    mesh = trimesh.load(TRANSFER / f"{name}.obj", process=False, force="mesh")
    return np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)


def other_horse(rest):
    centre = rest.mean(0)
    u = (rest - centre) / np.abs(rest - centre).max()
    bump = np.exp(-4 * u[:, 0] ** 2)
    return centre + np.abs(rest - centre).max() * np.stack(
        [1.25 * u[:, 0] + 0.1 * u[:, 1] ** 2, u[:, 1] * (1 + 0.3 * bump), u[:, 2] * (1 + 0.2 * bump)], 1)


def median(fn, repeats=None):
    return float(np.median(timings(fn, repeats or args.repeats)))


def verdict(value, limit):
    return "met" if value <= limit else "NOT met"


failed = []
rest, faces = load("horse_ref")
poses = np.stack([load(f"horse-{i:02d}")[0] for i in range(1, 11)])
camel, camel_faces = load("camel_ref")
markers = np.loadtxt(TRANSFER / "horse_camel.cons", delimiter=",", skiprows=1, dtype=np.int64).reshape(-1, 2)
print(f"deformkit {dk.build_info()}  |  CPUs busy before the run {cpu_busy():.0%}")

# 1. Horse -> camel ------------------------------------------------------------------------------
print(f"\nhorse -> camel: {len(faces):,} -> {len(camel_faces):,} triangles, {len(markers)} markers; construction "
      f"with markers median of {args.correspondence_repeats} (1 warm-up), the rest medians of {args.repeats}")
with OtherLoad() as load_share:
    marker_pair = (markers[:, 0], markers[:, 1])
    build = lambda: dk.DeformationTransfer(rest, faces, camel, camel_faces, markers=marker_pair)  # noqa: E731
    with_markers = median(build, args.correspondence_repeats)
    dt = build()
    pairs = np.asarray(dt.correspondence)
    rebuild = lambda: dk.DeformationTransfer(rest, faces, camel, camel_faces, markers=marker_pair,  # noqa: E731
                                             correspondence=pairs)
    factorise = median(rebuild)
    one = median(lambda: dt.transfer(poses[0]))
    ten = median(lambda: dt.transfer(poses))
    camel_size = float(np.linalg.norm(np.ptp(camel, axis=0)))
    alike = float(np.abs(rebuild().transfer(poses) - dt.transfer(poses)).max()) / camel_size
if not alike <= 1e-9:
    failed.append(f"horse -> camel: construction with correspondence= transfers differently ({alike:.1e} of the diagonal)")
mean_distance, max_distance = dt.correspondence_distance
correspondence = with_markers - factorise
print(f"{'construction with markers s':34s}{with_markers:9.3f}")
print(f"{'construction with correspondence= s':34s}{factorise:9.3f}   (the factorisation)")
print(f"{'correspondence phase s':34s}{correspondence:9.3f}   (the difference)")
print(f"{'one pose ms':34s}{one * 1e3:9.1f}")
print(f"{'ten poses ms':34s}{ten * 1e3:9.1f}   ({ten * 1e2:.1f} per pose)")
print(f"  {len(pairs):,} triangle pairs, {len(np.asarray(dt.unmatched_target_triangles)):,} camel triangles without a "
      f"partner; correspondence distance mean {mean_distance:.2e}, max {max_distance:.2e} (camel diagonal "
      f"{camel_size:.3f}); the two constructions transfer alike to {alike:.0e} of the diagonal")
print(f"  targets: per pose {one * 1e3:.1f} ms <= {CAMEL_POSE_MS} ms on the camel: {verdict(one * 1e3, CAMEL_POSE_MS)}; "
      f"correspondence {correspondence:.2f} s <= {CORRESPONDENCE_S} s: {verdict(correspondence, CORRESPONDENCE_S)}")
print(load_share.report())
del dt

# 2. Same connectivity ---------------------------------------------------------------------------
print(f"\nsame connectivity: one construction, medians of {args.repeats}")
print(f"{'mesh':28s}{'triangles':>10s}{'factorise s':>13s}{'one pose ms':>13s}{'ten poses ms':>14s}")
refined = dk.subdivide(rest, faces, 2, scheme="loop")
sub = dk.Subdivider(rest, faces, 2, scheme="loop")
cases = [dict(label="horse -> other horse", points=rest, tris=faces, poses=poses),
         dict(label="refined x2 (Loop)", points=np.asarray(refined.points), tris=np.asarray(refined.faces),
              poses=np.stack([np.asarray(sub.subdivide(p)) for p in poses]))]
with OtherLoad() as load_share:
    for case in cases:
        case["target"] = other_horse(case["points"])
        t0 = time.perf_counter()
        case["dt"] = dk.DeformationTransfer(case["points"], case["tris"], case["target"])
        factor = time.perf_counter() - t0
        case["one"] = median(lambda: case["dt"].transfer(case["poses"][0]))
        case["ten"] = median(lambda: case["dt"].transfer(case["poses"]))
        print(f"{case['label']:28s}{len(case['tris']):10,d}{factor:13.3f}{case['one'] * 1e3:13.1f}"
              f"{case['ten'] * 1e3:14.1f}")
large = max(cases, key=lambda c: len(c["tris"]))
if len(large["tris"]) >= LARGE_TRIANGLES:
    print(f"  target: per pose {large['one'] * 1e3:.1f} ms at {len(large['tris']):,} triangles <= {LARGE_POSE_MS} ms "
          f"at {LARGE_TRIANGLES:,}: {verdict(large['one'] * 1e3, LARGE_POSE_MS)}")
print(load_share.report())


# 3. Blender's Transfer Shape Key ----------------------------------------------------------------
def shape_key_pair(case):
    """Source object (Basis = rest, one key per pose) and target object (Basis = the other horse)."""
    source = blender_mesh("source", case["points"], case["tris"])
    source.shape_key_add(name="Basis")
    for i, pose in enumerate(case["poses"]):
        key = source.shape_key_add(name=f"horse-{i + 1:02d}", from_mix=False)
        key.data.foreach_set("co", pose.astype(np.float32).ravel())
    target = blender_mesh("target", case["target"], case["tris"])
    target.shape_key_add(name="Basis")
    for obj in (source, target):
        obj.select_set(True)
    bpy.context.view_layer.objects.active = target  # the operator copies from the selected one onto the active
    return source, target


def key_positions(key):
    co = np.empty(len(key.data) * 3, np.float32)
    key.data.foreach_get("co", co)
    return co.reshape(-1, 3).astype(np.float64)


def drop_added_keys(target):
    blocks = target.data.shape_keys.key_blocks
    while len(blocks) > 1:
        target.shape_key_remove(blocks[-1])


def transfer_keys(source, target, keys, mode):
    for k in keys:
        source.active_shape_key_index = k + 1
        bpy.ops.object.shape_key_transfer(mode=mode)


def timed_calls(fn, target, repeats):
    """Seconds of fn() per repeat after a warm-up, the target's added keys removed (untimed) after each."""
    ts = []
    for i in range(repeats + 1):
        t0 = time.perf_counter()
        fn()
        if i:
            ts.append(time.perf_counter() - t0)
        drop_added_keys(target)
    return float(np.median(ts))


def deformkit_as_keys(dt, target, pose_set):
    """deformkit's transfer of the poses written as new shape keys of the target."""
    for x in np.reshape(dt.transfer(pose_set), (-1,) + pose_set.shape[-2:]):
        target.shape_key_add(from_mix=False).data.foreach_set("co", x.astype(np.float32).ravel())


def blender_rows(case, modes):
    source, target = shape_key_pair(case)
    diagonal = float(np.linalg.norm(np.ptp(case["target"], axis=0)))
    dk_first = case["dt"].transfer(case["poses"][0])
    rows = [("deformkit transfer (array)", case["one"], case["ten"], None)]
    rows.append(("deformkit + new shape key",
                 timed_calls(lambda: deformkit_as_keys(case["dt"], target, case["poses"][0]), target, args.blender_repeats),
                 timed_calls(lambda: deformkit_as_keys(case["dt"], target, case["poses"]), target, args.blender_repeats),
                 None))
    for mode in modes:
        transfer_keys(source, target, [0], mode)
        got = key_positions(target.data.shape_keys.key_blocks[-1])
        drop_added_keys(target)
        if mode == "OFFSET":
            offset = case["target"] + case["poses"][0] - case["points"]
            allowed = 8 * float(np.finfo(np.float32).eps) * float(np.abs(offset).max())
            if not float(np.abs(got - offset).max()) <= allowed:
                failed.append(f"{case['label']}: Transfer Shape Key OFFSET is not target + (pose - rest)")
        one_key = timed_calls(lambda: transfer_keys(source, target, [0], mode), target, args.blender_repeats)
        ten_keys = timed_calls(lambda: transfer_keys(source, target, range(len(case["poses"])), mode), target,
                               args.blender_repeats)
        distance = np.linalg.norm(got - dk_first, axis=1) / diagonal
        rows.append((f"Blender {mode}", one_key, ten_keys, distance))
    for obj in (source, target):
        mesh = obj.data
        bpy.data.objects.remove(obj)
        bpy.data.meshes.remove(mesh)
    return rows


if not args.no_blender:
    import bpy  # noqa: E402  (after the deformkit parts: its import is not in their figures)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    print(f"\nBlender {bpy.app.version_string} Transfer Shape Key vs deformkit, same connectivity; the operator call, "
          f"medians of {args.blender_repeats} (1 warm-up); deformkit's array figures are part 2's")
    print(f"{'mesh':28s}{'side':30s}{'one key ms':>12s}{'ten keys ms':>13s}{'/ dk one':>10s}"
          f"{'|key - dk| mean':>17s}{'max':>8s}  (of the diagonal, pose 1)")
    for case in cases:
        big = case is large and len(large["tris"]) > len(cases[0]["tris"])
        if big and args.blender_large == "none":
            continue
        modes = BLENDER_MODES[:1] if big and args.blender_large == "offset" else BLENDER_MODES
        with OtherLoad() as load_share:
            rows = blender_rows(case, modes)
        for k, (side, one_key, ten_keys, distance) in enumerate(rows):
            label = f"{case['label']} {len(case['tris']) // 1000}k" if k == 0 else ""
            gap = f"{distance.mean():17.1e}{distance.max():8.1e}" if distance is not None else ""
            print(f"{label:28s}{side:30s}{one_key * 1e3:12.1f}{ten_keys * 1e3:13.1f}{one_key / case['one']:10.1f}{gap}")
        print(load_share.report())

if failed:
    print("FAILED: " + "; ".join(failed))
    sys.exit(1)

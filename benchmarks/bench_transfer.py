"""Deformation transfer, same connectivity: Sumner's horse poses onto another horse on its mesh.

    .venv/bin/python benchmarks/bench_transfer.py [--repeats R]

dk.DeformationTransfer of ../shared/transfer's horse_ref onto a second character on the horse's
mesh (a smooth non-affine reshaping, as tests/transfer uses), and onto the same pair refined by
dk.subdivide (Loop) to 270k triangles: construction (the gradient system factorised), one pose,
the ten poses at once. The issue's targets at the camel's size (43,814 triangles) and at 200k
triangles are per-pose times after factoring; the camel itself needs the unlike-mesh
correspondence, not built yet. Skips with a message when ../shared/transfer is absent.
"""
import argparse
import pathlib
import sys
import time

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from bench_common import OtherLoad, cpu_busy, timings  # noqa: E402

TRANSFER = pathlib.Path(__file__).resolve().parents[1].parent / "shared" / "transfer"

ap = argparse.ArgumentParser()
ap.add_argument("--repeats", type=int, default=7)
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


def median(fn):
    return float(np.median(timings(fn, args.repeats)))


rest, faces = load("horse_ref")
poses = np.stack([load(f"horse-{i:02d}")[0] for i in range(1, 11)])
print(f"deformkit {dk.build_info()}  |  CPUs busy before the run {cpu_busy():.0%}")
print(f"{'mesh':28s}{'triangles':>10s}{'factorise s':>13s}{'one pose ms':>13s}{'ten poses ms':>14s}")
cases = [("horse -> other horse", rest, faces, poses)]
refined = dk.subdivide(rest, faces, 2, scheme="loop")
sub = dk.Subdivider(rest, faces, 2, scheme="loop")
cases.append(("refined x2 (Loop)", np.asarray(refined.points), np.asarray(refined.faces),
              np.stack([np.asarray(sub.subdivide(p)) for p in poses])))
with OtherLoad() as load_share:
    for label, points, tris, pose_set in cases:
        target = other_horse(points)
        t0 = time.perf_counter()
        dt = dk.DeformationTransfer(points, tris, target)
        factor = time.perf_counter() - t0
        one = median(lambda: dt.transfer(pose_set[0]))
        ten = median(lambda: dt.transfer(pose_set))
        print(f"{label:28s}{len(tris):10,d}{factor:13.3f}{one * 1e3:13.1f}{ten * 1e3:14.1f}")
print(load_share.report())

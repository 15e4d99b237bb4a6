"""The derivative paths beside deform, at 1M points: Jacobians, carried normals and volume ratios.

    .venv/bin/python benchmarks/bench_derivatives.py [--points N] [--repeats R]

For Barr's twist, bend and taper and the FFD and Blender lattices: deform (the anchor, float64
and float32), jacobian, transform_normals (float64, and float32 points and normals) and
volume_ratio, and jacobian into a reused out= array (no page faults: what the kernels cost),
medians of R calls on N random points in [-1, 1]^3, with a numpy copy of the
points as the memory-bandwidth yardstick, all in one run; for the lattices also bind (float64 and
float32). Issue 19's targets: Barr transform_normals >= 200 M points/s (<= 5 ms at 1M), jacobian
<= 5 ms, volume_ratio <= 3 ms; the lattices' derivative paths within 2x of their deform (float32
normals against float32 deform), and their bind <= 10 ms at 1M.
"""
import argparse
import pathlib
import sys

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from bench_common import OtherLoad, timings  # noqa: E402

import deformkit as dk  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("--points", type=int, default=1_000_000)
ap.add_argument("--repeats", type=int, default=11)
args = ap.parse_args()

rng = np.random.default_rng(0)
p64 = rng.uniform(-1, 1, (args.points, 3))
n64 = rng.normal(size=p64.shape)
p32, n32 = p64.astype(np.float32), n64.astype(np.float32)


def median_ms(fn):
    return 1e3 * float(np.median(timings(fn, args.repeats)))


lattice = dk.FFD(3)
lattice.control_points = lattice.rest_control_points + 0.05 * rng.normal(size=lattice.rest_control_points.shape)
blender = dk.BlenderLattice((4, 4, 4))
blender.control_points = blender.rest_control_points + 0.05 * rng.normal(size=blender.rest_control_points.shape)
deformers = [("Twist", dk.Twist(rate=2.0)), ("Bend", dk.Bend(curvature=0.8)), ("Taper", dk.Taper(rate=0.5)),
             ("FFD (cubic)", lattice), ("BlenderLattice 4^3", blender)]
print(f"deformkit {dk.build_info()}  |  {args.points:,} points, medians of {args.repeats}")
with OtherLoad() as load:
    copy = median_ms(lambda: p64.copy())
    print(f"numpy copy of the float64 points: {copy:.2f} ms (the memory yardstick)")
    # The jacobian's floor: writing its (n, 3, 3) float64 result, into new memory (page faults, as
    # jacobian() without out= must) and into memory already touched (as with out=).
    fresh = median_ms(lambda: np.full((args.points, 3, 3), 1.0))
    touched = np.empty((args.points, 3, 3))
    refill = median_ms(lambda: touched.fill(2.0))
    print(f"numpy writing an ({args.points:,}, 3, 3) float64 array: {fresh:.2f} ms new (np.full), {refill:.2f} ms "
          f"already touched (fill): the jacobian's floor without and with out= (one thread)")
    head = (f"{'deformer':20} {'deform f64':>10} {'deform f32':>10} {'jacobian':>9} {'normals f64':>11} {'normals f32':>11}"
            f" {'volume':>7} {'jac out=':>9}   (ms)")
    jac_out = np.empty((args.points, 3, 3))
    print(head)
    for name, d in deformers:
        row = [median_ms(lambda: d.deform(p64)), median_ms(lambda: d.deform(p32)), median_ms(lambda: d.jacobian(p64)),
               median_ms(lambda: d.transform_normals(p64, n64)), median_ms(lambda: d.transform_normals(p32, n32)),
               median_ms(lambda: d.volume_ratio(p64)), median_ms(lambda: d.jacobian(p64, out=jac_out))]
        print(f"{name:20} " + " ".join(f"{v:{w}.2f}" for v, w in zip(row, (10, 10, 9, 11, 11, 7, 9)))
              + f"   normals f64 {args.points / row[3] / 1e3:.0f} M points/s")
        if hasattr(d, "bind"):
            ratios = [row[2] / row[0], row[3] / row[0], row[4] / row[1], row[5] / row[0]]
            bind = [median_ms(lambda: d.bind(p64)), median_ms(lambda: d.bind(p32))]
            print(f"{'':20} / deform: jacobian {ratios[0]:.2f}x, normals f64 {ratios[1]:.2f}x, f32 {ratios[2]:.2f}x, "
                  f"volume {ratios[3]:.2f}x (<= 2x: {'met' if max(ratios) <= 2 else 'missed'});  bind f64 "
                  f"{bind[0]:.2f} ms, f32 {bind[1]:.2f} ms (<= 10 ms: {'met' if max(bind) <= 10 else 'missed'})")
    # The bind's floor: what it writes into new memory per point (parameters 3 doubles, status 1
    # byte, order 4 bytes, the points and their cell coordinates sorted by cell, 6 values), written
    # by numpy into a new array of that size.
    for label, value_bytes in (("f64", 8), ("f32", 4)):
        nbytes = args.points * (3 * 8 + 1 + 4 + 6 * value_bytes)
        floor = median_ms(lambda: np.full(nbytes, 1, np.uint8))
        print(f"lattice bind {label} writes {nbytes / 1e6:.0f} MB into new memory; numpy filling a new array of that "
              f"size: {floor:.2f} ms (one thread)")
print(load.report())

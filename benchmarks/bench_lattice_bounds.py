"""Certified volume-ratio bounds of the box lattices (issue 34): how long a certificate takes.

    .venv/bin/python benchmarks/bench_lattice_bounds.py [--repeats R] [--json PATH]

Cases (control points moved by a seeded normal perturbation, none folded unless said):
- a tricubic 4x4x4 Bezier block (BezierFFD(1)): volume_ratio_bounds(tolerance=1e-3) and fold_free;
  target <= 1 ms;
- a 16x16x16 B-spline lattice (BSplineLattice(16), 13^3 = 2197 tricubic cells): the same;
  target <= 50 ms (both cores);
- the trilinear Blender lattice (BlenderLattice(64, 'linear'), 63^3 = 250047 cells): the same and
  deformed_volume, in cells per second (gmsh's rate for linear hexahedra: millions a second).

Each row: median wall time of R calls after a warm-up, the CPU seconds of this process over the
same calls (both cores count), and the share of the CPUs other processes used meanwhile
(bench_common.OtherLoad): the machine is shared, so the CPU time is the figure to compare.
"""
import argparse
import json
import os
import resource
import statistics
import sys
import time

import numpy as np

import deformkit as dk
from bench_common import OtherLoad

TARGETS = {"bezier-block": 1e-3, "bspline-16": 50e-3}


def cpu_seconds():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def moved(lattice, amount, seed):
    rng = np.random.default_rng(seed)
    lattice.control_points = lattice.rest_control_points + rng.normal(0, amount, lattice.rest_control_points.shape)
    return lattice


def measure(fn, repeats):
    fn()  # warm-up
    walls, cpu0 = [], cpu_seconds()
    with OtherLoad() as load:
        for _ in range(repeats):
            t0 = time.perf_counter()
            result = fn()
            walls.append(time.perf_counter() - t0)
    return {"wall_s": statistics.median(walls), "wall_min_s": min(walls), "cpu_s": (cpu_seconds() - cpu0) / repeats,
            "other_load": load.share, "result": repr(result)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    cases = {
        "bezier-block": (moved(dk.BezierFFD(1), 0.04, 1), args.repeats * 10),
        "bspline-16": (moved(dk.BSplineLattice(16), 0.01, 2), args.repeats),
        "blender-linear-64": (moved(dk.BlenderLattice(64, "linear"), 0.002, 3), max(3, args.repeats // 4)),
    }
    rows = []
    print(f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f} at the start")
    for name, (lat, repeats) in cases.items():
        cells = int(np.prod(lat.cell_grid))
        for what, fn in (("volume_ratio_bounds", lambda: lat.volume_ratio_bounds(tolerance=1e-3)),
                         ("fold_free", lambda: lat.fold_free()), ("deformed_volume", lambda: lat.deformed_volume())):
            r = measure(fn, repeats)
            # The bounds of a Blender linear lattice also cover its faces as Blender evaluates them.
            n = {"volume_ratio_bounds": lambda: fn().cells, "fold_free": lambda: fn().cells_checked}.get(what, lambda: cells)()
            r.update(case=name, call=what, cells=n, cells_per_cpu_s=n / r["cpu_s"] if r["cpu_s"] else float("nan"))
            target = TARGETS.get(name)
            verdict = "" if target is None or what == "deformed_volume" else \
                f"  target <= {target * 1e3:.0f} ms: {'met' if r['wall_s'] <= target else 'NOT met'} (wall)"
            print(f"{name:18s} {what:20s} {n:7d} cells  wall {r['wall_s'] * 1e3:8.2f} ms (min "
                  f"{r['wall_min_s'] * 1e3:.2f})  CPU {r['cpu_s'] * 1e3:8.2f} ms  {r['cells_per_cpu_s'] / 1e6:6.2f} M "
                  f"cells/CPU-s  others {r['other_load']:.0%}{verdict}")
            rows.append(r)
        print(f"   {rows[-3]['result']}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())

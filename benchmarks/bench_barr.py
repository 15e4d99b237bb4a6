"""Throughput of deformkit's Barr deformers against straightforward numpy and a plain copy.

    .venv/bin/python benchmarks/bench_barr.py [--points N] [--repeats R] [--json PATH]

Figures are million points per second, best of R timed runs after one warm-up. "dk out=" writes
into a preallocated array (the same memory traffic as np.copyto, the headline), "dk alloc" returns
a new array. The copy rows are the physical limit: one thread (np.copyto) and one per deformkit
thread (np.copyto on contiguous slices from a thread pool; numpy releases the GIL while copying).
"""
import argparse
import json
import os
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

import deformkit as dk
from bench_common import cpu_busy

TARGET_MPTS, TARGET_RATIO = 300.0, 20.0  # project targets: twist, taper, bend in float32


# Plain numpy, written as a user would: same formulas as the docstrings of deformkit.
def np_twist(p, rate, lo, hi):
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    t = rate * np.clip(z, lo, hi)
    c, s = np.cos(t), np.sin(t)
    return np.stack([x * c - y * s, x * s + y * c, z], axis=1)


def np_taper(p, rate, lo, hi):
    r = 1 + rate * np.clip(p[:, 2], lo, hi)
    return np.stack([r * p[:, 0], r * p[:, 1], p[:, 2]], axis=1)


def np_bend(p, k, y0, lo, hi):
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    yh = np.clip(y, lo, hi)
    t = k * (yh - y0)
    c, s = np.cos(t), np.sin(t)
    return np.stack([x, -s * (z - 1 / k) + y0 + c * (y - yh), c * (z - 1 / k) + 1 / k + s * (y - yh)], axis=1)


def np_stretch(p, k, lo, hi):
    zc = np.clip(p[:, 2], lo, hi)
    s = 1 + k * (zc * zc - 1)
    return np.stack([s * p[:, 0], s * p[:, 1], p[:, 2] + k * zc], axis=1)


def np_simple_twist(p, angle):  # Blender SIMPLE_DEFORM twist about X, limits (0, 1)
    x = p[:, 0]
    lo, hi = x.min(), x.max()
    t = angle / (hi - lo) * x  # x already lies in [lo, hi]
    c, s = np.cos(t), np.sin(t)
    return np.stack([x, p[:, 1] * c - p[:, 2] * s, p[:, 1] * s + p[:, 2] * c], axis=1)


CASES = [  # name, deformkit deformer, numpy function
    ("Twist", dk.Twist(rate=1.2, limits=(-0.8, 0.8)), lambda p: np_twist(p, 1.2, -0.8, 0.8)),
    ("Taper", dk.Taper(rate=0.4, limits=(-0.8, 0.8)), lambda p: np_taper(p, 0.4, -0.8, 0.8)),
    ("Bend", dk.Bend(curvature=0.7, center=0.1, region=(-0.6, 0.6)), lambda p: np_bend(p, 0.7, 0.1, -0.6, 0.6)),
    ("Stretch", dk.Stretch(factor=0.3, limits=(-0.8, 0.8)), lambda p: np_stretch(p, 0.3, -0.8, 0.8)),
    ("SimpleDeform(TWIST)", dk.SimpleDeform(mode="TWIST", angle=1.0), lambda p: np_simple_twist(p, 1.0)),
    ("Stack(twist, bend)",
     dk.Stack([dk.Twist(rate=1.2, limits=(-0.8, 0.8)), dk.Bend(curvature=0.7, center=0.1, region=(-0.6, 0.6))]),
     lambda p: np_bend(np_twist(p, 1.2, -0.8, 0.8), 0.7, 0.1, -0.6, 0.6)),
]
TOL = {np.float32: dict(rtol=1e-5, atol=2e-6), np.float64: dict(rtol=1e-12, atol=1e-14)}  # |p| <= ~3


def best_rates(fns, n, repeats):
    """Million points per second of each function: best of `repeats` back-to-back timed calls
    after a warm-up call (so each sees its data as warm in cache as the previous call left it)."""
    rates = []
    for fn in fns:
        fn()
        best = float("inf")
        for _ in range(repeats):
            t0 = time.perf_counter()
            fn()
            best = min(best, time.perf_counter() - t0)
        rates.append(n / best / 1e6)
    return rates


def l3_bytes():
    try:
        with open("/sys/devices/system/cpu/cpu0/cache/index3/size") as f:
            text = f.read().strip()  # e.g. "107520K"
        return int(text[:-1]) << {"K": 10, "M": 20}[text[-1]]
    except (OSError, ValueError, KeyError):
        return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=1_000_000, help="number of points (default 1e6)")
    ap.add_argument("--repeats", type=int, default=20, help="timed calls per figure, best one kept")
    ap.add_argument("--json", metavar="PATH", help="also write the figures to this JSON file")
    args = ap.parse_args()
    n, reps = args.points, args.repeats
    info = dk.build_info()
    threads = int(info.get("threads", 1))
    print("deformkit", dk.__version__, "build_info:", info)
    print(f"numpy {np.__version__}, {n:,} points uniform in [-1, 1]^3, best of {reps} after a warm-up, M points/s")
    busy = cpu_busy()
    print(f"CPU busy before the run (other processes): {busy:.0%} of {os.cpu_count()} CPUs"
          + ("  ** the machine is not idle: figures are unreliable **" if busy > 0.1 else "") + "\n")

    pool = ThreadPoolExecutor(threads)
    rows, copies = [], {}
    head = f"{'dtype':7} {'deformer':20} {'dk out=':>8} {'dk alloc':>8} {'numpy':>7} {'dk/np':>6} {'%copy':>6}  target"
    for dtype in (np.float32, np.float64):
        pts = np.random.default_rng(1).uniform(-1, 1, (n, 3)).astype(dtype)
        out = np.empty_like(pts)
        cuts = np.linspace(0, n, threads + 1).astype(int)
        copy1, copyt = best_rates([lambda: np.copyto(out, pts), lambda: list(pool.map(
            lambda a, b: np.copyto(out[a:b], pts[a:b]), cuts[:-1], cuts[1:]))], n, reps)
        name, l3, ws = np.dtype(dtype).name, l3_bytes(), 2 * pts.nbytes
        where = "" if l3 is None else f" {'<' if ws < l3 else '>'} L3 {l3 >> 20} MB: " + (
            "cache-resident" if ws < l3 else "memory-bound")
        copies[name] = {"copy_1thread": copy1, f"copy_{threads}threads": copyt}
        limit = max(copy1, copyt)
        print(f"{name}: copy bandwidth {copy1:7.1f} M pts/s (np.copyto, 1 thread), "
              f"{copyt:7.1f} M pts/s ({threads} threads) = {copyt * 1e6 * 2 * 3 * pts.itemsize / 1e9:.1f} GB/s read+write"
              f" (working set in+out {ws / 2**20:.0f} MB{where})")
        print(head)
        for label, d, ref in CASES:
            # Apples to apples: both sides compute the same map (checked before any timing).
            want, got = ref(pts), d.deform(pts)
            assert got.dtype == dtype and want.dtype == dtype, (label, got.dtype, want.dtype)
            diff = float(np.abs(got - want).max())
            assert np.allclose(got, want, **TOL[dtype]), f"{label} {name}: max |dk - numpy| = {diff:.3g}"
            d.deform(pts, out=out)
            assert np.array_equal(out, got), f"{label} {name}: out= differs from the allocating call"
            r_out, r_alloc, r_np = best_rates([lambda: d.deform(pts, out=out), lambda: d.deform(pts),
                                               lambda: ref(pts)], n, reps)
            tgt = ""
            if dtype is np.float32 and label in ("Twist", "Taper", "Bend"):
                misses = [f"< {TARGET_MPTS:.0f} M pts/s"] * (r_out < TARGET_MPTS) + [
                    f"< {TARGET_RATIO:.0f}x numpy"] * (r_out / r_np < TARGET_RATIO)
                tgt = "MISSED: " + ", ".join(misses) if misses else "met"
            print(f"{name:7} {label:20} {r_out:8.1f} {r_alloc:8.1f} {r_np:7.1f} {r_out / r_np:5.1f}x "
                  f"{100 * r_out / limit:5.0f}%  {tgt}")
            rows.append({"dtype": name, "deformer": label, "dk_out_mpts": r_out, "dk_alloc_mpts": r_alloc,
                         "numpy_mpts": r_np, "ratio_out_vs_numpy": r_out / r_np,
                         "max_abs_diff_vs_numpy": diff})
        print()
    print(f"%copy: 'dk out=' against the faster copy (same bytes read and written). target: the project's"
          f" float32 goal for twist, taper and bend, >= {TARGET_MPTS:.0f} M pts/s and >= {TARGET_RATIO:.0f}x numpy.")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"build_info": info, "numpy": np.__version__, "points": n, "repeats": reps,
                       "cpu_busy_before": busy, "copy_mpts": copies, "results": rows}, f, indent=2)
        print("wrote", args.json)


if __name__ == "__main__":
    main()

"""The installed module against another build of it, case by case, in the same session: for a
re-organisation that must not make anything slower.

    .venv/bin/python benchmarks/bench_before_after.py BEFORE_DIR [--rounds R]

BEFORE_DIR holds an installed copy of the other build's `deformkit` package (for example
`cp -a .venv/lib/python3.11/site-packages/deformkit BEFORE_DIR/` before the change). Each round
runs one timing pass per module in its own process, alternating before and after; the best
(minimum) time per case over the rounds is kept. Cases: 1e6 points in [-1, 1]^3 through Barr
deformers and lattices (deform, bind, deform_bound, float32 and float64), a Jacobian, and, when
../shared/meshes is present, mesh_volume and SurfaceDeformer on ogre.obj and subdivide on beast.obj.
"""
import argparse
import json
import os
import pathlib
import subprocess
import sys
import time

MESHES = pathlib.Path(__file__).resolve().parents[1].parent / "shared" / "meshes"


def best(f, repeats):
    f()
    t = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        f()
        t = min(t, time.perf_counter() - start)
    return t * 1e3


def one_pass():
    """Times every case once with the deformkit on sys.path; returns {case: ms}."""
    import numpy as np
    import deformkit as dk
    rng = np.random.default_rng(0)
    res = {}
    n = 1_000_000
    for dt in (np.float32, np.float64):
        p = rng.uniform(-1, 1, (n, 3)).astype(dt)
        out = np.empty_like(p)
        for k, d in {"Twist": dk.Twist(rate=1.0), "Bend": dk.Bend(curvature=0.7),
                     "SimpleDeform": dk.SimpleDeform("TWIST", angle=1.0)}.items():
            res[f"{dt.__name__} {k} deform"] = best(lambda: d.deform(p, out=out), 7)
        for name, lat in {"FFD3": dk.FFD(3, origin=(-1, -1, -1), edges=np.eye(3) * 2),
                          "Blender4": dk.BlenderLattice(4, origin=(-1, -1, -1), edges=np.eye(3) * 2)}.items():
            lat.control_points = lat.rest_control_points + rng.normal(0, 0.05, lat.rest_control_points.shape)
            res[f"{dt.__name__} {name} deform"] = best(lambda: lat.deform(p, out=out), 7)
            res[f"{dt.__name__} {name} bind"] = best(lambda: lat.bind(p), 3)
            b = lat.bind(p)
            res[f"{dt.__name__} {name} deform_bound"] = best(lambda: lat.deform_bound(b, out=out), 7)
    p = rng.uniform(-1, 1, (n, 3))
    twist = dk.Twist(rate=1.0)
    res["float64 Twist jacobian"] = best(lambda: twist.jacobian(p), 5)
    if MESHES.is_dir():
        import trimesh
        m = trimesh.load(MESHES / "ogre.obj", process=False)
        v, f = np.asarray(m.vertices), np.asarray(m.faces, dtype=np.int32)
        order = np.argsort(v[:, 1])
        lo, hi = order[: len(v) // 300], order[-(len(v) // 300):]
        res["mesh_volume ogre"] = best(lambda: dk.mesh_volume(v, f), 20)
        for method in ("laplacian", "arap"):
            res[f"SurfaceDeformer {method} construct"] = best(
                lambda: dk.SurfaceDeformer(v, f, anchors=lo, handles=hi, method=method), 3)
            sd = dk.SurfaceDeformer(v, f, anchors=lo, handles=hi, method=method)
            res[f"SurfaceDeformer {method} deform"] = best(lambda: sd.deform(v[hi] + [0.1, 0, 0]), 3)
        b = trimesh.load(MESHES / "beast.obj", process=False)
        bv, bf = np.asarray(b.vertices), np.asarray(b.faces, dtype=np.int32)
        res["subdivide beast level 2"] = best(lambda: dk.subdivide(bv, bf, 2), 3)
        sub = dk.Subdivider(bv, bf, 2)
        res["Subdivider beast level 2 re-evaluate"] = best(lambda: sub.subdivide(bv), 5)
    return res


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("before", nargs="?", help="folder holding the other build's deformkit package")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--pass", dest="one", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one:
        print(json.dumps(one_pass()))
        return 0
    if not args.before or not (pathlib.Path(args.before) / "deformkit").is_dir():
        ap.error(f"before: expected a folder holding a deformkit package, got {args.before!r}")
    runs = {"before": [], "after": []}
    for _ in range(args.rounds):
        for tag in runs:
            env = dict(os.environ)
            env.pop("PYTHONPATH", None)
            if tag == "before":
                env["PYTHONPATH"] = str(pathlib.Path(args.before).resolve())
            done = subprocess.run([sys.executable, __file__, "--pass"], env=env, capture_output=True, text=True,
                                  cwd=pathlib.Path(args.before).resolve().parent)
            if done.returncode:
                sys.exit(f"{tag} pass failed:\n{done.stderr}")
            runs[tag].append(json.loads(done.stdout))
    print(f"{'case':40s} {'before ms':>10s} {'after ms':>10s} {'after/before':>13s}")
    for k in runs["before"][0]:
        o = min(r[k] for r in runs["before"])
        n = min(r[k] for r in runs["after"])
        print(f"{k:40s} {o:10.2f} {n:10.2f} {n / o:13.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

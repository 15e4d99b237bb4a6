"""Generated cages (issue 33): dk.generate_cage against the alpha wrap alone, the hand-made cages of
../shared/cages and, when it is installed in a separate environment, PyPI's nested-cages (Sacht,
Vouga, Jacobson 2015).

    .venv/bin/python benchmarks/bench_generate_cage.py [--models Beast,Ogre] [--repeats R]
        [--nested-python /tmp/nc/bin/python] [--nested-timeout S]

For each model: the budget is the hand-made cage's triangle count (its polygons fanned). Time is
the best of R calls; memory is the peak resident size a fresh process adds for the call (the mesh
loaded, the module imported; VmHWM reset through /proc/self/clear_refs). Tightness, for every
cage: its volume over the mesh's, the one-sided distance from
the cage to the mesh (20,000 points sampled evenly on the cage, distance to the nearest mesh
vertex, mean and max, over the mesh's diagonal) and the mesh vertices outside it (winding number).
The alpha wrap alone is generate_cage with the same alpha and an unlimited budget (no collapse
runs). nested-cages is GPL and not a dependency: install it in its own venv
(python -m venv /tmp/nc && /tmp/nc/bin/pip install nested-cages) and pass --nested-python.
Skips with a message when ../shared/cages is absent.
"""
import argparse
import json
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
CAGES = ROOT.parent / "shared" / "cages"
MODELS = ["Beast", "Bench", "FireHydrant", "ManHead", "Ogre", "SpikyBox", "WireSphere"]

CHILD = r"""
import json, sys, time, numpy as np
kind, path, budget, alpha = sys.argv[1], sys.argv[2], int(sys.argv[3]), float(sys.argv[4])
d = np.load(path)
V, F = d["V"], d["F"]
if kind == "nested":
    from nested_cages import nested_cages
else:
    import deformkit as dk
def status(key):
    return next(int(l.split()[1]) for l in open("/proc/self/status") if l.startswith(key + ":"))
open("/proc/self/clear_refs", "w").write("5")  # the peak (VmHWM) restarts from the current size
before = status("VmRSS")
t = time.perf_counter()
if kind == "nested":
    try:
        cp, cf = nested_cages(np.asfortranarray(V), np.asfortranarray(F.astype(np.int32)), [budget])[0]
    except Exception as e:
        print(json.dumps({"error": f"{type(e).__name__}: {e}"})); sys.exit(0)
else:
    cp, cf = dk.generate_cage(V, F, max_faces=budget, alpha=alpha if alpha > 0 else None)
seconds = time.perf_counter() - t
after = status("VmHWM")
np.savez(path + ".out.npz", P=np.asarray(cp, float), F=np.asarray(cf, np.int64))
print(json.dumps({"seconds": seconds, "rss_mb": (after - before) / 1024}))
"""


def fan(faces):
    return np.array([(f[0], f[i], f[i + 1]) for f in faces for i in range(1, len(f) - 1)], dtype=np.int64)


def volume(points, triangles):
    p = (points - points.mean(axis=0))[triangles]
    return np.einsum("ti,ti->t", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6


def tightness(cp, ct, mesh_points, tree, diag, winding_numbers):
    import trimesh
    samples, _ = trimesh.sample.sample_surface_even(trimesh.Trimesh(cp, ct, process=False), 20000, seed=0)
    d, _ = tree.query(samples)
    outside = int(np.sum(winding_numbers(mesh_points, cp, ct) < 0.5))
    return d.mean() / diag, d.max() / diag, outside


def child(python, kind, path, budget, alpha, timeout):
    try:
        out = subprocess.run([python, "-c", CHILD, kind, path, str(budget), str(alpha)], capture_output=True, text=True,
                             timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": f"no result in {timeout} s"}
    if out.returncode != 0:
        return {"error": (out.stderr.strip().splitlines() or ["exit " + str(out.returncode)])[-1]}
    r = json.loads(out.stdout.strip().splitlines()[-1])
    if "error" not in r:
        c = np.load(path + ".out.npz")
        r["P"], r["F"] = c["P"], c["F"]
    return r


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--models", default=",".join(MODELS))
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--nested-python", default=None)
    ap.add_argument("--nested-timeout", type=float, default=300)
    args = ap.parse_args()
    if not CAGES.is_dir():
        print(f"bench_generate_cage: {CAGES} is absent (the project's test data); nothing to measure")
        return
    sys.path.insert(0, str(ROOT / "tests" / "cage"))
    import trimesh
    from cage_files import read_polygons, winding_numbers
    from scipy.spatial import cKDTree

    print("| model (triangles) | cage | faces | time s | +memory MB | volume / mesh's | distance mean / max (of diag) | vertices outside |")
    print("|---|---|---|---|---|---|---|---|")
    for name in args.models.split(","):
        mesh = trimesh.load(CAGES / f"{name}.obj", process=False, force="mesh")
        V, F = np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64)
        hp, hf = read_polygons(CAGES / f"{name}_Cage.obj")
        ht = fan(hf)
        budget = len(ht)
        diag = float(np.linalg.norm(np.ptp(V, axis=0)))
        size = diag + 2 * diag / 100
        alpha = size / min(max(1.2 * np.sqrt(budget), 4), 20)  # generate_cage's default for this budget
        tree = cKDTree(V)
        mesh_volume = abs(volume(V, F))
        rows = [("hand-made", {"P": hp, "F": ht})]
        with tempfile.TemporaryDirectory() as tmp:
            path = str(pathlib.Path(tmp) / "mesh.npz")
            np.savez(path, V=V, F=F)
            runs = [child(sys.executable, "generate", path, budget, 0.0, 600) for _ in range(args.repeats)]
            best = min(runs, key=lambda r: r.get("seconds", np.inf))
            rows.append(("generate_cage", best))
            rows.append(("alpha wrap alone", child(sys.executable, "generate", path, 10**7, alpha, 600)))
            if args.nested_python:
                rows.append(("nested-cages", child(args.nested_python, "nested", path, budget, 0.0, args.nested_timeout)))
        for label, r in rows:
            if "error" in r:
                print(f"| {name} ({len(F)}) | {label} | - | - | - | - | {r['error']} | - |")
                continue
            cp, ct = np.asarray(r["P"], float), np.asarray(r["F"], np.int64)
            mean, worst, outside = tightness(cp, ct, V, tree, diag, winding_numbers)
            secs = f"{r['seconds']:.2f}" if "seconds" in r else "-"
            mem = f"{r['rss_mb']:.0f}" if "rss_mb" in r else "-"
            print(f"| {name} ({len(F)}) | {label} | {len(ct)} | {secs} | {mem} | {abs(volume(cp, ct)) / mesh_volume:.2f} | "
                  f"{mean:.4f} / {worst:.4f} | {outside} |", flush=True)


if __name__ == "__main__":
    main()

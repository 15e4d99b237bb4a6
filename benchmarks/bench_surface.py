"""Surface deformation speed (issues 5 and 19): dk.SurfaceDeformer against Blender's Laplacian Deform modifier and CGAL's Surface_mesh_deformation (ARAP).

    .venv/bin/python benchmarks/bench_surface.py [--mesh PATH] [--repeats R] [--skip-blender] [--skip-cgal]
                                                 [--skip-subdivided] [--ri-limit SECONDS] [--cgal-iterations K]
                                                 [--drag-tolerance TOL] [--json PATH]

Meshes (from ../shared/meshes, skipped with a message when that folder is absent):
  * ogre.obj as loaded by trimesh (process=False): 62,194 vertices in 44 connected components
    (body, eyes, teeth, ...), or the mesh given with --mesh;
  * "ogre body, loop x1": the largest connected component of ogre (26,034 vertices), one Loop
    subdivision (trimesh.remesh.subdivide_loop, edge midpoints shared) -> 104,068 vertices, one component.
Anchors: the lowest 0.3% of the vertices in y (the feet); handles: the highest 0.3% in y (the head).
Every connected component that gets neither also gets one anchor (its lowest vertex): Blender's
modifier has no answer for a component without anchors (its normal matrix is singular; on ogre it
produced displacements of ~1000 units), and deformkit gets exactly the same anchor set. Handle
targets: the handles translated by 10% of the mesh height in x.

deformkit (no Blender in the loop): construction = bind (assembly + ordering + factorisation) for
'laplacian', 'arap' and 'rotation_invariant' (cotangent weights). A bind remembers the fill-reducing
ordering of its mesh's connectivity for the next bind of the same connectivity (another method,
other iterations, other anchors, a reload): "first bind" = the orderings forgotten before each
timed bind (dk._core._forget_remembered_orderings), "rebind" = the same mesh bound again. Each first
bind's stages (SurfaceDeformer.bind_stages: wall ms, the binding thread's CPU ms, minor page faults)
are printed. "re-solve" = deform() of the laplacian deformer, set against its floor: the triangular
solves read the factor twice, so two reads of its size at the read bandwidth measured here (numpy
copy and sum of a buffer of the factor's size, 1 and 2 threads). ARAP iteration = (deform with
iterations=11 - deform with iterations=1) / 10, tolerance 0. ARAP drag: the handles moved from rest
to the edit's targets in 60 equal steps, tolerance --drag-tolerance (relative energy decrease,
default 1e-3), at most 200 iterations a step, four ways: initial = the previous result with plain
local/global steps, the same with anderson=5, initial = dk.extrapolated_start of the last two
results, plain (what the add-on's viewport ARAP entry does) and with anderson=5; cold = from R = I, on steps
10, 20, .., 60: median iterations and ms per step, the previous-start / cold energy ratio at the
cold steps, and each way's last result against ARAP run to convergence.
deformkit's iterations=k is k + 1 global solves (the first with identity rotations) and k local
steps. The two ARAP deforms are timed again with OpenMP limited to one thread (libgomp's
omp_set_num_threads) for the comparison with CGAL, which runs on one thread.
'rotation_invariant' is constructed once per mesh and skipped on a mesh when it took longer than
--ri-limit seconds on a smaller one (estimated with the observed growth).

CGAL (benchmark-only dependency: Debian's libcgal-dev 5.5.1, installed by scripts/setup_bench.sh,
which `make bench` runs; without it this part prints "skipped: ... run scripts/setup_bench.sh" and
the rest goes on; --skip-cgal leaves it out): benchmarks/cgal_arap/cgal_arap.cpp, configured with
the .venv's cmake into build/bench-cgal (Release: -O2 -DNDEBUG, no -march, plus CGAL's own
-frounding-math) on first use and rebuilt incrementally afterwards, runs in a child process after
the deformkit part. It reads the mesh, anchors, handles and targets from a temporary binary file
and builds a CGAL::Surface_mesh<Simple_cartesian<double>::Point_3> (both meshes are accepted as
they are: ogre's 44 components, boundaries and 4 zero-area faces included); region of interest =
every vertex, control vertices = anchors + handles (anchors keep their rest position as target).
Surface_mesh_deformation<..., ORIGINAL_ARAP> with its defaults: cotangent weights, Eigen SparseLU
(COLAMD) on the system with identity rows for control vertices, polar closest rotations.
  bind = constructor (halfedge weights) + insert ROI / control vertices + preprocess() (assembly +
         factorisation): one warm-up, then max(3, min(R, 5)) timed binds on fresh objects, median.
  deform(k) = deform(k, tolerance 0) alone. CGAL's deform() warm-starts from the previous call's
         positions and rotations, so every call is preceded (untimed) by reset() (rest positions,
         identity rotations) and set_target_position() on the handles: each call does the same
         work. One CGAL iteration = global step (3 back-substitutions) + local step (rotations);
         its output is the k-th global solve, so deform(k + 1) has the global solves of deformkit's
         iterations=k (deform(2) is set against deformkit's iterations=1). One warm-up, then R
         timed calls for k = 1, 2, 11; ARAP iteration = (deform(11) - deform(1)) / 10.
  cross-check (untimed): CGAL deform(K + 1) against deformkit arap iterations=K (--cgal-iterations,
         default 10), max and RMS of |x_CGAL - x_dk| over the bounding-box diagonal. The weights are
         not the same: deformkit takes w = (cot a + cot b) / 2 (cotangents clamped to +-1e4) and
         raises w <= 0 to 1e-3 x the mean positive weight; CGAL (Weights::Cotangent_weight) clamps
         each negative cotangent to 0 before the sum, so every edge opposite an obtuse angle
         differs and an edge opposite two gets 0 (zero-area corners: cot 0). The same CGAL run is
         therefore repeated with a custom weight calculator returning deformkit's weights: that
         result must agree to rounding (~1e-12), the first one shows what the weighting rules change.
The figures are printed beside deformkit's from the same run (CGAL/dk ratios) and are in --json.

Blender (PyPI bpy, the same process, after the deformkit part): the same mesh as a mesh object, a
vertex group "anchors" = anchors + handles (weight 1; Blender's modifier treats every vertex in the
group as a soft anchor whose target is its *incoming* position), a Laplacian Deform modifier
(Repeat = iterations 1 and 5). Bind = bpy.ops.object.laplaciandeform_bind() with the object as
context (the operator forces one evaluation of the modifier, which builds and factorises the
system and solves once). The handles are moved by a Hook modifier (an empty, handles assigned)
placed before the Laplacian Deform, the usual animation set-up: a frame = set the empty's location
(the target offset, or back to zero on alternate frames, so every frame is a real change),
depsgraph update, read the evaluated positions (foreach_get). With the Hook the modifier keeps its
factorisation between frames. The same frame loop with the Laplacian Deform disabled
(show_viewport=False, Hook still on) is timed in the same run; "modifier only" = median(with) -
median(without), i.e. the modifier's re-evaluation alone. Blender's own per-modifier timer
(Modifier.execution_time of the evaluated object) is printed beside it. For information, two frames
that instead rewrite the base positions (foreach_set + mesh.update()) are timed too: that path makes
Blender rebuild and refactorise the system on every frame, so it is not used for the comparison.

All figures: median (and min) over R timed calls after one untimed warm-up call, except the
one-shot rows (rotation_invariant construction, Blender bind). "other processes used N% of the
CPUs" counts neither this process nor the CGAL child it waited for.
"""
import argparse
import json
import os
import pathlib
import shutil
import statistics
import subprocess
import tempfile
import time

import numpy as np

import deformkit as dk
from bench_common import OtherLoad, cpu_busy, omp_threads, timings

ROOT = pathlib.Path(__file__).resolve().parents[1]
MESHES = ROOT.parent / "shared" / "meshes"
TARGET_BIND = 0.5        # s, construction (factorisation)
TARGET_RI_BIND = 1.5     # s, rotation-invariant construction (issue 19)
TARGET_DRAG_ITERATIONS = 3  # ARAP iterations per step of a small-step drag, warm-started (issue 19)
DRAG_STEPS = 60
DRAG_TOLERANCE = 1e-3
TARGET_RESOLVE = 0.020   # s, one Laplacian re-solve
TARGET_ARAP_IT = 0.060   # s, one ARAP iteration
TARGET_VS_BLENDER = 5.0  # x faster than Blender's Laplacian Deform per frame
FRACTION = 0.003         # anchors / handles: 0.3% of the vertices at each end in y
CGAL_SRC = ROOT / "benchmarks" / "cgal_arap"
CGAL_BUILD = ROOT / "build" / "bench-cgal"
CGAL_ITERATIONS = 10     # cross-check: deformkit iterations=K against CGAL deform(K + 1)


# ---------------------------------------------------------------------------------------------
# helpers (same conventions as bench_lattice.py)

def med(ts):
    return statistics.median(ts)


def components(n, faces):
    """Connected-component label per vertex (vectorised min-label propagation + pointer jumping)."""
    lab = np.arange(n)
    a = faces.ravel()
    b = np.roll(faces, -1, axis=1).ravel()
    while True:
        old = lab.copy()
        m = np.minimum(lab[a], lab[b])
        np.minimum.at(lab, lab[a], m)
        np.minimum.at(lab, lab[b], m)
        while True:
            nxt = lab[lab]
            if np.array_equal(nxt, lab):
                break
            lab = nxt
        if np.array_equal(lab, old):
            return np.unique(lab, return_inverse=True)[1]


def weight_stats(points, faces):
    """Edges whose cotangent weight the two libraries treat differently: deformkit raises an edge
    weight (cot a + cot b) / 2 <= 0 to a small positive floor; CGAL clamps each negative cotangent to 0
    before the sum (so any edge opposite an obtuse angle differs, and both-obtuse edges get 0)."""
    cots, edges = [], []
    for k in range(3):
        a, b, c = faces[:, k], faces[:, (k + 1) % 3], faces[:, (k + 2) % 3]
        u, w = points[b] - points[a], points[c] - points[a]
        cross, dot = np.linalg.norm(np.cross(u, w), axis=1), np.einsum("ij,ij->i", u, w)
        cots.append(np.divide(dot, cross, out=np.zeros_like(dot), where=cross > 0))
        edges.append(np.sort(np.stack([b, c], 1), 1))
    cots = np.concatenate(cots)
    _, inv = np.unique(np.concatenate(edges), axis=0, return_inverse=True)
    inv = inv.ravel()
    total = np.bincount(inv, 0.5 * cots)
    negative = np.bincount(inv, cots < 0) > 0
    return {"edges": len(total), "edges_floored_dk": int((total <= 0).sum()),
            "edges_negative_cot": int(negative.sum()), "obtuse_corners": float((cots < 0).mean())}


# ---------------------------------------------------------------------------------------------
# meshes and the edit

def load_obj(path):
    import trimesh
    m = trimesh.load(str(path), process=False, force="mesh")
    return np.ascontiguousarray(m.vertices, dtype=np.float64), np.ascontiguousarray(m.faces, dtype=np.int64)


def largest_component_loop(points, faces):
    import trimesh
    lab = components(len(points), faces)
    big = np.argmax(np.bincount(lab))
    fk = faces[lab[faces[:, 0]] == big]
    used = np.unique(fk)
    remap = np.full(len(points), -1, np.int64)
    remap[used] = np.arange(len(used))
    v, f = trimesh.remesh.subdivide_loop(points[used], remap[fk])
    return np.ascontiguousarray(v, dtype=np.float64), np.ascontiguousarray(f, dtype=np.int64), len(used)


def make_edit(points, faces):
    n = len(points)
    k = max(1, int(round(FRACTION * n)))
    order = np.argsort(points[:, 1], kind="stable")
    anchors, handles = order[:k], order[-k:]
    lab = components(n, faces)
    ncomp = lab.max() + 1
    has = np.zeros(ncomp, bool)
    has[lab[anchors]] = True
    has[lab[handles]] = True
    extra = []
    for c in np.flatnonzero(~has):
        idx = np.flatnonzero(lab == c)
        extra.append(idx[np.argmin(points[idx, 1])])
    anchors = np.concatenate([anchors, np.asarray(extra, np.int64)])
    height = np.ptp(points[:, 1])
    targets = points[handles] + np.array([0.1 * height, 0.0, 0.0])
    return {"anchors": anchors, "handles": handles, "targets": targets, "components": int(ncomp),
            "extra_anchors": len(extra), "k": k}


# ---------------------------------------------------------------------------------------------
# deformkit

def print_breakdown(breakdown):
    """Each first bind's stages (SurfaceDeformer.bind_stages): wall ms, the binding thread's CPU ms
    (below the wall time when other programs take the core, or when the pool's threads do the work)
    and minor page faults (first touches of fresh memory)."""
    for method, stages in breakdown.items():
        total = sum(s[1] for s in stages)
        print(f"  where the first {method} bind's time goes ({total * 1e3:.0f} ms in stages; wall ms, "
              f"this thread's CPU ms, minor page faults):")
        for stage, wall, cpu, faults in stages:
            if wall >= 0.0005:
                print(f"    {stage:62s}{wall * 1e3:9.1f}{cpu * 1e3:9.1f}{faults:9d}")


def bandwidth(nbytes):
    """GB/s of a memory copy (bytes read + written) and of a read (numpy sum) of nbytes, on 1 and 2
    threads (numpy releases the GIL: each thread takes half), best of 5."""
    import threading
    a = np.ones(max(nbytes // 8, 1024))
    b = np.empty_like(a)

    def best(work, threads):
        parts = np.array_split(np.arange(len(a)), threads)
        spans = [(p[0], p[-1] + 1) for p in parts]
        out = []
        for _ in range(5):
            ts = [threading.Thread(target=work, args=span) for span in spans]
            t0 = time.perf_counter()
            for t in ts:
                t.start()
            for t in ts:
                t.join()
            out.append(time.perf_counter() - t0)
        return min(out)

    copy = lambda i, j: np.copyto(b[i:j], a[i:j])  # noqa: E731
    read = lambda i, j: a[i:j].sum()  # noqa: E731
    return ({k: 2 * a.nbytes / best(copy, k) / 1e9 for k in (1, 2)},
            {k: a.nbytes / best(read, k) / 1e9 for k in (1, 2)})


def dense_rate(n=3000):
    """GFlop/s of a dense n x n matrix product through numpy's BLAS (its threads: both cores), best of
    3: what a sparse factorisation's dense kernels could reach at most on this machine."""
    a = np.random.default_rng(0).random((n, n))
    best = min(timeit(lambda: a @ a) for _ in range(3))
    return 2 * n ** 3 / best / 1e9


def timeit(work):
    t0 = time.perf_counter()
    work()
    return time.perf_counter() - t0


def numeric_limit(stages):
    """The rotation-invariant bind's floor: its numeric factorisation's flops at the dense rate."""
    import re
    for name, wall, _cpu, _faults in stages:
        m = re.search(r"implicit 3n: numeric \(.*?([\d.]+) GFlop\)", name)
        if m:
            gflop, rate = float(m.group(1)), dense_rate()
            return (f"its numeric factorisation does {gflop:.1f} GFlop in {wall * 1e3:.0f} ms ({gflop / wall:.1f} GFlop/s, "
                    f"CHOLMOD on the serial BLAS it links); a dense product through numpy's BLAS on both cores runs at "
                    f"{rate:.1f} GFlop/s, so that step alone takes at least {gflop / rate * 1e3:.0f} ms here")
    return None


def resolve_limit(factor_entries, solve_seconds):
    """The re-solve's floor: the triangular solves read the factor's values (8 bytes an entry, a row
    index per supernode row besides) once forward and once backward."""
    nbytes = 8 * factor_entries
    copy, read = bandwidth(nbytes)
    return {"factor_mb": nbytes / 1e6, "solve_gbs": 2 * nbytes / solve_seconds / 1e9, "copy_gbs": copy,
            "read_gbs": read, "floor_ms": 2 * nbytes / (max(read.values()) * 1e9) * 1e3}


DRAG_STARTS = (  # (label, anderson window, initial guess): plain warm start, accelerated, predicted
    ("previous", 0, "previous"),
    ("previous, anderson 5", 5, "previous"),
    ("extrapolated", 0, "extrapolated"),
    ("extrapolated, anderson 5", 5, "extrapolated"),
)
DRAG_CHOSEN = "extrapolated"  # what the add-on's viewport ARAP entry does (its solver is plain)


def arap_drag(points, faces, kw, final_targets, tolerance, steps=DRAG_STEPS, cold_every=10):
    """The handles dragged from rest to final_targets in `steps` equal steps, ARAP to `tolerance`
    (relative energy decrease) at most 200 iterations a step, for each of DRAG_STARTS: initial =
    the previous step's result, or dk.extrapolated_start of the last two; anderson 0 (plain
    local/global) or 5. Cold, from R = I, plain, on every cold_every-th step (the same targets).
    Each variant's last result is set against ARAP run to convergence (relative decrease 1e-8)."""
    H = kw["handles"]
    start = points[H]
    targets_at = [start + (final_targets - start) * (k / steps) for k in range(steps + 1)]
    out = {"steps": steps, "tolerance": tolerance, "variants": {}, "cold": []}
    for label, window, guess in DRAG_STARTS:
        arap = dk.SurfaceDeformer(points, faces, method="arap", iterations=200, tolerance=tolerance, anderson=window, **kw)
        results, rows = [points, points], []
        for k in range(1, steps + 1):
            initial = results[-1]
            if guess == "extrapolated" and k >= 2:
                initial = dk.extrapolated_start(results[-1], results[-2], targets_at[k], targets_at[k - 1], targets_at[k - 2])
            t0 = time.perf_counter()
            x = arap.deform(targets_at[k], initial=initial)
            rows.append((len(arap.energy), time.perf_counter() - t0, arap.energy[-1]))
            results = [results[-1], x]
            if window == 0 and guess == "previous" and k % cold_every == 0:
                t0 = time.perf_counter()
                arap.deform(targets_at[k])
                out["cold"].append([k, len(arap.energy), time.perf_counter() - t0, arap.energy[-1], rows[-1][2]])
        its, secs, energy = np.array(rows).T
        out["variants"][label] = {"iterations": its.tolist(), "seconds": secs.tolist(), "energy": energy.tolist(),
                                  "last": results[-1]}
    ref = dk.SurfaceDeformer(points, faces, method="arap", iterations=3000, tolerance=1e-8, anderson=5, **kw)
    converged = ref.deform(final_targets, initial=out["variants"][DRAG_CHOSEN]["last"])
    diag = float(np.linalg.norm(np.ptp(points, axis=0)))
    for v in out["variants"].values():
        v["excess_energy"] = v["energy"][-1] / ref.energy[-1] - 1
        v["distance_to_converged"] = float(np.abs(v.pop("last") - converged).max()) / diag
    out["converged_energy"] = ref.energy[-1]
    return out


def print_drag(d):
    print(f"  ARAP drag, {d['steps']} steps to the edit's targets, tolerance {d['tolerance']:g} (relative energy "
          f"decrease); last step against ARAP converged (energy {d['converged_energy']:.5g}):")
    for label, v in d["variants"].items():
        its, secs = np.array(v["iterations"]), np.array(v["seconds"])
        met = "yes" if np.median(its) <= TARGET_DRAG_ITERATIONS else "NO"
        print(f"    {label:26s} iterations per step median {np.median(its):.0f}, mean {its.mean():.1f}, first "
              f"{its[0]:.0f}, max {its.max():.0f} (target <= {TARGET_DRAG_ITERATIONS}: {met}); ms per step median "
              f"{np.median(secs) * 1e3:.0f}, mean {secs.mean() * 1e3:.0f}; last step: energy {100 * v['excess_energy']:.2f}% "
              f"above converged, max distance {v['distance_to_converged']:.1e} of the diagonal")
    cold = np.array(d["cold"])
    print(f"    cold (R = I) on steps {', '.join(str(int(k)) for k in cold[:, 0])}: iterations median "
          f"{np.median(cold[:, 1]):.0f}, ms median {np.median(cold[:, 2]) * 1e3:.0f}; 'previous' / cold energy at those "
          f"steps {', '.join(f'{w / c:.3f}' for w, c in zip(cold[:, 4], cold[:, 3]))}")


def dk_part(name, points, faces, edit, reps, ri_state, ri_limit, res, drag_tolerance):
    n = len(points)
    A, H, T = edit["anchors"], edit["handles"], edit["targets"]
    kw = dict(anchors=A, handles=H, weights="cotangent")
    rows = []

    def build(method, iterations=10):
        return dk.SurfaceDeformer(points, faces, method=method, iterations=iterations, tolerance=0.0, **kw)

    reps_bind = max(3, min(reps, 5))

    def first_binds(method, iterations=10):
        """Binds that each order from scratch (the orderings remembered per connectivity forgotten
        first), after one untimed warm-up; the last one's deformer is kept for its stages."""
        build(method, iterations)
        ts = []
        for _ in range(reps_bind):
            dk._core._forget_remembered_orderings()
            t0 = time.perf_counter()
            d = build(method, iterations)
            ts.append(time.perf_counter() - t0)
        return ts, d

    t_lap_first, lap = first_binds("laplacian")
    t_lap = timings(lambda: build("laplacian"), reps_bind)  # rebinds: the ordering is remembered
    t_arap_first, arap_first = first_binds("arap", 1)
    t_arap = timings(lambda: build("arap", 1), reps_bind)
    free = lap.free_count
    breakdown = {"laplacian": lap.bind_stages, "arap": arap_first.bind_stages}
    del arap_first
    rows.append(("construct laplacian (first bind)", t_lap_first, TARGET_BIND))
    rows.append(("construct laplacian (rebind, same mesh)", t_lap, TARGET_BIND))
    rows.append(("construct arap (first bind)", t_arap_first, TARGET_BIND))
    rows.append(("construct arap (rebind, same mesh)", t_arap, TARGET_BIND))

    # rotation_invariant: once, unless a smaller mesh predicts it to be too slow
    ri_t = None
    predicted = None
    if ri_state.get("t") is not None:
        growth = (free / ri_state["free"]) ** 1.5  # assumed superlinear growth, for the skip decision
        predicted = ri_state["t"] * growth
    if predicted is not None and predicted > ri_limit:
        ri_note = f"skipped: predicted ~{predicted:.0f} s from {ri_state['t']:.1f} s at {ri_state['free']:,} free vertices (> --ri-limit {ri_limit:.0f} s)"
    else:
        dk._core._forget_remembered_orderings()
        t0 = time.perf_counter()
        ri = build("rotation_invariant")
        ri_t = time.perf_counter() - t0
        breakdown["rotation_invariant"] = ri.bind_stages
        ri_state.update(t=ri_t, free=free)
        ri_res = timings(lambda: ri.deform(T), max(3, min(reps, 5)))
        del ri
        ri_note = None
        rows.append(("construct rotation_invariant (first bind)", [ri_t], TARGET_RI_BIND))
        rows.append(("  rotation_invariant deform", ri_res, None))

    t_solve = timings(lambda: lap.deform(T), reps)
    rows.append(("laplacian re-solve (deform)", t_solve, TARGET_RESOLVE))
    limit = resolve_limit(lap.factor_nonzeros, med(t_solve))

    a1, a11, a5 = build("arap", 1), build("arap", 11), build("arap", 5)
    t1 = timings(lambda: a1.deform(T), reps)
    t11 = timings(lambda: a11.deform(T), reps)
    t5 = timings(lambda: a5.deform(T), reps)
    it = (med(t11) - med(t1)) / 10
    rows.append(("arap deform, iterations=1", t1, None))
    rows.append(("arap deform, iterations=5", t5, None))
    rows.append(("arap deform, iterations=11", t11, None))
    rows.append(("ARAP iteration = (it11 - it1) / 10", [it], TARGET_ARAP_IT))
    # the same on one OpenMP thread, for the comparison with CGAL (single-threaded)
    it_1thread = None
    with omp_threads(1) as limited:
        if limited:
            s1, s11 = timings(lambda: a1.deform(T), reps), timings(lambda: a11.deform(T), reps)
            it_1thread = (med(s11) - med(s1)) / 10
            rows.append(("arap deform, iterations=1, 1 thread", s1, None))
            rows.append(("arap deform, iterations=11, 1 thread", s11, None))
            rows.append(("ARAP iteration, 1 thread", [it_1thread], None))

    # sanity: handles at targets, anchors at rest, energies decreasing
    out = lap.deform(T)
    chk_l = (np.abs(out[H] - T).max(), np.abs(out[edit["anchors"]] - points[edit["anchors"]]).max())
    out_a = a11.deform(T)
    e = np.asarray(a11.energy)
    print(f"== deformkit, {name}: {n:,} vertices, {len(faces):,} faces, {edit['components']} component(s); "
          f"{len(A):,} anchors ({edit['k']} lowest in y + {edit['extra_anchors']} one per otherwise "
          f"unconstrained component), {len(H):,} handles (highest in y); {free:,} free vertices")
    print(f"  {'':44s}{'median ms':>10s}{'min ms':>9s}{'target':>10s}{'met':>5s}")
    for label, ts, target in rows:
        md, mn = med(ts), min(ts)
        tgt = f"<= {target * 1e3:.0f}" if target else ""
        met = ("yes" if md <= target else "NO") if target else ""
        print(f"  {label:44s}{md * 1e3:10.1f}{mn * 1e3:9.1f}{tgt:>10s}{met:>5s}")
    if ri_note:
        print(f"  construct rotation_invariant: {ri_note}")
    print(f"  check: laplacian |handle - target| max {chk_l[0]:.2g}, |anchor - rest| max {chk_l[1]:.2g}; "
          f"arap x11 energy {e[0]:.4g} -> {e[-1]:.4g} ({'monotone' if np.all(np.diff(e) <= 1e-9 * abs(e[0])) else 'NOT monotone'}), "
          f"max displacement {np.linalg.norm(out_a - points, axis=1).max():.3g} (edit {0.1 * np.ptp(points[:, 1]):.3g})")
    print_breakdown(breakdown)
    print(f"  re-solve limit: the factor holds {lap.factor_nonzeros:,} entries ({limit['factor_mb']:.0f} MB); a solve reads "
          f"it twice (forward, backward): {2 * limit['factor_mb']:.0f} MB in {med(t_solve) * 1e3:.1f} ms = "
          f"{limit['solve_gbs']:.1f} GB/s. Memory copy of {limit['factor_mb']:.0f} MB: {limit['copy_gbs'][1]:.1f} GB/s "
          f"(read + write, 1 thread), {limit['copy_gbs'][2]:.1f} GB/s (2 threads); read: {limit['read_gbs'][1]:.1f} / "
          f"{limit['read_gbs'][2]:.1f} GB/s (1 / 2 threads) -> two reads of the factor take at least "
          f"{limit['floor_ms']:.1f} ms")
    if "rotation_invariant" in breakdown:
        ri_limit_figures = numeric_limit(breakdown["rotation_invariant"])
        if ri_limit_figures:
            print("  rotation_invariant limit: " + ri_limit_figures)
    drag = arap_drag(points, faces, kw, T, drag_tolerance)
    print_drag(drag)
    res.update({"bind_laplacian_first": med(t_lap_first), "bind_arap_first": med(t_arap_first),
                "resolve_limit": limit, "drag": drag,
                "bind_stages": {k: [list(s) for s in v] for k, v in breakdown.items()}})
    res.update({"vertices": n, "free": free, "bind_laplacian": med(t_lap), "bind_arap": med(t_arap),
                "bind_rotation_invariant": ri_t, "resolve_laplacian": med(t_solve), "arap_it1": med(t1),
                "arap_it5": med(t5), "arap_it11": med(t11), "arap_iteration": it,
                "arap_iteration_1thread": it_1thread})


# ---------------------------------------------------------------------------------------------
# CGAL (benchmark-only dependency: Debian's libcgal-dev, scripts/setup_bench.sh)

def cgal_tool():
    """(path of cgal_arap, CGAL package version) built into build/bench-cgal, or (None, reason)."""
    try:
        q = subprocess.run(["dpkg-query", "-W", "-f=${Status}\t${Version}", "libcgal-dev"],
                           capture_output=True, text=True)
        status, _, version = q.stdout.partition("\t")
        installed = "install ok installed" in status
    except FileNotFoundError:  # not a Debian system: look for the header
        installed, version = pathlib.Path("/usr/include/CGAL/Surface_mesh_deformation.h").exists(), "?"
    if not installed:
        return None, "libcgal-dev is not installed"
    venv_bin = ROOT / ".venv" / "bin"
    cmake = str(venv_bin / "cmake") if (venv_bin / "cmake").exists() else shutil.which("cmake")
    if not cmake:
        return None, "cmake not found"
    env = dict(os.environ, PATH=f"{venv_bin}{os.pathsep}{os.environ.get('PATH', '')}")
    CGAL_BUILD.mkdir(parents=True, exist_ok=True)
    steps = [("build", [cmake, "--build", str(CGAL_BUILD)])]
    if not (CGAL_BUILD / "CMakeCache.txt").exists():
        generator = ["-G", "Ninja"] if shutil.which("ninja", path=env["PATH"]) else []
        steps.insert(0, ("configure", [cmake, "-S", str(CGAL_SRC), "-B", str(CGAL_BUILD), *generator,
                                       "-DCMAKE_BUILD_TYPE=Release"]))
    for step, cmd in steps:
        log = CGAL_BUILD / f"{step}.log"
        with open(log, "w") as f:
            r = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, env=env)
        if r.returncode != 0:
            tail = "".join(log.read_text().splitlines(keepends=True)[-15:])
            return None, f"the {step} of {CGAL_SRC.relative_to(ROOT)} failed (see {log}):\n{tail}"
    return CGAL_BUILD / "cgal_arap", version


def cgal_part(name, points, faces, edit, reps, res, exe, iterations):
    n = len(points)
    A, H, T = edit["anchors"], edit["handles"], edit["targets"]
    reps_bind = max(3, min(reps, 5))
    if faces.ndim != 2 or faces.shape[1] != 3:
        print(f"== CGAL, {name}: skipped: Surface_mesh_deformation needs a triangle mesh")
        res["cgal_error"] = "not a triangle mesh"
        return
    with tempfile.TemporaryDirectory(prefix="bench-cgal-") as tmp:
        tmp = pathlib.Path(tmp)
        with open(tmp / "input.bin", "wb") as f:  # the format cgal_arap.cpp reads
            f.write(b"DKCGAL01" + np.array([n, len(faces), len(A), len(H)], "<i8").tobytes())
            for arr, dt in ((points, "<f8"), (faces, "<i8"), (A, "<i8"), (H, "<i8"), (T, "<f8")):
                f.write(np.ascontiguousarray(arr, dtype=dt).tobytes())
        cmd = [str(exe), str(tmp / "input.bin"), "--repeats", str(reps), "--bind-repeats", str(reps_bind),
               "--result-iterations", str(iterations + 1), "--out", str(tmp / "cgal.f64"),
               "--out-dk-weights", str(tmp / "cgal_dkw.f64")]
        r = subprocess.run(cmd, capture_output=True, text=True)
        try:
            out = json.loads(r.stdout)
        except json.JSONDecodeError:
            out = {"ok": False, "error": f"exit code {r.returncode}, no JSON: {r.stdout[-300:]} {r.stderr[-500:]}"}
        if not out.get("ok"):
            print(f"== CGAL, {name}: FAILED: {out.get('error')}")
            res["cgal_error"] = out.get("error")
            return
        xc = np.fromfile(tmp / "cgal.f64").reshape(n, 3)
        xw = np.fromfile(tmp / "cgal_dkw.f64").reshape(n, 3) if out.get("dk_weights_preprocess_ok") else None
    # cross-check (untimed): deformkit's ARAP with `iterations` against CGAL's deform(iterations + 1)
    xd = dk.SurfaceDeformer(points, faces, anchors=A, handles=H, method="arap", weights="cotangent",
                            iterations=iterations, tolerance=0.0).deform(T)
    diag = float(np.linalg.norm(np.ptp(points, axis=0)))
    dist = lambda x: np.linalg.norm(x - xd, axis=1)
    d_c = dist(xc)
    d_w = dist(xw) if xw is not None else None
    ws = weight_stats(points, faces)

    print(f"== CGAL {out['cgal_version']} Surface_mesh_deformation<ORIGINAL_ARAP> (Eigen {out['eigen_version']} SparseLU, "
          f"1 thread), {name}: ROI = {out['roi']:,} of {n:,} vertices (all with a face), {out['controls']:,} control "
          f"vertices (the same anchors + handles" + (f"; {out['isolated_controls']} without a face left out"
                                                     if out.get("isolated_controls") else "") + ")")
    print(f"  {'':58s}{'median ms':>10s}{'min ms':>9s}{'deformkit ms':>14s}{'CGAL/dk':>9s}")
    lines = [("bind: constructor + ROI/controls + preprocess()", out["bind_all"], res.get("bind_arap")),
             ("  of which constructor (halfedge weights)", [out["bind_weights"]], None),
             ("  of which preprocess() (assembly + SparseLU)", [out["bind_preprocess"]], None),
             ("deform(1): 1 global + 1 local step", out["deform_1_all"], None),
             ("deform(2): 2 global + 2 local (dk: iterations=1)", out["deform_2_all"], res.get("arap_it1")),
             ("deform(11)", out["deform_11_all"], None),
             ("ARAP iteration = (deform(11) - deform(1)) / 10", [out["iteration"]], res.get("arap_iteration"))]
    if res.get("arap_iteration_1thread"):
        lines.append(("ARAP iteration vs deformkit on 1 thread", [out["iteration"]], res["arap_iteration_1thread"]))
    for label, ts, ref in lines:
        cmp = f"{ref * 1e3:14.1f}{med(ts) / ref:8.2f}x" if ref else ""
        print(f"  {label:58s}{med(ts) * 1e3:10.1f}{min(ts) * 1e3:9.1f}{cmp}")
    print(f"  check: |handle - target| max {out['handle_error']:.2g}, |anchor - rest| max {out['anchor_error']:.2g}, "
          f"max displacement {out['max_displacement']:.3g}")
    print(f"  cross-check, deformkit arap iterations={iterations} vs CGAL deform({iterations + 1}) (both {iterations + 1} "
          f"global solves): max |x_CGAL - x_dk| = {d_c.max() / diag:.2e} x bbox diagonal ({diag:.4g}), "
          f"RMS {np.sqrt((d_c ** 2).mean()) / diag:.2e}")
    if d_w is not None:
        print(f"    CGAL with deformkit's edge weights (custom weight calculator): max {d_w.max() / diag:.2e}, "
              f"RMS {np.sqrt((d_w ** 2).mean()) / diag:.2e} -> the remaining difference is the weighting rule")
    print(f"    weights: {ws['edges_negative_cot']:,} of {ws['edges']:,} edges are opposite an obtuse angle (CGAL "
          f"clamps that cotangent to 0), {out['zero_weight_edges']:,} get CGAL weight 0, "
          f"{ws['edges_floored_dk']:,} get deformkit's positive floor")
    res.update({"cgal_version": out["cgal_version"], "cgal_bind": out["bind"], "cgal_bind_weights": out["bind_weights"],
                "cgal_bind_preprocess": out["bind_preprocess"], "cgal_deform1": out["deform_1"],
                "cgal_deform2": out["deform_2"], "cgal_deform11": out["deform_11"], "cgal_iteration": out["iteration"],
                "cgal_check_iterations": iterations, "cgal_vs_dk_max": float(d_c.max() / diag),
                "cgal_vs_dk_rms": float(np.sqrt((d_c ** 2).mean()) / diag),
                "cgal_dkweights_vs_dk_max": float(d_w.max() / diag) if d_w is not None else None,
                "cgal_zero_weight_edges": out["zero_weight_edges"], **{f"weights_{k}": v for k, v in ws.items()}})


# ---------------------------------------------------------------------------------------------
# Blender

def blender_part(name, points, faces, edit, reps, res):
    import bpy
    n = len(points)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    me = bpy.data.meshes.new("bench_surface")
    me.vertices.add(n)
    me.vertices.foreach_set("co", points.astype(np.float32).ravel())
    me.loops.add(faces.size)
    me.loops.foreach_set("vertex_index", faces.astype(np.int32).ravel())
    me.polygons.add(len(faces))
    me.polygons.foreach_set("loop_start", np.arange(0, faces.size, faces.shape[1], dtype=np.int32))
    me.update(calc_edges=True)
    ob = bpy.data.objects.new("bench_surface", me)
    bpy.context.scene.collection.objects.link(ob)
    bpy.context.view_layer.objects.active = ob
    ob.select_set(True)
    H, T = edit["handles"], edit["targets"]
    group = np.concatenate([edit["anchors"], H])
    vg = ob.vertex_groups.new(name="anchors")
    vg.add(group.tolist(), 1.0, "REPLACE")
    # handles are moved by a Hook modifier (an empty) in front of the Laplacian Deform, the usual
    # animation set-up; the modifier keeps its factorisation across such frames
    emp = bpy.data.objects.new("bench_surface_hook", None)
    bpy.context.scene.collection.objects.link(emp)
    hook = ob.modifiers.new("Hook", "HOOK")
    hook.object = emp
    hook.vertex_indices_set(H.tolist())
    md = ob.modifiers.new("LaplacianDeform", "LAPLACIANDEFORM")
    md.vertex_group = "anchors"
    md.iterations = 1
    dg = bpy.context.evaluated_depsgraph_get()
    dg.update()

    offset = tuple(T[0] - points[H[0]])
    out = np.empty(3 * n, np.float32)
    pos = me.attributes["position"].data
    rest = points.astype(np.float32).ravel()

    def frame_loop(count, state):
        ts, exec_t = [], []
        for i in range(count):
            state[0] ^= 1
            t0 = time.perf_counter()
            emp.location = offset if state[0] == 0 else (0.0, 0.0, 0.0)
            dg.update()
            ob.evaluated_get(dg).data.attributes["position"].data.foreach_get("vector", out)
            ts.append(time.perf_counter() - t0)
            if md.show_viewport:
                exec_t.append(ob.evaluated_get(dg).modifiers["LaplacianDeform"].execution_time)
        return ts, exec_t

    def base_edit_frame():  # rewrite the base positions (unchanged values) + mesh.update()
        t0 = time.perf_counter()
        pos.foreach_set("vector", rest)
        me.update()
        dg.update()
        ob.evaluated_get(dg).data.attributes["position"].data.foreach_get("vector", out)
        return time.perf_counter() - t0

    # bind (the operator evaluates the modifier once: build, factorise, solve)
    t0 = time.perf_counter()
    with bpy.context.temp_override(object=ob, active_object=ob, selected_objects=[ob]):
        r = bpy.ops.object.laplaciandeform_bind(modifier=md.name)
    t_bind = time.perf_counter() - t0
    if "FINISHED" not in r or not md.is_bind:
        print(f"== Blender, {name}: bind failed ({r}, is_bind={md.is_bind}); not timed")
        return
    state = [1]
    t_first = frame_loop(1, state)[0][0]  # first frame after bind (runtime cache state)
    rows = {}
    for it in (1, 5):
        md.iterations = it
        frame_loop(1, state)  # warm-up after the change
        rows[it] = frame_loop(reps, state)
    # check: the evaluated handles follow the moved base positions
    state[0] = 1
    md.iterations = 1
    frame_loop(1, state)  # state 0 = moved
    got = out.reshape(-1, 3)
    chk = np.abs(got[H] - T).max()
    disp = np.linalg.norm(got - points, axis=1).max()
    t_base_edit = [base_edit_frame() for _ in range(2)]
    md.show_viewport = False
    dg.update()
    base = frame_loop(reps + 1, state)[0][1:]
    md.show_viewport = True

    print(f"== Blender {bpy.app.version_string} Laplacian Deform, {name}: {n:,} vertices, vertex group of "
          f"{len(group):,} (anchors + handles), Hook on the handles, frames alternate hook at target offset / at rest")
    print(f"  {'':58s}{'median ms':>10s}{'min ms':>9s}")
    lines = [(f"bind (laplaciandeform_bind operator, one call)", [t_bind]),
             (f"first frame after bind (Repeat 1)", [t_first])]
    for it in (1, 5):
        lines.append((f"frame, Repeat {it}: hook moved + depsgraph + read", rows[it][0]))
        lines.append((f"  Blender's execution_time of the modifier", rows[it][1]))
    lines.append(("frame, Laplacian Deform disabled (Hook only)", base))
    lines.append(("base positions rewritten + mesh.update() (Repeat 1, 2 calls)", t_base_edit))
    for label, ts in lines:
        print(f"  {label:58s}{med(ts) * 1e3:10.1f}{min(ts) * 1e3:9.1f}")
    only = {it: med(rows[it][0]) - med(base) for it in (1, 5)}
    for it in (1, 5):
        print(f"  {'modifier only, Repeat %d (frame - disabled frame)' % it:58s}{only[it] * 1e3:10.1f}")
    print(f"  check (Repeat 1): |evaluated handle - target| max {chk:.3g} (soft constraints), "
          f"max displacement {disp:.3g}")
    res.update({"blender_bind": t_bind, "blender_first_frame": t_first, "blender_frame_r1": med(rows[1][0]),
                "blender_frame_r5": med(rows[5][0]), "blender_exec_r1": med(rows[1][1]),
                "blender_exec_r5": med(rows[5][1]), "blender_base": med(base),
                "blender_only_r1": only[1], "blender_only_r5": only[5]})
    res["blender_base_edit_frame"] = med(t_base_edit)
    bpy.data.objects.remove(ob)
    bpy.data.objects.remove(emp)
    bpy.data.meshes.remove(me)


# ---------------------------------------------------------------------------------------------

def summary_table(results):
    print("== summary (issue 5 and 19 targets on this machine; 'vs Blender' = Blender modifier-only per frame / dk; "
          "CGAL/dk ratios > 1: deformkit faster)")
    hdr = f"  {'':46s}" + "".join(f"{name[:22]:>24s}" for name in results)
    print(hdr)

    def row(label, fn):
        cells = []
        for r in results.values():
            try:
                cells.append(fn(r))
            except (KeyError, TypeError, ZeroDivisionError):
                cells.append("-")
        print(f"  {label:46s}" + "".join(f"{c:>24s}" for c in cells))

    ms = lambda x: f"{x * 1e3:.1f} ms"
    ok = lambda x, t: f"{x * 1e3:.1f} ms {'ok' if x <= t else 'MISS'}"
    row("vertices (free)", lambda r: f"{r['vertices']:,} ({r['free']:,})")
    row(f"dk first bind laplacian (<= {TARGET_BIND * 1e3:.0f} ms)", lambda r: ok(r["bind_laplacian_first"], TARGET_BIND))
    row(f"dk rebind laplacian, same mesh (<= {TARGET_BIND * 1e3:.0f} ms)", lambda r: ok(r["bind_laplacian"], TARGET_BIND))
    row(f"dk first bind arap (<= {TARGET_BIND * 1e3:.0f} ms)", lambda r: ok(r["bind_arap_first"], TARGET_BIND))
    row(f"dk rebind arap, same mesh (<= {TARGET_BIND * 1e3:.0f} ms)", lambda r: ok(r["bind_arap"], TARGET_BIND))
    row(f"dk first bind rotation_invariant (<= {TARGET_RI_BIND:.1f} s)",
        lambda r: ok(r["bind_rotation_invariant"], TARGET_RI_BIND) if r["bind_rotation_invariant"] else "skipped")
    row(f"dk laplacian re-solve (<= {TARGET_RESOLVE * 1e3:.0f} ms)", lambda r: ok(r["resolve_laplacian"], TARGET_RESOLVE))
    row("  floor: 2 reads of the factor (2 threads)", lambda r: f"{r['resolve_limit']['floor_ms']:.1f} ms")
    chosen = lambda r: r["drag"]["variants"][DRAG_CHOSEN]
    previous = lambda r: r["drag"]["variants"]["previous"]
    row(f"dk ARAP drag, its/step add-on's start (<= {TARGET_DRAG_ITERATIONS})",
        lambda r: f"{np.median(chosen(r)['iterations']):.0f} {'ok' if np.median(chosen(r)['iterations']) <= TARGET_DRAG_ITERATIONS else 'MISS'}")
    row("dk ARAP drag, ms/step add-on's / previous / cold its",
        lambda r: f"{np.median(chosen(r)['seconds']) * 1e3:.0f} / {np.median(previous(r)['seconds']) * 1e3:.0f} ms / "
                  f"{np.median([c[1] for c in r['drag']['cold']]):.0f}")
    row(f"dk ARAP iteration (<= {TARGET_ARAP_IT * 1e3:.0f} ms)", lambda r: ok(r["arap_iteration"], TARGET_ARAP_IT))
    row("dk arap deform iterations=1 / 5", lambda r: f"{r['arap_it1'] * 1e3:.0f} / {r['arap_it5'] * 1e3:.0f} ms")
    row("dk ARAP iteration, 1 thread", lambda r: ms(r["arap_iteration_1thread"]))
    row("CGAL bind (constructor + preprocess)", lambda r: ms(r["cgal_bind"]) if "cgal_bind" in r else r.get("cgal_error", "-")[:22])
    row("CGAL bind / dk bind arap", lambda r: f"{r['cgal_bind'] / r['bind_arap']:.1f}x")
    row("CGAL ARAP iteration (1 thread)", lambda r: ms(r["cgal_iteration"]))
    row("CGAL / dk ARAP iteration (dk 2 / 1 threads)",
        lambda r: f"{r['cgal_iteration'] / r['arap_iteration']:.1f}x" + (
            f" / {r['cgal_iteration'] / r['arap_iteration_1thread']:.1f}x" if r.get("arap_iteration_1thread") else ""))
    row("CGAL deform(2) / dk arap iterations=1", lambda r: f"{r['cgal_deform2'] / r['arap_it1']:.1f}x")
    row("|CGAL - dk| max / diag (dk weights)",
        lambda r: f"{r['cgal_vs_dk_max']:.1e} ({r['cgal_dkweights_vs_dk_max']:.0e})")
    row("Blender bind (operator)", lambda r: ms(r["blender_bind"]))
    row("Blender frame R1 / modifier only", lambda r: f"{r['blender_frame_r1'] * 1e3:.0f} / {r['blender_only_r1'] * 1e3:.0f} ms")
    row("Blender frame R5 / modifier only", lambda r: f"{r['blender_frame_r5'] * 1e3:.0f} / {r['blender_only_r5'] * 1e3:.0f} ms")
    row("Blender bind / dk first bind laplacian", lambda r: f"{r['blender_bind'] / r['bind_laplacian_first']:.1f}x")
    row(f"Blender R1 / dk laplacian re-solve (>= {TARGET_VS_BLENDER:.0f}x)",
        lambda r: f"{r['blender_only_r1'] / r['resolve_laplacian']:.1f}x {'ok' if r['blender_only_r1'] / r['resolve_laplacian'] >= TARGET_VS_BLENDER else 'MISS'}")
    row("Blender R1 / dk arap iterations=1", lambda r: f"{r['blender_only_r1'] / r['arap_it1']:.1f}x")
    row("Blender R5 / dk arap iterations=5", lambda r: f"{r['blender_only_r5'] / r['arap_it5']:.1f}x")
    row("Blender base-position edit frame (rebuilds)", lambda r: ms(r["blender_base_edit_frame"]))
    row("Blender R1 frame / (dk re-solve + Blender base frame)",
        lambda r: f"{r['blender_frame_r1'] / (r['resolve_laplacian'] + r['blender_base']):.1f}x")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mesh", help="OBJ to use instead of ../shared/meshes/ogre.obj")
    ap.add_argument("--repeats", type=int, default=7, help="timed calls per figure (median kept)")
    ap.add_argument("--skip-blender", action="store_true")
    ap.add_argument("--skip-subdivided", action="store_true", help="only the mesh itself, no ~100k version")
    ap.add_argument("--skip-cgal", action="store_true", help="no CGAL Surface_mesh_deformation comparison")
    ap.add_argument("--cgal-iterations", type=int, default=CGAL_ITERATIONS, metavar="K",
                    help="cross-check: deformkit arap iterations=K against CGAL deform(K + 1)")
    ap.add_argument("--ri-limit", type=float, default=20.0,
                    help="skip rotation_invariant on a larger mesh when predicted above this (s)")
    ap.add_argument("--drag-tolerance", type=float, default=DRAG_TOLERANCE,
                    help="ARAP drag: stop a step when the relative energy decrease falls below this")
    ap.add_argument("--json", metavar="PATH")
    args = ap.parse_args()
    if args.cgal_iterations < 1:
        ap.error("--cgal-iterations: must be >= 1")

    path = pathlib.Path(args.mesh) if args.mesh else MESHES / "ogre.obj"
    if not path.exists():
        print(f"SKIPPED: mesh {path} not found (the shared meshes live in ../shared/meshes next to the "
              f"project; pass --mesh PATH to use another OBJ)")
        return
    if not hasattr(dk, "SurfaceDeformer"):
        print("SKIPPED: dk.SurfaceDeformer is not in this build of deformkit")
        return

    busy = cpu_busy()
    print(f"deformkit {dk.__version__} {dk.build_info()} | numpy {np.__version__} | {os.cpu_count()} CPUs")
    print(f"CPU busy before the run: {busy:.0%}" + ("  ** the machine is not idle: figures are noisy **" if busy > 0.1 else "") + "\n")

    points, faces = load_obj(path)
    meshes = [(path.name, points, faces)]
    if not args.skip_subdivided:
        v, f, nb = largest_component_loop(points, faces)
        meshes.append((f"{path.stem} body, loop x1", v, f))
        print(f"subdivided mesh: largest component of {path.name} ({nb:,} vertices), one Loop subdivision "
              f"-> {len(v):,} vertices, {len(f):,} faces\n")

    results, ri_state = {}, {}
    for name, p, f in meshes:
        edit = make_edit(p, f)
        res = results.setdefault(name, {})
        with OtherLoad() as load:
            dk_part(name, p, f, edit, args.repeats, ri_state, args.ri_limit, res, args.drag_tolerance)
        print(load.report() + "\n")
        res["other_cpu_dk"] = load.share
    cgal = {"skipped": "--skip-cgal"} if args.skip_cgal else {}
    if not args.skip_cgal:
        t0 = time.perf_counter()
        exe, info = cgal_tool()
        if exe is None:
            print(f"CGAL part skipped: {info}; run scripts/setup_bench.sh (installs Debian's libcgal-dev)\n")
            cgal["skipped"] = info
        else:
            print(f"CGAL: libcgal-dev {info}, {exe.relative_to(ROOT)} built from {CGAL_SRC.relative_to(ROOT)} "
                  f"({time.perf_counter() - t0:.1f} s)\n")
            cgal.update(package=info, program=str(exe.relative_to(ROOT)))
            for name, p, f in meshes:
                edit = make_edit(p, f)
                with OtherLoad() as load:
                    cgal_part(name, p, f, edit, args.repeats, results[name], exe, args.cgal_iterations)
                print(load.report() + "\n")
                results[name]["other_cpu_cgal"] = load.share
    if not args.skip_blender:
        try:
            import bpy  # noqa: F401
        except ImportError as exc:
            print(f"Blender part SKIPPED: bpy not importable ({exc})\n")
        else:
            for name, p, f in meshes:
                edit = make_edit(p, f)
                with OtherLoad() as load:
                    blender_part(name, p, f, edit, args.repeats, results[name])
                print(load.report() + "\n")
                results[name]["other_cpu_blender"] = load.share
    summary_table(results)
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps({"cpu_busy": busy, "build_info": dk.build_info(),
                                                       "cgal": cgal, "results": results}, indent=1, default=float))
        print("wrote", args.json)


if __name__ == "__main__":
    main()

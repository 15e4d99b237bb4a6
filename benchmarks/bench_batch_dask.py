"""The batch command on Dask against the local executor (issue 18), in one run on this machine.

    .venv/bin/python benchmarks/bench_batch_dask.py [--files 40] [--recipe twist|demo] [--rounds 1]
                                                    [--work DIR] [--json PATH]

The .blend fixtures (blend_fixtures/make_fixtures.py, made by Blender 3.4 in the work folder)
repeated by symbolic links to --files inputs, run by `scripts/deformkit-batch` three ways: the
local executor (--jobs 2), a Dask LocalCluster of 2 workers and one of 1 worker (--executor
dask-local), --rounds times (each round starting with the next way). Per way: the wall time of
the whole command (Python start, cluster start and stop included), the same command on one
missing file (what a run costs without any file: start-up and tear-down), the CPU seconds of the
command and all it started (its waited-for children: workers and Blenders), Blender's seconds per
file and the tasks' queue seconds from the report. Dask's overhead per file is
((dask 2 - its empty run) - (local 2 - its empty run)) / files. The twist recipe (TWIST + BEND on
every mesh) keeps each file close to a Blender start, so the overhead shows; "demo" is make demo's
recipe (Subdivide and smoothness figures too). Not in `make bench`: about 4 minutes with the
defaults. Other processes' CPU share is printed per way (bench_common.OtherLoad).
"""
import argparse
import json
import os
import pathlib
import resource
import statistics
import subprocess
import sys
import tempfile
import time

from bench_common import OtherLoad

REPO = pathlib.Path(__file__).resolve().parents[1]
BATCH = REPO / "scripts" / "deformkit-batch"
RECIPES = {"twist": {"objects": ["*"], "deformers": [{"type": "TWIST", "angle": 1.2, "deform_axis": "Z"},
                                                     {"type": "BEND", "angle": 0.9, "deform_axis": "X"}]},
           "demo": json.loads((REPO / "blend_fixtures" / "demo_recipe.json").read_text())}
WAYS = {"local --jobs 2": ["--jobs", "2"], "dask-local 2 workers": ["--executor", "dask-local", "--workers", "2"],
        "dask-local 1 worker": ["--executor", "dask-local", "--workers", "1"]}

ap = argparse.ArgumentParser()
ap.add_argument("--files", type=int, default=40)
ap.add_argument("--recipe", choices=sorted(RECIPES), default="twist")
ap.add_argument("--rounds", type=int, default=1)
ap.add_argument("--work", help="folder for the fixtures, inputs and outputs (default: a new temporary one)")
ap.add_argument("--json")
args = ap.parse_args()


def make_inputs(work):
    fixtures = work / "fixtures"
    fixtures.mkdir(exist_ok=True)
    if not list(fixtures.glob("*.blend")):
        subprocess.run(["blender", "-b", "--factory-startup", "--python-exit-code", "1", "-P",
                        str(REPO / "blend_fixtures" / "make_fixtures.py"), "--", str(fixtures)],
                       check=True, capture_output=True, timeout=600)
    blends = sorted(fixtures.glob("*.blend"))
    inputs = work / "inputs"
    inputs.mkdir(exist_ok=True)
    for i in range(args.files):
        link = inputs / f"{i:03d}_{blends[i % len(blends)].name}"
        if not link.exists():
            link.symlink_to(blends[i % len(blends)])
    return sorted(inputs.glob("*.blend")), blends


def children_cpu():
    use = resource.getrusage(resource.RUSAGE_CHILDREN)
    return use.ru_utime + use.ru_stime


def run(way, paths, out, recipe):
    """(wall seconds, CPU seconds of the command and everything it started, report) of one batch
    command."""
    t0, c0 = time.perf_counter(), children_cpu()
    proc = subprocess.run([str(BATCH), *map(str, paths), "--recipe", str(recipe), "--out", str(out), *WAYS[way]],
                          capture_output=True, text=True, timeout=3600)
    seconds, cpu = time.perf_counter() - t0, children_cpu() - c0
    if proc.returncode not in (0, 1):
        raise SystemExit(f"{way}: exit {proc.returncode}\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}")
    return seconds, cpu, json.loads((out / "report.json").read_text())


def main():
    work = pathlib.Path(args.work or tempfile.mkdtemp(prefix="bench_batch_dask_"))
    work.mkdir(parents=True, exist_ok=True)
    paths, blends = make_inputs(work)
    recipe = work / "recipe.json"
    recipe.write_text(json.dumps(RECIPES[args.recipe]))
    print(f"{len(paths)} files ({len(blends)} fixtures repeated), recipe {args.recipe}, {os.cpu_count()} CPUs, "
          f"load average before {os.getloadavg()[0]:.2f}")
    wall, cpu, empty, load, queue, process = {w: [] for w in WAYS}, {w: [] for w in WAYS}, {}, {}, {}, {}
    for way in WAYS:
        empty[way] = run(way, [work / "missing.blend"], work / "out-empty", recipe)[0]
    ways = list(WAYS)
    for r in range(args.rounds):
        for way in ways[r % 3:] + ways[:r % 3]:  # each round starts with the next way: drift spreads out
            out = work / f"out-{way.replace(' ', '_')}-{r}"
            with OtherLoad() as other:
                seconds, used, report = run(way, paths, out, recipe)
            failed = [f["file"] for f in report["files"] if f["status"] != "ok"]
            if failed:
                raise SystemExit(f"{way}: {len(failed)} files failed, e.g. {failed[0]}")
            wall[way].append(seconds)
            cpu[way].append(used)
            load.setdefault(way, []).append(other.share)
            queue.setdefault(way, []).extend(f.get("queue_seconds") or 0.0 for f in report["files"])
            process.setdefault(way, []).extend(f.get("process_seconds", 0.0) for f in report["files"])
    t = {w: statistics.median(v) for w, v in wall.items()}
    c = {w: statistics.median(v) for w, v in cpu.items()}
    print(f"\n{'way':24} {'wall s':>8} {'empty s':>8} {'s/file':>7} {'CPU s/file':>10} {'Blender s/file':>15} "
          f"{'queue s':>8} {'other load':>10}")
    for way in WAYS:
        print(f"{way:24} {t[way]:8.2f} {empty[way]:8.2f} {t[way] / len(paths):7.3f} {c[way] / len(paths):10.3f} "
              f"{statistics.mean(process[way]):15.3f} {statistics.mean(queue[way]):8.3f} "
              f"{max(load[way]):10.0%}")
    local, dask2, dask1 = (t[w] for w in WAYS)
    overhead = ((dask2 - empty["dask-local 2 workers"]) - (local - empty["local --jobs 2"])) / len(paths)
    figures = {"files": len(paths), "recipe": args.recipe, "wall": t, "cpu": c, "empty": empty, "load": load,
               "dask2_over_local2": dask2 / local, "dask1_over_dask2": dask1 / dask2,
               "dask_overhead_per_file": overhead,
               "blender_seconds_per_file": statistics.mean(process["local --jobs 2"])}
    print(f"\ndask-local 2 workers / local --jobs 2: {dask2 / local:.3f}")
    print(f"dask-local 1 worker / 2 workers:       {dask1 / dask2:.3f} (2.0 would be perfect scaling)")
    print(f"Dask overhead per file (start-up and tear-down of each way left out): {overhead * 1000:+.0f} ms, "
          f"against {figures['blender_seconds_per_file']:.2f} s of Blender per file")
    print(f"CPU per file, dask-local 2 workers minus local --jobs 2: "
          f"{(c['dask-local 2 workers'] - c['local --jobs 2']) / len(paths) * 1000:+.0f} ms")
    print(f"cluster start + stop: {empty['dask-local 2 workers'] - empty['local --jobs 2']:+.2f} s beside the "
          "local executor's")
    if max(max(v) for v in load.values()) > 0.1:
        print("** other processes used more than 10% of the CPUs: figures disturbed, rerun on an idle machine **")
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps(figures, indent=1))


if __name__ == "__main__":
    sys.exit(main())

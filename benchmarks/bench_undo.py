"""An undo of a cage move on a rig with a Harmonic Cage entry, and the reopening of its file,
against Mesh Deform's.

    .venv/bin/python benchmarks/bench_undo.py [--model Ogre] [--precisions 5,6,7] [--repeats 5]
        [--addon DIR]

One bpy 5.0 process per run. The model of ../shared/cages and its cage (bench_common.cage_model);
for each precision, a twin of the model with a Cage entry of Method Harmonic (Mesh Deform), bound,
and the model itself with Blender's Mesh Deform modifier, bound, both to their own copy of the
cage. A step: the cage moved to its `_Cage_Deformed` pose, an undo step pushed, then
`bpy.ops.ed.undo()` timed together with the depsgraph update that shows the undone rig (the
add-on's undo handler evaluates its stacks there), then redo. Medians of R steps, each side alone
(Mesh Deform's first, before the entry exists; then its modifier hidden). Reopening: each rig
saved alone in its own file (the other side removed), then `open_mainfile` and the depsgraph update
that shows it timed, best of R. Skips with a message when ../shared/cages is absent.
"""
import argparse
import pathlib
import statistics
import tempfile
import time

from bench_common import OtherLoad, blender_with_addon, cage_model, cpu_busy, mesh_deform_bind, set_positions, \
    shared_cages_or_exit, twin

ap = argparse.ArgumentParser()
ap.add_argument("--model", default="Ogre")
ap.add_argument("--precisions", default="5,6,7")
ap.add_argument("--repeats", type=int, default=5)
ap.add_argument("--addon", default=str(pathlib.Path(__file__).resolve().parents[1] / "python_addon"))
args = ap.parse_args()
CAGES = shared_cages_or_exit("bench_undo")

busy = cpu_busy()
blender_with_addon(args.addon)
import bpy  # noqa: E402
from deformkit_addon import api  # noqa: E402


def undo_seconds(cage_name, m):
    """Seconds of undo + depsgraph update, the cage having been moved in the step undone."""
    times = []
    for _ in range(args.repeats):
        set_positions(bpy.data.objects[cage_name].data, m.moved)
        bpy.context.evaluated_depsgraph_get().update()
        bpy.ops.ed.undo_push(message="cage moved")
        t0 = time.perf_counter()
        bpy.ops.ed.undo()
        bpy.context.evaluated_depsgraph_get().update()
        times.append(time.perf_counter() - t0)
        bpy.ops.ed.redo()
        set_positions(bpy.data.objects[cage_name].data, m.rest)
        bpy.context.evaluated_depsgraph_get().update()
        bpy.ops.ed.undo_push(message="cage back")
    return statistics.median(times)


def reopen_seconds(path):
    """Best of R: the file opened and its depsgraph evaluated."""
    times = []
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        bpy.ops.wm.open_mainfile(filepath=path)
        bpy.context.evaluated_depsgraph_get().update()
        times.append(time.perf_counter() - t0)
    return min(times)


def saved_alone(keep, drop, path):
    """The file with only `keep`'s rig: `drop` and its cage removed."""
    for name in drop:
        bpy.data.objects.remove(bpy.data.objects[name])
    bpy.ops.wm.save_as_mainfile(filepath=path)
    return path


FOLDER = tempfile.mkdtemp()
print(f"bpy {bpy.app.version_string} | add-on {args.addon} | CPUs busy before the run {busy:.0%}")
print(f"undo of a cage move, with its depsgraph update, medians of {args.repeats}; reopening, best of {args.repeats}")
print("| precision | Mesh Deform undo s | Harmonic entry undo s | Mesh Deform reopen s | Harmonic entry reopen s |")
print("|---|---|---|---|---|")
with OtherLoad() as load:
    for precision in (int(p) for p in args.precisions.split(",")):
        bpy.ops.wm.read_factory_settings(use_empty=True)
        m = cage_model(CAGES, args.model)
        modifier, _ = mesh_deform_bind(m.model, m.cage, precision)
        model, cage, modifier = m.model.name, m.cage.name, modifier.name  # undo makes new objects
        bpy.ops.ed.undo_push(message="Mesh Deform bound")
        md_seconds = undo_seconds(cage, m)  # no deformkit entry in the file yet
        bpy.data.objects[model].modifiers[modifier].show_viewport = False
        ours, our_cage = twin(bpy.data.objects[model], "Ours"), twin(bpy.data.objects[cage], "Our cage")
        ours.modifiers.remove(ours.modifiers[modifier])
        api.add_entry(ours, "CAGE", cage=our_cage, cage_method="HARMONIC", precision=precision)
        api.bind_cage(ours, 0)
        bpy.ops.ed.undo_push(message="entry bound")
        our_seconds = undo_seconds("Our cage", m)
        bpy.data.objects[model].modifiers[modifier].show_viewport = True
        base = f"{FOLDER}/p{precision}"
        bpy.ops.wm.save_as_mainfile(filepath=base + ".blend")
        md_file = saved_alone(model, ["Ours", "Our cage"], base + "_md.blend")
        bpy.ops.wm.open_mainfile(filepath=base + ".blend")
        ours_file = saved_alone("Ours", [model, cage], base + "_ours.blend")
        md_open, our_open = reopen_seconds(md_file), reopen_seconds(ours_file)
        print(f"| {precision} | {md_seconds:.3f} | {our_seconds:.3f} | {md_open:.3f} | {our_open:.3f} |", flush=True)
print(load.report())

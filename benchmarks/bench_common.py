"""Helpers the benchmarks share: how busy the machine is, and repeated timings."""
import ctypes
import ctypes.util
import os
import resource
import time
from contextlib import contextmanager


def cpu_busy(seconds=0.5):
    """Fraction of all CPUs used (by other processes) over `seconds`, from /proc/stat."""
    try:
        ticks = []
        for wait in (seconds, 0):
            with open("/proc/stat") as f:
                v = [int(x) for x in f.readline().split()[1:]]
            ticks.append((v[3] + v[4], sum(v)))
            time.sleep(wait)
        return 1 - (ticks[1][0] - ticks[0][0]) / max(ticks[1][1] - ticks[0][1], 1)
    except OSError:
        return float("nan")


class OtherLoad:
    """Share of all CPUs used by *other* processes while the block ran: /proc/stat busy time
    minus the CPU time of this process and of its finished (waited-for) children, such as a
    benchmark program run with subprocess.run (getrusage), over wall time x CPUs."""

    def _sample(self):
        with open("/proc/stat") as f:
            v = [int(x) for x in f.readline().split()[1:]]
        own = resource.getrusage(resource.RUSAGE_SELF)
        kids = resource.getrusage(resource.RUSAGE_CHILDREN)
        return (time.perf_counter(), (sum(v) - v[3] - v[4]) / os.sysconf("SC_CLK_TCK"),
                own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime)

    def __enter__(self):
        try:
            self.start = self._sample()
        except (OSError, ValueError):
            self.start = None
        return self

    def __exit__(self, *exc):
        self.share = float("nan")
        if self.start is not None:
            (w0, b0, o0), (w1, b1, o1) = self.start, self._sample()
            self.share = max(0.0, (b1 - b0) - (o1 - o0)) / max((w1 - w0) * (os.cpu_count() or 1), 1e-9)

    def report(self):
        return (f"  other processes used {self.share:.0%} of the {os.cpu_count()} CPUs during this part"
                + ("  ** figures disturbed: rerun on an idle machine **" if self.share > 0.1 else ""))


def timings(fn, repeats, warmup=1):
    """Seconds of `repeats` calls of fn() after `warmup` untimed calls."""
    for _ in range(warmup):
        fn()
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return ts


@contextmanager
def omp_threads(count):
    """OpenMP threads of the calls made from this thread inside the block (libgomp's
    omp_set_num_threads; deformkit is built with GCC's OpenMP). Yields False when libgomp is absent."""
    try:
        gomp = ctypes.CDLL(ctypes.util.find_library("gomp") or "libgomp.so.1")
    except OSError:
        yield False
        return
    before = gomp.omp_get_max_threads()
    gomp.omp_set_num_threads(count)
    try:
        yield True
    finally:
        gomp.omp_set_num_threads(before)


def blender_with_addon(addon_dir):
    """bpy on an empty scene with the add-on at `addon_dir` registered as deformkit_addon (a
    symlink in a temporary addons folder, as users install it). Returns the deformkit_addon package."""
    import importlib
    import pathlib
    import sys
    import tempfile
    addons = pathlib.Path(tempfile.mkdtemp())
    (addons / "deformkit_addon").symlink_to(addon_dir, target_is_directory=True)
    sys.path.insert(0, str(addons))
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon = importlib.import_module("deformkit_addon")
    if not hasattr(bpy.types.Object, "deformkit"):
        addon.register()
    return addon


def displaced_grid_pair(vertices):
    """Two identical objects "deformkit" and "blender": a grid of about `vertices` points with a
    smooth z displacement (so a Z twist has an extent). Returns (A, B, positions)."""
    import math
    import bpy
    import numpy as np
    from deformkit_addon import meshdata
    s = max(2, round(math.sqrt(vertices)) - 1)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=s, y_subdivisions=s, size=2)
    a = bpy.context.active_object
    co = meshdata.base_positions(a.data)
    co[:, 2] = 0.3 * np.sin(3 * co[:, 0]) * np.cos(2 * co[:, 1])
    a.data.vertices.foreach_set("co", co.ravel())
    a.data.update()
    b = a.copy()  # before A gets its entry
    b.data = a.data.copy()
    bpy.context.scene.collection.objects.link(b)
    a.name, b.name = "deformkit", "blender"
    return a, b, co


@contextmanager
def c_stdout_silenced():
    """File descriptor 1 to /dev/null inside the block: what C code (Blender) prints goes; Python's
    own print is flushed before and after."""
    import sys
    libc = ctypes.CDLL(None)
    sys.stdout.flush()
    saved, devnull = os.dup(1), os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    try:
        yield
    finally:
        libc.fflush(None)  # C stdio's buffer still holds the text when stdout is a pipe or a file
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)


def imported(path):
    """The one mesh object Blender's OBJ importer makes of `path`, its positions (float64, the
    mesh's float32 values) and polygons; the file's axes kept (Y forward, Z up)."""
    import bpy
    import numpy as np
    before = set(bpy.data.objects)
    with c_stdout_silenced():  # the importer's "OBJ import of ... took" lines would split the tables
        bpy.ops.wm.obj_import(filepath=str(path), forward_axis="Y", up_axis="Z")
    (obj,) = set(bpy.data.objects) - before
    mesh = obj.data
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.attributes["position"].data.foreach_get("vector", co)
    faces = [list(p.vertices) for p in mesh.polygons]
    return obj, co.reshape(-1, 3).astype(np.float64), faces


def evaluated(obj):
    """obj's evaluated positions (all modifiers), float64 of the mesh's float32."""
    import bpy
    import numpy as np
    dg = bpy.context.evaluated_depsgraph_get()
    mesh = obj.evaluated_get(dg).data
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.attributes["position"].data.foreach_get("vector", co)
    return co.reshape(-1, 3).astype(np.float64)


def shared_cages_dir():
    """../shared/cages beside the repository (the project's cage test data; never committed)."""
    import pathlib
    return pathlib.Path(__file__).resolve().parents[1].parent / "shared" / "cages"


def shared_cages_or_exit(script):
    """shared_cages_dir(), or exit 0 saying it is absent (`script`: the benchmark's name)."""
    import sys
    folder = shared_cages_dir()
    if not folder.is_dir():
        print(f"{script}: {folder} is absent (the project's test data); nothing to measure")
        sys.exit(0)
    return folder


def cage_model(folder, name):
    """Model `name` of the shared cages imported into the current scene: a namespace with model
    (object), points, faces, cage (object), rest, cage_faces and moved (the deformed cage's points,
    the rest cage's vertex order; its own imported object is removed)."""
    import types
    import bpy
    model, points, faces = imported(folder / f"{name}.obj")
    cage, rest, cage_faces = imported(folder / f"{name}_Cage.obj")
    moved_obj, moved, moved_faces = imported(folder / f"{name}_Cage_Deformed.obj")
    moved_mesh = moved_obj.data
    bpy.data.objects.remove(moved_obj)
    bpy.data.meshes.remove(moved_mesh)
    # The files list the same faces in different orders; the vertices are in the same order.
    same = sorted(map(sorted, moved_faces)) == sorted(map(sorted, cage_faces))
    if not (same and len(moved) == len(rest)):
        raise SystemExit(f"{name}: the rest and deformed cages differ in topology")
    return types.SimpleNamespace(name=name, model=model, points=points, faces=faces, cage=cage, rest=rest,
                                 cage_faces=cage_faces, moved=moved)


def set_positions(mesh, points):
    """Write (n, 3) points into a mesh's positions (float32) and tag it, as a script's cage edit does."""
    import numpy as np
    mesh.attributes["position"].data.foreach_set("vector", np.ascontiguousarray(points, np.float32).ravel())
    mesh.update()


def blender_mesh(name, points, triangles):
    """A mesh object of (n, 3) points and (f, 3) triangles in the scene, written by foreach_set
    (from_pydata goes through Python lists: minutes at a million vertices), with its edges (what
    edge-based tools such as Transfer Shape Key's Relative Edge mode walk)."""
    import bpy
    import numpy as np
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(points))
    mesh.loops.add(3 * len(triangles))
    mesh.polygons.add(len(triangles))
    mesh.attributes["position"].data.foreach_set("vector", np.asarray(points, np.float32).ravel())
    mesh.loops.foreach_set("vertex_index", np.asarray(triangles, np.int32).ravel())
    mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * len(triangles), 3, dtype=np.int32))
    mesh.update(calc_edges=True)
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def mesh_deform_bind(model, cage, precision):
    """A Mesh Deform modifier on `model` bound to `cage` at `precision` by Blender's Bind operator.
    Returns (modifier, seconds: the operator and the evaluation that runs the bind)."""
    import time
    import bpy
    mod = model.modifiers.new("MeshDeform", "MESH_DEFORM")
    mod.object, mod.precision = cage, precision
    bpy.context.view_layer.objects.active = model
    t0 = time.perf_counter()
    with bpy.context.temp_override(object=model, active_object=model):
        bpy.ops.object.meshdeform_bind(modifier=mod.name)
    bpy.context.evaluated_depsgraph_get().update()  # the bind runs in the modifier's next evaluation
    seconds = time.perf_counter() - t0
    if not mod.is_bound:
        raise SystemExit(f"Mesh Deform did not bind {model.name}")
    return mod, seconds


def _status_kib(field):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field + ":"):
                return int(line.split()[1])
    raise OSError(f"/proc/self/status has no {field}")


class PeakMemory:
    """Peak growth of this process's resident set while the block ran (bytes, `growth`): the
    kernel's high-water mark VmHWM minus the resident size on entry. On entry the mark is reset to
    the current size by writing 5 to /proc/self/clear_refs (proc(5), Linux >= 4.0), so an earlier,
    higher peak does not hide the block's own; where that is refused, `exact` is False and the
    growth counts only what rose above the earlier peak."""

    def __enter__(self):
        self.exact = True
        try:
            with open("/proc/self/clear_refs", "w") as f:
                f.write("5")
        except OSError:
            self.exact = False
        self.start_rss = _status_kib("VmRSS") * 1024
        self.start_hwm = _status_kib("VmHWM") * 1024
        return self

    def __exit__(self, *exc):
        hwm = _status_kib("VmHWM") * 1024
        self.growth = max(0, hwm - (self.start_rss if self.exact else self.start_hwm))


def twin(source, name):
    """A copy of object `source` with a copy of its mesh, named `name`, in the scene."""
    import bpy
    obj = source.copy()
    obj.data = source.data.copy()
    obj.name = name
    bpy.context.scene.collection.objects.link(obj)
    return obj

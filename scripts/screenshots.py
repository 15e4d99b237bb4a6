"""Screenshots of the Blender add-on's UI, for people to look at (not run by CI; `make screenshots`).

    python scripts/screenshots.py [--out build/screenshots] [--blender /usr/bin/blender] [--timeout 600]

Starts Xvfb (a 1920x1080 screen) and Debian's Blender 3.4 with its GUI and factory settings, the
add-on from this tree (python_addon/, installed as deformkit_addon) and the deformkit module of the
Python running this script. Inside Blender, the same file builds a scene with one object per entry
type (and a mesh without entries, one with broken entries, and a twin with Blender's Simple Deform)
and, for each, saves the Properties editor's Modifiers tab at the default layout's width, and the
3D viewport in Object Mode and in Edit Mode with the top of the mesh moved (docs/contributing.md,
"Looking at the add-on's UI"). Exits non-zero, saying why, when Blender fails, a picture is missing or the timeout
passes.

The outer part needs only the standard library (and an importable deformkit); the inner part runs
in Blender's own Python, which keeps its own numpy (so the module is passed as a folder holding
only a symlink to the deformkit package, as tests/addon/test_blender34.py does).
"""
import argparse
import os
import pathlib
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import time

REPO = pathlib.Path(__file__).resolve().parents[1]
SCREEN = (1920, 1080)
# One object per entry type (the Cage entry also with its Harmonic method, bound, and once more
# after its mesh changed under the binding: the Rebind row); a mesh without entries (the compact
# panel); new Cage, RBF and Laplacian entries (their hints, Generate Cage); one whose entries show
# messages (a deleted lattice, an unbound Laplacian, Check Smoothness's figures); and the Twist
# tube's twin with Blender's own Simple Deform, to hold the panel and Edit Mode against. The inner
# part builds them, the outer checks that each left its three pictures.
SHOTS = ("no_entries", "twist", "bend", "taper", "stretch", "lattice", "laplacian", "cage", "harmonic", "rebind",
         "rbf", "new_entries", "subdivide", "messages", "blender_simple_deform")
VIEWS = ("panel", "object_mode", "edit_mode")
INNER_FLAG = "--deformkit-screenshots-inner"


# ---------------------------------------------------------------------------------------------
# Outside Blender: Xvfb, the add-on and module folders, Blender, the checks

def png_size(path):
    """(width, height) from a PNG's IHDR chunk, which the format puts first (PNG spec, 11.2.2)."""
    with open(path, "rb") as f:
        head = f.read(24)
    if head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        raise ValueError(f"{path} is not a PNG")
    return struct.unpack(">II", head[16:24])


def start_xvfb():
    """Xvfb on the first free display (it writes the number it took to -displayfd)."""
    if shutil.which("Xvfb") is None:
        sys.exit("screenshots: Xvfb is missing: run scripts/setup_screenshots.sh (or `make screenshots`)")
    read, write = os.pipe()
    proc = subprocess.Popen(["Xvfb", "-displayfd", str(write), "-screen", "0", f"{SCREEN[0]}x{SCREEN[1]}x24",
                             "-nolisten", "tcp"], pass_fds=(write,), stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    os.close(write)
    with os.fdopen(read) as f:
        display = f.readline().strip()
    if not display:
        proc.kill()
        sys.exit("screenshots: Xvfb did not start")
    return proc, f":{display}"


def stop(proc, group=False):
    """End `proc` (with group: its whole session, as Blender was started in its own)."""
    if proc.poll() is None:
        if group:
            os.killpg(proc.pid, signal.SIGTERM)
        else:
            proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def module_folders(deformkit_dir):
    """A temporary addons folder with deformkit_addon -> python_addon (as tests/addon/conftest.py)
    and a folder holding only deformkit -> the built package."""
    addons = pathlib.Path(tempfile.mkdtemp(prefix="deformkit_shots_addons_"))
    (addons / "deformkit_addon").symlink_to(REPO / "python_addon", target_is_directory=True)
    lib = pathlib.Path(tempfile.mkdtemp(prefix="deformkit_shots_lib_"))
    (lib / "deformkit").symlink_to(deformkit_dir, target_is_directory=True)
    return addons, lib


def find_deformkit(given):
    if given:
        path = pathlib.Path(given).resolve()
    else:
        try:
            import deformkit
        except ImportError as e:
            sys.exit(f"screenshots: cannot import deformkit ({e}): run `make build` first, or pass --deformkit DIR")
        path = pathlib.Path(deformkit.__file__).resolve().parent
    if not (path / "__init__.py").exists():
        sys.exit(f"screenshots: {path} is not the deformkit package folder")
    return path


def outer(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default=str(REPO / "build/screenshots"), help="folder for the PNGs")
    parser.add_argument("--blender", default="/usr/bin/blender")
    parser.add_argument("--deformkit", help="the deformkit package folder (default: the one this Python imports)")
    parser.add_argument("--timeout", type=float, default=600.0, help="seconds before Blender is stopped")
    args = parser.parse_args(argv)
    out = pathlib.Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    for old in out.glob("*.png"):
        old.unlink()  # a picture left from an earlier run must not pass for this run's
    deformkit_dir = find_deformkit(args.deformkit)
    if not os.path.exists(args.blender):
        sys.exit(f"screenshots: {args.blender} is missing: run scripts/setup_screenshots.sh")
    addons, lib = module_folders(deformkit_dir)
    xvfb, display = start_xvfb()
    log_path = out / "blender.log"
    env = dict(os.environ, DISPLAY=display,
               # Mesa's llvmpipe: no GPU here; Blender 3.4 needs OpenGL 3.3, which llvmpipe has.
               LIBGL_ALWAYS_SOFTWARE="1", GALLIUM_DRIVER="llvmpipe")
    # Event simulation: the splash screen, which --factory-startup opens over the viewport, is
    # closed with a simulated Escape (Xvfb has no one to press it).
    cmd = [args.blender, "--factory-startup", "--enable-event-simulate", "--no-window-focus",
           "--window-geometry", "0", "0", str(SCREEN[0]), str(SCREEN[1]), "--python-exit-code", "1",
           "-P", str(pathlib.Path(__file__).resolve()), "--", INNER_FLAG, str(out), str(addons), str(lib)]
    started = time.monotonic()
    try:
        with open(log_path, "w") as log:
            blender = subprocess.Popen(cmd, env=env, stdout=log, stderr=subprocess.STDOUT, cwd=REPO,
                                       start_new_session=True)
            try:
                code = blender.wait(args.timeout)
            except subprocess.TimeoutExpired:
                stop(blender, group=True)
                tail = log_path.read_text(errors="replace")[-3000:]
                sys.exit(f"{tail}\nscreenshots: Blender did not finish within {args.timeout:.0f} s (log: {log_path})")
    finally:
        stop(xvfb)
        shutil.rmtree(addons, ignore_errors=True)
        shutil.rmtree(lib, ignore_errors=True)
    log_text = log_path.read_text(errors="replace")
    missing = [f"{s}_{v}.png" for s in SHOTS for v in VIEWS if not (out / f"{s}_{v}.png").exists()]
    if code != 0 or missing or "screenshots: done" not in log_text:
        why = f"Blender exited with {code}" if code else "Blender did not finish the shots"
        listed = ", ".join(missing[:4]) + (f" and {len(missing) - 4} more" if len(missing) > 4 else "")
        sys.exit(f"{log_text[-3000:]}\nscreenshots: {why}; missing pictures: {listed or 'none'} (log: {log_path})")
    for name in sorted(p.name for p in out.glob("*.png")):
        width, height = png_size(out / name)
        print(f"  {name}: {width}x{height}")
    print(f"screenshots: {len(list(out.glob('*.png')))} pictures in {out} ({time.monotonic() - started:.0f} s)")


# ---------------------------------------------------------------------------------------------
# Inside Blender 3.4: the scene, then the shots from a timer (the UI draws between its steps)

def tube(bpy, name, rings=16, segments=16, length=3.0, radius=0.5):
    """A capped tube along z from 0 to `length` with vertex groups Bottom and Top (two rings each):
    rings enough for a Barr deformation to bend smoothly, few enough to read in Edit Mode."""
    import math
    co = [(radius * math.cos(2 * math.pi * j / segments), radius * math.sin(2 * math.pi * j / segments),
           length * i / (rings - 1)) for i in range(rings) for j in range(segments)]
    ring = [[i * segments + j for j in range(segments)] for i in range(rings)]
    faces = [(r0[j], r0[(j + 1) % segments], r1[(j + 1) % segments], r1[j]) for r0, r1 in zip(ring, ring[1:])
             for j in range(segments)]
    faces += [tuple(reversed(ring[0])), tuple(ring[-1])]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(co, [], faces)
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    obj.vertex_groups.new(name="Bottom").add(ring[0] + ring[1], 1.0, "REPLACE")
    obj.vertex_groups.new(name="Top").add(ring[-1] + ring[-2], 1.0, "REPLACE")
    return obj


def build_scene(bpy):
    """{shot name: object}; every object at the origin, shown one at a time."""
    import math
    from deformkit_addon import api
    for obj in list(bpy.data.objects):
        if obj.type == "MESH":
            bpy.data.objects.remove(obj)  # the default cube: each shot builds its own mesh
    objects = {"no_entries": tube(bpy, "Plain Tube")}
    for kind, params in (("twist", dict(angle=math.radians(120), deform_axis="Z")),
                         ("bend", dict(angle=math.radians(90), deform_axis="Y")),
                         ("taper", dict(factor=0.8, deform_axis="Z")),
                         ("stretch", dict(factor=0.4, deform_axis="Z"))):
        obj = objects[kind] = tube(bpy, f"{kind.title()} Tube")
        api.add_entry(obj, kind.upper(), **params)
    obj = objects["lattice"] = tube(bpy, "Lattice Tube")
    entry = api.add_lattice(obj, resolution=(3, 3, 3))
    points = entry.lattice.data.points
    for p in points[len(points) - 9:]:  # the top layer (w fastest last), widened and shifted
        p.co_deform = (p.co.x * 1.8 + 0.3, p.co.y * 1.8, p.co.z)
    for p in points[9:18]:  # the middle layer pulled up through the top one: the panel's fold warning
        p.co_deform = (p.co.x, p.co.y, 1.0)
    obj = objects["laplacian"] = tube(bpy, "Laplacian Tube")
    empty = bpy.data.objects.new("Handle", None)
    bpy.context.scene.collection.objects.link(empty)
    empty.location = (0.0, 0.0, 3.0)
    bpy.context.view_layer.update()
    api.add_laplacian(obj, anchors_group="Bottom", handles_group="Top", handle_target="OBJECT", handle_object=empty)
    empty.location = (1.0, 0.0, 2.6)
    empty.rotation_euler = (0.0, math.radians(40), 0.0)
    obj = objects["cage"] = tube(bpy, "Cage Tube")
    bpy.ops.mesh.primitive_cube_add(location=(0.0, 0.0, 1.5), scale=(0.8, 0.8, 1.8))
    cage = bpy.context.active_object
    cage.name, cage.display_type = "Cage", "WIRE"
    api.add_entry(obj, "CAGE", cage=cage, cage_method="GREEN")
    api.bind_cage(obj, 0)
    for v in cage.data.vertices:  # the cage's top turned and widened: the tube follows
        if v.co.z > 0:
            v.co.x, v.co.y = v.co.x * 1.5 - 0.3 * v.co.y, v.co.y * 1.5 + 0.3 * v.co.x
    cage.data.update()
    objects["harmonic"] = harmonic_tube(bpy, "Harmonic Tube")
    obj = objects["rebind"] = harmonic_tube(bpy, "Rebind Tube")
    obj.data.vertices.add(1)  # a vertex more than at bind: the entry asks for Rebind
    obj.data.update()
    obj = objects["rbf"] = tube(bpy, "RBF Tube")
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=1, radius=1.2, location=(0.0, 0.0, 1.5))
    controls = bpy.context.active_object
    controls.name, controls.display_type = "Controls", "WIRE"
    api.add_entry(obj, "RBF", controls=controls)
    api.bind_rbf(obj, 0)
    for v in controls.data.vertices:  # the controls' top half pushed along X: the tube follows
        if v.co.z > 0:
            v.co.x += 0.4
    controls.data.update()
    objects["new_entries"] = obj = tube(bpy, "New Entries Tube")  # issue 31: hints, not errors
    for kind in ("CAGE", "RBF", "LAPLACIAN"):
        api.add_entry(obj, kind)
    obj = objects["subdivide"] = tube(bpy, "Subdivide Tube", rings=4, segments=6)
    api.add_entry(obj, "TWIST", angle=math.radians(60), deform_axis="Z")
    api.add_entry(obj, "SUBDIVIDE", levels=2)
    api.check_smoothness(obj)  # its figures (of the twisted cage) at the bottom of the panel
    objects["messages"] = messages_tube(bpy)
    obj = objects["blender_simple_deform"] = tube(bpy, "Simple Deform Tube")
    mod = obj.modifiers.new("SimpleDeform", "SIMPLE_DEFORM")
    mod.deform_method, mod.angle, mod.deform_axis = "TWIST", math.radians(120), "Z"  # the Twist entry's settings
    bpy.context.view_layer.update()
    return objects


def harmonic_tube(bpy, name):
    """A tube in a box cage bound with the Harmonic method (Mesh Deform's coordinates), the cage's
    top turned and widened."""
    from deformkit_addon import api
    obj = tube(bpy, name)
    bpy.ops.mesh.primitive_cube_add(location=(0.0, 0.0, 1.5), scale=(0.8, 0.8, 1.8))
    cage = bpy.context.active_object
    cage.name, cage.display_type = f"{name} Cage", "WIRE"
    api.add_entry(obj, "CAGE", cage=cage, cage_method="HARMONIC")
    api.bind_cage(obj, 0)
    for v in cage.data.vertices:
        if v.co.z > 0:
            v.co.x, v.co.y = v.co.x * 1.5 - 0.3 * v.co.y, v.co.y * 1.5 + 0.3 * v.co.x
    cage.data.update()
    return obj


def messages_tube(bpy):
    """A tube whose panel shows the add-on's messages: a Lattice entry whose lattice was deleted
    (then a parameter edit, after which issue 14 saw the stack report it), an unbound Laplacian
    entry and the figures of Check Smoothness."""
    import math
    from deformkit_addon import api
    obj = tube(bpy, "Messages Tube")
    api.add_entry(obj, "TWIST", angle=math.radians(90), deform_axis="Z")
    bpy.data.objects.remove(api.add_lattice(obj, resolution=(3, 3, 3)).lattice)
    api.add_laplacian(obj, bind=False, anchors_group="Bottom", handles_group="Top")
    obj.deformkit.entries[0].angle = math.radians(100)  # through the property's update, as a drag in the panel
    try:
        api.check_smoothness(obj)
    except ValueError as e:  # a refusal is one more message to look at, not a failed run
        print(f"screenshots: Check Smoothness refused: {e}", flush=True)
    return obj


def area_of(screen, kind):
    found = [a for a in screen.areas if a.type == kind]
    if not found:
        raise RuntimeError(f"the default screen has no {kind} area")
    return max(found, key=lambda a: a.width * a.height)


def window_region(area):
    return next(r for r in area.regions if r.type == "WINDOW")


def shoot(bpy, window, area, path):
    """bpy.ops.screen.screenshot_area of `area` (it reads the window's last drawn frame)."""
    with bpy.context.temp_override(window=window, screen=window.screen, area=area, region=window_region(area)):
        result = bpy.ops.screen.screenshot_area(filepath=str(path))
    if result != {"FINISHED"} or not os.path.exists(path):
        raise RuntimeError(f"screenshot_area of the {area.type} area gave {result}, no {path}")
    print(f"screenshots: saved {path.name}", flush=True)


def panel_pages(bpy, window, area, out, name, most=5):
    """{name}_panel.png, then {name}_panel_2.png ... a page further down each, while scrolling
    still changes the picture (a long stack does not fit even the enlarged area), then back up."""
    shoot(bpy, window, area, out / f"{name}_panel.png")
    last = (out / f"{name}_panel.png").read_bytes()
    override = dict(window=window, screen=window.screen, area=area, region=window_region(area))
    scrolled = 0
    for page in range(2, most + 1):
        with bpy.context.temp_override(**override):
            bpy.ops.view2d.scroll_down(page=True)
        scrolled += 1
        yield 0.3
        path = out / f"{name}_panel_{page}.png"
        shoot(bpy, window, area, path)
        if path.read_bytes() == last:
            path.unlink()  # at the end already: this page is the one before
            break
        last = path.read_bytes()
    for _ in range(scrolled):
        with bpy.context.temp_override(**override):
            bpy.ops.view2d.scroll_up(page=True)
    yield 0.3


def redraw(bpy, window):
    for area in window.screen.areas:
        area.tag_redraw()
    with bpy.context.temp_override(window=window):
        bpy.ops.wm.redraw_timer(type="DRAW_WIN_SWAP", iterations=1)


def steps(bpy, out, objects):
    """The shots, one UI change at a time: each `yield` hands back to Blender so that it draws."""
    import bmesh
    window = bpy.context.window_manager.windows[0]
    # An instant view_selected (no smooth-view animation), so the zoom after it is not undone.
    bpy.context.preferences.view.smooth_view = 0
    window.event_simulate(type="ESC", value="PRESS")
    window.event_simulate(type="ESC", value="RELEASE")
    yield 0.5
    props, view3d = area_of(window.screen, "PROPERTIES"), area_of(window.screen, "VIEW_3D")
    width, height = props.width, props.height
    # The default Properties area (333x699 in 3.4) cuts long stacks at the bottom: move its top edge
    # (shared with the Outliner) up, which keeps the width that the panel is to be read at.
    with bpy.context.temp_override(window=window, screen=window.screen, area=props):
        bpy.ops.screen.area_move(x=props.x + props.width // 2, y=props.y + props.height, delta=SCREEN[1])
    yield 0.3
    if props.width != width:
        raise RuntimeError(f"moving the Outliner's edge changed the Properties width: {width} -> {props.width}")
    print(f"screenshots: Properties area {width}x{height} (made {props.width}x{props.height}), "
          f"3D viewport {view3d.width}x{view3d.height}", flush=True)
    overlay = view3d.spaces.active.overlay
    overlay.show_stats = True  # the vertex count tells a subdivided result apart
    overlay.show_wireframes = True  # a twist of a smooth tube shows only in its edges
    for name, obj in objects.items():
        helpers = {o for o in bpy.data.objects if o.type != "MESH"} - {c for c in bpy.data.objects if c.type in (
            "CAMERA", "LIGHT")}  # the lattice, the handle empty, the cage: shown with the object that uses them
        helpers |= {e.cage for o in objects.values() for e in o.deformkit.entries if e.cage is not None}
        used = {e.lattice for e in obj.deformkit.entries} | {e.handle_object for e in obj.deformkit.entries} \
            | {e.cage for e in obj.deformkit.entries}
        for other in list(objects.values()) + list(helpers):
            other.hide_set(other is not obj and other not in used)
        bpy.context.view_layer.objects.active = obj
        for o in bpy.context.view_layer.objects:
            o.select_set(o is obj)
        region = window_region(view3d)
        with bpy.context.temp_override(window=window, area=view3d, region=region):
            bpy.ops.view3d.view_selected()
            bpy.ops.view3d.zoom(delta=-1)  # room for the top ring moved in Edit Mode
        yield 0.5  # view_selected animates the view (smooth view); let it settle and draw
        # Only once the Properties editor has drawn with the new active object does it offer the
        # Modifiers tab.
        props.spaces.active.context = "MODIFIER"
        redraw(bpy, window)
        yield 0.2
        yield from panel_pages(bpy, window, props, out, name)
        shoot(bpy, window, view3d, out / f"{name}_object_mode.png")
        with bpy.context.temp_override(window=window, area=view3d, region=region, active_object=obj, object=obj):
            bpy.ops.object.mode_set(mode="EDIT")
        bm = bmesh.from_edit_mesh(obj.data)
        top = max(v.co.z for v in bm.verts)
        for v in bm.verts:
            v.select_set(v.co.z > top - 1e-4)
            if v.co.z > top - 1e-4:
                v.co.x += 0.5  # as G X 0.5 on the top ring (issue 14's Edit Mode steps)
        bm.select_flush_mode()
        bmesh.update_edit_mesh(obj.data)
        yield 0.5
        redraw(bpy, window)
        yield 0.2
        shoot(bpy, window, view3d, out / f"{name}_edit_mode.png")
        with bpy.context.temp_override(window=window, area=view3d, region=region, active_object=obj, object=obj):
            bpy.ops.object.mode_set(mode="OBJECT")
        yield 0.2


def inner(out, addons, lib):
    import traceback

    import bpy
    sys.path[:0] = [lib, addons]
    out = pathlib.Path(out)

    def fail(message):
        print(f"screenshots: FAILED: {message}", flush=True)
        sys.stdout.flush()
        os._exit(1)  # quit_blender would exit 0; the outer part reads the code

    try:
        import deformkit_addon
        deformkit_addon.register()
        from deformkit_addon import native
        if not native.available():
            fail(f"the add-on cannot use the deformkit module: {native.IMPORT_ERROR}")
        objects = build_scene(bpy)
    except Exception:
        fail(traceback.format_exc())
    run = steps(bpy, out, objects)

    def tick():
        try:
            return next(run)
        except StopIteration:
            print("screenshots: done", flush=True)
            bpy.ops.wm.quit_blender()
            return None
        except Exception:
            fail(traceback.format_exc())

    # A first delay long enough for the window to open and draw once under Xvfb.
    bpy.app.timers.register(tick, first_interval=2.0)


if __name__ == "__main__":
    if INNER_FLAG in sys.argv:
        inner(*sys.argv[sys.argv.index(INNER_FLAG) + 1:][:3])
    else:
        outer(sys.argv[1:])

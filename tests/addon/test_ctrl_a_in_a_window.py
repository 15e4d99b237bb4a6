"""Ctrl+A in a real Blender 3.4 window (under Xvfb): the add-on's key map item comes before
Blender's, so deformkit.entry_apply first lets object.modifier_apply find a modifier panel under
the mouse, as the hotkey alone would. The mouse is put over each place by a simulated mouse move
(Blender started with --enable-event-simulate: the window's event state moves at once, and the
real pointer is ignored); which places are over which modifier's panel is found by Blender's own
hover lookup (Copy Modifier's invoke, undone at once), not by assuming a layout. After each
change of the stack the script waits for the Properties editor to have been drawn again (a draw
handler counts its draws), not for a time."""
import os
import shutil
import subprocess

import pytest

from addon_helpers import IN_BLENDER_BINARY, REPO

pytestmark = pytest.mark.skipif(IN_BLENDER_BINARY, reason="starts its own Blender 3.4 window, from outside Blender")

SCRIPT = r'''
import os, sys, tempfile
addons = tempfile.mkdtemp()
os.symlink(os.environ["ADDON"], os.path.join(addons, "deformkit_addon"))
sys.path[:0] = [addons, os.environ["DKLIB"]]
import bpy

def properties():
    area = next(a for a in bpy.context.screen.areas if a.type == "PROPERTIES")
    return area, next(r for r in area.regions if r.type == "WINDOW")

draws = [0]

def count_draw():
    draws[0] += 1

bpy.types.SpaceProperties.draw_handler_add(count_draw, (), "WINDOW", "POST_PIXEL")

def redrawn(times=2):
    """Timer steps until the Properties editor has been drawn `times` more times (its panels laid
    out after the last change): waits for draws, polled each 10 ms, never for a set time."""
    area, _ = properties()
    target = draws[0] + times
    while draws[0] < target:
        area.tag_redraw()
        yield 0.01

def move_mouse(window, x, y):
    window.event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y)

def over(window):
    """What the hotkey would find under the mouse: the modifier Copy Modifier copies, if any."""
    cube = bpy.data.objects["Cube"]
    before = [m.name for m in cube.modifiers]
    area, region = properties()
    with bpy.context.temp_override(window=window, area=area, region=region):
        if "FINISHED" not in bpy.ops.object.modifier_copy("INVOKE_DEFAULT"):
            return None
    new = next(m for m in cube.modifiers if m.name not in before)
    source = before[[m.name for m in cube.modifiers].index(new.name) - 1]
    cube.modifiers.remove(new)
    return source

def run():
    window = bpy.context.window_manager.windows[0]
    import deformkit_addon
    from deformkit_addon import api
    deformkit_addon.register()
    cube = bpy.data.objects["Cube"]
    bpy.context.view_layer.objects.active = cube
    api.add_entry(cube, "TWIST", angle=1.0, deform_axis="Z")
    api.add_entry(cube, "TAPER", factor=0.5, deform_axis="Z")  # the active entry
    for entry in cube.deformkit.entries:
        entry.show_expanded = False
    cube.modifiers.new("SD", "SIMPLE_DEFORM")
    area, region = properties()
    area.spaces[0].context = "MODIFIER"
    yield from redrawn()
    found = {}
    for y in range(region.y + region.height - 40, region.y + 10, -12):
        move_mouse(window, region.x + region.width // 2, y)  # the layout is unchanged: no redraw needed
        found.setdefault(over(window), []).append(y)
    print("FOUND", {k: len(v) for k, v in found.items()})
    top_modifier = max(y for name, ys in found.items() if name for y in ys)
    above = [y for y in found.get(None, []) if y > top_modifier]  # the deformkit panel and Add Modifier
    for name, place in (("SD", found["SD"][len(found["SD"]) // 2]), (None, above[len(above) // 2])):
        yield from redrawn()  # after the last lookup or apply, the panels laid out anew
        move_mouse(window, region.x + region.width // 2, place)
        with bpy.context.temp_override(window=window, area=area, region=region):
            result = bpy.ops.deformkit.entry_apply("INVOKE_DEFAULT")  # as the key map item calls it
        print("APPLIED", name, sorted(result), [m.name for m in cube.modifiers],
              [e.name for e in cube.deformkit.entries])
    bpy.ops.wm.quit_blender()

steps = run()
bpy.app.timers.register(lambda: next(steps, None), first_interval=0.0)
'''


def test_ctrl_a_applies_the_modifier_under_the_mouse_else_the_active_entry(tmp_path):
    from test_blender34 import BLENDER, deformkit_lib
    if shutil.which("xvfb-run") is None:  # a pinned test dependency: fail, do not skip
        pytest.fail("xvfb-run is missing: scripts/setup.sh installs Debian's xvfb and xauth")
    script = tmp_path / "ctrl_a.py"
    script.write_text(SCRIPT)
    env = dict(os.environ, ADDON=str(REPO / "python_addon"), DKLIB=deformkit_lib())
    proc = subprocess.run(["xvfb-run", "-a", "-s", "-screen 0 1920x1080x24", BLENDER, "--factory-startup",
                           "--enable-event-simulate", "-P", str(script)], capture_output=True, text=True, timeout=300,
                          env=env)
    lines = [line for line in proc.stdout.splitlines() if line.startswith(("FOUND", "APPLIED"))]
    tail = (proc.stdout + proc.stderr)[-3000:]
    assert len(lines) == 3, tail
    # Over Simple Deform's panel: that modifier is applied, the entries stay.
    assert lines[1] == "APPLIED SD ['FINISHED'] ['deformkit'] ['Twist', 'Taper']", tail
    # Over no modifier's panel (above them all): the active entry, Taper, is applied.
    assert lines[2] == "APPLIED None ['FINISHED'] ['deformkit'] ['Twist']", tail

"""Text the panel draws, as plain functions the tests call: messages wrapped to the editor's width
(a label is cut, not wrapped, by Blender), and figures in readable units."""
import math

# Blender's default Properties editor width, and the average advance of its 11 px UI font at scale
# 1, taken wide: blf.dimensions(0, ...) in Blender 3.4 gives 4.8 px per character for a typical
# error message; 6 leaves room for capitals and digits, so a line ends a little early rather than
# being cut.
DEFAULT_WIDTH = 330
CHAR_WIDTH = 6.0
MARGIN = 40  # the icon and the box's padding on both sides
MIN_BUDGET = 16


def char_budget(width=None, ui_scale=1.0):
    """How many characters of a message fit on one line of a region `width` pixels wide (the
    region's width is in pixels after UI scaling, so the font is ui_scale times wider too)."""
    scale = ui_scale if ui_scale and ui_scale > 0 else 1.0
    width = width or DEFAULT_WIDTH * scale
    return max(MIN_BUDGET, int((width - MARGIN * scale) / (CHAR_WIDTH * scale)))


def context_budget(context=None):
    """The character budget of the region being drawn (the default width without one, as in tests
    and background mode)."""
    import bpy
    context = context if context is not None else bpy.context
    region = getattr(context, "region", None)
    preferences = getattr(context, "preferences", None) or bpy.context.preferences
    # system.ui_scale is the resolution scale with the display's DPI; 0 without a window.
    scale = (preferences.system.ui_scale or preferences.view.ui_scale) if preferences is not None else 1.0
    return char_budget(region.width if region is not None else None, scale)


def wrap(text, budget):
    """`text` split at spaces into lines of at most `budget` characters; a word longer than the
    budget gets a line of its own rather than being cut (a cut word reads as another word)."""
    lines, line = [], ""
    for word in text.split():
        if line and len(line) + 1 + len(word) > budget:
            lines.append(line)
            line = word
        else:
            line = f"{line} {word}" if line else word
    if line:
        lines.append(line)
    return lines


def label_wrapped(layout, text, icon="NONE", budget=None):
    """`text` as labels of at most `budget` characters, the icon on the first only (the others
    indented by a blank icon so that the text lines up)."""
    budget = context_budget() if budget is None else budget
    col = layout.column(align=True)
    for i, line in enumerate(wrap(text, budget)):
        col.label(text=line, icon=icon if i == 0 else ("BLANK1" if icon != "NONE" else "NONE"))
    return col


def degrees(radians):
    """An angle in degrees, readable: no exponent; below 0.001° (rounding noise of a smooth
    surface) it reads "< 0.001°"."""
    value = math.degrees(radians)
    if value == 0.0:
        return "0°"
    if abs(value) < 0.001:
        return "< 0.001°"
    digits = 3 if abs(value) < 1 else 2 if abs(value) < 10 else 1
    return f"{value:.{digits}f}°"

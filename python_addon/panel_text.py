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
# A use_property_split row gives its label 40 % of the row (UI_ITEM_PROP_SEP_DIVIDE); inside an
# entry's box, beside the decorator column and the label's own padding, less is left: at the
# default width Blender 3.4 cut "Boundary Smooth" (88 px in its UI font, blf.dimensions) after 11
# characters and kept "Levels Viewport" (80 px) whole, about 14 characters at CHAR_WIDTH.
LABEL_SHARE = 0.4
LABEL_PADDING = 5
# A button's icon and padding, in characters: at the default width Blender 3.4 showed "Selection
# to Emp" and the ellipsis (2 characters wide) on a half row, 18 of a 24-character share.
BUTTON_PADDING = 6


def char_budget(width=None, ui_scale=1.0):
    """How many characters of a message fit on one line of a region `width` pixels wide (the
    region's width is in pixels after UI scaling, so the font is ui_scale times wider too)."""
    scale = ui_scale if ui_scale and ui_scale > 0 else 1.0
    width = width or DEFAULT_WIDTH * scale
    return max(MIN_BUDGET, int((width - MARGIN * scale) / (CHAR_WIDTH * scale)))


def label_column_budget(width=None, ui_scale=1.0):
    """How many characters of a property's label fit in the label column of a use_property_split
    layout inside an entry's box."""
    return max(1, int(LABEL_SHARE * char_budget(width, ui_scale)) - LABEL_PADDING)


def row_characters(items):
    """The characters a row of (text, is_button) items takes: their texts and each button's
    padding. Blender shrinks every item of a row that is wider than the region, cutting them all,
    so a row reads whole while this is within char_budget."""
    return sum(len(text) + (BUTTON_PADDING if button else 0) for text, button in items)


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


# An entry's box (its padding, the property-split column's indent) takes a few characters more
# from a line: Blender 3.4 showed 39 characters and an ellipsis of a 44-character hint with an icon
# at the default width, inside a box.
BOX_CHARACTERS = 8


def box_budget(context=None):
    """The character budget of a message inside an entry's box."""
    return max(MIN_BUDGET, context_budget(context) - BOX_CHARACTERS)


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


def percent(fraction):
    """A fraction (of the bounding box's diagonal, say) as a percentage with two significant
    digits and no exponent; below 0.0001 % (rounding noise of a closed surface) "< 0.0001 %"."""
    value = 100.0 * abs(fraction)
    if value == 0.0:
        return "0 %"
    if value < 1e-4:
        return "< 0.0001 %"
    digits = max(0, 1 - math.floor(math.log10(value)))
    return f"{value:.{digits}f} %"

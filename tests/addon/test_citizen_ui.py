"""The add-on as a Blender citizen (issue 31, sections 3 and 4): no error before the user did
anything, names that read whole, Check Smoothness only where it applies, helper objects that go
with their owner and stay out of the pickers, a helper modifier that repairs itself, and entries
found in Blender's menus and F3 search."""
import types

import pytest

from addon_helpers import CheckingLayout, make_object


def draw_panel(obj):
    from deformkit_addon import ui
    log = []
    ui.DEFORMKIT_PT_stack.draw(types.SimpleNamespace(layout=CheckingLayout(log)), types.SimpleNamespace(object=obj))
    return log


def labels(log):
    return [text for what, text in log if what == "label"]


# ---------------------------------------------------------------------------------------------
# A new Cage or RBF entry: a hint, as Mesh Deform's empty Object field, not an error

@pytest.mark.parametrize("entry_type,field", [("CAGE", "cage"), ("RBF", "controls")])
def test_a_new_entry_without_its_object_is_a_hint_not_an_error(scene, entry_type, field):
    import bpy
    from deformkit_addon import api, entries
    obj = make_object(bpy)
    entry = api.add_entry(obj, entry_type)
    assert entry.error == "" and obj.deformkit.error == ""
    text = labels(draw_panel(obj))
    assert entries.kind(entry).HINT in text
    assert not any("See the message" in t or "no cage" in t or "no control" in t for t in text), text
    # Something actually wrong is still said: Bind without the object, and an object that is deleted.
    with pytest.raises(ValueError, match="no (cage|control) object set"):
        api.bind(obj, 0)
    other = make_object(bpy, "Other")
    setattr(obj.deformkit.entries[0], field, other)
    bpy.data.objects.remove(other)
    with pytest.raises(ValueError, match="no longer exists|deleted"):
        api.evaluate(obj)
    entry = obj.deformkit.entries[0]
    assert "no longer exists" in entry.error or "deleted" in entry.error, entry.error
    assert entries.kind(entry).HINT not in labels(draw_panel(obj))

"""deformkit for Blender: Barr deformers, lattices, Laplacian surface editing and OpenSubdiv
subdivision as non-destructive entries beside the modifier stack, plus headless batch processing."""

bl_info = {
    "name": "deformkit",
    "author": "deformkit developers",
    # A literal, not read from pyproject.toml: Blender's legacy loader parses bl_info from this file's
    # syntax tree without running it. tests/core/test_version.py and package_addon.py check it.
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Properties > Modifiers > deformkit",
    "description": "Barr's twist, bend, taper and stretch, lattices, Laplacian editing and subdivision, as "
                   "non-destructive entries",
    "category": "Object",
}

if "bpy" in locals():  # F8 / script reload
    import importlib
    for _m in (native, properties, outputs, meshdata, lattices, surface, subdivision, evaluation,  # noqa: F821
               api, operators, ui, handlers):  # noqa: F821
        importlib.reload(_m)
else:
    from . import (api, evaluation, handlers, lattices, meshdata, native, operators, outputs, properties,
                   subdivision, surface, ui)

import bpy  # noqa: E402

classes = properties.classes + operators.classes + ui.classes


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    properties.register()
    handlers.register()


def unregister():
    handlers.unregister()
    properties.unregister()
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)

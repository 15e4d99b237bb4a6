"""deformkit for Blender: Barr deformers, lattices, Laplacian surface editing and OpenSubdiv
subdivision as non-destructive entries beside the modifier stack, deformation transfer of shape
keys and animation between meshes (transfer/), plus headless batch processing."""

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
    for _m in (native, cache, properties, outputs, meshdata, entries.common, entries.barr,  # noqa: F821
               entries.lattice, entries.laplacian, entries.subdivide, entries, evaluation,  # noqa: F821
               api, transfer.similarity, transfer.correspondence, transfer.storage,  # noqa: F821
               transfer.system, transfer.keys, transfer.shape_keys, transfer.bake, transfer,  # noqa: F821
               operators.stack, operators.transfer, operators, ui, handlers):  # noqa: F821
        importlib.reload(_m)
else:
    from . import (api, cache, entries, evaluation, handlers, meshdata, native, operators, outputs, properties,
                   transfer, ui)

import sys  # noqa: E402

import bpy  # noqa: E402

# The kinds' modules under the names they had before the entries/ folder (scripts, the batch).
lattices, surface, subdivision = entries.lattice, entries.laplacian, entries.subdivide
for _name, _module in (("lattices", lattices), ("surface", surface), ("subdivision", subdivision)):
    sys.modules[f"{__name__}.{_name}"] = _module

classes = properties.classes + operators.classes + ui.classes


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    properties.register()
    handlers.register()
    operators.register_keymaps()
    operators.register_menus()


def unregister():
    operators.unregister_menus()
    operators.unregister_keymaps()
    handlers.unregister()
    properties.unregister()
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)

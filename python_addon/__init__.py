"""deformkit for Blender: Barr deformers, lattices, Laplacian surface editing, cages, RBF and
OpenSubdiv subdivision as non-destructive entries beside the modifier stack, deformation transfer
of shape keys and animation between meshes (transfer/), plus headless batch processing."""

bl_info = {
    "name": "deformkit",
    "author": "deformkit developers",
    # A literal, not read from pyproject.toml: Blender's legacy loader parses bl_info from this file's
    # syntax tree without running it. tests/core/test_version.py and package_addon.py check it.
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Properties > Modifiers > deformkit",
    "description": "Barr's twist, bend, taper and stretch, lattices, Laplacian/ARAP editing, cages, RBF "
                   "and subdivision as non-destructive entries, and deformation transfer",
    "category": "Object",
}

# Every module, each after the modules it imports: the order of import, F8 reload and registration
# (tests/core/test_addon_layout.py checks that this is every module there is, in that order). A
# module registers its `classes`, then runs its `register()` if it has one; unregistering reverses.
MODULES = (
    "errors", "native", "cache", "panel_text", "recipe_schema", "node_builder", "outputs", "shapekeys", "meshdata",
    "subdivision_order", "echo",
    "entries.common", "entries.binding", "entries.saved_rows", "entries.barr", "entries.lattice", "entries.laplacian",
    "entries.cage", "entries.rbf", "entries.subdivide", "entries",
    "properties", "stack_run", "follow", "entry_animation", "evaluation", "lattice_tools", "smoothness", "api",
    "mesh_deform",
    "transfer.correspondence", "transfer.similarity", "transfer.storage", "transfer.keys", "transfer.system",
    "transfer.shape_keys", "transfer.bake", "transfer.markers", "transfer",
    "operators.base", "operators.stack", "operators.lattice", "operators.laplacian", "operators.cage",
    "operators.cage_generation", "operators.rbf", "operators.transfer", "operators.markers", "operators",
    "ui", "ui_markers", "handlers", "batch_checks", "batch",
)

import importlib  # noqa: E402

import bpy  # noqa: E402

if "_loaded" in globals():  # F8 / script reload runs this file again in its old namespace
    _loaded = [importlib.reload(module) for module in _loaded]
else:
    _loaded = [importlib.import_module(f"{__name__}.{name}") for name in MODULES]
classes = tuple(cls for module in _loaded for cls in getattr(module, "classes", ()))


def register():
    for module in _loaded:
        for cls in getattr(module, "classes", ()):
            bpy.utils.register_class(cls)
        if hasattr(module, "register"):
            module.register()


def unregister():
    for module in reversed(_loaded):
        if hasattr(module, "unregister"):
            module.unregister()
        for cls in reversed(getattr(module, "classes", ())):
            bpy.utils.unregister_class(cls)

"""The Python side of the layout (docs/contributing.md, "What may use what"): the add-on uses only
the Python module of the project, and the Python module never uses the add-on."""
import ast
import pathlib
import sys

REPO = pathlib.Path(__file__).resolve().parents[2]
BLENDER = {"bpy", "bmesh", "mathutils", "gpu", "gpu_extras", "blf", "bl_math", "bl_ui", "addon_utils", "idprop"}


def imported_modules(path):
    """Top-level names of the absolute imports of a file."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            names.add(node.module.split(".")[0])
    return names


def test_the_addon_uses_only_the_python_module():
    addon = REPO / "python_addon"
    own = {p.stem for p in addon.glob("*.py")} | {p.name for p in addon.iterdir() if p.is_dir()}
    allowed = set(sys.stdlib_module_names) | BLENDER | own | {"deformkit", "numpy"}
    wrong = [f"{p.relative_to(REPO)} imports {name}" for p in addon.rglob("*.py")
             for name in sorted(imported_modules(p) - allowed)]
    assert wrong == []


# Blender's start script for a batch job: run by Blender (`--python in_blender.py`), never imported by
# the package; it enables the add-on there, as any script run inside Blender may.
BLENDER_START = pathlib.Path("python/deformkit/batch/in_blender.py")


def test_the_python_module_never_uses_the_addon():
    files = [p for p in (REPO / "python" / "deformkit").rglob("*.py") if p.relative_to(REPO) != BLENDER_START]
    wrong = [f"{p.relative_to(REPO)} imports {name}" for p in files
             for name in sorted(imported_modules(p) & {"deformkit_addon", "python_addon"})]
    assert wrong == []
    assert (REPO / BLENDER_START).exists()
    # ... and nothing in the package imports the start script, which is what keeps it outside.
    assert not [p for p in files for node in ast.walk(ast.parse(p.read_text()))
                if isinstance(node, (ast.Import, ast.ImportFrom)) and "in_blender" in ast.dump(node)]

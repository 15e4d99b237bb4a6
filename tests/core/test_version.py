"""The version is written once, as pyproject.toml's [project] version; everything else that names
it derives from it, or (bl_info, which Blender reads without running the file) equals it."""
import ast
import importlib.metadata
import importlib.util
import pathlib
import tomllib

import deformkit as dk

REPO = pathlib.Path(__file__).resolve().parents[2]
VERSION = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["version"]


def package_addon():
    spec = importlib.util.spec_from_file_location("package_addon", REPO / "scripts" / "package_addon.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_module_reports_the_project_version():
    assert dk.__version__ == VERSION
    assert importlib.metadata.version("deformkit") == VERSION


def test_bl_info_equals_the_project_version():
    tree = ast.parse((REPO / "python_addon" / "__init__.py").read_text())
    bl_info = next(ast.literal_eval(node.value) for node in tree.body
                   if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", None) == "bl_info")
    assert ".".join(map(str, bl_info["version"])) == VERSION


def test_the_packaged_manifest_gets_the_version_and_the_wheel():
    source = (REPO / "python_addon" / "blender_manifest.toml").read_text()
    assert {"version", "wheels"}.isdisjoint(tomllib.loads(source))
    wheel = f"deformkit-{VERSION}-cp311-cp311-linux_x86_64.whl"
    packaged = tomllib.loads(package_addon().packaged_manifest(source, VERSION, wheel))
    assert packaged["version"] == VERSION and packaged["wheels"] == [f"./wheels/{wheel}"]
    assert {k: v for k, v in packaged.items() if k not in ("version", "wheels")} == tomllib.loads(source)


def test_no_other_file_writes_the_version():
    written = []
    for root in ("cpp", "python", "python_addon", "scripts", "docs", "benchmarks", "blend_fixtures"):
        for path in (REPO / root).rglob("*"):
            if path.is_file() and path.suffix in (".py", ".toml", ".cpp", ".hpp", ".md", ".json", ".sh", ""):
                text = path.read_text(errors="replace")
                written += [str(path.relative_to(REPO)) for quoted in (f'"{VERSION}"', f"'{VERSION}'", f"-{VERSION}-")
                            if quoted in text]
    for name in ("CMakeLists.txt", "Makefile", "README.md"):
        if VERSION in (REPO / name).read_text():
            written.append(name)
    assert written == []

"""The add-on's layers (docs/contributing.md, "The add-on's layers"), read from its syntax tree:
imports run one way (UI and operators -> api and evaluation -> kinds -> shared entry code ->
helpers), a kind never imports another kind, nothing imports another module's private name, the
evaluation reads as short stages, and the module list of __init__.py is every module there is."""
import ast
import fnmatch
import pathlib

REPO = pathlib.Path(__file__).resolve().parents[2]
ADDON = REPO / "python_addon"

# Layer of each module (dotted, relative to the add-on; a package is its __init__), by pattern,
# first match wins. A new module must be given a place here and in docs/contributing.md.
LAYERS = (
    ("__init__", 4), ("ui", 4), ("ui_markers", 4), ("handlers", 4), ("batch", 4), ("batch_checks", 4),
    ("operators", 4), ("operators.cage_generation", 4), ("operators.*", 4),
    ("api", 3), ("entry_animation", 3), ("evaluation", 3), ("stack_run", 3), ("follow", 3), ("properties", 3), ("lattice_tools", 3),
    ("smoothness", 3), ("mesh_deform", 3), ("transfer", 3), ("transfer.*", 3),
    ("entries", 2),  # the registry
    ("entries.common", 1), ("entries.binding", 1), ("entries.saved_rows", 1),
    ("entries.*", 2),  # the kinds
    ("errors", 0), ("native", 0), ("cache", 0), ("meshdata", 0), ("shapekeys", 0), ("outputs", 0), ("node_builder", 0),
    ("panel_text", 0), ("recipe_schema", 0), ("subdivision_order", 0), ("echo", 0),
)
NAMES = {4: "UI and operators", 3: "api and evaluation", 2: "kinds", 1: "shared entry code", 0: "helpers"}


def module_name(path):
    parts = list(path.relative_to(ADDON).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts) or "__init__"


MODULES = {module_name(p): p for p in sorted(ADDON.rglob("*.py"))}


def layer(name):
    return next((level for pattern, level in LAYERS if fnmatch.fnmatchcase(name, pattern)), None)


def is_kind(name):
    return layer(name) == 2 and name != "entries"


def package_of(name):
    """The package a module's relative imports start from."""
    path = MODULES[name]
    if path.name == "__init__.py":
        return name if name != "__init__" else ""
    return name.rpartition(".")[0]


def resolve(name, node):
    """[(imported add-on module, [imported names])] of one import statement (any depth in the file)."""
    if isinstance(node, ast.Import):
        found = []
        for alias in node.names:
            if alias.name.split(".")[0] == "deformkit_addon":
                target = alias.name.partition(".")[2] or "__init__"
                found.append((target, []))
        return found
    if node.level == 0:
        if (node.module or "").split(".")[0] != "deformkit_addon":
            return []
        base = node.module.partition(".")[2]
    else:
        base = package_of(name)
        for _ in range(node.level - 1):
            base = base.rpartition(".")[0]
        if node.module:
            base = f"{base}.{node.module}" if base else node.module
    found = []
    names = []
    for alias in node.names:
        sub = f"{base}.{alias.name}" if base else alias.name
        if sub in MODULES:
            found.append((sub, []))  # `from . import api`: the module itself
        else:
            names.append(alias.name)
    if names:
        found.append((base or "__init__", names))
    return found


def imports():
    """{module: {imported module: [names taken from it]}}, function-level imports included."""
    graph = {}
    for name, path in MODULES.items():
        edges = graph.setdefault(name, {})
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                for target, names in resolve(name, node):
                    if target != name:
                        edges.setdefault(target, []).extend(names)
    return graph


GRAPH = imports()


def test_every_module_has_a_layer():
    assert [m for m in MODULES if layer(m) is None] == []


def test_no_import_cycle():
    """Tarjan's strongly connected components of the import graph: each must be one module."""
    index, low, on_stack, stack, cycles = {}, {}, set(), [], []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in GRAPH.get(v, {}):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for v in GRAPH:
        if v not in index:
            visit(v)
    assert cycles == []


def test_imports_run_downward_and_kinds_stay_apart():
    wrong = []
    for source, targets in GRAPH.items():
        for target in targets:
            if layer(target) is None or layer(source) is None:
                continue  # test_every_module_has_a_layer names them
            if layer(target) > layer(source):
                wrong.append(f"{source} ({NAMES[layer(source)]}) imports {target} ({NAMES[layer(target)]})")
            elif is_kind(source) and layer(target) == 2:
                wrong.append(f"the kind {source} imports {target}")
    assert wrong == []


def test_no_module_takes_another_modules_private_names():
    wrong = [f"{source} imports {target}.{n}" for source, targets in GRAPH.items()
             for target, names in targets.items() for n in names if n.startswith("_") and not n.startswith("__")]
    for name, path in MODULES.items():
        tree = ast.parse(path.read_text())
        aliases = set()  # names bound to add-on modules in this file
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                modules = {target for target, taken in resolve(name, node) if not taken}
                for alias in node.names:
                    if any(t == alias.name or t.endswith("." + alias.name) for t in modules):
                        aliases.add(alias.asname or alias.name.split(".")[-1])
        for node in ast.walk(tree):
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in aliases
                    and node.attr.startswith("_") and not node.attr.startswith("__")):
                wrong.append(f"{name} uses {node.value.id}.{node.attr}")
    assert wrong == []


def function_lengths(path):
    return {node.name: node.end_lineno - node.lineno + 1 for node in ast.walk(ast.parse(path.read_text()))
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))}


def test_the_evaluation_reads_as_short_stages():
    lengths = function_lengths(ADDON / "evaluation.py")
    assert lengths["evaluate"] <= 40
    assert {f: n for f, n in lengths.items() if n > 50} == {}


def declared_modules():
    tree = ast.parse((ADDON / "__init__.py").read_text())
    found = [node.value for node in tree.body if isinstance(node, ast.Assign)
             and any(isinstance(t, ast.Name) and t.id == "MODULES" for t in node.targets)]
    assert len(found) == 1, "__init__.py declares MODULES once"
    return list(ast.literal_eval(found[0]))


def test_the_module_list_is_every_module_in_import_order():
    """One list drives import, reload (F8) and registration: it must name every module, and name
    each after the modules it imports, so that a reload refreshes what a module uses first."""
    declared = declared_modules()
    assert sorted(declared) == sorted(m for m in MODULES if m != "__init__")
    place = {m: i for i, m in enumerate(declared)}
    late = [f"{m} is listed before {t}, which it imports" for m in declared
            for t in GRAPH[m] if t != "__init__" and place[t] > place[m]]
    assert late == []


def test_files_are_short_enough_to_read_in_one_sitting():
    for folder in (ADDON, REPO / "python" / "deformkit" / "batch"):
        long = {str(p.relative_to(REPO)): n for p in sorted(folder.rglob("*.py"))
                if (n := len(p.read_text().splitlines())) > 450}
        assert long == {}


# What runs on every evaluation: numpy.linalg stays out of it. Its LAPACK calls wake OpenBLAS's
# threads, and on a busy machine one 4x4 inverse then took 1.1 ms (44 us with one thread): two per
# frame made the Cage entry's own cost half a Mesh Deform frame again (entries/common.affine_inverse).
EVALUATION_PATH = ("entries", "evaluation.py", "stack_run.py", "outputs.py", "meshdata.py", "shapekeys.py",
                   "handlers.py", "cache.py", "node_builder.py")


def test_no_lapack_on_the_evaluation_path():
    found = []
    for name in EVALUATION_PATH:
        paths = sorted((ADDON / name).glob("*.py")) if (ADDON / name).is_dir() else [ADDON / name]
        for path in paths:
            for node in ast.walk(ast.parse(path.read_text())):
                named = (isinstance(node, ast.Attribute) and node.attr == "linalg") or \
                    (isinstance(node, (ast.Import, ast.ImportFrom)) and "linalg" in ast.dump(node))
                if named:
                    found.append(f"{path.relative_to(ADDON)}:{node.lineno}")
    assert not found, "numpy.linalg on the evaluation path (use entries.common.affine_inverse): " + ", ".join(found)

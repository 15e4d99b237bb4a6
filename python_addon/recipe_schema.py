"""The batch recipe's schema, checked before any file is opened, without bpy.

Everything an entry accepts comes from the add-on's own source, read as syntax trees (so the
launcher needs no Blender): each property's kind, hard min/max, vector size and enum identifiers
from DEFORMKIT_PG_entry in properties.py (the enum tables from the kind modules it imports them
from), and which properties each entry type uses from the kinds themselves (entries/: the registry's
MODULES, each kind's ENTRY_TYPES and FIELDS or TYPE_FIELDS). Written here are only the keys that
are no entry property: "bind" (BATCH_ONLY, taken by the kinds with an Unbind, which deform nothing
until bound) and the keys of a transfer step (TRANSFER_KEYS: the arguments of the transfer package's
functions). A value Blender would clamp, round to zero or reinterpret is refused, with the key path
(`deformers[2].limits`) and what the key accepts.
"""
import ast
import datetime
import difflib
import functools
import math
import os

ADDON = os.path.dirname(os.path.abspath(__file__))
PROPERTIES_PY = os.path.join(ADDON, "properties.py")
REGISTRY_PY = os.path.join(ADDON, "entries", "__init__.py")
FLT_MAX = 3.4028234663852886e38   # a FloatProperty without min/max: RNA's hard range is +-FLT_MAX
FLT_TRUE_MIN = 1.401298464324817e-45  # smaller magnitudes are stored as 0.0 (float32)
INT_MIN, INT_MAX = -2 ** 31, 2 ** 31 - 1

COMMON = ("type", "name", "show_viewport", "show_render")  # every deformer table's keys
BATCH_ONLY = {"bind": {"kind": "bool"}}  # the kinds with an Unbind (Laplacian, Cage, RBF): bound as they are added
TOP_LEVEL = {"objects": "a list of object names (\"*\": every mesh)", "deformers": "a non-empty list of tables",
             "replace": "true or false (clear the objects' stacks first)",
             "smoothness": "true or false (smoothness figures in the report)",
             "transfers": "a non-empty list of tables with a source and a target (shape keys from one object "
                          "onto another, before the deformers)"}
# A transfers[i] table: the arguments of transfer.transfer_shape_keys / transfer_animation (the
# operator's properties). Frames: Blender's scene frame range (MINAFRAME, MAXAFRAME).
FRAME_RANGE = {"kind": "int", "min": -1048574, "max": 1048574}
TRANSFER_KEYS = {"source": {"kind": "object"}, "target": {"kind": "object"},
                 "mode": {"kind": "enum", "items": ("SHAPE_KEYS", "ANIMATION")},
                 "frame_start": FRAME_RANGE, "frame_end": FRAME_RANGE, "replace": {"kind": "bool"},
                 "marker_prefix": {"kind": "string"}}
TRANSFER_REQUIRED = ("source", "target")


@functools.lru_cache(maxsize=None)
def _module(path):
    """(syntax tree, {name: definition}) of an add-on module: each top-level assignment as
    ("value", expression) and each relative import as ("module", file) or ("name", name, file)."""
    with open(path, encoding="utf-8") as fh:
        tree = ast.parse(fh.read(), path)
    names = {}
    for node in tree.body:
        if isinstance(node, ast.Assign):
            names.update({t.id: ("value", node.value) for t in node.targets if isinstance(t, ast.Name)})
        elif isinstance(node, ast.ImportFrom) and node.level:
            base = os.path.dirname(path)
            for _ in range(node.level - 1):
                base = os.path.dirname(base)
            base = os.path.join(base, *(node.module or "").split("."))
            for alias in node.names:
                names[alias.asname or alias.name] = _imported(base, alias.name)
    return tree, names


def _imported(base, name):
    for module in (os.path.join(base, name + ".py"), os.path.join(base, name, "__init__.py")):
        if os.path.exists(module):
            return ("module", module)
    return ("name", name, os.path.join(base, "__init__.py") if os.path.isdir(base) else base + ".py")


def _named(name, path):
    """The literal value of `name` in the module at `path` (followed through relative imports)."""
    found = _module(path)[1].get(name)
    if found is None or found[0] == "module":
        raise ValueError(f"{path}: {name} is no literal the recipe schema can read")
    return _value(found[1], path) if found[0] == "value" else _named(found[1], found[2])


def _module_of(name, path):
    found = _module(path)[1].get(name)
    if found is None or found[0] != "module":
        raise ValueError(f"{path}: {name} is no add-on module")
    return found[1]


def _value(node, path):
    """The value of a literal expression of the module at `path`: constants and containers of
    them, names (and module.NAME) of such literals, and + of them (tuples joined)."""
    if isinstance(node, ast.Name):
        return _named(node.id, path)
    if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
        return _named(node.attr, _module_of(node.value.id, path))
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add):
        return _value(node.left, path) + _value(node.right, path)
    if isinstance(node, (ast.Tuple, ast.List)):
        items = [_value(item, path) for item in node.elts]
        return tuple(items) if isinstance(node, ast.Tuple) else items
    if isinstance(node, ast.Dict):
        return {_value(k, path): _value(v, path) for k, v in zip(node.keys, node.values)}
    return ast.literal_eval(node)


def _defines(path, name):
    """True when the module at `path` defines `name` at its top level (a function or a value)."""
    tree, names = _module(path)
    return name in names or any(isinstance(node, ast.FunctionDef) and node.name == name for node in tree.body)


def read_type_keys(registry=REGISTRY_PY):
    """{entry type: the keys its deformer table takes besides COMMON}, in the registry's order of
    the kinds: the properties each type uses, and "bind" for the kinds with an Unbind."""
    table = {}
    for name in _module(registry)[1]["MODULES"][1].elts:
        kind = _module_of(name.id, registry)
        by_type = _named("TYPE_FIELDS", kind) if _defines(kind, "TYPE_FIELDS") else {}
        bind = ("bind",) if _defines(kind, "unbind") else ()
        for row in _named("ENTRY_TYPES", kind):
            table[row[0]] = tuple(by_type[row[0]] if by_type else _named("FIELDS", kind)) + bind
    return table


TYPE_KEYS = read_type_keys()


def read_type_labels(registry=REGISTRY_PY):
    """{entry type: its label ("RBF", "Laplacian")}, as the panel names it."""
    return {row[0]: row[1] for name in _module(registry)[1]["MODULES"][1].elts
            for row in _named("ENTRY_TYPES", _module_of(name.id, registry))}


TYPE_LABELS = read_type_labels()


class RecipeError(ValueError):
    """A recipe that cannot run; str() names every bad key path."""

    def __init__(self, problems):
        super().__init__("; ".join(problems))
        self.problems = list(problems)


def read_property_table(path=PROPERTIES_PY):
    """{parameter: spec} for every property of DEFORMKIT_PG_entry, from properties.py's source
    (the Type enum's identifiers: every kind's, TYPE_KEYS')."""
    tree = _module(path)[0]
    entry = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "DEFORMKIT_PG_entry")
    table = {}
    for node in entry.body:
        if not (isinstance(node, ast.AnnAssign) and isinstance(node.annotation, ast.Call)):
            continue
        call, key = node.annotation, node.target.id
        kw = {k.arg: k.value for k in call.keywords if k.arg in ("min", "max", "size", "items")}
        if key == "type":
            table[key] = {"kind": "enum", "items": tuple(TYPE_KEYS)}
        else:
            table[key] = _spec(call.func.id, {k: _value(v, path) for k, v in kw.items()})
    return table


def _spec(prop, kw):
    if prop in ("FloatProperty", "FloatVectorProperty"):
        spec = {"kind": "float", "min": float(kw.get("min", -FLT_MAX)), "max": float(kw.get("max", FLT_MAX))}
        if prop == "FloatVectorProperty":
            spec["size"] = kw.get("size", 3)
        return spec
    if prop == "IntProperty":
        return {"kind": "int", "min": int(kw.get("min", INT_MIN)), "max": int(kw.get("max", INT_MAX))}
    if prop == "BoolProperty":
        return {"kind": "bool"}
    if prop == "EnumProperty":
        return {"kind": "enum", "items": tuple(item[0] for item in kw["items"])}
    if prop == "StringProperty":
        return {"kind": "string"}
    if prop == "PointerProperty":
        return {"kind": "object"}
    return {"kind": "other"}


PROPERTIES = read_property_table()
ENTRY_TYPES = PROPERTIES["type"]["items"]


def _got(value):
    if isinstance(value, (datetime.date, datetime.time)):  # TOML dates, times and datetimes
        return f"a TOML {type(value).__name__} ({value.isoformat()})"
    text = repr(value)
    return f"{type(value).__name__} {text if len(text) <= 60 else text[:57] + '...'}"


def _is_number(value):
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _float_problem(value, spec):
    accepts = f"a finite number in [{spec['min']:.9g}, {spec['max']:.9g}]"
    if not _is_number(value):
        return f"expected {accepts}, got {_got(value)}"
    try:
        x = float(value)
    except OverflowError:
        return f"expected {accepts}, got an integer of {len(str(abs(value)))} digits"
    if not math.isfinite(x) or not spec["min"] <= x <= spec["max"]:
        return f"expected {accepts} (Blender would clamp it), got {value!r}"
    if 0.0 < abs(x) < FLT_TRUE_MIN:
        return f"expected {accepts}; {value!r} is too small for Blender's 32-bit float (it would become 0)"
    return ""


def _int_problem(value, spec):
    accepts = f"an integer in {spec['min']}..{spec['max']}"
    if not isinstance(value, int) or isinstance(value, bool):
        return f"expected {accepts}, got {_got(value)}"
    if not spec["min"] <= value <= spec["max"]:
        return f"expected {accepts} (Blender would clamp it), got {value}"
    return ""


def value_problem(value, spec):
    """'' when Blender stores `value` unchanged in a property of this spec, else what is wrong."""
    kind = spec["kind"]
    if kind == "bool":
        return "" if isinstance(value, bool) else f"expected true or false, got {_got(value)}"
    if kind == "enum":
        if isinstance(value, str) and value in spec["items"]:
            return ""
        return f"expected one of {', '.join(spec['items'])}, got {_got(value)}"
    if kind in ("string", "object"):
        if not isinstance(value, str):
            return f"expected {'an object name' if kind == 'object' else 'a string'}, got {_got(value)}"
        if "\x00" in value:
            return "expected a string without NUL characters (Blender would cut it there)"
        return "" if value or kind == "string" else "expected an object name, got an empty string"
    if kind == "int":
        return _int_problem(value, spec)
    if kind == "float" and "size" in spec:
        if not isinstance(value, (list, tuple)) or len(value) != spec["size"]:
            return f"expected a list of {spec['size']} numbers in [{spec['min']:g}, {spec['max']:g}], got {_got(value)}"
        for i, x in enumerate(value):
            problem = _float_problem(x, spec)
            if problem:
                return f"[{i}]: {problem}"
        return ""
    if kind == "float":
        return _float_problem(value, spec)
    return f"cannot be set from a recipe (got {_got(value)})"


def _unknown_key(key, accepted, where):
    near = difflib.get_close_matches(str(key), accepted, n=1)
    hint = f" (did you mean '{near[0]}'?)" if near else ""
    return f"{where}{key}: not a key here{hint}; accepted: {', '.join(accepted)}"


def entry_problems(spec, path):
    """Problems of one deformer table at key path `path` (e.g. "deformers[2]")."""
    if not isinstance(spec, dict):
        return [f"{path}: expected a table with a 'type', got {_got(spec)}"]
    kind = spec.get("type")
    if not isinstance(kind, str) or kind.upper() not in TYPE_KEYS:
        return [f"{path}.type: expected one of {', '.join(ENTRY_TYPES)}, got "
                + (_got(kind) if "type" in spec else "nothing")]
    kind = kind.upper()
    accepted = COMMON + TYPE_KEYS[kind]
    problems = []
    for key, value in spec.items():
        if key == "type":
            continue
        if key not in accepted:
            problems.append(_unknown_key(key, accepted, f"{path}.") + f" (for a {TYPE_LABELS[kind]} entry)")
            continue
        problem = value_problem(value, BATCH_ONLY.get(key) or PROPERTIES[key])
        if not problem and key == "limits" and value[0] > value[1]:
            problem = f"the lower limit {value[0]!r} is above the upper limit {value[1]!r} (expected [lo, hi], lo <= hi)"
        if problem:
            problems.append(f"{path}.{key}{'' if problem.startswith('[') else ': '}{problem}")
    return problems


def transfer_problems(spec, path):
    """Problems of one transfers table at key path `path` (e.g. "transfers[0]")."""
    if not isinstance(spec, dict):
        return [f"{path}: expected a table with a 'source' and a 'target', got {_got(spec)}"]
    accepted = tuple(TRANSFER_KEYS)
    problems = [f"{path}.{key}: missing (the object's name)" for key in TRANSFER_REQUIRED if key not in spec]
    for key, value in spec.items():
        if key not in TRANSFER_KEYS:
            problems.append(_unknown_key(key, accepted, f"{path}.") + " (for a transfer)")
            continue
        problem = value_problem(value, TRANSFER_KEYS[key])
        if not problem and key == "marker_prefix" and not value:
            problem = "expected a non-empty prefix (the marker vertex groups' common start, e.g. 'dt_')"
        if problem:
            problems.append(f"{path}.{key}: {problem}")
    if spec.get("mode", "SHAPE_KEYS") != "ANIMATION":
        problems += [f"{path}.{key}: only with \"mode\": \"ANIMATION\" (a frame range to bake)"
                     for key in ("frame_start", "frame_end") if key in spec]
    start, end = spec.get("frame_start"), spec.get("frame_end")
    if isinstance(start, int) and isinstance(end, int) and start > end:
        problems.append(f"{path}.frame_end: {end} is before frame_start {start}")
    if isinstance(spec.get("source"), str) and spec.get("source") == spec.get("target"):
        problems.append(f"{path}.target: the same object as the source ('{spec['source']}'): expected another")
    return problems


def recipe_problems(recipe):
    """Every problem of a parsed recipe, each naming its key path; [] for a good recipe."""
    if not isinstance(recipe, dict):
        return [f"recipe: expected a table with 'deformers', got {_got(recipe)}"]
    problems = [_unknown_key(key, tuple(TOP_LEVEL), "") for key in recipe if key not in TOP_LEVEL]
    transfers = recipe.get("transfers")
    if "transfers" in recipe:
        if not isinstance(transfers, list) or not transfers:
            problems.append(f"transfers: expected {TOP_LEVEL['transfers']}, got {_got(transfers)}")
        else:
            for i, spec in enumerate(transfers):
                problems += transfer_problems(spec, f"transfers[{i}]")
    for key in ("replace", "smoothness"):
        if key in recipe and not isinstance(recipe[key], bool):
            problems.append(f"{key}: expected true or false, got {_got(recipe[key])}")
    objects = recipe.get("objects", ["*"])
    if not isinstance(objects, list) or not objects:
        problems.append(f"objects: expected {TOP_LEVEL['objects']}, got {_got(objects)}")
    else:
        problems += [f"objects[{i}]: expected an object name, got {_got(o)}"
                     for i, o in enumerate(objects) if not isinstance(o, str) or not o or "\x00" in o]
    deformers = recipe.get("deformers")
    if "deformers" not in recipe and "transfers" in recipe:
        return problems  # transfers only
    if not isinstance(deformers, list) or not deformers:
        problems.append(f"deformers: expected {TOP_LEVEL['deformers']}, got "
                        + (_got(deformers) if "deformers" in recipe else "nothing"))
        return problems
    for i, spec in enumerate(deformers):
        problems += entry_problems(spec, f"deformers[{i}]")
    subdivide = [i for i, s in enumerate(deformers) if isinstance(s, dict) and str(s.get("type")).upper() == "SUBDIVIDE"]
    if subdivide and subdivide[0] != len(deformers) - 1:
        problems.append(f"deformers[{subdivide[0]}]: a Subdivide entry must be the last deformer "
                        f"(the stack subdivides what the entries above make), but {len(deformers) - 1 - subdivide[0]} follow it")
    return problems


def validate(recipe):
    """The recipe with "objects" defaulted, or RecipeError naming every bad key path."""
    problems = recipe_problems(recipe)
    if problems:
        raise RecipeError(problems)
    return {**recipe, "objects": recipe.get("objects", ["*"])}

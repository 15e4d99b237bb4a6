"""The batch recipe's schema against what Blender itself stores: every value it accepts is kept
exactly by the entry's property, every value it refuses Blender would clamp, round or refuse; and
bad recipes are refused on the command line, before Blender starts, naming the key path."""
import importlib.util
import json
import math
import subprocess
import sys

import pytest

from addon_helpers import IN_BLENDER_BINARY, REPO, make_object

# Loaded from its file, bpy-free, as the launcher loads it (not through the add-on package).
_spec = importlib.util.spec_from_file_location("recipe_schema", REPO / "python_addon/recipe_schema.py")
recipe_schema = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(recipe_schema)

ENTRY_KEYS = sorted({k for keys in recipe_schema.TYPE_KEYS.values() for k in keys} | set(recipe_schema.COMMON))
RNA_KINDS = {"FLOAT": "float", "INT": "int", "BOOLEAN": "bool", "ENUM": "enum", "STRING": "string",
             "POINTER": "object"}


def rna(key):
    from deformkit_addon import properties
    return properties.DEFORMKIT_PG_entry.bl_rna.properties[key]


def test_every_entry_parameter_has_a_schema(addon):
    from deformkit_addon import api
    assert set(ENTRY_KEYS) - {"type", "bind"} == set(api.PARAMS)
    assert set(recipe_schema.TYPE_KEYS) == set(api.TYPES)


@pytest.mark.parametrize("key", [k for k in ENTRY_KEYS if k not in ("type", "bind")])
def test_schema_is_the_registered_property(addon, key):
    """The ranges, sizes and enum items read from properties.py are those Blender registered."""
    prop, spec = rna(key), recipe_schema.PROPERTIES[key]
    assert RNA_KINDS[prop.type] == spec["kind"]
    if prop.type in ("FLOAT", "INT"):
        assert (prop.hard_min, prop.hard_max) == (spec["min"], spec["max"])
        assert getattr(prop, "array_length", 0) == spec.get("size", 0)
    if prop.type == "ENUM":
        assert tuple(item.identifier for item in prop.enum_items) == spec["items"]


def stored(entry, key, value):
    """What the entry holds after Blender is given `value`; None if Blender refuses it."""
    try:
        setattr(entry, key, value)
    except (TypeError, ValueError, OverflowError):
        return None
    got = getattr(entry, key)
    return tuple(got) if hasattr(got, "__len__") and not isinstance(got, str) else got


def kept(value, got):
    """Blender stores floats as float32: kept means equal but for that rounding (half an ulp)."""
    if got is None:
        return False
    if isinstance(value, (list, tuple)):
        return all(kept(v, g) for v, g in zip(value, got))
    if isinstance(value, float):
        return got == value if not math.isfinite(value) else abs(got - value) <= abs(value) * 2.0 ** -24
    return value == got and type(value) is type(got)


def candidates(spec):
    """Values at, inside and beyond a numeric spec's limits, and wrongly typed ones."""
    if spec["kind"] == "int":
        lo, hi = spec["min"], spec["max"]
        return [lo, hi, (lo + hi) // 2, lo - 1, hi + 1, 10 ** 9, -10 ** 9, 2.0, True, "3"]
    lo, hi = spec["min"], spec["max"]

    def beyond(x, direction):  # further out than float32 rounding could explain
        return x + direction * max(abs(x) * 1e-5, 1e-5)

    return [lo, hi, (lo + hi) / 2, 0.25 * hi, beyond(hi, 1), hi * 4 if hi > 0 else hi + 4, beyond(lo, -1),
            math.inf, -math.inf, math.nan, 1e-50, 1e400, 10 ** 400, True, "1"]


@pytest.mark.parametrize("key", ["angle", "factor", "strength", "iterations", "levels", "render_levels", "limits"])
def test_accepted_means_stored_unchanged(scene, key):
    """For each candidate value: the schema accepts it exactly when Blender keeps it unchanged
    (no FLT_MAX clamp, no level clamp, no float32 underflow to 0, no bool taken as a number)."""
    import bpy
    from deformkit_addon import api
    entry = api.add_entry(make_object(bpy), "TWIST")
    spec = recipe_schema.PROPERTIES[key]
    for value in candidates(spec):
        if "size" in spec:  # limits: vary the upper limit, lower limit 0 (lo <= hi is checked apart)
            value = [0.0, value] if not isinstance(value, (bool, str)) else [value, 1.0]
        accepted = recipe_schema.value_problem(value, spec) == ""
        if "size" in spec and value[1] == 10 ** 400:  # bpy crashes on it (SIGSEGV): the schema keeps it away
            assert not accepted
            continue
        assert accepted == kept(value, stored(entry, key, value)), (key, value)


def test_booleans_must_be_booleans(scene):
    for text in ("no", "false", "False", 0, 1, None):
        problem = recipe_schema.value_problem(text, {"kind": "bool"})
        assert problem.startswith("expected true or false"), text


def run_cli(tmp_path, recipe_text, suffix=".json"):
    path = tmp_path / f"recipe{suffix}"
    path.write_text(recipe_text)
    return subprocess.run([sys.executable, "-m", "deformkit.batch", "--addon", str(REPO / "python_addon"), str(tmp_path / "none.blend"),
                           "--recipe", str(path), "--out", str(tmp_path / "out"), "--blender", sys.executable],
                          capture_output=True, text=True, timeout=60)


BAD = [
    ('{"deformers": [{"type": "TWIST", "angle": Infinity}]}', "deformers[0].angle: expected a finite number"),
    ('{"deformers": [{"type": "TWIST", "angle": 1e308}]}', "deformers[0].angle: expected a finite number"),
    ('{"deformers": [{"type": "BEND"}, {"type": "TWIST", "angle": 1e400}]}', "deformers[1].angle"),
    ('{"deformers": [{"type": "TWIST"}, {"type": "TAPER"}, {"type": "TWIST", "limits": [0.8, 0.2]}]}',
     "deformers[2].limits: the lower limit 0.8 is above the upper limit 0.2"),
    ('{"deformers": [{"type": "SUBDIVIDE", "levels": -1}]}', "deformers[0].levels: expected an integer in 0..8"),
    ('{"deformers": [{"type": "SUBDIVIDE", "levels": 1000000000}]}', "deformers[0].levels: expected an integer in 0..8"),
    ('{"deformers": [{"type": "SUBDIVIDE", "levels": 1e9}]}', "deformers[0].levels: expected an integer in 0..8"),
    ('{"deformers": [{"type": "TWIST", "lock_x": "no"}]}', "deformers[0].lock_x: expected true or false"),
    ('{"deformers": [{"type": "SUBDIVIDE", "use_creases": "false"}]}', "deformers[0].use_creases: expected true"),
    ('{"deformers": [{"type": "TWIST", "angel": 1.0}]}', "deformers[0].angel: not a key here (did you mean 'angle'?)"),
    ('{"deformers": [{"type": "TWIST", "origin": 5}]}', "deformers[0].origin: expected an object name"),
    ('{"deformers": [{"type": "SUBDIVIDE"}, {"type": "TWIST"}]}', "deformers[0]: a Subdivide entry must be the last"),
    ('{"deformers": [{"type": "SPIN"}]}', "deformers[0].type: expected one of TWIST, BEND"),
    ('{"deformers": [{"type": "TWIST", "angle": 1, "angle": 2}]}', "key 'angle' given twice"),
    ('{"deformers": []}', "deformers: expected a non-empty list of tables"),
    ('{"deformers": [{"type": "TWIST"}], "smoothness": "yes"}', "smoothness: expected true or false"),
    ('[' * 100000 + ']' * 100000, "nested too deeply"),
]


@pytest.mark.skipif(IN_BLENDER_BINARY, reason="runs the launcher, not Blender")
@pytest.mark.parametrize("text, message", BAD)
def test_bad_recipes_are_refused_before_blender(tmp_path, text, message):
    """Exit status 2, one line naming --recipe and the key path, no traceback, nothing run (the
    Blender given is not even a Blender: the recipe is refused first)."""
    proc = run_cli(tmp_path, text)
    assert proc.returncode == 2 and message in proc.stderr, proc.stderr
    assert proc.stderr.count("\n") == 1 and "--recipe" in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.skipif(IN_BLENDER_BINARY, reason="runs the launcher, not Blender")
def test_toml_datetimes_and_deep_toml(tmp_path):
    proc = run_cli(tmp_path, '[[deformers]]\ntype = "TWIST"\nangle = 1979-05-27T07:32:00Z\n', ".toml")
    assert proc.returncode == 2 and "deformers[0].angle: expected a finite number" in proc.stderr
    assert "TOML datetime (1979-05-27T07:32:00+00:00)" in proc.stderr
    proc = run_cli(tmp_path, "deformers = " + "[" * 100000 + "]" * 100000 + "\n", ".toml")
    assert proc.returncode == 2 and "nested too deeply" in proc.stderr and "Traceback" not in proc.stderr


def test_good_recipes_pass():
    recipe = json.loads((REPO / "blend_fixtures/demo_recipe.json").read_text())
    assert recipe_schema.validate(recipe)["deformers"] == recipe["deformers"]
    assert recipe_schema.recipe_problems({"deformers": [
        {"type": "twist", "angle": -3.0e38, "limits": [0.5, 0.5], "lock_y": True, "origin": "Empty"},
        {"type": "LATTICE", "lattice": "Lattice", "strength": 0.0, "outside": "EXTRAPOLATE"},
        {"type": "LAPLACIAN", "iterations": 1000, "bind": True, "handle_object": "Empty"},
        {"type": "SUBDIVIDE", "levels": 8, "render_levels": 0, "uv_smooth": "SMOOTH_ALL"}]}) == []

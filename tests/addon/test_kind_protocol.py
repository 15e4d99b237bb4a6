"""The kind protocol (python_addon/entries/__init__.py): the registry gives a kind the defaults of
the optional members it leaves out, so no kind writes stubs; the bind protocol is the one way the
api binds; each kind's enum tables are written once, in the kind."""
import ast
import types

import numpy as np
import pytest

from addon_helpers import REPO, make_object, positions

ENTRIES = REPO / "python_addon" / "entries"
KIND_FILES = ("barr", "lattice", "laplacian", "cage", "rbf", "subdivide")


def bare_kind(**members):
    """A kind module with the required members only (and `members`)."""
    module = types.ModuleType("bare_kind")
    module.ENTRY_TYPES = [("BARE", "Bare", "A test kind", "NONE", 99)]
    module.TYPES = ("BARE",)
    module.ICON = "NONE"
    module.FIELDS = ("strength",)
    module.setup = module.deform = module.draw = lambda *args: None
    vars(module).update(members)
    return module


class Doubling:
    def deform(self, points):
        return 2.0 * np.asarray(points)


def test_a_kind_with_the_required_members_only_gets_every_default(scene):
    import bpy
    from deformkit_addon import entries
    from deformkit_addon.entries.common import Prepared
    kind = entries.Kind(bare_kind())
    assert (kind.STACKABLE, kind.LAST, kind.DEFORMS_INTO, kind.MENU, kind.TYPE_LABEL) == (False, False, False, (),
                                                                                         "Type")
    assert kind.fields("BARE") == ("strength",)
    assert kind.followed(None) == [] and kind.volume_note([]) == ""
    assert kind.retyped(None) is None and kind.prune(None, []) is None and kind.copy_bind(None, None) is None
    assert kind.bind is None and kind.unbind is None and kind.is_bound(None) is False and kind.NOT_COPIED == ()
    # apply's default: the entry's deformer takes the base mesh, which becomes its result.
    obj = make_object(bpy)
    base = positions(obj.data)
    kind.apply(obj, None, Prepared(Doubling(), None, None), base)
    np.testing.assert_array_equal(positions(obj.data), (2.0 * base).astype(np.float32))


def test_the_module_is_asked_each_time_and_overrides_the_default(addon):
    from deformkit_addon import entries
    module = bare_kind(LAST=True)
    kind = entries.Kind(module)
    assert kind.LAST is True
    module.volume_note = lambda entries: "patched"  # as a benchmark's timer wraps a kind's function
    assert kind.volume_note([]) == "patched"
    by_type = entries.Kind(bare_kind(TYPE_FIELDS={"BARE": ("angle", "factor")}))
    del by_type.module.FIELDS
    assert by_type.fields("BARE") == ("angle", "factor") and by_type.FIELDS == ("angle", "factor")


@pytest.mark.parametrize("missing", ["ENTRY_TYPES", "TYPES", "ICON", "FIELDS", "setup", "deform", "draw"])
def test_a_kind_without_a_required_member_is_refused_naming_it(addon, missing):
    from deformkit_addon import entries
    module = bare_kind()
    delattr(module, missing)
    with pytest.raises(ImportError, match=f"bare_kind lacks {missing}"):
        entries.Kind(module)


TRIVIAL_RETURNS = ([], "", None, False, ())


def is_stub(function):
    """A function that does nothing or returns what the protocol's default returns."""
    body = [node for node in function.body
            if not (isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant))]  # its docstring
    if not body or all(isinstance(node, ast.Pass) for node in body):
        return True
    if len(body) == 1 and isinstance(body[0], ast.Return):
        value = body[0].value
        try:
            return value is None or ast.literal_eval(value) in TRIVIAL_RETURNS
        except ValueError:
            return False
    return False


def test_no_kind_writes_a_stub_of_an_optional_member(addon):
    from deformkit_addon import entries
    optional = set(entries.DEFAULTS) | {"fields"}
    stubs = []
    for name in KIND_FILES:
        tree = ast.parse((ENTRIES / f"{name}.py").read_text())
        for node in tree.body:
            if isinstance(node, ast.FunctionDef) and node.name in optional and is_stub(node):
                stubs.append(f"{name}.{node.name}")
            if isinstance(node, ast.Assign) and any(getattr(t, "id", None) in entries.DEFAULTS for t in node.targets):
                target = next(t.id for t in node.targets)
                try:
                    if ast.literal_eval(node.value) == entries.DEFAULTS[target]:
                        stubs.append(f"{name}.{target}")
                except ValueError:
                    pass
    assert stubs == []


def test_the_enum_tables_are_written_once_in_the_kinds(addon):
    """properties.py takes every enum's items from a kind: it assigns no table of its own."""
    from deformkit_addon import entries, properties
    tree = ast.parse((REPO / "python_addon" / "properties.py").read_text())
    tables = [t.id for node in tree.body if isinstance(node, ast.Assign) and isinstance(node.value, ast.List)
              for t in node.targets]
    assert tables == []
    for entry_type, label, description, _icon, number in properties.ENTRY_TYPES:
        kind = entries.kind(entry_type)
        assert (entry_type, label, description, "NONE", number) in kind.module.ENTRY_TYPES
    assert properties.LATTICE_BASES is entries.lattice.LATTICE_BASES
    assert properties.RBF_KERNELS is entries.rbf.RBF_KERNELS


def test_no_module_outside_the_registry_keys_a_dict_by_entry_type(addon):
    from deformkit_addon import entries
    types_ = set(entries.TYPES)
    keyed = []
    for path in (REPO / "python_addon").rglob("*.py"):
        if path.parent == ENTRIES or path.name == "recipe_schema.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Dict) and any(isinstance(k, ast.Constant) and k.value in types_ for k in node.keys):
                keyed.append(f"{path.name}:{node.lineno}")
            if isinstance(node, ast.Call) and any(k.arg in types_ for k in node.keywords):  # dict(..., LATTICE=...)
                keyed.append(f"{path.name}:{node.lineno}")
    assert keyed == []


def test_bind_takes_the_incoming_points_only_when_its_kind_needs_them(scene, monkeypatch):
    """A Cage or RBF bind does not run the stack above the entry; a Laplacian one does."""
    import bpy
    from deformkit_addon import api, evaluation
    obj = make_object(bpy)
    api.add_entry(obj, "TWIST", angle=0.5)
    bpy.ops.mesh.primitive_cube_add(size=4.0, location=obj.location)
    cage = bpy.context.active_object
    api.add_entry(obj, "CAGE", cage=cage)
    api.add_entry(obj, "RBF", controls=cage, polynomial="LINEAR")
    api.add_laplacian(obj, bind=False, anchors_group="", handles_group="")
    computed = []
    real = evaluation.entry_input
    monkeypatch.setattr(evaluation, "entry_input", lambda o, i, *a: computed.append(i) or real(o, i, *a))
    assert api.bind(obj, 1) == 8 and api.bind(obj, 2) == 8
    assert computed == []
    with pytest.raises(ValueError, match="no anchors and no handles"):
        api.bind(obj, 3)  # the Laplacian bind reads what comes in first, then its groups
    assert computed == [3]
    with pytest.raises(ValueError, match="'Twist' is a Twist entry, which has no bind"):
        api.bind(obj, 0)
    with pytest.raises(ValueError, match="'Twist' is a Twist entry, which has no unbind"):
        api.unbind(obj, 0)

"""The type stubs describe the native module as it is: every public name, and the keyword
arguments of each class's constructor as pybind11 reports them."""
import ast
import pathlib
import re

import deformkit._core as core

STUB = pathlib.Path(__file__).resolve().parents[2] / "python/deformkit/_core.pyi"


def stub_tree():
    return ast.parse(STUB.read_text())


def test_every_public_name_has_a_stub():
    body = stub_tree().body
    names = {n.name for n in body if isinstance(n, (ast.ClassDef, ast.FunctionDef))}
    names |= {n.target.id for n in body if isinstance(n, ast.AnnAssign) and n.target.id.isupper()}
    public = {n for n in dir(core) if not n.startswith("_")}
    assert public - names == set(), "missing from _core.pyi"
    assert names - public == set(), "stubbed but not in the module"


def test_constructor_keywords_match():
    for cls in (n for n in stub_tree().body if isinstance(n, ast.ClassDef)):
        init = next((f for f in cls.body if isinstance(f, ast.FunctionDef) and f.name == "__init__"), None)
        if init is None:
            continue
        stubbed = [a.arg for a in init.args.args[1:] + init.args.kwonlyargs]
        doc = getattr(core, cls.name).__init__.__doc__
        runtime = re.findall(r"(\w+): [^,()]+(?:\[[^\]]*\])?", doc.split("->")[0].split("(", 1)[1])
        assert [a for a in runtime if a != "self"] == stubbed, cls.name

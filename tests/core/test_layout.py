"""The C++ layout's rule: folder = concept, and nothing includes upward. core depends on no family,
numerics on core only, every other family on core, numerics and itself; public headers never
include private ones (those live beside the sources, in cpp/src/<family>/)."""
import pathlib
import re

REPO = pathlib.Path(__file__).resolve().parents[2]
FAMILIES = ("core", "numerics", "barr", "lattice", "surface", "subdivision", "cage", "rbf", "transfer")
ALLOWED = {"core": {"core"}, "numerics": {"core", "numerics"}}
INCLUDE = re.compile(r'#include "([^"]+)"')


def family_of(path):
    """The family a file belongs to, or None for the top level (umbrella, build info)."""
    parts = path.relative_to(REPO / "cpp").parts
    if parts[0] == "include" and len(parts) > 3:
        return parts[2]
    if parts[0] == "src" and len(parts) > 2:
        return parts[1]
    return None


def included_family(name):
    parts = name.split("/")
    if parts[0] == "deformkit" and len(parts) > 2:
        return parts[1], True
    if parts[0] in FAMILIES and len(parts) > 1:
        return parts[0], False
    return None, None


def core_files():
    for root in (REPO / "cpp" / "include", REPO / "cpp" / "src"):
        yield from (p for p in root.rglob("*") if p.suffix in (".hpp", ".cpp"))


def test_every_file_is_in_a_family_folder():
    loose = [p for p in core_files() if family_of(p) is None
             and p.name not in ("deformkit.hpp", "build_info.hpp", "build_info.cpp")]
    assert loose == []
    assert {family_of(p) for p in core_files()} - {None} == set(FAMILIES)


def test_nothing_includes_upward():
    wrong = []
    for path in core_files():
        family = family_of(path)
        if family is None:
            continue
        allowed = ALLOWED.get(family, {"core", "numerics", family})
        public = path.is_relative_to(REPO / "cpp" / "include")
        for name in INCLUDE.findall(path.read_text()):
            target, target_public = included_family(name)
            if target is None:
                continue
            if target not in allowed:
                wrong.append(f"{path.relative_to(REPO)} includes {name} ({family} may not use {target})")
            if public and not target_public:
                wrong.append(f"{path.relative_to(REPO)} is public but includes the private {name}")
    assert wrong == []


def test_nothing_includes_the_bindings():
    """The bindings convert and check; the library and its tests never depend on them."""
    library = [p for p in (REPO / "cpp").rglob("*") if p.suffix in (".hpp", ".cpp")
               and not p.is_relative_to(REPO / "cpp" / "bindings")]
    bindings = {p.name for p in (REPO / "cpp" / "bindings").iterdir()}
    wrong = [f"{p.relative_to(REPO)} includes {name}" for p in library for name in INCLUDE.findall(p.read_text())
             if name.startswith("bindings/") or pathlib.PurePath(name).name in bindings]
    assert library and bindings >= {"common.hpp", "module.cpp"}
    assert wrong == []


def test_private_headers_stay_out_of_include():
    """Kernels, threads and solver internals are no part of the interface."""
    public = {p.stem for p in (REPO / "cpp" / "include").rglob("*.hpp")}
    assert public & {"parallel", "scale_free", "cholesky_factor", "barr_kernels", "extent_kernel", "lattice_kernel",
                     "osd_refiner", "dual3", "weight_rows"} == set()


CITATION = re.compile(r'docs/([\w/.-]+\.md)(?:, "([^"]+)")?')


def test_citations_resolve_inside_the_repository():
    """Code cites docs/ pages (and their sections) that exist here, never research notes outside it."""
    sources = [p for p in (REPO / "cpp").rglob("*") if p.suffix in (".hpp", ".cpp")]
    sources += [p for p in (REPO / "tests").rglob("*.py")] + [REPO / "CMakeLists.txt"]
    outside, missing = [], []
    for path in sources:
        text = path.read_text()
        if path != pathlib.Path(__file__).resolve():
            outside += [f"{path.relative_to(REPO)}: {m}" for m in re.findall(r"\w+\.md [AB]\.\d+|blender_modifiers\.md|"
                                                                              r"algorithms\.md", text)]
        for page, section in CITATION.findall(text):
            doc = REPO / "docs" / page
            if not doc.exists() or (section and f"## {section}" not in doc.read_text()):
                missing.append(f"{path.relative_to(REPO)}: docs/{page} {section}")
    assert outside == [] and missing == []

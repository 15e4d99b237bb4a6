import pathlib

import numpy as np
import pytest

REPO = pathlib.Path(__file__).resolve().parents[1]
MESHES = REPO.parent / "shared" / "meshes"


def pytest_collection_modifyitems(items):
    """Under `make test` pytest runs on two workers (pytest-xdist, --dist loadgroup): the packaging
    tests share one session build of the wheel and zips in dist/, so they stay on one worker."""
    for item in items:
        if "packaging" in item.path.parts:
            item.add_marker(pytest.mark.xdist_group("packaging"))


@pytest.fixture
def rng():
    return np.random.default_rng(1234)


@pytest.fixture
def shared_mesh():
    """Load a mesh from ../shared/meshes, skipping with a clear message when the folder is absent."""
    def load(name):
        path = MESHES / name
        if not path.exists():
            pytest.skip(f"{path} not found: the shared test meshes are not beside this checkout")
        import trimesh
        return trimesh.load(path, process=False, force="mesh")
    return load

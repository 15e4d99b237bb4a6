"""Shared test helpers (importable by name, unlike conftest)."""
import numpy as np


def random_frame(rng):
    """A rotation times a non-uniform scale plus a translation, as a 4x4 matrix."""
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    if np.linalg.det(q) < 0:
        q[:, 0] *= -1
    m = np.eye(4)
    m[:3, :3] = q @ np.diag([1.3, 0.7, 1.1])
    m[:3, 3] = rng.uniform(-1, 1, 3)
    return m

"""Sumner's horse and camel of ../shared/transfer, and the measures the transfer tests share: unit
normals, Sumner's per-triangle frames, and the folded-triangle counts."""
import pathlib

import numpy as np
import pytest

TRANSFER = pathlib.Path(__file__).resolve().parents[2].parent / "shared" / "transfer"


def load(name):
    if not TRANSFER.is_dir():
        pytest.skip(f"{TRANSFER} not found: the shared transfer data is not beside this checkout")
    import trimesh
    mesh = trimesh.load(TRANSFER / f"{name}.obj", process=False, force="mesh")
    return np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)


def markers():
    """The 107 horse -> camel marker pairs: an (m, 2) array of (horse vertex, camel vertex)."""
    load("horse_ref")  # skips without the data
    return np.loadtxt(TRANSFER / "horse_camel.cons", delimiter=",", skiprows=1, dtype=np.int64)


def normals(points, faces):
    n = np.cross(points[faces[:, 1]] - points[faces[:, 0]], points[faces[:, 2]] - points[faces[:, 0]])
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def frames(points, faces):
    """Sumner's per-triangle frames: the edges and the normal over the square root of its length."""
    e1, e2 = points[faces[:, 1]] - points[faces[:, 0]], points[faces[:, 2]] - points[faces[:, 0]]
    n = np.cross(e1, e2)
    return np.stack([e1, e2, n / np.sqrt(np.linalg.norm(n, axis=1, keepdims=True))], 2)


def expected_normals(source_rest, source_faces, pose, target_rest, target_faces, pairs):
    """Which way each target triangle should face: its rest normal turned by the rotation (polar
    factor) of its source partners' mean deformation gradient; unpaired ones keep their rest normal."""
    gradient = frames(pose, source_faces) @ np.linalg.inv(frames(source_rest, source_faces))
    total = np.zeros((len(target_faces), 3, 3))
    count = np.zeros(len(target_faces))
    np.add.at(total, pairs[:, 1], gradient[pairs[:, 0]])
    np.add.at(count, pairs[:, 1], 1)
    total[count == 0] = np.eye(3)
    u, _, vt = np.linalg.svd(total / np.maximum(count, 1)[:, None, None])
    return np.einsum("tij,tj->ti", u @ vt, normals(target_rest, target_faces))


def flipped_against(points, faces, expected):
    """Triangles facing against the expected normal (a dot product <= 0)."""
    return int(((normals(points, faces) * expected).sum(1) <= 0).sum())


def local_folds(points, faces):
    """Triangles whose normal opposes the sum of their edge neighbours' normals: creases folded
    back on themselves, measured on the mesh alone."""
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    owner = np.repeat(np.arange(len(faces)), 3)
    order = np.lexsort((edges[:, 1], edges[:, 0]))
    edges, owner = edges[order], owner[order]
    shared = (edges[1:] == edges[:-1]).all(1)
    a, b = owner[:-1][shared], owner[1:][shared]
    n = normals(points, faces)
    around = np.zeros_like(n)
    np.add.at(around, a, n[b])
    np.add.at(around, b, n[a])
    return int(((n * around).sum(1) <= 0).sum())

"""A static Harmonic bind's per-point data kept with the file: the points bound (x y z float32) and
their coordinates, as Mesh Deform keeps its weights: the rows as binding.weights() gives them (row
starts int32, cage vertices int32, weights float32, Blender's float), so that a reopened file binds
from them (dk.MeshDeform.bind(rows=...)) instead of solving the grid again.

They are ID properties of a mesh datablock of their own (the entry's harmonic_rows, its name
starting with a dot, which Blender's pickers hide), not of the object: Blender copies an object's
ID properties into its evaluated copy whenever its mesh changes, which for megabytes of weights
(Ogre at precision 5: 7 MB) would cost every frame of a drag half a millisecond."""
import bpy
import numpy as np

from .common import store_array

ROWS = ("deformkit_cage_row_starts", "deformkit_cage_row_vertices", "deformkit_cage_row_weights")
POINTS = "deformkit_cage_bound"  # where binds before these kept the points: on the entry (cage.BOUND)
NAME = ".deformkit harmonic bind"


def keep(entry, points, rows):
    """The entry's harmonic_rows holding the bound points and their rows (None: none, and a
    datablock only it used goes). One another entry shares (a duplicated object's, with the same
    bind) is left to it."""
    kept = entry.harmonic_rows
    if kept is not None and (points is None or kept.users > 1):
        entry.harmonic_rows = None
        if kept.users == 0:
            bpy.data.meshes.remove(kept)
        kept = None
    if points is None:
        return
    if kept is None:
        kept = bpy.data.meshes.new(NAME)
        entry.harmonic_rows = kept
    for name, values in zip((POINTS,) + ROWS, (points,) + rows):
        store_array(kept, name, values)


def points(entry):
    """The bound points (flat x y z) kept for the entry's bind, or None."""
    kept = entry.harmonic_rows
    return None if kept is None or POINTS not in kept else kept[POINTS]


def read(entry):
    """(indptr, indices, data) kept for the entry's bind, or None (none kept: a file saved before
    they were, or a Dynamic bind)."""
    kept = entry.harmonic_rows
    if kept is None or not all(name in kept for name in ROWS):
        return None
    return tuple(np.array(kept[name]) for name in ROWS)  # copies: the datablock may go away


def gone(entry, bound):
    """What is wrong with a static Harmonic bind whose bound points are gone (`bound` None: their
    datablock deleted by hand, or Dynamic turned off since Bind), or '': binding the points as they
    come instead would deform otherwise than the bind did."""
    if entry.use_dynamic_bind or bound is not None:
        return ""
    return f"the points bound at Bind are gone (their data, '{NAME}', was deleted, or Dynamic changed): Rebind"


def bind(deformer, points, rows):
    """The static bind of points: from its kept rows, else solved. Rows that are no bind of these
    points (a damaged file) are solved again: the same result, only slower."""
    if rows is not None:
        try:
            return deformer.bind(points, rows=rows)
        except ValueError:
            pass
    return deformer.bind(points)

"""Shared references of the tests: numpy transcriptions of the formulas, finite differences,
reference meshes and the Blender oracle scripts."""

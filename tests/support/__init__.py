"""Shared references of the tests: numpy transcriptions of the formulas, finite differences,
reference meshes, the Blender oracle (blender_oracle.py, run inside Blender) and the runner that
starts it (blender_runner.py)."""

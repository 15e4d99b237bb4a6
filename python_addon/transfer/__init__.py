"""Transfer Deformation (issue 17): a source mesh's shape keys, or its animation baked frame by
frame, carried onto a target mesh as shape keys by deformation transfer (dk.DeformationTransfer,
docs/transfer.md). Plain functions, called by the operator (operators/transfer.py), the batch and
the tests alike.

* Same vertex count and faces: direct (vertex i of one is vertex i of the other).
* Otherwise marker pairs (correspondence.py): vertex groups named alike on both meshes with a
  common prefix ("dt_" by default); each group's marker is its member of highest weight (the first
  of equals); markers.py makes them (Add Marker Pair, select, remove, mirror, a first guess). The
  correspondence (Sumner and Popovic 2004, section 5) is computed once and stored
  on the target (ID property STORE, storage.py) with a fingerprint of both rests, faces and the
  markers, so a later run reuses it and an edit of either mesh recomputes it.
* Both rests are brought into one frame first (see docs/blender_addon.md, "Transfer Deformation"):
  the source is placed on the target by the best-fitting similarity (Umeyama 1991, similarity.py),
  since a deformation gradient is carried in the frame it was measured in.
Nothing is written before every pose has been transferred (system.py builds and runs the transfer;
shape_keys.py and bake.py, the two modes, then write through keys.py): a refusal leaves the target
as it was. The target's base mesh (its vertex positions) is never written.
"""
from .bake import FRAME_KEY, transfer_animation
from .correspondence import DEFAULT_PREFIX, MIN_MARKERS, marker_pairs
from .shape_keys import transfer_shape_keys
from .storage import STORE
from .system import Result

__all__ = ["DEFAULT_PREFIX", "FRAME_KEY", "MIN_MARKERS", "Result", "STORE", "marker_pairs", "transfer_animation",
           "transfer_shape_keys"]

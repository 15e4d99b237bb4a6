"""The echo of the add-on's own writes: writing a result into an object's mesh (its offsets) makes
Blender report an update of that mesh at the next depsgraph update, which must not be taken for an
edit of the mesh by the user (which would read the base positions again, for nothing).

In the cache: "echo", (object cache key,) -> the time of the add-on's last write into the object's
own mesh, whose echo is expected.
"""
import time

from . import cache
from .meshdata import cache_key

WINDOW = 1.0  # seconds within which a depsgraph update of the mesh counts as that echo


def expect(uid):
    """The add-on just wrote into the mesh of the object with cache key `uid`."""
    cache.put("echo", (uid,), time.monotonic())


def is_echo(obj, count):
    """True when a depsgraph update of obj's mesh is the echo of the add-on's own write (within
    WINDOW of it, and the mesh still has the `count` vertices the write was for), so the base need
    not be re-read.

    Any Python read of the positions makes Blender copy them out of their shared storage, which on
    a large mesh costs as much as Blender's own Simple Deform, so the echo is judged without one.
    The one case this misses: a script that changes a parameter and then edits base positions
    before any depsgraph update. Such scripts should call api.evaluate(obj); api.evaluated_positions,
    frame changes, undo, redo and file load compare every position anyway."""
    written = cache.pop("echo", (cache_key(obj),))
    if written is None or count is None or time.monotonic() - written > WINDOW:
        return False
    return len(obj.data.vertices) == count


def forget():
    """A frame change evaluates without passing through depsgraph_update_post, so an echo still
    expected then would be mistaken for the next real edit of the mesh."""
    cache.forget(space="echo")

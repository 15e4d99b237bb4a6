"""Bind bookkeeping shared by the kinds that are bound once and then deform (Laplacian, Cage, RBF).

A bind is kept on the entry itself: ID-property arrays (its rest), the fingerprint of the topology
it was made on (bind_vertices, bind_faces, bind_topology) and a bind id, 0 while unbound. What a
kind keeps in memory for a bind (a solver, a cage's tables, a fitted RBF) is keyed by (object,
bind id): a new bind takes a new id, so nothing made for the old one is used again."""
import random

# The entry properties of a bind, which a copy of an entry does not take (a bind belongs to the
# mesh it was made on; Duplicate copies one explicitly where it is valid: copy_bind).
NOT_COPIED = ("bind_id", "bind_vertices", "bind_faces", "bind_topology")


def is_bound(entry):
    return entry.bind_id != 0


def new_bind_id(obj):
    """An id no entry of obj uses: what a bind keeps in memory is keyed by (object, bind id)."""
    used = {e.bind_id for e in obj.deformkit.entries}
    bind_id = 0
    while bind_id == 0 or bind_id in used:
        bind_id = random.randrange(1, 1 << 31)
    return bind_id


def signed(crc):
    """crc32 in an IntProperty, which is signed 32-bit (bind_topology)."""
    return crc - (1 << 32) if crc >= 1 << 31 else crc


def forget(entry, arrays=()):
    """Unbound: drop the bind's ID-property arrays `arrays` and its id."""
    for name in arrays:
        if name in entry:
            del entry[name]
    entry.bind_id = 0

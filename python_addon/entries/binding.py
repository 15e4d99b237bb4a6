"""Bind bookkeeping shared by the kinds that are bound once and then deform (Laplacian, Cage, RBF).

A bind is kept on the entry itself: ID-property arrays (its rest), the fingerprint of the topology
it was made on (bind_vertices, bind_faces, bind_topology) and a bind id, 0 while unbound. What a
kind keeps in memory for a bind (a solver, a cage's tables, a fitted RBF) is keyed by (object,
bind id): a new bind takes a new id, so nothing made for the old one is used again.

A bind that no longer fits what it was made on (the mesh, the cage or the control object has
other vertices now) is the entry's failure, which says what changed and ends ": Rebind"; the
entry is skipped (its input passes through) and the kind's panel offers Rebind beside it
(`outdated`, `draw_rebind`), one click instead of Unbind and Bind."""
import random

from ..errors import EntryError

# The entry properties of a bind, which a copy of an entry does not take (a bind belongs to the
# mesh it was made on; Duplicate copies one explicitly where it is valid: copy_bind).
NOT_COPIED = ("bind_id", "bind_vertices", "bind_faces", "bind_topology", "bind_outdated")


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
    if entry.bind_outdated:
        entry.bind_outdated = ""


def count(n):
    """A count as the panel writes it, its thousands apart: 8 000, 32 000."""
    return f"{n:,}".replace(",", " ")


def counts_changed(what, then, now, units=("vertices", "faces")):
    """What changed since bind, or '': `then` and `now` are counts (vertices, faces) of `what` ("the
    mesh", "the cage 'Cage'"); those that differ are told: "bound to 8 000 vertices, the mesh now
    has 32 000: Rebind"."""
    differ = [i for i, (a, b) in enumerate(zip(then, now)) if a != b]
    if not differ:
        return ""
    at_bind = " and ".join(f"{count(then[i])} {units[i]}" for i in differ)
    current = " and ".join(count(now[i]) for i in differ)
    return f"bound to {at_bind}, {what} now has {current}: Rebind"


def require_current(entry, changed):
    """The bind still fits when `changed` (what changed since bind) is '': else EntryError(changed),
    the entry's failure, remembered on the entry (bind_outdated) for the panel's Rebind."""
    if entry.bind_outdated != changed:
        entry.bind_outdated = changed
    if changed:
        raise EntryError(changed)


def outdated(entry):
    """What changed since bind when that is why the entry fails now, else '' (the panel then
    shows Rebind)."""
    note = entry.bind_outdated
    return note if note and is_bound(entry) and entry.error == note else ""


def draw_rebind(col, entry, bind_operator, index, unbind_operator):
    """A bound entry's Bind row: Unbind, and Rebind (the kind's Bind, one click) first when the bind
    no longer fits (the entry's message above says what changed)."""
    row = col.row(align=True)
    if outdated(entry):
        row.alert = True
        row.operator(bind_operator, text="Rebind", icon="FILE_REFRESH").index = index
    row.operator(unbind_operator, text="Unbind", icon="UNLINKED").index = index

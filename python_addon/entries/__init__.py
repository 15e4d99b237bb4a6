"""The entry kinds and the registry that maps `entry.type` to them, as Blender keeps one type-info
per modifier. Evaluation, the api, the panel, the operators and the handlers ask the registry;
none of them switches on type strings.

Every entry, of any kind, is one DEFORMKIT_PG_entry (properties.py), whose property names are the
saved data paths (`deformkit.entries[i].angle`): keyframes, drivers and files depend on them, so a
kind does not own properties but declares which of them it uses. A kind is a module with:

    TYPES       the entry.type identifiers it implements (properties.ENTRY_TYPES)
    ICON        its icon in the panel and the Add menu
    STACKABLE   its deformers compose with neighbouring ones in one dk.Stack (pointwise maps)
    LAST        it changes the topology: the stack's last entry, run by evaluation after the rest
    MENU        (operator, icon) items below the Add menu's entry types
    FIELDS      every entry property it uses; fields(type): those one type of it uses
    setup(obj, entry, reuse_weights) -> common.Prepared (EntryError for a problem with its settings)
    deform(key, prepared, points) -> points, through what it keeps under `key`
                (object cache key, entry index, "viewport"/"render"); EntryError: the entry's failure
    DEFORMS_INTO  (optional, default False) deform also takes out=, a float32 array to write into
    apply(obj, entry, prepared, base)  bakes the entry into the base mesh
    followed(entry) -> [(object, remembered name)] of the objects it follows (lattice, handles)
    volume_note(entries) -> the panel's note on the volume colors for these entries of the kind, or ""
    retyped(entry)  the entry became another kind: drop what only this kind keeps on it
    prune(object_key, entries)  drop what it keeps for the object beyond these entries of its kind
    draw(col, obj, entry)  its settings in the panel

A kind with LAST is run by evaluation after the rest of the stack, through these members:
    results(object_key, data, viewport, render) -> what `write` takes, or None when it makes nothing,
                from its setup's data and the deformed cage of the viewport and of renders;
                EntryError: the entry's failure (the cage is shown)
    write(obj, data, results) -> the helper objects that now hold the results (the modifier shows them)
    discard(obj, keep)  delete obj's helper objects except those in `keep` (discard_helpers)
    forget(object_key)  drop what it keeps to make its results again (forget_refined)
"""
from ..properties import ENTRY_TYPES
from . import barr, cage, laplacian, lattice, rbf, subdivide

KINDS = (barr, lattice, laplacian, cage, rbf, subdivide)
COMMON = ("name", "show_viewport", "show_render")  # every entry's parameters
_BY_TYPE = {t: kind for kind in KINDS for t in kind.TYPES}
if set(_BY_TYPE) != {t[0] for t in ENTRY_TYPES} or len(_BY_TYPE) != len(ENTRY_TYPES):
    raise ImportError(f"deformkit entry kinds implement {sorted(_BY_TYPE)}, but the entry types are "
                      f"{sorted(t[0] for t in ENTRY_TYPES)}: each type needs exactly one kind")

TYPES = tuple(t[0] for t in ENTRY_TYPES)
LABELS = {t[0]: t[1] for t in ENTRY_TYPES}
# Every parameter the api sets, in the order of the kinds.
PARAMS = tuple(dict.fromkeys(COMMON + tuple(f for kind in KINDS for f in kind.FIELDS)))


def kind(entry):
    """The kind of an entry (or of an entry type)."""
    return _BY_TYPE[entry if isinstance(entry, str) else entry.type]


def params(entry_type):
    """The parameters an entry of this type takes."""
    return COMMON + kind(entry_type).fields(entry_type)


def check_params(entry_type, names):
    """ValueError naming the first of `names` that is no entry parameter, or that an entry of this
    type does not use (with what it takes)."""
    accepted = params(entry_type)
    for name in names:
        if name not in PARAMS:
            raise ValueError(f"{name}: not a deformkit entry parameter (expected one of {', '.join(PARAMS)})")
        if name not in accepted:
            label = LABELS[entry_type]
            raise ValueError(f"{name}: not a parameter of a {label} entry (a {label} entry takes "
                             f"{', '.join(accepted)})")


def last_index(entries):
    """The index of the first entry that must be last (Subdivide), else len(entries)."""
    return next((i for i, e in enumerate(entries) if kind(e).LAST), len(entries))


def followed(entry):
    return kind(entry).followed(entry)


def prune(object_key, stack_entries):
    """Every kind drops what it keeps for the object that none of its entries in the stack uses."""
    for other in KINDS:
        other.prune(object_key, [e for e in stack_entries if e.type in other.TYPES])


def type_changed(entry):
    """Each kind the entry is not (any more) drops what it kept on it."""
    for other in KINDS:
        if entry.type not in other.TYPES:
            other.retyped(entry)


def volume_notes(entries):
    """The panel's notes on the volume colors, one per kind that has one for its entries here."""
    notes = [k.volume_note([e for e in entries if e.type in k.TYPES]) for k in KINDS]
    return [note for note in notes if note]


def discard_helpers(obj, keep=()):
    """The kinds that change the topology delete obj's helper objects, except those in `keep`."""
    for other in KINDS:
        if other.LAST:
            other.discard(obj, keep)


def forget_refined(object_key):
    """The kinds that change the topology drop what they keep for the object to make their results
    again (no entry of theirs runs on it any more)."""
    for other in KINDS:
        if other.LAST:
            other.forget(object_key)

"""The entry kinds and the registry that maps `entry.type` to them, as Blender keeps one type-info
per modifier. Evaluation, the api, the panel, the operators and the handlers ask the registry;
none of them switches on type strings.

Every entry, of any kind, is one DEFORMKIT_PG_entry (properties.py), whose property names are the
saved data paths (`deformkit.entries[i].angle`): keyframes, drivers and files depend on them, so a
kind does not own properties but declares which of them it uses. A kind is a module (listed in
MODULES below) with these members; each table is a literal, which properties.py, this registry
and recipe_schema.py (from the module's source, without bpy) all read.

Required:
    ENTRY_TYPES  its rows of the Type enum: (identifier, label, description, icon, number); the
                 number is what saved files store
    TYPES        their identifiers: the entry.type values it implements
    ICON         its icon in the panel and the Add menu
    FIELDS       every entry property it uses, or TYPE_FIELDS {type: properties} when its types use
                 different ones (FIELDS is then their union)
    setup(obj, entry, reuse_weights) -> common.Prepared (EntryError for a problem with its settings)
    deform(key, prepared, points) -> points, through what it keeps under `key`
                 (object cache key, entry index, "viewport"/"render"); EntryError: the entry's failure
    draw(col, obj, entry)  its settings in the panel
and, as literals, the enum tables of its properties (e.g. lattice.LATTICE_BASES).

Optional, with the default the registry gives a kind that leaves them out (as Blender's modifier
type-info leaves a callback nullptr):
    TYPE_LABEL    "Type": the label of the Type row in its entries' panels
    STACKABLE     False: its deformers compose with neighbouring ones in one dk.Stack (pointwise maps)
    LAST          False: it changes the topology: the stack's last entry, run by evaluation after the rest
    DEFORMS_INTO  False: deform also takes out=, a float32 array to write into
    displace(key, prepared, points, out) -> out holding w (F(x) - x) of the points, in one pass (the
                  offsets the modifier adds, when the entry deforms the base itself); None: deform
                  then subtract
    refresh(obj, entry, prepared) -> common.Prepared: setup again where only what the entry follows
                  changed (evaluation's Reason.MOVED: a frame of a cage or lattice drag), given its
                  last setup, whose settings, bind and weights stand; None: setup runs whole
    MENU          (): (operator, icon) items below the Add menu's entry types
    NEW_ENTRY     {}: settings a new entry of the kind starts with (api.add_entry: the Add menu, the
                  scripting API, recipes; or a Type change, for the settings the entry never had
                  set) where they differ from the properties' defaults, which saved entries keep
                  (a file stores only the properties that were set)
    apply(obj, entry, prepared, base)  bakes the entry into the base mesh: writes
                  prepared.deformer.deform(base) into it
    followed(entry) -> [(object, remembered name)] of the objects it follows (lattice, handles): []
    volume_note(entries) -> the panel's note on the volume colors for these entries of the kind: ""
    retyped(entry)  the entry became another kind, drop what only this kind keeps on it: nothing
    prune(object_key, entries)  drop what it keeps for the object beyond these entries of its kind:
                  nothing
    loaded()      a file was loaded: drop what it keeps by name across files (file_loaded): nothing
    KEPT_THROUGH_UNDO  (): the cache spaces whose values are keyed by the bind they were made from
                  (its bind_id, which no later edit gives another bind), so that undo and redo,
                  which may bring back an older bind but never change what a bind_id stands for,
                  keep them (kept_through_undo): a Harmonic bind's grid is not solved again
    owns(obj) -> whether obj is one of the helper objects it writes (is_helper): False
The bind protocol, for kinds that record something at Bind (Laplacian, Cage, RBF; Lattice binds
again), all optional:
    bind(obj, entry, incoming) -> what Bind reports (a count, lattice.Bound); None: no Bind.
                  incoming() returns the points coming into the entry (the base mesh through the
                  entries above), computed only when called. ValueError if it cannot bind, with the
                  entry left as it was
    unbind(obj, entry)  forget the bind (the entry then passes its input through); None: no Unbind.
                  A kind with an Unbind deforms nothing until bound: a batch recipe may bind it
                  as it is added ("bind": true)
    is_bound(entry) -> False
    NOT_COPIED    (): entry properties a copy of any entry does not take (a bind belongs to its mesh)
    copy_bind(source, copy)  give a Duplicate (same object) source's bind: nothing (it arrives unbound)
A kind with LAST is run by evaluation after the rest of the stack, through these members:
    results(object_key, data, viewport, render) -> what `write` takes, or None when it makes nothing,
                from its setup's data and the deformed cage of the viewport and of renders;
                EntryError: the entry's failure (the cage is shown)
    write(obj, data, results) -> the helper objects that now hold the results (the modifier shows them)
    discard(obj, keep)  delete obj's helper objects except those in `keep` (discard_helpers)
    forget(object_key)  drop what it keeps to make its results again (forget_refined)
The registry adds fields(type): the properties an entry of that type uses.

Adding a kind costs its module (with these members), its line in MODULES (and its import), its
properties in properties.py (annotations whose items are its enum tables) and, only for a recipe
key that is no entry property, an entry in recipe_schema.py (whose "bind" already goes to every
kind with an Unbind).
"""
from . import barr, cage, common, laplacian, lattice, rbf, subdivide

MODULES = (barr, lattice, laplacian, cage, rbf, subdivide)  # the Type enum lists their types in this order
COMMON = ("name", "show_viewport", "show_render")  # every entry's parameters
REQUIRED = ("ENTRY_TYPES", "TYPES", "ICON", "setup", "deform", "draw")


def _write_deformed(obj, entry, prepared, base):
    """Apply: the entry's deformer takes the base mesh, which becomes its result."""
    common.write_base(obj, prepared.deformer.deform(base))


def _follows_nothing(entry):
    return []


def _no_note(entries):
    return ""


def _nothing(*args):
    """Nothing to do: the kind keeps nothing there."""


def _never_bound(entry_or_object):
    return False


DEFAULTS = {"TYPE_LABEL": "Type", "STACKABLE": False, "LAST": False, "DEFORMS_INTO": False, "MENU": (), "NEW_ENTRY": {},
            "apply": _write_deformed, "followed": _follows_nothing, "volume_note": _no_note, "retyped": _nothing,
            "prune": _nothing, "bind": None, "unbind": None, "is_bound": _never_bound, "NOT_COPIED": (),
            "copy_bind": _nothing, "loaded": _nothing, "owns": _never_bound, "displace": None,
            "refresh": None, "KEPT_THROUGH_UNDO": ()}


class Kind:
    """A kind as the registry hands it out: its module's members, looked up there each time, and
    the protocol's default for each optional member the module leaves out."""

    def __init__(self, module):
        self.module = module
        missing = [name for name in REQUIRED if not hasattr(module, name)]
        if not hasattr(module, "FIELDS") and not hasattr(module, "TYPE_FIELDS"):
            missing.append("FIELDS")
        if missing:
            raise ImportError(f"the deformkit entry kind {module.__name__} lacks {', '.join(missing)}")
        self.__name__ = module.__name__
        by_type = getattr(module, "TYPE_FIELDS", None)
        union = () if by_type is None else tuple(dict.fromkeys(f for t in module.TYPES for f in by_type[t]))
        self._defaults = dict(DEFAULTS, FIELDS=union)

    def __getattr__(self, name):
        if name.startswith("_"):  # not the module's: this one's own, not set yet (copy, pickle)
            raise AttributeError(name)
        try:
            return getattr(self.module, name)
        except AttributeError:
            if name in self._defaults:
                return self._defaults[name]
            raise

    def __repr__(self):
        return f"<deformkit entry kind {self.__name__}>"

    def fields(self, entry_type):
        """The entry properties an entry of this type uses (the panel shows exactly these)."""
        return getattr(self.module, "TYPE_FIELDS", {}).get(entry_type, self.FIELDS)


KINDS = tuple(Kind(module) for module in MODULES)
ENTRY_TYPES = [row for k in KINDS for row in k.ENTRY_TYPES]  # properties.DEFORMKIT_PG_entry.type's items
_BY_TYPE = {t: k for k in KINDS for t in k.TYPES}
if len(_BY_TYPE) != len(ENTRY_TYPES) or len({row[4] for row in ENTRY_TYPES}) != len(ENTRY_TYPES):
    raise ImportError("deformkit entry kinds: each entry type needs exactly one kind, and its own number "
                      f"(got {[(row[0], row[4]) for row in ENTRY_TYPES]})")

TYPES = tuple(row[0] for row in ENTRY_TYPES)
LABELS = {row[0]: row[1] for row in ENTRY_TYPES}
# Every parameter the api sets, in the order of the kinds.
PARAMS = tuple(dict.fromkeys(COMMON + tuple(f for k in KINDS for f in k.FIELDS)))
# What a copy of an entry does not take from it: its type and name (set first), its message, and
# what any kind keeps of a bind or of its helper objects (copy_bind copies a bind where it is valid).
NOT_COPIED = frozenset(("rna_type", "type", "name", "error") + tuple(p for k in KINDS for p in k.NOT_COPIED))


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
    """Each kind the entry is not (any more) drops what it kept on it; its new kind gives it a new
    entry's settings (NEW_ENTRY) where it has none of its own (a file stores only what was set)."""
    for other in KINDS:
        if entry.type not in other.TYPES:
            other.retyped(entry)
    for name, value in kind(entry).NEW_ENTRY.items():
        if not entry.is_property_set(name):
            setattr(entry, name, value)


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


def file_loaded():
    """Every kind drops what it keeps by name, which another file's objects may reuse."""
    for other in KINDS:
        other.loaded()


def kept_through_undo():
    """The cache spaces undo and redo keep (each kind's KEPT_THROUGH_UNDO)."""
    return frozenset(space for other in KINDS for space in other.KEPT_THROUGH_UNDO)


def is_helper(obj):
    """Whether obj is a helper object some kind writes (a Subdivide entry's result), not the user's."""
    return any(other.owns(obj) for other in KINDS)

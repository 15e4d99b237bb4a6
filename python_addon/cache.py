"""What the add-on keeps in memory between evaluations, in one keyed store.

Each use has its own space (a name) and keys whose first element is the cache key of the object
the value belongs to (meshdata.cache_key), so one `forget` drops an object's values of every space
(api.evaluate, file load; undo and redo keep the spaces the kinds key by bind, forget_but) and
nothing needs wiring by hand. Values are rebuilt from the file when missing: nothing here is ever
the only copy of the user's data.

Spaces: "inputs" (evaluation: the last settings and base), "echo" (echo.py: the last write's time),
"follow" and "checked" (follow.py: what a drag's steps reuse; when each object's modifier was last
checked), "weights" (vertex-group weights read from the mesh), "lattice" (bindings, and each entry's lattice,
moved to the new control points while nothing else changes), "barr" (each Barr entry's deformer,
while its settings and weights stay), "laplacian" (factorised solvers), "subdivide" (refined
topologies) and "subdivide_written" (what each helper mesh holds).
"""
_store = {}  # (space, key) -> value, key[0]: the owning object's cache key


def get(space, key, default=None):
    return _store.get((space, key), default)


def put(space, key, value):
    _store[(space, key)] = value
    return value


def pop(space, key):
    return _store.pop((space, key), None)


def items(space):
    """{key: value} of one space (a copy: forgetting while iterating over it is fine)."""
    return {key: value for (s, key), value in _store.items() if s == space}


def forget(object_key=None, space=None, keep=None):
    """Drop the values of one object (None: of every object), in one space (None: in all),
    except those whose key `keep(key)` is true for."""
    for s, key in [k for k in _store if (space is None or k[0] == space)
                   and (object_key is None or k[1][0] == object_key)]:
        if keep is None or not keep(key):
            del _store[(s, key)]


def forget_but(spaces, object_keys):
    """Drop every value but those of `spaces` that belong to an object of `object_keys`."""
    for s, key in [k for k in _store if not (k[0] in spaces and k[1][0] in object_keys)]:
        del _store[(s, key)]

"""Undo and redo keep what the entries made of a bind (a cage's deformer and bindings, a Harmonic
grid solve among them: seconds at high precision; an RBF fit; a Laplacian entry's factorised
solver), since a bind_id always stands for the same bind; the result after undo and redo is still
what a fresh evaluation gives. A file load still trusts nothing it kept."""
import numpy as np
import pytest

from addon_helpers import evaluated, make_object, positions, update
from test_laplacian_addon import bound_tube, turn_and_shift
from test_mesh_deform_addon import cage_around, shake
from test_rbf_addon import bound as bound_rbf, move_vertices


@pytest.fixture
def counted_binds(bpy_module):
    """Counts the expensive steps of every kind's bind while in use: the dk cage classes' binds
    (their grid solves and coordinates), RBF fits and binds, Laplacian factorisations."""
    from deformkit_addon import native
    calls, patched = [], []
    for name in ("MeshDeform", "MeanValueCage", "GreenCage", "RBF"):
        cls = getattr(native.dk, name)
        original = cls.bind

        def bind(self, *args, _original=original, _name=name, **kwargs):
            calls.append(_name + (".bind(rows)" if kwargs.get("rows") is not None else ".bind"))
            return _original(self, *args, **kwargs)
        patched.append((cls, "bind", original if "bind" in vars(cls) else None))  # None: inherited
        cls.bind = bind
    for name in ("RBF", "SurfaceDeformer"):
        original = getattr(native.dk, name)

        def make(*args, _original=original, _name=name, **kwargs):
            calls.append(_name)
            return _original(*args, **kwargs)
        patched.append((native.dk, name, original))
        setattr(native.dk, name, make)
    yield calls
    for owner, name, original in reversed(patched):
        if original is None:
            delattr(owner, name)
        else:
            setattr(owner, name, original)


def fresh(obj):
    """What a full evaluation with nothing kept shows."""
    from deformkit_addon import api, evaluation
    evaluation.forget()
    api.evaluate(obj)
    return evaluated(obj).copy()


def rig(bpy, kind):
    """An object named "Ours" with a bound entry of `kind`, and a function moving what it follows
    (seed: how)."""
    from deformkit_addon import api
    if kind == "LAPLACIAN":
        obj, _, empty = bound_tube(bpy)
        obj.name = "Ours"

        def move(seed):
            empty.location.x += 0.1 * seed
            turn_and_shift(empty) if seed == 3 else update()
        return obj, move
    if kind == "RBF":
        obj, controls, _ = bound_rbf(bpy)
        obj.name = "Ours"
        return obj, lambda seed: move_vertices(controls, seed=seed)
    obj = make_object(bpy, name="Ours")
    cage = cage_around(bpy, obj)
    api.add_entry(obj, "CAGE", cage=cage, cage_method=kind, precision=4)
    api.bind_cage(obj, 0)
    return obj, lambda seed: shake(cage, seed=seed)


@pytest.mark.parametrize("kind", ["HARMONIC", "MEAN_VALUE", "GREEN", "RBF", "LAPLACIAN"])
def test_undo_and_redo_do_not_bind_again(scene, counted_binds, kind):
    import bpy
    obj, move = rig(bpy, kind)
    update()
    bpy.ops.ed.undo_push(message="bound")
    move(3)
    update()
    bpy.ops.ed.undo_push(message="moved")
    shaken = evaluated(obj).copy()
    move(4)
    update()
    bpy.ops.ed.undo_push(message="moved again")
    binds = len(counted_binds)
    assert binds >= 1
    bpy.ops.ed.undo()
    obj = bpy.data.objects["Ours"]  # undo rebuilds the data: look the objects up again
    undone = evaluated(obj).copy()
    np.testing.assert_array_equal(undone, shaken)
    bpy.ops.ed.redo()
    obj = bpy.data.objects["Ours"]
    redone = evaluated(obj).copy()
    assert len(counted_binds) == binds, f"undo and redo bound again: {counted_binds[binds:]}"
    np.testing.assert_array_equal(redone, fresh(obj))
    assert len(counted_binds) > binds  # the fresh evaluation (nothing kept) binds: the counter counts
    assert not np.array_equal(redone, shaken)


def test_an_undone_rebind_shows_the_bind_before_it(scene, counted_binds):
    """Undo past a Rebind brings back the earlier bind, whose rest and bound points differ: the
    result is that bind's, as a fresh evaluation makes it, not the later bind's kept one."""
    import bpy
    from deformkit_addon import api
    obj, move = rig(bpy, "HARMONIC")
    move(5)
    update()
    bpy.ops.ed.undo_push(message="first bind, shaken")
    first = evaluated(obj).copy()
    api.bind_cage(obj, 0)  # the shaken cage is the rest now: nothing moves
    update()
    bpy.ops.ed.undo_push(message="bound again")
    np.testing.assert_array_equal(evaluated(obj), positions(obj.data))  # the cage at its new rest
    assert not np.array_equal(evaluated(obj), first)
    bpy.ops.ed.undo()
    obj = bpy.data.objects["Ours"]
    np.testing.assert_array_equal(evaluated(obj), first)
    np.testing.assert_array_equal(evaluated(obj), fresh(obj))


@pytest.mark.parametrize("saved", ["rows", "no rows", "damaged rows"])
def test_a_reopened_file_binds_from_its_saved_rows(scene, counted_binds, tmp_path, saved):
    """A static Harmonic bind keeps its coordinates in the file (as Mesh Deform keeps its weights):
    reopened, the entry binds from them without solving the grid, and shows what it showed. A file
    without them (saved before they were kept) or with rows that are no bind of its points solves
    again, to the same result."""
    import bpy
    from deformkit_addon import api
    from deformkit_addon.entries import cage as kind, saved_rows
    obj, move = rig(bpy, "HARMONIC")
    move(6)
    update()
    shown = evaluated(obj).copy()
    entry = obj.deformkit.entries[0]
    kept = entry.harmonic_rows
    assert kept.name.startswith(".") and all(name in kept for name in saved_rows.ROWS)
    assert not any(name in entry for name in saved_rows.ROWS)  # not on the object: see saved_rows
    if saved == "no rows":  # a bind made before: the points on the entry, no rows
        entry[kind.BOUND] = kept[saved_rows.POINTS]
        entry.harmonic_rows = None
    elif saved == "damaged rows":
        weights = np.array(kept[saved_rows.ROWS[2]])
        weights[0] = 2.0  # not a coordinate: the rows are refused
        saved_rows.store_array(kept, saved_rows.ROWS[2], weights)
    path = str(tmp_path / "bound.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    counted_binds.clear()
    bpy.ops.wm.open_mainfile(filepath=path)
    update()
    expected = ["MeshDeform.bind(rows)"] if saved == "rows" else \
        ["MeshDeform.bind"] if saved == "no rows" else ["MeshDeform.bind(rows)", "MeshDeform.bind"]
    assert counted_binds == expected
    np.testing.assert_array_equal(evaluated(bpy.data.objects["Ours"]), shown)
    rows = bpy.data.objects["Ours"].deformkit.entries[0].harmonic_rows
    api.unbind(bpy.data.objects["Ours"], 0)
    entry = bpy.data.objects["Ours"].deformkit.entries[0]
    assert not any(name in entry for name in kind.SAVED) and entry.harmonic_rows is None
    assert rows is None or saved_rows.NAME not in [m.name for m in bpy.data.meshes if m.users]  # gone with the bind


def test_a_static_bind_whose_points_are_gone_asks_for_rebind(scene):
    """The bind's datablock deleted by hand: the entry says so and offers Rebind (the mesh passes
    through, as with any bind that no longer fits), instead of binding the points as they come;
    Rebind makes it whole again."""
    import bpy
    from deformkit_addon import api, evaluation
    obj, move = rig(bpy, "HARMONIC")
    move(7)
    update()
    bpy.data.meshes.remove(obj.deformkit.entries[0].harmonic_rows)
    evaluation.forget()
    with pytest.raises(ValueError, match="the points bound at Bind are gone"):  # the api says what the entry says
        api.evaluate(obj)
    entry = obj.deformkit.entries[0]
    assert entry.error.startswith("the points bound at Bind are gone") and entry.error.endswith(": Rebind")
    assert entry.bind_outdated
    np.testing.assert_array_equal(evaluated(obj), positions(obj.data))
    api.bind_cage(obj, 0)
    update()
    assert entry.error == "" and entry.harmonic_rows is not None

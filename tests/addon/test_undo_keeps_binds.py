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
            calls.append(_name + ".bind")
            return _original(self, *args, **kwargs)
        cls.bind = bind
        patched.append((cls, "bind", original))
    for name in ("RBF", "SurfaceDeformer"):
        original = getattr(native.dk, name)

        def make(*args, _original=original, _name=name, **kwargs):
            calls.append(_name)
            return _original(*args, **kwargs)
        setattr(native.dk, name, make)
        patched.append((native.dk, name, original))
    yield calls
    for owner, name, original in reversed(patched):
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
    obj = make_object(bpy, name="Ours")
    cage = cage_around(bpy, obj)
    api.add_entry(obj, "CAGE", cage=cage, cage_method="HARMONIC", precision=4)
    api.bind_cage(obj, 0)
    shake(cage, seed=5)
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


def test_a_file_load_binds_again(scene, counted_binds, tmp_path):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy, name="Ours")
    cage = cage_around(bpy, obj)
    api.add_entry(obj, "CAGE", cage=cage, cage_method="HARMONIC", precision=4)
    api.bind_cage(obj, 0)
    shake(cage, seed=6)
    update()
    shown = evaluated(obj).copy()
    path = str(tmp_path / "bound.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    binds = len(counted_binds)
    bpy.ops.wm.open_mainfile(filepath=path)
    update()
    assert len(counted_binds) > binds  # nothing kept is trusted across files
    np.testing.assert_array_equal(evaluated(bpy.data.objects["Ours"]), shown)

"""The handlers' list of the objects that have entries (handlers._listed): kept between depsgraph
updates, so an update in a large scene does not read every object, and listed again whenever an
object may have come, gone or got entries, so no stack stops following what it follows."""
import numpy as np

from addon_helpers import evaluated, make_lattice, make_object, perturb_lattice, update


def lattice_rig(bpy, name="Obj"):
    from deformkit_addon import api
    obj = make_object(bpy, name)
    lattice = make_lattice(bpy, name + " lattice")
    api.add_entry(obj, "LATTICE", lattice=lattice)
    update()
    return obj, lattice


def follows(obj, lattice, seed):
    """Whether obj's evaluated points change when its lattice's points move."""
    before = evaluated(obj).copy()
    perturb_lattice(lattice, amount=0.05, seed=seed)
    update()
    return not np.array_equal(evaluated(obj), before)


def test_the_list_is_kept_across_updates_that_add_no_object(scene):
    import bpy
    from deformkit_addon import handlers
    obj, lattice = lattice_rig(bpy)
    for i in range(30):  # a scene with other objects, one of which moves
        bpy.context.scene.collection.objects.link(bpy.data.objects.new(f"Empty {i}", None))
    update()
    listed = handlers._listed[bpy.context.scene.name_full]
    bpy.data.objects["Empty 3"].location.x += 1.0
    update()
    assert handlers._listed[bpy.context.scene.name_full] is listed
    assert follows(obj, lattice, 1)
    assert handlers._listed[bpy.context.scene.name_full] is listed


def test_an_object_that_gets_entries_later_is_followed(scene):
    import bpy
    from deformkit_addon import handlers
    first, first_lattice = lattice_rig(bpy, "First")
    other = make_object(bpy, "Other")
    lattice = make_lattice(bpy, "Other lattice")
    update()
    assert other.name not in [k[0] for k in handlers._listed[bpy.context.scene.name_full]]
    entry = other.deformkit.entries.add()  # by hand, not through the api: its settings' updates tell
    entry.type = "LATTICE"
    entry.lattice = lattice
    update()
    assert follows(other, lattice, 2) and follows(first, first_lattice, 3)


def test_a_renamed_object_is_still_followed(scene):
    import bpy
    obj, lattice = lattice_rig(bpy)
    obj.name = "Renamed"
    update()
    assert follows(obj, lattice, 4)


def test_a_duplicate_is_followed_and_a_deleted_object_is_dropped(scene):
    import bpy
    from deformkit_addon import handlers
    obj, lattice = lattice_rig(bpy)
    copy = obj.copy()
    copy.data = obj.data.copy()
    bpy.context.scene.collection.objects.link(copy)
    update()
    assert follows(copy, lattice, 5) and follows(obj, lattice, 6)
    bpy.data.objects.remove(obj)
    update()
    assert [o.name for o in handlers._stack_objects(bpy.context.scene)] == [copy.name]
    assert follows(copy, lattice, 7)

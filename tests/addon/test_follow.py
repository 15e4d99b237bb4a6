"""A drag's frames (follow.py, issue 32): while only a Cage entry's cage changes, the frames take the
short path (the cage read again through the kind's refresh), and each shows exactly what a full
evaluation of the same inputs shows; a change of anything else goes through the full evaluation."""
import numpy as np
import pytest

from addon_helpers import evaluated, make_object, update
from test_mesh_deform_addon import MIN_PRECISION, cage_around, has_mesh_deform, shake

METHODS = ["MEAN_VALUE", "GREEN", "HARMONIC"]


@pytest.fixture
def frames(monkeypatch):
    """Counts of follow.step's outcomes: "short" (it deformed, or found nothing new), "full"
    (it gave the step to the full evaluation)."""
    from deformkit_addon import follow
    seen = {"short": 0, "full": 0}
    original = follow.step

    def counted(*args):
        done = original(*args)
        seen["full" if done is None else "short"] += 1
        return done

    monkeypatch.setattr(follow, "step", counted)
    return seen


def nudge(obj, every, by):
    """An edit of the base mesh: every `every`-th coordinate moved by `by`."""
    co = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.vertices.foreach_get("co", co)
    co[::every] += np.float32(by)
    obj.data.vertices.foreach_set("co", co)
    obj.data.update()


def rigged(bpy, method, strength=0.7):
    """A sphere in a turned, moved cage, bound with `method`, its upper group at `strength`."""
    from deformkit_addon import api
    if method == "HARMONIC" and not has_mesh_deform():
        pytest.skip("this build has no MeshDeform")
    obj = make_object(bpy)
    cage = cage_around(bpy, obj)
    cage.rotation_euler = (0.2, -0.1, 0.3)
    cage.location = (0.1, 0.05, -0.1)
    update()
    settings = {"precision": MIN_PRECISION} if method == "HARMONIC" else {}
    api.add_entry(obj, "CAGE", cage=cage, cage_method=method, vertex_group="Upper", strength=strength, **settings)
    api.bind_cage(obj, 0)
    update()
    return obj, cage


def fresh(obj):
    """What a full evaluation of the same inputs shows (nothing kept from before)."""
    from deformkit_addon import api
    api.evaluate(obj)
    update()
    return evaluated(obj)


@pytest.mark.parametrize("method", METHODS)
def test_a_drag_of_the_cage_shows_what_a_full_evaluation_shows(scene, frames, method):
    import bpy
    obj, cage = rigged(bpy, method)
    rest = evaluated(obj).copy()
    frames.update(short=0, full=0)  # the set-up's own steps (add_entry's settings) are not the drag's
    for step in range(4):
        shake(cage, amount=0.05, seed=step)
        if step == 2:
            cage.location.x += 0.05  # the cage object itself moves: its place is read again too
            update()
        shown = evaluated(obj).copy()
        assert not np.array_equal(shown, rest)
        np.testing.assert_array_equal(shown, fresh(obj))
    assert frames["short"] >= 4 and frames["full"] == 0, frames


@pytest.mark.parametrize("method", ["MEAN_VALUE", "HARMONIC"])
def test_a_setting_changed_between_frames_is_read_again(scene, frames, method):
    """The strength changes (a property update: a full evaluation), then the drag goes on: the
    frames use the new strength."""
    import bpy
    obj, cage = rigged(bpy, method)
    shake(cage, amount=0.05, seed=1)
    obj.deformkit.entries[0].strength = 0.3
    shake(cage, amount=0.05, seed=2)
    np.testing.assert_array_equal(evaluated(obj), fresh(obj))
    twin, twin_cage = rigged(bpy, method, strength=0.3)  # the same rig made with 0.3 from the start
    twin_cage.data.vertices.foreach_set("co", np.array([v.co for v in cage.data.vertices], np.float32).ravel())
    twin_cage.data.update()
    update()
    np.testing.assert_allclose(evaluated(obj), evaluated(twin), atol=1e-6)


def test_a_broken_node_group_is_repaired_on_the_next_frame(scene, frames):
    import bpy
    from deformkit_addon import outputs
    obj, cage = rigged(bpy, "MEAN_VALUE")
    shake(cage, amount=0.05, seed=1)
    group = obj.modifiers[outputs.MODIFIER_NAME].node_group
    group.links.remove(group.links[0])  # a stray click in the node editor
    update()
    shake(cage, amount=0.05, seed=2)
    assert outputs.is_whole(obj.modifiers[outputs.MODIFIER_NAME].node_group)
    np.testing.assert_array_equal(evaluated(obj), fresh(obj))


def test_a_mesh_shared_since_goes_to_each_object(scene, frames):
    """A linked duplicate made between frames: the next frame writes no offsets into the shared mesh,
    which would show them on the duplicate (a full evaluation puts them per object)."""
    import bpy
    from deformkit_addon import outputs
    obj, cage = rigged(bpy, "MEAN_VALUE")
    other = bpy.data.objects.new("Other", bpy.data.meshes.new("Other"))
    bpy.context.scene.collection.objects.link(other)
    update()
    shake(cage, amount=0.05, seed=1)
    other.data = obj.data  # Link Object Data (Ctrl+L): obj's mesh is shared, obj itself not touched
    update()
    shake(cage, amount=0.05, seed=2)
    assert outputs.modifier_kind(obj).startswith("per_object")
    np.testing.assert_array_equal(evaluated(obj), fresh(obj))


def test_a_cage_whose_topology_changed_asks_for_rebind(scene, frames):
    import bpy
    import bmesh
    obj, cage = rigged(bpy, "MEAN_VALUE")
    shake(cage, amount=0.05, seed=1)
    mesh = bmesh.new()
    mesh.from_mesh(cage.data)
    bmesh.ops.triangulate(mesh, faces=mesh.faces[:1])
    mesh.to_mesh(cage.data)
    mesh.free()
    cage.data.update()
    update()
    assert "Rebind" in obj.deformkit.entries[0].error
    assert frames["full"] >= 1


def test_a_drag_of_a_lattice_shows_what_a_full_evaluation_shows(scene, frames):
    import bpy
    from addon_helpers import make_lattice, perturb_lattice
    from deformkit_addon import api
    obj = make_object(bpy)
    lattice = make_lattice(bpy)
    api.add_entry(obj, "LATTICE", lattice=lattice, vertex_group="Upper", strength=0.8)
    update()
    rest = evaluated(obj).copy()
    perturb_lattice(lattice, amount=0.05, seed=9)  # the first frame after the modifier's group was made is full
    update()
    frames.update(short=0, full=0)
    for step in range(3):
        perturb_lattice(lattice, amount=0.05, seed=step)
        update()
        shown = evaluated(obj).copy()
        assert not np.array_equal(shown, rest)
        np.testing.assert_array_equal(shown, fresh(obj))
    assert frames["short"] >= 3 and frames["full"] == 0, frames


def test_an_edited_setting_steps_as_a_full_evaluation(scene, frames):
    """A Twist angle dragged in the panel (Reason.EDIT): each step short, each as a full evaluation;
    the entry hidden and shown again in between goes through the full evaluation."""
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    entry = api.add_entry(obj, "TWIST", angle=0.2, deform_axis="Z", vertex_group="Upper")
    update()
    entry.angle = 0.25  # the first step after the modifier's group was made is full
    update()
    frames.update(short=0, full=0)
    for angle in (0.3, 0.5, 0.9):
        entry.angle = angle
        update()
        np.testing.assert_array_equal(evaluated(obj), fresh(obj))
    assert frames["short"] >= 3 and frames["full"] == 0, frames
    base = evaluated(obj).copy()
    entry.show_viewport = False
    update()
    assert frames["full"] >= 1
    assert not np.array_equal(evaluated(obj), base)
    entry.show_viewport = True
    entry.angle = 1.1
    update()
    np.testing.assert_array_equal(evaluated(obj), fresh(obj))


def test_each_object_checks_its_modifier_after_a_stray_edit(scene, frames):
    """Two rigs; one's modifier loses its group (a stray click): the other's drag does not stand in
    for it, its own next drag step puts the group back."""
    import bpy
    from deformkit_addon import outputs
    first, first_cage = rigged(bpy, "MEAN_VALUE")
    second, second_cage = rigged(bpy, "MEAN_VALUE")
    shake(first_cage, amount=0.05, seed=1)
    shake(second_cage, amount=0.05, seed=2)
    second.modifiers[outputs.MODIFIER_NAME].node_group = None
    update()
    frames.update(short=0, full=0)
    shake(first_cage, amount=0.05, seed=3)
    shake(second_cage, amount=0.05, seed=4)
    assert frames["short"] == 2, frames
    assert outputs.modifier_kind(second) == "offsets"
    np.testing.assert_array_equal(evaluated(second), fresh(second))


def test_a_mesh_edit_right_after_a_setting_edit_is_shown(scene):
    """The echo of the add-on's write after a setting's edit comes with the update that follows it.
    On a stack that follows an object, that update took another branch of the handler, which left
    the echo waiting; after an entry was added, the next real edit of the mesh passed for it and
    was not shown (found by the random sequences below)."""
    import bpy
    from addon_helpers import make_lattice
    from deformkit_addon import api
    obj = make_object(bpy)
    api.add_entry(obj, "LATTICE", lattice=make_lattice(bpy), vertex_group="Upper")
    update()
    obj.deformkit.entries[0].strength = 0.5
    update()
    api.add_entry(obj, "TWIST", angle=0.3, deform_axis="Z")
    update()
    nudge(obj, 7, 0.01)
    update()
    shown = evaluated(obj).copy()
    np.testing.assert_array_equal(shown, fresh(obj))


def test_a_shape_key_change_right_after_a_drag_is_shown(scene):
    """A drag's write from the handlers is evaluated again by Blender in the same update, which
    calls no handler for it: an echo expected of it never came, and the next change of the mesh
    (a shape key's value here) passed for it and was not shown (found by the random sequences)."""
    import bpy
    from addon_helpers import make_lattice, perturb_lattice
    from deformkit_addon import api
    obj = make_object(bpy)
    obj.shape_key_add(name="Basis")
    key = obj.shape_key_add(name="Wider", from_mix=False)
    co = np.array([v.co for v in key.data], np.float32)
    key.data.foreach_set("co", (co * np.float32(1.2)).ravel())
    lattice = make_lattice(bpy)
    api.add_entry(obj, "LATTICE", lattice=lattice)
    update()
    perturb_lattice(lattice, amount=0.05, seed=1)
    update()
    key.value = 0.7
    update()
    np.testing.assert_array_equal(evaluated(obj), fresh(obj))


def against_twin(shown, twin, act, actions, count, rng, objects=(0,), scene_wide=()):
    """Drive two rigs built alike through `count` random actions (each drawn with one number that both
    get); after each, a full evaluation recomputes the twin's objects (at `objects` in the rigs),
    and the shown rig's, which took whatever path its steps took, must equal them bit for bit. An
    action in scene_wide is done once, with rig None."""
    from deformkit_addon import api
    for name in rng.choice(actions, size=count):
        draw = int(rng.integers(1 << 30))
        for rig in (None,) if name in scene_wide else (shown, twin):
            act(name, rig, draw)
        for index in objects:
            api.evaluate(twin[index])
            update()
            np.testing.assert_array_equal(evaluated(shown[index]), evaluated(twin[index]),
                                          err_msg=f"after '{name}' on {shown[index].name}")


@pytest.mark.parametrize("seed", [0, 1])
def test_random_sequences_of_edits_show_what_a_full_evaluation_shows(scene, seed):
    """Random drags, setting edits, toggles and stack changes (fixed seeds) on a cage rig and a
    lattice rig, and the same on their twins, which a full evaluation recomputes after each: the
    rigs' steps follow one another undisturbed, and show the twins' results bit for bit."""
    import bpy
    from addon_helpers import make_lattice, perturb_lattice
    from deformkit_addon import api
    method = "HARMONIC" if has_mesh_deform() else "MEAN_VALUE"

    def rigs(name):
        obj, cage = rigged(bpy, method)
        obj.name = cage.name = name
        other = make_object(bpy, name + " other", location=(3.0, 0.0, 0.0))
        lattice = make_lattice(bpy, name + " lattice", location=(3.0, 0.0, 0.0))
        api.add_entry(other, "LATTICE", lattice=lattice, vertex_group="Upper")
        update()
        return obj, cage, other, lattice

    shown, twin = rigs("Shown"), rigs("Twin")
    rng = np.random.default_rng(seed)

    def act(name, rig, draw):
        obj, cage, other, lattice = rig
        if name == "cage":
            shake(cage, amount=0.03, seed=draw)
        elif name == "cage object":
            cage.location.z += (draw % 100 - 50) * 4e-4
        elif name == "lattice":
            perturb_lattice(lattice, amount=0.05, seed=draw)
        elif name == "strength":
            obj.deformkit.entries[0].strength = 0.2 + (draw % 80) / 100
        elif name == "lattice strength":
            other.deformkit.entries[0].strength = 0.2 + (draw % 80) / 100
        elif name == "toggle":
            other.deformkit.entries[0].show_viewport = not other.deformkit.entries[0].show_viewport
        elif name == "twist":
            if len(other.deformkit.entries) == 1:
                api.add_entry(other, "TWIST", angle=(draw % 200 - 100) / 100, deform_axis="Z")
            else:
                api.remove_entry(other, 1)
        elif name == "twist angle" and len(other.deformkit.entries) == 2:
            other.deformkit.entries[1].angle = (draw % 200 - 100) / 100
        elif name == "mesh":
            nudge(other, 7, (draw % 100 - 50) * 2e-4)
        update()

    actions = ["cage", "cage", "cage object", "lattice", "lattice", "strength", "lattice strength", "toggle",
               "twist", "twist angle", "mesh"]
    against_twin(shown, twin, act, actions, 30, rng, objects=(0, 2))


@pytest.mark.parametrize("seed", [2, 3])
def test_random_sequences_on_handles_shape_keys_and_frames(scene, seed):
    """As above, on a Laplacian entry whose handles follow an empty (a drag without a refresh), a
    Twist keyed over frames, shape-key values, and the object itself moved: the shown rigs against
    twins a full evaluation recomputes after each action."""
    import bpy
    from addon_helpers import make_tube
    from deformkit_addon import api

    def rig(name):
        tube = make_tube(bpy, name)
        tube.shape_key_add(name="Basis")
        key = tube.shape_key_add(name="Bulge", from_mix=False)
        co = np.array([v.co for v in key.data], np.float32)
        co[:, 0] *= 1.3
        key.data.foreach_set("co", co.ravel())
        empty = bpy.data.objects.new(name + " handle", None)
        bpy.context.scene.collection.objects.link(empty)
        empty.location = (0.4, -0.3, 3.2)
        update()
        api.add_laplacian(tube, anchors_group="Bottom", handles_group="Top", handle_target="OBJECT",
                          handle_object=empty, method="ARAP")
        twist = api.add_entry(tube, "TWIST", angle=0.2, deform_axis="Z")
        twist.keyframe_insert("angle", frame=1)
        twist.angle = 0.8
        twist.keyframe_insert("angle", frame=20)
        update()
        return tube, empty, key

    shown, twin = rig("Shown"), rig("Twin")
    rng = np.random.default_rng(seed)

    def act(name, rig_, draw):
        tube, empty, key = rig_ or (None, None, None)
        if name == "handle":
            empty.location.x += (draw % 100 - 50) * 2e-3
            empty.rotation_euler.z += (draw % 30 - 15) * 1e-2
        elif name == "shape key":
            key.value = (draw % 100) / 100
        elif name == "object":
            tube.location.y += (draw % 100 - 50) * 1e-3
        elif name == "twist off":
            tube.deformkit.entries[1].show_viewport = not tube.deformkit.entries[1].show_viewport
        elif name == "frame":
            bpy.context.scene.frame_set(1 + draw % 20)  # both rigs at once
        update()

    against_twin(shown, twin, act, ["handle", "handle", "shape key", "object", "twist off", "frame"], 20, rng,
                 scene_wide=("frame",))


@pytest.mark.parametrize("seed", [4, 5])
def test_random_sequences_on_stacks_toggles_and_shared_meshes(scene, seed):
    """As above, on a stack of a lattice, a Taper and a Bend: entries moved, hidden and shown, the
    volume colors toggled, the lattice dragged, the mesh shared with a linked duplicate and let go,
    Edit Mode entered with an edit and left; against a twin a full evaluation recomputes."""
    import bpy
    from addon_helpers import make_lattice, perturb_lattice
    from deformkit_addon import api

    def rig(name):
        obj = make_object(bpy, name)
        lattice = make_lattice(bpy, name + " lattice")
        api.add_entry(obj, "LATTICE", lattice=lattice, vertex_group="Upper")
        api.add_entry(obj, "TAPER", factor=0.3, deform_axis="Z")
        api.add_entry(obj, "BEND", angle=0.4, deform_axis="Z")
        update()
        return obj, lattice

    shown, twin = rig("Shown"), rig("Twin")
    linked = {}
    rng = np.random.default_rng(seed)

    def act(name, rig_, draw):
        obj, lattice = rig_
        stack = obj.deformkit
        if name == "lattice":
            perturb_lattice(lattice, amount=0.05, seed=draw)
        elif name == "move":
            api.move_entry_to(obj, draw % 3, ("FIRST", "LAST")[draw % 2])
        elif name == "toggle":
            entry = stack.entries[draw % 3]
            entry.show_viewport = not entry.show_viewport
        elif name == "colors":
            stack.show_volume_ratio = not stack.show_volume_ratio
        elif name == "value":
            entry = stack.entries[draw % 3]
            if entry.type == "TAPER":
                entry.factor = (draw % 100 - 50) / 100
            elif entry.type == "BEND":
                entry.angle = (draw % 100 - 50) / 50
            else:
                entry.strength = 0.3 + (draw % 70) / 100
        elif name == "linked":
            if obj.name in linked:
                bpy.data.objects.remove(linked.pop(obj.name))
            else:
                copy = bpy.data.objects.new(obj.name + " linked", obj.data)
                copy.location.x += 5.0
                bpy.context.scene.collection.objects.link(copy)
                linked[obj.name] = copy
        elif name == "edit mode":  # this object alone: the others selected would be edited with it
            for other in bpy.context.view_layer.objects:
                other.select_set(other == obj)
            bpy.context.view_layer.objects.active = obj
            bpy.ops.object.mode_set(mode="EDIT")
            bpy.ops.mesh.select_all(action="SELECT")
            bpy.ops.transform.translate(value=(0.0, 0.0, (draw % 100 - 50) * 1e-3))
            bpy.ops.object.mode_set(mode="OBJECT")
        update()

    against_twin(shown, twin, act, ["lattice", "lattice", "move", "toggle", "colors", "value", "value", "linked",
                                    "edit mode"], 24, rng)


@pytest.mark.parametrize("seed", [6, 7])
def test_random_sequences_on_an_rbf_and_a_cage_in_one_stack(scene, seed):
    """As above, on a stack of an RBF entry on its controls and a Green cage: the controls' vertices
    and object moved, the cage shaken, the kernel and its epsilon changed, a bind again, the strength
    of each; against a twin a full evaluation recomputes."""
    import bpy
    from deformkit_addon import api
    from test_rbf_addon import make_controls, move_vertices

    def rig(name):
        obj = make_object(bpy, name)
        controls = make_controls(bpy, name + " controls")
        api.add_entry(obj, "RBF", controls=controls, kernel="THIN_PLATE_SPLINE")
        api.bind_rbf(obj, 0)
        cage = cage_around(bpy, obj, name + " cage", margin=0.8)
        api.add_entry(obj, "CAGE", cage=cage, cage_method="GREEN")
        api.bind_cage(obj, 1)
        update()
        return obj, controls, cage

    shown, twin = rig("Shown"), rig("Twin")
    rng = np.random.default_rng(seed)

    def act(name, rig_, draw):
        obj, controls, cage = rig_
        rbf, cage_entry = obj.deformkit.entries[0], obj.deformkit.entries[1]
        if name == "controls":
            move_vertices(controls, seed=draw, amount=0.05)
        elif name == "controls object":
            controls.location.x += (draw % 100 - 50) * 1e-3
        elif name == "cage":
            shake(cage, amount=0.03, seed=draw)
        elif name == "kernel":
            rbf.kernel = ("THIN_PLATE_SPLINE", "CUBIC", "LINEAR")[draw % 3]
        elif name == "strength":
            (rbf, cage_entry)[draw % 2].strength = 0.3 + (draw % 70) / 100
        elif name == "bind":
            api.bind_rbf(obj, 0)
        update()

    against_twin(shown, twin, act, ["controls", "controls", "controls object", "cage", "cage", "kernel", "strength",
                                    "bind"], 20, rng)


@pytest.mark.parametrize("seed", [8, 9])
def test_random_sequences_on_a_lattice_under_a_subdivide_entry(scene, seed):
    """As above, on a lattice entry followed by a Subdivide entry (the result in helper objects): the
    lattice dragged, the level and the limit surface changed, the lattice entry hidden and shown,
    the mesh edited; against a twin a full evaluation recomputes."""
    import bpy
    from addon_helpers import make_lattice, perturb_lattice
    from deformkit_addon import api

    def rig(name, like=None):
        obj = make_object(bpy, name)
        if like is not None:  # the same mesh, element by element: Blender's primitives are not numbered alike
            obj.data = like.data.copy()
        lattice = make_lattice(bpy, name + " lattice")
        api.add_entry(obj, "LATTICE", lattice=lattice)
        api.add_entry(obj, "SUBDIVIDE", levels=1, use_limit_surface=False)
        update()
        return obj, lattice

    shown = rig("Shown")
    twin = rig("Twin", like=shown[0])
    rng = np.random.default_rng(seed)

    def act(name, rig_, draw):
        obj, lattice = rig_
        if name == "lattice":
            perturb_lattice(lattice, amount=0.05, seed=draw)
        elif name == "level":
            obj.deformkit.entries[1].levels = 1 + draw % 2
        elif name == "limit":
            obj.deformkit.entries[1].use_limit_surface = not obj.deformkit.entries[1].use_limit_surface
        elif name == "toggle":
            obj.deformkit.entries[0].show_viewport = not obj.deformkit.entries[0].show_viewport
        elif name == "mesh":
            nudge(obj, 5, (draw % 100 - 50) * 2e-4)
        update()

    against_twin(shown, twin, act, ["lattice", "lattice", "level", "limit", "toggle", "mesh"], 16, rng)

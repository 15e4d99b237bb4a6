"""What evaluations keep between edits (a Lattice entry's lattice, a Barr entry's deformer, the
checksum and inverse of a vertex group) is made again whenever what it was made from changes:
after every edit the entry still equals Blender's own modifier on a twin."""
import numpy as np

from addon_helpers import (close, evaluated, make_lattice, make_object, perturb_lattice, positions,
                           twin_with_lattice_modifier, twin_with_simple_deform, update)


def _reweight(objects, scale):
    """The "Upper" group's weights times `scale` on each object, then the evaluation a weight paint
    stroke's mesh update gets (the weights read again)."""
    from deformkit_addon import evaluation
    for obj in objects:
        group = obj.vertex_groups["Upper"]
        for v in obj.data.vertices:
            for g in v.groups:
                if g.group == group.index:
                    g.weight *= scale
        obj.data.update()
    evaluation.evaluate(objects[0], evaluation.Reason.MESH)


def test_a_kept_lattice_follows_every_setting(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    base = positions(obj.data).copy()
    lat = make_lattice(bpy, resolution=(3, 3, 3))
    entry = api.add_entry(obj, "LATTICE", lattice=lat)
    twin = twin_with_lattice_modifier(bpy, obj, lat)
    mod = twin.modifiers["Lattice"]

    def both(prop, value):
        setattr(entry, prop, value)
        setattr(mod, prop, value)

    previous = evaluated(obj)
    for what, edit in [
        ("co_deform", lambda: perturb_lattice(lat, seed=1)),
        ("co_deform again", lambda: perturb_lattice(lat, seed=2)),
        ("strength", lambda: both("strength", 0.6)),
        ("vertex group", lambda: both("vertex_group", "Upper")),
        ("weights painted", lambda: _reweight((obj, twin), 0.5)),
        ("inverted", lambda: both("invert_vertex_group", True)),
        ("interpolation", lambda: setattr(lat.data, "interpolation_type_u", "KEY_CARDINAL")),
        ("lattice moved", lambda: setattr(lat, "location", (0.4, -0.1, 0.7))),
    ]:
        edit()
        update()
        ours, theirs = evaluated(obj), evaluated(twin)
        assert close(ours, theirs, 3.0), (what, np.abs(ours - theirs).max())
        assert not close(ours, previous), what  # the edit changed the result
        previous = ours
    # Back at rest, the kept lattice is the identity bit for bit, as a new one is.
    lat.data.points.foreach_set("co_deform", np.array([p.co for p in lat.data.points], np.float32).ravel())
    lat.data.update_tag()
    update()
    np.testing.assert_array_equal(evaluated(obj), base)


def test_a_kept_twist_follows_its_mode_and_weights(scene):
    import bpy
    from deformkit_addon import api
    obj = make_object(bpy)
    entry = api.add_entry(obj, "TWIST", angle=0.8, deform_axis="Z", vertex_group="Upper")
    twin = twin_with_simple_deform(bpy, obj, deform_method="TWIST", angle=0.8, deform_axis="Z",
                                   vertex_group="Upper")
    mod = twin.modifiers["SimpleDeform"]
    previous = evaluated(obj)
    for what, edit in [
        ("mode", lambda: (setattr(entry, "type", "BEND"), setattr(mod, "deform_method", "BEND"))),
        ("weights painted", lambda: _reweight((obj, twin), 0.5)),
        ("inverted", lambda: (setattr(entry, "invert_vertex_group", True),
                              setattr(mod, "invert_vertex_group", True))),
    ]:
        edit()
        update()
        ours, theirs = evaluated(obj), evaluated(twin)
        assert close(ours, theirs, 3.0), (what, np.abs(ours - theirs).max())
        assert not close(ours, previous), what
        previous = ours


def test_what_a_removed_entry_kept_goes(scene):
    import bpy
    from deformkit_addon import api, cache, meshdata
    obj = make_object(bpy)
    lat = make_lattice(bpy)
    api.add_entry(obj, "TWIST", angle=0.5)
    api.add_entry(obj, "LATTICE", lattice=lat)
    api.add_entry(obj, "TWIST", angle=0.3)
    key = meshdata.cache_key(obj)

    def kept():
        return (sorted(k[1] for k in cache.items("barr") if k[0] == key),
                sorted(k[1] for k in cache.items("lattice") if k[0] == key and k[2] == "setup"))

    assert kept() == ([0, 2], [1])
    api.remove_entry(obj, 0)  # the lattice is now at 0, the second twist at 1
    assert kept() == ([1], [0])
    api.remove_entry(obj, 0)
    assert kept() == ([0], [])

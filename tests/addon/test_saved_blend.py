"""A .blend saved by the add-on of release 0.1.0 (data/saved_by_0.1.0.blend, made by
data/make_saved_by_0_1_0.py in Blender 3.4) opens with today's add-on with its stacks intact: every
entry's kind and parameters, the keyframes and drivers on their data paths, and the same result.

The expected positions are computed here from the deformkit module and the saved parameters (and
numpy for the lattice), and compared with what the 0.1.0 add-on itself wrote (the .npz)."""
import shutil

import numpy as np
import pytest

from addon_helpers import (REPO, axis_weights, close, evaluated, group_members, in_blenders_order, lattice_points,
                           polygons, positions)
from saved_stack import BLEND, DRIVERS, FRAMES, KEYFRAMES, POSITIONS, STACKS, VOLUME_COLORS, driven_value, keyed_value

DATA = REPO / "tests/addon/data"
OBJECT_PARAMS = ("origin", "lattice", "handle_object")


@pytest.fixture
def saved(scene, tmp_path):
    """The saved file opened (from a copy: opening may not write the fixture, but saving would)."""
    import bpy
    path = tmp_path / BLEND
    shutil.copy(DATA / BLEND, path)
    bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
    return bpy


def fcurves(obj, drivers=False):
    """{data path: F-curve} of obj's keyframes (or drivers), in the action API of 3.4 and of 4.4+."""
    anim = obj.animation_data
    if anim is None or (anim.action is None and not drivers):
        return {}
    if drivers:
        curves = list(anim.drivers)
    elif hasattr(anim.action, "fcurves"):  # before slotted actions
        curves = list(anim.action.fcurves)
    else:
        from bpy_extras.anim_utils import action_get_channelbag_for_slot
        curves = list(action_get_channelbag_for_slot(anim.action, anim.action_slot).fcurves)
    return {c.data_path: c for c in curves}


def animated(name):
    return set(KEYFRAMES.get(name, {})) | set(DRIVERS.get(name, {}))


def value_at(name, path, frame, default):
    if path in KEYFRAMES.get(name, {}):
        return keyed_value(KEYFRAMES[name][path], frame)
    if path in DRIVERS.get(name, {}):
        return driven_value(DRIVERS[name][path], frame)
    return default


def params_at(name, index, frame):
    """Entry `index`'s saved parameters with the animated ones at `frame`."""
    params = dict(STACKS[name][index][1])
    for key in params:
        params[key] = value_at(name, f"deformkit.entries[{index}].{key}", frame, params[key])
    return params


def weights(obj, group, invert=False):
    """The group's weights per vertex, read with bpy (0 off the group)."""
    index = obj.vertex_groups[group].index
    found = np.array([next((g.weight for g in v.groups if g.group == index), 0.0) for v in obj.data.vertices])
    return 1.0 - found if invert else found


def simple_deform(dk, bpy, obj, kind, params):
    p = {k: v for k, v in params.items() if k not in ("name", "show_render", "vertex_group", "invert_vertex_group")}
    if "origin" in p:
        p["origin"] = np.array(obj.matrix_world.inverted() @ bpy.data.objects[p["origin"]].matrix_world)
    if "vertex_group" in params:
        p["weights"] = weights(obj, params["vertex_group"], params.get("invert_vertex_group", False))
    return dk.SimpleDeform(mode=kind, **p)


def expected_barrs(bpy, frame, render=False):
    import deformkit as dk
    obj = bpy.data.objects["Barrs"]
    deformers = [simple_deform(dk, bpy, obj, kind, params_at("Barrs", i, frame))
                 for i, (kind, params) in enumerate(STACKS["Barrs"]) if not render or params.get("show_render", True)]
    return dk.Stack(deformers).deform(positions(obj.data))


def expected_latticed(bpy, frame):
    """The Bernstein FFD written out (Sederberg-Parry: one Bernstein polynomial of degree n - 1 per
    axis over the lattice's box), blended by strength and weight, points outside left alone."""
    obj, lat = bpy.data.objects["Latticed"], bpy.data.objects["Cage"]
    params = params_at("Latticed", 0, frame)
    counts = (lat.data.points_u, lat.data.points_v, lat.data.points_w)
    frame_matrix = np.array(obj.matrix_world.inverted() @ lat.matrix_world)
    x = positions(obj.data).astype(np.float64)
    s = (x - frame_matrix[:3, 3]) @ np.linalg.inv(frame_matrix[:3, :3]).T + 0.5
    inside = ((s >= 0) & (s <= 1)).all(axis=1)
    grid = (lattice_points(lat) - lattice_points(lat, "co")).astype(np.float64).reshape(*counts[::-1], 3)
    wu, wv, ww = (axis_weights("BERNSTEIN", n, np.clip(s[:, a], 0, 1)) for a, n in enumerate(counts))
    moved = np.einsum("pi,pj,pk,kjia->pa", wu, wv, ww, grid) @ frame_matrix[:3, :3].T
    influence = params["strength"] * weights(obj, params["vertex_group"]) * inside
    return x + influence[:, None] * moved


def expected_arm(bpy, entry):
    """ARAP from the rest saved in the file, the handles moved as the handle object moved since
    bind (relative to the mesh object, as Blender's Hook)."""
    import deformkit as dk
    obj, hand = bpy.data.objects["Arm"], bpy.data.objects["Hand"]
    params = STACKS["Arm"][1][1]
    rest = np.array(entry["deformkit_rest"], np.float32).reshape(-1, 3)
    anchors, handles = group_members(obj, params["anchors_group"]), group_members(obj, params["handles_group"])
    motion = np.array(obj.matrix_world.inverted() @ hand.matrix_world) @ np.array(entry.handle_matrix).reshape(4, 4)
    targets = rest[handles].astype(np.float64) @ motion[:3, :3].T + motion[:3, 3]
    solver = dk.SurfaceDeformer(rest, polygons(obj.data), anchors=anchors, handles=handles,
                                method=params["method"].lower(), weights=params["weights"].lower(),
                                iterations=params["iterations"])
    return rest, solver.deform(targets)


def expected_smooth(bpy, frame, level):
    import deformkit as dk
    obj = bpy.data.objects["Smooth"]
    twist = simple_deform(dk, bpy, obj, "TWIST", params_at("Smooth", 0, frame))
    p = STACKS["Smooth"][1][1]
    assert (p["boundary_smooth"], p["use_creases"]) == ("PRESERVE_CORNERS", False)
    points = dk.subdivide(twist.deform(positions(obj.data)), polygons(obj.data), level, scheme="catmull_clark",
                          boundary="edge_and_corner", sharpen_two_edge_vertices=p["sharpen_two_edge_vertices"],
                          limit_surface=p["use_limit_surface"]).points
    return in_blenders_order(obj.data, points, level, scheme="catmull_clark")  # as the entry numbers it


def render_attribute(obj):
    """The render result the modifier shows (0.1 stored it as positions, now as offsets)."""
    from deformkit_addon import evaluation
    return evaluation.stored_positions(obj, "render")


def test_every_entry_keeps_its_kind_and_parameters(saved):
    bpy = saved
    for name, stack in STACKS.items():
        obj = bpy.data.objects[name]
        assert obj.deformkit.show_volume_ratio == VOLUME_COLORS.get(name, False)
        assert [e.type for e in obj.deformkit.entries] == [kind for kind, _ in stack], name
        for index, (kind, params) in enumerate(stack):
            entry = obj.deformkit.entries[index]
            assert entry.error == "", (name, index, entry.error)
            for key, value in params.items():
                if f"deformkit.entries[{index}].{key}" in animated(name):
                    continue  # checked against the animation
                got = getattr(entry, key)
                if key in OBJECT_PARAMS:
                    assert got is not None and got.name == value, (name, key)
                elif isinstance(value, float) or isinstance(value, tuple):
                    np.testing.assert_allclose(got, value, rtol=1e-6, err_msg=f"{name}.{key}")
                else:
                    assert got == value, (name, key, got)


def test_keyframes_and_drivers_drive_the_same_data_paths(saved):
    bpy = saved
    for frame in FRAMES:
        bpy.context.scene.frame_set(frame)
        for name in set(KEYFRAMES) | set(DRIVERS):
            obj = bpy.data.objects[name]
            keyed, driven = fcurves(obj), fcurves(obj, drivers=True)
            for path, keys in KEYFRAMES.get(name, {}).items():
                np.testing.assert_allclose([tuple(k.co) for k in keyed[path].keyframe_points], keys, rtol=1e-6)
                assert abs(obj.path_resolve(path) - keyed_value(keys, frame)) < 1e-5, (name, path, frame)
            for path, expression in DRIVERS.get(name, {}).items():
                assert driven[path].driver.expression == expression
                assert abs(obj.path_resolve(path) - driven_value(expression, frame)) < 1e-6, (name, path, frame)


def test_bind_data_and_subdivision_helpers_are_kept(saved):
    import deformkit as dk
    bpy = saved
    obj = bpy.data.objects["Arm"]
    entry = obj.deformkit.entries[1]
    assert entry.bind_id != 0 and entry.bind_vertices == len(obj.data.vertices)
    rest, _ = expected_arm(bpy, entry)
    thin = dk.SimpleDeform(mode="TAPER", factor=STACKS["Arm"][0][1]["factor"], deform_axis="Z")
    assert close(rest, thin.deform(positions(obj.data)))  # the rest: what came into the entry at bind
    smooth = bpy.data.objects["Smooth"].deformkit.entries[1]
    assert smooth.subdivision_viewport is not None and smooth.subdivision_render is not None


@pytest.mark.parametrize("frame", FRAMES)
def test_evaluation_gives_the_same_positions(saved, frame):
    from deformkit_addon import api
    bpy = saved
    recorded = np.load(DATA / POSITIONS)
    bpy.context.scene.frame_set(frame)
    for forced in (False, True):  # as the handlers left it, then evaluated from scratch
        for name in STACKS:
            obj = bpy.data.objects[name]
            if forced:
                api.evaluate(obj)
            ours = evaluated(obj)
            saved = recorded[f"{name}/{frame}/viewport"]
            if name == "Smooth":  # 0.1.0 numbered its subdivision as dk does; now it is Blender's order
                saved = in_blenders_order(obj.data, saved, STACKS["Smooth"][1][1]["levels"], scheme="catmull_clark")
            assert close(ours, saved, 3.0), (name, frame, forced)
        barrs = bpy.data.objects["Barrs"]
        assert close(evaluated(barrs), expected_barrs(bpy, frame), 3.0)
        assert close(render_attribute(barrs), expected_barrs(bpy, frame, render=True), 3.0)
        assert close(render_attribute(barrs), recorded[f"Barrs/{frame}/render"], 3.0)
        assert close(evaluated(bpy.data.objects["Latticed"]), expected_latticed(bpy, frame), 3.0)
        arm = bpy.data.objects["Arm"]
        assert np.abs(evaluated(arm) - expected_arm(bpy, arm.deformkit.entries[1])[1]).max() < 1e-5
        smooth = bpy.data.objects["Smooth"]
        assert close(evaluated(smooth), expected_smooth(bpy, frame, 1), 3.0)
        helper = smooth.deformkit.entries[1].subdivision_render
        assert close(positions(helper.data), expected_smooth(bpy, frame, 2), 3.0)

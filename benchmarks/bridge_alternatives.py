"""The Blender bridge's alternatives side by side (issue 19), for bench_blender.py: how the add-on's
result can be handed to Blender at 1M vertices, each way timed in the same loop as Blender's own
Simple Deform on a copy of the same mesh.

Geometry Nodes trees: each on its own copy of the mesh holding the same offsets; time = the
depsgraph update after the offsets are rewritten (foreach_set) and the mesh tagged, i.e. what the
modifier costs. Rows marked "unsafe" are floors, not candidates: absolute positions collapse a
mesh that lacks them (outputs.py), a constant offset shows no result.

Writing the offsets: the ways of turning the twist's input into the offsets attribute, each after a
depsgraph update (so the evaluated mesh shares the attribute's array, as in use), with a kept numpy
array (the compute alone) and np.copyto of 12 MB (the memory floor) beside them.
"""
import statistics
import time

import numpy as np


def _tree(bpy, outputs, name, build):
    group = bpy.data.node_groups.new(name, "GeometryNodeTree")
    outputs._add_socket(group, "Geometry", "INPUT", "NodeSocketGeometry")
    outputs._add_socket(group, "Geometry", "OUTPUT", "NodeSocketGeometry")
    b = outputs._Builder(group)
    b.link(build(b, b.source.outputs[0]), b.sink.inputs[0])
    return group


def _store_position(b, outputs, geometry, value):
    store = b.node("GeometryNodeStoreNamedAttribute", data_type="FLOAT_VECTOR", domain="POINT")
    store.inputs["Name"].default_value = "position"
    b.link(geometry, store.inputs["Geometry"])
    b.link(value, outputs._input(store, "Value"))
    return store.outputs[0]


def _set_position(b, geometry, offset):
    move = b.node("GeometryNodeSetPosition")
    b.link(geometry, move.inputs["Geometry"])
    b.link(offset, move.inputs["Offset"])
    return move.outputs[0]


def _position_plus(b, outputs, value):
    add = b.node("ShaderNodeVectorMath", operation="ADD")
    b.link(b.node("GeometryNodeInputPosition").outputs[0], add.inputs[0])
    b.link(value, add.inputs[1])
    return outputs._output(add, "Vector")


def _constant(b):
    node = b.node("FunctionNodeInputVector")
    node.vector = (0.0, 0.0, 0.001)
    return node.outputs[0]


def node_tree_variants(bpy, outputs):
    """label -> node group (None: no modifier). The first GN row is the add-on's own tree."""
    A = outputs.ATTR_OFFSET
    builds = {
        "GN pass-through (the modifier's floor)": lambda b, g: g,
        "GN Store position = Position + offset [kept]": None,
        "GN Set Position, Offset = offset": lambda b, g: b.drop_internal(_set_position(b, g, b.named(A))),
        "GN Store position = offset (absolute: unsafe)": lambda b, g: b.drop_internal(
            _store_position(b, outputs, g, b.named(A))),
        "GN Store position = Position + constant (unsafe)": lambda b, g: _store_position(
            b, outputs, g, _position_plus(b, outputs, _constant(b))),
    }
    return {"no modifier (depsgraph floor)": None,
            **{label: outputs.node_group("offsets") if build is None else _tree(bpy, outputs, label, build)
               for label, build in builds.items()}}


def _copy(bpy, src):
    obj = src.copy()
    obj.data = src.data.copy()
    for mod in list(obj.modifiers):
        obj.modifiers.remove(mod)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def _stats(ts):
    return statistics.median(ts) * 1e3, min(ts) * 1e3


def node_trees(bpy, outputs, src, co, offsets, repeats, warmup=3):
    """{label: (median ms, min ms)} of the depsgraph update per tree and of Simple Deform's."""
    objects = {}
    for label, group in node_tree_variants(bpy, outputs).items():
        obj = _copy(bpy, src)
        outputs.write_vector_attribute(obj.data, outputs.ATTR_OFFSET, offsets)
        if group is not None:
            obj.modifiers.new("deformkit", "NODES").node_group = group
        objects[label] = obj
    # The per-object tree (Edit Mode, linked duplicates): the offsets in a points-only helper mesh.
    per_object, helper = "GN per-object helper mesh, sampled by index", None
    objects[per_object] = _copy(bpy, src)
    helper = bpy.data.objects.new("bench helper", bpy.data.meshes.new("bench helper"))
    helper[outputs.RESULT_OWNER] = objects[per_object].name_full  # else the handler lets go of it as a copy's
    outputs.write_result_helper(helper, offsets, None)
    mod = objects[per_object].modifiers.new("deformkit", "NODES")
    mod.node_group = outputs.node_group("per_object")
    mod[outputs._input_identifier(mod.node_group, outputs.RESULT_INPUT)] = helper
    mod.node_group = mod.node_group
    anchor = "Blender's Simple Deform twist (anchor)"
    objects[anchor] = _copy(bpy, src)
    mod = objects[anchor].modifiers.new("SimpleDeform", "SIMPLE_DEFORM")
    mod.deform_method, mod.deform_axis = "TWIST", "Z"
    dg = bpy.context.evaluated_depsgraph_get()
    dg.update()
    buf = np.empty(co.size, np.float32)
    for label, obj in objects.items():  # what each tree gives, before timing it
        obj.evaluated_get(dg).data.attributes["position"].data.foreach_get("vector", buf)
        expected = {"[kept]": co + offsets, "Set Position": co + offsets, "absolute": offsets, "helper": co + offsets}
        for key, value in expected.items():
            if key in label:
                assert float(np.abs(buf.reshape(-1, 3) - value).max()) < 1e-5, label
    times = {label: [] for label in objects}
    flat = np.ascontiguousarray(offsets, np.float32).ravel()
    for i in range(warmup + repeats):
        for label, obj in (objects.items() if i % 2 == 0 else reversed(objects.items())):
            if label == anchor:
                obj.modifiers["SimpleDeform"].angle = 0.3 + 0.0137 * i
            else:
                mesh = helper.data if label == per_object else obj.data
                mesh.attributes[outputs.ATTR_OFFSET].data.foreach_set("vector", flat)
                mesh.update()
            t0 = time.perf_counter()
            bpy.context.evaluated_depsgraph_get().update()
            if i >= warmup:
                times[label].append(time.perf_counter() - t0)
    for obj in list(objects.values()) + [helper]:
        mesh = obj.data
        bpy.data.objects.remove(obj)
        bpy.data.meshes.remove(mesh)
    return {label: _stats(ts) for label, ts in times.items()}


def write_paths(bpy, outputs, dk, src, co, repeats):
    """{label: (median ms, min ms)} of the ways of computing the twist's offsets into the mesh."""
    obj = _copy(bpy, src)
    obj.modifiers.new("deformkit", "NODES").node_group = outputs.node_group("offsets")
    mesh, n, name = obj.data, len(co), outputs.ATTR_OFFSET
    twist = dk.SimpleDeform(mode="TWIST", angle=0.5, deform_axis="Z")
    stack = dk.Stack([twist])
    base, kept = np.ascontiguousarray(co, np.float32), np.empty((len(co), 3), np.float32)

    def deform_subtract_foreach_set():  # the add-on up to issue 19
        p = stack.deform(base)
        outputs.write_vector_attribute(mesh, name, np.subtract(p, base, out=p))

    def deform_into_subtract():
        view = outputs.vector_attribute_memory(mesh, name, n)
        np.subtract(stack.deform(base, out=view), base, out=view)

    paths = {
        "deform, subtract, foreach_set (before)": deform_subtract_foreach_set,
        "Stack displacement (deform, then a second pass) into the attribute's memory": lambda: stack.displacement(
            base, out=outputs.vector_attribute_memory(mesh, name, n)),
        "deform into the attribute's memory, subtract": deform_into_subtract,
        "one-pass displacement into the attribute's memory [kept]": lambda: twist.displacement(
            base, out=outputs.vector_attribute_memory(mesh, name, n)),
        "one-pass displacement into a kept numpy array (compute alone)": lambda: twist.displacement(base, out=kept),
        "deform into a kept numpy array (compute alone)": lambda: stack.deform(base, out=kept),
        "np.subtract in place, 1M x 3 float32": lambda: np.subtract(kept, base, out=kept),
        "np.copyto of the 12 MB (memory floor)": lambda: np.copyto(kept, base),
        # Looking an existing attribute up makes Blender unshare its array from the evaluated
        # mesh (a 12 MB copy): every path above pays it; it is the write's own floor in Blender.
        "attributes.get alone (Blender unshares the array)": lambda: mesh.attributes.get(name),
    }
    outputs.write_vector_attribute(mesh, name, np.zeros_like(base))
    times = {label: [] for label in paths}
    for i in range(repeats + 1):
        for label, fn in paths.items():
            mesh.update()
            bpy.context.evaluated_depsgraph_get().update()  # the evaluated mesh shares the array again
            t0 = time.perf_counter()
            fn()
            if i > 0:
                times[label].append(time.perf_counter() - t0)
    got = np.empty(base.size, np.float32)
    mesh.attributes[name].data.foreach_get("vector", got)
    assert float(np.abs(got.reshape(-1, 3) - (stack.deform(base) - base)).max()) < 1e-6
    bpy.data.objects.remove(obj)
    bpy.data.meshes.remove(mesh)
    return {label: _stats(ts) for label, ts in times.items()}


def report(bpy, outputs, dk, src, co, repeats):
    """Print both tables; returns their figures for the JSON."""
    offsets = (0.01 * np.random.default_rng(1).normal(size=co.shape)).astype(np.float32)
    trees = node_trees(bpy, outputs, src, co, offsets, repeats)
    writes = write_paths(bpy, outputs, dk, src, co, repeats)
    anchor = trees["Blender's Simple Deform twist (anchor)"][0]
    print(f"\nHanding the result to Blender, {len(co):,} vertices ({repeats} each, interleaved)")
    print(f"{'depsgraph update after the offsets are rewritten':56s}{'median ms':>10s}{'min ms':>9s}"
          f"{'/ Simple Deform':>16s}")
    for label, (md, mn) in trees.items():
        print(f"  {label:54s}{md:10.2f}{mn:9.2f}{md / anchor:16.2f}")
    print(f"{'writing the offsets (twist 1M, float32)':56s}{'median ms':>10s}{'min ms':>9s}")
    for label, (md, mn) in writes.items():
        print(f"  {label:54s}{md:10.2f}{mn:9.2f}")
    return {"node_trees": trees, "write_paths": writes}

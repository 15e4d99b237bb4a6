"""The stored result and the Geometry Nodes modifier named "deformkit" that shows it.

The result is stored as per-point offsets (deformed minus input), never as positions, so the
modifier can only add to what it is given: on a mesh without the offsets (Copy Modifiers), with
another vertex count, or below another modifier it passes its input through or moves it by the
offsets, and never collapses a mesh. Where they live:

* "offsets": attributes of the object's own mesh (Object Mode, mesh used by this object only):
  the cheapest for Blender to read;
* "per_object": a points-only helper mesh and object per object (Edit Mode, where the mesh belongs
  to the edit mesh; a mesh shared by linked duplicates, each with its own entries), sampled by
  index, and only when it has as many points as the input;
* "subdivided": a Subdivide entry's helper objects, output in place of the input (entries/subdivide.py),
  only when the input has the vertex count they were made from.
The node groups are named "deformkit result ..." (before issue 31 "Needs deformkit add-on ...",
renamed when met); in Blender 4.2+ the modifier hides its group selector, its Manage panel and the
group's inputs (3.4 has no such switches). The modifier's output never carries the internal
attributes (so Apply and Convert give a clean mesh).
"""
import ctypes

import bpy
import numpy as np

from .errors import EntryError
from .node_builder import Builder, add_socket, input_of, output

MODIFIER_NAME = "deformkit"
ATTR_OFFSET = "deformkit_offset"
ATTR_OFFSET_RENDER = "deformkit_offset_render"
ATTR_VOLUME = "deformkit_volume_ratio"
ATTR_INPUT = "deformkit_input"  # per-object kinds: the modifier's input, read back in Edit Mode
OUTPUT_ATTRIBUTES = (ATTR_OFFSET, ATTR_OFFSET_RENDER, ATTR_VOLUME, ATTR_INPUT)
INTERNAL = (ATTR_OFFSET, ATTR_OFFSET_RENDER)  # dropped from the modifier's output
LEGACY_ATTRIBUTES = ("deformkit_position", "deformkit_position_render")  # absolute positions, up to 0.1
# Names that read right with the add-on enabled or not (it makes the result; the group only shows it).
KIND_NAMES = {"offsets": "deformkit result", "offsets_split": "deformkit result (render)",
              "per_object": "deformkit result (object)", "per_object_volume": "deformkit result (colors)",
              "subdivided": "deformkit result (subdivided)"}
LEGACY_NAME = "Needs deformkit add-on"  # the groups' names before issue 31 (one suffix per kind)
SHAPE = "deformkit_shape"  # on a group: [nodes, links] as built, to notice a stray edit
NODE_GROUP_NAME = KIND_NAMES["offsets"]
MARKER = "deformkit_result"  # 0.1 marked its (absolute-position) groups "deformkit_node_group"
RESULT_INPUT = "Result"  # the per-object helper; a Subdivide entry's helpers:
HELPER_INPUTS = ("Viewport", "Render")
VERTICES_INPUT = "Vertices"  # the vertex count the result was made for
RESULT_OWNER = "deformkit_result_of"  # on a per-object helper: the name of its object


def vector_attribute(mesh, name):
    """mesh's point attribute `name` of 3 floats, made (or remade, if of another type) as needed."""
    attr = mesh.attributes.get(name)
    if attr is not None and (attr.data_type != "FLOAT_VECTOR" or attr.domain != "POINT"):
        mesh.attributes.remove(attr)
        attr = None
    if attr is None:
        attr = mesh.attributes.new(name, "FLOAT_VECTOR", "POINT")
    return attr


def write_vector_attribute(mesh, name, values):
    vector_attribute(mesh, name).data.foreach_set("vector", np.ascontiguousarray(values, np.float32).ravel())


def vector_attribute_memory(mesh, name, count):
    """Blender's own float32 (count, 3) array of mesh's point attribute `name` (made as needed), as a
    numpy view to write the result into: no temporary array and no foreach_set copy of it.

    Opening the attribute's data makes Blender's array unshared first (a copy if the evaluated
    mesh or an undo step still shares it), as foreach_set does, so writing it in place has the
    same effect as foreach_set. The view is valid only until Blender next touches the mesh: fill
    it at once and drop it."""
    data = vector_attribute(mesh, name).data
    if len(data) != count or count == 0:
        raise EntryError(f"attribute '{name}' has {len(data)} points, the result {count}")
    address = data[0].as_pointer()  # the iterator's begin is what unshares the array
    return np.ctypeslib.as_array((ctypes.c_float * (3 * count)).from_address(address)).reshape(count, 3)


def volume_colors(ratio):
    """det J as a color: 1 is white, stretch (> 1) goes red, compression (< 1) blue."""
    t = np.clip(np.log2(np.maximum(ratio, 1e-6)), -1.0, 1.0).astype(np.float32)
    rgba = np.ones((len(t), 4), np.float32)
    rgba[:, 1] = 1.0 - np.abs(t)
    rgba[:, 0] = np.where(t < 0, 1.0 + t, 1.0)
    rgba[:, 2] = np.where(t > 0, 1.0 - t, 1.0)
    return rgba


def write_volume_colors(mesh, ratio):
    attr = mesh.attributes.get(ATTR_VOLUME)
    if attr is None:
        attr = mesh.attributes.new(ATTR_VOLUME, "FLOAT_COLOR", "POINT")
    attr.data.foreach_set("color", volume_colors(ratio).ravel())


def remove_attributes(mesh, names):
    for name in names:
        attr = mesh.attributes.get(name)
        if attr is not None:
            mesh.attributes.remove(attr)


def our_modifier(obj):
    """The "deformkit" modifier if it is one of ours (a Geometry Nodes modifier with our group)."""
    mod = obj.modifiers.get(MODIFIER_NAME)
    if mod is None or mod.type != "NODES" or mod.node_group is None or mod.node_group.get(MARKER) not in KIND_NAMES:
        return None
    return mod


def modifier_kind(obj):
    mod = our_modifier(obj)
    return None if mod is None else mod.node_group[MARKER]


def follow_toggles(obj, entries):
    """The modifier's Edit Mode and On Cage follow the entries': shown in Edit Mode when one entry
    is, on the cage when the last entry shown there is (one modifier shows the whole stack's result)."""
    mod = our_modifier(obj)
    if mod is None:
        return
    in_edit = [e for e in entries if e.show_viewport and e.show_in_editmode]
    on_cage = bool(in_edit) and in_edit[-1].show_on_cage
    for prop, value in (("show_in_editmode", bool(in_edit)), ("show_on_cage", on_cage)):
        if getattr(mod, prop) != value:
            setattr(mod, prop, value)


def _input_identifier(group, name):
    if hasattr(group, "interface"):
        return next(i.identifier for i in group.interface.items_tree if i.name == name and i.in_out == "INPUT")
    return group.inputs[name].identifier


def node_group(kind):
    """The node group that shows a result of `kind` (see the module's docstring), whole. Found by
    a marker, not by name, so a user's group of the same name is left alone; one a stray edit
    broke (a node or link removed) is built again in place, so every modifier using it is whole."""
    for group in bpy.data.node_groups:
        if group.get(MARKER) == kind:
            if group.name.startswith(LEGACY_NAME):  # as named up to 0.1 and issue 31
                group.name = KIND_NAMES[kind]
            if not is_whole(group):
                _fill(group, kind)
            return group
    group = bpy.data.node_groups.new(KIND_NAMES[kind], "GeometryNodeTree")
    group[MARKER] = kind
    _fill(group, kind)
    return group


def is_whole(group):
    """Whether the group has the nodes and links it was built with (counted; SHAPE)."""
    return list(group.get(SHAPE, ())) == [len(group.nodes), len(group.links)] and all(link.is_valid for link in group.links)


def _fill(group, kind):
    group.nodes.clear()
    if hasattr(group, "interface"):  # Blender 4.0+
        group.interface.clear()
    else:
        group.inputs.clear()
        group.outputs.clear()
    _build(group, kind)
    group[SHAPE] = [len(group.nodes), len(group.links)]
    items = group.interface.items_tree if hasattr(group, "interface") else ()
    for item in items:  # 4.2+: the helper objects and vertex count are not the user's (3.4 shows them)
        if item.in_out == "INPUT" and item.socket_type != "NodeSocketGeometry" and hasattr(item, "hide_in_modifier"):
            item.hide_in_modifier = True


def _build(group, kind):
    add_socket(group, "Geometry", "INPUT", "NodeSocketGeometry")
    add_socket(group, "Geometry", "OUTPUT", "NodeSocketGeometry")
    b = Builder(group)
    geometry = b.source.outputs[0]
    if kind == "subdivided":
        for name in HELPER_INPUTS:
            add_socket(group, name, "INPUT", "NodeSocketObject")
        add_socket(group, VERTICES_INPUT, "INPUT", "NodeSocketInt")
        helpers = []
        for name in HELPER_INPUTS:
            info = b.node("GeometryNodeObjectInfo", transform_space="ORIGINAL")  # in this object's space
            b.link(b.source.outputs[name], info.inputs["Object"])
            helpers.append(info.outputs["Geometry"])
        subdivided = b.viewport_or_render(helpers[0], helpers[1], "GEOMETRY")
        switch = b.node("GeometryNodeSwitch", input_type="GEOMETRY")
        condition, if_false, if_true = [i for i in switch.inputs if i.enabled]
        b.link(b.count_matches(geometry, b.source.outputs[VERTICES_INPUT]), condition)
        b.link(b.drop(geometry, INTERNAL), if_false)
        b.link(subdivided, if_true)
        b.link(output(switch), b.sink.inputs[0])
        return group
    if kind.startswith("per_object"):
        add_socket(group, RESULT_INPUT, "INPUT", "NodeSocketObject")
        info = b.node("GeometryNodeObjectInfo", transform_space="ORIGINAL")
        b.link(b.source.outputs[RESULT_INPUT], info.inputs["Object"])
        helper = info.outputs["Geometry"]
        size = b.node("GeometryNodeAttributeDomainSize", component="MESH")
        b.link(helper, size.inputs[0])
        matches = b.count_matches(geometry, output(size, "Point Count"))

        def sampled(value, data_type):
            sample = b.node("GeometryNodeSampleIndex", data_type=data_type, domain="POINT")
            b.link(helper, sample.inputs["Geometry"])
            b.link(b.node("GeometryNodeInputIndex").outputs[0], sample.inputs["Index"])
            b.link(value, input_of(sample, "Value"))
            return output(sample)

        # The input as it came in (an edit, the shape keys), for captured_input: Edit Mode holds the
        # mesh in a BMesh, which Python reads a hundred times slower than an attribute.
        capture = b.node("GeometryNodeStoreNamedAttribute", data_type="FLOAT_VECTOR", domain="POINT")
        capture.inputs["Name"].default_value = ATTR_INPUT
        b.link(geometry, capture.inputs["Geometry"])
        b.link(b.node("GeometryNodeInputPosition").outputs[0], input_of(capture, "Value"))
        geometry = capture.outputs[0]
        offset = sampled(b.viewport_or_render(b.named(ATTR_OFFSET), b.named(ATTR_OFFSET_RENDER)), "FLOAT_VECTOR")
        move = b.node("GeometryNodeSetPosition")
        b.link(geometry, move.inputs["Geometry"])
        b.link(matches, move.inputs["Selection"])
        b.link(offset, move.inputs["Offset"])
        geometry = move.outputs[0]
        if kind == "per_object_volume":
            store = b.node("GeometryNodeStoreNamedAttribute", data_type="FLOAT_COLOR", domain="POINT")
            store.inputs["Name"].default_value = ATTR_VOLUME
            b.link(geometry, store.inputs["Geometry"])
            # Store Named Attribute has no Selection in 3.4: white (det J = 1) where the result is not shown.
            switch = b.node("GeometryNodeSwitch", input_type="RGBA")
            condition, if_false, if_true = [i for i in switch.inputs if i.enabled]
            if_false.default_value = (1.0, 1.0, 1.0, 1.0)
            b.link(matches, condition)
            b.link(sampled(b.named(ATTR_VOLUME, "FLOAT_COLOR"), "FLOAT_COLOR"), if_true)
            b.link(output(switch), input_of(store, "Value"))
            geometry = store.outputs[0]
        b.link(b.drop(geometry, INTERNAL), b.sink.inputs[0])
        return group
    # Own-mesh offsets: a Store Named Attribute into "position" is cheaper than Set Position on large meshes.
    offset = b.named(ATTR_OFFSET)
    if kind == "offsets_split":
        offset = b.viewport_or_render(offset, b.named(ATTR_OFFSET_RENDER))
    add = b.node("ShaderNodeVectorMath", operation="ADD")
    b.link(b.node("GeometryNodeInputPosition").outputs[0], add.inputs[0])
    b.link(offset, add.inputs[1])
    store = b.node("GeometryNodeStoreNamedAttribute", data_type="FLOAT_VECTOR", domain="POINT")
    store.inputs["Name"].default_value = "position"
    b.link(geometry, store.inputs["Geometry"])
    b.link(output(add, "Vector"), input_of(store, "Value"))
    b.link(b.drop(store.outputs[0], INTERNAL), b.sink.inputs[0])
    return group


def ensure_modifier(obj, kind, inputs=()):
    """The "deformkit" modifier showing a result of `kind`, with these (name, value) inputs. New,
    it goes first in the stack: the entries deform the mesh as it comes in (shape keys applied)."""
    mod = obj.modifiers.get(MODIFIER_NAME)
    if mod is not None and mod.type != "NODES":
        raise EntryError(f"a modifier named '{MODIFIER_NAME}' of another type is in the way")
    if mod is None:
        mod = obj.modifiers.new(MODIFIER_NAME, "NODES")
        with bpy.context.temp_override(object=obj, active_object=obj):
            bpy.ops.object.modifier_move_to_index(modifier=mod.name, index=0)
    relink = False
    group = mod.node_group
    if group is None or group.get(MARKER) != kind or not is_whole(group) or group.name.startswith(LEGACY_NAME):
        mod.node_group = node_group(kind)  # also a stray click's repair: another group, none, a link gone
        relink = True
        for prop in ("show_group_selector", "show_manage_panel"):  # Blender 4.2+: plumbing, not settings
            if getattr(mod, prop, False):
                setattr(mod, prop, False)
    for name, value in inputs:
        identifier = _input_identifier(mod.node_group, name)
        if mod.get(identifier) != value:
            mod[identifier] = value
            relink = True
    if relink:
        # An ID property write tags nothing; assigning the group rebuilds the depsgraph's relations.
        mod.node_group = mod.node_group
    return mod


def modifier_input(obj, name):
    mod = our_modifier(obj)
    if mod is None:
        return None
    try:
        return mod.get(_input_identifier(mod.node_group, name))
    except (StopIteration, KeyError):
        return None


def helper_objects(obj):
    """The objects the "deformkit" modifier's subdivided group outputs (viewport, render), or []."""
    if modifier_kind(obj) != "subdivided":
        return []
    return [modifier_input(obj, name) for name in HELPER_INPUTS]


def result_helper(obj, create=True):
    """obj's per-object helper (points only, linked to no scene), made on first use. A copy of
    obj (linked duplicate, Copy Modifiers) finds the original's on its modifier and makes its own."""
    helper = modifier_input(obj, RESULT_INPUT)
    if helper is not None and _owned_by(obj, helper):
        if helper.get(RESULT_OWNER) != obj.name_full:
            helper[RESULT_OWNER] = obj.name_full  # adopted after a rename of obj
        return helper
    for candidate in bpy.data.objects:
        if candidate.get(RESULT_OWNER) == obj.name_full:
            return candidate
    if not create:
        return None
    name = f"{obj.name_full} deformkit result"
    helper = bpy.data.objects.new(name, bpy.data.meshes.new(name))
    helper[RESULT_OWNER] = obj.name_full
    return helper


def is_helper_object(obj):
    """Whether obj is a per-object helper (the user's objects never carry RESULT_OWNER)."""
    return RESULT_OWNER in obj


def _owned_by(obj, helper):
    """A per-object helper is obj's if made for it, or for an object of a name that is gone (obj renamed)."""
    owner = helper.get(RESULT_OWNER)
    return owner == obj.name_full or (owner is not None and bpy.data.objects.get(owner) is None)


def write_result_helper(helper, offsets, render_offsets, ratio=None):
    mesh = helper.data
    if len(mesh.vertices) != len(offsets):
        mesh.clear_geometry()
        mesh.vertices.add(len(offsets))
    write_vector_attribute(mesh, ATTR_OFFSET, offsets)
    write_vector_attribute(mesh, ATTR_OFFSET_RENDER, offsets if render_offsets is None else render_offsets)
    if ratio is not None:
        write_volume_colors(mesh, ratio)
    mesh.update()


def discard_result_helper(obj):
    helper = result_helper(obj, create=False)
    if helper is not None:
        mesh = helper.data
        bpy.data.objects.remove(helper)
        if mesh.users == 0:
            bpy.data.meshes.remove(mesh)


def captured_input(obj, depsgraph, count):
    """The input the per-object modifier last got, as float32 (count, 3), read from the evaluated
    mesh; None unless the modifier is first, shown and the evaluated mesh has `count` points."""
    mod = our_modifier(obj)
    if mod is None or not mod.node_group[MARKER].startswith("per_object") or place_problem(obj) \
            or not (mod.show_viewport and (mod.show_in_editmode or obj.mode != "EDIT")):
        return None
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        attr = mesh.attributes.get(ATTR_INPUT)
        if attr is None or len(mesh.vertices) != count or attr.domain != "POINT":
            return None
        values = np.empty(count * 3, np.float32)
        attr.data.foreach_get("vector", values)
        return values.reshape(-1, 3)
    finally:
        evaluated.to_mesh_clear()


def is_copied(obj):
    """True when obj's "deformkit" modifier shows another object's result (Copy Modifiers, or a
    duplicate before its first evaluation)."""
    kind = modifier_kind(obj)
    if kind is None:
        return False
    if kind.startswith("per_object"):
        helper = modifier_input(obj, RESULT_INPUT)
        return helper is not None and not _owned_by(obj, helper)
    if kind == "subdivided":
        return any(h is not None and h.get("deformkit_subdivision_of") not in (None, obj.name_full)
                   and len(obj.deformkit.entries) == 0 for h in helper_objects(obj))
    return False


def let_go_of_copy(obj):
    """A copied modifier is emptied (it then passes its input through), not deleted: it is the user's."""
    mod = our_modifier(obj)
    names = (RESULT_INPUT,) if mod.node_group[MARKER].startswith("per_object") else HELPER_INPUTS
    for name in names:
        mod[_input_identifier(mod.node_group, name)] = None
    mod.node_group = mod.node_group


def remove_outputs(obj, mesh_attributes=True):
    """The modifier, the per-object helper and (with mesh_attributes) the mesh's attributes go."""
    mod = obj.modifiers.get(MODIFIER_NAME)
    if mod is not None and mod.type == "NODES":
        obj.modifiers.remove(mod)
    discard_result_helper(obj)
    if mesh_attributes:
        remove_attributes(obj.data, OUTPUT_ATTRIBUTES + LEGACY_ATTRIBUTES)
        obj.data.update()


def place_problem(obj):
    """What moving the "deformkit" modifier below others does, or '' when it is first among those shown."""
    mod = our_modifier(obj)
    if mod is None:
        return ""
    before = []
    for other in obj.modifiers:
        if other == mod:
            break
        if other.show_viewport:
            before.append(other.name)
    if not before:
        return ""
    return (f"The 'deformkit' modifier is below {', '.join(repr(n) for n in before)}: it adds the entries' "
            "displacements of the mesh before those modifiers to their result, which is exact only where they "
            "leave the mesh as it was. Move it to first to see the entries as computed")

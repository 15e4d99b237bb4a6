"""The stored result: per-point position attributes and the Geometry Nodes modifier named
"deformkit" that stores them into the positions, placed first in the modifier stack (or, after a
Subdivide entry, outputs its helper objects' geometry instead)."""
import bpy
import numpy as np

MODIFIER_NAME = "deformkit"
NODE_GROUP_NAME = "deformkit_positions"            # one result for viewport and render
SPLIT_NODE_GROUP_NAME = "deformkit_positions_split"  # different results in the viewport and in renders
SUBDIVIDED_NODE_GROUP_NAME = "deformkit_subdivided"  # a Subdivide entry's helper objects
GROUP_NAMES = {"single": NODE_GROUP_NAME, "split": SPLIT_NODE_GROUP_NAME, "subdivided": SUBDIVIDED_NODE_GROUP_NAME}
HELPER_INPUTS = ("Viewport", "Render")
ATTR_VIEWPORT = "deformkit_position"
ATTR_RENDER = "deformkit_position_render"
ATTR_VOLUME = "deformkit_volume_ratio"
OUTPUT_ATTRIBUTES = (ATTR_VIEWPORT, ATTR_RENDER, ATTR_VOLUME)


class EntryError(ValueError):
    """A problem with one entry's settings, shown on the entry."""


def write_vector_attribute(mesh, name, values):
    attr = mesh.attributes.get(name)
    if attr is not None and (attr.data_type != "FLOAT_VECTOR" or attr.domain != "POINT"):
        mesh.attributes.remove(attr)
        attr = None
    if attr is None:
        attr = mesh.attributes.new(name, "FLOAT_VECTOR", "POINT")
    attr.data.foreach_set("vector", np.ascontiguousarray(values, np.float32).ravel())


def write_volume_colors(mesh, ratio):
    """det J as a color: 1 is white, stretch (> 1) goes red, compression (< 1) blue."""
    t = np.clip(np.log2(np.maximum(ratio, 1e-6)), -1.0, 1.0).astype(np.float32)
    rgba = np.ones((len(t), 4), np.float32)
    rgba[:, 1] = 1.0 - np.abs(t)
    rgba[:, 0] = np.where(t < 0, 1.0 + t, 1.0)
    rgba[:, 2] = np.where(t > 0, 1.0 - t, 1.0)
    attr = mesh.attributes.get(ATTR_VOLUME)
    if attr is None:
        attr = mesh.attributes.new(ATTR_VOLUME, "FLOAT_COLOR", "POINT")
    attr.data.foreach_set("color", rgba.ravel())


def outputs_present(obj):
    mod = obj.modifiers.get(MODIFIER_NAME)
    if mod is None or mod.type != "NODES" or mod.node_group is None:
        return False
    kind = mod.node_group.get("deformkit_node_group")
    if kind == "subdivided" and None in helper_objects(obj):
        return False
    return ATTR_VIEWPORT in obj.data.attributes and (kind != "split" or ATTR_RENDER in obj.data.attributes)


def _add_socket(group, name, in_out, socket_type):
    if hasattr(group, "interface"):  # Blender 4.0+
        return group.interface.new_socket(name, in_out=in_out, socket_type=socket_type).identifier
    return (group.inputs if in_out == "INPUT" else group.outputs).new(socket_type, name).identifier


def _input_identifier(group, name):
    if hasattr(group, "interface"):
        return next(i.identifier for i in group.interface.items_tree if i.name == name and i.in_out == "INPUT")
    return group.inputs[name].identifier


def node_group(kind):
    """Geometry Nodes that give the result: "single", one stored position attribute everywhere (a
    Store Named Attribute into "position": cheaper than Set Position on large meshes); "split", the
    viewport attribute in the viewport and the render attribute in renders; "subdivided", the
    geometry of the Viewport or Render object (a Subdivide entry's helpers) in place of the input.
    Found by a marker, not by name, so a user's group of the same name is left alone."""
    for group in bpy.data.node_groups:
        if group.get("deformkit_node_group") == kind:
            return group
    group = bpy.data.node_groups.new(GROUP_NAMES[kind], "GeometryNodeTree")
    group["deformkit_node_group"] = kind
    _add_socket(group, "Geometry", "INPUT", "NodeSocketGeometry")
    _add_socket(group, "Geometry", "OUTPUT", "NodeSocketGeometry")
    nodes, links = group.nodes, group.links
    source, sink = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    if kind == "single":
        named = nodes.new("GeometryNodeInputNamedAttribute")
        named.data_type = "FLOAT_VECTOR"
        named.inputs["Name"].default_value = ATTR_VIEWPORT
        store = nodes.new("GeometryNodeStoreNamedAttribute")
        store.data_type = "FLOAT_VECTOR"
        store.domain = "POINT"
        store.inputs["Name"].default_value = "position"
        links.new(source.outputs[0], store.inputs["Geometry"])
        links.new(_output(named), [i for i in store.inputs if i.name == "Value" and i.enabled][0])
        links.new(store.outputs[0], sink.inputs[0])
        return group
    is_viewport = nodes.new("GeometryNodeIsViewport")
    if kind == "subdivided":
        objects = []
        for name in HELPER_INPUTS:
            _add_socket(group, name, "INPUT", "NodeSocketObject")
            info = nodes.new("GeometryNodeObjectInfo")
            info.transform_space = "ORIGINAL"  # the helper holds positions in this object's space
            links.new(source.outputs[name], info.inputs["Object"])
            objects.append(info.outputs["Geometry"])
        switch = nodes.new("GeometryNodeSwitch")
        switch.input_type = "GEOMETRY"
        condition, if_false, if_true = [i for i in switch.inputs if i.enabled]  # 3.4 lists every type
        links.new(is_viewport.outputs[0], condition)
        links.new(objects[1], if_false)
        links.new(objects[0], if_true)
        links.new(_output(switch), sink.inputs[0])
        return group
    not_viewport = nodes.new("FunctionNodeBooleanMath")
    not_viewport.operation = "NOT"
    links.new(is_viewport.outputs[0], not_viewport.inputs[0])
    geometry = source.outputs[0]
    for attribute, selection in ((ATTR_VIEWPORT, is_viewport.outputs[0]), (ATTR_RENDER, not_viewport.outputs[0])):
        named = nodes.new("GeometryNodeInputNamedAttribute")
        named.data_type = "FLOAT_VECTOR"
        named.inputs["Name"].default_value = attribute
        set_position = nodes.new("GeometryNodeSetPosition")
        links.new(geometry, set_position.inputs["Geometry"])
        links.new(selection, set_position.inputs["Selection"])
        links.new(_output(named), set_position.inputs["Position"])
        geometry = set_position.outputs[0]
    links.new(geometry, sink.inputs[0])
    return group


def _output(node):
    # Blender 3.4 lists one output per data type on these nodes; the enabled one is ours.
    return [o for o in node.outputs if o.enabled][0]


def ensure_modifier(obj, split=False, helpers=None):
    """The "deformkit" modifier with the node group for this result; `helpers`: the (viewport,
    render) objects of a Subdivide entry, whose geometry it then outputs."""
    mod = obj.modifiers.get(MODIFIER_NAME)
    if mod is not None and mod.type != "NODES":
        raise EntryError(f"a modifier named '{MODIFIER_NAME}' of another type is in the way")
    if mod is None:
        mod = obj.modifiers.new(MODIFIER_NAME, "NODES")
        # First in the stack: the positions were computed from the base mesh.
        with bpy.context.temp_override(object=obj, active_object=obj):
            bpy.ops.object.modifier_move_to_index(modifier=mod.name, index=0)
    kind = "subdivided" if helpers else "split" if split else "single"
    if mod.node_group is None or mod.node_group.get("deformkit_node_group") != kind:
        mod.node_group = node_group(kind)
    if helpers and tuple(helper_objects(obj)) != tuple(helpers):
        for name, helper in zip(HELPER_INPUTS, helpers):
            mod[_input_identifier(mod.node_group, name)] = helper
        # An ID property write tags nothing; assigning the group rebuilds the depsgraph's relations.
        mod.node_group = mod.node_group
    return mod


def helper_objects(obj):
    """The objects the "deformkit" modifier's subdivided group outputs (viewport, render), or []."""
    mod = obj.modifiers.get(MODIFIER_NAME)
    if mod is None or mod.type != "NODES" or mod.node_group is None \
            or mod.node_group.get("deformkit_node_group") != "subdivided":
        return []
    return [mod.get(_input_identifier(mod.node_group, name)) for name in HELPER_INPUTS]


def remove_outputs(obj):
    mod = obj.modifiers.get(MODIFIER_NAME)
    if mod is not None and mod.type == "NODES":
        obj.modifiers.remove(mod)
    mesh = obj.data
    for name in OUTPUT_ATTRIBUTES:
        attr = mesh.attributes.get(name)
        if attr is not None:
            mesh.attributes.remove(attr)
    mesh.update()

"""The stored result: per-point position attributes and the Geometry Nodes modifier named
"deformkit" that stores them into the positions, placed first in the modifier stack."""
import bpy
import numpy as np

MODIFIER_NAME = "deformkit"
NODE_GROUP_NAME = "deformkit_positions"            # one result for viewport and render
SPLIT_NODE_GROUP_NAME = "deformkit_positions_split"  # different results in the viewport and in renders
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
    split = mod.node_group.get("deformkit_node_group") == "split"
    return ATTR_VIEWPORT in obj.data.attributes and (not split or ATTR_RENDER in obj.data.attributes)


def node_group(split):
    """Geometry Nodes that take the stored positions: with `split`, the viewport attribute in the
    viewport and the render attribute in renders; otherwise one attribute everywhere (a Store
    Named Attribute into "position": cheaper than Set Position on large meshes). Found by a
    marker, not by name, so a user's group of the same name is left alone."""
    kind = "split" if split else "single"
    for group in bpy.data.node_groups:
        if group.get("deformkit_node_group") == kind:
            return group
    group = bpy.data.node_groups.new(SPLIT_NODE_GROUP_NAME if split else NODE_GROUP_NAME, "GeometryNodeTree")
    group["deformkit_node_group"] = kind
    if hasattr(group, "interface"):  # Blender 4.0+
        group.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
        group.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    else:
        group.inputs.new("NodeSocketGeometry", "Geometry")
        group.outputs.new("NodeSocketGeometry", "Geometry")
    nodes, links = group.nodes, group.links
    source, sink = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    if not split:
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


def _output(named_attribute_node):
    # Blender 3.4 lists one "Attribute" output per data type; the enabled one is the vector.
    return [o for o in named_attribute_node.outputs if o.enabled][0]


def ensure_modifier(obj, split=False):
    mod = obj.modifiers.get(MODIFIER_NAME)
    if mod is not None and mod.type != "NODES":
        raise EntryError(f"a modifier named '{MODIFIER_NAME}' of another type is in the way")
    if mod is None:
        mod = obj.modifiers.new(MODIFIER_NAME, "NODES")
        # First in the stack: the positions were computed from the base mesh.
        with bpy.context.temp_override(object=obj, active_object=obj):
            bpy.ops.object.modifier_move_to_index(modifier=mod.name, index=0)
    if mod.node_group is None or mod.node_group.get("deformkit_node_group") != ("split" if split else "single"):
        mod.node_group = node_group(split)
    return mod


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

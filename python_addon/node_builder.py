"""Building Geometry Nodes groups from Python, with the Blender 3.4 / 4.x socket differences in
one place (outputs.py builds the groups that show a result)."""


def add_socket(group, name, in_out, socket_type):
    if hasattr(group, "interface"):  # Blender 4.0+
        return group.interface.new_socket(name, in_out=in_out, socket_type=socket_type).identifier
    return (group.inputs if in_out == "INPUT" else group.outputs).new(socket_type, name).identifier


def output(node, name=None):
    # Blender 3.4 lists one socket per data type on these nodes; the enabled one is ours.
    return [o for o in node.outputs if o.enabled and (name is None or o.name == name)][0]


def input_of(node, name):
    return [i for i in node.inputs if i.enabled and i.name == name][0]


class Builder:
    """A few nodes at a time, with the 3.4/4.x socket differences in one place."""

    def __init__(self, group):
        self.nodes, self.links = group.nodes, group.links
        self.source, self.sink = self.nodes.new("NodeGroupInput"), self.nodes.new("NodeGroupOutput")

    def node(self, kind, **settings):
        node = self.nodes.new(kind)
        for name, value in settings.items():
            setattr(node, name, value)
        return node

    def link(self, a, b):
        self.links.new(a, b)

    def named(self, name, data_type="FLOAT_VECTOR"):
        node = self.node("GeometryNodeInputNamedAttribute", data_type=data_type)
        node.inputs["Name"].default_value = name
        return output(node, "Attribute")

    def viewport_or_render(self, viewport, render, data_type="VECTOR"):
        switch = self.node("GeometryNodeSwitch", input_type=data_type)
        condition, if_false, if_true = [i for i in switch.inputs if i.enabled]
        self.link(output(self.node("GeometryNodeIsViewport")), condition)
        self.link(render, if_false)
        self.link(viewport, if_true)
        return output(switch)

    def count_matches(self, geometry, count):
        """True when `geometry` has `count` points (a single value)."""
        size = self.node("GeometryNodeAttributeDomainSize", component="MESH")
        self.link(geometry, size.inputs[0])
        compare = self.node("FunctionNodeCompare", data_type="INT", operation="EQUAL")
        self.link(output(size, "Point Count"), input_of(compare, "A"))
        self.link(count, input_of(compare, "B"))
        return output(compare)

    def drop(self, geometry, names):
        """geometry without the attributes `names`."""
        for name in names:
            remove = self.node("GeometryNodeRemoveAttribute")
            remove.inputs["Name"].default_value = name
            self.link(geometry, remove.inputs["Geometry"])
            geometry = remove.outputs[0]
        return geometry

"""Shape keys and their drivers copied from one mesh object to another: the source's key blocks,
the target's key block to write, a key's settings and its value driver (variables retargeted from
the source's shape keys to the target's). Nothing here is particular to deformation transfer."""
import numpy as np

from ..errors import EntryError
from ..shapekeys import block_points


def source_key_blocks(obj):
    """The source's shape keys to transfer: every key block but the reference key."""
    key = obj.data.shape_keys
    blocks = [] if key is None else [b for b in key.key_blocks if b != key.reference_key]
    if not blocks:
        raise EntryError(f"the source '{obj.name}' has no shape keys to transfer (besides its basis)")
    return key, blocks


def block_points_of(block, count):
    return block_points(block, count).astype(np.float64)


def ensure_basis(obj):
    """The target's shape keys, with a Basis made from the mesh when it has none (its vertex
    positions stay as they are)."""
    if obj.data.shape_keys is None:
        obj.shape_key_add(name="Basis", from_mix=False)
    return obj.data.shape_keys


def output_block(target, name, replace):
    """The target's key block to write `name` into: the one of that name with replace (never the
    reference key), else a new one (Blender makes its name unique: "Smile.001")."""
    key = target.data.shape_keys
    existing = key.key_blocks.get(name)
    if existing is not None and replace and existing != key.reference_key:
        return existing
    return target.shape_key_add(name=name, from_mix=False)


def write_points(block, points):
    block.data.foreach_set("co", np.ascontiguousarray(points, np.float32).ravel())


def copy_key_settings(source_block, block, target):
    """Slider range, value, mute, interpolation and vertex group (where the target has one of that
    name) of the source key; the relative key is set once every key exists."""
    block.slider_min, block.slider_max = source_block.slider_min, source_block.slider_max
    block.value = source_block.value
    block.mute = source_block.mute
    block.interpolation = source_block.interpolation
    group = source_block.vertex_group
    block.vertex_group = group if group and target.vertex_groups.get(group) is not None else ""


def fcurves(anim_data):
    """The F-curves of an ID's action: Action.fcurves up to Blender 4.x, the assigned slot's
    channel bag from 4.4 (layered actions; 5.0 has only that)."""
    action = anim_data.action if anim_data is not None else None
    if action is None:
        return None
    if hasattr(action, "fcurves"):
        return action.fcurves
    for layer in action.layers:  # as bpy_extras.anim_utils.action_get_channelbag_for_slot
        for strip in layer.strips:
            bag = strip.channelbag(anim_data.action_slot)
            if bag is not None:
                return bag.fcurves
    return None


def block_path(name):
    return f'key_blocks["{_escaped(name)}"]'


def _escaped(name):
    return name.replace("\\", "\\\\").replace('"', '\\"')


def remove_driver(key, name):
    ad = key.animation_data
    if ad is not None and ad.drivers.find(block_path(name) + ".value") is not None:
        key.driver_remove(block_path(name) + ".value")


def retargeted(id_, path, source, target):
    """A driver variable's (ID, data path) with the source's own shape keys replaced by the
    target's (the Key, the object's data.shape_keys, the mesh's shape_keys), key names kept."""
    if id_ is None:
        return id_, path
    key = source.data.shape_keys
    if id_ == key:
        return target.data.shape_keys, path
    if id_ == source and path.startswith("data.shape_keys"):
        return target, path
    if id_ == source.data and path.startswith("shape_keys"):
        return target.data, path
    return id_, path


def copy_driver(source, target, source_name, target_name):
    """The source key's value driver, if any, onto the target key: type, expression, variables
    (retargeted), the F-curve's points and modifiers. Returns True when there was one."""
    ad = source.data.shape_keys.animation_data
    fcurve = None if ad is None else ad.drivers.find(block_path(source_name) + ".value")
    tkey = target.data.shape_keys
    remove_driver(tkey, target_name)
    if fcurve is None:
        return False
    copy = tkey.key_blocks[target_name].driver_add("value")
    driver, given = copy.driver, fcurve.driver
    driver.type, driver.use_self = given.type, given.use_self
    driver.expression = given.expression
    for var in given.variables:
        new = driver.variables.new()
        new.name, new.type = var.name, var.type
        for i, t in enumerate(var.targets):
            out = new.targets[i]
            if var.type == "SINGLE_PROP":
                out.id_type = t.id_type
            id_, path = retargeted(t.id, t.data_path, source, target)
            out.id = id_
            out.data_path = path
            for attr in ("bone_target", "transform_type", "transform_space", "rotation_mode", "context_property"):
                if hasattr(t, attr):
                    setattr(out, attr, getattr(t, attr))
    for mod in list(copy.modifiers):
        copy.modifiers.remove(mod)
    for mod in fcurve.modifiers:
        if mod.type == "GENERATOR":
            new = copy.modifiers.new("GENERATOR")
            new.mode, new.use_additive, new.poly_order = mod.mode, mod.use_additive, mod.poly_order
            new.coefficients = tuple(mod.coefficients)
    for point in fcurve.keyframe_points:
        new = copy.keyframe_points.insert(point.co[0], point.co[1])
        new.interpolation = point.interpolation
        new.handle_left_type, new.handle_right_type = point.handle_left_type, point.handle_right_type
        new.handle_left, new.handle_right = point.handle_left, point.handle_right
    return True

"""Helpers for the add-on tests: meshes and twins with Blender's own modifier."""
import math
import os
import pathlib

import numpy as np

REPO = pathlib.Path(__file__).resolve().parents[2]
IN_BLENDER_BINARY = os.environ.get("DEFORMKIT_IN_BLENDER") == "1"


def evaluated(obj):
    """What Blender shows: the depsgraph's result, read without asking the add-on to re-evaluate,
    so that property updates and app handlers are what keeps it current."""
    import bpy
    from deformkit_addon import evaluation
    return evaluation.evaluated_positions(obj, bpy.context.evaluated_depsgraph_get())


def close(a, b, scale=1.0):
    return np.abs(a - b).max() <= 2e-6 * max(scale, 1.0)


def update():
    import bpy
    bpy.context.view_layer.update()


def positions(mesh):
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def make_object(bpy, name="Obj", location=(0.3, -0.2, 0.5)):
    """An off-centre UV sphere, stretched along z, with a vertex group over its upper half."""
    bpy.ops.mesh.primitive_uv_sphere_add(segments=24, ring_count=16, location=location)
    obj = bpy.context.active_object
    obj.name = name
    co = positions(obj.data)
    co[:, 2] *= 1.8
    co[:, 0] += 0.2 * co[:, 2]
    obj.data.vertices.foreach_set("co", co.ravel())
    obj.data.update()
    group = obj.vertex_groups.new(name="Upper")
    for v in obj.data.vertices:
        if v.co.z > -0.5:
            group.add([v.index], min(1.0, (v.co.z + 0.5) / 2.0), "REPLACE")
    return obj


def make_tube(bpy, name="Tube", segments=16, rings=20, length=3.0, radius=0.5, location=(0.4, -0.3, 0.2),
              rotation=(0.3, -0.2, 0.5), scale=(1.2, 1.2, 1.2)):
    """A closed bumpy tube along z (quads, a 16-gon at the bottom, a triangle fan on top: every
    kind of polygon) with vertex groups "Bottom" (the two lowest rings) and "Top" (the two highest
    rings and the top's centre), turned and placed off the origin."""
    z = np.linspace(0.0, length, rings)
    theta = 2 * np.pi * np.arange(segments) / segments
    r = radius * (1 + 0.15 * np.sin(3 * theta)[None, :] * np.sin(np.pi * z / length)[:, None])
    co = np.stack([r * np.cos(theta), r * np.sin(theta), np.repeat(z[:, None], segments, 1)], -1).reshape(-1, 3)
    co = np.vstack([co, [(0.0, 0.0, length + 0.2)]])
    ring = np.arange(rings * segments).reshape(rings, segments)
    faces = [(a, b, c, d) for i in range(rings - 1) for a, b, c, d in
             zip(ring[i], np.roll(ring[i], -1), np.roll(ring[i + 1], -1), ring[i + 1])]
    faces.append(tuple(ring[0][::-1]))
    top = len(co) - 1
    faces += [(a, b, top) for a, b in zip(ring[-1], np.roll(ring[-1], -1))]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(co.tolist(), [], [tuple(int(i) for i in f) for f in faces])
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    obj.location, obj.rotation_euler, obj.scale = location, rotation, scale
    bpy.context.view_layer.objects.active = obj
    obj.vertex_groups.new(name="Bottom").add(ring[:2].ravel().tolist(), 1.0, "REPLACE")
    obj.vertex_groups.new(name="Top").add(ring[-2:].ravel().tolist() + [top], 1.0, "REPLACE")
    bpy.context.view_layer.update()
    return obj


def group_members(obj, name):
    """Indices of the vertices in vertex group `name` with a weight above 0."""
    index = obj.vertex_groups[name].index
    return np.array([v.index for v in obj.data.vertices if any(g.group == index and g.weight > 0 for g in v.groups)])


def polygons(mesh):
    return [list(p.vertices) for p in mesh.polygons]


def in_blenders_order(mesh, subdivided, level, **settings):
    """Points of dk's subdivision of mesh (its polygons) to `level`, in dk's order, renumbered as
    Blender's Subdivision Surface (and so the Subdivide entry) numbers them."""
    import deformkit as dk
    edges = np.empty(len(mesh.edges) * 2, np.int32)
    mesh.edges.foreach_get("vertices", edges)
    vertex = dk.Subdivider(positions(mesh), polygons(mesh), level, **settings).blender_order(edges.reshape(-1, 2))[0]
    out = np.empty_like(subdivided)
    out[vertex] = subdivided
    return out


def twin_with_simple_deform(bpy, obj, **settings):
    """A copy of obj with Blender's own Simple Deform modifier and the same settings."""
    twin = obj.copy()
    twin.data = obj.data.copy()
    twin.name = obj.name + "_blender"
    bpy.context.scene.collection.objects.link(twin)
    twin.deformkit.entries.clear()
    for mod in list(twin.modifiers):
        twin.modifiers.remove(mod)
    mod = twin.modifiers.new("SimpleDeform", "SIMPLE_DEFORM")
    for key, value in settings.items():
        setattr(mod, key, value)
    return twin


def make_lattice(bpy, name="Lattice", resolution=(3, 4, 2), location=(0.35, -0.15, 0.6),
                 rotation=(0.2, -0.1, 0.4), scale=(3.4, 3.0, 4.8), interpolation="KEY_BSPLINE"):
    """A turned, scaled Lattice object at rest around (by default: containing) make_object's
    sphere. The resolution is set once the object exists, as in the UI, so the rest grid spans
    [-1/2, 1/2]; that resize leaves co_deform an ulp off co here and there, so the points are then
    put exactly at rest."""
    data = bpy.data.lattices.new(name)
    lat = bpy.data.objects.new(name, data)
    data.points_u, data.points_v, data.points_w = resolution
    data.points.foreach_set("co_deform", lattice_points(lat, "co").ravel())
    for axis in "uvw":
        setattr(data, f"interpolation_type_{axis}", interpolation)
    bpy.context.scene.collection.objects.link(lat)
    lat.location, lat.rotation_euler, lat.scale = location, rotation, scale
    bpy.context.view_layer.update()
    return lat


def lattice_points(lat, prop="co_deform"):
    co = np.empty(len(lat.data.points) * 3, np.float32)
    lat.data.points.foreach_get(prop, co)
    return co.reshape(-1, 3)


def perturb_lattice(lat, amount=0.15, seed=0):
    """Move every point of the lattice by a random offset in lattice-local space."""
    rng = np.random.default_rng(seed)
    co = lattice_points(lat, "co")
    co += rng.uniform(-amount, amount, co.shape).astype(np.float32)
    lat.data.points.foreach_set("co_deform", co.ravel())
    lat.data.update_tag()
    return co


def bare_twin(bpy, obj):
    """A linked copy of obj's object and mesh with no deformkit entries, modifiers or attributes:
    the base mesh, for Blender's own modifiers to work on."""
    twin = obj.copy()
    twin.data = obj.data.copy()
    twin.name = obj.name + "_blender"
    bpy.context.scene.collection.objects.link(twin)
    twin.deformkit.entries.clear()
    for mod in list(twin.modifiers):
        twin.modifiers.remove(mod)
    for name in [a.name for a in twin.data.attributes if a.name.startswith("deformkit_")]:
        twin.data.attributes.remove(twin.data.attributes[name])
    return twin


def twin_with_lattice_modifier(bpy, obj, lattice, **settings):
    """A copy of obj with Blender's own Lattice modifier on `lattice` and the same settings."""
    twin = bare_twin(bpy, obj)
    mod = twin.modifiers.new("Lattice", "LATTICE")
    mod.object = lattice
    for key, value in settings.items():
        setattr(mod, key, value)
    return twin


# The FFD formulas written out, as an independent check of the lattice entries' other bases.

def bernstein(n, s):
    i = np.arange(n + 1)
    return np.array([math.comb(n, k) for k in i]) * s[:, None] ** i * (1 - s[:, None]) ** (n - i)


def axis_weights(basis, count, s):
    """(n, count) weights of the control points along one axis at parameters s in [0, 1]."""
    w = np.zeros((len(s), count))
    if basis == "BERNSTEIN":
        return bernstein(count - 1, s)
    if basis == "BEZIER":
        blocks = (count - 1) // 3
        b = np.minimum(np.floor(s * blocks), blocks - 1).astype(int)
        local = bernstein(3, s * blocks - b)
        for r in range(4):
            w[np.arange(len(s)), 3 * b + r] = local[:, r]
        return w
    x = s * (count - 1)  # uniform cubic B-spline over control points spaced 1 apart
    k = np.clip(np.floor(x - 1), 0, count - 4).astype(int)
    t = x - 1 - k
    local = np.stack([(1 - t) ** 3, 3 * t ** 3 - 6 * t ** 2 + 4, -3 * t ** 3 + 3 * t ** 2 + 3 * t + 1, t ** 3], 1) / 6
    for r in range(4):
        w[np.arange(len(s)), k + r] = local[:, r]
    return w


def ffd_reference(obj, lat, basis):
    """The free-form deformation written out: lattice coordinates from the lattice's frame, then
    each vertex moved by the weighted offsets co_deform - co, turned into the object's space."""
    nu, nv, nw = lat.data.points_u, lat.data.points_v, lat.data.points_w
    frame = np.array(obj.matrix_world.inverted() @ lat.matrix_world)
    x = positions(obj.data).astype(np.float64)
    local = (x - frame[:3, 3]) @ np.linalg.inv(frame[:3, :3]).T
    s = local + 0.5
    assert s.min() > 0 and s.max() < 1
    if basis == "BSPLINE":  # inside the inner domain, where the B-spline needs no clamping
        for axis, n in enumerate((nu, nv, nw)):
            assert s[:, axis].min() > 1 / (n - 1) and s[:, axis].max() < (n - 2) / (n - 1)
    offsets = (lattice_points(lat) - lattice_points(lat, "co")).astype(np.float64)
    grid = offsets.reshape(nw, nv, nu, 3)  # Blender's order: u fastest
    wu, wv, ww = (axis_weights(basis, n, s[:, a]) for a, n in enumerate((nu, nv, nw)))
    moved = np.einsum("pi,pj,pk,kjia->pa", wu, wv, ww, grid)
    return x + moved @ frame[:3, :3].T


def lattice_box(obj, lat):
    """(min, max) corners of the lattice's box in obj's local space."""
    frame = np.array(obj.matrix_world.inverted() @ lat.matrix_world)
    corners = np.array([(x, y, z) for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    local = corners @ frame[:3, :3].T + frame[:3, 3]
    return local.min(axis=0), local.max(axis=0)


def select_vertices(obj, indices):
    """Select these vertices only (edges and faces too, or edit mode would select more)."""
    mesh = obj.data
    flags = np.zeros(len(mesh.vertices), bool)
    flags[list(indices)] = True
    mesh.vertices.foreach_set("select", flags)
    for items in (mesh.edges, mesh.polygons):
        for item in items:
            item.select = all(flags[v] for v in item.vertices)


def to_world(obj, local):
    m = np.array(obj.matrix_world)
    return local @ m[:3, :3].T + m[:3, 3]


# The add-on's panels drawn without a window.

class CheckingLayout:
    """Stands in for bpy.types.UILayout (there is no window here): records what is drawn and
    fails on a property, operator, operator setting, menu or icon that Blender does not know."""

    def __init__(self, log):
        self.log, self.alert, self.active, self.enabled, self.use_property_split = log, False, True, True, False

    def _icon(self, icon):
        import bpy
        icons = bpy.types.UILayout.bl_rna.functions["label"].parameters["icon"].enum_items
        assert icon in icons, icon

    def row(self, **_kw):
        return CheckingLayout(self.log)

    column = box = row

    def separator(self, **_kw):
        pass

    def context_pointer_set(self, name, value):
        pass

    def label(self, text="", icon="NONE"):
        self._icon(icon)
        self.log.append(("label", text))

    def prop(self, data, name, icon="NONE", **_kw):
        self._icon(icon)
        assert name in data.bl_rna.properties, name
        self.log.append(("prop", name))

    def prop_search(self, data, name, search_data, search_name, **_kw):
        assert name in data.bl_rna.properties and search_name in search_data.bl_rna.properties
        self.log.append(("prop", name))

    def menu(self, idname, icon="NONE", **_kw):
        import bpy
        self._icon(icon)
        assert hasattr(bpy.types, idname), idname

    def operator(self, idname, icon="NONE", **_kw):
        import bpy
        self._icon(icon)
        module, name = idname.split(".")
        rna = getattr(getattr(bpy.ops, module), name).get_rna_type()
        self.log.append(("operator", idname))

        class Settings:
            def __setattr__(self, key, value):
                assert key in rna.properties, (idname, key)

        return Settings()

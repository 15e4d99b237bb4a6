"""The stacks of tests/addon/data/saved_by_0.1.0.blend: the parameters it was saved with, shared by
the script that made it (data/make_saved_by_0_1_0.py, run once with the add-on of release 0.1.0)
and by the test that opens it with today's add-on (test_saved_blend.py).

Every entry kind is here with settings off their defaults, so that a renamed property, a changed
default or a lost data path shows as a difference. Objects are named, not referenced: the
test looks them up in the opened file.
"""
BLEND = "saved_by_0.1.0.blend"
POSITIONS = "saved_by_0.1.0.npz"   # the evaluated positions the 0.1.0 add-on saved, per object and frame
FRAMES = (1, 11)                   # frame 1: as saved; frame 11: between the keyframes, the driver moved

# (type, parameters): every parameter is set on the entry when the file is made.
STACKS = {
    "Barrs": [
        ("TWIST", dict(name="Twist Upper", angle=1.1, deform_axis="Z", limits=(0.1, 0.9), lock_x=True,
                       vertex_group="Upper", invert_vertex_group=True)),
        ("BEND", dict(name="Bend", angle=0.7, deform_axis="X", origin="Origin", limits=(0.0, 0.8))),
        ("TAPER", dict(name="Taper", factor=-0.4, deform_axis="Z", lock_y=True, show_render=False)),
        ("STRETCH", dict(name="Stretch", factor=0.3, deform_axis="Y", limits=(0.2, 1.0), vertex_group="Upper")),
    ],
    "Latticed": [
        ("LATTICE", dict(name="Cage", lattice="Cage", lattice_basis="BERNSTEIN", strength=0.8, outside="UNCHANGED",
                         vertex_group="Upper")),
    ],
    "Arm": [
        ("TAPER", dict(name="Thin", factor=0.2, deform_axis="Z")),
        ("LAPLACIAN", dict(name="Reach", method="ARAP", weights="COTANGENT", iterations=6, anchors_group="Bottom",
                           handles_group="Top", handle_target="OBJECT", handle_object="Hand")),
    ],
    "Smooth": [
        ("TWIST", dict(name="Twist", angle=0.9, deform_axis="Z")),
        ("SUBDIVIDE", dict(name="Subdivide", levels=1, render_levels=2, scheme="CATMULL_CLARK",
                           boundary_smooth="PRESERVE_CORNERS", use_creases=False, uv_smooth="NONE",
                           use_limit_surface=False, sharpen_two_edge_vertices=False)),
    ],
}
VOLUME_COLORS = {"Barrs": True}  # show_volume_ratio on these stacks

# Animation: keyframes (data path -> ((frame, value), ...)) and drivers (data path -> simple
# expression, which Blender evaluates without running Python, so also with auto-run off).
KEYFRAMES = {
    "Barrs": {"deformkit.entries[0].angle": ((1, 0.4), (21, 1.6))},
    "Latticed": {"deformkit.entries[0].strength": ((1, 0.8), (21, 0.3))},
}
DRIVERS = {
    "Barrs": {"deformkit.entries[2].factor": "frame / 40 - 0.5"},
    "Smooth": {"deformkit.entries[0].angle": "frame / 10"},
}


def driven_value(expression, frame):
    """The value of one of DRIVERS' expressions at `frame`."""
    return eval(expression, {"__builtins__": {}}, {"frame": float(frame)})  # noqa: S307 (our own constants)


def keyed_value(keys, frame):
    """Blender's default Bezier keyframes with automatic-clamped handles between two keys: the
    ease in-out curve v0 + (v1 - v0) * (3 t^2 - 2 t^3) with t the fraction of the way (flat
    tangents at both ends, so the Bezier's x(t) is linear and y(t) is the smoothstep)."""
    (f0, v0), (f1, v1) = keys
    t = min(max((frame - f0) / (f1 - f0), 0.0), 1.0)
    return v0 + (v1 - v0) * (3 * t * t - 2 * t ** 3)

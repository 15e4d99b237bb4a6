"""Data: the per-object deformkit stack and its entries, stored as RNA so that they save with the
file, undo, and can be keyframed and driven (data path `deformkit.entries[i].<param>`)."""
import math

import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty,
                       FloatVectorProperty, IntProperty, PointerProperty, StringProperty)

# Laplacian entries come with their issue. No icons: the Type row shows text only, like Simple
# Deform's, and stays readable in a narrow editor.
ENTRY_TYPES = [
    ("TWIST", "Twist", "Rotate around the deform axis (Barr's twist)", "NONE", 0),
    ("BEND", "Bend", "Bend around the deform axis (Barr's bend)", "NONE", 1),
    ("TAPER", "Taper", "Scale linearly along the deform axis (Barr's taper)", "NONE", 2),
    ("STRETCH", "Stretch", "Stretch along the deform axis (Blender's stretch)", "NONE", 3),
    ("LATTICE", "Lattice", "Free-form deformation by a Lattice object, edited with Blender's lattice tools",
     "NONE", 4),
]
AXES = [("X", "X", ""), ("Y", "Y", ""), ("Z", "Z", "")]
LATTICE_BASES = [
    ("BLENDER", "Blender", "Blender's Lattice modifier, with the lattice's own interpolation settings", 0),
    ("BERNSTEIN", "Bernstein", "Sederberg-Parry FFD: one Bernstein polynomial of degree points - 1 per axis", 1),
    ("BEZIER", "Bezier Blocks", "Piecewise tricubic Bezier blocks: 3k + 1 points per axis (4, 7, 10, ...)", 2),
    ("BSPLINE", "B-Spline", "Uniform cubic B-spline FFD (C2): at least 4 points per axis", 3),
]
OUTSIDE = [
    ("CLAMP", "Clamp", "Points outside the lattice move with its nearest boundary point, as in Blender", 0),
    ("UNCHANGED", "Unchanged", "Points outside the lattice do not move", 1),
    ("EXTRAPOLATE", "Extrapolate", "Continue the polynomial pieces outside the lattice (not with the Blender basis)",
     2),
]


def _changed(self, context):
    from . import evaluation
    evaluation.request_update(self.id_data)


def _origin_changed(self, context):
    # Remember the name so that a later deletion can be told apart from "no origin".
    self.origin_name = self.origin.name if self.origin else ""
    _changed(self, context)


def _lattice_changed(self, context):
    self.lattice_name = self.lattice.name if self.lattice else ""
    _changed(self, context)


def _is_lattice(self, obj):
    return obj.type == "LATTICE"


class DEFORMKIT_PG_entry(bpy.types.PropertyGroup):
    name: StringProperty(name="Name", default="Twist")
    type: EnumProperty(name="Type", items=ENTRY_TYPES, default="TWIST", update=_changed)
    show_viewport: BoolProperty(name="Viewport", description="Display in the viewport", default=True,
                                update=_changed)
    show_render: BoolProperty(name="Render", description="Use in renders", default=True, update=_changed)
    show_expanded: BoolProperty(name="Expanded", default=True, description="Show the entry's settings")
    angle: FloatProperty(name="Angle", subtype="ANGLE", default=math.radians(45.0), update=_changed,
                         description="Twist or bend angle over the limited extent (as Simple Deform)")
    factor: FloatProperty(name="Factor", default=0.785398, soft_min=-10.0, soft_max=10.0, update=_changed,
                          description="Taper or stretch amount (as Simple Deform)")
    deform_axis: EnumProperty(name="Axis", items=AXES, default="X", update=_changed)
    origin: PointerProperty(name="Origin", type=bpy.types.Object, update=_origin_changed,
                            description="Object whose frame places the deformation")
    origin_name: StringProperty(options={"HIDDEN"})
    limits: FloatVectorProperty(name="Limits", size=2, default=(0.0, 1.0), min=0.0, max=1.0, precision=2,
                                update=_changed, description="Lower and upper limits as fractions of the extent")
    lock_x: BoolProperty(name="Lock X", update=_changed)
    lock_y: BoolProperty(name="Lock Y", update=_changed)
    lock_z: BoolProperty(name="Lock Z", update=_changed)
    lattice: PointerProperty(name="Lattice", type=bpy.types.Object, poll=_is_lattice, update=_lattice_changed,
                             description="Lattice object whose points deform the mesh (edit it in its edit mode)")
    lattice_name: StringProperty(options={"HIDDEN"})
    lattice_basis: EnumProperty(name="Basis", items=LATTICE_BASES, default="BLENDER", update=_changed,
                                description="The functions that blend the lattice points")
    strength: FloatProperty(name="Strength", default=1.0, min=0.0, max=1.0, update=_changed,
                            description="How far the mesh follows the lattice (as the Lattice modifier)")
    outside: EnumProperty(name="Outside", items=OUTSIDE, default="CLAMP", update=_changed,
                          description="What happens to points outside the lattice")
    vertex_group: StringProperty(name="Vertex Group", update=_changed)
    invert_vertex_group: BoolProperty(name="Invert", update=_changed)
    error: StringProperty(options={"HIDDEN", "SKIP_SAVE"})

    @property
    def amount(self):
        """The one value Simple Deform uses: the angle for twist and bend, the factor otherwise."""
        return self.angle if self.type in {"TWIST", "BEND"} else self.factor


class DEFORMKIT_PG_stack(bpy.types.PropertyGroup):
    entries: CollectionProperty(type=DEFORMKIT_PG_entry)
    active_index: IntProperty(name="Active Entry")
    show_volume_ratio: BoolProperty(
        name="Volume Colors", default=False, update=_changed,
        description="Write a color attribute with det(J), stretch red and compression blue "
                    "(shown with Viewport Shading > Color > Attribute)")
    error: StringProperty(options={"HIDDEN", "SKIP_SAVE"})


classes = (DEFORMKIT_PG_entry, DEFORMKIT_PG_stack)


def register():
    bpy.types.Object.deformkit = PointerProperty(type=DEFORMKIT_PG_stack)


def unregister():
    del bpy.types.Object.deformkit

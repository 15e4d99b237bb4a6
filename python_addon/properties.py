"""Data: the per-object deformkit stack and its entries, stored as RNA so that they save with the
file, undo, and can be keyframed and driven (data path `deformkit.entries[i].<param>`).

One PropertyGroup holds the properties of every entry kind: their names, types and defaults are
the saved data paths, so they stay as they are; each kind (entries/) declares which it uses."""
import math

import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty,
                       FloatVectorProperty, IntProperty, IntVectorProperty, PointerProperty, StringProperty)

from . import entries, outputs
from .entries import barr, laplacian
# Each kind's enum tables are its own (entries/): the properties below take their items from there.
from .entries.barr import AXES
from .entries.cage import CAGE_METHODS
from .entries.laplacian import HANDLE_TARGETS, SURFACE_METHODS, SURFACE_WEIGHTS
from .entries.lattice import LATTICE_BASES, OUTSIDE
from .entries.rbf import CONTROL_USE, REST_FROM, RBF_KERNELS, RBF_POLYNOMIALS
from .entries.subdivide import BOUNDARY_SMOOTH, SCHEMES, UV_SMOOTH

# The Type enum: every kind's rows, in the registry's order. No icons: the Type row shows text
# only, like Simple Deform's, and stays readable in a narrow editor.
ENTRY_TYPES = entries.ENTRY_TYPES


# What a property update calls with the object whose stack changed: evaluation.request_update, set at
# registration (handlers.register), None before, so that properties need not import evaluation.
on_change = None


def _changed(self, context):
    if on_change is not None:
        on_change(self.id_data)


def _origin_changed(self, context):
    # Remember the name so that a later deletion can be told apart from "no origin".
    self.origin_name = self.origin.name if self.origin else ""
    _changed(self, context)


def _lattice_changed(self, context):
    self.lattice_name = self.lattice.name if self.lattice else ""
    _changed(self, context)


def _cage_changed(self, context):
    self.cage_name = self.cage.name if self.cage else ""
    _changed(self, context)


def _controls_changed(self, context):
    self.controls_name = self.controls.name if self.controls else ""
    _changed(self, context)


def _rest_object_changed(self, context):
    self.rest_object_name = self.rest_object.name if self.rest_object else ""
    _changed(self, context)


def _not_self(self, obj):
    """The object pickers list neither the entry's own object nor the helper objects the add-on
    writes (a result in Edit Mode, a Subdivide entry's meshes): they are not the user's to pick."""
    return obj != self.id_data and not outputs.is_helper_object(obj) and not entries.is_helper(obj)


def _is_other_mesh(self, obj):
    return obj.type == "MESH" and _not_self(self, obj)


def _is_lattice(self, obj):
    return obj.type == "LATTICE"


def _type_changed(self, context):
    entries.type_changed(self)  # the kinds it is not drop what they kept on it (a Laplacian bind)
    _changed(self, context)


def _handle_object_changed(self, context):
    previous, self.handle_object_name = self.handle_object_name, self.handle_object.name if self.handle_object else ""
    if laplacian.is_bound(self) and self.handle_object is not None and self.handle_object.name != previous:
        laplacian.record_handle_matrix(self)  # another object: its place now is its place at bind
    _changed(self, context)


class DEFORMKIT_PG_entry(bpy.types.PropertyGroup):
    name: StringProperty(name="Name", default="Twist")
    type: EnumProperty(name="Type", items=ENTRY_TYPES, default="TWIST", update=_type_changed,
                       description="What the entry does: one of Simple Deform's modes (Twist, Bend, Taper, "
                                   "Stretch), a lattice, Laplacian surface editing or subdivision")
    show_viewport: BoolProperty(name="Viewport", description="Display in the viewport", default=True,
                                update=_changed)
    show_render: BoolProperty(name="Render", description="Use in renders", default=True, update=_changed)
    show_expanded: BoolProperty(name="Expanded", default=True, description="Show the entry's settings")
    # Simple Deform's Edit Mode and On Cage toggles (one modifier shows the stack: see outputs.follow_toggles).
    show_in_editmode: BoolProperty(name="Edit Mode", default=True, update=_changed,
                                   description="Display the entry in Edit Mode")
    show_on_cage: BoolProperty(name="On Cage", default=False, update=_changed,
                               description="Adjust the edit cage to the entry's result")
    # Simple Deform's soft range (±360°) and drag step.
    angle: FloatProperty(name="Angle", subtype="ANGLE", default=math.radians(45.0), update=_changed,
                         soft_min=-2 * math.pi, soft_max=2 * math.pi, step=10,
                         description="Twist or bend angle over the limited extent (as Simple Deform)")
    factor: FloatProperty(name="Factor", default=0.785398, soft_min=-10.0, soft_max=10.0, update=_changed,
                          description="Taper or stretch amount (as Simple Deform)")
    deform_axis: EnumProperty(name="Axis", items=AXES, default="X", update=_changed,
                              description="Deform around local axis (of the origin object, if set)")
    origin: PointerProperty(name="Origin", type=bpy.types.Object, poll=_not_self, update=_origin_changed,
                            description="Object whose frame places the deformation")
    origin_name: StringProperty(options={"HIDDEN"})
    limits: FloatVectorProperty(name="Limits", size=2, default=(0.0, 1.0), min=0.0, max=1.0, precision=2,
                                update=_changed, description="Lower and upper limits as fractions of the extent")
    lock_x: BoolProperty(name="Lock X", update=_changed, description="Do not allow deformation along the X axis")
    lock_y: BoolProperty(name="Lock Y", update=_changed, description="Do not allow deformation along the Y axis")
    lock_z: BoolProperty(name="Lock Z", update=_changed, description="Do not allow deformation along the Z axis")
    lattice: PointerProperty(name="Lattice", type=bpy.types.Object, poll=_is_lattice, update=_lattice_changed,
                             description="Lattice object whose points deform the mesh (edit it in its edit mode)")
    lattice_name: StringProperty(options={"HIDDEN"})
    lattice_basis: EnumProperty(name="Basis", items=LATTICE_BASES, default="BLENDER", update=_changed,
                                description="The functions that blend the lattice points")
    strength: FloatProperty(name="Strength", default=1.0, min=0.0, max=1.0, update=_changed,
                            description="How far the mesh follows the lattice (as the Lattice modifier)")
    outside: EnumProperty(name="Outside", items=OUTSIDE, default="CLAMP", update=_changed,
                          description="What happens to points outside the lattice")
    preserve_volume: BoolProperty(name="Preserve Volume", default=False,
                                  description="Move Selection To keeps the volume of the mesh under the lattice "
                                              "(the mesh must be closed)")
    vertex_group: StringProperty(name="Vertex Group", update=_changed,
                                 description="Vertex group whose weights scale the entry's effect per vertex "
                                             "(none: every vertex fully)")
    invert_vertex_group: BoolProperty(name="Invert", update=_changed, description="Invert vertex group influence")
    # Laplacian entries
    method: EnumProperty(name="Method", items=SURFACE_METHODS, default="ARAP", update=_changed,
                         description="How the surface keeps its shape")
    weights: EnumProperty(name="Weights", items=SURFACE_WEIGHTS, default="COTANGENT", update=_changed,
                          description="The Laplacian's edge weights")
    iterations: IntProperty(name="Iterations", default=10, min=1, max=1000, update=_changed,
                            description="ARAP's local/global steps, or the rotation-invariant method's "
                                        "rotation passes, per evaluation (more: closer to rigid under large "
                                        "rotations, slower)")
    anchors_group: StringProperty(name="Anchors", update=_changed,
                                  description="Vertex group of the vertices that stay where they were at bind "
                                              "(weight above 0)")
    handles_group: StringProperty(name="Handles", update=_changed,
                                  description="Vertex group of the vertices that move to the targets "
                                              "(weight above 0)")
    handle_target: EnumProperty(name="Targets", items=HANDLE_TARGETS, default="INCOMING", update=_changed,
                                description="Where the handles go")
    handle_object: PointerProperty(name="Handle Object", type=bpy.types.Object, poll=_not_self,
                                   update=_handle_object_changed,
                                   description="Object whose motion since bind moves the handles")
    handle_object_name: StringProperty(options={"HIDDEN"})
    # The bind (see entries/laplacian.py); the rest itself is the entry's ID property "deformkit_rest".
    bind_id: IntProperty(options={"HIDDEN"})  # 0: not bound
    bind_vertices: IntProperty(options={"HIDDEN"})
    bind_faces: IntProperty(options={"HIDDEN"})
    bind_topology: IntProperty(options={"HIDDEN"})
    # What changed since bind when the bind no longer fits ("bound to 8 000 vertices, the mesh now
    # has 32 000: Rebind"), '' while it fits: the panel offers Rebind beside it (entries/binding.py).
    bind_outdated: StringProperty(options={"HIDDEN", "SKIP_SAVE"})
    handle_matrix: FloatVectorProperty(size=16, options={"HIDDEN"},
                                       default=[float(i % 5 == 0) for i in range(16)])
    # Subdivide entries, with the Subdivision Surface modifier's names
    levels: IntProperty(name="Levels Viewport", default=1, min=0, max=8, soft_max=6, update=_changed,
                        description="Number of subdivisions to perform in the viewport (0: the cage)")
    render_levels: IntProperty(name="Render", default=2, min=0, max=8, soft_max=6, update=_changed,
                               description="Number of subdivisions to perform when rendering")
    # Catmull-Clark on every mesh, all-triangle ones too, as Blender's modifier (Auto picks Loop there).
    scheme: EnumProperty(name="Scheme", items=SCHEMES, default="CATMULL_CLARK", update=_changed,
                         description="Subdivision rules")
    boundary_smooth: EnumProperty(name="Boundary Smooth", items=BOUNDARY_SMOOTH, default="ALL",
                                  update=_changed, description="Controls how open boundaries are smoothed")
    use_creases: BoolProperty(name="Use Creases", default=True, update=_changed,
                              description="Use mesh crease information to sharpen edges or corners")
    uv_smooth: EnumProperty(name="UV Smooth", items=UV_SMOOTH, default="PRESERVE_BOUNDARIES", update=_changed,
                            description="Controls how smoothing is applied to UVs (the active UV map)")
    use_limit_surface: BoolProperty(name="Use Limit Surface", default=True, update=_changed,
                                    description="Place vertices at the surface that would be produced with infinite "
                                                "levels of subdivision (exact limit points: Blender's at a Quality "
                                                "of at least the level)")
    sharpen_two_edge_vertices: BoolProperty(name="Sharpen Two-Edge Vertices", default=True, update=_changed,
                                            description="A vertex with exactly two edges takes the smaller of their "
                                                        "creases, so creased borders keep their corners (what "
                                                        "Blender's Subdivision Surface does)")
    # The helper objects holding the subdivided meshes (see entries/subdivide.py); render: None when the same.
    subdivision_viewport: PointerProperty(type=bpy.types.Object, options={"HIDDEN"})
    subdivision_render: PointerProperty(type=bpy.types.Object, options={"HIDDEN"})
    # Cage entries (the bind uses bind_id, bind_vertices, bind_faces and bind_topology, of the cage,
    # and the ID property "deformkit_cage_rest": see entries/cage.py)
    cage: PointerProperty(name="Cage", type=bpy.types.Object, poll=_is_other_mesh, update=_cage_changed,
                          description="Closed mesh object around the mesh whose shape deforms it (as Mesh Deform's "
                                      "Object)")
    cage_name: StringProperty(options={"HIDDEN"})
    # A static Harmonic bind's points and coordinates, on a mesh datablock of their own (entries/saved_rows.py)
    harmonic_rows: PointerProperty(type=bpy.types.Mesh, options={"HIDDEN"})
    cage_method: EnumProperty(name="Method", items=CAGE_METHODS, default="MEAN_VALUE", update=_changed,
                              description="The coordinates that tie the mesh to the cage")
    # The Harmonic method's, with the Mesh Deform modifier's names, defaults and range (read at Bind).
    precision: IntProperty(name="Precision", default=5, min=2, max=10, update=_changed,
                           description="The grid size (2^Precision + 2 cells a side) for the harmonic coordinates: "
                                       "higher is closer to true harmonic coordinates, binds slower")
    use_dynamic_bind: BoolProperty(name="Dynamic", default=False, update=_changed,
                                   description="Recompute the binding as the mesh coming into the entry changes "
                                               "(slower), as Mesh Deform's Dynamic")
    # RBF entries (the bind uses bind_id and bind_vertices, the control object's vertex count, and
    # the ID properties "deformkit_rbf_rest" and "deformkit_rbf_indices": see entries/rbf.py)
    controls: PointerProperty(name="Controls", type=bpy.types.Object, poll=_is_other_mesh, update=_controls_changed,
                              description="Mesh object whose vertices are the control points: the mesh follows them "
                                          "from their rest positions to where they are (edits, shape keys, hooks, "
                                          "armatures and modifiers count)")
    controls_name: StringProperty(options={"HIDDEN"})
    controls_use: EnumProperty(name="Use", items=CONTROL_USE, default="ALL", update=_changed,
                               description="Which of the control object's vertices are control points (taken at "
                                           "bind)")
    controls_group: StringProperty(name="Control Group", update=_changed,
                                   description="Vertex group of the control object whose vertices are the control "
                                               "points (taken at bind)")
    rest_from: EnumProperty(name="Rest From", items=REST_FROM, default="CURRENT", update=_changed,
                            description="Where the controls' rest positions come from (taken at bind)")
    rest_object: PointerProperty(name="Rest Object", type=bpy.types.Object, poll=_is_other_mesh,
                                 update=_rest_object_changed,
                                 description="Mesh object with the control object's vertex count whose vertices are "
                                             "the controls' rest positions (taken at bind)")
    rest_object_name: StringProperty(options={"HIDDEN"})
    rest_shape_key: StringProperty(name="Rest Shape Key", update=_changed,
                                   description="Shape key of the control object whose positions are the controls' "
                                               "rest (taken at bind)")
    kernel: EnumProperty(name="Kernel", items=RBF_KERNELS, default="THIN_PLATE_SPLINE", update=_changed,
                         description="The radial function that spreads each control's motion (dk.RBF's kernel)")
    # min 2^-10, a float32 exactly (the batch's schema reads it from here): dk.RBF needs > 0.
    epsilon: FloatProperty(name="Epsilon", default=1.0, min=0.0009765625, soft_min=0.01, soft_max=100.0, update=_changed,
                           description="Shape parameter (scipy's epsilon): the kernel is taken at epsilon times the "
                                       "distance, so larger is narrower")
    radius: FloatProperty(name="Radius", default=1.0, min=0.0009765625, soft_max=100.0, subtype="DISTANCE", update=_changed,
                          description="Support radius, in this object's space: a control moves nothing farther "
                                      "than this from it")
    polynomial: EnumProperty(name="Polynomial", items=RBF_POLYNOMIALS, default="LINEAR", update=_changed,
                             description="The polynomial added to the kernel sum (dk.RBF's degree), which the fit "
                                         "reproduces exactly")
    smoothing: FloatProperty(name="Smoothing", default=0.0, min=0.0, soft_max=1.0, precision=4, update=_changed,
                             description="0: every control lands exactly on its target; above 0 the fit is "
                                         "smoother and only near them (scipy's smoothing)")
    error: StringProperty(options={"HIDDEN", "SKIP_SAVE"})
    # Closed by default, as a modifier's subpanels (Simple Deform's Restrictions) are.
    show_restrictions: BoolProperty(name="Restrictions", default=False,
                                    description="Show the limits, locks and vertex group")
    # A Laplacian entry copied to another mesh (Copy to Selected) arrives unbound: a bind belongs
    # to the mesh it was made on. The name of that object, until the copy is bound.
    bind_copied_from: StringProperty(options={"HIDDEN"})

    @property
    def amount(self):
        """The one value Simple Deform uses: the angle for twist and bend, the factor otherwise."""
        return barr.amount(self)


class DEFORMKIT_PG_smoothness(bpy.types.PropertyGroup):
    """The figures of the last Check Smoothness, for the panel."""
    checked: BoolProperty(options={"HIDDEN"})
    max_angle: FloatProperty(name="Max Angle", subtype="ANGLE", options={"HIDDEN"},
                             description="Largest angle between the limit surface's normals across an edge")
    max_gap: FloatProperty(name="Max Gap", options={"HIDDEN"},
                           description="Largest gap between the two sides of an edge, per bounding-box diagonal")
    degenerate: IntProperty(name="Degenerate", options={"HIDDEN"},
                            description="Samples where the surface's tangents are parallel")
    flipped: IntProperty(name="Flipped", options={"HIDDEN"},
                         description="Samples whose normal points against the control face's normal")
    worst_edge: IntVectorProperty(name="Worst Edge", size=2, default=(-1, -1), options={"HIDDEN"},
                                  description="Vertices of the edge with the largest angle")
    selected: IntProperty(name="Selected", options={"HIDDEN"}, description="Edges selected as creased")


class DEFORMKIT_PG_stack(bpy.types.PropertyGroup):
    entries: CollectionProperty(type=DEFORMKIT_PG_entry)
    active_index: IntProperty(name="Active Entry")
    show_volume_ratio: BoolProperty(
        name="Volume Colors", default=False, update=_changed,
        description="Write a color attribute with det(J), stretch red and compression blue "
                    "(shown with Viewport Shading > Color > Attribute). Laplacian entries are left out: "
                    "they have no Jacobian")
    smoothness: PointerProperty(type=DEFORMKIT_PG_smoothness)
    error: StringProperty(options={"HIDDEN", "SKIP_SAVE"})
    notice: StringProperty(options={"HIDDEN", "SKIP_SAVE"})  # what the add-on did on its own (evaluation.modifier_gone)


classes = (DEFORMKIT_PG_entry, DEFORMKIT_PG_smoothness, DEFORMKIT_PG_stack)


def register():
    bpy.types.Object.deformkit = PointerProperty(type=DEFORMKIT_PG_stack)


def unregister():
    del bpy.types.Object.deformkit

"""Operators: thin wrappers around `api` with poll, undo and reports."""
import bpy
import numpy as np
from bpy.props import EnumProperty, FloatProperty, IntProperty, IntVectorProperty

from . import api, native
from .properties import ENTRY_TYPES, LATTICE_BASES


def _mesh_object(context):
    obj = context.object
    return obj if obj is not None and obj.type == "MESH" else None


class _EntryOperator:
    bl_options = {"REGISTER", "UNDO"}
    index: IntProperty(name="Index", default=-1, options={"SKIP_SAVE"})

    @classmethod
    def poll(cls, context):
        obj = _mesh_object(context)
        return obj is not None and len(obj.deformkit.entries) > 0

    def entry_index(self, context):
        return self.index if self.index >= 0 else context.object.deformkit.active_index


class DEFORMKIT_OT_entry_add(bpy.types.Operator):
    """Add a deformkit entry to the active object's stack"""
    bl_idname = "deformkit.entry_add"
    bl_label = "Add deformkit Entry"
    bl_options = {"REGISTER", "UNDO"}
    type: EnumProperty(name="Type", items=ENTRY_TYPES)

    @classmethod
    def poll(cls, context):
        if not native.available():
            cls.poll_message_set(native.IMPORT_ERROR)
            return False
        return _mesh_object(context) is not None

    def execute(self, context):
        try:
            api.add_entry(context.object, self.type)
        except ValueError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        return {"FINISHED"}


class DEFORMKIT_OT_entry_remove(_EntryOperator, bpy.types.Operator):
    """Remove the entry"""
    bl_idname = "deformkit.entry_remove"
    bl_label = "Remove deformkit Entry"

    def execute(self, context):
        api.remove_entry(context.object, self.entry_index(context))
        return {"FINISHED"}


class DEFORMKIT_OT_entry_move(_EntryOperator, bpy.types.Operator):
    """Move the entry up or down in the stack"""
    bl_idname = "deformkit.entry_move"
    bl_label = "Move deformkit Entry"
    direction: EnumProperty(items=[("UP", "Up", ""), ("DOWN", "Down", "")])

    def execute(self, context):
        try:
            api.move_entry(context.object, self.entry_index(context), -1 if self.direction == "UP" else 1)
        except IndexError:
            return {"CANCELLED"}
        return {"FINISHED"}


class DEFORMKIT_OT_entry_apply(_EntryOperator, bpy.types.Operator):
    """Apply the entry: bake its deformation into the mesh and remove it"""
    bl_idname = "deformkit.entry_apply"
    bl_label = "Apply deformkit Entry"

    @classmethod
    def poll(cls, context):
        if not super().poll(context):
            return False
        if context.object.mode == "EDIT":
            cls.poll_message_set("Leave edit mode to apply")
            return False
        return True

    def execute(self, context):
        try:
            warning = api.apply(context.object, self.entry_index(context))
        except ValueError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        if warning:
            self.report({"INFO"}, warning)
        return {"FINISHED"}


class DEFORMKIT_OT_add_lattice(bpy.types.Operator):
    """Add a Lattice object fitted to the mesh (to the selected vertices in edit mode) and a Lattice entry using it"""
    bl_idname = "object.deformkit_add_lattice"
    bl_label = "Add Fitted Lattice"
    bl_options = {"REGISTER", "UNDO"}
    resolution: IntVectorProperty(name="Resolution", size=3, default=(4, 4, 4), min=1, max=64,
                                  description="Points along u, v and w")
    basis: EnumProperty(name="Basis", items=LATTICE_BASES, default="BLENDER")

    @classmethod
    def poll(cls, context):
        return DEFORMKIT_OT_entry_add.poll(context)

    def execute(self, context):
        obj = context.object
        try:
            entry = api.add_lattice(obj, tuple(self.resolution), self.basis, selected_only=obj.mode == "EDIT")
        except ValueError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        self.report({"INFO"}, f"Added '{entry.lattice.name}': edit its points in its edit mode")
        return {"FINISHED"}


class _LatticeOperator:
    """Acts on a Lattice entry: the given one, or the active mesh's active (else first) Lattice
    entry, or, with a Lattice object active, the entry that uses it (on a selected mesh first)."""
    bl_options = {"REGISTER", "UNDO"}
    index: IntProperty(name="Index", default=-1, options={"SKIP_SAVE"})

    @classmethod
    def poll(cls, context):
        if not native.available():
            cls.poll_message_set(native.IMPORT_ERROR)
            return False
        obj = context.object
        if obj is not None and (obj.type == "LATTICE" or (
                obj.type == "MESH" and any(e.type == "LATTICE" for e in obj.deformkit.entries))):
            return True
        cls.poll_message_set("Needs a mesh with a Lattice entry, or a Lattice object")
        return False

    def target_entry(self, context):
        obj = context.object
        if obj.type == "LATTICE":
            users = api.lattice_users(obj)
            if not users:
                raise ValueError(f"lattice '{obj.name}' is not used by any deformkit entry")
            selected = set(context.selected_objects)
            return ([u for u in users if u[0] in selected] or users)[0]
        entries = obj.deformkit.entries
        if self.index >= 0:
            return obj, self.index
        active = obj.deformkit.active_index
        if 0 <= active < len(entries) and entries[active].type == "LATTICE":
            return obj, active
        return obj, [e.type for e in entries].index("LATTICE")

    def execute(self, context):
        try:
            return self.run(context)
        except (ValueError, IndexError) as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}


class DEFORMKIT_OT_lattice_bind(_LatticeOperator, bpy.types.Operator):
    """Bind the mesh to the lattice again (also done by itself when either changes)"""
    bl_idname = "object.deformkit_lattice_bind"
    bl_label = "Bind to Lattice"

    def run(self, context):
        obj, index = self.target_entry(context)
        if obj.mode == "EDIT":
            raise ValueError("bind: leave the mesh's edit mode first")
        bound = api.bind_lattice(obj, index)
        self.report({"INFO"}, f"Bound '{obj.name}': {bound.inside} vertices inside the lattice, "
                              f"{bound.outside} outside")
        return {"FINISHED"}


class DEFORMKIT_OT_lattice_reset(_LatticeOperator, bpy.types.Operator):
    """Move every point of the lattice back to its rest position"""
    bl_idname = "object.deformkit_lattice_reset"
    bl_label = "Reset Lattice"

    def run(self, context):
        if context.object.type == "LATTICE":
            lattice = context.object
        else:
            obj, index = self.target_entry(context)
            lattice = api.lattice_entry(obj, index).lattice
            if lattice is None:
                raise ValueError("the entry has no lattice object")
        api.reset_lattice(lattice)
        return {"FINISHED"}


class DEFORMKIT_OT_lattice_direct(_LatticeOperator, bpy.types.Operator):
    """Move the lattice's points so that the mesh's selected vertices reach the targets"""
    bl_idname = "object.deformkit_lattice_direct"
    bl_label = "Move Lattice to Targets"
    targets: EnumProperty(name="Targets", items=[
        ("CURSOR", "3D Cursor", "Move the selected vertices' centroid to the 3D cursor"),
        ("EMPTIES", "Selected Empties", "Pull, for each selected empty, the nearest selected vertex to it"),
    ])

    def run(self, context):
        obj, index = self.target_entry(context)
        if obj.mode == "EDIT":
            obj.update_from_editmode()  # the selection lives in edit mode's own copy
        selected = np.zeros(len(obj.data.vertices), bool)
        obj.data.vertices.foreach_get("select", selected)
        if not selected.any():
            raise ValueError(f"no vertices of '{obj.name}' are selected: select them in its edit mode")
        empties = [o for o in context.selected_objects if o.type == "EMPTY"]
        vertices, targets = api.manipulation_targets(obj, index, np.flatnonzero(selected), self.targets,
                                                     cursor=context.scene.cursor.location, empties=empties)
        result = api.direct_manipulation(obj, index, vertices, targets)
        if result.max_residual > 1e-5 * max(1.0, *obj.dimensions):
            self.report({"WARNING"}, f"Targets not all reached: up to {result.max_residual:.3g} away (more "
                                     "constraints than the lattice's points allow, or vertices outside it)")
        else:
            self.report({"INFO"}, f"Moved {len(vertices)} vertices to their targets "
                                  f"(within {result.max_residual:.2g})")
        return {"FINISHED"}


class _LaplacianOperator:
    """Acts on a Laplacian entry of the active mesh: the given one, else the active entry if it is
    one, else the first."""
    bl_options = {"REGISTER", "UNDO"}
    index: IntProperty(name="Index", default=-1, options={"SKIP_SAVE"})

    @classmethod
    def poll(cls, context):
        if not native.available():
            cls.poll_message_set(native.IMPORT_ERROR)
            return False
        obj = _mesh_object(context)
        if obj is None or not any(e.type == "LAPLACIAN" for e in obj.deformkit.entries):
            cls.poll_message_set("Needs a mesh with a Laplacian entry")
            return False
        if obj.mode == "EDIT":
            cls.poll_message_set("Leave edit mode first")
            return False
        return True

    def target_index(self, context):
        entries = context.object.deformkit.entries
        if self.index >= 0:
            return self.index
        active = context.object.deformkit.active_index
        if 0 <= active < len(entries) and entries[active].type == "LAPLACIAN":
            return active
        return [e.type for e in entries].index("LAPLACIAN")

    def execute(self, context):
        try:
            return self.run(context.object, self.target_index(context))
        except (ValueError, IndexError) as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}


class DEFORMKIT_OT_laplacian_bind(_LaplacianOperator, bpy.types.Operator):
    """Record the mesh as it comes into the entry as the rest shape, and prepare the solver"""
    bl_idname = "object.deformkit_laplacian_bind"
    bl_label = "Bind"

    def run(self, obj, index):
        count = api.bind_laplacian(obj, index)
        self.report({"INFO"}, f"Bound '{obj.deformkit.entries[index].name}': {count} vertices")
        return {"FINISHED"}


class DEFORMKIT_OT_laplacian_unbind(_LaplacianOperator, bpy.types.Operator):
    """Forget the rest shape: the entry passes the mesh through until bound again"""
    bl_idname = "object.deformkit_laplacian_unbind"
    bl_label = "Unbind"

    def run(self, obj, index):
        api.unbind_laplacian(obj, index)
        return {"FINISHED"}


class DEFORMKIT_OT_check_smoothness(bpy.types.Operator):
    """Check the limit surface of the cage (as the entries above any Subdivide entry leave it): select creased edges"""
    bl_idname = "object.deformkit_check_smoothness"
    bl_label = "Check Smoothness"
    bl_options = {"REGISTER", "UNDO"}  # the selection changes
    worst: IntProperty(name="Worst Edges", default=10, min=1, max=100000,
                       description="How many of the edges with the largest angles to consider for selection")
    min_angle: FloatProperty(name="Minimum Angle", subtype="ANGLE", default=1e-6, min=0.0, precision=6,
                             description="Select the worst edges whose angle exceeds this (smooth: rounding only)")

    @classmethod
    def poll(cls, context):
        return DEFORMKIT_OT_entry_add.poll(context)

    def execute(self, context):
        try:
            figures = api.check_smoothness(context.object, worst=self.worst, min_angle=self.min_angle)
        except ValueError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        edge = figures["worst_edge"]
        where = f" at edge {tuple(edge)}" if edge else ""
        self.report({"WARNING" if figures["selected_edges"] else "INFO"},
                    f"Max normal angle {figures['max_angle_degrees']:.3g}°{where}; gap {figures['max_gap']:.2g}, "
                    f"{figures['degenerate_samples']} degenerate, {figures['flipped_samples']} flipped samples; "
                    f"{len(figures['selected_edges'])} creased edges selected")
        return {"FINISHED"}


classes = (DEFORMKIT_OT_entry_add, DEFORMKIT_OT_entry_remove, DEFORMKIT_OT_entry_move, DEFORMKIT_OT_entry_apply,
           DEFORMKIT_OT_add_lattice, DEFORMKIT_OT_lattice_bind, DEFORMKIT_OT_lattice_reset,
           DEFORMKIT_OT_lattice_direct, DEFORMKIT_OT_laplacian_bind, DEFORMKIT_OT_laplacian_unbind,
           DEFORMKIT_OT_check_smoothness)

"""The Lattice entry's operators: Add Fitted Lattice (in the Add menu), Bind, Reset, Move Lattice
to Targets and Select Folded Lattice Cells (named by bl_idname in the entry's panel)."""
import bpy
import numpy as np
from bpy.props import EnumProperty, IntVectorProperty

from .. import api
from ..properties import LATTICE_BASES
from .base import EntryOperator, Operator, core_missing, mesh_object


class DEFORMKIT_OT_add_lattice(Operator, bpy.types.Operator):
    """Add a Lattice object fitted to the mesh (to the selected vertices in edit mode) and a Lattice entry using it"""
    bl_idname = "deformkit.add_lattice"
    bl_label = "Add Fitted Lattice"
    resolution: IntVectorProperty(name="Resolution", size=3, default=(4, 4, 4), min=1, max=64,
                                  description="Points along u, v and w")
    basis: EnumProperty(name="Basis", items=LATTICE_BASES, default="BLENDER")

    @classmethod
    def poll(cls, context):
        return not core_missing(cls) and mesh_object(context) is not None

    def run(self, context):
        obj = context.object
        entry = api.add_lattice(obj, tuple(self.resolution), self.basis, selected_only=obj.mode == "EDIT")
        self.report({"INFO"}, f"Added '{entry.lattice.name}': edit its points in its edit mode")


class _LatticeOperator(EntryOperator):
    """Acts on a Lattice entry: the given one, or the active mesh's active (else first) Lattice
    entry, or, with a Lattice object active, the entry that uses it (on a selected mesh first)."""
    TYPES = ("LATTICE",)

    @classmethod
    def poll(cls, context):
        if core_missing(cls):
            return False
        obj = context.object
        if obj is not None and (obj.type == "LATTICE" or (obj.type == "MESH" and
                                                          any(cls.of_kind(e) for e in obj.deformkit.entries))):
            return True
        cls.poll_message_set("Needs a mesh with a Lattice entry, or a Lattice object")
        return False

    def target(self, context):
        obj = context.object
        if obj.type == "LATTICE":
            found = api.lattice_users(obj)
            if not found:
                raise ValueError(f"lattice '{obj.name}' is not used by any deformkit entry")
            selected = set(context.selected_objects)
            return ([u for u in found if u[0] in selected] or found)[0]
        return super().target(context)


class DEFORMKIT_OT_lattice_bind(_LatticeOperator, bpy.types.Operator):
    """Bind the mesh to the lattice again (also done by itself when either changes)"""
    bl_idname = "deformkit.lattice_bind"
    bl_label = "Bind to Lattice"

    def run(self, context):
        obj, index = self.target(context)
        if obj.mode == "EDIT":
            raise ValueError("bind: leave the mesh's edit mode first")
        bound = api.bind(obj, index)
        self.report({"INFO"}, f"Bound '{obj.name}': {bound.inside} vertices inside the lattice, "
                              f"{bound.outside} outside")


class DEFORMKIT_OT_lattice_reset(_LatticeOperator, bpy.types.Operator):
    """Move every point of the lattice back to its rest position"""
    bl_idname = "deformkit.lattice_reset"
    bl_label = "Reset Lattice"

    def run(self, context):
        if context.object.type == "LATTICE":
            lattice = context.object
        else:
            obj, index = self.target(context)
            lattice = api.lattice_entry(obj, index).lattice
            if lattice is None:
                raise ValueError("the entry has no lattice object")
        api.reset_lattice(lattice)


class DEFORMKIT_OT_lattice_direct(_LatticeOperator, bpy.types.Operator):
    """Move the lattice's points so that the mesh's selected vertices reach the targets"""
    bl_idname = "deformkit.lattice_direct"
    bl_label = "Move Lattice to Targets"
    targets: EnumProperty(name="Targets", items=[
        ("CURSOR", "3D Cursor", "Move the selected vertices' centroid to the 3D cursor"),
        ("EMPTIES", "Selected Empties", "Pull, for each selected empty, the nearest selected vertex to it"),
    ])

    def run(self, context):
        obj, index = self.target(context)
        if obj.mode == "EDIT":
            obj.update_from_editmode()  # the selection lives in edit mode's own copy
        selected = np.zeros(len(obj.data.vertices), bool)
        obj.data.vertices.foreach_get("select", selected)
        if not selected.any():
            raise ValueError(f"no vertices of '{obj.name}' are selected: select them in its edit mode")
        empties = [o for o in context.selected_objects if o.type == "EMPTY"]
        vertices, targets = api.manipulation_targets(obj, index, np.flatnonzero(selected), self.targets,
                                                     cursor=context.scene.cursor.location, empties=empties)
        preserve = obj.deformkit.entries[index].preserve_volume
        result = api.direct_manipulation(obj, index, vertices, targets, preserve_volume=preserve)
        if result.max_residual > 1e-5 * max(1.0, *obj.dimensions):
            self.report({"WARNING"}, f"Targets not all reached: up to {result.max_residual:.3g} away (more "
                                     "constraints than the lattice's points allow, or vertices outside it)")
        else:
            kept = f", volume kept to {result.volume_residual:.1g} relative" if preserve else ""
            self.report({"INFO"}, f"Moved {len(vertices)} vertices to their targets "
                                  f"(within {result.max_residual:.2g}{kept})")


class DEFORMKIT_OT_lattice_select_folded(_LatticeOperator, bpy.types.Operator):
    """Select the lattice points of the cells where the lattice folds (or may fold) where the mesh is, in the lattice's Edit Mode"""
    bl_idname = "deformkit.lattice_select_folded"
    bl_label = "Select Folded Lattice Cells"

    def run(self, context):
        obj, index = self.target(context)
        if obj.mode == "EDIT":
            with context.temp_override(object=obj, active_object=obj):
                bpy.ops.object.mode_set(mode="OBJECT")
        api.folded_control_points(obj, index)  # a ValueError before any mode changes
        lattice = api.lattice_entry(obj, index).lattice
        if lattice.mode != "EDIT":
            # Its Edit Mode first, so that the flags are set on the edit copy, which undo restores.
            context.view_layer.objects.active = lattice
            lattice.select_set(True)
            with context.temp_override(object=lattice, active_object=lattice):
                bpy.ops.object.mode_set(mode="EDIT")
        lattice, points = api.select_folded(obj, index)
        self.report({"INFO"}, f"{len(points)} points of '{lattice.name}' selected")


classes = (DEFORMKIT_OT_add_lattice, DEFORMKIT_OT_lattice_bind, DEFORMKIT_OT_lattice_reset,
           DEFORMKIT_OT_lattice_direct, DEFORMKIT_OT_lattice_select_folded)

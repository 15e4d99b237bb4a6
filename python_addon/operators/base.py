"""The one operator base: a ValueError or IndexError of `run` is the user's to read, reported on
the status bar, and cancels (the operator's undo step is then not pushed)."""
from bpy.props import IntProperty

from .. import api, native


def mesh_object(context):
    obj = context.object
    return obj if obj is not None and obj.type == "MESH" else None


def core_missing(operator):
    """True, with the reason as the operator's poll message, when the compiled core is missing."""
    if not native.available():
        operator.poll_message_set(native.IMPORT_ERROR)
        return True
    return False


def mesh_poll(operator, context, needs, accepts=lambda obj: True):
    """The poll of an operator on the active mesh object: the core is there, the object is a mesh
    that `accepts` (else `needs` is the poll message, if any), and it is not in Edit Mode, which
    holds its own copy of the mesh."""
    if core_missing(operator):
        return False
    obj = mesh_object(context)
    if obj is None or not accepts(obj):
        if needs:
            operator.poll_message_set(needs)
        return False
    if obj.mode == "EDIT":
        operator.poll_message_set("Leave edit mode first")
        return False
    return True


class Operator:
    """`run(context)` does the work and returns the operator's result set (None: FINISHED)."""
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        try:
            return self.run(context) or {"FINISHED"}
        except (ValueError, IndexError) as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}


class EntryOperator(Operator):
    """Acts on one entry: `index` if given, else the active entry if it is of TYPES (all types when
    empty), else the first entry of TYPES. Available on a mesh with such an entry; NEEDS is the poll
    message otherwise ("Needs a mesh with a Cage entry"); with OBJECT_MODE, not in Edit Mode."""
    index: IntProperty(name="Index", default=-1, options={"SKIP_SAVE"})
    TYPES = ()
    NEEDS = ""
    OBJECT_MODE = False  # not in Edit Mode, which holds its own copy of the mesh

    @classmethod
    def of_kind(cls, entry):
        return not cls.TYPES or entry.type in cls.TYPES

    @classmethod
    def poll(cls, context):
        if core_missing(cls):
            return False
        obj = mesh_object(context)
        if obj is None or not any(cls.of_kind(e) for e in obj.deformkit.entries):
            if cls.NEEDS:
                cls.poll_message_set(cls.NEEDS)
            return False
        if cls.OBJECT_MODE and obj.mode == "EDIT":
            cls.poll_message_set("Leave edit mode first")
            return False
        return True

    def target(self, context):
        """(mesh object, entry index) on the active mesh."""
        obj = context.object
        entries = obj.deformkit.entries
        if self.index >= 0:
            return obj, self.index
        active = obj.deformkit.active_index
        if 0 <= active < len(entries) and self.of_kind(entries[active]):
            return obj, active
        return obj, [self.of_kind(e) for e in entries].index(True)




class BindOperator(EntryOperator):
    """A kind's Bind button: api.bind on the entry, then REPORT, formatted with the object's name
    (`obj`), the entry's (`entry`) and what the kind's bind returned (`result`)."""
    REPORT = "Bound '{entry}'"

    def run(self, context):
        obj, index = self.target(context)
        result = api.bind(obj, index)
        self.report({"INFO"}, self.REPORT.format(obj=obj.name, entry=obj.deformkit.entries[index].name, result=result))


class UnbindOperator(EntryOperator):
    """A kind's Unbind button: api.unbind on the entry."""

    def run(self, context):
        api.unbind(*self.target(context))

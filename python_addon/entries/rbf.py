"""RBF entries: the vertices of a mesh object (the controls) move from their rest positions to
where they are now, and the mesh follows through radial basis function interpolation (dk.RBF, de
Boer, van der Schoot, Bijl 2007; docs/math/rbf.md).

Bind records which of the control object's vertices are controls (all, the selected ones or a
vertex group's) and their rest positions in this object's space: the control object's current
evaluated shape, another mesh object's (the body clothes were made for, fitted to the body they go
to), or one of its shape keys. Both are ID property arrays on the entry, as a Cage entry's rest, so
they save and undo with the object. Afterwards the targets are those vertices of the control
object's *evaluated* mesh: edits (in Edit Mode too), shape keys, hooks, an armature and modifiers
such as Displace drive the mesh, and moving the control object moves them.

Fitting (dk.RBF's construction) factorises the system: the RBF is kept while the bind, the kernel
settings and the influence stay, and an evaluation only assigns its targets (a back-substitution)
and deforms the mesh through a binding kept per incoming points (cache spaces "rbf_deformer" and
"rbf_binding").

Here too: the entry's settings and panel; its operators are in operators/rbf.py.
"""
import zlib
from collections import namedtuple

import numpy as np

from .. import cache, meshdata, native, panel_text
from ..errors import EntryError
from . import binding
from .binding import is_bound, new_bind_id
from .common import (Prepared, draw_vertex_group, evaluated_mesh_in, followed_mesh, followed_object,
                     forget_bindings, in_space_of, kept_binding, scaled_influence, store_array, weights_crc)

ENTRY_TYPES = [
    ("RBF", "RBF", "Radial basis functions: the vertices of a mesh object (the controls) move from their rest "
     "positions to where they are now, and the mesh follows smoothly (Bind first)", "NONE", 8),
]
TYPES = tuple(row[0] for row in ENTRY_TYPES)  # its entry.type identifiers
# The kernels are dk.RBF's, named as scipy.interpolate.RBFInterpolator names them (the identifier
# lowercased): docs/math/rbf.md, "Kernels".
RBF_KERNELS = [
    ("THIN_PLATE_SPLINE", "Thin Plate Spline", "The smoothest fit with the least bending between the controls "
     "(scipy's 'thin_plate_spline'); needs a Linear polynomial", 0),
    ("CUBIC", "Cubic", "Smooth, a little stiffer than Thin Plate Spline (scipy's 'cubic'); needs a Linear polynomial",
     1),
    ("QUINTIC", "Quintic", "Smoother still, swings wider between far-apart controls (scipy's 'quintic'); needs a "
     "Quadratic polynomial", 2),
    ("LINEAR", "Linear", "Straight between the controls, creased at them (scipy's 'linear'); needs a Constant "
     "polynomial", 3),
    ("GAUSSIAN", "Gaussian", "Each control pulls a bell-shaped region about 1/Epsilon wide (scipy's 'gaussian')", 4),
    ("MULTIQUADRIC", "Multiquadric", "Smooth and broad; Epsilon sets how round it is near the controls (scipy's "
     "'multiquadric'); needs a Constant polynomial", 5),
    ("INVERSE_MULTIQUADRIC", "Inverse Multiquadric", "Each control pulls a region about 1/Epsilon wide, fading "
     "slowly (scipy's 'inverse_multiquadric')", 6),
    ("INVERSE_QUADRATIC", "Inverse Quadratic", "Each control pulls a region about 1/Epsilon wide (scipy's "
     "'inverse_quadratic')", 7),
    ("WENDLAND_C0", "Wendland C0 (Compact)", "Each control moves only what is within Radius; creased at the "
     "controls (deformkit's 'wendland_c0', not in scipy)", 8),
    ("WENDLAND_C2", "Wendland C2 (Compact)", "Each control moves only what is within Radius; smooth (deformkit's "
     "'wendland_c2', not in scipy)", 9),
    ("WENDLAND_C4", "Wendland C4 (Compact)", "Each control moves only what is within Radius; smoother "
     "(deformkit's 'wendland_c4', not in scipy)", 10),
    ("CLIP", "Clip (Compact)", "The RBF note's (1 - distance/Radius)^2, equal to Wendland C0 (deformkit's 'clip', "
     "not in scipy)", 11),
]
RBF_POLYNOMIALS = [  # dk.RBF's (and scipy's) degree: -1, 0, 1, 2
    ("NONE", "None", "No polynomial term: with a Gaussian, inverse or compact kernel, what is far from every "
     "control does not move (degree -1)", 0),
    ("CONSTANT", "Constant", "Plus a common shift of every point (degree 0)", 1),
    ("LINEAR", "Linear", "Plus an affine map: any move, turn, scale or shear of all the controls together moves "
     "the mesh exactly so (degree 1; needs controls not all on a plane)", 2),
    ("QUADRATIC", "Quadratic", "Plus a quadratic map (degree 2; needs at least 10 controls not on one quadric)", 3),
]
CONTROL_USE = [
    ("ALL", "All Vertices", "Every vertex of the control object is a control point", 0),
    ("SELECTED", "Selected", "The vertices selected in the control object when Bind is pressed", 1),
    ("GROUP", "Vertex Group", "The vertices of a vertex group of the control object (weight above 0) when Bind is "
     "pressed", 2),
]
REST_FROM = [
    ("CURRENT", "Current Shape", "The control object's evaluated shape when Bind is pressed", 0),
    ("OBJECT", "Object", "Another mesh object with the same vertex count (e.g. the body the clothes were made for, "
     "the control object being the body they go to)", 1),
    ("SHAPE_KEY", "Shape Key", "A shape key of the control object (e.g. the Basis: the controls then move as the "
     "other keys move them)", 2),
]
ICON = "MOD_WARP"
FIELDS = ("controls", "controls_use", "controls_group", "rest_from", "rest_object", "rest_shape_key", "kernel",
          "epsilon", "radius", "polynomial", "smoothing", "strength", "vertex_group", "invert_vertex_group")

REST = "deformkit_rbf_rest"        # the controls at bind, x y z per control, float32, in this object's space
INDICES = "deformkit_rbf_indices"  # which of the control object's vertices they are
NOT_COPIED = binding.NOT_COPIED  # a copy arrives unbound

KERNEL_LABELS = {k[0]: k[1] for k in RBF_KERNELS}
DEGREES = {"NONE": -1, "CONSTANT": 0, "LINEAR": 1, "QUADRATIC": 2}
POLYNOMIAL_LABELS = {DEGREES[p[0]]: p[1] for p in RBF_POLYNOMIALS}
# The kernels taken at epsilon * r whose fit depends on epsilon (the others are scale-invariant up
# to their polynomial, docs/math/rbf.md "Kernels"), and those with a support radius.
SHAPED = ("GAUSSIAN", "MULTIQUADRIC", "INVERSE_MULTIQUADRIC", "INVERSE_QUADRATIC")
COMPACT = ("WENDLAND_C0", "WENDLAND_C2", "WENDLAND_C4", "CLIP")
# The least polynomial degree that makes each kernel's system solvable (conditionally positive
# definite kernels: docs/math/rbf.md, "Kernels"); dk.RBF refuses less, this names it in the panel.
MINIMUM_DEGREE = {"THIN_PLATE_SPLINE": 1, "CUBIC": 1, "QUINTIC": 2, "LINEAR": 0, "MULTIQUADRIC": 0}

# rbf: the dk.RBF with the current targets; bind: the key its bindings are kept under; fingerprint:
# everything besides the incoming points.
Setup = namedtuple("Setup", "rbf bind fingerprint")
# In the cache: "rbf_deformer", (object cache key, bind id) -> (fit settings, weights crc, dk.RBF);
# "rbf_binding", (object cache key, entry index, "viewport"/"render") -> (bind key (object cache
# key, bind id, kernel settings), points, binding).


def kernel_settings(entry):
    """dk.RBF's kernel, epsilon and radius for the entry (None where the kernel takes none)."""
    return (entry.kernel.lower(), entry.epsilon if entry.kernel in SHAPED else None,
            entry.radius if entry.kernel in COMPACT else None)


def degree_problem(entry):
    """Why the entry's polynomial is too low for its kernel, or ''."""
    least = MINIMUM_DEGREE.get(entry.kernel, -1)
    if DEGREES[entry.polynomial] >= least:
        return ""
    return (f"Polynomial: the {KERNEL_LABELS[entry.kernel]} kernel needs at least {POLYNOMIAL_LABELS[least]} "
            "(below it the fit can have no solution)")


UNSET = "no control object set: pick a mesh object whose vertices are the control points"
HINT = "Pick a mesh object whose vertices are the control points as Object, then Bind"


def control_object(entry, obj, unset=UNSET):
    return followed_mesh(entry, "controls", "control", obj, unset)


def saved(entry):
    """(rest (k, 3) float64, indices (k,) int64) recorded at bind."""
    return (np.asarray(entry[REST], np.float64).reshape(-1, 3), np.asarray(entry[INDICES], np.int64))


def _rbf(obj, entry, weights):
    """The entry's dk.RBF of its saved rest, kept while the bind, the fit settings and the
    per-point weights stay: constructing it fits and factorises the system."""
    if not hasattr(native.dk, "RBF"):
        raise EntryError(f"this build of deformkit has no RBF deformer: {native.BUILD_HINT}")
    problem = degree_problem(entry)
    if problem:
        raise EntryError(problem)
    kernel, epsilon, radius = kernel_settings(entry)
    settings = (kernel, epsilon, radius, DEGREES[entry.polynomial], entry.smoothing)
    key = (meshdata.cache_key(obj), entry.bind_id)
    crc = weights_crc(weights)
    cached = cache.get("rbf_deformer", key)
    if cached is not None and cached[:2] == (settings, crc):
        return cached[2], crc
    try:
        rbf = native.dk.RBF(saved(entry)[0], kernel=kernel, epsilon=epsilon, radius=radius, degree=settings[3],
                            smoothing=entry.smoothing, weights=weights)
    except ValueError as exc:  # dk names the reason: coincident controls, a singular system, ...
        raise EntryError(str(exc)) from exc
    cache.put("rbf_deformer", key, (settings, crc, rbf))
    return rbf, crc


def setup(obj, entry, reuse_weights=False):
    controls = control_object(entry, obj, unset="")  # none picked yet: a hint in the panel, as a Cage entry's
    if controls is None or not is_bound(entry) or REST not in entry:
        return Prepared(None, ("unbound",), None)  # as a Cage entry before Bind: the mesh passes through
    points = evaluated_mesh_in(obj, controls)[0]
    binding.require_current(entry, binding.counts_changed(f"the control object '{controls.name}'",
                                                          (entry.bind_vertices,), (len(points),)))
    targets = points[saved(entry)[1]]
    rbf, crc = _rbf(obj, entry, scaled_influence(obj, entry, reuse_weights))
    if not np.array_equal(rbf.targets, targets):
        rbf.targets = targets  # a solve with the kept factorisation
    bind_key = (meshdata.cache_key(obj), entry.bind_id) + kernel_settings(entry)
    fingerprint = (bind_key, DEGREES[entry.polynomial], entry.smoothing, zlib.crc32(targets.tobytes()), crc)
    return Prepared(rbf, fingerprint, Setup(rbf, bind_key, fingerprint))


def deform(key, prepared, points):
    """The entry's result on `points`, through a binding kept while the points and the kernel stay
    (for a compact kernel it holds the kernel values within the support)."""
    setup_ = prepared.data
    if setup_ is None:
        return points
    return setup_.rbf.deform_bound(kept_binding("rbf_binding", key, setup_.bind, points, setup_.rbf.bind))


def _chosen(controls, entry):
    """The indices of the control object's vertices that Use Selected or Use Vertex Group takes,
    from its mesh."""
    count = len(controls.data.vertices)
    if entry.controls_use == "SELECTED":
        flags = np.zeros(count, bool)
        controls.data.vertices.foreach_get("select", flags)
        chosen = np.flatnonzero(flags)
        if not len(chosen):
            raise ValueError(f"Use Selected: no vertex of '{controls.name}' is selected")
        return chosen
    if not entry.controls_group:
        raise ValueError("Use Vertex Group: no vertex group of the control object set")
    if controls.vertex_groups.get(entry.controls_group) is None:
        raise ValueError(f"Use Vertex Group: '{controls.name}' has no vertex group '{entry.controls_group}'")
    chosen = np.flatnonzero(meshdata.vertex_group_weights(controls, entry.controls_group) > 0)
    if not len(chosen):
        raise ValueError(f"Use Vertex Group: no vertex of '{controls.name}' is in '{entry.controls_group}'")
    return chosen


def _rest_points(obj, controls, entry, count):
    """All the control object's vertices at rest, in obj's space: (count, 3) float64."""
    if entry.rest_from == "CURRENT":
        return evaluated_mesh_in(obj, controls)[0]
    if entry.rest_from == "OBJECT":
        other = followed_object(entry, "rest_object", "rest", "Rest From Object: no rest object set")
        if other.type != "MESH":
            raise ValueError(f"Rest From Object: '{other.name}' is not a mesh object")
        rest = evaluated_mesh_in(obj, other)[0]
        if len(rest) != count:
            raise ValueError(f"Rest From Object: '{other.name}' has {len(rest)} vertices, the control object "
                             f"'{controls.name}' {count}: they need the same vertex count")
        return rest
    keys = controls.data.shape_keys
    block = keys.key_blocks.get(entry.rest_shape_key) if keys is not None else None
    if block is None:
        raise ValueError(f"Rest From Shape Key: '{controls.name}' has no shape key '{entry.rest_shape_key}'")
    co = np.empty(len(block.data) * 3, np.float32)
    block.data.foreach_get("co", co)
    if len(co) != 3 * count:
        raise ValueError(f"Rest From Shape Key: the control object's modifiers change its vertex count "
                         f"({len(co) // 3} in the mesh, {count} evaluated)")
    return in_space_of(obj, controls, co.reshape(-1, 3))


def bind(obj, entry, incoming):
    """Record the controls (indices) and their rest positions, checked by fitting them with the
    entry's settings; nothing changes if that fails (ValueError). Returns the number of controls.
    The points coming into the entry (incoming) play no part: they are bound as they come."""
    controls = control_object(entry, obj)
    if not hasattr(native.dk, "RBF"):
        raise ValueError(f"this build of deformkit has no RBF deformer: {native.BUILD_HINT}")
    if controls.mode == "EDIT":
        controls.update_from_editmode()  # its selection, groups and shape keys are in the edit mesh until then
    count = len(evaluated_mesh_in(obj, controls)[0])
    if entry.controls_use == "ALL":
        chosen = np.arange(count)
    elif count != len(controls.data.vertices):
        raise ValueError(f"Use {'Selected' if entry.controls_use == 'SELECTED' else 'Vertex Group'}: the control "
                         f"object's modifiers change its vertex count ({len(controls.data.vertices)} in the mesh, "
                         f"{count} evaluated), so its vertices cannot be picked; use All Vertices")
    else:
        chosen = _chosen(controls, entry)
    rest = _rest_points(obj, controls, entry, count)[chosen]
    problem = degree_problem(entry)
    if problem:
        raise ValueError(problem)
    kernel, epsilon, radius = kernel_settings(entry)
    native.dk.RBF(rest, kernel=kernel, epsilon=epsilon, radius=radius, degree=DEGREES[entry.polynomial],
                  smoothing=entry.smoothing)  # ValueError naming the reason: coincident controls, ...
    store_array(entry, REST, rest.astype(np.float32).ravel())
    store_array(entry, INDICES, chosen.astype(np.int32))
    entry.bind_vertices = count
    entry.bind_id = new_bind_id(obj)  # a new bind key: the old RBF and bindings are not used again
    return len(chosen)


def unbind(obj, entry):
    binding.forget(entry, (REST, INDICES))


def followed(entry):
    return [(entry.controls, entry.controls_name)]


# Keyed by the bind (bind_id) and checked against the fit's settings, the weights and the points:
# undo keeps them.
KEPT_THROUGH_UNDO = ("rbf_deformer", "rbf_binding")


def prune(object_key, entries):
    """The fits and bindings of binds no entry has any more go."""
    forget_bindings(object_key, "rbf_binding", entries, lambda e: (e.bind_id,) + kernel_settings(e))
    alive = {e.bind_id for e in entries}
    cache.forget(object_key, "rbf_deformer", keep=lambda k: k[1] in alive)


def retyped(entry):
    binding.forget(entry, (REST, INDICES))


def draw(col, obj, entry):
    """The controls and what of them Bind takes (greyed once bound), the fit, then Bind / Unbind."""
    index = list(obj.deformkit.entries).index(entry)
    controls = entry.controls
    col.prop(entry, "controls", text="Object")
    if controls is None and not entry.controls_name:
        panel_text.label_wrapped(col, HINT, "INFO", panel_text.box_budget())  # a label is cut
    at_bind = col.column()
    at_bind.enabled = not is_bound(entry)  # read at bind: Unbind to change them
    at_bind.prop(entry, "controls_use")
    if entry.controls_use == "GROUP":
        if controls is not None:
            at_bind.prop_search(entry, "controls_group", controls, "vertex_groups", text="Group")
        else:
            at_bind.prop(entry, "controls_group", text="Group")
    at_bind.prop(entry, "rest_from")
    if entry.rest_from == "OBJECT":
        at_bind.prop(entry, "rest_object", text="Object")
    elif entry.rest_from == "SHAPE_KEY":
        if controls is not None and controls.data.shape_keys is not None:
            at_bind.prop_search(entry, "rest_shape_key", controls.data.shape_keys, "key_blocks", text="Shape Key")
        else:
            at_bind.prop(entry, "rest_shape_key", text="Shape Key")
    col.separator()
    col.prop(entry, "kernel")
    if entry.kernel in SHAPED:
        col.prop(entry, "epsilon")
    if entry.kernel in COMPACT:
        col.prop(entry, "radius")
    row = col.row()
    row.alert = bool(degree_problem(entry))  # the message is on the entry
    row.prop(entry, "polynomial")
    col.prop(entry, "smoothing")
    col.prop(entry, "strength", slider=True)
    draw_vertex_group(col, obj, entry)
    col.separator()
    if is_bound(entry) and INDICES in entry:
        count = len(entry[INDICES])
        of = "" if count == entry.bind_vertices else f" of {entry.bind_vertices} vertices"
        col.label(text=f"Bound: {count} controls{of}", icon="LINKED")
        binding.draw_rebind(col, entry, "deformkit.rbf_bind", index, "deformkit.rbf_unbind")
    else:
        col.label(text="Not bound", icon="UNLINKED")
        col.operator("deformkit.rbf_bind", text="Bind", icon="LINKED").index = index

"""Running a planned stack (evaluation.py's run stage): the pointwise entries in order, for the
viewport and for renders, with the offsets written straight into the mesh's memory where they can
be; the volume ratio; then the topology-changing entry (a kind with LAST) on the deformed cage."""
import functools
from typing import NamedTuple, Optional

import numpy as np

from . import native, outputs
from .errors import EntryError


class Built(NamedTuple):
    """An entry that set up: where it is in the stack, the entry, its kind and its kind's setup."""
    index: int
    entry: object
    kind: object
    prepared: object  # common.Prepared


class Result(NamedTuple):
    """What running a plan gave."""
    viewport: np.ndarray  # the viewport's points; in place: already their offsets, in the mesh's memory
    render: Optional[np.ndarray]  # the renders' points (`viewport` itself when the same); None in place
    in_place: bool
    failures: dict  # {entry index: message} of the entries that failed on their input (skipped)
    pieces: Optional[list]  # [(deformers, their input)]: the volume ratio's factors; None without it
    ratio: Optional[np.ndarray] = None  # the volume ratio per point, or None
    finished: object = None  # the topology-changing entry's results (its kind's), or None


class EntryFailed(EntryError):
    """An entry that could not deform the points it was given (found while running the stack)."""

    def __init__(self, index, message):
        super().__init__(message)
        self.index = index


def shown(entry, kind, editing):
    """Whether the entry runs in the viewport (in Edit Mode: only with its Edit Mode toggle) or in renders."""
    if kind == "render":
        return entry.show_render
    return entry.show_viewport and (entry.show_in_editmode or not editing)


def run(obj, plan):
    """The viewport's and the renders' points (one array when the same entries run in both) of the
    plan's pointwise entries (evaluation.Plan). In the common case (own mesh, one result for viewport
    and render) the offsets are computed straight into the mesh's attribute
    (outputs.vector_attribute_memory), the cheapest hand-over. ValueError: the stack could not run."""
    viewport = [b for b in plan.built if shown(b.entry, "viewport", plan.editing)]
    render = [b for b in plan.built if shown(b.entry, "render", plan.editing)]
    pieces = [] if plan.volume_ratio and viewport else None
    failures = {}
    same = [b.index for b in render] == [b.index for b in viewport]
    in_place = same and plan.last is None and not plan.per_object and not plan.editing
    if in_place:
        into = functools.partial(outputs.vector_attribute_memory, obj.data, outputs.ATTR_OFFSET, len(plan.base))
        offsets = deformed(plan.uid, "viewport", viewport, plan.base, pieces, failures, offsets_into=into)
        return Result(offsets, None, True, failures, pieces)
    positions = deformed(plan.uid, "viewport", viewport, plan.base, pieces, failures)
    render_positions = positions if same else deformed(plan.uid, "render", render, plan.base, failures=failures)
    return Result(positions, render_positions, False, failures, pieces)


def finish(plan, result):
    """The result with the volume ratio and the topology-changing entry's results on the deformed
    cage (its failure skips it, as any entry's: the cage is shown)."""
    finished, last = None, plan.last
    if last is not None:
        try:
            finished = last.kind.results(plan.uid, last.prepared.data, result.viewport, result.render)
        except EntryError as exc:
            result.failures[last.index] = str(exc)
    return result._replace(ratio=volume_ratio(result.pieces, len(plan.base)), finished=finished)


def volume_ratio(pieces, count):
    """det J of the stack at `count` points, or None without pieces. Entries without a Jacobian
    (Laplacian) have none: the product of the others', each run at its own input."""
    if pieces is None:
        return None
    ratio = np.ones(count)
    for deformers, points in pieces:
        ratio *= native.dk.Stack(deformers).volume_ratio(points)
    return ratio


def deformed(uid, kind, built, base, pieces=None, failures=None, offsets_into=None):
    """Run the entries ([Built]) in order: runs of stackable (Barr) entries as one dk.Stack, each
    other entry through its kind (a lattice through its binding, kept per object, entry and
    viewport/render; a Laplacian entry through its solver). `pieces`, if a list, receives
    (deformers, their input) for each stretch of entries between those without a Jacobian: the
    factors of the volume ratio. `failures`, if a dict, receives {index: message} of the entries
    that failed on their input, which are skipped (their input goes on, as Blender skips a modifier
    that fails); without it the first failure raises EntryFailed.

    offsets_into: a function giving a float32 (n, 3) array (Blender's own attribute memory); with
    it, the result minus `base` is computed into that array and returned, the last step writing
    straight into it, with no temporary result and no copy (an entry deforming the base itself
    through its kind's displace: its offsets in one pass)."""
    points, pending, piece, piece_input = base, [], [], base
    out = None  # offsets_into's array, once asked for
    displaced = False  # the last entry wrote its offsets into it (its kind's displace)
    for position, b in enumerate(built):
        if b.kind.STACKABLE:
            pending.append(b.prepared.deformer)
            piece.append(b.prepared.deformer)
            continue
        if pending:
            points, pending = native.dk.Stack(pending).deform(points), []
        if b.prepared.deformer is None and pieces is not None and piece:  # no Jacobian: the piece ends here
            pieces.append((piece, piece_input))
        last = offsets_into is not None and position == len(built) - 1 and points.dtype == np.float32
        displace = last and points is base and b.kind.displace is not None  # its offsets, in one pass
        into = {}
        if last and (b.kind.DEFORMS_INTO or displace):
            out = offsets_into()
            into = {"out": out}
        try:
            key = (uid, b.index, kind)
            points = b.kind.displace(key, b.prepared, points, out) if displace else \
                b.kind.deform(key, b.prepared, points, **into)
        except EntryError as exc:
            if failures is None:
                raise EntryFailed(b.index, str(exc)) from exc
            failures.setdefault(b.index, str(exc))
            continue  # skipped: contributes no factor to the volume ratio either
        displaced = displace
        if b.prepared.deformer is None:
            piece, piece_input = [], points
        else:
            piece.append(b.prepared.deformer)
    if pieces is not None and piece:
        pieces.append((piece, piece_input))
    if offsets_into is not None:
        return out if displaced else _offsets(points, pending, base, out, offsets_into)
    if pending:
        points = native.dk.Stack(pending).deform(points)
    return base.copy() if points is base else points


def _one_pass_displacements():
    """The deformer types whose displacement is one pass of SIMD lanes (Barr's)."""
    dk = native.dk
    return (dk.BarrDeformer, dk.Twist, dk.Bend, dk.Taper, dk.Stretch, dk.SimpleDeform)


def _offsets(points, pending, base, out, offsets_into):
    """The end of `deformed` with offsets_into: the pending stack run on `points`, minus base,
    into offsets_into's array (`out` if already asked for). One Barr deformer on the base itself:
    its displacement, which the lanes write in one pass (F(x) - x exactly); otherwise deform then
    one numpy subtract, faster than the generic displacement's second pass (bridge_alternatives.py)."""
    if out is None:
        out = offsets_into()
    if (len(pending) == 1 and points is base and points.dtype == out.dtype
            and isinstance(pending[0], _one_pass_displacements())):
        return pending[0].displacement(points, out=out)
    if pending:
        points = native.dk.Stack(pending).deform(points, **({"out": out} if points.dtype == out.dtype else {}))
    return np.subtract(points, base, out=out, casting="same_kind")

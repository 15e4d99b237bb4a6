"""deformkit: shape deformation with exact Jacobians.

Every deformer shares one interface -- ``deform(points)``, ``jacobian(points)``,
``transform_normals(points, normals)``, ``volume_ratio(points)`` -- and deformers compose with
:class:`Stack`. Lattices (:class:`FFD`, :class:`BezierFFD`, :class:`BSplineLattice`,
:class:`BlenderLattice`, :class:`ExtendedFFD`) add ``bind(points)`` / ``deform_bound(binding)``
for deforming the same points again after their control points move, and
``direct_manipulation(points, targets)``. :meth:`SimpleDeform.bind` gives the fixed map (a
:class:`BarrDeformer`) that ``SimpleDeform.deform`` applies to given points, so that chunks of
them deform as the whole would. :func:`subdivide`, :class:`LimitSurface` and
:func:`smoothness_report` subdivide a (deformed) control mesh with OpenSubdiv and check that its
limit surface is smooth. :class:`MeanValueCage` deforms points with a closed polygon cage (mean
value coordinates, :class:`GreenCage` Green coordinates), with the lattices' ``bind`` /
``deform_bound``. :class:`RBF` moves any set of control points onto targets and everything else
with them (radial basis functions, scipy's kernels and compactly supported Wendland ones).
:class:`DeformationTransfer` carries a source mesh's poses onto a target mesh of the same
connectivity (Sumner and Popovic's deformation gradients).

>>> import numpy as np, deformkit as dk
>>> pts = np.random.rand(1000, 3)
>>> out = dk.Stack([dk.Twist(rate=1.0), dk.Bend(curvature=0.5)]).deform(pts)
"""

from . import _arguments, _core
from ._version import __version__  # generated into the wheel from pyproject.toml's version

_arguments.install(_core)  # refused calls name their argument

from ._core import (
    BarrDeformer,
    Bend,
    BezierFFD,
    BlenderLattice,
    BSplineLattice,
    CageBinding,
    CageDeformer,
    Deformer,
    DeformationTransfer,
    DirectManipulation,
    ExtendedFFD,
    FFD,
    FoldCertificate,
    GreenCage,
    Lattice,
    LimitSurface,
    LatticeBinding,
    MeanValueCage,
    MeshDeform,
    MeshDeformBinding,
    RBF,
    RBFBinding,
    SimpleDeform,
    SmoothnessReport,
    Stack,
    Stretch,
    SUBDIVISION_MAX_FACES,
    SUBDIVISION_MAX_LEVEL,
    SubdividedMesh,
    Subdivider,
    SurfaceDeformer,
    Taper,
    Twist,
    VolumeRatioBounds,
    build_info,
    cotangent_laplacian,
    extrapolated_start,
    generate_cage,
    mesh_volume,
    smoothness_report,
    subdivide,
)

__all__ = [
    "BSplineLattice", "BarrDeformer", "Bend", "BezierFFD", "BlenderLattice", "Deformer", "DirectManipulation", "ExtendedFFD",
    "FFD", "Lattice", "LatticeBinding", "SimpleDeform", "Stack", "Stretch", "Taper", "Twist", "build_info",
    "SurfaceDeformer", "cotangent_laplacian", "extrapolated_start", "mesh_volume",
    "LimitSurface", "SmoothnessReport", "SubdividedMesh", "Subdivider", "SUBDIVISION_MAX_FACES", "SUBDIVISION_MAX_LEVEL",
    "smoothness_report", "subdivide",
    "CageBinding", "CageDeformer", "GreenCage", "MeanValueCage", "MeshDeform", "MeshDeformBinding",
    "generate_cage",
    "RBF", "RBFBinding",
    "DeformationTransfer",
    "FoldCertificate", "VolumeRatioBounds",
]

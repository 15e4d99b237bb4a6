"""Type stubs for the native core (deformkit._core)."""
from typing import Literal, Sequence, TypeVar

import numpy as np
import numpy.typing as npt

_F = TypeVar("_F", np.float32, np.float64)
_Axis = Literal["x", "y", "z", "X", "Y", "Z", 0, 1, 2]
_Matrix4 = npt.ArrayLike
_Profile = tuple[npt.ArrayLike, npt.ArrayLike]

class Deformer:
    """Interface shared by every spatial deformer."""
    def deform(self, points: np.ndarray[tuple[int, int], np.dtype[_F]], *,
               out: np.ndarray[tuple[int, int], np.dtype[_F]] | None = None) -> np.ndarray[tuple[int, int], np.dtype[_F]]:
        """F(x) per row of an (n, 3) array; x + w (F(x) - x) with weights."""
    def displacement(self, points: np.ndarray[tuple[int, int], np.dtype[_F]], *,
                     out: np.ndarray[tuple[int, int], np.dtype[_F]] | None = None) -> np.ndarray[tuple[int, int], np.dtype[_F]]:
        """F(x) - x per row (what an offset attribute adds); out may not be points."""
    def jacobian(self, points: np.ndarray[tuple[int, int], np.dtype[_F]], *,
                 out: np.ndarray[tuple[int, int, int], np.dtype[_F]] | None = None) -> np.ndarray[tuple[int, int, int], np.dtype[_F]]:
        """J = dF/dx, shape (n, 3, 3), J[i, r, c] = dF_r/dx_c (Barr 1984)."""
    def transform_normals(self, points: np.ndarray[tuple[int, int], np.dtype[np.floating]],
                          normals: np.ndarray[tuple[int, int], np.dtype[_F]], *,
                          out: np.ndarray[tuple[int, int], np.dtype[_F]] | None = None) -> np.ndarray[tuple[int, int], np.dtype[_F]]:
        """Unit normals N' = det(J) J^-T N, renormalised."""
    def volume_ratio(self, points: np.ndarray[tuple[int, int], np.dtype[_F]], *,
                     out: np.ndarray[tuple[int], np.dtype[_F]] | None = None) -> np.ndarray[tuple[int], np.dtype[_F]]:
        """det(J) per point."""
    @property
    def weights(self) -> np.ndarray[tuple[int], np.dtype[np.float64]] | None: ...

class Twist(Deformer):
    """theta = f(z): x' = x cos - y sin, y' = x sin + y cos, z' = z (Barr 1984)."""
    def __init__(self, rate: float | None = None, axis: _Axis = "z", limits: tuple[float, float] | None = None,
                 profile: _Profile | None = None, extend: Literal["constant", "linear"] = "constant",
                 frame: _Matrix4 | None = None, weights: npt.ArrayLike | None = None) -> None: ...

class Taper(Deformer):
    """r = f(z): x' = r x, y' = r y, z' = z (Barr 1984)."""
    def __init__(self, rate: float | None = None, axis: _Axis = "z", limits: tuple[float, float] | None = None,
                 profile: _Profile | None = None, extend: Literal["constant", "linear"] = "constant",
                 frame: _Matrix4 | None = None, weights: npt.ArrayLike | None = None) -> None: ...

class Stretch(Deformer):
    """Blender's stretch: s = 1 + k (z^2 - 1), x' = s x, y' = s y, z' = z + k z^."""
    def __init__(self, factor: float = 0.785398163397448, axis: _Axis = "z",
                 limits: tuple[float, float] | None = None, frame: _Matrix4 | None = None,
                 weights: npt.ArrayLike | None = None) -> None: ...

class Bend(Deformer):
    """Barr's bend: theta = k (clamp(y, region) - center), tangent continuation outside."""
    def __init__(self, curvature: float = 0.785398163397448, center: float = 0.0,
                 region: tuple[float, float] | None = None, axis: _Axis = "x", frame: _Matrix4 | None = None,
                 weights: npt.ArrayLike | None = None) -> None: ...

class BarrDeformer(Deformer):
    """A Barr operator placed in object space: the fixed map SimpleDeform.bind(points) returns.

    Its extent was measured once, on the bound points; it carries the SimpleDeform's weights."""

class SimpleDeform(Deformer):
    """Blender's Simple Deform modifier: k = amount / (L1 - L0) over the limited extent."""
    def __init__(self, mode: Literal["TWIST", "BEND", "TAPER", "STRETCH"] = "TWIST", angle: float | None = None,
                 factor: float | None = None, deform_axis: _Axis = "X", origin: _Matrix4 | None = None,
                 limits: tuple[float, float] = (0.0, 1.0), lock_x: bool = False, lock_y: bool = False,
                 lock_z: bool = False, weights: npt.ArrayLike | None = None, invert_weights: bool = False) -> None: ...
    @property
    def mode(self) -> str: ...
    @property
    def angle(self) -> float: ...
    @property
    def factor(self) -> float: ...
    @property
    def deform_axis(self) -> str: ...
    @property
    def limits(self) -> tuple[float, float]: ...
    def replace(self, *, mode: Literal["TWIST", "BEND", "TAPER", "STRETCH"] | None = None,
                angle: float | None = None, factor: float | None = None,
                deform_axis: Literal["X", "Y", "Z"] | None = None, origin: _Matrix4 | None = None,
                limits: tuple[float, float] | None = None, lock_x: bool | None = None,
                lock_y: bool | None = None, lock_z: bool | None = None) -> SimpleDeform: ...
    def bind(self, points: npt.ArrayLike) -> BarrDeformer:
        """The fixed map deform(points) applies, its extent measured on `points` once.

        Deforming chunks of the points with it equals deform(points) bit for bit; it carries
        these weights, which must count `points`."""

class Stack(Deformer):
    """F_n o ... o F_1 with J = J_n(F_n-1(...)) ... J_1(x)."""
    def __init__(self, deformers: Sequence[Deformer], weights: npt.ArrayLike | None = None) -> None: ...
    def __len__(self) -> int: ...
    @property
    def deformers(self) -> list[Deformer]: ...

_Vector3 = Sequence[float] | npt.NDArray[np.floating]
_Counts = int | tuple[int, int, int]
_Outside = Literal["clamp", "unchanged", "extrapolate"]
_Interpolation = Literal["linear", "cardinal", "catmull_rom", "bspline",
                         "KEY_LINEAR", "KEY_CARDINAL", "KEY_CATMULL_ROM", "KEY_BSPLINE"]

class LatticeBinding:
    """Points bound to a lattice: their lattice coordinates, found once."""
    def __len__(self) -> int: ...
    @property
    def status(self) -> npt.NDArray[np.uint8]:
        """0 inside, 1 outside (the outside policy applies), 2 not placed (EFFD Newton failed)."""
    @property
    def parameters(self) -> npt.NDArray[np.float64]: ...
    def weights(self) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int32], npt.NDArray[np.float64]]:
        """CSR rows (indptr, indices, data) of W: deform = x + strength * W (P - R)."""

class DirectManipulation:
    control_points: npt.NDArray[np.float64]
    displacement: npt.NDArray[np.float64]
    residual: npt.NDArray[np.float64]
    max_residual: float
    rank: int
    volume: float | None
    volume_target: float | None
    volume_residual: float | None
    iterations: int

class Lattice(Deformer):
    """Interface of the lattice deformers: F(x) = x + strength * sum w(x) (P - R)."""
    control_points: npt.NDArray[np.float64]
    @property
    def rest_control_points(self) -> npt.NDArray[np.float64]: ...
    @property
    def resolution(self) -> tuple[int, int, int]: ...
    @property
    def strength(self) -> float: ...
    @property
    def outside(self) -> str: ...
    @property
    def handle_index(self) -> npt.NDArray[np.int32]: ...
    @property
    def handles(self) -> int: ...
    def bind(self, points: npt.ArrayLike) -> LatticeBinding: ...
    def deform_bound(self, binding: LatticeBinding, *, out: npt.NDArray[np.floating] | None = None
                     ) -> npt.NDArray[np.floating]: ...
    def displacement_bound(self, binding: LatticeBinding, *, out: npt.NDArray[np.floating] | None = None
                           ) -> npt.NDArray[np.floating]: ...
    def lattice_coordinates(self, points: npt.ArrayLike) -> npt.NDArray[np.float64]: ...
    def direct_manipulation(self, points: npt.ArrayLike, targets: npt.ArrayLike, *,
                            preserve_volume: tuple[npt.ArrayLike, _Faces] | None = None) -> DirectManipulation: ...

class FFD(Lattice):
    """Sederberg-Parry FFD: one trivariate Bernstein polynomial of degree (l, m, n)."""
    def __init__(self, degree: _Counts = 3, *, origin: _Vector3 | None = None, edges: npt.ArrayLike | None = None,
                 frame: _Matrix4 | None = None, control_points: npt.ArrayLike | None = None,
                 outside: _Outside = "clamp", strength: float = 1.0, weights: npt.ArrayLike | None = None) -> None: ...
    @property
    def degree(self) -> tuple[int, int, int]: ...

class BezierFFD(Lattice):
    """Piecewise tricubic Bezier FFD blocks, (3a+1, 3b+1, 3c+1) control points."""
    def __init__(self, blocks: _Counts = 1, *, origin: _Vector3 | None = None, edges: npt.ArrayLike | None = None,
                 frame: _Matrix4 | None = None, control_points: npt.ArrayLike | None = None,
                 outside: _Outside = "clamp", strength: float = 1.0, weights: npt.ArrayLike | None = None) -> None: ...

class BSplineLattice(Lattice):
    """Uniform cubic B-spline FFD over the box's inner part."""
    def __init__(self, resolution: _Counts = 4, *, origin: _Vector3 | None = None, edges: npt.ArrayLike | None = None,
                 frame: _Matrix4 | None = None, control_points: npt.ArrayLike | None = None,
                 outside: _Outside = "clamp", strength: float = 1.0, weights: npt.ArrayLike | None = None) -> None: ...

class BlenderLattice(Lattice):
    """Blender's Lattice modifier, reproduced (interpolation per axis, index clamping outside)."""
    def __init__(self, resolution: _Counts = 2, interpolation: _Interpolation | Sequence[_Interpolation] = "bspline",
                 *, origin: _Vector3 | None = None, edges: npt.ArrayLike | None = None,
                 frame: _Matrix4 | None = None, control_points: npt.ArrayLike | None = None,
                 outside: Literal["clamp", "unchanged"] = "clamp", strength: float = 1.0,
                 weights: npt.ArrayLike | None = None) -> None: ...
    @property
    def interpolation(self) -> tuple[str, str, str]: ...

class ExtendedFFD(Lattice):
    """Coquillart's extended FFD: Bezier blocks of any rest shape, points placed by Newton iteration."""
    def __init__(self, rest_control_points: npt.ArrayLike, *, control_points: npt.ArrayLike | None = None,
                 strength: float = 1.0, weights: npt.ArrayLike | None = None, tolerance: float = 1e-10,
                 max_iterations: int = 30) -> None: ...
    @staticmethod
    def cylinder(radius: float = 1.0, height: float = 1.0, blocks: _Counts = (1, 4, 1),
                 center: _Vector3 | None = None, axis: _Axis = "z", strength: float = 1.0,
                 weights: npt.ArrayLike | None = None, tolerance: float = 1e-10,
                 max_iterations: int = 30) -> ExtendedFFD: ...
    @staticmethod
    def prism(triangle: npt.ArrayLike, height: _Vector3, blocks: _Counts = 1, strength: float = 1.0,
              weights: npt.ArrayLike | None = None, tolerance: float = 1e-10,
              max_iterations: int = 30) -> ExtendedFFD: ...
    @property
    def tolerance(self) -> float: ...
    @property
    def max_iterations(self) -> int: ...

def cotangent_laplacian(points: npt.ArrayLike, faces: npt.ArrayLike | Sequence[Sequence[int]]
                        ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int32], npt.NDArray[np.float64]]:
    """The cotangent Laplacian as CSR (indptr, indices, data): symmetric, rows summing to 0."""

def extrapolated_start(previous: npt.NDArray[np.floating], earlier: npt.NDArray[np.floating],
                       targets: npt.NDArray[np.floating], previous_targets: npt.NDArray[np.floating],
                       earlier_targets: npt.NDArray[np.floating]) -> npt.NDArray[np.float64]:
    """previous + s (previous - earlier), s the handles' step projected on their last one, in [0, 2]:
    an initial guess for SurfaceDeformer.deform over a drag."""

class SurfaceDeformer:
    """Laplacian editing (Sorkine et al. 2004), its rotation-invariant form, and ARAP (Sorkine and
    Alexa 2007) on a mesh: the system is factorised here, deform() back-substitutes."""
    def __init__(self, points: npt.ArrayLike, faces: npt.ArrayLike | Sequence[Sequence[int]], *,
                 anchors: npt.ArrayLike = (), handles: npt.ArrayLike = (), roi: npt.ArrayLike | None = None,
                 method: Literal["arap", "rotation_invariant", "laplacian"] = "arap",
                 weights: Literal["cotangent", "uniform"] = "cotangent", iterations: int = 10,
                 tolerance: float = 0.0, constraint_weight: float | None = None, anderson: int = 0) -> None: ...
    def deform(self, handle_targets: npt.ArrayLike, initial: npt.NDArray[np.floating] | None = None) -> npt.NDArray[np.float64]:
        """(n, 3) positions with the handles at handle_targets (len(handles), 3); ARAP warm-starts from initial (n, 3)."""
    def __len__(self) -> int: ...
    @property
    def free_count(self) -> int: ...
    @property
    def warnings(self) -> list[str]:
        """Components left in place, singular rotation-invariant systems."""
    @property
    def energy(self) -> list[float]:
        """ARAP energy after each iteration of the last deform()."""
    @property
    def factor_nonzeros(self) -> int: ...
    @property
    def method(self) -> str: ...
    @property
    def weights_kind(self) -> str: ...

def mesh_volume(points: npt.ArrayLike, faces: npt.ArrayLike) -> float:
    """Signed volume of a closed mesh (divergence theorem); faces (m, k), polygons fanned."""

def build_info() -> dict[str, str]:
    """Library versions, the SIMD target chosen for this CPU and the thread count."""

_Faces = npt.ArrayLike | Sequence[Sequence[int]]
_Scheme = Literal["auto", "catmull_clark", "loop"]
_Boundary = Literal["edge_and_corner", "edge_only"]
_Sharpness = tuple[npt.ArrayLike, npt.ArrayLike]

def generate_cage(
    points: npt.ArrayLike,
    faces: _Faces | None = None,
    *,
    max_faces: int = 200,
    offset: float | None = None,
    alpha: float | None = None,
    quads: bool = False,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int32] | list[list[int]]]:
    """A closed cage of at most max_faces faces strictly around the mesh (alpha wrap, outward simplification)."""

SUBDIVISION_MAX_LEVEL: int
SUBDIVISION_MAX_FACES: int

class SubdividedMesh:
    """The result of subdivide()."""
    @property
    def points(self) -> npt.NDArray[np.float64]: ...
    @property
    def faces(self) -> npt.NDArray[np.int32]: ...
    @property
    def face_origin(self) -> npt.NDArray[np.int32]: ...
    @property
    def uvs(self) -> npt.NDArray[np.float64] | None: ...
    @property
    def level(self) -> int: ...
    @property
    def scheme(self) -> str: ...

def subdivide(points: npt.ArrayLike, faces: _Faces, level: int, *, scheme: _Scheme = "auto",
              boundary: _Boundary = "edge_and_corner", creases: _Sharpness | None = None,
              corners: _Sharpness | None = None, sharpen_two_edge_vertices: bool = True,
              uvs: npt.ArrayLike | None = None,
              uv_smooth: Literal["none", "preserve_corners", "preserve_corners_and_junctions",
                                 "preserve_corners_junctions_and_concave", "preserve_boundaries",
                                 "smooth_all"] = "preserve_boundaries",
              max_faces: int = ..., limit_surface: bool = False) -> SubdividedMesh:
    """Uniform OpenSubdiv subdivision (Catmull-Clark or Loop) to level 1..SUBDIVISION_MAX_LEVEL."""

class Subdivider:
    """The refined topology of a control mesh at one level, kept to subdivide many cages of it."""
    def __init__(self, points: npt.ArrayLike, faces: _Faces, level: int, *, scheme: _Scheme = "auto",
                 boundary: _Boundary = "edge_and_corner", creases: _Sharpness | None = None,
                 corners: _Sharpness | None = None, sharpen_two_edge_vertices: bool = True,
                 uvs: npt.ArrayLike | None = None, uv_smooth: str = "preserve_boundaries", max_faces: int = ...,
                 limit_surface: bool = False) -> None: ...
    def subdivide(self, points: npt.ArrayLike | None = None) -> npt.NDArray[np.float64]: ...
    def mesh(self, points: npt.ArrayLike | None = None) -> SubdividedMesh: ...
    @property
    def vertex_count(self) -> int: ...
    @property
    def level(self) -> int: ...
    @property
    def scheme(self) -> str: ...
    @property
    def faces(self) -> npt.NDArray[np.int32]: ...
    @property
    def face_origin(self) -> npt.NDArray[np.int32]: ...
    @property
    def limit_surface(self) -> bool: ...
    def vertex_parameters(self) -> tuple[npt.NDArray[np.int32], npt.NDArray[np.float64]]: ...
    def blender_order(self, edges: npt.ArrayLike) -> tuple[npt.NDArray[np.int32], npt.NDArray[np.int32],
                                                         npt.NDArray[np.int32], npt.NDArray[np.int32]]: ...

class SmoothnessReport:
    """Normal angles and position gaps of the limit surface across the interior edges."""
    max_angle: float
    max_gap: float
    min_regularity: float
    degenerate_samples: int
    flipped_samples: int
    sample_count: int
    boundary_edges: int
    max_crease: float
    @property
    def face_crease(self) -> npt.NDArray[np.float64]: ...
    @property
    def worst_faces(self) -> npt.NDArray[np.int32]: ...
    @property
    def edges(self) -> npt.NDArray[np.int32]: ...
    @property
    def edge_angle(self) -> npt.NDArray[np.float64]: ...
    @property
    def edge_gap(self) -> npt.NDArray[np.float64]: ...
    @property
    def worst_edges(self) -> npt.NDArray[np.int32]: ...
    @property
    def flipped_faces(self) -> npt.NDArray[np.int32]: ...
    def to_dict(self) -> dict[str, object]: ...

class LimitSurface:
    """The limit surface of a control mesh (Gregory patches near extraordinary vertices), at ptex samples."""
    def __init__(self, points: npt.ArrayLike, faces: _Faces, *, scheme: _Scheme = "auto",
                 boundary: _Boundary = "edge_and_corner", creases: _Sharpness | None = None,
                 corners: _Sharpness | None = None, sharpen_two_edge_vertices: bool = True) -> None: ...
    @property
    def ptex_count(self) -> int: ...
    @property
    def ptex_offset(self) -> npt.NDArray[np.int32]: ...
    @property
    def vertex_count(self) -> int: ...
    @property
    def scheme(self) -> str: ...
    def evaluate(self, ptex: npt.ArrayLike, uv: npt.ArrayLike, *, points: npt.ArrayLike | None = None,
                 derivatives: int = 1) -> dict[str, npt.NDArray[np.float64]]: ...
    def limit_points(self, points: npt.ArrayLike | None = None) -> npt.NDArray[np.float64]: ...
    def smoothness_report(self, points: npt.ArrayLike | None = None, *, samples_per_edge: int = 8,
                          reference: npt.ArrayLike | None = None, worst: int = 10,
                          deformer: Deformer | None = None, crease_grid: int = 16) -> SmoothnessReport: ...

def smoothness_report(points: npt.ArrayLike, faces: _Faces, *, scheme: _Scheme = "auto",
                      boundary: _Boundary = "edge_and_corner", creases: _Sharpness | None = None,
                      corners: _Sharpness | None = None, sharpen_two_edge_vertices: bool = True,
                      samples_per_edge: int = 8,
                      reference: npt.ArrayLike | None = None, worst: int = 10,
                      deformer: Deformer | None = None, crease_grid: int = 16) -> SmoothnessReport:
    """Check that the limit surface (or, with deformer, its image F(S)) is smooth: normal angles
    and gaps across every interior edge; with deformer, also normal jumps inside faces."""

class CageBinding:
    """Points bound to a cage: their coordinates, computed once."""
    def __len__(self) -> int: ...
    @property
    def storage(self) -> Literal["float64", "float32", "sparse"]: ...
    @property
    def columns(self) -> int: ...
    @property
    def dropped_weight_max(self) -> float: ...
    @property
    def weight_change_max(self) -> float: ...
    @property
    def float32_rounding_max(self) -> float: ...
    def weights(self) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int32], npt.NDArray[np.float64]]:
        """CSR rows (indptr, indices, data) of W: deform_bound = W c."""

class CageDeformer(Deformer):
    """Interface of the cage deformers: F(x) = sum_j w_j(x) c_j."""
    cage_points: npt.NDArray[np.float64]
    @property
    def rest_cage_points(self) -> npt.NDArray[np.float64]: ...
    @property
    def triangles(self) -> npt.NDArray[np.int32]: ...
    @property
    def triangle_faces(self) -> npt.NDArray[np.int32]: ...
    @property
    def flipped(self) -> bool: ...
    @property
    def volume(self) -> float: ...
    @property
    def columns(self) -> int: ...
    def bind(self, points: npt.ArrayLike, *, precision: Literal["float64", "float32"] = "float64",
             sparsify: float | None = None) -> CageBinding: ...
    def deform_bound(self, binding: CageBinding, *, out: npt.NDArray[np.floating] | None = None
                     ) -> npt.NDArray[np.floating]: ...

class GreenCage(CageDeformer):
    """Green coordinates of a closed polygon cage (quasi-conformal, exterior extension, exact Jacobians)."""
    def __init__(self, cage_points: npt.ArrayLike, cage_faces: _Faces, *, stretch: bool = True,
                 weights: npt.ArrayLike | None = None) -> None: ...
    @property
    def stretch(self) -> bool: ...

class MeanValueCage(CageDeformer):
    """Mean value coordinates of a closed polygon cage (determinant form, exact Jacobians)."""
    def __init__(self, cage_points: npt.ArrayLike, cage_faces: _Faces, *,
                 weights: npt.ArrayLike | None = None) -> None: ...

class MeshDeformBinding:
    """Points bound to a MeshDeform: Blender's inside test, and for a static bind their coordinates."""
    def __len__(self) -> int: ...
    @property
    def dynamic(self) -> bool: ...
    @property
    def inside(self) -> npt.NDArray[np.bool_]: ...
    def weights(self) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int32], npt.NDArray[np.float64]]:
        """CSR rows (indptr, indices, data) of the harmonic coordinates over the cage's vertices."""

class MeshDeform(Deformer):
    """Blender's Mesh Deform modifier: harmonic coordinates on a grid (Joshi et al. 2007)."""
    def __init__(self, cage_points: npt.ArrayLike, cage_faces: _Faces, *, precision: int = 5,
                 dynamic: bool = False, blender_version: tuple[int, ...] = (5, 0),
                 weights: npt.ArrayLike | None = None) -> None: ...
    cage_points: npt.NDArray[np.float64]
    @property
    def rest_cage_points(self) -> npt.NDArray[np.float64]: ...
    @property
    def precision(self) -> int: ...
    @property
    def dynamic(self) -> bool: ...
    @property
    def grid_size(self) -> int: ...
    @property
    def unknowns(self) -> int: ...
    @property
    def flipped(self) -> bool: ...
    def bind(self, points: npt.ArrayLike) -> MeshDeformBinding: ...
    def deform_bound(self, binding: MeshDeformBinding, *, out: npt.NDArray[np.floating] | None = None
                     ) -> npt.NDArray[np.floating]: ...

_RbfKernel = Literal["thin_plate_spline", "cubic", "quintic", "linear", "gaussian", "multiquadric",
                     "inverse_multiquadric", "inverse_quadratic", "wendland_c0", "wendland_c2", "wendland_c4", "clip"]

class RBFBinding:
    """Points bound to an RBF: a compact kernel's values within the support, or the points only."""
    def __len__(self) -> int: ...
    @property
    def nonzeros(self) -> int: ...
    def weights(self) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int32], npt.NDArray[np.float64]]:
        """Compact kernels: phi(|x_i - c_j|) as CSR rows (indptr, indices, data)."""

class RBF(Deformer):
    """Radial basis function deformation: controls move to targets, every point with them."""
    def __init__(self, control_points: npt.ArrayLike, targets: npt.ArrayLike | None = None, *,
                 kernel: _RbfKernel = "thin_plate_spline", epsilon: float | None = None, radius: float | None = None,
                 degree: int | None = None, smoothing: float = 0.0, weights: npt.ArrayLike | None = None) -> None: ...
    @property
    def control_points(self) -> npt.NDArray[np.float64]: ...
    targets: npt.NDArray[np.float64]
    @property
    def kernel(self) -> _RbfKernel: ...
    @property
    def epsilon(self) -> float | None: ...
    @property
    def radius(self) -> float | None: ...
    @property
    def degree(self) -> int: ...
    @property
    def smoothing(self) -> float: ...
    @property
    def condition_estimate(self) -> float: ...
    @property
    def coefficients(self) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def bind(self, points: npt.ArrayLike) -> RBFBinding: ...
    def deform_bound(self, binding: RBFBinding, *, out: npt.NDArray[np.floating] | None = None
                     ) -> npt.NDArray[np.floating]: ...

class DeformationTransfer:
    """Deformation transfer (Sumner and Popovic 2004): source poses onto a target, same or unlike connectivity."""
    def __init__(self, source_points: npt.ArrayLike, source_faces: _Faces, target_points: npt.ArrayLike,
                 target_faces: _Faces | None = None, *, markers: object = None, correspondence: npt.ArrayLike | None = None,
                 fixed_vertices: npt.ArrayLike | None = None) -> None: ...
    @property
    def anchors(self) -> npt.NDArray[np.int32]: ...
    @property
    def fixed_vertices(self) -> npt.NDArray[np.int32]: ...
    @property
    def correspondence(self) -> npt.NDArray[np.int32]: ...
    @property
    def unmatched_target_triangles(self) -> npt.NDArray[np.int32]: ...
    @property
    def correspondence_distance(self) -> tuple[float, float] | None: ...
    @property
    def fitted_source(self) -> npt.NDArray[np.float64] | None: ...
    @property
    def source_triangles(self) -> npt.NDArray[np.int32]: ...
    @property
    def target_triangles(self) -> npt.NDArray[np.int32]: ...
    def transfer(self, source_pose: npt.ArrayLike, fixed_positions: npt.ArrayLike | None = None) -> npt.NDArray[np.float64]: ...

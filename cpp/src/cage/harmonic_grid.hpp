#pragma once
// Blender's Mesh Deform grid (meshlaplacian.cc, "Harmonic Coordinates"; Joshi et al. 2007): a cube
// of 2^p + 2 cells a side around the cage, the segments between neighbouring cell centres cut by
// the cage, the cells tagged exterior by a flood fill from a corner, and the 7-point Laplacian
// with cut edges whose solutions are the harmonic coordinates (docs/math/mesh_deform.md, "The grid").
#include "cage/blender_bvh.hpp"
#include "cage/grid_stencil_direct.hpp"
#include "deformkit/cage/cage_mesh.hpp"
#include "deformkit/core/types.hpp"

#include <array>
#include <cstdint>
#include <utility>
#include <vector>

namespace deformkit::harmonic {

// The exact sign (-1, 0, 1) of component `axis` of (b - a) x (c - a), as cage_exact::turn_along
// gives it, mostly without its exact arithmetic (a floating-point filter in front).
int turn_along(const Vec3& a, const Vec3& b, const Vec3& c, int axis);

// The cage as Blender ray-casts it: its polygons tessellated as Blender does (a quad on its 0-2
// diagonal unless that diagonal lies outside it; a triangle as it is; larger polygons as CageMesh
// splits them), outward, with each triangle's polygon; and per axis a bucket grid of the
// triangles' projections for the axis-aligned lines every query runs along.
class RayCage {
 public:
  RayCage(const CageMesh& cage, int bvh_arity);

  struct Hit {
    double t;      // the coordinate along the line's axis
    int triangle;
  };
  // Every triangle the line {x : x[u] = pu, x[v] = pv} (u, v the other two axes, in cyclic
  // order after `axis`) meets, edges included, sorted by t. Meeting is decided exactly.
  void line_hits(int axis, double pu, double pv, std::vector<Hit>& out) const;

  // Where triangle `triangle` meets that line (decided exactly), at coordinate t along it.
  bool meets(int triangle, int axis, double pu, double pv, double& t) const;
  // The triangle Blender's ray cast keeps for the ray from origin along sign * axis, `length`
  // long (BlenderBvh), or -1; t (unless null) its coordinate along the axis.
  int blender_hit(const Vec3& origin, int axis, int sign, double length, double* t) const;

  int face_of(int triangle) const { return triangle_face_[std::size_t(triangle)]; }
  // Component `axis` of the polygon's outward (Newell) normal.
  double normal(int face, int axis) const { return normal_[std::size_t(face)][axis]; }
  // Mean value weights of x (on the polygon) over its corners (face_size of them), with Blender's
  // rules within 1e-5 of a corner (that corner) or an edge (linear along it).
  void polygon_weights(int face, const Vec3& x, double* w) const;
  const PolygonMesh& polygons() const { return *polygons_; }

 private:
  struct Buckets {
    double lo[2] = {0, 0}, step[2] = {1, 1};
    int res = 1;
    std::vector<int> start, items;
  };
  const PolygonMesh* polygons_;
  std::vector<Vec3> point_;
  std::vector<std::array<int, 3>> triangle_;
  std::vector<int> triangle_face_;
  std::vector<Vec3> triangle_normal_;             // (p1 - p0) x (p2 - p0)
  std::vector<std::array<signed char, 3>> turn_;  // per axis: the triangle's turn seen from +axis
  std::vector<Vec3> normal_;
  Buckets buckets_[3];
  BlenderBvh bvh_;
};

// A segment between neighbouring cell centres that the cage cuts: where (distance from the cell,
// at least 1e-6 as in Blender) and the hit polygon's mean value weights there.
struct Cut {
  double length;
  int face;
  std::int64_t weights;  // offset of face_size(face) weights in HarmonicGrid::cut_weights
};

struct HarmonicGrid {
  int size = 0;             // cells a side
  double min[3] = {0, 0, 0};
  double width = 0.0;       // a cell's width
  double ray_length = 0.0;  // the inside test's rays: the padded box's side + 1 (Blender's)
  std::vector<std::uint8_t> cut;       // per cell, bit d: its segment toward neighbour d is cut
  std::vector<std::uint8_t> exterior;  // per cell
  std::vector<std::int64_t> cut_key;   // cell * 6 + d of each cut, ascending
  std::vector<Cut> cuts;
  std::vector<double> cut_weights;

  std::int64_t cells() const { return std::int64_t(size) * size * size; }
  std::int64_t index(int i, int j, int k) const { return i + std::int64_t(size) * (j + std::int64_t(size) * k); }
  double centre(int axis, int i) const { return min[axis] + i * width + 0.5 * width; }
  // Neighbour d (-x, +x, -y, +y, -z, +z) of cell c, or -1 beyond the grid.
  std::int64_t neighbour(std::int64_t c, int d) const;
  const Cut& cut_of(std::int64_t c, int d) const;
  bool semibound(std::int64_t c) const { return exterior[std::size_t(c)] && cut[std::size_t(c)]; }
};

// Blender's grid for `precision` (2^precision + 2 cells a side), its cuts and its flood fill.
HarmonicGrid build_grid(const RayCage& cage, const std::vector<double>& cage_points, int precision);

// Blender's inside test: some axis ray from p (of the grid's ray_length) meets the cage first
// from inside (the hit polygon faces away from the ray).
bool inside_cage(const RayCage& cage, const HarmonicGrid& grid, const Vec3& p, std::vector<RayCage::Hit>& scratch);

// The Laplacian over the cells that are not exterior, in its symmetric form: Blender's rows
// times their weight sums (1/width per uncut edge, 1/length per cut one).
numerics::GridStencil grid_stencil(const HarmonicGrid& grid);

// Column `vertex`'s right-hand side gets sum over u's cuts of value(cut) / length: the cage
// vertex's boundary values (its weight in the hit polygon) carried into the unknowns.
struct BoundaryTerm {
  int unknown;
  double inverse_length;
  int face;
  std::int64_t weights;
};
std::vector<BoundaryTerm> boundary_terms(const HarmonicGrid& grid, const numerics::GridStencil& stencil);

// The coordinates at a cell that is not an unknown, as sparse (cage vertex, value) pairs: at a
// cut exterior cell the cuts' boundary values averaged with weights 1/length, at another exterior
// cell the average of its cut exterior neighbours, else none (Blender's semibound and exterior phi).
using SparseValues = std::vector<std::pair<int, double>>;
SparseValues exterior_values(const RayCage& cage, const HarmonicGrid& grid, std::int64_t cell);

}  // namespace deformkit::harmonic

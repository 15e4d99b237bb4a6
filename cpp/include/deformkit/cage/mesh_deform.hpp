#pragma once
// Blender's Mesh Deform modifier reproduced: harmonic coordinates (Joshi, Meyer, DeRose, Green,
// Sanocki 2007) solved on Blender's grid, bound statically (each point's coordinates, trilinear in
// its 8 cells) or dynamically (each cell's coordinates, interpolated where the point is), applied
// in displacement form x + sum_a w_a (c_a - c_a at rest) / sum_a w_a (docs/cage.md,
// "Mesh Deform (harmonic coordinates)"; docs/math/mesh_deform.md, "Binding and evaluation").
#include "deformkit/cage/cage_mesh.hpp"
#include "deformkit/core/point_binding.hpp"

#include <cstddef>
#include <cstdint>
#include <memory>
#include <type_traits>
#include <variant>
#include <vector>

namespace deformkit {

// The cage vertex of each stored weight, in the narrowest unsigned type that holds the cage's
// vertex indices (1 byte up to 256 vertices, 2 up to 65536, else 4): a binding holds and a static
// frame reads one per weight, and Mesh Deform cages are small. Exactly one vector is used.
class WeightColumns {
 public:
  using Storage = std::variant<std::vector<std::uint8_t>, std::vector<std::uint16_t>, std::vector<std::uint32_t>>;
  WeightColumns() = default;
  // `count` entries, each to hold a vertex index below `vertex_count`.
  WeightColumns(std::size_t count, std::size_t vertex_count);
  std::size_t size() const {
    return std::visit([](const auto& c) { return c.size(); }, storage_);
  }
  std::size_t bytes_per_index() const {
    return std::visit([](const auto& c) { return sizeof(typename std::decay_t<decltype(c)>::value_type); }, storage_);
  }
  std::uint32_t operator[](std::size_t e) const {
    return std::visit([e](const auto& c) { return std::uint32_t(c[e]); }, storage_);
  }
  // Entries [at, at + count) set to `vertices`, each below the vertex count given at construction.
  void assign(std::size_t at, const std::uint32_t* vertices, std::size_t count);
  const Storage& storage() const { return storage_; }

 private:
  Storage storage_;
};

struct MeshDeformBinding : PointBinding {
  bool dynamic = false;
  std::vector<std::uint8_t> inside;  // per point: inside the rest cage (Blender's ray test)
  // Static: the kept, renormalised coordinates of each point that has any, a row per such point
  // (row_point: its point), the rows ordered by length (a frame's loop then runs one length many
  // times over, which the branch predictor follows), CSR: row r's are [weight_start[r],
  // weight_start[r + 1]). The values in the points' precision: float for float32 points, as
  // Blender stores them, double for float64 points; their cage vertices 1 or 2 bytes each for
  // cages up to 256 or 65536 vertices (a float32 frame reads 5 or 6 bytes a weight, not 8).
  std::vector<std::uint32_t> row_point;
  std::vector<std::uint32_t> weight_start;
  WeightColumns weight_vertex;
  std::vector<double> weight_value;
  std::vector<float> weight_value_f32;
  // A float32 binding's rows once more, dense, where that takes not many more bytes than the rows
  // (a cage of few vertices, each point weighing most of them): blocks of 8 points in point order,
  // per block and cage vertex a its 8 points' weights side by side, dense_weight[8 (m block + a) +
  // k], 0 where a weight was dropped or a point has none. A frame then reads no indices
  // (harmonic::dense_blocks).
  std::vector<float> dense_weight;
  // Dynamic: the cells the bound points reach, and per point its 8 cells (slots into cells) and
  // their trilinear weights, so a frame sums each cell's influences once.
  std::vector<std::int64_t> cells;
  std::vector<std::uint32_t> corner_slot;
  std::vector<double> corner_weight;
  std::vector<double> points_f64;    // n x 3 as bound (float64 points)
  std::vector<float> points_f32;     // (float32 points)
};

namespace harmonic {
struct Solved;  // the grid and, for a dynamic bind, its cells' coordinates
}

// How the grid system is solved: multigrid-preconditioned conjugate gradients (the default; every
// column to a relative residual of 1e-7) or a sparse Cholesky factorisation (exact to rounding,
// memory growing faster with the grid: kept as the reference the tests compare with).
enum class GridSolver { Multigrid, Cholesky };

class MeshDeform : public BoundDeformer {
 public:
  static constexpr int kMinPrecision = 2, kMaxPrecision = 10;
  // Throws std::invalid_argument naming `precision` outside [2, 10]. The cage is checked by
  // CageMesh. A dynamic deformer solves its grid here; a static one at each bind. bvh_arity: the
  // children per branch of the ray-cast tree of the Blender to match (2 since Blender 4.4, 4 before;
  // it decides which hit Blender keeps on a ray that meets the cage more than once).
  MeshDeform(CageMesh cage, int precision, bool dynamic, int bvh_arity = 2,
             GridSolver solver = GridSolver::Multigrid);
  ~MeshDeform() override;

  const CageMesh& cage() const { return cage_; }
  int precision() const { return precision_; }
  bool dynamic() const { return dynamic_; }
  int bvh_arity() const { return bvh_arity_; }
  int grid_size() const { return (1 << precision_) + 2; }
  std::size_t vertex_count() const { return cage_.vertex_count(); }
  const std::vector<double>& rest_cage_points() const { return cage_.rest_points(); }
  const std::vector<double>& cage_points() const { return current_; }
  // Throws std::invalid_argument naming cage_points for a wrong count or a non-finite point.
  void set_cage_points(std::vector<double> points);
  bool is_identity() const override { return at_rest_; }
  std::string overflow_parameters() const override { return "cage_points"; }

  // Blender's bind of these points (their inside test, and for a static bind the grid solve and
  // their coordinates). Throws std::invalid_argument naming `points` for a non-finite row, and
  // std::runtime_error naming the cage when the grid has no cell inside it or no solution.
  // `inside` (n flags, dynamic only, else std::invalid_argument naming it): which points are
  // deformed, as Blender's dynamic bind keeps them from Bind (dynverts), instead of testing the
  // points where they are now; a kept point in cells without coordinates is not displaced.
  MeshDeformBinding bind(const double* points, std::size_t n, const std::uint8_t* inside = nullptr) const;
  MeshDeformBinding bind(const float* points, std::size_t n, const std::uint8_t* inside = nullptr) const;
  // A static bind of these points from its coordinates as weights_table gives them (a row per point
  // over the cage's vertices, each inside point's renormalised weights), without the grid solve: a
  // saved bind loaded. `inside` (n flags; null: the points with a row). Throws
  // std::invalid_argument naming `rows` for a dynamic deformer or a table that is no static bind
  // of n points to this cage (not n rows, a vertex out of range or not rising along a row, a
  // weight outside (0, 1] or a row not summing to 1 within 1e-4, a row of an outside point),
  // naming `inside` for flags of another count, and `points` for a non-finite point.
  MeshDeformBinding bind_rows(const double* points, std::size_t n, const std::uint8_t* inside,
                              const WeightTable& rows) const;
  MeshDeformBinding bind_rows(const float* points, std::size_t n, const std::uint8_t* inside,
                              const WeightTable& rows) const;
  // The coordinates of the bound points (static: as stored; dynamic: interpolated at the bound
  // points), a point outside the cage an empty row.
  WeightTable weights_table(const MeshDeformBinding& binding) const;
  // Unknowns of the last solve (for reports).
  std::size_t unknown_count() const;

 private:
  template <class T>
  MeshDeformBinding bind_points(const T* in, std::size_t n, const std::uint8_t* inside) const;
  template <class T>
  MeshDeformBinding bound_rows(const T* in, std::size_t n, const std::uint8_t* inside, const WeightTable& rows) const;
  template <class T>
  bool deform_points(const T* in, T* out, std::size_t n) const;
  // offsets: out = w_i o_i (w null: o_i), else out = x_i + o_i, o_i the point's displacement
  // (mesh_deform_eval.cpp); false where a result is not finite.
  template <class T>
  bool evaluate_bound(const MeshDeformBinding& b, T* out, bool offsets, const double* w) const;
  std::uint64_t layout() const;
  std::vector<double> displacements() const;  // c_a - c_a at rest, m x 3

  bool deform_impl(const float* in, float* out, std::size_t n) const override;
  bool deform_impl(const double* in, double* out, std::size_t n) const override;
  bool jacobian_impl(const double* in, double* jac, std::size_t n) const override;
  void check_binding(const PointBinding& binding) const override;
  bool deform_bound_impl(const PointBinding& binding, float* out) const override;
  bool deform_bound_impl(const PointBinding& binding, double* out) const override;
  bool displacement_bound_impl(const PointBinding& binding, float* out, const double* weights) const override;
  bool displacement_bound_impl(const PointBinding& binding, double* out, const double* weights) const override;
  void bound_points(const PointBinding& binding, StoredPoints<float>& points) const override;
  void bound_points(const PointBinding& binding, StoredPoints<double>& points) const override;

  CageMesh cage_;
  int precision_;
  bool dynamic_;
  int bvh_arity_;
  GridSolver solver_;
  std::vector<double> current_;
  bool at_rest_ = true;
  std::shared_ptr<const harmonic::Solved> solved_;  // the grid, and a dynamic bind's cells
};

}  // namespace deformkit

#pragma once
// What every cage-coordinate deformer shares (mean value now, Green next): F(x) = sum_j w_j(x) c_j,
// coordinates w of the rest cage times control values c of the current cage, and the bind-once /
// deform-often path as one (dense or sparse) matrix product. A coordinate kind supplies only its
// coordinate function and its control values (docs/math/cage.md, "The shared interface").
#include "deformkit/cage/cage_mesh.hpp"
#include "deformkit/core/buffer.hpp"
#include "deformkit/core/point_binding.hpp"
#include "deformkit/core/types.hpp"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace deformkit {

enum class WeightStorage : std::uint8_t {
  Float64 = 0,  // dense n x columns float64 (the default)
  Float32 = 1,  // dense float32: half the memory, weights rounded to float
  Sparse = 2,   // CSR of the weights of magnitude >= the threshold, renormalised (float32 values
                // for float32 points, float64 otherwise)
};

struct CageBindOptions {
  WeightStorage storage = WeightStorage::Float64;
  double sparsify_threshold = 0.0;  // Sparse: drop |w| below this (> 0)
};

// Points bound to a cage: their coordinates, computed once, and the points as they were bound.
struct CageBinding : PointBinding {
  WeightStorage storage = WeightStorage::Float64;
  std::size_t columns = 0;
  Buffer<double> weights_f64;  // n x columns, row-major (Float64)
  Buffer<float> weights_f32;   // n x columns (Float32)
  // Sparse: the kept weights as CSR. For float32 points the values are rounded to float and kept
  // in sparse_values_f32 (sparse.values is then empty): the output is float32 anyway, and the
  // frame reads a third less memory.
  WeightTable sparse;
  Buffer<float> sparse_values_f32;
  Buffer<double> points_f64;   // n x 3, as bound (float64 points)
  Buffer<float> points_f32;    // (float32 points)
  // Sparse only, over the bound points: the largest sum of |dropped weights| of a point, and the
  // largest weighted L1 change of a point's weights, sum over the vertex columns of |change| plus
  // sum over the other columns of kappa_c |change| (CageDeformer::vector_column_bounds): the
  // position error at any deformed cage is at most weight_change_max * max_i |v'_i - o| for any
  // point o, the deformed cage's radius about it (the vertex weights still sum to what they summed
  // to; docs/math/cage.md, "Sparsified bindings").
  double dropped_weight_max = 0.0;
  double weight_change_max = 0.0;
  // Float32, and Sparse of float32 points: the largest L1 change rounding to float made to a point's
  // (kept, renormalised) weights; the position error bound above then grows by
  // float32_rounding_max * max_j |c'_j| (the rounded weights need not keep the row's sum).
  double float32_rounding_max = 0.0;
};

class CageDeformer : public BoundDeformer {
 public:
  const CageMesh& cage() const { return cage_; }
  std::size_t vertex_count() const { return cage_.vertex_count(); }
  const std::vector<double>& rest_cage_points() const { return cage_.rest_points(); }
  const std::vector<double>& cage_points() const { return current_; }
  std::string overflow_parameters() const override { return "cage_points"; }
  // Copies the current cage in. Throws std::invalid_argument naming cage_points for a wrong count
  // or a non-finite point. At rest (bit for bit the rest cage) the map is the identity.
  void set_cage_points(std::vector<double> points);
  bool is_identity() const override { return at_rest_; }

  // The coordinate kind: how many columns its coordinates have, the coordinates (and, where dw is
  // not null, their gradients, 3 per column) of one finite point, and the control values the
  // columns multiply (columns x 3) for the current cage.
  virtual std::size_t columns() const = 0;
  virtual void coordinates(const Vec3& x, double* w, double* dw) const = 0;
  virtual void control_values(double* out) const = 0;
  // The coordinates of n finite points (n x 3, row-major) into rows of w (n x columns()), without
  // gradients. This default calls coordinates() per point; a kind overrides it to compute several
  // points at once (SIMD lanes over points), equal to coordinates() to rounding.
  virtual void coordinate_rows(const double* points, std::size_t n, double* w) const;
  // The first vertex_columns() columns multiply the cage's vertices; the others (Green's faces)
  // multiply vectors c with |c| <= kappa_c R' for every deformed cage of radius R' about any centre:
  // kappa of each such column into out (columns() - vertex_columns()). Sparsifying keeps the vertex
  // weights' sum and charges the other columns' changes by kappa.
  virtual std::size_t vertex_columns() const { return columns(); }
  virtual void vector_column_bounds(double* /*out*/) const {}

  // Throws std::invalid_argument naming `points` for a non-finite row, `sparsify` for a threshold
  // that is not positive and finite or that would drop every weight of a point (or leave weights
  // summing to zero), and `memory` where the dense table would not fit.
  CageBinding bind(const double* points, std::size_t n, const CageBindOptions& options = {}) const;
  CageBinding bind(const float* points, std::size_t n, const CageBindOptions& options = {}) const;
  // The binding's weights as CSR (every stored entry, zeros dropped), float32 weights widened.
  WeightTable weights_table(const CageBinding& binding) const;
  // Identifies the coordinate kind and the rest cage a binding depends on.
  std::uint64_t layout() const;

 protected:
  explicit CageDeformer(CageMesh cage);
  // A name of the coordinate kind, mixed into layout().
  virtual const char* kind() const = 0;

 private:
  bool deform_impl(const float* in, float* out, std::size_t n) const override;
  bool deform_impl(const double* in, double* out, std::size_t n) const override;
  bool jacobian_impl(const double* in, double* jac, std::size_t n) const override;
  template <class T>
  bool deform_points(const T* in, T* out, std::size_t n) const;
  template <class T>
  CageBinding bind_points(const T* in, std::size_t n, const CageBindOptions& options) const;
  void check_binding(const PointBinding& binding) const override;
  bool deform_bound_impl(const PointBinding& binding, float* out) const override;
  bool deform_bound_impl(const PointBinding& binding, double* out) const override;
  void bound_points(const PointBinding& binding, StoredPoints<float>& points) const override;
  void bound_points(const PointBinding& binding, StoredPoints<double>& points) const override;
  template <class T>
  bool multiply(const CageBinding& b, T* out) const;

  CageMesh cage_;
  std::vector<double> current_;
  bool at_rest_ = true;
};

}  // namespace deformkit

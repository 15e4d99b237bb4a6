#pragma once
// Bind once, deform often: what every "weights per point" deformer shares (lattices now; cage
// coordinates and RBF next). A binding holds whatever a deformer computed once for a fixed set of
// points; a BoundDeformer deforms them again with its current state and owns the per-point
// policy (weight count, blend, overflow report, identity, dtype) in one place.
#include "deformkit/core/deformer.hpp"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace deformkit {

// Polymorphic so that a deformer can tell its own bindings from another family's (dynamic_cast);
// copies and moves stay explicit because the virtual destructor would otherwise drop the moves.
class PointBinding {
 public:
  PointBinding() = default;
  PointBinding(const PointBinding&) = default;
  PointBinding(PointBinding&&) = default;
  PointBinding& operator=(const PointBinding&) = default;
  PointBinding& operator=(PointBinding&&) = default;
  virtual ~PointBinding() = default;

  std::size_t size() const { return point_count; }

  std::size_t point_count = 0;
  bool single_precision = false;  // the points were float32: deform_bound writes float32
  std::uint64_t layout = 0;       // identifies the deformer state the binding depends on
};

// Where a binding keeps its original points, in whatever order suits its kernel: point order[i]
// (point i where order is null) is (coord[0][i * stride], coord[1][i * stride], coord[2][i * stride]).
// An (n, 3) array in point order is {{p, p + 1, p + 2}, 3, nullptr}; the lattices' cell-sorted
// structure of arrays is {{x, y, z}, 1, order}.
template <class T>
struct StoredPoints {
  const T* coord[3] = {nullptr, nullptr, nullptr};
  std::size_t stride = 3;
  const std::uint32_t* order = nullptr;
};

// A sparse weight table in CSR form: row i (a bound point) holds the weights
// values[indptr[i] .. indptr[i + 1]) of the columns (control values) indices[...].
struct WeightTable {
  std::vector<std::int64_t> indptr{0};
  std::vector<std::int32_t> indices;
  std::vector<double> values;
  std::size_t rows() const { return indptr.empty() ? 0 : indptr.size() - 1; }
  // Throws std::invalid_argument naming `name` when the arrays do not form a table over `columns`
  // columns (offsets not starting at 0 or not non-decreasing, lengths that differ, a column out
  // of range, a weight that is not finite).
  void require_valid(std::size_t columns, const char* name) const;
};

// out (rows x width) = W * control (columns x width), row by row in parallel, accumulated in
// double; the table must be valid over the control values' columns.
template <class T>
void apply_weight_table(const WeightTable& w, const double* control, std::size_t width, T* out);

// Per-point policy of the bound path, once for every family:
//   - per-point weights, if set, must count the bound points, and blend each result toward its
//     bound original position as deform() does;
//   - at the identity the bound points come back as bound, bit for bit;
//   - a non-finite result is the deformer's overflow report, never inf or NaN handed back;
//   - the output dtype is the bound points' dtype.
class BoundDeformer : public Deformer {
 public:
  // Throws std::invalid_argument naming `binding` for a binding of another deformer or dtype,
  // `weights` for a weight count other than the binding's, `deformer` where a result overflows.
  void deform_bound(const PointBinding& binding, float* out) const;
  void deform_bound(const PointBinding& binding, double* out) const;
  // w (F(x) - x) of the bound points (w: the weights, 1 without), what an offset-based consumer
  // (Blender's Geometry Nodes) adds to them; 0 at the identity. Throws as deform_bound does.
  void displacement_bound(const PointBinding& binding, float* out) const;
  void displacement_bound(const PointBinding& binding, double* out) const;

 protected:
  // Throws std::invalid_argument naming `binding` unless this deformer made `binding` (and could
  // still use it: the state it depends on, its layout, is unchanged).
  virtual void check_binding(const PointBinding& binding) const = 0;
  // The bound points deformed with the current state, in point order, before any per-point blend;
  // false when some result is not finite (the output is then unspecified). Not called at the
  // identity.
  virtual bool deform_bound_impl(const PointBinding& binding, float* out) const = 0;
  virtual bool deform_bound_impl(const PointBinding& binding, double* out) const = 0;
  // w (F(x) - x) in one pass (weights: null or the deformer's own, one per bound point); false (the
  // default) leaves it to deform_bound then a subtraction, which also names any error.
  virtual bool displacement_bound_impl(const PointBinding&, float*, const double*) const { return false; }
  virtual bool displacement_bound_impl(const PointBinding&, double*, const double*) const { return false; }
  // Where the bound original positions are kept: the identity's result and the blend's origin,
  // read in place (no copy in point order is made).
  virtual void bound_points(const PointBinding& binding, StoredPoints<float>& points) const = 0;
  virtual void bound_points(const PointBinding& binding, StoredPoints<double>& points) const = 0;

 private:
  template <class T>
  void check_bound_call(const PointBinding& binding) const;
  template <class T>
  void deform_bound_checked(const PointBinding& binding, T* out) const;
  template <class T>
  void displacement_bound_checked(const PointBinding& binding, T* out) const;
};

}  // namespace deformkit

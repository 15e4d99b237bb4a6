#pragma once
// What every lattice deformer shares: a grid of control points, tensor-product weights, and the
// bind-once / deform-often path. F(x) = x + strength * sum_ijk w_ijk(x) (P_ijk - R_ijk), the
// displacement form, which makes a lattice at rest the identity for every basis.
#include "deformkit/core/buffer.hpp"
#include "deformkit/core/point_binding.hpp"
#include "deformkit/lattice/lattice_basis.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace deformkit {

enum class PointStatus : std::uint8_t {
  Inside = 0,     // placed inside the lattice
  Outside = 1,    // outside; the outside policy decides
  NotPlaced = 2,  // the inversion did not converge (extended FFD): left unchanged
};

// Each point's lattice coordinates, found once; deforming after control points move needs
// nothing else. Points are sorted by lattice cell so that a cell's control points are loaded
// once and its points fill the SIMD lanes; the weights are regenerated from the coordinates in
// registers, which is cheaper than streaming 64 stored weights per point from memory.
// The layout (PointBinding) identifies the lattice's bases, resolution and rest placement.
struct LatticeBinding : PointBinding {
  std::array<int, 3> resolution{};
  Buffer<double> parameters;         // 3n, normalised lattice coordinates
  Buffer<std::uint8_t> status;       // n, PointStatus

  // Sorted by cell: sorted position i is point order[i]; run r is [run_begin[r], run_begin[r+1]).
  Buffer<std::uint32_t> order;
  std::vector<std::uint32_t> run_begin;
  std::vector<std::int32_t> run_cell;               // index into cells
  std::vector<std::array<std::int32_t, 3>> cells;   // distinct cells: the piece per axis
  std::vector<std::uint8_t> cell_moves;             // 0: the cell's points are left unchanged
  // Structure of arrays in sorted order: local t0, t1, t2 then x, y, z (one of the two is used).
  Buffer<float> sorted_f;
  Buffer<double> sorted_d;
};

// The lattice's weight table is the core's: the name stays for the lattice code that uses it.
using SparseWeights = WeightTable;

class ControlLattice : public BoundDeformer {
 public:
  const LatticeAxes& axes() const { return axes_; }
  std::array<int, 3> resolution() const { return {axes_[0].count, axes_[1].count, axes_[2].count}; }
  std::size_t control_count() const { return rest_.size() / 3; }
  const std::vector<double>& rest_control_points() const { return rest_; }
  const std::vector<double>& control_points() const { return control_; }
  // Throws std::invalid_argument naming control_points for a wrong size, non-finite entries, or
  // merged control points given different positions.
  void set_control_points(std::vector<double> grid);
  double strength() const { return strength_; }
  bool is_identity() const override { return strength_ == 0.0 || at_rest_; }
  std::string overflow_parameters() const override { return "control_points, strength"; }
  Outside outside() const { return outside_; }
  // Control points merged into one handle (extended FFD: coincident at rest); identity otherwise.
  const std::vector<int>& handle_of() const { return handle_of_; }
  int handle_count() const { return handle_count_; }
  std::uint64_t layout() const;

  LatticeBinding bind(const double* points, std::size_t n) const;
  LatticeBinding bind(const float* points, std::size_t n) const;
  // deform_bound (BoundDeformer) throws std::invalid_argument naming `binding` when it was made by
  // a lattice of another layout; per-point weights blend as in deform().

  // Rows of the weight matrix W (deform = x + strength W (P - R), before any per-point blend
  // weights), over flattened control points (i * nv + j) * nw + k; duplicate columns (Blender's
  // index clamping) merged.
  WeightTable weights_matrix(const LatticeBinding& binding) const;

  // With outside='extrapolate', sum |w_ijk| over a point's weights, the product over the axes of
  // sum |w_axis|: the factor by which rounding in sum w (P - R), and in its derivatives per cell,
  // can exceed eps max|P - R| (docs/lattice.md, "Far outside"). 1 inside the domain.
  double extrapolation_gain(const Vec3& parameters) const;
  // Points whose gain passes this are refused on every path: eps * 1e6 = 2.2e-10 keeps a float64
  // result within about 1e-9 of max|P - R| (docs/lattice.md, "Far outside").
  static constexpr double kMaxExtrapolationGain = 1e6;

  // The Jacobians through the per-point formulas, with no SIMD lanes: what jacobian(),
  // transform_normals() and volume_ratio() are tested against (weights not applied). Throws as
  // jacobian() does for a row whose lattice coordinates overflow.
  void reference_jacobian(const double* points, double* jac, std::size_t n) const;

 protected:
  ControlLattice(const LatticeAxes& axes, std::vector<double> rest, Outside outside, double strength);
  void merge_coincident_control_points(double tolerance);
  // Whatever else the lattice coordinates depend on (extended FFD: the Newton settings).
  std::uint64_t layout_salt_ = 0;

  // Lattice coordinates and status of one finite point.
  virtual PointStatus locate(const Vec3& x, Vec3& parameters) const = 0;
  // d(parameters)/dx at a placed point.
  virtual Mat3 parameter_jacobian(const Vec3& parameters) const = 0;
  // A box lattice's parameters are to_parameters (x - origin): said once by its constructor, so
  // that points are placed in SIMD lanes, and the derivatives, whose d(parameters)/dx is then
  // constant, run in them too.
  void set_affine_placement(const Mat3& to_parameters, const Vec3& origin);

  bool displaces(PointStatus s) const {
    return s == PointStatus::Inside || (s == PointStatus::Outside && outside_ != Outside::Unchanged);
  }
  // sum w (P - R) at the given coordinates, and optionally its derivatives d/d(s,t,u) as columns.
  Vec3 displacement_at(const Vec3& parameters, Mat3* derivative) const;
  // sum w R and d/d(s,t,u): the rest map, for lattices whose rest shape is not a box.
  Vec3 rest_map(const Vec3& parameters, Mat3* derivative) const;

 private:
  bool deform_impl(const float* in, float* out, std::size_t n) const override;
  bool deform_impl(const double* in, double* out, std::size_t n) const override;
  bool jacobian_impl(const double* in, double* jac, std::size_t n) const override;
  bool normals_impl(const double* points, const double* normals, double* out, std::size_t n) const override;
  bool normals_impl(const float* points, const float* normals, float* out, std::size_t n) const override;
  bool volume_ratio_impl(const double* points, double* out, std::size_t n) const override;
  template <class T>
  bool derivative_lanes(int what, const T* in, const T* normals, T* out, std::size_t n, bool* all_lanes = nullptr) const;
  Mat3 jacobian_at(const Vec3& x, bool& overflow) const;
  // Placed parameters that 'extrapolate' cannot evaluate accurately (extrapolation_gain).
  bool too_far(const Vec3& parameters) const;
  void find_safe_ranges();
  // The refusal of a finite row whose parameters overflow or are too_far: names points, the row,
  // the point and, for too_far, its gain and the limit.
  template <class T>
  [[noreturn]] void refuse_row(const T* in, std::size_t row) const;
  // locate() for any point: a non-finite one gets NaN parameters (NotPlaced), so every path
  // reports it as the input's fault, whatever a lattice's locate would make of it.
  PointStatus place(const Vec3& x, Vec3& parameters) const;
  // Rows [0, n): parameters, status (or null), cell key (still's for a point left unchanged),
  // local and ds (or null) as cell_key's. False when some row's parameters are not finite (its
  // input, an overflow, or a row too_far, whose parameters are set to NaN): the caller decides;
  // the other rows are complete.
  template <class T>
  bool place_rows(const T* in, std::size_t n, double* parameters, std::uint8_t* status, std::uint64_t* key,
                  double* local, double* ds) const;
  template <class T>
  bool place_rows_unchecked(const T* in, std::size_t n, double* parameters, std::uint8_t* status,
                            std::uint64_t* key, double* local, double* ds) const;
  template <class T>
  bool deform_points(const T* in, T* out, std::size_t n) const;
  template <class T>
  LatticeBinding bind_points(const T* in, std::size_t n) const;
  void check_binding(const PointBinding& binding) const override;
  bool deform_bound_impl(const PointBinding& binding, float* out) const override;
  bool deform_bound_impl(const PointBinding& binding, double* out) const override;
  bool displacement_bound_impl(const PointBinding& binding, float* out, const double* weights) const override;
  bool displacement_bound_impl(const PointBinding& binding, double* out, const double* weights) const override;
  void bound_points(const PointBinding& binding, StoredPoints<float>& points) const override;
  void bound_points(const PointBinding& binding, StoredPoints<double>& points) const override;
  // The bound points deformed, or with `displacement` their w (F(x) - x) (weights: null or per point).
  template <class T>
  bool deform_sorted(const LatticeBinding& b, T* out, bool displacement = false, const double* weights = nullptr) const;
  template <class T>
  void sort_by_cell(LatticeBinding& b, const T* in, const std::uint64_t* key) const;  // many cells
  // local and ds (optional): per axis the coordinate within the cell and d(local)/d(parameter),
  // 0 where the axis is clamped.
  std::uint64_t cell_key(const Vec3& parameters, double* local, double* ds = nullptr) const;
  std::uint64_t still_key() const;
  std::array<std::int32_t, 3> cell_of_key(std::uint64_t key) const;
  template <class T>
  void cell_block(const std::array<std::int32_t, 3>& cell, T* block) const;
  Vec3 contract(const std::vector<double>& grid, const Vec3& parameters, Mat3* derivative) const;

  LatticeAxes axes_;
  std::vector<double> rest_, control_, offset_;  // offset_ = control_ - rest_
  bool at_rest_ = true;                           // offset_ is all zero
  Outside outside_;
  double strength_;
  std::vector<int> handle_of_;
  int handle_count_ = 0;
  bool affine_ = false;
  Mat3 to_parameters_ = Mat3::Identity();
  Vec3 origin_ = Vec3::Zero();
  // 'extrapolate': per axis, coordinates whose weights' magnitudes sum to at most 99.
  double safe_lo_[3] = {0, 0, 0}, safe_hi_[3] = {1, 1, 1};
};

}  // namespace deformkit

#pragma once
// Radial basis function deformation (de Boer, van der Schoot, Bijl 2007): the displacement field
// d(x) = sum_j alpha_j phi(|x - c_j|) + p(x) that moves every control point c_j exactly onto its
// target (or, with smoothing, in the regularised least-squares sense), with a polynomial p of
// degree <= 2 whose moments the alphas annul. Fitted once per set of controls; a new set of targets
// costs solves with the kept factorisation (docs/math/rbf.md).
#include "deformkit/core/point_binding.hpp"
#include "deformkit/rbf/rbf_kernel.hpp"

#include <cstddef>
#include <memory>
#include <vector>

namespace deformkit {

struct RbfOptions {
  RbfKernelShape kernel;
  int degree = 1;          // -1 (no polynomial), 0 (constant), 1 (affine), 2 (quadratic)
  double smoothing = 0.0;  // >= 0: added to the kernel matrix's diagonal, as scipy's smoothing
};

class RbfFit;    // the factorised system (private: cpp/src/rbf/rbf_fit.hpp)
class RbfGrid;   // compact kernels: the controls by cell of the support radius

// Points bound to an RBF: for a compact kernel their kernel values at the controls within the
// support (a weight table); for a global kernel only the points (a table would be n x m).
struct RbfBinding : PointBinding {
  WeightTable table;           // compact kernels
  std::vector<double> points_f64;
  std::vector<float> points_f32;
};

class RbfDeformer : public BoundDeformer {
 public:
  // controls m x 3, row-major. Throws std::invalid_argument naming control_points (non-finite,
  // too few for the degree, duplicates without smoothing, all on a plane or line that the
  // polynomial cannot be fitted over), kernel parameters (epsilon, radius: positive and finite),
  // degree (-1 .. 2, and at least the kernel's minimum) or smoothing (finite, >= 0), and names a
  // singular or ill-conditioned system with its condition estimate.
  RbfDeformer(const double* controls, std::size_t m, const RbfOptions& options);

  std::size_t control_count() const { return controls_.size() / 3; }
  const std::vector<double>& control_points() const { return controls_; }
  const std::vector<double>& targets() const { return targets_; }
  // New targets (m x 3): the coefficients follow by solves with the kept factorisation. Throws
  // std::invalid_argument naming targets for a wrong count or a non-finite value. Targets equal
  // to the controls bit for bit are the identity.
  void set_targets(std::vector<double> targets);
  const RbfOptions& options() const { return options_; }
  bool is_identity() const override { return at_rest_; }
  // The kernels that grow as r^k with k > 2 (cubic, quintic) map a shorter range than the default.
  double point_magnitude(double limit) const override;
  std::string overflow_parameters() const override;
  // 1-norm condition estimate of the factorised (null-space or sparse) kernel system.
  double condition_estimate() const;
  // The coefficients: alpha (m x 3) and the polynomial's beta (terms x 3, in the basis of
  // docs/math/rbf.md, "Polynomial term").
  const std::vector<double>& alpha() const { return alpha_; }
  const std::vector<double>& beta() const { return beta_; }

  RbfBinding bind(const double* points, std::size_t n) const;
  RbfBinding bind(const float* points, std::size_t n) const;

 private:
  bool deform_impl(const float* in, float* out, std::size_t n) const override;
  bool deform_impl(const double* in, double* out, std::size_t n) const override;
  bool jacobian_impl(const double* in, double* jac, std::size_t n) const override;
  template <class T>
  bool deform_points(const T* in, T* out, std::size_t n) const;
  template <class T>
  RbfBinding bind_points(const T* in, std::size_t n) const;
  void check_binding(const PointBinding& binding) const override;
  bool deform_bound_impl(const PointBinding& binding, float* out) const override;
  bool deform_bound_impl(const PointBinding& binding, double* out) const override;
  void bound_points(const PointBinding& binding, StoredPoints<float>& points) const override;
  void bound_points(const PointBinding& binding, StoredPoints<double>& points) const override;
  template <class T>
  bool deform_bound_points(const RbfBinding& b, T* out) const;
  void displacements(const double* x, std::size_t count, double* out) const;
  void add_polynomial(const double* x, std::size_t count, double* out) const;
  std::uint64_t layout() const;

  std::vector<double> controls_, targets_, alpha_, beta_;
  std::vector<double> columns_;  // controls' x, y, z, then alphas' x, y, z, as columns (m each)
  RbfOptions options_;
  std::shared_ptr<const RbfFit> fit_;    // immutable, shared by copies
  std::shared_ptr<const RbfGrid> grid_;  // compact kernels only
  bool at_rest_ = true;
};

}  // namespace deformkit

#include "rbf/rbf_fit.hpp"

#include "rbf/rbf_grid.hpp"

#include "deformkit/core/validation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

namespace deformkit {

namespace {

// Beyond this the targets may be met to no better than about 1e-2 of the displacements
// (docs/math/rbf.md, "Conditioning"): an error, naming the estimate and what lowers it.
constexpr double kMaxCondition = 1e14;

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

double kernel_value(const RbfKernelShape& k, double r) {
  double v, s;
  rbf_kernel(k, r, &v, &s);
  return v;
}

// Interpolation sends each control to one target: two controls at one place cannot go to two.
void require_distinct(const double* c, std::size_t m) {
  std::vector<std::size_t> order(m);
  std::iota(order.begin(), order.end(), std::size_t(0));
  auto less = [c](std::size_t a, std::size_t b) {
    return std::lexicographical_compare(c + 3 * a, c + 3 * a + 3, c + 3 * b, c + 3 * b + 3);
  };
  std::sort(order.begin(), order.end(), less);
  for (std::size_t s = 1; s < m; ++s)
    if (std::equal(c + 3 * order[s - 1], c + 3 * order[s - 1] + 3, c + 3 * order[s])) {
      const std::size_t a = std::min(order[s - 1], order[s]), b = std::max(order[s - 1], order[s]);
      throw std::invalid_argument("control_points: points " + std::to_string(a) + " and " + std::to_string(b) +
                                  " coincide; an interpolating RBF cannot send one place to two targets "
                                  "(remove one, or give smoothing > 0)");
    }
}

RbfPolynomial polynomial_of(const double* c, std::size_t m, int degree) {
  RbfPolynomial p;
  p.degree = degree;
  double half = 0.0;
  for (int a = 0; a < 3; ++a) {
    double lo = c[a], hi = c[a];
    for (std::size_t j = 1; j < m; ++j) lo = std::min(lo, c[3 * j + a]), hi = std::max(hi, c[3 * j + a]);
    p.centre[a] = 0.5 * (lo + hi);
    half = std::max(half, 0.5 * (hi - lo));
  }
  p.scale = half > 0 ? half : 1.0;
  return p;
}

Eigen::MatrixXd polynomial_matrix(const RbfPolynomial& poly, const double* c, std::size_t m) {
  Eigen::MatrixXd p(Eigen::Index(m), poly.terms());
  double q[10];
  for (std::size_t j = 0; j < m; ++j) {
    poly.basis(c + 3 * j, q);
    for (int k = 0; k < poly.terms(); ++k) p(Eigen::Index(j), k) = q[k];
  }
  return p;
}

std::string span_problem(int degree, Eigen::Index rank, Eigen::Index terms) {
  if (degree == 1)
    return "the controls span only " + std::to_string(rank - 1) +
           " dimension(s) (all on a plane, a line or a point): an affine polynomial (degree=1) needs controls "
           "spanning 3D; use degree=0 or -1, or add controls off the plane";
  return "the controls lie on a quadric surface (the quadratic polynomial's basis has rank " + std::to_string(rank) +
         " of " + std::to_string(terms) + " on them): use degree=1 or add controls";
}

// The largest span of the controls along an axis.
double extent_of(const double* c, std::size_t m) {
  double span = 0.0;
  for (int a = 0; a < 3; ++a) {
    double lo = c[a], hi = c[a];
    for (std::size_t j = 1; j < m; ++j) lo = std::min(lo, c[3 * j + a]), hi = std::max(hi, c[3 * j + a]);
    span = std::max(span, hi - lo);
  }
  return span;
}

// The argument a singular system is blamed on: controls beyond the range points may take; else a
// shape parameter that makes the kernel nearly flat over the controls (epsilon, whose remedy is
// a larger one; a support radius of at least the controls' extent); else the controls themselves
// (nearly coincident).
[[noreturn]] void ill_conditioned(const RbfOptions& o, double condition, double extent) {
  const bool shaped = o.kernel.kind == RbfKernel::Gaussian || o.kernel.kind == RbfKernel::Multiquadric ||
                      o.kernel.kind == RbfKernel::InverseMultiquadric || o.kernel.kind == RbfKernel::InverseQuadratic;
  std::string hint = o.smoothing > 0 ? "a larger smoothing" : "smoothing > 0";
  std::string blamed = "control_points: these controls make the ";
  if (!(extent < point_range())) {
    blamed = "control_points: spanning " + number(extent) + ", beyond the magnitude points may take (" +
             number(point_range()) + "), they make the ";
  } else if (shaped) {
    // phi(eps r) flat over the controls (eps r small) or overflowing (eps r huge).
    const double scaled = o.kernel.epsilon * extent;
    hint = (scaled > 1.0 ? "a smaller epsilon (a wider kernel), " : "a larger epsilon (a narrower kernel), ") + hint;
    blamed = "epsilon: " + number(o.kernel.epsilon) + " (epsilon times the controls' extent is " + number(scaled) +
             ") makes the ";
  } else if (rbf_compact(o.kernel.kind) && o.kernel.radius >= extent) {
    hint = "a smaller radius, " + hint;
    blamed = "radius: " + number(o.kernel.radius) + ", at least the controls' extent " + number(extent) + ", makes the ";
  }
  throw std::invalid_argument(blamed + std::string(rbf_kernel_name(o.kernel.kind)) +
                              " RBF system singular or ill-conditioned (condition estimate " + number(condition) +
                              ", the limit is " + number(kMaxCondition) + "); try " + hint +
                              ", or remove controls that nearly coincide");
}

}  // namespace

void RbfPolynomial::basis(const double x[3], double* q) const {
  if (degree < 0) return;
  q[0] = 1.0;
  if (degree == 0) return;
  const double u[3] = {(x[0] - centre[0]) / scale, (x[1] - centre[1]) / scale, (x[2] - centre[2]) / scale};
  for (int a = 0; a < 3; ++a) q[1 + a] = u[a];
  if (degree == 1) return;
  int k = 4;
  for (int a = 0; a < 3; ++a)
    for (int b = a; b < 3; ++b) q[k++] = u[a] * u[b];
}

void RbfPolynomial::gradient(const double x[3], double* dq) const {
  const int t = terms();
  std::fill(dq, dq + 3 * t, 0.0);
  if (degree < 1) return;
  const double u[3] = {(x[0] - centre[0]) / scale, (x[1] - centre[1]) / scale, (x[2] - centre[2]) / scale};
  for (int a = 0; a < 3; ++a) dq[3 * (1 + a) + a] = 1.0 / scale;
  if (degree == 1) return;
  int k = 4;
  for (int a = 0; a < 3; ++a)
    for (int b = a; b < 3; ++b, ++k) {  // d(u_a u_b)/dx_c = (delta_ac u_b + u_a delta_bc) / scale
      dq[3 * k + a] += u[b] / scale;
      dq[3 * k + b] += u[a] / scale;
    }
}

RbfFit::RbfFit(const double* c, std::size_t m, const RbfOptions& o, const RbfGrid* grid) : m_(m) {
  polynomial_ = polynomial_of(c, m, o.degree);
  const Eigen::Index t = polynomial_.terms(), n = Eigen::Index(m);
  if (n < std::max<Eigen::Index>(t, 1))
    throw std::invalid_argument("control_points: degree " + std::to_string(o.degree) + " needs at least " +
                                std::to_string(std::max<Eigen::Index>(t, 1)) + " controls, got " + std::to_string(m));
  if (o.smoothing == 0.0) require_distinct(c, m);
  if (t > 0) {
    p_ = polynomial_matrix(polynomial_, c, m);
    qr_.setThreshold(1e-10);  // the basis is scaled to [-1, 1]: a relative rank threshold
    qr_.compute(p_);
    if (qr_.rank() < t) throw std::invalid_argument("control_points: " + span_problem(o.degree, qr_.rank(), t));
  }
  sparse_ = rbf_compact(o.kernel.kind);
  if (sparse_) {
    std::vector<Eigen::Triplet<double>> entries;
    for (std::size_t i = 0; i < m; ++i)
      grid->for_each_within(c + 3 * i, [&](std::size_t j, double r) {
        entries.emplace_back(Eigen::Index(i), Eigen::Index(j), kernel_value(o.kernel, r) + (i == j ? o.smoothing : 0.0));
      });
    SparseMatrix k(n, n);
    k.setFromTriplets(entries.begin(), entries.end());
    cholesky_ = std::make_shared<SparseCholesky>();
    if (!cholesky_->factorize(k, CholeskyKind::Supernodal)) ill_conditioned(o, std::numeric_limits<double>::infinity(), extent_of(c, m));
    if (t > 0) {
      kinv_p_ = cholesky_->solve(p_);
      schur_.compute(p_.transpose() * kinv_p_);
      if (schur_.info() != Eigen::Success || !(schur_.rcond() > 1.0 / kMaxCondition))
        ill_conditioned(o, 1.0 / schur_.rcond(), extent_of(c, m));
    }
    condition_ = std::numeric_limits<double>::quiet_NaN();  // not estimated for the sparse factor
    return;
  }
  kernel_.resize(n, n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j <= i; ++j) {
      const double* a = c + 3 * i;
      const double* b = c + 3 * j;
      const double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
      kernel_(i, j) = kernel_(j, i) = kernel_value(o.kernel, std::sqrt(dx * dx + dy * dy + dz * dz));
    }
  kernel_.diagonal().array() += o.smoothing;
  if (t == 0) {
    reduced_.compute(kernel_);
  } else {
    // Q^T K Q, whose block beyond the polynomial's t columns is A = Q2^T K Q2 (Q2: the null space
    // of P^T, where the alphas live). Positive definite for the kernel's minimum degree and above.
    Eigen::MatrixXd a = qr_.householderQ().adjoint() * kernel_;
    a = (qr_.householderQ().adjoint() * a.transpose()).eval();
    reduced_.compute(a.bottomRightCorner(n - t, n - t));
  }
  const double rcond = reduced_.info() == Eigen::Success ? reduced_.rcond() : 0.0;
  condition_ = rcond > 0 ? 1.0 / rcond : std::numeric_limits<double>::infinity();
  if (!(condition_ <= kMaxCondition)) ill_conditioned(o, condition_, extent_of(c, m));
}

void RbfFit::solve(const double* displacements, double* alpha, double* beta) const {
  const Eigen::Index n = Eigen::Index(m_), t = polynomial_.terms();
  using Rows = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>;
  using RowsOut = Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>;
  const Eigen::MatrixXd y = Rows(displacements, n, 3);
  Eigen::MatrixXd a, b;
  if (sparse_) {
    a = cholesky_->solve(y);
    if (t > 0) {
      b = schur_.solve(p_.transpose() * a);
      a -= kinv_p_ * b;
    }
  } else if (t == 0) {
    a = reduced_.solve(y);
  } else {
    Eigen::MatrixXd z = qr_.householderQ().adjoint() * y;
    z.topRows(t).setZero();
    z.bottomRows(n - t) = reduced_.solve(z.bottomRows(n - t));
    a = qr_.householderQ() * z;
    b = qr_.solve(Eigen::MatrixXd(y - kernel_ * a));  // P beta = y - K alpha, exactly solvable
  }
  RowsOut(alpha, n, 3) = a;
  if (t > 0) RowsOut(beta, t, 3) = b;
}

}  // namespace deformkit

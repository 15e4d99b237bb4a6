#include "deformkit/rbf/rbf_deformer.hpp"

#include "core/parallel.hpp"
#include "rbf/rbf_fit.hpp"
#include "rbf/rbf_grid.hpp"
#include "rbf/rbf_rows.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace deformkit {

namespace {

void require_positive(double v, const char* name) {
  if (!(std::isfinite(v) && v > 0.0))
    throw std::invalid_argument(std::string(name) + ": expected a positive finite number, got " + std::to_string(v));
}

void check_options(const RbfOptions& o) {
  require_positive(o.kernel.epsilon, "epsilon");
  require_positive(o.kernel.radius, "radius");
  if (o.degree < -1 || o.degree > 2)
    throw std::invalid_argument("degree: expected -1 (no polynomial), 0, 1 or 2, got " + std::to_string(o.degree));
  const int least = rbf_minimum_degree(o.kernel.kind);
  if (o.degree < least)
    throw std::invalid_argument("degree: the " + std::string(rbf_kernel_name(o.kernel.kind)) + " kernel needs degree >= " +
                                std::to_string(least) + ", got " + std::to_string(o.degree) +
                                " (below it the system can be singular: the kernel is only conditionally "
                                "positive definite)");
  if (!(std::isfinite(o.smoothing) && o.smoothing >= 0.0))
    throw std::invalid_argument("smoothing: expected a finite number >= 0, got " + std::to_string(o.smoothing));
}

// Points go to the kernel sums this many at a time: a few kilobytes of scratch per thread.
constexpr std::size_t kChunk = 256;

}  // namespace

// |phi(r)| grows as r^k for large r (thin plate spline as r^2 log r); the polynomial as |x|^degree.
static int growth(const RbfOptions& o) {
  int k = 0;
  switch (o.kernel.kind) {
    case RbfKernel::Linear: case RbfKernel::Multiquadric: k = 1; break;
    case RbfKernel::ThinPlateSpline: k = 2; break;
    case RbfKernel::Cubic: k = 3; break;
    case RbfKernel::Quintic: k = 5; break;
    default: k = 0;  // decaying or compactly supported
  }
  return std::max(k, o.degree);
}

double RbfDeformer::point_magnitude(double limit) const {
  // r^k stays below limit / 1024 (room for the log factor and the sum) up to (limit / 1024)^(1/k);
  // the margin of 16 is point_range's.
  const int k = growth(options_);
  const double range = point_range(limit);
  return k <= 2 ? range : std::min(range, std::pow(limit / 1024.0, 1.0 / k) / 16.0);
}

std::string RbfDeformer::overflow_parameters() const {
  if (rbf_compact(options_.kernel.kind)) return "targets, radius";
  switch (options_.kernel.kind) {
    case RbfKernel::Gaussian: case RbfKernel::Multiquadric: case RbfKernel::InverseMultiquadric:
    case RbfKernel::InverseQuadratic: return "targets, epsilon";
    default: return "targets";
  }
}

RbfDeformer::RbfDeformer(const double* controls, std::size_t m, const RbfOptions& options) : options_(options) {
  check_options(options);
  if (m == 0) throw std::invalid_argument("control_points: expected at least one control point, got none");
  require_finite_rows(controls, m, "control_points");
  controls_.assign(controls, controls + 3 * m);
  targets_ = controls_;
  if (rbf_compact(options.kernel.kind)) grid_ = std::make_shared<const RbfGrid>(controls, m, options.kernel.radius);
  fit_ = std::make_shared<const RbfFit>(controls, m, options, grid_.get());
  alpha_.assign(3 * m, 0.0);
  beta_.assign(3 * std::size_t(fit_->polynomial().terms()), 0.0);
  columns_.assign(6 * m, 0.0);
  for (std::size_t j = 0; j < m; ++j)
    for (int a = 0; a < 3; ++a) columns_[a * m + j] = controls_[3 * j + a];
}

double RbfDeformer::condition_estimate() const { return fit_->condition_estimate(); }

void RbfDeformer::set_targets(std::vector<double> targets) {
  const std::size_t m = control_count();
  if (targets.size() != controls_.size())
    throw std::invalid_argument("targets: expected " + std::to_string(m) + " points (one per control), got " +
                                std::to_string(targets.size() / 3));
  for (std::size_t i = 0; i < targets.size(); ++i)
    if (!std::isfinite(targets[i]))
      throw std::invalid_argument("targets: point " + std::to_string(i / 3) + " is not finite");
  std::vector<double> displacement(targets.size());
  for (std::size_t i = 0; i < targets.size(); ++i) displacement[i] = targets[i] - controls_[i];
  std::vector<double> alpha(alpha_.size()), beta(beta_.size());
  fit_->solve(displacement.data(), alpha.data(), beta.data());
  for (double v : alpha)
    if (!std::isfinite(v)) throw std::invalid_argument("targets: the coefficients overflow; the displacements are too large");
  // Bit for bit, so that targets moved back onto the controls are the identity again.
  at_rest_ = targets == controls_;
  targets_ = std::move(targets);
  alpha_ = std::move(alpha);
  beta_ = std::move(beta);
  for (std::size_t j = 0; j < m; ++j)
    for (int a = 0; a < 3; ++a) columns_[(3 + a) * m + j] = alpha_[3 * j + a];
}

// d(x) for count finite points (count x 3) into out: the kernel sums, then the polynomial.
void RbfDeformer::displacements(const double* x, std::size_t count, double* out) const {
  const std::size_t m = control_count();
  if (grid_) {
    for (std::size_t i = 0; i < count; ++i) {
      double s[3] = {0, 0, 0};
      grid_->for_each_within(x + 3 * i, [&](std::size_t j, double r) {
        double v, slope;
        rbf_kernel(options_.kernel, r, &v, &slope);
        for (int a = 0; a < 3; ++a) s[a] += alpha_[3 * j + a] * v;
      });
      for (int a = 0; a < 3; ++a) out[3 * i + a] = s[a];
    }
  } else {
    RbfColumns col;
    for (int a = 0; a < 3; ++a) {
      col.c[a] = columns_.data() + a * m;
      col.alpha[a] = columns_.data() + (3 + a) * m;
    }
    col.m = m;
    rbf_kernel_sums(x, count, col, options_.kernel, out);
  }
  add_polynomial(x, count, out);
}

void RbfDeformer::add_polynomial(const double* x, std::size_t count, double* out) const {
  const RbfPolynomial& poly = fit_->polynomial();
  const int t = poly.terms();
  if (t == 0) return;
  double q[10];
  for (std::size_t i = 0; i < count; ++i) {
    poly.basis(x + 3 * i, q);
    for (int k = 0; k < t; ++k)
      for (int a = 0; a < 3; ++a) out[3 * i + a] += q[k] * beta_[3 * std::size_t(k) + a];
  }
}

template <class T>
bool RbfDeformer::deform_points(const T* in, T* out, std::size_t n) const {
  std::atomic<bool> finite{true};
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    double x[3 * kChunk], d[3 * kChunk];
    bool ok = true;
    for (std::size_t lo = begin; lo < end; lo += kChunk) {
      const std::size_t count = std::min(kChunk, end - lo);
      for (std::size_t k = 0; k < 3 * count; ++k) {
        x[k] = double(in[3 * lo + k]);
        if (!std::isfinite(x[k])) ok = false, x[k] = 0.0;
      }
      displacements(x, count, d);
      for (std::size_t k = 0; k < 3 * count; ++k) {
        out[3 * lo + k] = static_cast<T>(x[k] + d[k]);
        ok = ok && std::isfinite(out[3 * lo + k]);
      }
    }
    if (!ok) finite = false;
  });
  return finite;
}

bool RbfDeformer::deform_impl(const float* in, float* out, std::size_t n) const { return deform_points(in, out, n); }
bool RbfDeformer::deform_impl(const double* in, double* out, std::size_t n) const { return deform_points(in, out, n); }

// J = I + sum_j alpha_j (phi'(r_j) / r_j) (x - c_j)^T + sum_k beta_k (grad q_k)^T.
bool RbfDeformer::jacobian_impl(const double* in, double* jac, std::size_t n) const {
  const std::size_t m = control_count();
  const RbfPolynomial& poly = fit_->polynomial();
  const int t = poly.terms();
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    double dq[30];
    for (std::size_t i = begin; i < end; ++i) {
      const double* x = in + 3 * i;
      double j[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
      auto add = [&](std::size_t c, double r) {
        double v, slope;
        rbf_kernel(options_.kernel, r, &v, &slope);
        const double* p = controls_.data() + 3 * c;
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) j[3 * a + b] += alpha_[3 * c + a] * slope * (x[b] - p[b]);
      };
      if (grid_) {
        grid_->for_each_within(x, add);
      } else {
        for (std::size_t c = 0; c < m; ++c) {
          const double* p = controls_.data() + 3 * c;
          const double dx = x[0] - p[0], dy = x[1] - p[1], dz = x[2] - p[2];
          add(c, std::sqrt(dx * dx + dy * dy + dz * dz));
        }
      }
      if (t > 0) {
        poly.gradient(x, dq);
        for (int k = 0; k < t; ++k)
          for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b) j[3 * a + b] += beta_[3 * std::size_t(k) + a] * dq[3 * k + b];
      }
      std::copy(j, j + 9, jac + 9 * i);
    }
  });
  return false;
}

std::uint64_t RbfDeformer::layout() const {
  std::uint64_t h = 1469598103934665603ull;  // FNV-1a over what a binding's table depends on
  auto mix = [&h](const void* p, std::size_t bytes) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < bytes; ++i) h = (h ^ c[i]) * 1099511628211ull;
  };
  mix(controls_.data(), controls_.size() * sizeof(double));
  mix(&options_.kernel.kind, sizeof options_.kernel.kind);
  mix(&options_.kernel.epsilon, sizeof(double));
  mix(&options_.kernel.radius, sizeof(double));
  return h;
}

template <class T>
RbfBinding RbfDeformer::bind_points(const T* in, std::size_t n) const {
  require_finite_rows(in, n, "points");
  RbfBinding b;
  b.point_count = n;
  b.single_precision = std::is_same<T, float>::value;
  b.layout = layout();
  if constexpr (std::is_same<T, float>::value) b.points_f32.assign(in, in + 3 * n);
  else b.points_f64.assign(in, in + 3 * n);
  if (!grid_) return b;  // a global kernel's table would be n x m: the sums are evaluated per deform
  // Compact: each point's kernel values at the controls within the support, one grid search per
  // point; each block's rows are joined in block order afterwards.
  struct Rows {
    std::size_t begin = 0;
    std::vector<std::int64_t> counts;
    std::vector<std::int32_t> indices;
    std::vector<double> values;
  };
  std::vector<Rows> blocks(std::size_t(parallel_threads()) + 1);
  std::atomic<std::size_t> block_count{0};
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    Rows& rows = blocks[block_count++];
    rows.begin = begin;
    rows.counts.reserve(end - begin);
    for (std::size_t i = begin; i < end; ++i) {
      const double x[3] = {double(in[3 * i]), double(in[3 * i + 1]), double(in[3 * i + 2])};
      const std::size_t before = rows.values.size();
      grid_->for_each_within(x, [&](std::size_t j, double r) {
        double v, slope;
        rbf_kernel(options_.kernel, r, &v, &slope);
        rows.indices.push_back(std::int32_t(j));
        rows.values.push_back(v);
      });
      rows.counts.push_back(std::int64_t(rows.values.size() - before));
    }
  });
  blocks.resize(block_count.load());
  std::sort(blocks.begin(), blocks.end(), [](const Rows& a, const Rows& c) { return a.begin < c.begin; });
  std::size_t total = 0;
  for (const Rows& r : blocks) total += r.values.size();
  b.table.indptr.reserve(n + 1);
  b.table.indices.reserve(total);
  b.table.values.reserve(total);
  for (Rows& r : blocks) {
    for (std::int64_t c : r.counts) b.table.indptr.push_back(b.table.indptr.back() + c);
    b.table.indices.insert(b.table.indices.end(), r.indices.begin(), r.indices.end());
    b.table.values.insert(b.table.values.end(), r.values.begin(), r.values.end());
    r = Rows{};  // the block's memory goes as soon as it is copied
  }
  return b;
}

RbfBinding RbfDeformer::bind(const double* points, std::size_t n) const { return bind_points(points, n); }
RbfBinding RbfDeformer::bind(const float* points, std::size_t n) const { return bind_points(points, n); }

void RbfDeformer::check_binding(const PointBinding& binding) const {
  const auto* b = dynamic_cast<const RbfBinding*>(&binding);
  if (!b) throw std::invalid_argument("binding: was not made by an RBF; bind the points to this RBF");
  if (b->layout != layout())
    throw std::invalid_argument("binding: was made by an RBF of other controls or kernel; bind the points to this RBF");
}

void RbfDeformer::bound_points(const PointBinding& b, StoredPoints<float>& points) const {
  const float* p = static_cast<const RbfBinding&>(b).points_f32.data();
  points = StoredPoints<float>{{p, p + 1, p + 2}, 3, nullptr};
}
void RbfDeformer::bound_points(const PointBinding& b, StoredPoints<double>& points) const {
  const double* p = static_cast<const RbfBinding&>(b).points_f64.data();
  points = StoredPoints<double>{{p, p + 1, p + 2}, 3, nullptr};
}

// Compact kernels: the table times the alphas (the shared seam's product), plus x and p(x).
template <class T>
bool RbfDeformer::deform_bound_points(const RbfBinding& b, T* out) const {
  const std::size_t n = b.size();
  const T* in = nullptr;
  if constexpr (std::is_same<T, float>::value) in = b.points_f32.data();
  else in = b.points_f64.data();
  if (!grid_) return deform_points(in, out, n);
  std::vector<double> sums(3 * n);
  apply_weight_table(b.table, alpha_.data(), 3, sums.data());
  std::atomic<bool> finite{true};
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    bool ok = true;
    for (std::size_t lo = begin; lo < end; lo += kChunk) {
      const std::size_t count = std::min(kChunk, end - lo);
      double x[3 * kChunk];
      for (std::size_t k = 0; k < 3 * count; ++k) x[k] = double(in[3 * lo + k]);
      add_polynomial(x, count, sums.data() + 3 * lo);
      for (std::size_t k = 0; k < 3 * count; ++k) {
        out[3 * lo + k] = static_cast<T>(x[k] + sums[3 * lo + k]);
        ok = ok && std::isfinite(out[3 * lo + k]);
      }
    }
    if (!ok) finite = false;
  });
  return finite;
}

bool RbfDeformer::deform_bound_impl(const PointBinding& b, float* out) const {
  return deform_bound_points(static_cast<const RbfBinding&>(b), out);
}
bool RbfDeformer::deform_bound_impl(const PointBinding& b, double* out) const {
  return deform_bound_points(static_cast<const RbfBinding&>(b), out);
}

}  // namespace deformkit

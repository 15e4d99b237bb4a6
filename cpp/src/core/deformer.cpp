#include "deformkit/core/deformer.hpp"

#include "core/parallel.hpp"
#include "core/weight_blend.hpp"
#include "core/scale_free.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

namespace deformkit {

constexpr double kDoubleMax = std::numeric_limits<double>::max();

void Deformer::set_weights(std::vector<double> weights) {
  if (weights.empty()) throw std::invalid_argument("weights: is empty (pass None for no weights)");
  for (std::size_t i = 0; i < weights.size(); ++i) {
    if (!std::isfinite(weights[i]))
      throw std::invalid_argument("weights: entry " + std::to_string(i) + " is not finite");
    if (!(weights[i] >= 0.0 && weights[i] <= 1.0)) {
      std::ostringstream msg;
      msg << "weights: entry " << i << " is " << weights[i] << "; expected a number in [0, 1] (as Blender's "
          << "vertex-group weights)";
      throw std::invalid_argument(msg.str());
    }
  }
  weights_ = std::make_shared<const std::vector<double>>(std::move(weights));
}

const std::vector<double>& Deformer::no_weights() {
  static const std::vector<double> none;
  return none;
}

void require_weight_count(const std::vector<double>& w, std::size_t n, const char* holder, const char* unit) {
  if (!w.empty() && w.size() != n)
    throw std::invalid_argument("weights: has " + std::to_string(w.size()) + " entries but " + holder + " has " +
                                std::to_string(n) + " " + unit);
}

void identity_jacobians(double* jac, std::size_t n) {
  for (std::size_t i = 0; i < 9 * n; ++i) jac[i] = (i % 9) % 4 == 0 ? 1.0 : 0.0;
}

// Runs a finite-results check; an overflow it reports is re-reported against `d`: the point
// (row of `in`, when given) beyond d's magnitude is blamed on `points`, else d's parameters are
// named, with the point.
template <class T, class Check>
static void report_against(const Deformer& d, const T* in, double limit, Check&& check) {
  try {
    check();
  } catch (const NonFiniteResult& e) {
    const double range = d.point_magnitude(std::min(limit, double(std::numeric_limits<T>::max())));
    std::ostringstream detail;
    detail.precision(3);
    if (in) {
      const T* x = in + 3 * e.row;
      blame_points_beyond_range(e.row, e.quantity, x, range);
      detail << " (the point (" << x[0] << ", " << x[1] << ", " << x[2] << ") is within the accepted magnitude "
             << range << ")";
    }
    const std::string names = d.overflow_parameters();
    throw_non_finite_result(e.row, e.quantity, names.empty() ? "the parameters" : "its parameters (" + names + ")",
                            detail.str());
  }
}

// After an implementation reported a non-finite row: blame the input if it is the culprit,
// otherwise the parameters, which made a finite point overflow.
// In place (in == out) the input was checked before it was overwritten: deform_checked kept the
// rows beyond the magnitude for this report.
template <class T>
static void report_non_finite(const Deformer& d, const T* in, const T* out, std::size_t n) {
  if (in == out) return report_against(d, static_cast<const T*>(nullptr), kDoubleMax, [&] {
    require_finite_results(out, n, 3, "position");
  });
  require_finite_rows(in, n, "points");
  report_against(d, in, kDoubleMax, [&] { require_finite_results_of(out, n, 3, "position", in); });
}

// An in-place call's input rows of magnitude `range` or more, kept before they are overwritten.
template <class T>
static std::vector<std::pair<std::size_t, std::array<T, 3>>> rows_beyond(const T* in, std::size_t n, double range) {
  std::vector<std::pair<std::size_t, std::array<T, 3>>> far;
  for (std::size_t i = 0; i < n; ++i)
    if (std::max({std::abs(double(in[3 * i])), std::abs(double(in[3 * i + 1])), std::abs(double(in[3 * i + 2]))}) >= range)
      far.push_back({i, {in[3 * i], in[3 * i + 1], in[3 * i + 2]}});
  return far;
}

template <class T>
void Deformer::deform_checked(const T* in, T* out, std::size_t n, bool input_verified) const {
  const double range = point_magnitude(double(std::numeric_limits<T>::max()));
  std::vector<std::pair<std::size_t, std::array<T, 3>>> far;
  // In place, a non-finite row must be reported before anything is overwritten, and a row beyond
  // the magnitude kept for the overflow report.
  if (in == out && !input_verified && !all_finite(in, n, 3, range)) {
    require_finite_rows(in, n, "points");
    far = rows_beyond(in, n, range);
  }
  try {
    deform_unchecked(in, out, n, input_verified);
  } catch (const NonFiniteResult& e) {
    const auto row = std::find_if(far.begin(), far.end(), [&](const auto& r) { return r.first == e.row; });
    if (row != far.end()) blame_points_beyond_range(e.row, e.quantity, row->second.data(), range);
    throw;
  }
}

template <class T>
void Deformer::deform_unchecked(const T* in, T* out, std::size_t n, bool input_verified) const {
  const std::vector<double>& w = weights();
  require_weight_count(w, n, "points", "rows");
  if (is_identity()) {  // exact, with no arithmetic that could round, flip -0.0 or overflow
    if (in != out) {
      if (!input_verified && !all_finite(in, n, 3)) require_finite_rows(in, n, "points");
      std::copy(in, in + 3 * n, out);
    }
    return;
  }
  if (w.empty()) {
    if (!deform_impl(in, out, n)) report_non_finite(*this, in, out, n);
    return;
  }
  // The blend needs the original positions, which an in-place call overwrites.
  std::vector<T> original;
  const T* source = in;
  if (in == out) {
    original.assign(in, in + 3 * n);
    source = original.data();
  }
  if (!deform_impl(source, out, n)) report_non_finite(*this, source, out, n);
  blend_toward_originals(w, source, out, n);
}

void Deformer::deform(const float* in, float* out, std::size_t n) const { deform_checked(in, out, n, false); }
void Deformer::deform(const double* in, double* out, std::size_t n) const { deform_checked(in, out, n, false); }
void Deformer::deform_verified(const float* in, float* out, std::size_t n) const { deform_checked(in, out, n, true); }
void Deformer::deform_verified(const double* in, double* out, std::size_t n) const { deform_checked(in, out, n, true); }

template <class T>
void Deformer::displace(const T* in, T* out, std::size_t n) const {
  if (in == out) throw std::invalid_argument("out: displacement cannot be written over points");
  require_weight_count(weights(), n, "points", "rows");
  if (!is_identity() && displacement_impl(in, out, n, weights().empty() ? nullptr : weights().data())) return;
  deform(in, out, n);
  std::atomic<bool> finite{true};
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    T acc = 0;  // F(x) and x finite, F(x) - x may still overflow (x near the range's end, moved far)
#pragma omp simd reduction(+ : acc)
    for (std::size_t i = 3 * begin; i < 3 * end; ++i) {
      out[i] -= in[i];
      acc += out[i] * T(0);
    }
    if (acc != acc) finite = false;
  });
  if (!finite) report_against(*this, in, kDoubleMax, [&] { require_finite_results_of(out, n, 3, "displacement", in); });
}

void Deformer::displacement(const float* in, float* out, std::size_t n) const { displace(in, out, n); }
void Deformer::displacement(const double* in, double* out, std::size_t n) const { displace(in, out, n); }

static void blend_jacobians(const std::vector<double>& w, double* jac, std::size_t n) {
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i)
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
          double& j = jac[9 * i + 3 * r + c];
          j = w[i] * j + (r == c ? 1.0 - w[i] : 0.0);
        }
  });
}

void Deformer::jacobian(const double* in, double* jac, std::size_t n, bool float32_result) const {
  require_weight_count(weights(), n, "points", "rows");
  if (is_identity()) {
    require_finite_rows(in, n, "points");
    identity_jacobians(jac, n);
    return;
  }
  const bool verified = jacobian_impl(in, jac, n);
  // (1 - w) I + w J with w in [0, 1] is finite where J is: one check after the blend serves both.
  const double limit = float32_result ? double(std::numeric_limits<float>::max()) : kDoubleMax;
  if (!weights().empty()) blend_jacobians(weights(), jac, n);
  if (verified && !float32_result) return;
  require_finite_rows(in, n, "points");  // a bad input row is named before the results it spoilt
  report_against(*this, in, limit, [&] { require_finite_results_of(jac, n, 9, "Jacobian", in, limit); });
}

Mat3 cofactor(const Mat3& j) {
  // Columns of cof(J) as in the lecture: [J2 x J3, J3 x J1, J1 x J2] are the rows of det(J) J^-1.
  Mat3 rows;
  rows.row(0) = j.col(1).cross(j.col(2)).transpose();
  rows.row(1) = j.col(2).cross(j.col(0)).transpose();
  rows.row(2) = j.col(0).cross(j.col(1)).transpose();
  return rows.transpose();
}

static Mat3 read_mat(const double* p) {
  Mat3 m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m(r, c) = p[3 * r + c];
  return m;
}

// A deformer's fast path serves a call the generic path would not refuse for its weights' count,
// and one whose output does not overlap its inputs (a fast path that gives up part way leaves the
// generic path to read the inputs again).
// out_width: the output's values per row (3 for normals, 1 for volume ratios); inputs have 3.
template <class T>
static bool fast_path_applies(const Deformer& d, const T* points, const T* normals, const T* out, std::size_t n,
                              std::size_t out_width) {
  auto apart = [n, out, out_width](const T* input) { return !input || out + out_width * n <= input || input + 3 * n <= out; };
  return !d.is_identity() && (d.weights().empty() || d.weights().size() == n) && apart(points) && apart(normals);
}

void transform_normals(const Deformer& d, const double* points, const double* normals, double* out,
                       std::size_t n) {
  if (fast_path_applies(d, points, normals, out, n, 3) && d.normals_impl(points, normals, out, n)) return;
  require_finite_rows(normals, n, "normals");
  std::vector<double> jac(9 * n);
  d.jacobian(points, jac.data(), n);
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const Vec3 m = normal_direction(read_mat(&jac[9 * i]), Vec3(normals[3 * i], normals[3 * i + 1], normals[3 * i + 2]));
      for (int a = 0; a < 3; ++a) out[3 * i + a] = m[a];
    }
  });
}

void transform_normals(const Deformer& d, const float* points, const float* normals, float* out, std::size_t n) {
  if (fast_path_applies(d, points, normals, out, n, 3) && d.normals_impl(points, normals, out, n)) return;
  const std::vector<double> p(points, points + 3 * n), q(normals, normals + 3 * n);
  std::vector<double> r(3 * n);
  transform_normals(d, p.data(), q.data(), r.data(), n);
  std::copy(r.begin(), r.end(), out);  // unit vectors: always representable
}

void volume_ratio(const Deformer& d, const double* points, double* out, std::size_t n, bool float32_result) {
  const double limit = float32_result ? double(std::numeric_limits<float>::max()) : kDoubleMax;
  if (fast_path_applies(d, points, static_cast<const double*>(nullptr), out, n, 1) && d.volume_ratio_impl(points, out, n)) {
    if (all_finite(out, n, 1, limit)) return;
  }
  std::vector<double> jac(9 * n);
  d.jacobian(points, jac.data(), n);
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) out[i] = scaled_determinant(read_mat(&jac[9 * i]));
  });
  report_against(d, points, limit, [&] { require_finite_results_of(out, n, 1, "volume ratio", points, limit); });
}

}  // namespace deformkit

#include "deformkit/core/point_binding.hpp"

#include "core/parallel.hpp"
#include "core/weight_blend.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace deformkit {

void WeightTable::require_valid(std::size_t columns, const char* name) const {
  const std::string n(name);
  if (indptr.empty() || indptr.front() != 0)
    throw std::invalid_argument(n + ": indptr must start at 0");
  if (std::uint64_t(indptr.back()) != indices.size() || indices.size() != values.size())
    throw std::invalid_argument(n + ": indptr ends at " + std::to_string(indptr.back()) + " but there are " +
                                std::to_string(indices.size()) + " indices and " + std::to_string(values.size()) +
                                " values");
  for (std::size_t r = 0; r + 1 < indptr.size(); ++r)
    if (indptr[r + 1] < indptr[r])
      throw std::invalid_argument(n + ": indptr decreases at row " + std::to_string(r));
  for (std::size_t k = 0; k < indices.size(); ++k) {
    if (indices[k] < 0 || std::size_t(indices[k]) >= columns)
      throw std::invalid_argument(n + ": column " + std::to_string(indices[k]) + " is outside 0.." +
                                  std::to_string(columns) + " - 1");
    if (!std::isfinite(values[k])) throw std::invalid_argument(n + ": weight " + std::to_string(k) + " is not finite");
  }
}

namespace {

// Rows [begin, end) of the product, kWidth columns when it is known at compile time (0: `width`).
// A known width keeps the accumulator in registers; the sums are the same, in the same order.
template <std::size_t kWidth, class T>
void weight_table_rows(const WeightTable& w, const double* control, std::size_t width, std::size_t begin,
                       std::size_t end, double* acc, T* out) {
  const std::size_t cw = kWidth ? kWidth : width;
  for (std::size_t i = begin; i < end; ++i) {
    for (std::size_t c = 0; c < cw; ++c) acc[c] = 0.0;
    for (std::int64_t k = w.indptr[i]; k < w.indptr[i + 1]; ++k) {
      const double v = w.values[k];
      const double* p = control + cw * std::size_t(w.indices[k]);
      for (std::size_t c = 0; c < cw; ++c) acc[c] += v * p[c];
    }
    for (std::size_t c = 0; c < cw; ++c) out[cw * i + c] = static_cast<T>(acc[c]);
  }
}

}  // namespace

template <class T>
void apply_weight_table(const WeightTable& w, const double* control, std::size_t width, T* out) {
  parallel_blocks(w.rows(), [&](std::size_t begin, std::size_t end) {
    if (width == 3) {  // positions: the common case
      double acc[3];
      weight_table_rows<3>(w, control, width, begin, end, acc, out);
    } else {
      std::vector<double> acc(width);  // in double also for float32 results
      weight_table_rows<0>(w, control, width, begin, end, acc.data(), out);
    }
  });
}
template void apply_weight_table<float>(const WeightTable&, const double*, std::size_t, float*);
template void apply_weight_table<double>(const WeightTable&, const double*, std::size_t, double*);

// The bound path's policy, in the order deform() applies it: the weight count first (nothing is
// computed for a call that cannot succeed), then the binding's owner and dtype.
template <class T>
void BoundDeformer::check_bound_call(const PointBinding& b) const {
  require_weight_count(weights(), b.size(), "the binding", "points");
  check_binding(b);
  if (b.single_precision != std::is_same<T, float>::value)
    throw std::invalid_argument(std::string("binding: holds ") + (b.single_precision ? "float32" : "float64") +
                                " points; deform them into an array of that dtype");
}

template <class T>
void BoundDeformer::deform_bound_checked(const PointBinding& b, T* out) const {
  check_bound_call<T>(b);
  StoredPoints<T> original;
  if (is_identity()) {  // exact, as deform() at the identity
    bound_points(b, original);
    copy_stored(original, out, b.size());
    return;
  }
  // The bound points were finite when bound, so a non-finite result is the parameters' overflow.
  // Weights in [0, 1] keep a blend of finite positions finite: the kernel's report suffices.
  if (!deform_bound_impl(b, out)) {
    try {
      require_finite_results(out, b.size(), 3, "position");
    } catch (const NonFiniteResult& e) {
      const std::string names = overflow_parameters();
      throw_non_finite_result(e.row, e.quantity, names.empty() ? "the parameters" : "its parameters (" + names + ")");
    }
  }
  if (weights().empty()) return;
  bound_points(b, original);
  blend_toward_stored(weights(), original, out, b.size());
}

void BoundDeformer::deform_bound(const PointBinding& b, float* out) const { deform_bound_checked(b, out); }
void BoundDeformer::deform_bound(const PointBinding& b, double* out) const { deform_bound_checked(b, out); }

template <class T>
void BoundDeformer::displacement_bound_checked(const PointBinding& b, T* out) const {
  check_bound_call<T>(b);
  const std::size_t n = b.size();
  if (is_identity()) {  // exactly nothing, as deform_bound gives the bound points back
    std::fill(out, out + 3 * n, T(0));
    return;
  }
  if (displacement_bound_impl(b, out, weights().empty() ? nullptr : weights().data())) return;
  deform_bound_checked(b, out);  // names an overflow of F(x)
  StoredPoints<T> x;
  bound_points(b, x);
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const std::size_t p = x.order ? x.order[i] : i;
      for (int a = 0; a < 3; ++a) out[3 * p + a] -= x.coord[a][i * x.stride];
    }
  });
  try {  // F(x) and x finite, F(x) - x may still overflow
    require_finite_results(out, n, 3, "displacement");
  } catch (const NonFiniteResult& e) {
    const std::string names = overflow_parameters();
    throw_non_finite_result(e.row, e.quantity, names.empty() ? "the parameters" : "its parameters (" + names + ")");
  }
}

void BoundDeformer::displacement_bound(const PointBinding& b, float* out) const { displacement_bound_checked(b, out); }
void BoundDeformer::displacement_bound(const PointBinding& b, double* out) const { displacement_bound_checked(b, out); }

}  // namespace deformkit

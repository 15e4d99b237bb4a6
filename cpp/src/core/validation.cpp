#include "deformkit/core/validation.hpp"

#include "core/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

namespace deformkit {

template <class T>
void require_finite_rows(const T* data, std::size_t n, const char* argument) {
  for (std::size_t i = 0; i < n; ++i) {
    if (std::isfinite(data[3 * i]) && std::isfinite(data[3 * i + 1]) && std::isfinite(data[3 * i + 2]))
      continue;
    std::ostringstream msg;
    msg << argument << ": row " << i << " is not finite (" << data[3 * i] << ", " << data[3 * i + 1] << ", "
        << data[3 * i + 2] << ")";
    throw std::invalid_argument(msg.str());
  }
}
template void require_finite_rows<float>(const float*, std::size_t, const char*);
template void require_finite_rows<double>(const double*, std::size_t, const char*);

void throw_non_finite_result(std::size_t row, const char* what, const std::string& parameters,
                             const std::string& detail) {
  throw NonFiniteResult("deformer: row " + std::to_string(row) + " maps to a non-finite " + what + ": " + parameters +
                            " overflow there" + detail,
                        row, what);
}

double point_range(double limit) { return std::sqrt(limit) / 16.0; }

constexpr double kDoubleMax = std::numeric_limits<double>::max();

// 0 * v is NaN exactly when v is NaN or infinite; the simd reductions let this vectorise. rows
// of `width` values; with a limit below DBL_MAX the largest magnitude is compared too.
template <class T>
bool all_finite(const T* data, std::size_t rows, std::size_t width, double limit) {
  std::atomic<bool> finite{true};
  parallel_blocks(rows, [&](std::size_t begin, std::size_t end) {
    T acc = 0, top = 0;
    if (limit < kDoubleMax) {
#pragma omp simd reduction(+ : acc) reduction(max : top)
      for (std::size_t i = width * begin; i < width * end; ++i) {
        acc += data[i] * T(0);
        top = std::max(top, std::abs(data[i]));
      }
    } else {
#pragma omp simd reduction(+ : acc)
      for (std::size_t i = width * begin; i < width * end; ++i) acc += data[i] * T(0);
    }
    if (acc != acc || !(top <= limit)) finite = false;
  });
  return finite;
}

template <class T>
static bool row_is_bad(const T* row, std::size_t width, double limit) {
  for (std::size_t e = 0; e < width; ++e)
    if (!(std::abs(row[e]) <= limit)) return true;  // NaN included
  return false;
}

template <class T>
void require_finite_results(const T* values, std::size_t n, std::size_t width, const char* what, double limit) {
  if (all_finite(values, n, width, limit)) return;
  for (std::size_t i = 0; i < n; ++i)
    if (row_is_bad(values + width * i, width, limit)) throw_non_finite_result(i, what);
}
template void require_finite_results<float>(const float*, std::size_t, std::size_t, const char*, double);

// Row i's `what` overflowed. A point beyond point_range(limit) is to blame (its squares, and the
// distances and products of such points, reach the end of the range under any non-trivial map);
// a point within it was mapped by the parameters, which are.
template <class T>
void blame_points_beyond_range(std::size_t i, const char* what, const T* x, double range) {
  if (std::max({std::abs(double(x[0])), std::abs(double(x[1])), std::abs(double(x[2]))}) < range) return;
  std::ostringstream msg;
  msg.precision(3);
  // The range says which dtype's results were checked (float32 points may be computed in double).
  const bool single = range <= point_range(std::numeric_limits<float>::max());
  msg << "points: row " << i << " maps to a non-finite " << what << ": its coordinates (" << x[0] << ", " << x[1]
      << ", " << x[2] << ") are beyond the magnitude this deformer maps (|coordinate| < " << range << " for "
      << (single ? "float32" : "float64") << " results)";
  throw std::invalid_argument(msg.str());
}
template void blame_points_beyond_range<float>(std::size_t, const char*, const float*, double);
template void blame_points_beyond_range<double>(std::size_t, const char*, const double*, double);

template <class T>
[[noreturn]] static void blame_row(std::size_t i, const char* what, const T* x, double limit) {
  blame_points_beyond_range(i, what, x, point_range(limit));
  throw_non_finite_result(i, what);
}

template <class T>
void require_finite_results_of(const T* values, std::size_t n, std::size_t width, const char* what, const T* points,
                               double limit) {
  if (all_finite(values, n, width, limit)) return;
  for (std::size_t i = 0; i < n; ++i)
    if (row_is_bad(values + width * i, width, limit))
      blame_row(i, what, points + 3 * i, std::min(limit, double(std::numeric_limits<T>::max())));
}
template void require_finite_results_of<float>(const float*, std::size_t, std::size_t, const char*, const float*,
                                               double);
template void require_finite_results_of<double>(const double*, std::size_t, std::size_t, const char*, const double*,
                                                double);
template void require_finite_results<double>(const double*, std::size_t, std::size_t, const char*, double);
template bool all_finite<float>(const float*, std::size_t, std::size_t, double);
template bool all_finite<double>(const double*, std::size_t, std::size_t, double);

}  // namespace deformkit

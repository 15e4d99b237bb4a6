#pragma once
// Finite-value checks shared by every family: inputs named by argument and row, and the one
// overflow report of every output path.
#include <cstddef>
#include <stdexcept>
#include <string>

namespace deformkit {

// True when every value of the n rows (width values each) is finite and of magnitude <= limit.
template <class T>
bool all_finite(const T* data, std::size_t rows, std::size_t width, double limit = 1.7976931348623157e308);

// Throws std::invalid_argument naming `argument` and the first non-finite row.
template <class T>
void require_finite_rows(const T* data, std::size_t n, const char* argument);

// The magnitude of coordinates deformers accept for results whose range ends at `limit`
// (DBL_MAX: 8.4e152; FLT_MAX: 1.2e18): sqrt(limit) / 16, so that the squares, sums of squares
// and distances of such points stay finite. A point beyond it whose result overflows is blamed
// on `points`; a point within it, on the deformer's parameters.
double point_range(double limit = 1.7976931348623157e308);

// The parameters' overflow report, with its row, so that a composition (Stack) can still blame
// its own caller's point when a member overflowed on what an earlier member made of it.
struct NonFiniteResult : std::invalid_argument {
  NonFiniteResult(const std::string& message, std::size_t row_, const char* quantity_)
      : std::invalid_argument(message), row(row_), quantity(quantity_) {}
  std::size_t row;
  const char* quantity;  // "position", "Jacobian", ...
};

// Throws the `points` report for row i of `x` (its value and `range`) when a coordinate is at
// least `range`; returns otherwise.
template <class T>
void blame_points_beyond_range(std::size_t i, const char* what, const T* x, double range);

// The one report of every output path: finite input row `row` gave a `what` ("position",
// "Jacobian", ...) that is not finite, so the deformation overflows there.
// `parameters` names what overflowed ("its parameters (rate, profile)"); `detail` follows.
[[noreturn]] void throw_non_finite_result(std::size_t row, const char* what,
                                          const std::string& parameters = "the parameters",
                                          const std::string& detail = "");
// Throws throw_non_finite_result for the first of n rows (width values each) with an entry not
// finite, or of magnitude above `limit` (FLT_MAX for results handed back as float32).
template <class T>
void require_finite_results(const T* values, std::size_t n, std::size_t width, const char* what,
                            double limit = 1.7976931348623157e308);
// As require_finite_results, for results of `points` (3 per row): a row with a coordinate beyond
// point_range is blamed on `points` (its row, its value and the accepted magnitude), any other on
// the parameters.
template <class T>
void require_finite_results_of(const T* values, std::size_t n, std::size_t width, const char* what, const T* points,
                               double limit = 1.7976931348623157e308);

}  // namespace deformkit

#pragma once
// Finite-value checks shared by every family: inputs named by argument and row, and the one
// overflow report of every output path.
#include <cstddef>

namespace deformkit {

// True when every value of the n rows (width values each) is finite and of magnitude <= limit.
template <class T>
bool all_finite(const T* data, std::size_t rows, std::size_t width, double limit = 1.7976931348623157e308);

// Throws std::invalid_argument naming `argument` and the first non-finite row.
template <class T>
void require_finite_rows(const T* data, std::size_t n, const char* argument);

// The one report of every output path: finite input row `row` gave a `what` ("position",
// "Jacobian", ...) that is not finite, so the deformation overflows there.
[[noreturn]] void throw_non_finite_result(std::size_t row, const char* what);
// Throws throw_non_finite_result for the first of n rows (width values each) with an entry not
// finite, or of magnitude above `limit` (FLT_MAX for results handed back as float32).
template <class T>
void require_finite_results(const T* values, std::size_t n, std::size_t width, const char* what,
                            double limit = 1.7976931348623157e308);
// As require_finite_results, for results of `points` (3 per row): a row whose coordinates exceed
// the square root of the range, which squares past it under any non-trivial map, is blamed on
// `points`.
template <class T>
void require_finite_results_of(const T* values, std::size_t n, std::size_t width, const char* what, const T* points,
                               double limit = 1.7976931348623157e308);

}  // namespace deformkit

#pragma once
// The cage deformers' inner product: rows of dense weights times the control values, W c.
#include <cstddef>

namespace deformkit {

// out[3 r + a] = sum_j w[r m + j] c[a][j] for each of `rows` rows of m weights, accumulated in
// double (float32 weights are widened), with the widest SIMD target of this CPU (Highway's
// run-time dispatch). The summation order depends only on m and the target, so one row gives the
// same bits whichever call computes it.
void weight_rows_product(const double* w, std::size_t rows, std::size_t m, const double* const c[3], double* out);
void weight_rows_product(const float* w, std::size_t rows, std::size_t m, const double* const c[3], double* out);

}  // namespace deformkit

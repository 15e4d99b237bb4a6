#pragma once
// The multigrid cycle's two hot row loops, in single precision, with the widest SIMD target of this CPU (Highway's
// run-time dispatch), across the `width` interleaved columns of a row. Each row's arithmetic
// depends only on the row and the target, never on which thread or chunk computes it.
#include <array>
#include <cstddef>

namespace deformkit::numerics {

// Gauss-Seidel on rows[0, count): x_u = (b_u + sum_k coupling_uk x_nb(u,k)) * inverse_diagonal_u,
// or b_u * inverse_diagonal_u when from_zero. Rows are `width` values apart in b and x.
void sweep_rows(const int* rows, std::size_t count, const float* inverse_diagonal, const std::array<float, 6>* coupling,
                const std::array<int, 6>* neighbour, const float* b, float* x, int width, bool from_zero);

// coarse_b_g = sum over u in child[child_start[g] .. child_end[g]) of b_u - diagonal_u x_u +
// sum_k coupling_uk x_nb(u,k), for g in [begin, end).
void restrict_rows(const int* child_start, const int* child_end, const int* child, std::size_t begin, std::size_t end, const float* diagonal,
                   const std::array<float, 6>* coupling, const std::array<int, 6>* neighbour, const float* b, const float* x,
                   float* coarse_b, int width);

}  // namespace deformkit::numerics

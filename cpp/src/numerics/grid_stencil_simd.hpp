#pragma once
// The multigrid cycle's two hot row loops with the widest SIMD target of this CPU (Highway's
// run-time dispatch), across the `width` interleaved columns of a row. Each row's arithmetic
// depends only on the row and the target, never on which thread or chunk computes it.
#include <array>
#include <cstddef>

namespace deformkit::numerics {

// Gauss-Seidel on rows[0, count): x_u = (b_u + sum_k coupling_uk x_nb(u,k)) * inverse_diagonal_u,
// or b_u * inverse_diagonal_u when from_zero. Rows are `width` values apart in b and x.
template <class T>
void sweep_rows(const int* rows, std::size_t count, const T* inverse_diagonal, const std::array<T, 6>* coupling,
                const std::array<int, 6>* neighbour, const T* b, T* x, int width, bool from_zero);

// coarse_b_g = sum over u in child[child_start[g] .. child_start[g + 1]) of b_u - diagonal_u x_u +
// sum_k coupling_uk x_nb(u,k), for g in [begin, end).
template <class T>
void restrict_rows(const int* child_start, const int* child, std::size_t begin, std::size_t end, const T* diagonal,
                   const std::array<T, 6>* coupling, const std::array<int, 6>* neighbour, const T* b, const T* x,
                   T* coarse_b, int width);

}  // namespace deformkit::numerics

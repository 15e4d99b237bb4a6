#pragma once
// Assembling the systems a factorisation reads straight into their lower triangle, column by
// column: no triplets, no transposed copy and no second pass to drop the upper half, which on a
// 100k-vertex mesh cost more than the ordering.
#include "deformkit/numerics/sparse.hpp"
#include "deformkit/numerics/sparse_cholesky.hpp"

#include <cstdint>
#include <vector>

namespace deformkit {

// The lower triangle of a symmetric matrix (its upper triangle is not read); a missing diagonal
// is stored as an explicit zero.
SymmetricLower lower_triangle(const SparseMatrix& a);

// The lower triangle of M^T M (M: rows x n), on the pool's threads; every diagonal present.
SymmetricLower normal_equations(const SparseMatrix& m);

// The columns of m with keep[col] >= 0, renumbered to keep[col] (ascending with col), in order.
// rows: when non-null, only rows with rows[row] >= 0 are kept, renumbered to rows[row] (also
// ascending); out_rows is the new row count.
SparseMatrix select_columns(const SparseMatrix& m, const std::vector<int>& keep, Eigen::Index out_cols,
                            const std::vector<int>* rows = nullptr, Eigen::Index out_rows = -1);

// A 64-bit digest of m's sparsity pattern (sizes, column starts and row indices, not values).
std::uint64_t pattern_digest(const SparseMatrix& m);

}  // namespace deformkit

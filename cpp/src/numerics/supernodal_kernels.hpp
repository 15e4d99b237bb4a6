#pragma once
// A supernode's dense block in a triangular solve (Highway, dispatched at run time). block: rows x
// cols, column-major, its lower-triangular top cols x cols the diagonal block of L; v: the
// supernode's rows of k right-hand sides, v[c * rows + r], k in {1, 3, 6, 12}.
#include <cstdint>

namespace deformkit {

// L y = v on the block: the top cols rows of v become y, the others get -L_below y added.
void supernode_forward(int k, const double* block, std::int64_t rows, std::int64_t cols, double* v);
// L^T x = v on the block, the rows below the top cols already solved: the top cols rows become x.
void supernode_backward(int k, const double* block, std::int64_t rows, std::int64_t cols, double* v);

}  // namespace deformkit

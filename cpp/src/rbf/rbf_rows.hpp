#pragma once
// The kernel sums of a global RBF for many points: sum_j alpha_j phi(|x - c_j|), SIMD lanes over
// points, every control visited per point (docs/math/rbf.md, "Evaluation").
#include "deformkit/rbf/rbf_kernel.hpp"

#include <cstddef>

namespace deformkit {

// The controls and their coefficients as columns (structure of arrays), which the lanes broadcast.
struct RbfColumns {
  const double* c[3] = {nullptr, nullptr, nullptr};  // control x, y, z
  const double* alpha[3] = {nullptr, nullptr, nullptr};
  std::size_t m = 0;
};

// out[3 i + a] = sum_j alpha[a][j] phi(|x_i - c_j|) for n points (n x 3), with the widest SIMD
// target of this CPU. Not parallel: the caller splits the points between threads.
void rbf_kernel_sums(const double* points, std::size_t n, const RbfColumns& columns, const RbfKernelShape& shape,
                     double* out);

}  // namespace deformkit

#include "cage/grid_stencil_direct.hpp"

#include "deformkit/numerics/sparse_cholesky.hpp"

#include <algorithm>
#include <stdexcept>

namespace deformkit::numerics {

namespace {

// The stencil's lower triangle in compressed columns: unknown u's column holds its diagonal, then
// its couplings to the unknowns of larger index (-coupling), rows ascending.
SymmetricLower lower_triangle(const GridStencil& s) {
  const std::array<int, 3> n = s.cells;
  const std::int64_t stride[3] = {1, n[0], std::int64_t(n[0]) * n[1]};
  SymmetricLower a;
  a.n = std::int64_t(s.diagonal.size());
  a.start.reserve(std::size_t(a.n) + 1);
  a.row.reserve(std::size_t(a.n) * 4);
  a.value.reserve(std::size_t(a.n) * 4);
  const std::int64_t cells = std::int64_t(n[0]) * n[1] * n[2];
  for (std::int64_t c = 0; c < cells; ++c) {
    const int u = s.unknown[std::size_t(c)];
    if (u < 0) continue;
    a.row.push_back(u);
    a.value.push_back(s.diagonal[std::size_t(u)]);
    // The +x, +y, +z neighbours have larger cell indices, hence (unknowns numbered in cell order
    // or not) are gathered and sorted by unknown index.
    std::array<std::pair<int, double>, 6> below{};
    int count = 0;
    for (int d = 0; d < 6; ++d) {
      const double w = s.coupling[std::size_t(u)][std::size_t(d)];
      if (w == 0.0) continue;
      const std::int64_t nb = c + (d % 2 ? 1 : -1) * stride[d / 2];
      const int v = s.unknown[std::size_t(nb)];
      if (v > u) below[std::size_t(count++)] = {v, -w};
    }
    std::sort(below.begin(), below.begin() + count);
    for (int k = 0; k < count; ++k) {
      a.row.push_back(below[std::size_t(k)].first);
      a.value.push_back(below[std::size_t(k)].second);
    }
    a.start.push_back(std::int64_t(a.row.size()));
  }
  return a;
}

}  // namespace

void solve_grid_stencil_direct(const GridStencil& system, int columns, int block_columns,
                               const std::function<void(int, Eigen::Ref<Eigen::MatrixXd>)>& fill,
                               const std::function<void(int, const Eigen::Ref<const Eigen::MatrixXd>&)>& take,
                               double /*relative_tolerance*/) {
  const Eigen::Index n = Eigen::Index(system.diagonal.size());
  if (n == 0 || columns <= 0) return;
  // Unknowns are numbered in cell order, so start's columns come out in unknown order.
  SparseCholesky cholesky;
  if (!cholesky.factorize(lower_triangle(system), CholeskyKind::Supernodal))
    throw std::runtime_error("the grid system is not positive definite");
  const int block = std::max(1, block_columns);
  Eigen::MatrixXd rhs;
  for (int first = 0; first < columns; first += block) {
    const int count = std::min(block, columns - first);
    rhs.setZero(n, count);
    fill(first, rhs);
    const Eigen::MatrixXd x = cholesky.solve(rhs);
    take(first, x);
  }
}

}  // namespace deformkit::numerics

#pragma once
// The harmonic grid's linear system, handed to a solver in one form (the interface md-solver's
// multigrid implements in deformkit/numerics/grid_stencil.hpp), and a direct solver of it: CHOLMOD
// on the symmetric form (docs/math/mesh_deform.md, "The system").
#if __has_include("deformkit/numerics/grid_stencil.hpp")
#include "deformkit/numerics/grid_stencil.hpp"
#else
#include <Eigen/Core>

#include <array>
#include <functional>
#include <vector>

namespace deformkit::numerics {

struct GridStencil {                             // SPD 7-point stencil on an n0 x n1 x n2 cell grid
  std::array<int, 3> cells;                      // cell (i,j,k) has index i + n0*(j + n1*k)
  std::vector<int> unknown;                      // per cell: its unknown's index, or -1
  std::vector<double> diagonal;                  // per unknown: sum of its 6 edge weights
  std::vector<std::array<double, 6>> coupling;   // per unknown: -x,+x,-y,+y,-z,+z; 0 if not an unknown
};

}  // namespace deformkit::numerics
#endif

#include <Eigen/Core>

#include <functional>

namespace deformkit::numerics {

// Solves diagonal_i u_i - sum_j coupling_ij u_j = rhs_i for `columns` right-hand sides, in blocks
// of block_columns: fill(first, block) writes rhs columns [first, first + block.cols()), take(first,
// solution) receives their solutions. Factorises once (sparse Cholesky); relative_tolerance is
// unused (the solve is direct). Throws std::runtime_error when the system is not positive definite.
void solve_grid_stencil_direct(const GridStencil& system, int columns, int block_columns,
                               const std::function<void(int, Eigen::Ref<Eigen::MatrixXd>)>& fill,
                               const std::function<void(int, const Eigen::Ref<const Eigen::MatrixXd>&)>& take,
                               double relative_tolerance);

}  // namespace deformkit::numerics

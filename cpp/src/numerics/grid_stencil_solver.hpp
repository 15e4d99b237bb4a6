#pragma once
// solve_grid_stencil with its settings open, for the tests and the benchmark.
#include "deformkit/numerics/grid_stencil.hpp"
#include "numerics/grid_stencil_multigrid.hpp"

namespace deformkit::numerics {

struct GridSolveOptions {
  MultigridSettings multigrid;
  bool serial = false;        // every kernel on the calling thread
  int max_iterations = 1000;  // per block; std::runtime_error beyond
};

struct GridSolveReport {
  int levels = 0;
  std::vector<int> iterations;  // per block: conjugate gradient steps until every column converged
};

void solve_grid_stencil(const GridStencil& system, int columns, int block_columns,
    const std::function<void(int, Eigen::Ref<Eigen::MatrixXd>)>& fill,
    const std::function<void(int, const Eigen::Ref<const Eigen::MatrixXd>&)>& take,
    double relative_tolerance, const GridSolveOptions& options, GridSolveReport* report);

}  // namespace deformkit::numerics

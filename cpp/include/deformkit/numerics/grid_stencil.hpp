#pragma once
// The symmetric positive definite 7-point system of a voxel grid with cut edges (harmonic
// coordinates on a grid, as Blender's Mesh Deform builds them), solved for many right-hand sides by
// conjugate gradients preconditioned with a geometric multigrid V-cycle (docs/math/numerics.md,
// "The grid solver").
#include <Eigen/Core>

#include <array>
#include <functional>
#include <vector>

namespace deformkit::numerics {

struct GridStencil {               // SPD 7-point stencil on an n0 x n1 x n2 cell grid
  std::array<int, 3> cells;        // cell (i,j,k) has index i + n0*(j + n1*k)
  std::vector<int> unknown;        // per cell: its unknown's index, or -1 (not an unknown)
  std::vector<double> diagonal;    // per unknown: sum of its 6 edge weights (cut edges included)
  std::vector<std::array<double, 6>> coupling; // per unknown: weight to neighbour -x,+x,-y,+y,-z,+z, 0 when that neighbour is not an unknown
};

// Solves diagonal_i u_i - sum_j coupling_ij u_j = rhs_i for `columns` right-hand sides, streamed in
// blocks so memory stays O(unknowns * block): fill(first, block) writes rhs columns
// [first, first+block.cols()); take(first, solution) receives the solutions of those columns.
// Every column ends with ||rhs - A u|| <= relative_tolerance ||rhs||, and the same for the rows
// divided by their diagonals (D^-1 (rhs - A u) against D^-1 rhs: huge cut-edge weights do not hide
// the other rows' residual); bit for bit the same result whatever the number of threads. Throws std::invalid_argument naming what is wrong with a system
// not of this form (docs/errors.md, "Grid solver systems"); std::runtime_error if a column does
// not converge.
void solve_grid_stencil(const GridStencil& system, int columns, int block_columns,
    const std::function<void(int, Eigen::Ref<Eigen::MatrixXd>)>& fill,
    const std::function<void(int, const Eigen::Ref<const Eigen::MatrixXd>&)>& take,
    double relative_tolerance);

}  // namespace deformkit::numerics

#pragma once
// Geometric multigrid on the voxel grid: 2x2x2 aggregation with Galerkin coarse operators (which
// keep the cut edges' weights on the coarse diagonals), red-black Gauss-Seidel smoothing, a dense
// Cholesky factor on the coarsest grid. One V-cycle is a symmetric positive definite
// preconditioner for conjugate gradients (docs/math/numerics.md, "The grid solver"). The cycle runs
// in single precision: half the memory traffic of its kernels, which are bound by it; the
// conjugate gradients around it stay in double and reach any tolerance.
#include "numerics/grid_stencil_kernels.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <vector>

namespace deformkit::numerics {

struct MultigridSettings {
  // The coarse correction's factor: piecewise constant interpolation makes the Galerkin operator
  // twice as stiff as the Laplacian on smooth errors, so a factor below 2 recovers most of the step
  // (Braess 1995, "Towards algebraic multigrid for elliptic problems of second order"). 1.95: at
  // 600k-800k unknowns 8 steps to 1e-8 where 1.8 took 10 (1.97: 8 too; 66^3-130^3: the same or
  // one fewer); any value below 2 keeps the cycle symmetric positive definite.
  double correction_scale = 1.95;
  int smoothing = 2;               // red-black sweeps before and after each coarse correction (2: fewest seconds measured)
  std::size_t coarsest_size = 400; // unknowns solved densely
};

class GridMultigrid {
 public:
  GridMultigrid(StencilLevel fine, const MultigridSettings& settings, const KernelRunner& run);
  const StencilLevel& fine() const { return levels_.front(); }
  int levels() const { return int(levels_.size()); }
  // The cycle's right-hand side on the finest level, `width` columns (zero rows are never read).
  BlockOf<float>& rhs(int width);
  // One V-cycle applied to rhs(); the result stays valid until the next call.
  const BlockOf<float>& cycle();

 private:
  void cycle(std::size_t l);

  std::vector<StencilLevel> levels_;
  std::vector<BlockOf<float>> b_, x_;  // per level
  Eigen::LLT<Eigen::MatrixXd> coarsest_;
  MultigridSettings settings_;
  KernelRunner run_;
};

}  // namespace deformkit::numerics

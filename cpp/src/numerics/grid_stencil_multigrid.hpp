#pragma once
// Geometric multigrid on the voxel grid: 2x2x2 aggregation with Galerkin coarse operators (which
// keep the cut edges' weights on the coarse diagonals), red-black Gauss-Seidel smoothing, a dense
// Cholesky factor on the coarsest grid. One V-cycle is a symmetric positive definite
// preconditioner for conjugate gradients (docs/numerics.md, "The grid solver").
#include "numerics/grid_stencil_kernels.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <vector>

namespace deformkit::numerics {

struct MultigridSettings {
  // The coarse correction's factor: piecewise constant interpolation makes the Galerkin operator
  // twice as stiff as the Laplacian on smooth errors, so a factor below 2 recovers most of the step
  // (Braess 1995, "Towards algebraic multigrid for elliptic problems of second order").
  double correction_scale = 1.8;
  int smoothing = 2;               // red-black sweeps before and after each coarse correction (2: fewest seconds measured)
  std::size_t coarsest_size = 400; // unknowns solved densely
  // The cycle in single precision halves its memory traffic (the kernels are bound by it); the
  // conjugate gradients around it stay in double and reach any tolerance.
  bool single_precision = true;
};

class GridMultigrid {
 public:
  GridMultigrid(StencilLevel fine, const MultigridSettings& settings, const KernelRunner& run);
  const StencilLevel& fine() const { return levels_.front(); }
  int levels() const { return int(levels_.size()); }
  // x = one V-cycle applied to b (x's old values are not read); b and x hold `width` columns.
  void precondition(const Block& b, Block& x);

 private:
  template <class T>
  void cycle(std::size_t l, const BlockOf<T>& b, BlockOf<T>& x);
  template <class T>
  std::vector<BlockOf<T>>& coarse_b();
  template <class T>
  std::vector<BlockOf<T>>& coarse_x();

  std::vector<StencilLevel> levels_;
  // Per level (the finest's only in single precision: the caller's are double).
  std::vector<Block> b_, x_;
  std::vector<BlockOf<float>> b_single_, x_single_;
  Eigen::LLT<Eigen::MatrixXd> coarsest_;
  MultigridSettings settings_;
  KernelRunner run_;
};

}  // namespace deformkit::numerics

#include "numerics/grid_stencil_multigrid.hpp"

#include <stdexcept>
#include <utility>

namespace deformkit::numerics {

namespace {

Eigen::MatrixXd dense_matrix(const StencilLevel& a) {
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(Eigen::Index(a.size), Eigen::Index(a.size));
  for (std::size_t u = 0; u < a.size; ++u) {
    m(Eigen::Index(u), Eigen::Index(u)) = a.diagonal[u];
    for (int d = 0; d < 6; ++d)
      if (std::size_t(a.neighbour[u][std::size_t(d)]) < a.size)
        m(Eigen::Index(u), a.neighbour[u][std::size_t(d)]) -= a.coupling[u][std::size_t(d)];
  }
  return m;
}

bool can_coarsen(const StencilLevel& a) { return a.cells[0] > 1 || a.cells[1] > 1 || a.cells[2] > 1; }

}  // namespace

GridMultigrid::GridMultigrid(StencilLevel fine, const MultigridSettings& settings, const KernelRunner& run)
    : settings_(settings), run_(run) {
  levels_.push_back(std::move(fine));
  while (levels_.back().size > settings_.coarsest_size && can_coarsen(levels_.back())) {
    StencilLevel next = aggregated_level(levels_.back());
    levels_.push_back(std::move(next));
  }
  for (StencilLevel& a : levels_) round_to_single(a);
  coarsest_.compute(dense_matrix(levels_.back()));
  if (coarsest_.info() != Eigen::Success) throw std::runtime_error("solve_grid_stencil: the coarsest grid's operator is not positive definite");
}

BlockOf<float>& GridMultigrid::rhs(int width) {
  b_.resize(levels_.size()), x_.resize(levels_.size());
  for (std::size_t l = 0; l < levels_.size(); ++l)
    if (b_[l].width != width) b_[l].resize(levels_[l].size, width), x_[l].resize(levels_[l].size, width);
  return b_[0];
}

const BlockOf<float>& GridMultigrid::cycle() {
  cycle(0);
  return x_[0];
}

// The V-cycle's smoothing runs red then black before the coarse correction and black then red
// after it, so the cycle is a symmetric operator.
void GridMultigrid::cycle(std::size_t l) {
  const StencilLevel& a = levels_[l];
  const BlockOf<float>& b = b_[l];
  BlockOf<float>& x = x_[l];
  if (l + 1 == levels_.size()) {
    using RowMajor = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    const Eigen::Map<const RowMajor> rhs(b.data.data(), Eigen::Index(a.size), b.width);
    Eigen::Map<RowMajor>(x.data.data(), Eigen::Index(a.size), x.width) = coarsest_.solve(rhs.cast<double>()).cast<float>();
    return;
  }
  for (int s = 0; s < settings_.smoothing; ++s) {
    colour_sweep(run_, a, 0, b, x, s == 0);
    colour_sweep(run_, a, 1, b, x, false);
  }
  const bool swept = settings_.smoothing > 0;
  restrict_residual(run_, a, b, x, b_[l + 1], swept);
  cycle(l + 1);
  prolong_add(run_, a, x_[l + 1], float(settings_.correction_scale), x, swept);
  for (int s = 0; s < settings_.smoothing; ++s) {
    colour_sweep(run_, a, 1, b, x, false);
    colour_sweep(run_, a, 0, b, x, false);
  }
}

}  // namespace deformkit::numerics

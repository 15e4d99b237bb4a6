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

template <class T>
void resize_levels(const std::vector<StencilLevel>& levels, std::size_t from, int width, std::vector<BlockOf<T>>& b, std::vector<BlockOf<T>>& x) {
  b.resize(levels.size()), x.resize(levels.size());
  for (std::size_t l = from; l < levels.size(); ++l)
    if (b[l].width != width) b[l].resize(levels[l].size, width), x[l].resize(levels[l].size, width);
}

}  // namespace

GridMultigrid::GridMultigrid(StencilLevel fine, const MultigridSettings& settings, const KernelRunner& run)
    : settings_(settings), run_(run) {
  levels_.push_back(std::move(fine));
  while (levels_.back().size > settings_.coarsest_size && can_coarsen(levels_.back())) {
    StencilLevel next = aggregated_level(levels_.back());
    levels_.push_back(std::move(next));
  }
  if (settings_.single_precision)
    for (StencilLevel& a : levels_) round_to_single(a);
  coarsest_.compute(dense_matrix(levels_.back()));
  if (coarsest_.info() != Eigen::Success) throw std::runtime_error("solve_grid_stencil: the coarsest grid's operator is not positive definite");
}

template <>
std::vector<BlockOf<double>>& GridMultigrid::coarse_b<double>() { return b_; }
template <>
std::vector<BlockOf<double>>& GridMultigrid::coarse_x<double>() { return x_; }
template <>
std::vector<BlockOf<float>>& GridMultigrid::coarse_b<float>() { return b_single_; }
template <>
std::vector<BlockOf<float>>& GridMultigrid::coarse_x<float>() { return x_single_; }

void GridMultigrid::precondition(const Block& b, Block& x) {
  if (!settings_.single_precision) {
    resize_levels(levels_, 1, b.width, b_, x_);
    cycle(0, b, x);
    return;
  }
  resize_levels(levels_, 0, b.width, b_single_, x_single_);
  convert_block(run_, b, b_single_[0]);
  cycle(0, b_single_[0], x_single_[0]);
  convert_block(run_, x_single_[0], x);
}

// The V-cycle's smoothing runs red then black before the coarse correction and black then red
// after it, so the cycle is a symmetric operator.
template <class T>
void GridMultigrid::cycle(std::size_t l, const BlockOf<T>& b, BlockOf<T>& x) {
  const StencilLevel& a = levels_[l];
  if (l + 1 == levels_.size()) {
    using RowMajor = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    const Eigen::Map<const RowMajor> rhs(b.data.data(), Eigen::Index(a.size), b.width);
    Eigen::Map<RowMajor>(x.data.data(), Eigen::Index(a.size), x.width) = coarsest_.solve(rhs.template cast<double>()).template cast<T>();
    return;
  }
  for (int s = 0; s < settings_.smoothing; ++s) {
    colour_sweep(run_, a, 0, b, x, s == 0);
    colour_sweep(run_, a, 1, b, x, false);
  }
  BlockOf<T>& cb = coarse_b<T>()[l + 1];
  BlockOf<T>& cx = coarse_x<T>()[l + 1];
  restrict_residual(run_, a, b, x, cb);
  cycle(l + 1, cb, cx);
  prolong_add(run_, a, cx, T(settings_.correction_scale), x);
  for (int s = 0; s < settings_.smoothing; ++s) {
    colour_sweep(run_, a, 1, b, x, false);
    colour_sweep(run_, a, 0, b, x, false);
  }
}

}  // namespace deformkit::numerics

// Conjugate gradients on several right-hand sides at once, each column with its own step sizes,
// preconditioned by one multigrid V-cycle (Tatebe 1993, "The multigrid preconditioned conjugate
// gradient method"): one pass over the stencil serves the whole block.
#include "numerics/grid_stencil_solver.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace deformkit::numerics {

namespace {

// CG's updated residual drifts from the true one by rounding; it is driven this much below the
// tolerance, and the true residual decides. The tolerance holds for the plain residual and for the
// row-normalised one, D^-1 (b - A x) against D^-1 b: with very short cut edges a few rows' huge
// diagonals dominate ||b||, and the plain test alone would leave the other rows inaccurate.
constexpr double kRecursiveMargin = 0.9;
// The search direction p is stored in single precision: half its memory traffic in the three
// passes that read it. x and r stay in double and q = A p is formed in double from the rounded p,
// so x += alpha p and r -= alpha q move together and the true residual still reaches any
// tolerance; the rounding only perturbs p's A-conjugacy, by about 1e-7. r^T z is taken on the
// single-precision r the cycle was applied to (z = M r_single), which keeps it positive.

void check_arguments(int columns, int block_columns, bool fill, bool take, double tolerance) {
  auto refuse = [](const std::string& what) { throw std::invalid_argument("solve_grid_stencil: " + what); };
  if (columns < 0) refuse("columns is " + std::to_string(columns) + "; it must be >= 0");
  if (block_columns < 1) refuse("block_columns is " + std::to_string(block_columns) + "; it must be >= 1");
  if (!fill) refuse("fill is empty; it must write the right-hand sides");
  if (!take) refuse("take is empty; it must receive the solutions");
  if (!(tolerance > 0.0 && tolerance < 1.0)) refuse("relative_tolerance is " + std::to_string(tolerance) + "; it must be in (0, 1)");
}

struct ColumnState {
  double target = 0.0, normalised_target = 0.0;  // tolerance * ||b||, tolerance * ||D^-1 b||
  double rz = 0.0;
  bool active = false, fresh = true;
};

class BlockSolver {
 public:
  BlockSolver(GridMultigrid& mg, const std::vector<int>& external, const KernelRunner& run, int max_iterations)
      : mg_(mg), a_(mg.fine()), external_(external), run_(run), max_iterations_(max_iterations) {}

  // rhs (caller's rows) in, solution (caller's rows) out; returns the CG steps taken.
  int solve(Eigen::MatrixXd& rhs, int first, double tolerance) {
    const int w = int(rhs.cols());
    first_ = first;
    for (Block* v : {&x_, &r_, &q_})
      if (v->width != w) v->resize(a_.size, w);
    if (p_.width != w) p_.resize(a_.size, w);
    std::fill(x_.data.begin(), x_.data.end(), 0.0);
    gather(rhs, r_, mg_.rhs(w));
    std::vector<ColumnState> state(static_cast<std::size_t>(w));
    const std::vector<double> bb = residual_norms(run_, a_, r_);
    for (std::size_t c = 0; c < std::size_t(w); ++c) {
      state[c].target = tolerance * std::sqrt(bb[c]);
      state[c].normalised_target = tolerance * std::sqrt(bb[std::size_t(w) + c]);
      state[c].active = bb[c] > 0.0;
    }
    int steps = 0;
    while (any_active(state) || reactivate(rhs, state)) {
      if (steps++ == max_iterations_) not_converged(first, state);
      iterate(state);
    }
    scatter(x_, rhs);
    return steps;
  }

 private:
  // squared: the plain and the row-normalised residual's squared norms.
  static bool converged(const ColumnState& s, double squared, double normalised_squared, double margin) {
    return std::sqrt(squared) <= margin * s.target && std::sqrt(normalised_squared) <= margin * s.normalised_target;
  }

  static bool any_active(const std::vector<ColumnState>& state) {
    for (const ColumnState& s : state)
      if (s.active) return true;
    return false;
  }

  // One preconditioned CG step on the active columns; the others stay as they are (step 0).
  void iterate(std::vector<ColumnState>& state) {
    const std::size_t w = state.size();
    const BlockOf<float>& z = mg_.cycle();  // of r, which the last step left in mg_.rhs()
    const std::vector<double> rz = column_dots(run_, mg_.rhs(int(w)), z);
    std::vector<double> beta(w, 0.0), alpha(w, 0.0);
    for (std::size_t c = 0; c < w; ++c) {
      if (state[c].active && !state[c].fresh) beta[c] = rz[c] / state[c].rz;
      state[c].rz = rz[c], state[c].fresh = false;
    }
    step_direction(run_, beta, z, p_);
    const std::vector<double> pq = apply_stencil(run_, a_, p_, q_);
    for (std::size_t c = 0; c < w; ++c) {
      if (!state[c].active) continue;
      if (!(pq[c] > 0.0) || !(rz[c] > 0.0) || !std::isfinite(pq[c]) || !std::isfinite(rz[c]))
        throw std::runtime_error("solve_grid_stencil: conjugate gradients broke down on right-hand side " + std::to_string(first_ + int(c)) +
                                 " (p^T A p = " + std::to_string(pq[c]) + ", r^T z = " + std::to_string(rz[c]) +
                                 "); the system or its multigrid cycle is not positive definite");
      alpha[c] = rz[c] / pq[c];
    }
    const std::vector<double> rr = step_solution(run_, a_, alpha, p_, q_, x_, r_, mg_.rhs(int(w)));
    for (std::size_t c = 0; c < w; ++c)
      if (state[c].active && converged(state[c], rr[c], rr[w + c], kRecursiveMargin)) state[c].active = false;
  }

  // The true residual of every column; the ones above tolerance restart from it. False if none.
  bool reactivate(const Eigen::MatrixXd& rhs, std::vector<ColumnState>& state) {
    apply_stencil(run_, a_, x_, q_);
    const int w = int(state.size());
    for_chunks(run_, a_.size, [&](std::size_t, std::size_t begin, std::size_t end) {
      for (std::size_t u = begin; u < end; ++u)
        for (int c = 0; c < w; ++c) q_.row(u)[c] = rhs(external_[u], c) - q_.row(u)[c];
    });
    const std::vector<double> tt = residual_norms(run_, a_, q_);
    bool any = false;
    for (int c = 0; c < w; ++c) {
      ColumnState& s = state[std::size_t(c)];
      if (converged(s, tt[std::size_t(c)], tt[std::size_t(w + c)], 1.0)) continue;
      s.active = s.fresh = any = true;
      BlockOf<float>& single = mg_.rhs(w);
      for (std::size_t u = 0; u < a_.size; ++u) r_.row(u)[c] = q_.row(u)[c], single.row(u)[c] = float(q_.row(u)[c]);
    }
    return any;
  }

  [[noreturn]] void not_converged(int first, const std::vector<ColumnState>& state) const {
    std::size_t c = 0;
    while (!state[c].active) ++c;
    throw std::runtime_error("solve_grid_stencil: right-hand side " + std::to_string(first + int(c)) + " did not converge in " +
                             std::to_string(max_iterations_) + " iterations");
  }

  void gather(const Eigen::MatrixXd& rhs, Block& b, BlockOf<float>& single) const {
    const int w = b.width;
    for_chunks(run_, a_.size, [&](std::size_t, std::size_t begin, std::size_t end) {
      for (std::size_t u = begin; u < end; ++u)
        for (int c = 0; c < w; ++c) b.row(u)[c] = rhs(external_[u], c), single.row(u)[c] = float(b.row(u)[c]);
    });
  }
  void scatter(const Block& x, Eigen::MatrixXd& out) const {
    const int w = x.width;
    for_chunks(run_, a_.size, [&](std::size_t, std::size_t begin, std::size_t end) {
      for (std::size_t u = begin; u < end; ++u)
        for (int c = 0; c < w; ++c) out(external_[u], c) = x.row(u)[c];
    });
  }

  GridMultigrid& mg_;
  const StencilLevel& a_;
  const std::vector<int>& external_;
  KernelRunner run_;
  int max_iterations_;
  int first_ = 0;  // the block's first column, for messages
  Block x_, r_, q_;
  BlockOf<float> p_;
};

void check_finite(const Eigen::MatrixXd& rhs, int first) {
  if (rhs.allFinite()) return;
  for (Eigen::Index c = 0; c < rhs.cols(); ++c)
    for (Eigen::Index r = 0; r < rhs.rows(); ++r)
      if (!std::isfinite(rhs(r, c)))
        throw std::invalid_argument("solve_grid_stencil: fill wrote " + std::to_string(rhs(r, c)) + " in row " + std::to_string(r) +
                                    " of right-hand side " + std::to_string(first + int(c)) + "; right-hand sides must be finite");
}

}  // namespace

void solve_grid_stencil(const GridStencil& system, int columns, int block_columns,
    const std::function<void(int, Eigen::Ref<Eigen::MatrixXd>)>& fill,
    const std::function<void(int, const Eigen::Ref<const Eigen::MatrixXd>&)>& take,
    double relative_tolerance, const GridSolveOptions& options, GridSolveReport* report) {
  check_arguments(columns, block_columns, bool(fill), bool(take), relative_tolerance);
  std::vector<int> external;
  StencilLevel fine = checked_fine_level(system, external);
  const KernelRunner run{options.serial};
  GridMultigrid mg(std::move(fine), options.multigrid, run);
  if (report) report->levels = mg.levels(), report->iterations.clear();
  BlockSolver solver(mg, external, run, options.max_iterations);
  const Eigen::Index n = Eigen::Index(system.diagonal.size());
  Eigen::MatrixXd rhs;
  for (int first = 0; first < columns; first += block_columns) {
    const int width = std::min(block_columns, columns - first);
    rhs.setZero(n, width);
    fill(first, rhs);
    check_finite(rhs, first);
    const int steps = n == 0 ? 0 : solver.solve(rhs, first, relative_tolerance);
    if (report) report->iterations.push_back(steps);
    take(first, rhs);
  }
}

void solve_grid_stencil(const GridStencil& system, int columns, int block_columns,
    const std::function<void(int, Eigen::Ref<Eigen::MatrixXd>)>& fill,
    const std::function<void(int, const Eigen::Ref<const Eigen::MatrixXd>&)>& take,
    double relative_tolerance) {
  solve_grid_stencil(system, columns, block_columns, fill, take, relative_tolerance, GridSolveOptions{}, nullptr);
}

}  // namespace deformkit::numerics

#include "deformkit/numerics/constrained_quadratic.hpp"

#include "core/parallel.hpp"
#include "numerics/fill_ordering.hpp"
#include "numerics/normal_equations.hpp"

#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>

namespace deformkit {

namespace {

// M^T R, one row per column of M on the pool's threads: Eigen's own product of a transposed
// (row-major) sparse matrix runs an OpenMP region, which stalls while a core is busy elsewhere.
Eigen::MatrixXd transpose_times(const SparseMatrix& m, const Eigen::MatrixXd& r) {
  Eigen::MatrixXd out(m.cols(), r.cols());
  parallel_blocks(std::size_t(m.cols()), [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const Eigen::Index col = Eigen::Index(i);
      for (Eigen::Index c = 0; c < r.cols(); ++c) {
        double acc = 0;
        for (SparseMatrix::InnerIterator e(m, col); e; ++e) acc += e.value() * r(e.row(), c);
        out(col, c) = acc;
      }
    }
  });
  return out;
}

}  // namespace

UnknownSplit::UnknownSplit(const std::vector<char>& fixed) {
  const std::size_t n = fixed.size();
  free_index_.assign(n, -1);
  fixed_index_.assign(n, -1);
  for (std::size_t i = 0; i < n; ++i) {
    if (fixed[i]) {
      fixed_index_[i] = int(fixed_.size());
      fixed_.push_back(int(i));
    } else {
      free_index_[i] = int(free_.size());
      free_.push_back(int(i));
    }
  }
}

UnknownSplit UnknownSplit::interleaved(int width) const {
  std::vector<char> fixed(size() * std::size_t(width));
  for (std::size_t i = 0; i < fixed.size(); ++i) fixed[i] = fixed_index_[i / std::size_t(width)] >= 0;
  return UnknownSplit(fixed);
}

namespace {

// The columns of `m` split into its free and fixed unknowns; with free_rows_only, its rows too
// (the quadratic form keeps only the free unknowns' equations).
std::pair<SparseMatrix, SparseMatrix> split_columns(const SparseMatrix& m, const UnknownSplit& split,
                                                    bool free_rows_only) {
  std::vector<int> free_col(std::size_t(m.cols()), -1), fixed_col(std::size_t(m.cols()), -1), free_row;
  for (Eigen::Index c = 0; c < m.cols(); ++c) (split.is_fixed(int(c)) ? fixed_col : free_col)[std::size_t(c)] =
      split.is_fixed(int(c)) ? split.fixed_index(int(c)) : split.free_index(int(c));
  const auto free = Eigen::Index(split.free().size()), fixed = Eigen::Index(split.fixed().size());
  if (!free_rows_only) return {select_columns(m, free_col, free), select_columns(m, fixed_col, fixed)};
  for (Eigen::Index r = 0; r < m.rows(); ++r) free_row.push_back(split.free_index(int(r)));
  return {select_columns(m, free_col, free, &free_row, free), select_columns(m, fixed_col, fixed, &free_row, free)};
}

std::vector<int> soft_positions(const SoftConstraints& soft, const UnknownSplit& split) {
  if (soft.weights.size() != soft.unknowns.size())
    throw std::invalid_argument("ConstrainedQuadratic: one weight per soft unknown expected");
  std::vector<int> positions;
  for (int u : soft.unknowns) {
    if (u < 0 || std::size_t(u) >= split.size() || split.is_fixed(u))
      throw std::invalid_argument("ConstrainedQuadratic: soft unknown " + std::to_string(u) + " is not a free unknown");
    positions.push_back(split.free_index(u));
  }
  return positions;
}

}  // namespace

ConstrainedQuadratic::ConstrainedQuadratic() = default;
ConstrainedQuadratic::~ConstrainedQuadratic() = default;
ConstrainedQuadratic::ConstrainedQuadratic(ConstrainedQuadratic&&) noexcept = default;
ConstrainedQuadratic& ConstrainedQuadratic::operator=(ConstrainedQuadratic&&) noexcept = default;

namespace {

// The caller's ordering of all n unknowns, restricted to the free ones.
std::optional<Ordering> free_ordering(const std::vector<std::int64_t>* ordering, const UnknownSplit& split) {
  if (!ordering) return std::nullopt;
  if (ordering->size() != split.size())
    throw std::invalid_argument("ConstrainedQuadratic: the ordering must have one entry per unknown");
  std::vector<int> index(split.size());
  for (std::size_t i = 0; i < split.size(); ++i) index[i] = split.free_index(int(i));
  return restricted_ordering(*ordering, index);
}

}  // namespace

ConstrainedQuadratic ConstrainedQuadratic::quadratic(const SparseMatrix& a, UnknownSplit split, SoftConstraints soft,
                                                     CholeskyKind kind, const std::vector<std::int64_t>* ordering) {
  if (a.rows() != a.cols() || std::size_t(a.rows()) != split.size())
    throw std::invalid_argument("ConstrainedQuadratic::quadratic: A must be n x n for n unknowns");
  ConstrainedQuadratic q;
  q.form_ = Form::Quadratic;
  q.split_ = std::move(split);
  q.soft_ = std::move(soft);
  q.soft_free_ = soft_positions(q.soft_, q.split_);
  StageClock clock(q.stages_);
  std::tie(q.free_part_, q.fixed_part_) = split_columns(a, q.split_, true);
  clock.mark("free / fixed split");
  const std::optional<Ordering> order = free_ordering(ordering, q.split_);
  q.factorize(lower_triangle(q.free_part_), 0.0, kind, clock, order ? &*order : nullptr);
  return q;
}

ConstrainedQuadratic ConstrainedQuadratic::least_squares(const SparseMatrix& m, UnknownSplit split,
                                                         SoftConstraints soft, double relative_ridge,
                                                         CholeskyKind kind, const std::vector<std::int64_t>* ordering) {
  if (std::size_t(m.cols()) != split.size())
    throw std::invalid_argument("ConstrainedQuadratic::least_squares: M must have n columns for n unknowns");
  ConstrainedQuadratic q;
  q.form_ = Form::LeastSquares;
  q.split_ = std::move(split);
  q.soft_ = std::move(soft);
  q.soft_free_ = soft_positions(q.soft_, q.split_);
  StageClock clock(q.stages_);
  std::tie(q.free_part_, q.fixed_part_) = split_columns(m, q.split_, false);
  clock.mark("free / fixed split");
  if (!q.split_.free().empty()) {
    SymmetricLower normal = normal_equations(q.free_part_);
    clock.mark("normal equations M_f^T M_f");
    const std::optional<Ordering> order = free_ordering(ordering, q.split_);
    q.factorize(std::move(normal), relative_ridge, kind, clock, order ? &*order : nullptr);
  }
  return q;
}

// The ridge is measured before the soft weights go on the diagonal, so that it does not depend on
// them. Each column's diagonal is its first entry.
void ConstrainedQuadratic::factorize(SymmetricLower system, double relative_ridge, CholeskyKind kind, StageClock& clock,
                                     const Ordering* ordering) {
  if (split_.free().empty()) return;
  const auto n = std::size_t(system.n);
  if (relative_ridge > 0) {
    double sum = 0;
    for (std::size_t k = 0; k < n; ++k) sum += system.value[std::size_t(system.start[k])];
    ridge_ = relative_ridge * sum / double(n);
    for (std::size_t k = 0; k < n; ++k) system.value[std::size_t(system.start[k])] += ridge_;
  }
  for (std::size_t s = 0; s < soft_free_.size(); ++s)
    system.value[std::size_t(system.start[std::size_t(soft_free_[s])])] += soft_.weights[s];
  solver_ = std::make_unique<SparseCholesky>();
  clock.mark("ridge and soft diagonal");
  factorised_ = solver_->factorize(system, kind, ordering);
  clock.add(solver_->stages(), "");
}

bool ConstrainedQuadratic::factorised() const { return factorised_; }

std::size_t ConstrainedQuadratic::factor_nonzeros() const { return solver_ ? solver_->factor_nonzeros() : 0; }

ConstrainedQuadratic::Matrix ConstrainedQuadratic::back_substitute(const Matrix& rhs) const {
  if (split_.free().empty()) return Matrix(0, rhs.cols());
  if (!factorised_) throw std::logic_error("ConstrainedQuadratic: solve after a failed factorisation");
  return solver_->solve(rhs);
}

ConstrainedQuadratic::Matrix ConstrainedQuadratic::constraint_term(const Matrix& fixed_values,
                                                                   const Matrix& soft_targets) const {
  if (form_ != Form::Quadratic) throw std::logic_error("ConstrainedQuadratic::constraint_term: quadratic form only");
  Matrix term = fixed_part_ * fixed_values;
  for (std::size_t s = 0; s < soft_free_.size(); ++s)
    term.row(soft_free_[s]) -= soft_.weights[s] * soft_targets.row(Eigen::Index(s));
  return term;
}

ConstrainedQuadratic::Matrix ConstrainedQuadratic::solve_free_with(const Matrix& b, const Matrix& term) const {
  return back_substitute(b.size() ? Matrix(b - term) : Matrix(-term));
}

ConstrainedQuadratic::Matrix ConstrainedQuadratic::solve_free(const Matrix& b, const Matrix& fixed_values,
                                                              const Matrix& soft_targets, const Matrix& guess) const {
  Matrix rhs;
  if (form_ == Form::Quadratic) {
    const Matrix term = constraint_term(fixed_values, soft_targets);
    rhs = b.size() ? Matrix(b - term) : Matrix(-term);
  } else {
    rhs = transpose_times(free_part_, b.size() ? Matrix(b - fixed_part_ * fixed_values) : Matrix(-(fixed_part_ * fixed_values)));
    for (std::size_t s = 0; s < soft_free_.size(); ++s)
      rhs.row(soft_free_[s]) += soft_.weights[s] * soft_targets.row(Eigen::Index(s));
  }
  if (ridge_ > 0 && guess.size()) rhs += ridge_ * guess;
  return back_substitute(rhs);
}

ConstrainedQuadratic::Matrix ConstrainedQuadratic::assemble(const Matrix& free_values, const Matrix& fixed_values) const {
  Matrix x(Eigen::Index(split_.size()), fixed_values.size() ? fixed_values.cols() : free_values.cols());
  for (std::size_t i = 0; i < split_.fixed().size(); ++i) x.row(split_.fixed()[i]) = fixed_values.row(Eigen::Index(i));
  for (std::size_t i = 0; i < split_.free().size(); ++i) x.row(split_.free()[i]) = free_values.row(Eigen::Index(i));
  return x;
}

Eigen::MatrixXd min_quadratic_with_fixed(const SparseMatrix& a, const Eigen::MatrixXd& b, const std::vector<int>& fixed,
                                         const Eigen::MatrixXd& fixed_values) {
  if (b.rows() != a.rows() || fixed_values.rows() != Eigen::Index(fixed.size()) ||
      (!fixed.empty() && fixed_values.cols() != b.cols()))
    throw std::invalid_argument("min_quadratic_with_fixed: expected b with A's rows and one row of fixed_values per fixed index");
  std::vector<char> is_fixed(std::size_t(a.rows()), 0);
  for (int i : fixed) {
    if (i < 0 || i >= a.rows() || is_fixed[std::size_t(i)])
      throw std::invalid_argument("min_quadratic_with_fixed: fixed index " + std::to_string(i) +
                                  " is out of range or repeated");
    is_fixed[std::size_t(i)] = 1;
  }
  UnknownSplit split(is_fixed);
  // The caller's order of fixed rows, in the split's (ascending) order.
  Eigen::MatrixXd y(Eigen::Index(split.fixed().size()), fixed_values.cols());
  for (std::size_t k = 0; k < fixed.size(); ++k) y.row(split.fixed_index(fixed[k])) = fixed_values.row(Eigen::Index(k));
  Eigen::MatrixXd bf(Eigen::Index(split.free().size()), b.cols());
  for (std::size_t i = 0; i < split.free().size(); ++i) bf.row(Eigen::Index(i)) = b.row(split.free()[i]);
  const ConstrainedQuadratic q = ConstrainedQuadratic::quadratic(a, split, {});
  if (!q.factorised())
    throw std::invalid_argument("min_quadratic_with_fixed: A is not positive definite on the free unknowns");
  return q.assemble(q.solve_free(bf, y, Eigen::MatrixXd(0, b.cols())), y);
}

}  // namespace deformkit

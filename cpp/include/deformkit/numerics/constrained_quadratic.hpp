#pragma once
// Minimising a quadratic energy with some unknowns given (fixed) and some pulled towards targets
// (soft), as libigl's min_quad_with_fixed: the free/fixed split is made and the free block
// factorised once; each solve then only forms a right-hand side and back-substitutes, for all its
// columns (the three coordinates) in one pass over the factor. The reduced system:
// docs/math/numerics.md, "Constrained quadratic".
#include "deformkit/numerics/sparse.hpp"
#include "deformkit/numerics/sparse_cholesky.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace deformkit {

// Which of n unknowns are solved for (free) and which are given (fixed), each list in index order.
class UnknownSplit {
 public:
  UnknownSplit() = default;
  // fixed[i] != 0: unknown i is given.
  explicit UnknownSplit(const std::vector<char>& fixed);

  // Each unknown as `width` consecutive ones (a vertex's x, y, z interleaved), fixed alike.
  UnknownSplit interleaved(int width) const;

  std::size_t size() const { return free_index_.size(); }
  const std::vector<int>& free() const { return free_; }
  const std::vector<int>& fixed() const { return fixed_; }
  int free_index(int i) const { return free_index_[std::size_t(i)]; }    // -1 if fixed
  int fixed_index(int i) const { return fixed_index_[std::size_t(i)]; }  // -1 if free
  bool is_fixed(int i) const { return fixed_index_[std::size_t(i)] >= 0; }

 private:
  std::vector<int> free_, fixed_, free_index_, fixed_index_;
};

// Free unknowns pulled towards targets: each adds 1/2 weight (x_i - c_i)^2 to the energy, so
// `weight` goes on the diagonal of the free block (w^2 for a penalty w |x_i - c_i| squared).
struct SoftConstraints {
  std::vector<int> unknowns;   // indices into the n unknowns; each must be free
  std::vector<double> weights; // one per unknown
};

class ConstrainedQuadratic {
 public:
  using Matrix = Eigen::MatrixXd;

  // E(x) = 1/2 x^T A x - x^T b (A symmetric, n x n), x_fixed = y: the free unknowns solve
  // A_ff x_f = b_f - A_fk y (+ the soft terms). Only A's free rows are read.
  // ordering (optional, n entries): a fill-reducing ordering of all n unknowns (e.g. remembered
  // for the mesh's connectivity), restricted here to the free ones; without it CHOLMOD's AMD
  // orders the free block.
  static ConstrainedQuadratic quadratic(const SparseMatrix& a, UnknownSplit split, SoftConstraints soft,
                                        CholeskyKind kind = CholeskyKind::Supernodal,
                                        const std::vector<std::int64_t>* ordering = nullptr);
  // E(x) = 1/2 |M x - r|^2 (M is rows x n), x_fixed = y: the normal equations
  // M_f^T M_f x_f = M_f^T (r - M_k y) (+ the soft terms), M^T M never formed for the fixed part.
  // relative_ridge > 0 adds a Tikhonov term 1/2 rho |x_f - g|^2, rho = relative_ridge times the
  // mean diagonal of M_f^T M_f, towards a guess g given to each solve: among several minimisers of
  // a singular system, the one nearest g.
  static ConstrainedQuadratic least_squares(const SparseMatrix& m, UnknownSplit split, SoftConstraints soft,
                                            double relative_ridge = 0.0,
                                            CholeskyKind kind = CholeskyKind::Supernodal,
                                            const std::vector<std::int64_t>* ordering = nullptr);

  ConstrainedQuadratic();
  ~ConstrainedQuadratic();
  ConstrainedQuadratic(ConstrainedQuadratic&&) noexcept;
  ConstrainedQuadratic& operator=(ConstrainedQuadratic&&) noexcept;

  // False when the free block (with the soft and ridge terms) is not positive definite; no solve
  // may follow then. True when nothing is free.
  bool factorised() const;
  const UnknownSplit& split() const { return split_; }
  const SoftConstraints& soft() const { return soft_; }
  double ridge() const { return ridge_; }
  std::size_t factor_nonzeros() const;
  const Stages& stages() const { return stages_; }  // where the construction spent its time

  // The free unknowns (free x k). fixed_values: fixed x k, in split().fixed() order;
  // soft_targets: one row per soft unknown; b: quadratic form, the free rows of b (free x k),
  // least squares, r (rows x k), either empty for zero; guess: free x k towards which the ridge
  // pulls (empty for zero).
  Matrix solve_free(const Matrix& b, const Matrix& fixed_values, const Matrix& soft_targets,
                    const Matrix& guess = Matrix()) const;

  // Quadratic form only, for solves that change b but not the constraints (ARAP's global steps):
  // the fixed values' and soft targets' part of the right-hand side, A_fk y - W c, formed once;
  // then solve_free_with(b, term) solves A_ff x_f = b - term.
  Matrix constraint_term(const Matrix& fixed_values, const Matrix& soft_targets) const;
  Matrix solve_free_with(const Matrix& b, const Matrix& term) const;

  // All n unknowns: the fixed ones y, the free ones from the given free values.
  Matrix assemble(const Matrix& free_values, const Matrix& fixed_values) const;

 private:
  enum class Form { Quadratic, LeastSquares };
  void factorize(SymmetricLower system, double relative_ridge, CholeskyKind kind, StageClock& clock,
                 const std::vector<std::int64_t>* ordering);
  Matrix back_substitute(const Matrix& rhs) const;

  Form form_ = Form::Quadratic;
  UnknownSplit split_;
  SoftConstraints soft_;
  std::vector<int> soft_free_;  // the soft unknowns' positions among the free ones
  SparseMatrix free_part_, fixed_part_;  // A_ff and A_fk, or M_f and M_k
  double ridge_ = 0.0;
  bool factorised_ = true;
  std::unique_ptr<SparseCholesky> solver_;
  Stages stages_;
};

// One-shot: argmin 1/2 x^T A x - x^T b with x[fixed[i]] = fixed_values.row(i); A n x n, b n x k.
// Throws std::invalid_argument if A is not positive definite on the free unknowns.
Eigen::MatrixXd min_quadratic_with_fixed(const SparseMatrix& a, const Eigen::MatrixXd& b,
                                         const std::vector<int>& fixed, const Eigen::MatrixXd& fixed_values);

}  // namespace deformkit

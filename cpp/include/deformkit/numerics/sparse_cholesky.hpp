#pragma once
// Sparse Cholesky factorisation of a symmetric positive definite matrix: CHOLMOD (SuiteSparse)
// orders, analyses and factorises it, deformkit's solve reads the factor in place; factorised once, then solved for several right-hand sides in one pass
// over the factor, which is what makes a re-solve of the three coordinates cheap (the solve is
// bound by memory traffic).
#include "deformkit/numerics/sparse.hpp"
#include "deformkit/core/stages.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace deformkit {

struct CholeskyFactor;
struct SupernodalFactor;

// Supernodal (dense blocks through CHOLMOD's BLAS; deformkit's solve on both cores) factorises
// faster on every mesh system measured (the cotangent Laplacian, its square, the rotation-invariant
// system); simplicial L D L^T is kept for small or very sparse systems, for a child forked while
// threads ran, and as the second code path the tests compare.
enum class CholeskyKind { Simplicial, Supernodal };

// The lower triangle of a symmetric n x n matrix in compressed columns, rows ascending, each
// column's diagonal present and first: what CHOLMOD reads, built without an intermediate copy.
struct SymmetricLower {
  std::int64_t n = 0;
  std::vector<std::int64_t> start{0}, row;  // column j: entries start[j] .. start[j + 1]
  std::vector<double> value;
};

class SparseCholesky {
 public:
  SparseCholesky();
  ~SparseCholesky();
  SparseCholesky(const SparseCholesky&) = delete;
  SparseCholesky& operator=(const SparseCholesky&) = delete;

  // Factorises a (its lower triangle is read). Returns false if a is not positive definite;
  // throws std::bad_alloc when CHOLMOD runs out of memory.
  bool factorize(const SparseMatrix& a, CholeskyKind kind);
  // The same for a lower triangle; ordering (n entries, or null for CHOLMOD's AMD): the
  // fill-reducing permutation to use, row k of the factored system being row ordering[k] of a.
  bool factorize(const SymmetricLower& a, CholeskyKind kind, const std::vector<std::int64_t>* ordering = nullptr);
  // X with A X = B, all columns of b at once (on every core). Safe to call from several threads.
  Eigen::MatrixXd solve(const Eigen::MatrixXd& b) const;
  bool empty() const;
  std::size_t factor_nonzeros() const;
  // The factor as single columns: a simplicial one as it is solved, a supernodal one converted on
  // the first call (for tests: it is not what a supernodal factor's solve reads).
  const CholeskyFactor& factor() const;
  const SupernodalFactor* supernodal_factor() const;  // null when simplicial
  const Stages& stages() const;  // where the last factorize() spent its time

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace deformkit

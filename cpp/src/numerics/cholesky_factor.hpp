#pragma once
// A sparse Cholesky factor P A P^T = L D L^T (or L L^T) in compressed columns, solved for several
// right-hand sides in one pass over L and on several cores. Disjoint subtrees of the elimination
// tree never touch each other's rows, so each core takes whole subtrees and only the top of the
// tree (the last separators) is solved by one core.
#include <cstdint>
#include <utility>
#include <vector>

namespace deformkit {

struct CholeskyFactor {
  std::vector<std::int64_t> start;  // n + 1 column offsets; a column's first entry is its diagonal
  std::vector<std::int32_t> row;
  std::vector<double> value;
  std::vector<std::int64_t> perm;   // row k of the factored system is row perm[k] of A
  bool unit_diagonal = true;        // L D L^T: diagonal entries hold D; else L L^T

  // Filled by schedule(): column ranges [first, last] per core, each a whole subtree, and the
  // remaining columns in ascending order (with their position in the shared accumulators).
  std::vector<std::vector<std::pair<std::int32_t, std::int32_t>>> ranges;
  std::vector<std::int32_t> top, top_position;

  std::size_t size() const { return perm.size(); }
  // Splits the elimination tree over `threads` cores (1: no split).
  void schedule(int threads);
  // x with A x = b for k columns (n x k, column-major); x may alias b.
  void solve(const double* b, double* x, int k) const;
};

}  // namespace deformkit

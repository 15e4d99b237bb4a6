#pragma once
// A supernodal Cholesky factor P A P^T = L L^T as CHOLMOD leaves it (columns grouped into
// supernodes that share one row list, each a dense column-major block), solved for several
// right-hand sides on several cores without converting it to single columns: one row index per
// supernode row instead of one per entry, so a solve, bound by reading the factor, reads 8 bytes
// per stored entry instead of 12, and the conversion's time and memory at bind are saved.
#include <cstdint>
#include <vector>

namespace deformkit {

struct SupernodalFactor {
  // Views into the factor's storage (CHOLMOD's, kept alive by its owner). Supernode s holds
  // columns [column[s], column[s + 1]) and rows row[row_start[s] .. row_start[s + 1]), its own
  // columns first, ascending; its values are value[value_start[s] ..], nrows x ncols column-major.
  std::int64_t n = 0, supernodes = 0;
  const std::int64_t *column = nullptr, *row_start = nullptr, *row = nullptr, *value_start = nullptr;
  const double* value = nullptr;
  const std::int64_t* perm = nullptr;  // row k of the factored system is row perm[k] of A

  // Filled by schedule(): per core, supernode ranges that are whole subtrees; the other (top)
  // supernodes, ascending; each top column's position in the cores' shared accumulators, or -1.
  std::vector<std::vector<std::pair<std::int32_t, std::int32_t>>> ranges;
  std::vector<std::int32_t> top;
  std::vector<std::int32_t> top_position;
  std::int32_t top_columns = 0, widest = 0;  // widest: the most rows of any supernode

  std::size_t stored() const { return n ? std::size_t(value_start[supernodes]) : 0; }  // explicit zeros included
  void schedule(int threads);
  // x with A x = b for k columns (n x k, column-major); x may alias b.
  void solve(const double* b, double* x, int k) const;
};

}  // namespace deformkit

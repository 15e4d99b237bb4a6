#include "numerics/supernodal_factor.hpp"

#include "core/parallel.hpp"
#include "numerics/supernodal_kernels.hpp"
#include "numerics/tree_split.hpp"

#include <algorithm>

namespace deformkit {

void SupernodalFactor::schedule(int threads) {
  const auto count = std::size_t(supernodes);
  // A supernode's parent holds its first row below its own columns.
  std::vector<std::int32_t> parent(count, -1), owner(std::size_t(n), -1);
  std::vector<std::int64_t> work(count);
  widest = 0;
  for (std::size_t s = 0; s < count; ++s)
    for (std::int64_t j = column[s]; j < column[s + 1]; ++j) owner[std::size_t(j)] = std::int32_t(s);
  for (std::size_t s = 0; s < count; ++s) {
    const std::int64_t cols = column[s + 1] - column[s], rows = row_start[s + 1] - row_start[s];
    if (rows > cols) parent[s] = owner[std::size_t(row[row_start[s] + cols])];
    work[s] = value_start[s + 1] - value_start[s];
    widest = std::max(widest, std::int32_t(rows));
  }
  TreeSplit split = split_tree(parent, work, threads, 200000);
  ranges = std::move(split.ranges);
  top = std::move(split.top);
  top_position.assign(std::size_t(n), -1);
  top_columns = 0;
  for (std::int32_t s : top)
    for (std::int64_t j = column[s]; j < column[s + 1]; ++j) top_position[std::size_t(j)] = top_columns++;
}

namespace {

// K right-hand sides side by side (y[i * K + c]). A supernode's rows are gathered into v, one
// contiguous run per right-hand side (v[c * rows + r]), so that each column of its block is read
// once, in order, for all K.
template <int K>
struct SupernodalSolver {
  const SupernodalFactor& f;

  // L y = b on supernode s; rows at or beyond `limit` (outside the subtree) go to `shared`.
  void forward(std::int32_t s, std::int64_t limit, double* y, double* shared, double* v) const {
    const std::int64_t j0 = f.column[s], cols = f.column[s + 1] - j0, rows = f.row_start[s + 1] - f.row_start[s];
    const std::int64_t* r_of = f.row + f.row_start[s];
    const double* block = f.value + f.value_start[s];
    for (int c = 0; c < K; ++c) {
      for (std::int64_t r = 0; r < cols; ++r) v[c * rows + r] = y[(j0 + r) * K + c];
      std::fill(v + c * rows + cols, v + (c + 1) * rows, 0.0);
    }
    supernode_forward(K, block, rows, cols, v);
    for (std::int64_t r = 0; r < cols; ++r)
      for (int c = 0; c < K; ++c) y[(j0 + r) * K + c] = v[c * rows + r];
    for (std::int64_t r = cols; r < rows; ++r) {
      const std::int64_t i = r_of[r];
      double* yi = i < limit ? y + i * K : shared + std::int64_t(f.top_position[std::size_t(i)]) * K;
      for (int c = 0; c < K; ++c) yi[c] += v[c * rows + r];
    }
  }

  // L^T x = y on supernode s, its rows below already solved.
  void backward(std::int32_t s, double* x, double* v) const {
    const std::int64_t j0 = f.column[s], cols = f.column[s + 1] - j0, rows = f.row_start[s + 1] - f.row_start[s];
    const std::int64_t* r_of = f.row + f.row_start[s];
    const double* block = f.value + f.value_start[s];
    for (std::int64_t r = 0; r < rows; ++r)
      for (int c = 0; c < K; ++c) v[c * rows + r] = x[r_of[r] * K + c];
    supernode_backward(K, block, rows, cols, v);
    for (std::int64_t r = 0; r < cols; ++r)
      for (int c = 0; c < K; ++c) x[(j0 + r) * K + c] = v[c * rows + r];
  }

  void run(double* y) const {
    const std::size_t tasks = f.ranges.size(), stride = std::size_t(f.top_columns) * K;
    std::vector<double> shared(tasks * stride, 0.0);
    const std::size_t scratch = std::size_t(f.widest) * K;
    // The ranges' subtrees are independent: one task each, on the caller and the pool's workers.
    parallel_tasks(int(tasks), [&](int t) {
      std::vector<double> v(scratch);
      for (const auto& [lo, hi] : f.ranges[std::size_t(t)])
        for (std::int32_t s = lo; s <= hi; ++s) forward(s, f.column[hi + 1], y, shared.data() + std::size_t(t) * stride, v.data());
    });
    std::vector<double> v(scratch);
    for (std::size_t t = 0; t < tasks; ++t)
      for (std::int32_t s : f.top)
        for (std::int64_t j = f.column[s]; j < f.column[s + 1]; ++j)
          for (int c = 0; c < K; ++c) y[j * K + c] += shared[t * stride + std::size_t(f.top_position[std::size_t(j)]) * K + std::size_t(c)];
    for (std::int32_t s : f.top) forward(s, f.n, y, nullptr, v.data());
    for (auto it = f.top.rbegin(); it != f.top.rend(); ++it) backward(*it, y, v.data());
    parallel_tasks(int(tasks), [&](int t) {
      std::vector<double> w(scratch);
      const auto& list = f.ranges[std::size_t(t)];
      for (auto range = list.rbegin(); range != list.rend(); ++range)
        for (std::int32_t s = range->second; s >= range->first; --s) backward(s, y, w.data());
    });
  }
};

}  // namespace

// Columns go through in blocks of a width known at compile time (12, 6, 3 or 1); one pass over L
// per block.
void SupernodalFactor::solve(const double* b, double* x, int k) const {
  const auto rows = std::size_t(n);
  std::vector<double> y;
  for (int first = 0; first < k;) {
    const int left = k - first;
    const int w = left >= 12 ? 12 : left >= 6 ? 6 : left >= 3 ? 3 : 1;
    y.resize(rows * std::size_t(w));
    const double* bb = b + std::size_t(first) * rows;
    for (std::size_t i = 0; i < rows; ++i)
      for (int c = 0; c < w; ++c) y[i * std::size_t(w) + std::size_t(c)] = bb[std::size_t(perm[i]) + std::size_t(c) * rows];
    switch (w) {
      case 12: SupernodalSolver<12>{*this}.run(y.data()); break;
      case 6: SupernodalSolver<6>{*this}.run(y.data()); break;
      case 3: SupernodalSolver<3>{*this}.run(y.data()); break;
      default: SupernodalSolver<1>{*this}.run(y.data()); break;
    }
    double* xx = x + std::size_t(first) * rows;
    for (std::size_t i = 0; i < rows; ++i)
      for (int c = 0; c < w; ++c) xx[std::size_t(perm[i]) + std::size_t(c) * rows] = y[i * std::size_t(w) + std::size_t(c)];
    first += w;
  }
}

}  // namespace deformkit

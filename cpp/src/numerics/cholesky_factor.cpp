#include "numerics/cholesky_factor.hpp"

#include "core/parallel.hpp"
#include "numerics/tree_split.hpp"

#include <algorithm>

namespace deformkit {

void CholeskyFactor::schedule(int threads) {
  const std::int32_t n = std::int32_t(size());
  // Elimination tree: a column's parent is its first off-diagonal row.
  std::vector<std::int32_t> parent(std::size_t(n), -1);
  std::vector<std::int64_t> work(static_cast<std::size_t>(n));
  for (std::int32_t j = 0; j < n; ++j) {
    std::int32_t p = -1;
    for (std::int64_t e = start[j] + 1; e < start[j + 1]; ++e) p = p < 0 ? row[e] : std::min(p, row[e]);
    parent[std::size_t(j)] = p;
    work[std::size_t(j)] = start[j + 1] - start[j];
  }
  TreeSplit split = split_tree(parent, work, threads, 200000);
  ranges = std::move(split.ranges);
  top = std::move(split.top);
  top_position.assign(std::size_t(n), -1);
  for (std::size_t k = 0; k < top.size(); ++k) top_position[top[k]] = std::int32_t(k);
}

namespace {

// K right-hand sides sit side by side (y[i * K + c]) so that each entry of L is read once.
template <int K>
struct Solver {
  const CholeskyFactor& f;
  static constexpr int width() { return K; }

  // Column j of the forward substitution L y = b; rows outside [.., last] go to `shared`.
  void forward(std::int32_t j, std::int32_t last, double* y, double* shared) const {
    double* yj = y + std::int64_t(j) * K;
    if (!f.unit_diagonal)
      for (int c = 0; c < K; ++c) yj[c] /= f.value[f.start[j]];
    double v[K];  // in registers: the stores below could alias yj as far as the compiler knows
    for (int c = 0; c < K; ++c) v[c] = yj[c];
    for (std::int64_t e = f.start[j] + 1; e < f.start[j + 1]; ++e) {
      const std::int32_t i = f.row[e];
      const double l = f.value[e];
      double* yi = i <= last ? y + std::int64_t(i) * K : shared + std::int64_t(f.top_position[i]) * K;
      for (int c = 0; c < K; ++c) yi[c] -= l * v[c];
    }
  }
  // Column j of the backward substitution L^T x = y (after the diagonal).
  void backward(std::int32_t j, double* x) const {
    double acc[K];
    double* xj = x + std::int64_t(j) * K;
    for (int c = 0; c < K; ++c) acc[c] = xj[c];
    for (std::int64_t e = f.start[j] + 1; e < f.start[j + 1]; ++e) {
      const double* xi = x + std::int64_t(f.row[e]) * K;
      for (int c = 0; c < K; ++c) acc[c] -= f.value[e] * xi[c];
    }
    for (int c = 0; c < K; ++c) xj[c] = f.unit_diagonal ? acc[c] : acc[c] / f.value[f.start[j]];
  }

  void run(double* y) const {
    constexpr int w = K;
    // The ranges' subtrees are independent: one task each, on the caller and the pool's workers,
    // so a busy core does not stall the solve (core/parallel.hpp).
    const std::int32_t n = std::int32_t(f.size());
    std::vector<double> shared(f.ranges.size() * f.top.size() * std::size_t(w), 0.0);
    const std::size_t stride = f.top.size() * std::size_t(w);
    parallel_tasks(int(f.ranges.size()), [&](int t) {
      for (const auto& [lo, hi] : f.ranges[std::size_t(t)])
        for (std::int32_t j = lo; j <= hi; ++j) forward(j, hi, y, shared.data() + std::size_t(t) * stride);
    });
    for (std::size_t t = 0; t < f.ranges.size(); ++t)
      for (std::size_t p = 0; p < f.top.size(); ++p)
        for (int c = 0; c < w; ++c) y[std::int64_t(f.top[p]) * w + c] += shared[t * stride + p * std::size_t(w) + std::size_t(c)];
    for (std::int32_t j : f.top) forward(j, n, y, nullptr);
    if (f.unit_diagonal)
      for (std::int32_t j = 0; j < n; ++j)
        for (int c = 0; c < w; ++c) y[std::int64_t(j) * w + c] /= f.value[f.start[j]];
    for (auto it = f.top.rbegin(); it != f.top.rend(); ++it) backward(*it, y);
    parallel_tasks(int(f.ranges.size()), [&](int t) {
      for (auto range = f.ranges[std::size_t(t)].rbegin(); range != f.ranges[std::size_t(t)].rend(); ++range)
        for (std::int32_t j = range->second; j >= range->first; --j) backward(j, y);
    });
  }
};

}  // namespace

// Columns go through in blocks of a width known at compile time (12, 6, 3 or 1), whose values the
// inner loops keep in registers; one pass over L per block.
void CholeskyFactor::solve(const double* b, double* x, int k) const {
  const std::size_t n = size();
  std::vector<double> y;
  for (int first = 0; first < k;) {
    const int left = k - first;
    const int w = left >= 12 ? 12 : left >= 6 ? 6 : left >= 3 ? 3 : 1;
    y.assign(n * std::size_t(w), 0.0);
    const double* bb = b + std::size_t(first) * n;
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < w; ++c) y[i * std::size_t(w) + std::size_t(c)] = bb[std::size_t(perm[i]) + std::size_t(c) * n];
    switch (w) {
      case 12: Solver<12>{*this}.run(y.data()); break;
      case 6: Solver<6>{*this}.run(y.data()); break;
      case 3: Solver<3>{*this}.run(y.data()); break;
      default: Solver<1>{*this}.run(y.data()); break;
    }
    double* xx = x + std::size_t(first) * n;
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < w; ++c) xx[std::size_t(perm[i]) + std::size_t(c) * n] = y[i * std::size_t(w) + std::size_t(c)];
    first += w;
  }
}

}  // namespace deformkit

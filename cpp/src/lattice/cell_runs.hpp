#pragma once
// What the lattice's deform and derivative paths share: the counting sort of points by cell, the
// kernel's view of an axis, and the overflow report that must wait until an OpenMP region ends.
#include "deformkit/lattice/lattice_basis.hpp"
#include "lattice/lattice_kernel.hpp"

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace deformkit {

// A finite point far enough from the lattice overflows its lattice coordinates (M^-1 (x - X0)),
// or, extrapolating, lies too far out to evaluate accurately (ControlLattice::refuse_row names it).
// Exceptions must not leave an OpenMP region, so rows are noted there and reported after it.
class OverflowRows {
 public:
  void note(std::size_t i) {
    std::size_t cur = first_.load();
    while (i < cur && !first_.compare_exchange_weak(cur, i)) {
    }
  }
  bool any() const { return first_.load() != kNone; }
  std::size_t first() const { return first_.load(); }

 private:
  static constexpr std::size_t kNone = ~std::size_t(0);
  std::atomic<std::size_t> first_{kNone};
};

// Keys below this many are sorted by counting, chunk by chunk (the counts fit in the L1 cache).
constexpr std::uint64_t kCountingSortKeys = std::uint64_t(1) << 14;

// Stable counting sort of one chunk of keys in three steps, so that the counting can share the
// loop that computes the keys: count() each key, prefix(), then slot(key) hands each point its
// sorted position in input order; afterwards run_end(key) is where key's run ends.
class CountingSort {
 public:
  explicit CountingSort(std::uint64_t keys) : start_(keys + 1) {}
  void clear() { std::fill(start_.begin(), start_.end(), 0u); }
  void count(std::uint64_t key) { ++start_[key + 1]; }
  void prefix() {
    for (std::size_t k = 1; k < start_.size(); ++k) start_[k] += start_[k - 1];
  }
  std::uint32_t slot(std::uint64_t key) { return start_[key]++; }
  std::uint32_t run_end(std::uint64_t key) const { return start_[key]; }

 private:
  std::vector<std::uint32_t> start_;
};

// One chunk of points sorted by cell with a counting sort: the caller fills key[0, m) for the
// chunk's rows first + 0 .. first + m - 1; sort() hands each row its sorted slot and leaves order[slot]
// = its point index, and runs() walks the runs of one cell in key order.
class ChunkByCell {
 public:
  ChunkByCell(std::uint64_t keys, std::size_t chunk) : key(chunk), order(chunk), sort_(keys) {}
  std::vector<std::uint64_t> key;
  std::vector<std::uint32_t> order;

  // place(row, slot) for each row of the chunk, in row order.
  template <class F>
  void sort(std::size_t first, std::size_t m, F&& place) {
    first_ = first;
    sort_.clear();
    for (std::size_t i = 0; i < m; ++i) sort_.count(key[i]);
    sort_.prefix();
    for (std::size_t i = 0; i < m; ++i) {
      const std::size_t to = sort_.slot(key[i]);
      order[to] = static_cast<std::uint32_t>(first + i);
      place(i, to);
    }
  }
  // run(key, lo, hi) for the slots [lo, hi) of each cell.
  template <class F>
  void runs(std::size_t m, F&& run) const {
    for (std::size_t lo = 0; lo < m;) {
      const std::uint64_t k = key[order[lo] - first_];
      const std::size_t hi = sort_.run_end(k);
      run(k, lo, hi);
      lo = hi;
    }
  }

 private:
  CountingSort sort_;
  std::size_t first_ = 0;
};

// The kernel's view of an axis.
inline KernelAxis kernel_axis(const AxisBasis& a) {
  switch (a.kind) {
    case BasisKind::Bernstein: return {KernelBasis::Bernstein, a.count, 0.0};
    case BasisKind::BezierBlocks: return {KernelBasis::Bernstein, 4, 0.0};
    case BasisKind::UniformBSpline:
    case BasisKind::BlenderBSpline: return {a.count == 1 ? KernelBasis::Constant : KernelBasis::CubicBSpline,
                                            a.count == 1 ? 1 : 4, 0.0};
    case BasisKind::BlenderLinear: return {a.count == 1 ? KernelBasis::Constant : KernelBasis::Linear,
                                           a.count == 1 ? 1 : 2, 0.0};
    case BasisKind::BlenderCardinal: return {a.count == 1 ? KernelBasis::Constant : KernelBasis::Cardinal,
                                             a.count == 1 ? 1 : 4, 0.71};
    case BasisKind::BlenderCatmullRom: return {a.count == 1 ? KernelBasis::Constant : KernelBasis::Cardinal,
                                               a.count == 1 ? 1 : 4, 0.5};
  }
  return {};
}

}  // namespace deformkit

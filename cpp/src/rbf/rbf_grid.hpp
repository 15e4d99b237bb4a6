#pragma once
// The controls of a compactly supported kernel by cubic cell of the support radius, so that a
// point visits only the controls of its cell and the 26 around it.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

namespace deformkit {

class RbfGrid {
 public:
  // Throws std::invalid_argument naming radius when the controls' extent spans more cells than
  // a 64-bit cell index holds.
  RbfGrid(const double* controls, std::size_t m, double radius);

  // f(j, r) for every control j with r = |x - c_j| < radius.
  template <class F>
  void for_each_within(const double x[3], F&& f) const {
    std::int64_t cell[3];
    for (int a = 0; a < 3; ++a) {
      const double u = std::floor((x[a] - origin_[a]) / radius_);
      if (!(u >= -1.0 && u <= double(extent_[a]))) return;  // beyond the controls' cells and their neighbours
      cell[a] = std::int64_t(u);
    }
    for (std::int64_t i = cell[0] - 1; i <= cell[0] + 1; ++i)
      for (std::int64_t j = cell[1] - 1; j <= cell[1] + 1; ++j) {
        // The three cells along k have consecutive keys: one range of the sorted controls.
        std::uint32_t s, e;
        if (!dense_.empty()) {
          const std::uint64_t k0 = key(i, j, cell[2] - 1);
          s = dense_[k0], e = dense_[k0 + 3];
        } else {
          s = e = 0;
          for (std::int64_t k = cell[2] - 1; k <= cell[2] + 1; ++k) {
            const auto found = cells_.find(key(i, j, k));
            if (found != cells_.end()) visit(found->second.first, found->second.second, x, f);
          }
        }
        visit(s, e, x, f);
      }
  }

 private:
  template <class F>
  void visit(std::uint32_t s, std::uint32_t e, const double x[3], F& f) const {
    for (; s < e; ++s) {
      const std::uint32_t c = order_[s];
      const double* p = sorted_.data() + 3 * std::size_t(s);
      const double dx = x[0] - p[0], dy = x[1] - p[1], dz = x[2] - p[2];
      const double r = std::sqrt(dx * dx + dy * dy + dz * dz);
      if (r < radius_) f(std::size_t(c), r);
    }
  }

  std::uint64_t key(std::int64_t i, std::int64_t j, std::int64_t k) const {
    // Cells -2 .. extent + 1 (the controls' and two rings around them), offset to be non-negative.
    return (std::uint64_t(i + 2) * std::uint64_t(extent_[1] + 4) + std::uint64_t(j + 2)) * std::uint64_t(extent_[2] + 4) +
           std::uint64_t(k + 2);
  }

  double origin_[3] = {0, 0, 0};
  std::int64_t extent_[3] = {0, 0, 0};  // cells per axis holding controls
  double radius_ = 1.0;
  std::vector<std::uint32_t> order_;  // controls sorted by cell
  std::vector<double> sorted_;        // their positions in that order (x y z)
  // Up to kDenseCells cells: the start of each cell's controls in order_, indexed by key (one
  // past the last key: the end); beyond, a hash map of the occupied cells.
  std::vector<std::uint32_t> dense_;
  std::unordered_map<std::uint64_t, std::pair<std::uint32_t, std::uint32_t>> cells_;
};

}  // namespace deformkit

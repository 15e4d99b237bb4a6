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

  // f(j, r) for every control j with r = |x - c_j| < radius, in increasing j within each cell.
  template <class F>
  void for_each_within(const double x[3], F&& f) const {
    std::int64_t cell[3];
    for (int a = 0; a < 3; ++a) {
      const double u = std::floor((x[a] - origin_[a]) / radius_);
      if (!(u >= -1.0 && u <= double(extent_[a]))) return;  // beyond the controls' cells and their neighbours
      cell[a] = std::int64_t(u);
    }
    for (std::int64_t i = cell[0] - 1; i <= cell[0] + 1; ++i)
      for (std::int64_t j = cell[1] - 1; j <= cell[1] + 1; ++j)
        for (std::int64_t k = cell[2] - 1; k <= cell[2] + 1; ++k) {
          const auto found = cells_.find(key(i, j, k));
          if (found == cells_.end()) continue;
          for (std::uint32_t s = found->second.first; s < found->second.second; ++s) {
            const std::uint32_t c = order_[s];
            const double* p = controls_.data() + 3 * std::size_t(c);
            const double dx = x[0] - p[0], dy = x[1] - p[1], dz = x[2] - p[2];
            const double r = std::sqrt(dx * dx + dy * dy + dz * dz);
            if (r < radius_) f(std::size_t(c), r);
          }
        }
  }

 private:
  std::uint64_t key(std::int64_t i, std::int64_t j, std::int64_t k) const {
    // Cells -2 .. extent + 1 (the controls' and two rings around them), offset to be non-negative.
    return (std::uint64_t(i + 2) * std::uint64_t(extent_[1] + 4) + std::uint64_t(j + 2)) * std::uint64_t(extent_[2] + 4) +
           std::uint64_t(k + 2);
  }

  std::vector<double> controls_;
  double origin_[3] = {0, 0, 0};
  std::int64_t extent_[3] = {0, 0, 0};  // cells per axis holding controls
  double radius_ = 1.0;
  std::vector<std::uint32_t> order_;  // controls sorted by cell
  std::unordered_map<std::uint64_t, std::pair<std::uint32_t, std::uint32_t>> cells_;
};

}  // namespace deformkit

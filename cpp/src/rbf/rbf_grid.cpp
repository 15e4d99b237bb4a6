#include "rbf/rbf_grid.hpp"

#include "deformkit/core/validation.hpp"

#include <algorithm>
#include <cstdio>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

namespace deformkit {

namespace {
// A dense cell index up to this many cells (16 MB); beyond, a hash map of the occupied ones.
constexpr double kDenseCells = 4.0 * 1024 * 1024;
}  // namespace

static std::string short_number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

RbfGrid::RbfGrid(const double* controls, std::size_t m, double radius) : radius_(radius) {
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::numeric_limits<double>::infinity();
    hi[a] = -lo[a];
  }
  for (std::size_t j = 0; j < m; ++j)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], controls[3 * j + a]);
      hi[a] = std::max(hi[a], controls[3 * j + a]);
    }
  double cells = 1.0;
  for (int a = 0; a < 3; ++a) {
    origin_[a] = lo[a];
    const double span = std::floor((hi[a] - lo[a]) / radius) + 1.0;
    cells *= span + 4.0;
    extent_[a] = std::int64_t(std::min(span, 1e18));
  }
  double extent = 0.0;
  for (int a = 0; a < 3; ++a) extent = std::max(extent, hi[a] - lo[a]);
  if (!(cells < 1.8e19) && !(extent < point_range()))
    throw std::invalid_argument("control_points: spanning " + short_number(extent) +
                                ", beyond the magnitude points may take (" + short_number(point_range()) +
                                "): no support radius covers them in 2^64 grid cells");
  if (!(cells < 1.8e19))
    throw std::invalid_argument("radius: " + std::to_string(radius) +
                                " is too small for the controls' extent (more grid cells than 2^64); use a larger radius");
  std::vector<std::uint64_t> keys(m);
  for (std::size_t j = 0; j < m; ++j) {
    std::int64_t c[3];
    for (int a = 0; a < 3; ++a)
      c[a] = std::min(extent_[a] - 1, std::int64_t(std::floor((controls[3 * j + a] - origin_[a]) / radius)));
    keys[j] = key(c[0], c[1], c[2]);
  }
  order_.resize(m);
  std::iota(order_.begin(), order_.end(), 0u);
  std::stable_sort(order_.begin(), order_.end(), [&](std::uint32_t a, std::uint32_t b) { return keys[a] < keys[b]; });
  sorted_.resize(3 * m);
  for (std::size_t s = 0; s < m; ++s)
    for (int a = 0; a < 3; ++a) sorted_[3 * s + a] = controls[3 * std::size_t(order_[s]) + a];
  if (cells <= kDenseCells) {
    dense_.assign(std::size_t(cells) + 1, 0);
    for (std::size_t j = 0; j < m; ++j) ++dense_[keys[j] + 1];
    for (std::size_t k = 1; k < dense_.size(); ++k) dense_[k] += dense_[k - 1];
    return;
  }
  for (std::size_t s = 0; s < m;) {
    std::size_t e = s;
    while (e < m && keys[order_[e]] == keys[order_[s]]) ++e;
    cells_.emplace(keys[order_[s]], std::make_pair(std::uint32_t(s), std::uint32_t(e)));
    s = e;
  }
}

}  // namespace deformkit

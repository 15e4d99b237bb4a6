#include "deformkit/surface/drag_start.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

namespace deformkit {

std::vector<double> extrapolated_start(const double* previous, const double* earlier, std::size_t vertices,
                                       const double* targets, const double* previous_targets,
                                       const double* earlier_targets, std::size_t handles) {
  double along = 0, last = 0;
  for (std::size_t k = 0; k < 3 * handles; ++k) {
    const double step = targets[k] - previous_targets[k], last_step = previous_targets[k] - earlier_targets[k];
    along += step * last_step;
    last += last_step * last_step;
  }
  if (!std::isfinite(along) || !std::isfinite(last)) {
    // The one of the three handle positions with the largest coordinate made the steps overflow.
    const char* names[3] = {"targets", "previous_targets", "earlier_targets"};
    const double* arrays[3] = {targets, previous_targets, earlier_targets};
    int worst = 0;
    double top[3] = {0, 0, 0};
    for (int a = 0; a < 3; ++a) {
      for (std::size_t k = 0; k < 3 * handles; ++k) top[a] = std::max(top[a], std::abs(arrays[a][k]));
      if (top[a] > top[worst]) worst = a;
    }
    char magnitude[32];
    std::snprintf(magnitude, sizeof magnitude, "%.3g", top[worst]);
    throw std::invalid_argument(std::string(names[worst]) + ": a coordinate of magnitude " + magnitude +
                                " makes the handles' steps overflow (finite coordinates below ~1e154 are accepted)");
  }
  const double s = last > 0 ? std::clamp(along / last, 0.0, 2.0) : 0.0;
  std::vector<double> out(3 * vertices);
  for (std::size_t k = 0; k < out.size(); ++k) {
    out[k] = previous[k] + s * (previous[k] - earlier[k]);
    if (!std::isfinite(out[k]))
      throw std::invalid_argument("previous: row " + std::to_string(k / 3) + " extrapolated overflows");
  }
  return out;
}

}  // namespace deformkit

#include "deformkit/mesh_volume.hpp"

#include "deformkit/deformer.hpp"

#include <stdexcept>
#include <string>

namespace deformkit {

double mesh_volume(const double* points, std::size_t n, const std::int64_t* faces, std::size_t m, std::size_t k) {
  if (k < 3) throw std::invalid_argument("faces: need at least 3 corners per face");
  require_finite_rows(points, n, "points");
  for (std::size_t i = 0; i < m * k; ++i)
    if (faces[i] < 0 || std::size_t(faces[i]) >= n)
      throw std::invalid_argument("faces: face " + std::to_string(i / k) + " has corner index " +
                                  std::to_string(faces[i]) + ", outside 0.." + std::to_string(n - 1));
  auto p = [points](std::int64_t i) { return Vec3(points[3 * i], points[3 * i + 1], points[3 * i + 2]); };
  // Relative to the first point, so that a mesh far from the origin keeps its precision.
  const Vec3 o = p(faces[0]);
  double six_v = 0.0;
  for (std::size_t f = 0; f < m; ++f) {
    const std::int64_t* c = faces + f * k;
    const Vec3 a = p(c[0]) - o;
    for (std::size_t j = 1; j + 1 < k; ++j) six_v += a.dot((p(c[j]) - o).cross(p(c[j + 1]) - o));
  }
  return six_v / 6.0;
}

}  // namespace deformkit

#include "deformkit/core/mesh_volume.hpp"

#include "deformkit/core/types.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace deformkit {

// Per axis, 2^-e with 2^e near the largest magnitude, e clamped so that 2^-e is itself finite.
static Vec3 axis_scales(const double* points, std::size_t n, int exponent[3]) {
  Vec3 top = Vec3::Zero();
  for (std::size_t i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a) top[a] = std::max(top[a], std::abs(points[3 * i + a]));
  Vec3 scale;
  for (int a = 0; a < 3; ++a) {
    exponent[a] = top[a] > 0.0 ? std::clamp(std::ilogb(top[a]), -1000, 1023) : 0;
    scale[a] = std::ldexp(1.0, -exponent[a]);
  }
  return scale;
}

double mesh_volume(const PolygonMeshView& mesh) {
  require_distinct_corners(mesh);
  const double* points = mesh.points;
  const std::size_t n = mesh.vertex_count;
  // a . (b x c) = det[a b c] scales by sx sy sz when the axes are scaled by (sx, sy, sz): with each
  // axis brought near 1 by a power of two (exact), no product overflows or underflows on the way
  // to a volume that a double can hold, however large or flat the mesh is.
  int exponent[3];
  const Vec3 scale = axis_scales(points, n, exponent);
  auto p = [&](int i) -> Vec3 {
    return Vec3(points[3 * i], points[3 * i + 1], points[3 * i + 2]).cwiseProduct(scale);
  };
  // Relative to the first corner's point, so that a mesh far from the origin keeps its precision.
  const Vec3 o = p(mesh.corners[0]);
  double six_v = 0.0;
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    const int* c = mesh.face(f);
    const Vec3 a = p(c[0]) - o;
    for (int j = 1; j + 1 < mesh.face_size(f); ++j) six_v += a.dot((p(c[j]) - o).cross(p(c[j + 1]) - o));
  }
  const double volume = std::ldexp(six_v / 6.0, exponent[0] + exponent[1] + exponent[2]);
  if (!std::isfinite(volume)) {
    std::ostringstream msg;
    msg << "points: the enclosed volume, about 1e"
        << long(std::floor(std::log10(std::abs(six_v / 6.0)) + (exponent[0] + exponent[1] + exponent[2]) * std::log10(2.0)))
        << ", overflows a double (scale the mesh down)";
    throw std::invalid_argument(msg.str());
  }
  return volume;
}

}  // namespace deformkit

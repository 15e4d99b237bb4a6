#include "transfer/sliver.hpp"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace deformkit {

double triangle_shape(const double* a, const double* b, const double* c) {
  Eigen::Vector3d e[3];
  for (int k = 0; k < 3; ++k) e[0][k] = b[k] - a[k], e[1][k] = c[k] - b[k], e[2][k] = a[k] - c[k];
  const double scale = std::max({e[0].cwiseAbs().maxCoeff(), e[1].cwiseAbs().maxCoeff(), e[2].cwiseAbs().maxCoeff()});
  if (!(scale > 0)) return 0.0;
  for (Eigen::Vector3d& v : e) v /= scale;
  const double longest = std::max({e[0].squaredNorm(), e[1].squaredNorm(), e[2].squaredNorm()});
  return 0.5 * e[0].cross(-e[2]).norm() / longest;
}

void require_no_sliver(const PolygonMesh& triangles, const char* argument) {
  const double* p = triangles.points().data();
  for (std::size_t j = 0; j < triangles.face_count(); ++j) {
    const int* v = triangles.face(j);
    const double shape = triangle_shape(p + 3 * v[0], p + 3 * v[1], p + 3 * v[2]);
    if (shape >= kThinnestTriangle) continue;
    std::ostringstream message;
    message << argument << ": triangle " << j << " (vertices " << v[0] << ", " << v[1] << ", " << v[2] << ")";
    if (shape == 0)
      message << " has zero area";
    else
      message << " is a sliver: its area is " << shape << " of its longest edge squared, under the "
              << kThinnestTriangle << " accepted (a corner almost on the opposite edge leaves its normal to rounding)";
    throw std::invalid_argument(message.str());
  }
}

}  // namespace deformkit

#pragma once
// One triangle of a TriangleCageView with its corners read out: shared by the Green integrals and
// the exterior blend, which both walk the cage a triangle at a time.
#include "cage/green_coordinates.hpp"

#include <Eigen/Dense>

#include <cstddef>

namespace deformkit {

struct CageTriangle3 {
  Eigen::Vector3d p[3];
  int index[3];
};

inline CageTriangle3 cage_triangle(const TriangleCageView& cage, std::size_t j) {
  CageTriangle3 t;
  for (int k = 0; k < 3; ++k) {
    t.index[k] = cage.triangles[3 * j + k];
    const double* q = cage.points + 3 * static_cast<std::size_t>(t.index[k]);
    t.p[k] = Eigen::Vector3d(q[0], q[1], q[2]);
  }
  return t;
}

}  // namespace deformkit

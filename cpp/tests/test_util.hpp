#pragma once
// Shared helpers for the deformkit C++ tests: random inputs and finite differences.
#include "deformkit/deformkit.hpp"

#include <random>
#include <vector>

namespace deformkit::test {

inline std::vector<double> random_points(std::size_t n, double lo, double hi, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(lo, hi);
  std::vector<double> p(3 * n);
  for (auto& v : p) v = u(rng);
  return p;
}

// A rotation times a non-uniform scale plus a translation: a general affine frame.
inline Frame random_frame(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Eigen::Quaterniond q = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized();
  Mat4 m = Mat4::Identity();
  m.topLeftCorner<3, 3>() = q.toRotationMatrix() * Eigen::Vector3d(1.3, 0.7, 1.1).asDiagonal();
  m.topRightCorner<3, 1>() = Vec3(u(rng), u(rng), u(rng));
  return Frame::from_matrix(m);
}

inline Vec3 deform_one(const Deformer& d, const Vec3& p) {
  double in[3] = {p.x(), p.y(), p.z()}, out[3];
  d.deform(in, out, 1);
  return Vec3(out[0], out[1], out[2]);
}

inline Mat3 jacobian_one(const Deformer& d, const Vec3& p) {
  double in[3] = {p.x(), p.y(), p.z()}, jac[9];
  d.jacobian(in, jac, 1);
  Mat3 j;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) j(r, c) = jac[3 * r + c];
  return j;
}

// Central differences, O(h^2).
inline Mat3 finite_difference_jacobian(const Deformer& d, const Vec3& p, double h = 1e-6) {
  Mat3 j;
  for (int c = 0; c < 3; ++c) {
    Vec3 e = Vec3::Zero();
    e[c] = h;
    j.col(c) = (deform_one(d, p + e) - deform_one(d, p - e)) / (2.0 * h);
  }
  return j;
}

}  // namespace deformkit::test

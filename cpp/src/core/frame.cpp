#include "deformkit/core/frame.hpp"

#include <Eigen/LU>

#include <cmath>
#include <stdexcept>
#include <string>

namespace deformkit {

Frame Frame::from_matrix(const Mat4& m, const char* argument) {
  const std::string name(argument);
  if (!m.allFinite()) throw std::invalid_argument(name + ": matrix contains NaN or Inf");
  if (m(3, 0) != 0.0 || m(3, 1) != 0.0 || m(3, 2) != 0.0 || m(3, 3) != 1.0)
    throw std::invalid_argument(name + ": not an affine matrix (last row must be [0, 0, 0, 1])");
  Frame f;
  f.linear = m.topLeftCorner<3, 3>();
  f.translation = m.topRightCorner<3, 1>();
  // Scale-free test on unit columns: a frame scaled to 1e-100 is fine, a flattened one is not.
  const Eigen::RowVector3d norms = f.linear.colwise().norm();
  const bool zero_column = !(norms.minCoeff() > 0.0) || !std::isfinite(norms.maxCoeff());
  const double det = zero_column ? 0.0 : (f.linear * norms.cwiseInverse().asDiagonal()).determinant();
  if (!(std::abs(det) > 1e-12))
    throw std::invalid_argument(name + ": matrix is singular (its axes span no volume)");
  f.inverse_linear = f.linear.inverse();
  return f;
}

bool Frame::is_identity() const {
  return linear == Mat3::Identity() && translation == Vec3::Zero();
}

Placement::Placement(const Frame& frame, const Mat3& permutation) {
  to_canonical = permutation * frame.inverse_linear;
  canonical_offset = -(to_canonical * frame.translation);
  to_object = frame.linear * permutation.transpose();
  object_offset = frame.translation;
  identity = to_canonical == Mat3::Identity() && frame.translation == Vec3::Zero() &&
             to_object == Mat3::Identity();
}

// Rows pick the object axes that become canonical (x, y, z).
static Mat3 pick_axes(int a, int b, int c) {
  Mat3 p = Mat3::Zero();
  p(0, a) = 1.0;
  p(1, b) = 1.0;
  p(2, c) = 1.0;
  return p;
}

Mat3 axis_to_z(int axis) {
  switch (axis) {
    case 0: return pick_axes(1, 2, 0);
    case 1: return pick_axes(2, 0, 1);
    case 2: return Mat3::Identity();
  }
  throw std::invalid_argument("axis: expected 0, 1 or 2 (x, y, z), got " + std::to_string(axis));
}

Mat3 axis_to_x(int axis) {
  switch (axis) {
    case 0: return Mat3::Identity();
    case 1: return pick_axes(1, 2, 0);
    case 2: return pick_axes(2, 0, 1);
  }
  throw std::invalid_argument("axis: expected 0, 1 or 2 (x, y, z), got " + std::to_string(axis));
}

}  // namespace deformkit

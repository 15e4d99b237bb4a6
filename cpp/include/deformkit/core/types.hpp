#pragma once
// Value types shared by every deformkit header.
#include <Eigen/Dense>

#include <cstddef>

namespace deformkit {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Mat4 = Eigen::Matrix4d;

}  // namespace deformkit

#pragma once
// Placement of a deformer in object space: object = linear * local + translation.
#include "deformkit/core/types.hpp"

namespace deformkit {

struct Frame {
  Mat3 linear = Mat3::Identity();
  Mat3 inverse_linear = Mat3::Identity();
  Vec3 translation = Vec3::Zero();

  // Throws std::invalid_argument naming `argument` for a non-finite, non-affine or singular matrix.
  static Frame from_matrix(const Mat4& m, const char* argument = "frame");

  Vec3 to_local(const Vec3& p) const { return inverse_linear * (p - translation); }
  Vec3 to_object(const Vec3& q) const { return linear * q + translation; }
  bool is_identity() const;
};

// An affine map object -> canonical coordinates and back, with the canonical axes given by a
// permutation of the frame's axes.
struct Placement {
  Mat3 to_canonical = Mat3::Identity();    // M = P * A^-1
  Vec3 canonical_offset = Vec3::Zero();    // m = -P * A^-1 * t
  Mat3 to_object = Mat3::Identity();       // B = A * P^T
  Vec3 object_offset = Vec3::Zero();       // t
  bool identity = true;

  Placement() = default;
  Placement(const Frame& frame, const Mat3& permutation);

  Vec3 canonical(const Vec3& p) const { return to_canonical * p + canonical_offset; }
  Vec3 object(const Vec3& c) const { return to_object * c + object_offset; }
  // Chain rule for a map evaluated in canonical coordinates: J_obj = B * J_canon * M.
  Mat3 object_jacobian(const Mat3& canonical_jacobian) const {
    return to_object * canonical_jacobian * to_canonical;
  }
};

// Cyclic permutation that brings `axis` (0, 1, 2) to canonical z: keeps handedness.
Mat3 axis_to_z(int axis);
// Cyclic permutation that brings `axis` to canonical x (Barr's bend keeps x).
Mat3 axis_to_x(int axis);

}  // namespace deformkit

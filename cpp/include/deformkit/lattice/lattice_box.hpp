#pragma once
// The parallelepiped X0 + s S + t T + u U that places a lattice, and its coordinates (s, t, u).
#include "deformkit/core/types.hpp"

namespace deformkit {

struct LatticeBox {
  Vec3 origin = Vec3::Zero();
  Mat3 edges = Mat3::Identity();     // columns S, T, U
  Mat3 to_box = Mat3::Identity();    // rows (T x U)/((T x U).S), (S x U)/((S x U).T), (S x T)/((S x T).U)

  // Throws std::invalid_argument naming `argument` for non-finite or zero-volume edges.
  static LatticeBox from_edges(const Vec3& origin, const Mat3& edges, const char* argument = "edges");
  // A 4x4 affine matrix from lattice-local space, where the box is Blender's rest cube [-1/2, 1/2]^3.
  static LatticeBox from_matrix(const Mat4& m, const char* argument = "frame");

  // The lecture's cross-product formulas: s = (T x U).(X - X0) / ((T x U).S), and so on.
  // Written term by term: the SIMD placement (lattice/placement_kernel.cpp) gives the same bits.
  Vec3 coordinates(const Vec3& x) const {
    const Vec3 d = x - origin;
    const Mat3& a = to_box;
    return Vec3(a(0, 0) * d[0] + a(0, 1) * d[1] + a(0, 2) * d[2], a(1, 0) * d[0] + a(1, 1) * d[1] + a(1, 2) * d[2],
                a(2, 0) * d[0] + a(2, 1) * d[1] + a(2, 2) * d[2]);
  }
  Vec3 point(const Vec3& stu) const { return origin + edges * stu; }
};

}  // namespace deformkit

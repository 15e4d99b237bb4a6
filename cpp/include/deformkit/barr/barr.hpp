#pragma once
// Barr's global deformations (Barr 1984) in canonical coordinates, one point at a time.
// Twist, taper and Blender's stretch act along canonical z; the bend keeps x and bends the
// y axis toward +z (the lecture's form, with the tangent continuation outside the region).
#include "deformkit/barr/profile.hpp"
#include "deformkit/core/types.hpp"

#include <array>

namespace deformkit {

enum class BarrKind : int { Twist = 0, Taper = 1, Stretch = 2, Bend = 3 };

struct BarrOp {
  BarrKind kind = BarrKind::Twist;
  Profile profile = Profile::linear(0.0, 0.0);  // twist theta(z), taper r(z)
  double k = 0.0;       // stretch factor, or bend curvature (1/radius)
  double lo = -std::numeric_limits<double>::infinity();  // stretch z-range, bend y-region
  double hi = std::numeric_limits<double>::infinity();
  double center = 0.0;  // bend centre y0
  // Blender's lock axes, in canonical coordinates: a locked coordinate is zeroed before the
  // formula and added back afterwards (MOD_simpledeform; docs/blender/simple_deform.md, "Lock axes").
  std::array<bool, 3> locked{false, false, false};

  // Curvatures below this are the identity: the bend's limit k -> 0 (error O(k * extent^2)).
  static constexpr double kMinCurvature = 1e-20;
  bool is_identity_bend() const { return kind == BarrKind::Bend && std::abs(k) < kMinCurvature; }
};

Vec3 barr_apply(const BarrOp& op, const Vec3& c);
// Position and Jacobian d(out)/d(c) together.
void barr_apply_with_jacobian(const BarrOp& op, const Vec3& c, Vec3& out, Mat3& jacobian);
// As barr_apply_with_jacobian, with out - c in place of out: exactly zero at rest.
void barr_offset_with_jacobian(const BarrOp& op, const Vec3& c, Vec3& offset, Mat3& jacobian);

}  // namespace deformkit

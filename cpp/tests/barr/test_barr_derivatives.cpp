// The derivative paths in SIMD lanes (jacobian, transform_normals, volume_ratio) against the scalar
// formulas point by point (barr_offset_with_jacobian, cofactor, normal_direction,
// scaled_determinant): every kind, frame, lock, weight and vector tail; rows the lanes hand back
// (zero normals, collapsed planes, extreme magnitudes) as the scalar path gives them; float32
// normals against float64.
#include "test_util.hpp"

#include "core/scale_free.hpp"
#include "deformkit/barr/barr_deformer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <stdexcept>

using namespace deformkit;
using namespace deformkit::test;

namespace {

BarrOp locked(BarrOp op, bool x, bool y) {
  op.locked = {x, y, false};
  return op;
}

BarrOp op_of(BarrKind kind, const Profile& profile, double k = 0, double center = 0, double lo = -INFINITY, double hi = INFINITY) {
  BarrOp op;
  op.kind = kind;
  op.profile = profile;
  op.k = k;
  op.center = center;
  op.lo = lo;
  op.hi = hi;
  return op;
}

std::vector<std::pair<const char*, BarrOp>> ops() {
  const Profile none = Profile::linear(0.0, 0.0);
  return {
      {"twist", op_of(BarrKind::Twist, Profile::linear(0.3, 1.2, -0.4, 0.6))},
      {"twist_locked_x", locked(op_of(BarrKind::Twist, Profile::linear(0.3, 1.2, -0.4, 0.6)), true, false)},
      {"taper", op_of(BarrKind::Taper, Profile::linear(1.0, 0.5, -0.5, 0.5))},
      {"taper_locked_y", locked(op_of(BarrKind::Taper, Profile::linear(1.0, 0.5, -0.5, 0.5)), false, true)},
      {"stretch", op_of(BarrKind::Stretch, none, 0.6, 0, -0.5, 0.7)},
      {"stretch_locked", locked(op_of(BarrKind::Stretch, none, 0.6, 0, -0.5, 0.7), true, true)},
      {"bend", op_of(BarrKind::Bend, none, 0.9, 0.1, -0.4, 0.5)},
      {"bend_unbounded", op_of(BarrKind::Bend, none, -1.7, 0.0)},
  };
}

Mat3 scalar_jacobian(const BarrDeformer& d, const Vec3& p, double w) {
  Vec3 offset;
  Mat3 jc;
  barr_offset_with_jacobian(d.op(), d.placement().canonical(p), offset, jc);
  const Mat3 j = Mat3::Identity() + d.placement().to_object * (jc - Mat3::Identity()) * d.placement().to_canonical;
  return (1 - w) * Mat3::Identity() + w * j;
}

Vec3 at(const std::vector<double>& v, std::size_t i) { return Vec3(v[3 * i], v[3 * i + 1], v[3 * i + 2]); }

}  // namespace

TEST(BarrDerivatives, LanesMatchTheScalarFormulas) {
  for (const auto& [name, op] : ops())
    for (int axis = 0; axis < 3; ++axis)
      for (bool framed : {false, true})
        for (bool weighted : {false, true})
          for (std::size_t n : {1u, 5u, 8u, 13u, 1000u}) {
            const Mat3 perm = op.kind == BarrKind::Bend ? axis_to_x(axis) : axis_to_z(axis);
            BarrDeformer d(op, Placement(framed ? random_frame(50 + axis) : Frame{}, perm));
            const auto pts = random_points(n, -1.5, 1.5, 51 + unsigned(n));
            const auto nrm = random_points(n, -1.0, 1.0, 52 + unsigned(n));
            std::vector<double> w(n);
            for (std::size_t i = 0; i < n; ++i) w[i] = double((i * 37) % 11) / 10.0;
            if (weighted) d.set_weights(w);
            std::vector<double> jac(9 * n), normals(3 * n), det(n);
            d.jacobian(pts.data(), jac.data(), n);
            transform_normals(d, pts.data(), nrm.data(), normals.data(), n);
            volume_ratio(d, pts.data(), det.data(), n);
            for (std::size_t i = 0; i < n; ++i) {
              const Mat3 j = scalar_jacobian(d, at(pts, i), weighted ? w[i] : 1.0);
              for (int e = 0; e < 9; ++e) ASSERT_NEAR(jac[9 * i + e], j(e / 3, e % 3), 1e-13) << name << " row " << i;
              ASSERT_LT((at(normals, i) - normal_direction(j, at(nrm, i))).norm(), 1e-13) << name << " row " << i;
              ASSERT_NEAR(det[i], scaled_determinant(j), 1e-13 * std::max(1.0, std::abs(det[i]))) << name << " row " << i;
            }
          }
}

TEST(BarrDerivatives, RowsTheLanesHandBackAreTheScalarPathsAndLeaveTheOthersAlone) {
  // Bend about z with curvature 2 collapses the plane at z = 1/2 (det J = 1 - k z = 0 there).
  const Bend bend(2.0, 0.0, -1.0, 1.0, 0, Frame{});
  const std::vector<double> pts = {0.1, 0.2, 0.3, 0.2, 0.1, 0.5, -0.3, 0.4, -0.2, 0.0, -0.5, 0.1, 0.5, 0.5, 0.2};
  const std::vector<double> nrm = {0, 0, 1, 0, 1, 0, 0, 0, 0, 1e-300, 0, 2e-300, 3e300, -1e300, 1e300};
  const std::size_t n = 5;
  std::vector<double> out(3 * n), det(n);
  transform_normals(bend, pts.data(), nrm.data(), out.data(), n);
  volume_ratio(bend, pts.data(), det.data(), n);
  for (std::size_t i = 0; i < n; ++i) {
    const Mat3 j = scalar_jacobian(bend, at(pts, i), 1.0);
    const Vec3 want = normal_direction(j, at(nrm, i));
    ASSERT_LT((at(out, i) - want).norm(), 1e-13) << "row " << i;
    // Each row alone gives the same as within the others (a row never depends on its neighbours).
    Vec3 alone;
    transform_normals(bend, pts.data() + 3 * i, nrm.data() + 3 * i, alone.data(), 1);
    ASSERT_EQ(alone, at(out, i)) << "row " << i;
    ASSERT_NEAR(det[i], scaled_determinant(j), 1e-13) << "row " << i;
  }
  EXPECT_EQ(at(out, 2), Vec3::Zero());  // a zero normal stays zero
  EXPECT_EQ(det[1], 0.0);               // the collapsed plane
}

TEST(BarrDerivatives, Float32NormalsMatchFloat64) {
  for (const auto& [name, op] : ops()) {
    BarrDeformer d(op, Placement(random_frame(60), op.kind == BarrKind::Bend ? axis_to_x(1) : axis_to_z(1)));
    const std::size_t n = 3001;
    const auto pts = random_points(n, -1.5, 1.5, 61), nrm = random_points(n, -1.0, 1.0, 62);
    std::vector<float> p32(pts.begin(), pts.end()), n32(nrm.begin(), nrm.end()), o32(3 * n);
    std::vector<double> p64(p32.begin(), p32.end()), n64(n32.begin(), n32.end()), o64(3 * n);
    transform_normals(d, p32.data(), n32.data(), o32.data(), n);
    transform_normals(d, p64.data(), n64.data(), o64.data(), n);
    for (std::size_t i = 0; i < 3 * n; ++i) ASSERT_NEAR(o32[i], o64[i], 2e-5) << name << " entry " << i;
  }
}

TEST(BarrDerivatives, NonFiniteRowsAreStillNamed) {
  const Twist twist(Profile::linear(0.0, 1.0), 2, Frame{});
  std::vector<double> pts(30, 0.25), nrm(30, 1.0), out(30);
  nrm[13] = NAN;
  try {
    transform_normals(twist, pts.data(), nrm.data(), out.data(), 10);
    ADD_FAILURE() << "a NaN normal was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("normals: row 4", 0), 0u) << e.what();
  }
  nrm[13] = 1.0;
  pts[20] = INFINITY;
  for (int what = 0; what < 2; ++what) {
    try {
      if (what == 0) transform_normals(twist, pts.data(), nrm.data(), out.data(), 10);
      else volume_ratio(twist, pts.data(), out.data(), 10);
      ADD_FAILURE() << "an infinite point was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()).rfind("points: row 6", 0), 0u) << e.what();
    }
  }
}

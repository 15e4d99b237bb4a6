// SimpleDeform against an independent, literal transcription of Blender's per-vertex algorithm
// (MOD_simpledeform as described in docs/blender/simple_deform.md), computed in float as Blender does.
#include "test_util.hpp"

#include "barr/extent_kernel.hpp"

#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <stdexcept>
#include <string>

using namespace deformkit;
using namespace deformkit::test;

namespace {

using V3 = Eigen::Vector3f;

V3 remap(const V3& v, int axis) {  // brings the deform axis to z
  if (axis == 0) return V3(v.y(), v.z(), v.x());
  if (axis == 1) return V3(v.z(), v.x(), v.y());
  return v;
}
V3 unmap(const V3& v, int axis) {
  if (axis == 0) return V3(v.z(), v.x(), v.y());
  if (axis == 1) return V3(v.y(), v.z(), v.x());
  return v;
}

std::vector<float> blender_reference(const std::vector<float>& pts, const SimpleDeformSettings& s,
                                     const std::vector<double>& weights) {
  const std::size_t n = pts.size() / 3;
  const Eigen::Matrix3f to_origin = s.origin.inverse_linear.cast<float>();
  const V3 origin_t = s.origin.translation.cast<float>();
  const bool bend = s.mode == SimpleDeformMode::Bend;
  std::array<bool, 3> lock = s.lock;
  if (bend) lock = {false, false, false};
  else lock[s.deform_axis] = false;
  const int limit_axis = bend ? (s.deform_axis == 2 ? 0 : 2) : s.deform_axis;
  std::vector<V3> local(n);
  float lower = FLT_MAX, upper = -FLT_MAX;
  for (std::size_t i = 0; i < n; ++i) {
    local[i] = to_origin * (V3(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]) - origin_t);
    lower = std::min(lower, local[i][limit_axis]);
    upper = std::max(upper, local[i][limit_axis]);
  }
  const float l0 = lower + (upper - lower) * float(s.limit_lo), l1 = lower + (upper - lower) * float(s.limit_hi);
  const float k = float(s.factor) / std::max(FLT_EPSILON, l1 - l0);
  std::vector<float> out(pts);
  if (bend && std::abs(k) < 1e-6f) return out;
  for (std::size_t i = 0; i < n; ++i) {
    V3 co = local[i], dcut = V3::Zero();
    for (int a = 0; a < 3; ++a)
      if (lock[a]) {
        dcut[a] = co[a];
        co[a] = 0.0f;
      }
    const float c = std::clamp(co[limit_axis], l0, l1);
    dcut[limit_axis] = co[limit_axis] - c;
    co[limit_axis] = c;
    if (!bend) {
      co = remap(co, s.deform_axis);
      dcut = remap(dcut, s.deform_axis);
    }
    V3 r;
    const float x = co.x(), y = co.y(), z = co.z();
    switch (s.mode) {
      case SimpleDeformMode::Twist: {
        const float th = k * z;
        r = V3(x * std::cos(th) - y * std::sin(th), x * std::sin(th) + y * std::cos(th), z) + dcut;
        break;
      }
      case SimpleDeformMode::Taper:
        r = V3(x * (1 + k * z), y * (1 + k * z), z) + dcut;
        break;
      case SimpleDeformMode::Stretch: {
        const float sc = z * z * k - k + 1.0f;
        r = V3(x * sc, y * sc, z * (1 + k)) + dcut;
        break;
      }
      case SimpleDeformMode::Bend: {
        const float th = s.deform_axis == 2 ? k * x : k * z, sn = std::sin(th), cs = std::cos(th);
        if (s.deform_axis == 0)
          r = V3(x + dcut.x(), y * cs + (1 - cs) / k + sn * dcut.z(), -(y - 1 / k) * sn + cs * dcut.z());
        else if (s.deform_axis == 1)
          r = V3(x * cs + (1 - cs) / k + sn * dcut.z(), y + dcut.y(), -(x - 1 / k) * sn + cs * dcut.z());
        else
          r = V3(-(y - 1 / k) * sn + cs * dcut.x(), y * cs + (1 - cs) / k + sn * dcut.x(), z + dcut.z());
        break;
      }
    }
    if (!bend) r = unmap(r, s.deform_axis);
    const float w = weights.empty() ? 1.0f : float(weights[i]);
    const V3 blended = local[i] + w * (r - local[i]);
    const V3 obj = s.origin.linear.cast<float>() * blended + origin_t;
    for (int a = 0; a < 3; ++a) out[3 * i + a] = obj[a];
  }
  return out;
}

std::vector<float> box_points(std::size_t n, unsigned seed) {
  const auto p = random_points(n, -1.0, 1.0, seed);
  std::vector<float> out(3 * n);
  for (std::size_t i = 0; i < n; ++i) {  // an off-centre, non-cubic block
    out[3 * i] = float(0.3 + 0.8 * p[3 * i]);
    out[3 * i + 1] = float(-0.2 + 1.4 * p[3 * i + 1]);
    out[3 * i + 2] = float(0.5 + 1.1 * p[3 * i + 2]);
  }
  return out;
}

void expect_matches_blender(const SimpleDeformSettings& s, const std::vector<double>& weights, const char* what) {
  const auto pts = box_points(2000, 5);
  const auto ref = blender_reference(pts, s, weights);
  SimpleDeform d(s);
  if (!weights.empty()) d.set_weights(weights);
  std::vector<float> out(pts.size());
  d.deform(pts.data(), out.data(), pts.size() / 3);
  double worst = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) worst = std::max(worst, double(std::abs(out[i] - ref[i])));
  EXPECT_LT(worst, 2e-5) << what << " mode " << int(s.mode) << " axis " << s.deform_axis;
}

}  // namespace

TEST(SimpleDeform, AllModesAndAxesMatchBlendersFormulas) {
  for (int mode = 0; mode < 4; ++mode)
    for (int axis = 0; axis < 3; ++axis)
      for (double factor : {0.785398, -1.3, 0.4}) {
        SimpleDeformSettings s;
        s.mode = SimpleDeformMode(mode);
        s.deform_axis = axis;
        s.factor = factor;
        expect_matches_blender(s, {}, "defaults");
        s.limit_lo = 0.2;
        s.limit_hi = 0.7;
        expect_matches_blender(s, {}, "limits");
        s.origin = random_frame(3 + axis);
        expect_matches_blender(s, {}, "origin");
      }
}

TEST(SimpleDeform, LocksMatchBlendersFormulas) {
  for (int mode : {0, 2, 3})
    for (int axis = 0; axis < 3; ++axis)
      for (int mask = 1; mask < 8; ++mask) {
        SimpleDeformSettings s;
        s.mode = SimpleDeformMode(mode);
        s.deform_axis = axis;
        s.lock = {bool(mask & 1), bool(mask & 2), bool(mask & 4)};
        s.limit_lo = 0.1;
        expect_matches_blender(s, {}, "locks");
      }
}

TEST(SimpleDeform, WeightsMatchBlendersLerp) {
  std::vector<double> w(2000);
  for (std::size_t i = 0; i < w.size(); ++i) w[i] = double(i % 11) / 10.0;
  for (int mode = 0; mode < 4; ++mode) {
    SimpleDeformSettings s;
    s.mode = SimpleDeformMode(mode);
    s.deform_axis = 1;
    s.origin = random_frame(8);
    expect_matches_blender(s, w, "weights");
  }
}

TEST(SimpleDeform, DegenerateLimitsAndTinyBendAreHandledLikeBlender) {
  SimpleDeformSettings s;
  s.limit_lo = s.limit_hi = 0.5;  // zero span: k = amount / FLT_EPSILON, as in Blender
  for (int mode = 0; mode < 4; ++mode) {
    s.mode = SimpleDeformMode(mode);
    s.factor = 1e-9;
    expect_matches_blender(s, {}, "zero span");
  }
  s.mode = SimpleDeformMode::Bend;
  s.limit_lo = 0.0;
  s.limit_hi = 1.0;
  s.factor = 1e-7;  // |k| < 1e-6: Blender leaves the mesh alone
  const auto pts = box_points(100, 9);
  std::vector<float> out(pts.size());
  SimpleDeform(s).deform(pts.data(), out.data(), 100);
  EXPECT_EQ(out, pts);
}

TEST(SimpleDeform, JacobianMatchesFiniteDifferencesWithBoundsHeld) {
  SimpleDeformSettings s;
  s.mode = SimpleDeformMode::Bend;
  s.deform_axis = 2;
  s.limit_lo = 0.25;
  s.limit_hi = 0.8;
  s.origin = random_frame(12);
  const SimpleDeform d(s);
  const auto pts = random_points(64, -1.0, 1.0, 13);
  const auto barr = d.resolve(pts.data(), 64);  // the bounds of the whole set
  std::vector<double> jac(9 * 64);
  d.jacobian(pts.data(), jac.data(), 64);
  for (std::size_t i = 0; i < 64; ++i) {
    const Vec3 p(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]);
    const Mat3 fd = finite_difference_jacobian(*barr, p);
    for (int e = 0; e < 9; ++e) EXPECT_NEAR(jac[9 * i + e], fd(e / 3, e % 3), 2e-6);
  }
}

TEST(SimpleDeform, BadSettingsAreRejected) {
  SimpleDeformSettings s;
  s.limit_lo = 0.8;
  s.limit_hi = 0.2;
  EXPECT_THROW(SimpleDeform{s}, std::invalid_argument);
  s.limit_lo = -0.1;
  s.limit_hi = 1.0;
  EXPECT_THROW(SimpleDeform{s}, std::invalid_argument);
  s.limit_lo = 0.0;
  s.factor = NAN;
  EXPECT_THROW(SimpleDeform{s}, std::invalid_argument);
  s.factor = 1.0;
  s.deform_axis = 3;
  EXPECT_THROW(SimpleDeform{s}, std::invalid_argument);
}

TEST(SimpleDeform, ExtentKernelMatchesAScalarPass) {
  const double row[3] = {0.3, -1.2, 0.7};
  for (std::size_t n : {1u, 2u, 5u, 8u, 15u, 16u, 17u, 31u, 33u, 1001u}) {
    auto pts = random_points(n, -2.0, 2.0, 100 + n);
    double lo = INFINITY, hi = -INFINITY;
    for (std::size_t i = 0; i < n; ++i) {
      const double v = row[0] * pts[3 * i] + row[1] * pts[3 * i + 1] + row[2] * pts[3 * i + 2] - 0.25;
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
    const Extent e = coordinate_extent(row, 0.25, pts.data(), n);
    EXPECT_TRUE(e.finite);
    EXPECT_NEAR(e.lo, lo, 1e-14) << n;
    EXPECT_NEAR(e.hi, hi, 1e-14) << n;
    std::vector<float> p32(pts.begin(), pts.end());
    const Extent f = coordinate_extent(row, 0.25, p32.data(), n);
    EXPECT_NEAR(f.lo, lo, 1e-5);
    EXPECT_NEAR(f.hi, hi, 1e-5);
    pts[3 * (n - 1) + 2] = NAN;  // in the tail or in a full vector, depending on n
    EXPECT_FALSE(coordinate_extent(row, 0.25, pts.data(), n).finite) << n;
  }
}

// bind() fixes the extent: the bound map on any chunks equals deform() on all the points, bit for
// bit, while deform() on a chunk alone measures that chunk.
TEST(SimpleDeform, BoundMapDoesNotDependOnChunking) {
  const std::size_t n = 40000, split = 13000;
  const auto pts = random_points(n, -1.0, 2.0, 21);
  for (SimpleDeformMode mode : {SimpleDeformMode::Twist, SimpleDeformMode::Bend, SimpleDeformMode::Taper,
                                SimpleDeformMode::Stretch}) {
    SimpleDeformSettings s;
    s.mode = mode;
    s.factor = 0.9;
    s.deform_axis = 1;
    s.origin = random_frame(5);
    s.limit_lo = 0.15;
    s.limit_hi = 0.85;
    SimpleDeform d(s);
    std::vector<double> w(n);
    for (std::size_t i = 0; i < n; ++i) w[i] = double(i % 5) / 4.0;
    d.set_weights(w);
    std::vector<double> whole(3 * n), chunked(3 * n), alone(3 * split);
    d.deform(pts.data(), whole.data(), n);
    const auto map = d.bind(pts.data(), n);
    EXPECT_EQ(map->weights(), d.weights());
    // The weights count the bound points: chunks go through the weightless map and are blended
    // as the whole was (weights[i] belongs to point i).
    auto plain = std::make_shared<BarrDeformer>(map->op(), map->placement());
    plain->set_weights(std::vector<double>(w.begin(), w.begin() + split));
    plain->deform(pts.data(), chunked.data(), split);
    plain->set_weights(std::vector<double>(w.begin() + split, w.end()));
    plain->deform(pts.data() + 3 * split, chunked.data() + 3 * split, n - split);
    EXPECT_EQ(chunked, whole) << int(mode);
    std::vector<double> bound(3 * n);
    map->deform(pts.data(), bound.data(), n);
    EXPECT_EQ(bound, whole) << int(mode);
    SimpleDeform first(s);
    first.set_weights(std::vector<double>(w.begin(), w.begin() + split));
    first.deform(pts.data(), alone.data(), split);
    EXPECT_NE(alone, std::vector<double>(whole.begin(), whole.begin() + 3 * split)) << int(mode);
  }
}

TEST(SimpleDeform, BindNamesItsArguments) {
  SimpleDeform d{SimpleDeformSettings{}};
  std::vector<double> pts = {0, 0, 0, 1, 1, 1, 2, 2, 2};
  pts[4] = std::nan("");
  try {
    d.bind(pts.data(), 3);
    ADD_FAILURE() << "bind accepted a non-finite row";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("points: row 1 is not finite", 0), 0u) << e.what();
  }
  d.set_weights({0.5, 0.5});
  pts[4] = 1.0;
  try {
    d.bind(pts.data(), 3);
    ADD_FAILURE() << "bind accepted two weights for three points";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "weights: has 2 entries but points has 3 rows");
  }
}

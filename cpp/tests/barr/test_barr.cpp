#include "test_util.hpp"

#include "barr/barr_kernels.hpp"
#include "core/scale_free.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <stdexcept>

using namespace deformkit;
using namespace deformkit::test;

namespace {

struct Case {
  const char* name;
  std::function<std::shared_ptr<BarrDeformer>(int axis, const Frame&)> make;
};

std::vector<Case> cases() {
  const Profile spline = Profile::spline({-1.0, -0.3, 0.2, 0.9}, {0.5, -0.4, 0.9, 1.4});
  const Profile radius = Profile::spline({-1.0, 0.0, 1.0}, {0.6, 1.2, 0.9});
  return {
      {"twist_linear", [](int a, const Frame& f) { return std::make_shared<Twist>(Profile::linear(0.3, 1.2, -0.4, 0.6), a, f); }},
      {"twist_spline", [=](int a, const Frame& f) { return std::make_shared<Twist>(spline, a, f); }},
      {"taper_linear", [](int a, const Frame& f) { return std::make_shared<Taper>(Profile::linear(1.0, 0.5, -0.5, 0.5), a, f); }},
      {"taper_spline", [=](int a, const Frame& f) { return std::make_shared<Taper>(radius, a, f); }},
      {"stretch", [](int a, const Frame& f) { return std::make_shared<Stretch>(0.6, -0.5, 0.7, a, f); }},
      {"bend", [](int a, const Frame& f) { return std::make_shared<Bend>(0.9, 0.1, -0.4, 0.5, a, f); }},
      {"bend_unbounded", [](int a, const Frame& f) {
         return std::make_shared<Bend>(-1.7, 0.0, -INFINITY, INFINITY, a, f);
       }},
  };
}

}  // namespace

TEST(Barr, JacobianMatchesFiniteDifferences) {
  for (const auto& c : cases())
    for (int axis = 0; axis < 3; ++axis)
      for (unsigned seed : {1u, 2u}) {
        const auto d = c.make(axis, seed == 1 ? Frame{} : random_frame(seed));
        const auto pts = random_points(200, -1.0, 1.0, seed + 10 * axis);
        for (std::size_t i = 0; i < 200; ++i) {
          const Vec3 p(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]);
          const Mat3 err = jacobian_one(*d, p) - finite_difference_jacobian(*d, p);
          ASSERT_LT(err.cwiseAbs().maxCoeff(), 2e-6) << c.name << " axis " << axis << " at " << p.transpose();
        }
      }
}

TEST(Barr, CofactorCarriesCrossProducts) {
  // (J a) x (J b) = cof(J) (a x b): the normal transform N' = det(J) J^-T N (lecture).
  for (const auto& c : cases()) {
    const auto d = c.make(1, random_frame(7));
    const auto pts = random_points(100, -1.0, 1.0, 3), dirs = random_points(200, -1.0, 1.0, 4);
    for (std::size_t i = 0; i < 100; ++i) {
      const Mat3 j = jacobian_one(*d, Vec3(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]));
      const Vec3 a(dirs[6 * i], dirs[6 * i + 1], dirs[6 * i + 2]), b(dirs[6 * i + 3], dirs[6 * i + 4], dirs[6 * i + 5]);
      EXPECT_LT(((j * a).cross(j * b) - cofactor(j) * a.cross(b)).norm(), 1e-12) << c.name;
    }
  }
}

TEST(Barr, BendNormalMatrixIsTheCorrectCofactor) {
  // docs/math/barr.md, "Bend": cof(J) = [[1-kz, 0, 0], [0, C, -(1-kz) S], [0, S, (1-kz) C]] inside the region.
  const double k = 0.8;
  const Bend bend(k, 0.2, -1.0, 1.0, 0, Frame{});
  for (const Vec3 p : {Vec3(0.3, 0.5, 0.4), Vec3(-0.2, -0.7, -0.9), Vec3(0.0, 0.9, 0.1)}) {
    const double th = k * (p.y() - 0.2), a = 1.0 - k * p.z();
    Mat3 expected;
    expected << a, 0, 0, 0, std::cos(th), -a * std::sin(th), 0, std::sin(th), a * std::cos(th);
    EXPECT_LT((cofactor(jacobian_one(bend, p)) - expected).cwiseAbs().maxCoeff(), 1e-14);
  }
}

TEST(Barr, VolumeRatios) {
  const auto pts = random_points(100, -1.0, 1.0, 5);
  const Twist twist(Profile::linear(0.0, 2.0), 2, Frame{});
  const Taper taper(Profile::linear(1.0, 0.4), 2, Frame{});
  const Bend bend(0.7, 0.0, -0.5, 0.5, 0, Frame{});
  for (std::size_t i = 0; i < 100; ++i) {
    const Vec3 p(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]);
    EXPECT_NEAR(jacobian_one(twist, p).determinant(), 1.0, 1e-13);
    const double r = 1.0 + 0.4 * p.z();
    EXPECT_NEAR(jacobian_one(taper, p).determinant(), r * r, 1e-13);
    const bool inside = std::abs(p.y()) <= 0.5;
    EXPECT_NEAR(jacobian_one(bend, p).determinant(), inside ? 1.0 - 0.7 * p.z() : 1.0, 1e-13);
  }
}

TEST(Barr, BendAgreesWithTheLectureFormula) {
  const double k = 1.3, y0 = 0.15, lo = -0.4, hi = 0.6;
  const Bend bend(k, y0, lo, hi, 0, Frame{});
  const auto pts = random_points(300, -1.0, 1.0, 9);
  for (std::size_t i = 0; i < 300; ++i) {
    const Vec3 p(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]);
    const double yh = std::clamp(p.y(), lo, hi), th = k * (yh - y0), s = std::sin(th), c = std::cos(th);
    const Vec3 expected(p.x(), -s * (p.z() - 1 / k) + y0 + c * (p.y() - yh), c * (p.z() - 1 / k) + 1 / k + s * (p.y() - yh));
    EXPECT_LT((deform_one(bend, p) - expected).norm(), 1e-13);
  }
}

TEST(Barr, BendIsContinuousAcrossRegionEnds) {
  const Bend bend(1.1, 0.0, -0.3, 0.4, 0, Frame{});
  for (double end : {-0.3, 0.4})
    for (double z : {-0.5, 0.0, 0.6}) {
      const double e = 1e-9;
      EXPECT_LT((deform_one(bend, Vec3(0.2, end - e, z)) - deform_one(bend, Vec3(0.2, end + e, z))).norm(), 1e-8);
      // dF/dx and dF/dz are continuous; dF/dy jumps by k z (the crease Barr's bend has for z != 0).
      const Mat3 below = jacobian_one(bend, Vec3(0.2, end - 1e-7, z)), above = jacobian_one(bend, Vec3(0.2, end + 1e-7, z));
      EXPECT_LT((below.col(0) - above.col(0)).norm(), 1e-6);
      EXPECT_LT((below.col(2) - above.col(2)).norm(), 1e-6);
      EXPECT_NEAR((below.col(1) - above.col(1)).norm(), 1.1 * std::abs(z), 1e-6);
    }
}

TEST(Barr, BendTendsToIdentityAsCurvatureVanishes) {
  const auto pts = random_points(100, -2.0, 2.0, 11);
  double previous = INFINITY;
  for (double k : {1e-1, 1e-3, 1e-6, 1e-12, 1e-30, 0.0}) {
    const Bend bend(k, 0.3, -1.0, 1.5, 0, Frame{});
    double worst = 0;
    for (std::size_t i = 0; i < 100; ++i) {
      const Vec3 p(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]);
      const Vec3 q = deform_one(bend, p);
      ASSERT_TRUE(q.allFinite()) << "k = " << k;
      worst = std::max(worst, (q - p).norm());
      ASSERT_TRUE(jacobian_one(bend, p).allFinite());
    }
    // |F(x) - x| = O(k |x|^2): shrinks with k, never blows up.
    EXPECT_LE(worst, 20.0 * k + 1e-15) << "k = " << k;
    EXPECT_LE(worst, previous);
    previous = worst;
  }
}

TEST(Barr, TwistPreservesAxisAndRadius) {
  const Twist twist(Profile::linear(0.0, 3.0), 2, Frame{});
  const auto pts = random_points(100, -1.0, 1.0, 12);
  for (std::size_t i = 0; i < 100; ++i) {
    const Vec3 p(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]), q = deform_one(twist, p);
    EXPECT_NEAR(q.z(), p.z(), 1e-15);
    EXPECT_NEAR(q.head<2>().norm(), p.head<2>().norm(), 1e-14);
    const double turned = std::atan2(p.x() * q.y() - p.y() * q.x(), p.head<2>().dot(q.head<2>()));
    EXPECT_NEAR(turned, 3.0 * p.z(), 1e-12);
  }
}

TEST(Barr, FrameConjugatesTheCanonicalMap) {
  // F_frame(x) = A F(A^-1 (x - t)) + t for a frame (A, t), axis z.
  const Frame frame = random_frame(21);
  const Twist placed(Profile::linear(0.1, 0.9), 2, frame), canonical(Profile::linear(0.1, 0.9), 2, Frame{});
  const auto pts = random_points(50, -1.0, 1.0, 22);
  for (std::size_t i = 0; i < 50; ++i) {
    const Vec3 p(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]);
    EXPECT_LT((deform_one(placed, p) - frame.to_object(deform_one(canonical, frame.to_local(p)))).norm(), 1e-13);
  }
}

TEST(Barr, SimdKernelsMatchScalarDouble) {
  // Every kernel, every vector tail length, float64 against the scalar path.
  for (const auto& c : cases())
    for (int axis = 0; axis < 3; ++axis)
      for (std::size_t n : {1u, 3u, 7u, 8u, 9u, 17u, 33u, 1000u}) {
        const auto d = c.make(axis, random_frame(30 + axis));
        const auto pts = random_points(n, -1.5, 1.5, 31 + n);
        std::vector<double> out(3 * n);
        d->deform(pts.data(), out.data(), n);
        for (std::size_t i = 0; i < n; ++i) {
          const Vec3 p(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]);
          const Vec3 ref = d->placement().object(barr_apply(d->op(), d->placement().canonical(p)));
          ASSERT_LT((Vec3(out[3 * i], out[3 * i + 1], out[3 * i + 2]) - ref).norm(), 1e-12) << c.name << " n=" << n;
        }
      }
}

TEST(Barr, Float32MatchesFloat64) {
  for (const auto& c : cases()) {
    const auto d = c.make(2, random_frame(40));
    const std::size_t n = 5000;
    const auto pts = random_points(n, -1.5, 1.5, 41);
    std::vector<float> in32(pts.begin(), pts.end()), out32(3 * n);
    std::vector<double> in64(in32.begin(), in32.end()), out64(3 * n);
    d->deform(in32.data(), out32.data(), n);
    d->deform(in64.data(), out64.data(), n);
    for (std::size_t i = 0; i < 3 * n; ++i) ASSERT_NEAR(out32[i], out64[i], 2e-6) << c.name;
  }
}

TEST(Barr, HugeAnglesFallBackToExactSinCos) {
  const Twist twist(Profile::linear(0.0, 1e5), 2, Frame{});
  std::vector<double> pts{1.0, 0.0, 0.7, 0.0, 1.0, -0.9, 0.5, 0.5, 0.123}, out(9);
  twist.deform(pts.data(), out.data(), 3);
  for (int i = 0; i < 3; ++i) {
    const double th = 1e5 * pts[3 * i + 2];
    EXPECT_NEAR(out[3 * i], pts[3 * i] * std::cos(th) - pts[3 * i + 1] * std::sin(th), 1e-12);
    EXPECT_NEAR(out[3 * i + 1], pts[3 * i] * std::sin(th) + pts[3 * i + 1] * std::cos(th), 1e-12);
  }
}

TEST(Barr, InPlaceEqualsOutOfPlace) {
  const Bend bend(0.8, 0.0, -0.5, 0.5, 1, random_frame(50));
  auto pts = random_points(777, -1.0, 1.0, 51);
  std::vector<double> out(pts.size());
  bend.deform(pts.data(), out.data(), 777);
  bend.deform(pts.data(), pts.data(), 777);
  EXPECT_EQ(pts, out);
}

TEST(Barr, NonFiniteInputIsReported) {
  for (const auto& c : cases()) {
    const auto d = c.make(0, Frame{});
    auto pts = random_points(100, -1.0, 1.0, 60);
    pts[3 * 57 + 1] = NAN;
    std::vector<double> out(pts.size());
    try {
      d->deform(pts.data(), out.data(), 100);
      FAIL() << c.name << ": no exception";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("row 57"), std::string::npos) << e.what();
    }
    std::vector<float> p32(pts.begin(), pts.end()), o32(p32.size());
    p32[3 * 99] = INFINITY;
    p32[3 * 57 + 1] = 0.0f;
    EXPECT_THROW(d->deform(p32.data(), o32.data(), 100), std::invalid_argument) << c.name;
  }
}

TEST(Barr, WeightsBlendPositionsAndJacobians) {
  auto twist = std::make_shared<Twist>(Profile::linear(0.0, 1.5), 2, Frame{});
  const Twist plain(Profile::linear(0.0, 1.5), 2, Frame{});
  const auto pts = random_points(4, -1.0, 1.0, 70);
  twist->set_weights({0.0, 0.25, 1.0, 0.6});
  std::vector<double> out(12), disp(12);
  twist->deform(pts.data(), out.data(), 4);
  twist->displacement(pts.data(), disp.data(), 4);  // w (F(x) - x), the lanes' offset scaled in one pass
  for (int i = 0; i < 4; ++i) {
    const Vec3 p(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]);
    const double w = twist->weights()[i];
    const Vec3 expected = p + w * (deform_one(plain, p) - p);
    EXPECT_LT((Vec3(out[3 * i], out[3 * i + 1], out[3 * i + 2]) - expected).norm(), 1e-14);
    EXPECT_LT((Vec3(disp[3 * i], disp[3 * i + 1], disp[3 * i + 2]) - (expected - p)).norm(), 1e-14);
    Twist single(Profile::linear(0.0, 1.5), 2, Frame{});
    single.set_weights({w});
    EXPECT_LT((jacobian_one(single, p) - finite_difference_jacobian(single, p)).cwiseAbs().maxCoeff(), 1e-7);
  }
  std::vector<double> three(9);
  EXPECT_THROW(twist->deform(pts.data(), three.data(), 3), std::invalid_argument);
}

TEST(Frame, SingularAndNonAffineMatricesAreRejected) {
  Mat4 flat = Mat4::Identity();
  flat(2, 2) = 0.0;
  EXPECT_THROW(Frame::from_matrix(flat), std::invalid_argument);
  Mat4 projective = Mat4::Identity();
  projective(3, 0) = 0.5;
  EXPECT_THROW(Frame::from_matrix(projective), std::invalid_argument);
  Mat4 nan = Mat4::Identity();
  nan(0, 3) = NAN;
  EXPECT_THROW(Frame::from_matrix(nan), std::invalid_argument);
  Mat4 tiny = Mat4::Identity() * 1e-3;
  tiny(3, 3) = 1.0;
  EXPECT_NO_THROW(Frame::from_matrix(tiny));
}

template <class T>
void expect_identity_at_rest(const BarrDeformer& d, const char* name) {
  for (std::size_t n : {1u, 7u, 16u, 1001u}) {
    const auto pts = random_points(n, -1.5, 1.5, unsigned(50 + n));
    const std::vector<T> in(pts.begin(), pts.end());
    std::vector<T> out(3 * n);
    d.deform(in.data(), out.data(), n);
    for (std::size_t i = 0; i < 3 * n; ++i) ASSERT_EQ(out[i], in[i]) << name << " n=" << n << " entry " << i;
  }
}

TEST(Barr, AtRestEveryKernelIsTheIdentityToTheBit) {
  // Angle 0, radius 1, factor 0, curvature 0: SIMD (linear laws) and scalar (splines) kernels, float32
  // and float64, any axis and frame, give back the input exactly, and J = I exactly.
  const Profile zero = Profile::spline({-1.0, 0.0, 1.0}, {0.0, 0.0, 0.0}), one = Profile::spline({-1.0, 1.0}, {1.0, 1.0});
  for (int axis = 0; axis < 3; ++axis)
    for (const Frame& f : {Frame{}, random_frame(60 + axis)}) {
      const std::vector<std::pair<const char*, std::shared_ptr<BarrDeformer>>> rest = {
          {"twist", std::make_shared<Twist>(Profile::linear(0.0, 0.0), axis, f)},
          {"twist limited", std::make_shared<Twist>(Profile::linear(0.0, 0.0, -0.5, 0.5), axis, f)},
          {"twist spline", std::make_shared<Twist>(zero, axis, f)},
          {"taper", std::make_shared<Taper>(Profile::linear(1.0, 0.0), axis, f)},
          {"taper spline", std::make_shared<Taper>(one, axis, f)},
          {"stretch", std::make_shared<Stretch>(0.0, -0.5, 0.7, axis, f)},
          {"bend", std::make_shared<Bend>(0.0, 0.1, -0.4, 0.5, axis, f)},
      };
      for (const auto& [name, d] : rest) {
        expect_identity_at_rest<float>(*d, name);
        expect_identity_at_rest<double>(*d, name);
        const auto pts = random_points(20, -1.5, 1.5, 70);
        std::vector<double> jac(9 * 20);
        d->jacobian(pts.data(), jac.data(), 20);
        for (std::size_t e = 0; e < jac.size(); ++e) ASSERT_EQ(jac[e], (e % 9) % 4 == 0 ? 1.0 : 0.0) << name;
      }
    }
}

TEST(ScaleFree, NormalsAndDeterminantsOfExtremeJacobians) {
  // J = diag(a, b, c): cof(J) = diag(bc, ac, ab) and det J = abc, whose products leave the double range.
  const Mat3 big = Vec3(1e300, 1e300, 1e-300).asDiagonal();  // cof = diag(1, 1, 1e600)
  EXPECT_LT((normal_direction(big, Vec3(1, 1, 1)) - Vec3(0, 0, 1)).norm(), 1e-15);
  EXPECT_LT((normal_direction(big, Vec3(1, 0, 0)) - Vec3(1, 0, 0)).norm(), 1e-15);
  const Mat3 flat = Vec3(1e-300, 1.0, 1.0).asDiagonal();  // cof = diag(1, 1e-300, 1e-300)
  EXPECT_LT((normal_direction(flat, Vec3(1e-200, 0, 1e-200)) - Vec3(1, 0, 0)).norm(), 1e-15);
  EXPECT_LT((normal_direction(flat, Vec3(1e-200, 1e-200, 0)).normalized() - Vec3(1, 1e-300, 0).normalized()).norm(), 1e-15);
  EXPECT_DOUBLE_EQ(scaled_determinant(Vec3(1e200, 1e200, 1e-300).asDiagonal()), 1e100);
  EXPECT_DOUBLE_EQ(scaled_determinant(Vec3(1e-200, 1e-200, 1e300).asDiagonal()), 1e-100);
  EXPECT_TRUE(std::isinf(scaled_determinant(Vec3(1e200, 1e200, 1e-90).asDiagonal())));
  // A rotation times those scales keeps the direction law: cof(R D) n = R cof(D) n for a rotation R.
  const Mat3 r = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  EXPECT_LT((normal_direction(r * big, Vec3(1, 1, 1)) - r.col(2)).norm(), 1e-15);
  EXPECT_EQ(normal_direction(big, Vec3::Zero()), Vec3::Zero());
  EXPECT_EQ(normalized_or_zero(Vec3(5e-324, 0, -0.0)), Vec3(1, 0, 0));
}

TEST(Simd, ReportsATarget) { EXPECT_STRNE(simd_target(), ""); }

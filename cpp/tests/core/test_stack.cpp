#include "test_util.hpp"

#include <gtest/gtest.h>

using namespace deformkit;
using namespace deformkit::test;

TEST(Stack, ComposesInOrder) {
  auto twist = std::make_shared<Twist>(Profile::linear(0.0, 1.2), 2, Frame{});
  auto bend = std::make_shared<Bend>(0.8, 0.0, -0.5, 0.5, 0, random_frame(3));
  const Stack stack({twist, bend});
  const auto pts = random_points(100, -1.0, 1.0, 1);
  for (std::size_t i = 0; i < 100; ++i) {
    const Vec3 p(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]);
    EXPECT_LT((deform_one(stack, p) - deform_one(*bend, deform_one(*twist, p))).norm(), 1e-14);
  }
}

TEST(Stack, ChainRuleMatchesFiniteDifferences) {
  SimpleDeformSettings s;
  s.mode = SimpleDeformMode::Taper;
  s.factor = 0.5;
  const Stack stack({std::make_shared<Twist>(Profile::spline({-1, 0, 1}, {0.0, 0.8, 0.3}), 0, random_frame(5)),
                     std::make_shared<Bend>(1.1, 0.2, -0.6, 0.4, 1, Frame{}),
                     std::make_shared<Stretch>(0.3, -0.8, 0.8, 2, random_frame(6))});
  const auto pts = random_points(200, -1.0, 1.0, 2);
  for (std::size_t i = 0; i < 200; ++i) {
    const Vec3 p(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]);
    EXPECT_LT((jacobian_one(stack, p) - finite_difference_jacobian(stack, p)).cwiseAbs().maxCoeff(), 5e-6);
  }
}

TEST(Stack, EmptyStackIsTheIdentity) {
  const Stack empty({});
  const auto pts = random_points(10, -1.0, 1.0, 3);
  std::vector<double> out(30);
  empty.deform(pts.data(), out.data(), 10);
  EXPECT_EQ(out, pts);
  EXPECT_TRUE(jacobian_one(empty, Vec3(0.1, 0.2, 0.3)).isIdentity());
}

TEST(Stack, NullEntryIsRejected) { EXPECT_THROW(Stack({nullptr}), std::invalid_argument); }

TEST(Normals, TransformedNormalsAreUnitAndOrthogonalToTransformedTangents) {
  const Bend bend(0.9, 0.0, -0.5, 0.5, 2, random_frame(9));
  const auto pts = random_points(100, -1.0, 1.0, 10), tangents = random_points(100, -1.0, 1.0, 11);
  std::vector<double> normals(300), out(300), jac(900);
  for (std::size_t i = 0; i < 100; ++i) {  // a normal orthogonal to a tangent t
    const Vec3 t(tangents[3 * i], tangents[3 * i + 1], tangents[3 * i + 2]);
    const Vec3 nrm = t.cross(Vec3(0.3, -0.5, 0.8)).normalized();
    for (int a = 0; a < 3; ++a) normals[3 * i + a] = nrm[a];
  }
  transform_normals(bend, pts.data(), normals.data(), out.data(), 100);
  bend.jacobian(pts.data(), jac.data(), 100);
  for (std::size_t i = 0; i < 100; ++i) {
    const Vec3 t(tangents[3 * i], tangents[3 * i + 1], tangents[3 * i + 2]);
    const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> j(&jac[9 * i]);
    const Vec3 n(out[3 * i], out[3 * i + 1], out[3 * i + 2]);
    EXPECT_NEAR(n.norm(), 1.0, 1e-14);
    EXPECT_NEAR(n.dot(j * t), 0.0, 1e-12);
  }
}

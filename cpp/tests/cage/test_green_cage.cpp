// GreenCage on the cage seam: what the free Green coordinates give (test_green_coordinates.cpp),
// through the deformer: similarities of the cage reproduced inside and outside it, s = 1 differing
// under a scaling, exact Jacobians, the bound path equal to deform, and bindings shared by both modes.
#include "cage/cage_shapes.hpp"
#include "deformkit/cage/green_cage.hpp"
#include "deformkit/cage/mean_value_cage.hpp"
#include "test_util.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>

using namespace deformkit;
using namespace deformkit::test;

namespace {

GreenCage make(const PolygonSoup& s, bool stretch = true) { return GreenCage(CageMesh(polygon_mesh(s)), stretch); }

// A similarity: scale s, a rotation about a tilted axis, a translation.
Mat3 rotation() {
  return Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
}
Vec3 similar(const Vec3& x, double s) { return s * (rotation() * x) + Vec3(0.3, -1.0, 2.0); }

std::vector<double> mapped(const std::vector<double>& p, double s) {
  std::vector<double> out(p.size());
  for (std::size_t i = 0; i < p.size(); i += 3) {
    const Vec3 y = similar(Vec3(p[i], p[i + 1], p[i + 2]), s);
    for (int c = 0; c < 3; ++c) out[i + c] = y[c];
  }
  return out;
}

std::vector<double> sample_points() {
  // Inside the L-shaped prism, near its faces, and outside it (the exterior extension; the last
  // point's foot lies near a diagonal of the top hexagon's split, where the blend's weights turn).
  return {0.5, 0.5, 0.5, 1.5, 0.5, 0.2, 0.5, 1.5, 0.8, 0.999, 0.5, 0.5, 1e-6, 0.3, 0.7,
          -0.4, 0.5, 0.5, 2.5, 0.3, 0.4, 1.3, 1.6, 0.5, 0.5, 0.5, 1.7};
}

}  // namespace

TEST(GreenCage, ReproducesSimilaritiesInsideAndOutside) {
  for (double s : {1.0, 2.5, 0.4}) {
    GreenCage g = make(l_prism());
    g.set_cage_points(mapped(g.rest_cage_points(), s));
    const std::vector<double> x = sample_points();
    std::vector<double> y(x.size());
    g.deform(x.data(), y.data(), x.size() / 3);
    for (std::size_t i = 0; i < x.size(); i += 3) {
      const Vec3 want = similar(Vec3(x[i], x[i + 1], x[i + 2]), s);
      EXPECT_LT((Vec3(y[i], y[i + 1], y[i + 2]) - want).norm(), 1e-9 * s) << "point " << i / 3 << " scale " << s;
    }
  }
}

TEST(GreenCage, WithoutStretchAScalingIsNotReproduced) {
  GreenCage with = make(l_prism()), without = make(l_prism(), false);
  for (GreenCage* g : {&with, &without}) g->set_cage_points(mapped(g->rest_cage_points(), 2.0));
  const double x[3] = {0.5, 0.5, 0.5};
  double a[3], b[3];
  with.deform(x, a, 1);
  without.deform(x, b, 1);
  EXPECT_GT((Vec3(a[0], a[1], a[2]) - Vec3(b[0], b[1], b[2])).norm(), 1e-3);
}

TEST(GreenCage, JacobianMatchesCentralDifferences) {
  GreenCage g = make(l_prism());
  std::vector<double> moved = g.rest_cage_points();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.15, 0.15);
  for (double& v : moved) v += u(rng);
  g.set_cage_points(moved);
  // With the point above the top hexagon, near a diagonal of its split: the blended extension's
  // weights have derivatives there (docs/math/green_coordinates.md, "Exterior extension").
  const std::vector<double> x = sample_points();
  std::vector<double> jac(3 * x.size());
  g.jacobian(x.data(), jac.data(), x.size() / 3);
  const double h = 1e-6;
  for (std::size_t i = 0; i < x.size() / 3; ++i) {
    for (int c = 0; c < 3; ++c) {
      double p[3] = {x[3 * i], x[3 * i + 1], x[3 * i + 2]}, m[3] = {p[0], p[1], p[2]}, fp[3], fm[3];
      p[c] += h;
      m[c] -= h;
      g.deform(p, fp, 1);
      g.deform(m, fm, 1);
      for (int r = 0; r < 3; ++r)
        EXPECT_NEAR(jac[9 * i + 3 * r + c], (fp[r] - fm[r]) / (2 * h), 1e-6) << "point " << i << " d" << r << "/dx" << c;
    }
  }
}

TEST(GreenCage, BoundPathEqualsDeformAndBindingsAreSharedByBothModes) {
  GreenCage with = make(l_prism()), without = make(l_prism(), false);
  std::vector<double> moved = with.rest_cage_points();
  for (std::size_t i = 0; i < moved.size(); i += 3) moved[i + 2] *= 1.0 + 0.3 * moved[i];
  with.set_cage_points(moved);
  without.set_cage_points(moved);
  const std::vector<double> x = sample_points();
  const std::size_t n = x.size() / 3;
  const CageBinding b = with.bind(x.data(), n);
  EXPECT_EQ(b.columns, with.columns());
  std::vector<double> bound(x.size()), direct(x.size());
  with.deform_bound(b, bound.data());
  with.deform(x.data(), direct.data(), n);
  for (std::size_t i = 0; i < x.size(); ++i) EXPECT_NEAR(bound[i], direct[i], 1e-12) << i;
  without.deform_bound(b, bound.data());  // the same coordinates: another mode's binding is usable
  without.deform(x.data(), direct.data(), n);
  for (std::size_t i = 0; i < x.size(); ++i) EXPECT_NEAR(bound[i], direct[i], 1e-12) << i;
  MeanValueCage mvc(CageMesh(polygon_mesh(l_prism())));
  EXPECT_THROW(mvc.deform_bound(b, bound.data()), std::invalid_argument);  // another coordinate kind's
}

TEST(GreenCage, RestCageIsTheIdentityBitForBit) {
  GreenCage g = make(l_prism());
  g.set_cage_points(g.rest_cage_points());
  EXPECT_TRUE(g.is_identity());
  const std::vector<double> x = sample_points();
  std::vector<double> y(x.size());
  g.deform(x.data(), y.data(), x.size() / 3);
  EXPECT_EQ(x, y);
}

// The Bernstein algebra (products, elevation, de Casteljau halves) against evaluation, and the
// cells' det J coefficients and bounds against the per-point Jacobians (reference_jacobian), for
// every basis (docs/math/lattice.md, "Certified volume-ratio bounds").
#include "lattice/lattice_fixtures.hpp"

#include "deformkit/lattice/jacobian_bounds.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <memory>
#include <random>

using namespace deformkit;
using namespace deformkit::test;

namespace {

TriPoly random_poly(std::array<int, 3> degree, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  TriPoly p;
  p.reset(degree);
  for (double& c : p.c) c = u(rng);
  return p;
}

TEST(BernsteinAlgebra, ProductElevationAndHalvesAgreeWithEvaluation) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const TriPoly a = random_poly({2, 3, 1}, rng), b = random_poly({1, 0, 3}, rng);
  TriPoly sa = a, sb = b, product, scratch;
  to_scaled(sa);
  to_scaled(sb);
  multiply_scaled(sa, sb, product);
  TriPoly elevated;
  elevated.reset({4, 5, 6});
  add_elevated_scaled(sa, elevated, scratch);
  from_scaled(product);
  from_scaled(elevated);
  ASSERT_EQ(product.degree, (std::array<int, 3>{3, 3, 4}));
  for (int trial = 0; trial < 50; ++trial) {
    const double x = u(rng), y = u(rng), z = u(rng);
    const double fa = evaluate_bernstein(a, x, y, z), fb = evaluate_bernstein(b, x, y, z);
    EXPECT_NEAR(evaluate_bernstein(product, x, y, z), fa * fb, 1e-13);
    EXPECT_NEAR(evaluate_bernstein(elevated, x, y, z), fa, 1e-13);
    for (int axis = 0; axis < 3; ++axis) {
      TriPoly low, high;
      split_half(a, axis, low, high);
      double p[3] = {x, y, z}, lo[3] = {x, y, z}, hi[3] = {x, y, z};
      lo[axis] = 0.5 * p[axis], hi[axis] = 0.5 + 0.5 * p[axis];
      EXPECT_NEAR(evaluate_bernstein(low, x, y, z), evaluate_bernstein(a, lo[0], lo[1], lo[2]), 1e-13);
      EXPECT_NEAR(evaluate_bernstein(high, x, y, z), evaluate_bernstein(a, hi[0], hi[1], hi[2]), 1e-13);
    }
  }
}

struct Case {
  std::string name;
  std::function<std::unique_ptr<BoxLattice>(Outside)> make;
};

std::vector<Case> cases() {
  const LatticeBox box = skewed_box();
  auto blender = [box](std::array<int, 3> res, std::array<BasisKind, 3> kinds) {
    return [=](Outside o) { return std::make_unique<BlenderLattice>(box, res, kinds, o, 0.8); };
  };
  const BasisKind B = BasisKind::BlenderBSpline, L = BasisKind::BlenderLinear, C = BasisKind::BlenderCardinal,
                  R = BasisKind::BlenderCatmullRom;
  return {
      {"ffd_3_2_4", [box](Outside o) { return std::make_unique<FFD>(box, std::array<int, 3>{3, 2, 4}, o, 1.3); }},
      {"bezier_2_1_3", [box](Outside o) { return std::make_unique<BezierFFD>(box, std::array<int, 3>{2, 1, 3}, o); }},
      {"bspline_5_4_6", [box](Outside o) { return std::make_unique<BSplineLattice>(box, std::array<int, 3>{5, 4, 6}, o); }},
      {"blender_bspline", blender({4, 5, 3}, {B, B, B})},
      {"blender_linear", blender({3, 4, 2}, {L, L, L})},
      {"blender_mixed", blender({3, 4, 5}, {L, C, R})},
      {"blender_flat_axis", blender({4, 1, 3}, {B, L, C})},
  };
}

// The world point of local coordinates u (the cell's unit cube) of a region cell.
Vec3 cell_point(const BoxLattice& lat, const CellSpec& cell, const Vec3& u) {
  Vec3 s;
  for (int a = 0; a < 3; ++a) {
    const AxisBasis& axis = lat.axes()[a];
    const double t = cell.frozen[a] ? cell.lo[a] : cell.lo[a] + u[a] * (cell.hi[a] - cell.lo[a]);
    s[a] = axis.domain_lo() + (cell.piece[a] + t) / axis.scale();
  }
  return lat.box().point(s);
}

double reference_det(const BoxLattice& lat, const Vec3& x) {
  double j[9];
  lat.reference_jacobian(x.data(), j, 1);
  Mat3 m;
  for (int e = 0; e < 9; ++e) m(e / 3, e % 3) = j[e];
  return m.determinant();
}

TEST(JacobianBounds, CoefficientsEvaluateToThePerPointDeterminant) {
  for (const Case& c : cases()) {
    auto lat = c.make(Outside::Clamp);
    perturb(*lat, 11, 0.06);
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(0.02, 0.98);
    for (const CellSpec& cell : region_cells(*lat, false)) {  // a far face's points round to either side
      const CellVolumeRatio cv = cell_volume_ratio(*lat, cell);
      for (int trial = 0; trial < 5; ++trial) {
        const Vec3 p(u(rng), u(rng), u(rng));
        const double want = reference_det(*lat, cell_point(*lat, cell, p));
        EXPECT_NEAR(evaluate_bernstein(cv.coefficients, p[0], p[1], p[2]), want, 1e-11) << c.name;
      }
    }
  }
}

TEST(JacobianBounds, BoundsEncloseSamplesAndRestIsExactlyOne) {
  for (const Case& c : cases()) {
    auto lat = c.make(Outside::Clamp);
    const auto cells = region_cells(*lat);
    const VolumeRatioBounds rest = volume_ratio_bounds(*lat, cells, false, 1e-3);
    EXPECT_EQ(rest.lower, 1.0) << c.name;
    EXPECT_EQ(rest.upper, 1.0) << c.name;
    EXPECT_TRUE(fold_certificate(*lat, cells, false).certified) << c.name;
    perturb(*lat, 12, 0.25);  // folds some of them
    const VolumeRatioBounds b = volume_ratio_bounds(*lat, cells, false, 1e-4);
    const FoldCertificate cert = fold_certificate(*lat, cells, false);
    EXPECT_TRUE(b.converged) << c.name;
    std::mt19937 rng(6);
    std::uniform_real_distribution<double> u(1e-9, 1 - 1e-9);
    double least = 1e300;
    for (const CellSpec& cell : cells)
      for (int trial = 0; trial < 200; ++trial) {
        const double d = reference_det(*lat, cell_point(*lat, cell, Vec3(u(rng), u(rng), u(rng))));
        EXPECT_LE(b.lower, d + 1e-12) << c.name;
        EXPECT_GE(b.upper, d - 1e-12) << c.name;
        least = std::min(least, d);
      }
    EXPECT_LE(b.lower, b.minimum) << c.name;
    EXPECT_LE(b.minimum, least + 1e-12) << c.name;  // the refinement finds at least what sampling does
    EXPECT_GE(b.lower, b.minimum - 1e-4 * b.scale) << c.name;
    if (least <= 0.0) EXPECT_FALSE(cert.certified) << c.name;
    if (cert.certified) EXPECT_GT(least, 0.0) << c.name;
  }
}

// Nodes and weights of the n-point Gauss-Legendre rule on [-1, 1] (Newton on P_n).
void gauss_legendre(int n, std::vector<double>& x, std::vector<double>& w) {
  x.resize(n), w.resize(n);
  for (int i = 0; i < n; ++i) {
    double z = std::cos(M_PI * (i + 0.75) / (n + 0.5)), dp = 0.0;
    for (int iter = 0; iter < 100; ++iter) {
      double p0 = 1.0, p1 = z;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
        p0 = p1, p1 = p2;
      }
      dp = n * (z * p1 - p0) / (z * z - 1.0);
      const double step = p1 / dp;
      z -= step;
      if (std::abs(step) < 1e-16) break;
    }
    x[i] = z;
    w[i] = 2.0 / ((1.0 - z * z) * dp * dp);
  }
}

TEST(JacobianBounds, ExactVolumeIsTheMeanOfTheCoefficients) {
  for (const Case& c : cases()) {
    auto lat = c.make(Outside::Clamp);
    perturb(*lat, 13, 0.05);
    // Gauss-Legendre, 7 points per axis per cell: exact for degree 13 >= 3 * 4 - 1.
    std::vector<double> x, w;
    gauss_legendre(7, x, w);
    double quadrature = 0.0;
    for (const CellSpec& cell : region_cells(*lat, false)) {
      double cell_sum = 0.0;
      for (int i = 0; i < 7; ++i)
        for (int j = 0; j < 7; ++j)
          for (int k = 0; k < 7; ++k) {
            const Vec3 u(0.5 + 0.5 * x[i], 0.5 + 0.5 * x[j], 0.5 + 0.5 * x[k]);
            cell_sum += w[i] * w[j] * w[k] / 8.0 * reference_det(*lat, cell_point(*lat, cell, u));
          }
      double width = std::abs(lat->box().edges.determinant());
      for (int a = 0; a < 3; ++a) width /= lat->axes()[a].scale();
      quadrature += width * cell_sum;
    }
    EXPECT_NEAR(deformed_volume(*lat), quadrature, 1e-12 * std::abs(quadrature)) << c.name;
  }
}

TEST(JacobianBounds, ToleranceMustBeFiniteAndPositive) {
  BezierFFD lat(skewed_box(), {1, 1, 1});
  const auto cells = region_cells(lat);
  for (double tol : {0.0, -1.0, std::nan(""), HUGE_VAL}) {
    try {
      volume_ratio_bounds(lat, cells, false, tol);
      FAIL() << tol;
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()).rfind("tolerance: ", 0), 0u) << e.what();
    }
  }
}

}  // namespace

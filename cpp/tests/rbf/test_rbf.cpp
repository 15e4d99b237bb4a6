// RBF deformation against its defining properties: the kernels' derivatives against central
// differences, interpolation at the controls, exact affine reproduction with the affine term,
// compact support, Jacobians against finite differences, the bound path, and bad input.
#include "deformkit/rbf/rbf_deformer.hpp"
#include "rbf/rbf_rows.hpp"
#include "test_util.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

using namespace deformkit;
using namespace deformkit::test;

namespace {

const RbfKernel kAll[] = {RbfKernel::ThinPlateSpline,     RbfKernel::Cubic,           RbfKernel::Quintic,
                          RbfKernel::Linear,              RbfKernel::Gaussian,        RbfKernel::Multiquadric,
                          RbfKernel::InverseMultiquadric, RbfKernel::InverseQuadratic, RbfKernel::WendlandC0,
                          RbfKernel::WendlandC2,          RbfKernel::WendlandC4,      RbfKernel::Clip};

RbfOptions options_for(RbfKernel k) {
  RbfOptions o;
  o.kernel.kind = k;
  o.kernel.epsilon = 1.5;
  o.kernel.radius = 1.2;
  o.degree = std::max(1, rbf_minimum_degree(k));
  return o;
}

// Controls spread in [0, 1]^3 and targets moved by a smooth non-affine map.
std::vector<double> smooth_targets(const std::vector<double>& c) {
  std::vector<double> t(c.size());
  for (std::size_t j = 0; j < c.size() / 3; ++j) {
    const double x = c[3 * j], y = c[3 * j + 1], z = c[3 * j + 2];
    t[3 * j] = x + 0.1 * std::sin(3 * y);
    t[3 * j + 1] = y + 0.08 * z * z;
    t[3 * j + 2] = z - 0.05 * std::cos(2 * x);
  }
  return t;
}

Vec3 row(const std::vector<double>& a, std::size_t i) { return Vec3(a[3 * i], a[3 * i + 1], a[3 * i + 2]); }

}  // namespace

TEST(RbfKernel, SlopeIsTheDerivativeOverR) {
  for (RbfKernel k : kAll) {
    const RbfKernelShape shape = options_for(k).kernel;
    for (double r : {0.05, 0.3, 0.7, 1.1, 2.5}) {
      double v, slope, vp, vm, s;
      rbf_kernel(shape, r, &v, &slope);
      const double h = 1e-6;
      rbf_kernel(shape, r + h, &vp, &s);
      rbf_kernel(shape, r - h, &vm, &s);
      const double derivative = (vp - vm) / (2 * h);
      EXPECT_NEAR(slope * r, derivative, 1e-7 * (1 + std::abs(derivative))) << int(k) << " at r = " << r;
    }
  }
}

TEST(RbfKernel, CompactKernelsVanishAtTheRadius) {
  for (RbfKernel k : kAll) {
    if (!rbf_compact(k)) continue;
    RbfKernelShape shape = options_for(k).kernel;
    double v, s;
    rbf_kernel(shape, shape.radius, &v, &s);
    EXPECT_EQ(v, 0.0);
    rbf_kernel(shape, 0.0, &v, &s);
    EXPECT_EQ(v, 1.0);
  }
}

TEST(RbfDeformer, ControlsLandOnTheirTargets) {
  const std::size_t m = 60;
  const auto c = random_points(m, 0.0, 1.0, 3);
  const auto t = smooth_targets(c);
  for (RbfKernel k : kAll) {
    RbfDeformer rbf(c.data(), m, options_for(k));
    rbf.set_targets(t);
    std::vector<double> out(c.size());
    rbf.deform(c.data(), out.data(), m);
    double worst = 0;
    for (std::size_t i = 0; i < c.size(); ++i) worst = std::max(worst, std::abs(out[i] - t[i]));
    EXPECT_LT(worst, 1e-12) << int(k);  // measured 1e-16 .. 2e-14 at condition estimates up to 3e6
  }
}

TEST(RbfDeformer, TheAffineTermReproducesAffineMapsEverywhere) {
  const std::size_t m = 40;
  const auto c = random_points(m, 0.0, 1.0, 5);
  const Frame f = random_frame(8);
  std::vector<double> t(c.size());
  for (std::size_t j = 0; j < m; ++j) {
    const Vec3 q = f.to_object(row(c, j));
    for (int a = 0; a < 3; ++a) t[3 * j + a] = q[a];
  }
  const auto x = random_points(500, -0.5, 1.5, 9);
  for (RbfKernel k : kAll) {
    if (rbf_minimum_degree(k) > 1) continue;  // quintic: degree 2 reproduces affine maps too, tested below
    RbfDeformer rbf(c.data(), m, options_for(k));
    rbf.set_targets(t);
    std::vector<double> out(x.size());
    rbf.deform(x.data(), out.data(), 500);
    double worst = 0, alpha = 0;
    for (std::size_t i = 0; i < 500; ++i) worst = std::max(worst, (row(out, i) - f.to_object(row(x, i))).norm());
    for (double a : rbf.alpha()) alpha = std::max(alpha, std::abs(a));
    EXPECT_LT(worst, 1e-9) << int(k);
    EXPECT_LT(alpha, 1e-8) << int(k);  // the kernel part is not used
  }
  RbfOptions quintic = options_for(RbfKernel::Quintic);
  RbfDeformer rbf(c.data(), m, quintic);
  rbf.set_targets(t);
  const Vec3 got = deform_one(rbf, Vec3(0.3, 1.2, -0.2));
  EXPECT_LT((got - f.to_object(Vec3(0.3, 1.2, -0.2))).norm(), 1e-8);
}

TEST(RbfDeformer, CompactSupportLeavesFarPointsBitForBit) {
  const std::size_t m = 50;
  const auto c = random_points(m, 0.0, 1.0, 13);
  const auto t = smooth_targets(c);
  for (RbfKernel k : {RbfKernel::WendlandC0, RbfKernel::WendlandC2, RbfKernel::WendlandC4, RbfKernel::Clip}) {
    RbfOptions o = options_for(k);
    o.degree = -1;
    o.kernel.radius = 0.4;
    RbfDeformer rbf(c.data(), m, o);
    rbf.set_targets(t);
    const std::vector<double> far = {1.5, 0.5, 0.5, -0.41, -0.41, 0.2, 3.0, 3.0, 3.0, 1e12, -1e12, 0.0};
    std::vector<double> out(far.size());
    rbf.deform(far.data(), out.data(), 4);
    for (std::size_t i = 0; i < far.size(); ++i) EXPECT_EQ(out[i], far[i]);
  }
}

TEST(RbfDeformer, JacobianMatchesCentralDifferences) {
  const std::size_t m = 30;
  const auto c = random_points(m, 0.0, 1.0, 17);
  const auto t = smooth_targets(c);
  const auto x = random_points(20, -0.2, 1.2, 19);
  for (RbfKernel k : kAll) {
    RbfOptions o = options_for(k);
    o.degree = 2;  // the quadratic term's gradient too
    RbfDeformer rbf(c.data(), m, o);
    rbf.set_targets(t);
    for (std::size_t i = 0; i < 20; ++i) {
      const Mat3 j = jacobian_one(rbf, row(x, i)), fd = finite_difference_jacobian(rbf, row(x, i), 1e-6);
      EXPECT_LT((j - fd).norm(), 1e-6 * (1 + j.norm())) << int(k) << " point " << i;
    }
  }
}

TEST(RbfDeformer, BoundPathEqualsDeformAndTargetsAtRestAreTheIdentity) {
  const std::size_t m = 80, n = 20000;  // past the parallel grain: both cores
  const auto c = random_points(m, 0.0, 1.0, 23);
  const auto x = random_points(n, -0.3, 1.3, 29);
  for (RbfKernel k : {RbfKernel::ThinPlateSpline, RbfKernel::Gaussian, RbfKernel::WendlandC2}) {
    RbfDeformer rbf(c.data(), m, options_for(k));
    const RbfBinding b = rbf.bind(x.data(), n);
    std::vector<double> want(x.size()), got(x.size());
    rbf.deform_bound(b, got.data());
    EXPECT_EQ(got, x);  // at rest, bit for bit
    rbf.set_targets(smooth_targets(c));
    rbf.deform(x.data(), want.data(), n);
    rbf.deform_bound(b, got.data());
    for (std::size_t i = 0; i < x.size(); ++i) ASSERT_NEAR(got[i], want[i], 1e-12) << int(k);
    rbf.set_targets(c);
    rbf.deform(x.data(), got.data(), n);
    EXPECT_EQ(got, x);
  }
}

TEST(RbfDeformer, RefusesBadInput) {
  const auto c = random_points(10, 0.0, 1.0, 31);
  RbfOptions o;
  auto fails = [&](const std::vector<double>& pts, const RbfOptions& opt, const char* name) {
    try {
      RbfDeformer r(pts.data(), pts.size() / 3, opt);
      ADD_FAILURE() << "no error for " << name;
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()).rfind(name, 0), 0u) << e.what();
    }
  };
  RbfOptions bad = o;
  bad.kernel.epsilon = -1;
  fails(c, bad, "epsilon");
  bad = o;
  bad.degree = 0;  // thin plate needs 1
  fails(c, bad, "degree");
  bad = o;
  bad.degree = 3;
  fails(c, bad, "degree");
  bad = o;
  bad.smoothing = -1;
  fails(c, bad, "smoothing");
  std::vector<double> dup = c;
  for (int a = 0; a < 3; ++a) dup[3 * 7 + a] = dup[3 * 2 + a];
  fails(dup, o, "control_points");
  std::vector<double> flat = c;
  for (std::size_t j = 0; j < 10; ++j) flat[3 * j + 2] = 0.5;  // coplanar: the affine term cannot be fitted
  fails(flat, o, "control_points");
  fails(std::vector<double>(c.begin(), c.begin() + 9), o, "control_points");  // 3 controls, 4 terms
  std::vector<double> nan = c;
  nan[4] = std::nan("");
  fails(nan, o, "control_points");
  RbfOptions gauss;
  gauss.kernel.kind = RbfKernel::Gaussian;
  gauss.kernel.epsilon = 1e-4;  // flat: the kernel matrix is numerically singular
  gauss.degree = -1;
  fails(c, gauss, "epsilon");  // flat over the controls: the remedy is a larger epsilon
  RbfDeformer good(c.data(), 10, o);
  EXPECT_THROW(good.set_targets(std::vector<double>(27, 0.0)), std::invalid_argument);
  std::vector<double> t = c;
  t[0] = std::numeric_limits<double>::infinity();
  EXPECT_THROW(good.set_targets(t), std::invalid_argument);
  // With smoothing, coincident controls are a least-squares fit, not an error.
  RbfOptions smooth = o;
  smooth.smoothing = 1e-3;
  EXPECT_NO_THROW(RbfDeformer(dup.data(), 10, smooth));
}

// The grid visits exactly the controls within the support: the result equals the sum over every
// control, for controls whose cells fit the dense cell index and for a far-flung set that takes
// the hash map of occupied cells.
TEST(RbfDeformer, TheGridFindsEveryControlWithinTheSupport) {
  for (double spread : {1.0, 1e5}) {  // 1e5: 14M cells, past the dense index
    std::vector<double> c = random_points(80, 0.0, 1.0, 37);
    for (std::size_t j = 40; j < 80; ++j) c[3 * j] += spread;  // a second cluster, far away
    RbfOptions o;
    o.kernel.kind = RbfKernel::WendlandC2;
    o.kernel.radius = 0.35;
    o.degree = -1;
    RbfDeformer rbf(c.data(), 80, o);
    rbf.set_targets(smooth_targets(c));
    std::vector<double> x = random_points(400, -0.2, 1.2, 41);
    for (std::size_t i = 200; i < 400; ++i) x[3 * i] += spread;
    std::vector<double> got(x.size());
    rbf.deform(x.data(), got.data(), 400);
    double worst = 0;
    for (std::size_t i = 0; i < 400; ++i) {
      Vec3 want = row(x, i);
      for (std::size_t j = 0; j < 80; ++j) {
        double v, slope;
        rbf_kernel(o.kernel, (row(x, i) - row(c, j)).norm(), &v, &slope);
        want += v * row(rbf.alpha(), j);
      }
      worst = std::max(worst, (row(got, i) - want).norm());
    }
    EXPECT_LT(worst, 1e-12 * (1.0 + spread)) << "spread " << spread;  // rounding of x - c at |x| ~ spread
  }
}

// The SIMD kernel sums against the scalar definitions, one control at a time (the sum is then
// phi itself): a few ulps for every global kernel, also where the Gaussian underflows.
TEST(RbfKernel, SimdSumsMatchTheScalarKernels) {
  std::vector<double> x;
  for (int i = 0; i < 3000; ++i) x.insert(x.end(), {0.0, 0.0, 1e-3 * i * i * 1e-3 * 7.0});  // r from 0 to 63
  x.insert(x.end(), {1e-8, 0, 0, 0, 0, 1e3});
  const std::size_t n = x.size() / 3;
  const double zero = 0.0, one = 1.0;
  RbfColumns col;
  for (int a = 0; a < 3; ++a) {
    col.c[a] = &zero;
    col.alpha[a] = &one;
  }
  col.m = 1;
  for (RbfKernel k : kAll) {
    if (rbf_compact(k)) continue;
    RbfKernelShape shape = options_for(k).kernel;
    std::vector<double> out(3 * n);
    rbf_kernel_sums(x.data(), n, col, shape, out.data());
    for (std::size_t i = 0; i < n; ++i) {
      double v, slope;
      const double r = std::sqrt(x[3 * i] * x[3 * i] + x[3 * i + 2] * x[3 * i + 2]);
      rbf_kernel(shape, r, &v, &slope);
      // Thin plate near s = 1: log s -> 0, so its error is a few ulps of s^2, not of s^2 log s. The
      // Gaussian's: a few ulps of its argument s^2 (rounded differently from r^2 = |x - c|^2).
      const double s2 = std::pow(shape.epsilon * r, 2);
      const double scale = k == RbfKernel::ThinPlateSpline ? std::max(std::abs(v), s2)
                           : k == RbfKernel::Gaussian      ? std::abs(v) * (1.0 + s2)
                                                           : std::abs(v);
      ASSERT_NEAR(out[3 * i], v, 2e-15 * scale + 1e-300) << int(k) << " at point " << i;
    }
  }
}

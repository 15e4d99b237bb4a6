#include "test_util.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

using namespace deformkit;

TEST(Profile, LinearClampsOutsideLimits) {
  const Profile p = Profile::linear(1.0, 2.0, -0.5, 0.25);
  EXPECT_DOUBLE_EQ(p.value(0.1), 1.2);
  EXPECT_DOUBLE_EQ(p.value(-3.0), 0.0);
  EXPECT_DOUBLE_EQ(p.value(3.0), 1.5);
  EXPECT_DOUBLE_EQ(p.derivative(0.1), 2.0);
  EXPECT_DOUBLE_EQ(p.derivative(3.0), 0.0);
}

TEST(Profile, SplineInterpolatesSamples) {
  const std::vector<double> z{-1.0, -0.2, 0.5, 0.7, 2.0}, f{0.3, -1.0, 2.0, 2.5, 0.0};
  const Profile p = Profile::spline(z, f);
  for (std::size_t i = 0; i < z.size(); ++i) EXPECT_NEAR(p.value(z[i]), f[i], 1e-14);
}

TEST(Profile, SplineReproducesLinearData) {
  // A natural cubic spline through samples of a line is that line.
  const Profile p = Profile::spline({0.0, 0.3, 1.0, 2.5}, {1.0, 1.6, 3.0, 6.0});
  for (double z = 0.0; z <= 2.5; z += 0.05) {
    EXPECT_NEAR(p.value(z), 1.0 + 2.0 * z, 1e-12);
    EXPECT_NEAR(p.derivative(z), 2.0, 1e-12);
  }
}

TEST(Profile, SplineDerivativeMatchesFiniteDifferences) {
  const Profile p = Profile::spline({-1.0, 0.0, 0.4, 1.5, 3.0}, {0.0, 1.0, -0.5, 0.8, 2.0});
  for (double z = -0.95; z < 2.95; z += 0.0731) {
    const double h = 1e-6, fd = (p.value(z + h) - p.value(z - h)) / (2 * h);
    EXPECT_NEAR(p.derivative(z), fd, 1e-7) << "z = " << z;
  }
}

TEST(Profile, SplineIsC2AtKnots) {
  const Profile p = Profile::spline({0.0, 1.0, 2.0, 3.0}, {0.0, 2.0, 1.0, 3.0});
  for (double knot : {1.0, 2.0}) {
    const double e = 1e-7;
    EXPECT_NEAR(p.derivative(knot - e), p.derivative(knot + e), 1e-5);
  }
}

TEST(Profile, ExtensionOutsideSamples) {
  const Profile held = Profile::spline({0.0, 1.0, 2.0}, {0.0, 1.0, 0.0}, Extend::Constant);
  EXPECT_DOUBLE_EQ(held.value(5.0), 0.0);
  EXPECT_DOUBLE_EQ(held.derivative(5.0), 0.0);
  const Profile cont = Profile::spline({0.0, 1.0, 2.0}, {0.0, 1.0, 0.0}, Extend::Linear);
  const double slope = cont.derivative(2.0);
  EXPECT_NEAR(cont.value(3.0), slope, 1e-12);
  EXPECT_NEAR(cont.derivative(3.0), slope, 1e-12);
}

TEST(Profile, BadSamplesAreRejected) {
  EXPECT_THROW(Profile::spline({0.0}, {1.0}), std::invalid_argument);
  EXPECT_THROW(Profile::spline({0.0, 0.0}, {1.0, 2.0}), std::invalid_argument);
  EXPECT_THROW(Profile::spline({1.0, 0.0}, {1.0, 2.0}), std::invalid_argument);
  EXPECT_THROW(Profile::spline({0.0, 1.0}, {1.0}), std::invalid_argument);
  EXPECT_THROW(Profile::spline({0.0, NAN}, {1.0, 2.0}), std::invalid_argument);
  EXPECT_THROW(Profile::linear(NAN, 1.0), std::invalid_argument);
  EXPECT_THROW(Profile::linear(0.0, 1.0, 1.0, 0.0), std::invalid_argument);
}

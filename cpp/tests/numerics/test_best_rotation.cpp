// best_rotation / best_rotations (SIMD Newton polar step) against the SVD definition of the ARAP
// local step: R = V U^T maximising tr(R S), a proper rotation.
#include "deformkit/numerics/best_rotation.hpp"

#include <Eigen/SVD>
#include <gtest/gtest.h>

#include <random>
#include <vector>

using namespace deformkit;

namespace {

Mat3 svd_reference(const Mat3& s) {
  const Eigen::JacobiSVD<Mat3> svd(s, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 u = svd.matrixU();
  if ((svd.matrixV() * u.transpose()).determinant() < 0) u.col(2) *= -1.0;
  return svd.matrixV() * u.transpose();
}

// A one-ring-like S: a random rotation times singular values spread by `condition`, with a
// reflection or a singular direction in some.
std::vector<Mat3> sample(std::size_t count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Mat3> out;
  for (std::size_t i = 0; i < count; ++i) {
    Mat3 m;
    for (int k = 0; k < 9; ++k) m(k / 3, k % 3) = u(rng);
    const Eigen::JacobiSVD<Mat3> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
    const double condition = std::pow(10.0, 4.0 * (u(rng) + 1.0) / 2.0);
    Vec3 sigma(1.0, std::sqrt(condition) / condition * 3.0, 1.0 / condition);
    switch (i % 7) {
      case 0: sigma[2] = -sigma[2]; break;  // reflected
      case 1: sigma[2] = 0.0; break;        // planar one-ring
      case 2: sigma.setZero(); break;       // no neighbours
      default: break;
    }
    out.push_back(std::exp(6.0 * u(rng)) * svd.matrixU() * sigma.asDiagonal() * svd.matrixV().transpose());
  }
  return out;
}

}  // namespace

TEST(BestRotation, MatchesTheSvdDefinition) {
  for (const Mat3& s : sample(2000, 3)) {
    const Mat3 r = best_rotation(s);
    EXPECT_NEAR(r.determinant(), 1.0, 1e-12);
    EXPECT_LT((r.transpose() * r - Mat3::Identity()).cwiseAbs().maxCoeff(), 1e-12);
    if (s.isZero(0.0)) continue;  // every rotation is optimal
    // tr(R S) as large as the SVD's (the optimum may be non-unique when singular values repeat).
    EXPECT_GE((r * s).trace(), (svd_reference(s) * s).trace() - 1e-10 * s.norm());
    if (s.determinant() > 1e-3 * std::pow(s.cwiseAbs().maxCoeff(), 3))
      EXPECT_LT((r - svd_reference(s)).cwiseAbs().maxCoeff(), 1e-10);
  }
}

TEST(BestRotation, SimdLanesMatchTheScalarStepForEveryTail) {
  for (std::size_t count : {1u, 3u, 7u, 8u, 9u, 17u, 255u, 256u, 257u, 1029u}) {
    const std::vector<Mat3> ms = sample(count, unsigned(count));
    std::vector<double> s(9 * count), r(9 * count);
    for (std::size_t i = 0; i < count; ++i)
      for (int k = 0; k < 9; ++k) s[std::size_t(k) * count + i] = ms[i](k / 3, k % 3);
    best_rotations(s.data(), r.data(), count);
    for (std::size_t i = 0; i < count; ++i) {
      Mat3 got;
      for (int k = 0; k < 9; ++k) got(k / 3, k % 3) = r[std::size_t(k) * count + i];
      EXPECT_LT((got - best_rotation(ms[i])).cwiseAbs().maxCoeff(), 1e-12) << "count " << count << " i " << i;
    }
  }
}

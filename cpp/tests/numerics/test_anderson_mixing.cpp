// Anderson mixing against the fixed points it must find: a linear contraction's (reached exactly
// once the window spans its space) and a nonlinear map's.
#include "numerics/anderson_mixing.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace deformkit {
namespace {

TEST(AndersonMixing, SolvesALinearFixedPointWithinTheWindowsDimension) {
  // G(x) = A x + b with A's spectral radius 0.95: plain iteration needs ~400 steps for 1e-9, Anderson
  // with window >= dim is GMRES on (I - A) and is exact after dim + 1 steps.
  const int n = 4;
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(n, n);
  a.diagonal() << 0.95, 0.9, -0.5, 0.2;
  Eigen::MatrixXd q = Eigen::HouseholderQR<Eigen::MatrixXd>(Eigen::MatrixXd::Random(n, n)).householderQ();
  a = q * a * q.transpose();
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(n, 1, 2);
  const Eigen::VectorXd fixed = (Eigen::MatrixXd::Identity(n, n) - a).partialPivLu().solve(b);
  AndersonMixing mixing(n);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  for (int k = 0; k < n + 2; ++k) x = mixing.next(x, a * x + b);
  EXPECT_LT((x - fixed).norm(), 1e-9 * fixed.norm());
  Eigen::VectorXd plain = Eigen::VectorXd::Zero(n);
  for (int k = 0; k < n + 2; ++k) plain = a * plain + b;
  EXPECT_GT((plain - fixed).norm(), 1e-2 * fixed.norm());  // the acceleration is what got there
}

TEST(AndersonMixing, ConvergesOnANonlinearMapWithASmallWindow) {
  // x = 0.3 x + 0.7 cos(x) componentwise; its fixed point by Newton.
  const int n = 50;
  auto g = [](const Eigen::VectorXd& x) { return Eigen::VectorXd(0.3 * x + 0.7 * x.array().cos().matrix()); };
  double root = 0.7;
  for (int k = 0; k < 50; ++k) root -= (root - std::cos(root)) / (1 + std::sin(root));
  AndersonMixing mixing(3);
  Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(n, -1, 2);
  int steps = 0;
  for (; steps < 100 && (x.array() - root).abs().maxCoeff() > 1e-12; ++steps) x = mixing.next(x, g(x));
  EXPECT_LT((x.array() - root).abs().maxCoeff(), 1e-12);
  EXPECT_LT(steps, 20);
  EXPECT_EQ(mixing.history(), 3u);
}

TEST(AndersonMixing, FirstCallIsThePlainStepAndAWindowBelowOneIsRefused) {
  AndersonMixing mixing(2);
  const Eigen::VectorXd x = Eigen::VectorXd::Ones(3), g = Eigen::VectorXd::Constant(3, 2.0);
  EXPECT_EQ(mixing.next(x, g), g);
  EXPECT_EQ(mixing.history(), 0u);
  EXPECT_THROW(AndersonMixing(0), std::invalid_argument);
}

}  // namespace
}  // namespace deformkit

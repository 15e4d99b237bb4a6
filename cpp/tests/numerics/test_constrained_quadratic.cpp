// ConstrainedQuadratic against dense solves of the constrained problem written out independently:
// the KKT system [A C^T; C 0] [x; lambda] = [b; y] (C selecting the fixed unknowns), with the soft
// and ridge terms added to A and b by hand.
#include "deformkit/numerics/constrained_quadratic.hpp"

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

using namespace deformkit;

namespace {

// A random sparse symmetric positive definite matrix: a random weighted graph Laplacian (every
// unknown on a path, plus random chords) with a small positive diagonal.
SparseMatrix random_spd(int n, unsigned seed, double shift = 1e-2) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> weight(0.1, 2.0);
  std::uniform_int_distribution<int> vertex(0, n - 1);
  std::vector<Eigen::Triplet<double>> e;
  auto edge = [&](int a, int b) {
    const double w = weight(rng);
    e.emplace_back(a, a, w), e.emplace_back(b, b, w), e.emplace_back(a, b, -w), e.emplace_back(b, a, -w);
  };
  for (int i = 0; i + 1 < n; ++i) edge(i, i + 1);
  for (int k = 0; k < 2 * n; ++k) {
    const int a = vertex(rng), b = vertex(rng);
    if (a != b) edge(a, b);
  }
  for (int i = 0; i < n; ++i) e.emplace_back(i, i, shift);
  SparseMatrix a(n, n);
  a.setFromTriplets(e.begin(), e.end());
  return a;
}

Eigen::MatrixXd random_matrix(Eigen::Index rows, Eigen::Index cols, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixXd m(rows, cols);
  for (Eigen::Index i = 0; i < m.size(); ++i) m.data()[i] = u(rng);
  return m;
}

std::vector<char> random_fixed(int n, double fraction, unsigned seed) {
  std::mt19937 rng(seed);
  std::bernoulli_distribution pick(fraction);
  std::vector<char> fixed(n);
  for (auto& f : fixed) f = pick(rng);
  fixed[0] = 1;
  fixed[1] = 0;
  return fixed;
}

// argmin 1/2 x^T A x - x^T b subject to x_i = y_i on the fixed unknowns, from the dense KKT system.
Eigen::MatrixXd kkt_solve(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, const std::vector<int>& fixed,
                          const Eigen::MatrixXd& y) {
  const Eigen::Index n = a.rows(), k = Eigen::Index(fixed.size());
  Eigen::MatrixXd kkt = Eigen::MatrixXd::Zero(n + k, n + k), rhs(n + k, b.cols());
  kkt.topLeftCorner(n, n) = a;
  for (Eigen::Index i = 0; i < k; ++i) kkt(n + i, fixed[i]) = kkt(fixed[i], n + i) = 1.0;
  rhs.topRows(n) = b;
  rhs.bottomRows(k) = y;
  return kkt.fullPivLu().solve(rhs).topRows(n);
}

double relative_error(const Eigen::MatrixXd& x, const Eigen::MatrixXd& want) {
  return (x - want).cwiseAbs().maxCoeff() / std::max(1.0, want.cwiseAbs().maxCoeff());
}

// The free unknowns' rows of a full n x k matrix.
Eigen::MatrixXd free_rows(const Eigen::MatrixXd& full, const UnknownSplit& split) {
  Eigen::MatrixXd out(Eigen::Index(split.free().size()), full.cols());
  for (std::size_t i = 0; i < split.free().size(); ++i) out.row(Eigen::Index(i)) = full.row(split.free()[i]);
  return out;
}

}  // namespace

TEST(UnknownSplit, ListsAndIndicesAreInverse) {
  const std::vector<char> fixed = random_fixed(50, 0.3, 3);
  const UnknownSplit s(fixed);
  EXPECT_EQ(s.free().size() + s.fixed().size(), fixed.size());
  EXPECT_TRUE(std::is_sorted(s.free().begin(), s.free().end()));
  for (std::size_t i = 0; i < s.free().size(); ++i) EXPECT_EQ(s.free_index(s.free()[i]), int(i));
  for (std::size_t i = 0; i < s.fixed().size(); ++i) EXPECT_EQ(s.fixed_index(s.fixed()[i]), int(i));
  const UnknownSplit wide = s.interleaved(3);
  ASSERT_EQ(wide.size(), 3 * fixed.size());
  for (int i = 0; i < int(wide.size()); ++i) EXPECT_EQ(wide.is_fixed(i), bool(fixed[i / 3])) << i;
}

class ConstrainedQuadraticTest : public ::testing::TestWithParam<unsigned> {};

TEST_P(ConstrainedQuadraticTest, QuadraticFormMatchesDenseKkt) {
  const unsigned seed = GetParam();
  const int n = 80;
  const SparseMatrix a = random_spd(n, seed);
  const UnknownSplit split(random_fixed(n, 0.25, seed + 1));
  const Eigen::MatrixXd b = random_matrix(n, 3, seed + 2), y = random_matrix(Eigen::Index(split.fixed().size()), 3, seed + 3);
  const ConstrainedQuadratic q = ConstrainedQuadratic::quadratic(a, split, {});
  ASSERT_TRUE(q.factorised());
  const Eigen::MatrixXd x = q.assemble(q.solve_free(free_rows(b, split), y, Eigen::MatrixXd(0, 3)), y);
  EXPECT_LT(relative_error(x, kkt_solve(Eigen::MatrixXd(a), b, split.fixed(), y)), 1e-10);
  for (std::size_t i = 0; i < split.fixed().size(); ++i)  // reproduced exactly, not solved for
    EXPECT_TRUE((x.row(split.fixed()[i]).array() == y.row(Eigen::Index(i)).array()).all()) << i;
}

TEST_P(ConstrainedQuadraticTest, LeastSquaresMatchesDenseKktOfTheNormalEquations) {
  const unsigned seed = GetParam();
  const int n = 60, rows = 90;
  // A tall sparse M: a square SPD block over a few random extra rows.
  SparseMatrix m(rows, n);
  {
    const SparseMatrix top = random_spd(n, seed);
    std::vector<Eigen::Triplet<double>> e;
    for (int k = 0; k < top.outerSize(); ++k)
      for (SparseMatrix::InnerIterator it(top, k); it; ++it) e.emplace_back(int(it.row()), int(it.col()), it.value());
    std::mt19937 rng(seed);
    std::uniform_int_distribution<int> col(0, n - 1);
    for (int r = n; r < rows; ++r)
      for (int j = 0; j < 3; ++j) e.emplace_back(r, col(rng), 1.0 + 0.1 * j);
    m.setFromTriplets(e.begin(), e.end());
  }
  const UnknownSplit split(random_fixed(n, 0.3, seed + 4));
  const Eigen::MatrixXd r = random_matrix(rows, 3, seed + 5), y = random_matrix(Eigen::Index(split.fixed().size()), 3, seed + 6);
  const ConstrainedQuadratic q = ConstrainedQuadratic::least_squares(m, split, {});
  ASSERT_TRUE(q.factorised());
  const Eigen::MatrixXd dm(m);
  const Eigen::MatrixXd want = kkt_solve(dm.transpose() * dm, dm.transpose() * r, split.fixed(), y);
  EXPECT_LT(relative_error(q.assemble(q.solve_free(r, y, Eigen::MatrixXd(0, 3)), y), want), 1e-9);
  // r = 0 given as an empty matrix.
  const Eigen::MatrixXd want0 = kkt_solve(dm.transpose() * dm, Eigen::MatrixXd::Zero(n, 3), split.fixed(), y);
  EXPECT_LT(relative_error(q.assemble(q.solve_free({}, y, Eigen::MatrixXd(0, 3)), y), want0), 1e-9);
}

TEST_P(ConstrainedQuadraticTest, SoftConstraintsAreTheirPenaltyTerms) {
  const unsigned seed = GetParam();
  const int n = 70;
  const SparseMatrix a = random_spd(n, seed);
  const UnknownSplit split(random_fixed(n, 0.2, seed + 7));
  SoftConstraints soft;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> w(0.5, 20.0);
  for (int u : split.free())
    if (u % 5 == 0) soft.unknowns.push_back(u), soft.weights.push_back(w(rng));
  ASSERT_FALSE(soft.unknowns.empty());
  const Eigen::MatrixXd b = random_matrix(n, 3, seed + 8), y = random_matrix(Eigen::Index(split.fixed().size()), 3, seed + 9);
  const Eigen::MatrixXd c = random_matrix(Eigen::Index(soft.unknowns.size()), 3, seed + 10);
  // 1/2 w (x_i - c_i)^2 adds w to A_ii and w c_i to b_i.
  Eigen::MatrixXd dense(a), bd = b;
  for (std::size_t k = 0; k < soft.unknowns.size(); ++k) {
    dense(soft.unknowns[k], soft.unknowns[k]) += soft.weights[k];
    bd.row(soft.unknowns[k]) += soft.weights[k] * c.row(Eigen::Index(k));
  }
  const Eigen::MatrixXd want = kkt_solve(dense, bd, split.fixed(), y);
  const ConstrainedQuadratic q = ConstrainedQuadratic::quadratic(a, split, soft);
  const Eigen::MatrixXd x = q.assemble(q.solve_free(free_rows(b, split), y, c), y);
  EXPECT_LT(relative_error(x, want), 1e-10);
  // The precomputed constraint term gives the same solve to the last bit.
  const Eigen::MatrixXd again = q.assemble(q.solve_free_with(free_rows(b, split), q.constraint_term(y, c)), y);
  EXPECT_TRUE((again.array() == x.array()).all());
  // And the least-squares form of the same energy (A = M^T M with M = A^(1/2) is awkward; use
  // M = A itself: 1/2 |A x - r|^2 has Hessian A^T A) agrees with its dense counterpart.
  const Eigen::MatrixXd da(a), r = random_matrix(n, 3, seed + 11);
  Eigen::MatrixXd hessian = da.transpose() * da, linear = da.transpose() * r;
  for (std::size_t k = 0; k < soft.unknowns.size(); ++k) {
    hessian(soft.unknowns[k], soft.unknowns[k]) += soft.weights[k];
    linear.row(soft.unknowns[k]) += soft.weights[k] * c.row(Eigen::Index(k));
  }
  const ConstrainedQuadratic ls = ConstrainedQuadratic::least_squares(a, split, soft);
  EXPECT_LT(relative_error(ls.assemble(ls.solve_free(r, y, c), y), kkt_solve(hessian, linear, split.fixed(), y)), 1e-9);
}

TEST_P(ConstrainedQuadraticTest, SoftWeightToInfinityApproachesHard) {
  const unsigned seed = GetParam();
  const int n = 60;
  const SparseMatrix a = random_spd(n, seed);
  std::vector<char> fixed = random_fixed(n, 0.2, seed + 12), harder = fixed;
  std::vector<int> pulled;
  for (int i = 2; i < n; i += 7)
    if (!fixed[i]) pulled.push_back(i), harder[i] = 1;
  const UnknownSplit split(fixed), hard_split(harder);
  const Eigen::MatrixXd b = random_matrix(n, 3, seed + 13), y = random_matrix(Eigen::Index(split.fixed().size()), 3, seed + 14);
  const Eigen::MatrixXd c = random_matrix(Eigen::Index(pulled.size()), 3, seed + 15);
  // The hard solution: the pulled unknowns fixed at their targets.
  Eigen::MatrixXd hard_y(Eigen::Index(hard_split.fixed().size()), 3);
  for (std::size_t i = 0; i < split.fixed().size(); ++i) hard_y.row(hard_split.fixed_index(split.fixed()[i])) = y.row(Eigen::Index(i));
  for (std::size_t k = 0; k < pulled.size(); ++k) hard_y.row(hard_split.fixed_index(pulled[k])) = c.row(Eigen::Index(k));
  const ConstrainedQuadratic hard = ConstrainedQuadratic::quadratic(a, hard_split, {});
  const Eigen::MatrixXd want = hard.assemble(hard.solve_free(free_rows(b, hard_split), hard_y, Eigen::MatrixXd(0, 3)), hard_y);
  std::vector<double> errors;
  for (double w : {1e2, 1e4, 1e6}) {
    const ConstrainedQuadratic q =
        ConstrainedQuadratic::quadratic(a, split, {pulled, std::vector<double>(pulled.size(), w)});
    const Eigen::MatrixXd x = q.assemble(q.solve_free(free_rows(b, split), y, c), y);
    errors.push_back((x - want).cwiseAbs().maxCoeff());
  }
  // A penalty method: the error falls like 1/w.
  EXPECT_GT(errors[0] / errors[1], 50.0);
  EXPECT_GT(errors[1] / errors[2], 50.0);
  EXPECT_LT(errors[2], 1e-4);
}

TEST_P(ConstrainedQuadraticTest, RidgePicksTheMinimiserNearestTheGuess) {
  const unsigned seed = GetParam();
  const int n = 40;
  // Two components of a graph Laplacian (no diagonal shift); only the first is pinned, so the
  // second may translate freely: the least-squares system is singular without the ridge.
  SparseMatrix l(n, n);
  {
    const SparseMatrix left = random_spd(n / 2, seed, 0.0), right = random_spd(n / 2, seed + 1, 0.0);
    std::vector<Eigen::Triplet<double>> e;
    for (const auto& [m, offset] : {std::pair{&left, 0}, std::pair{&right, n / 2}})
      for (int k = 0; k < m->outerSize(); ++k)
        for (SparseMatrix::InnerIterator it(*m, k); it; ++it)
          e.emplace_back(int(it.row()) + offset, int(it.col()) + offset, it.value());
    l.setFromTriplets(e.begin(), e.end());
  }
  std::vector<char> fixed(n, 0);
  fixed[0] = fixed[3] = 1;
  const UnknownSplit split(fixed);
  const Eigen::MatrixXd y = random_matrix(2, 3, seed + 2), guess = random_matrix(n - 2, 3, seed + 3);
  const ConstrainedQuadratic q = ConstrainedQuadratic::least_squares(l, split, {}, 1e-6);
  ASSERT_TRUE(q.factorised());
  ASSERT_GT(q.ridge(), 0.0);
  const Eigen::MatrixXd x = q.solve_free({}, y, Eigen::MatrixXd(0, 3), guess);
  // Dense: (L_f^T L_f + rho I) x_f = -L_f^T L_k y + rho g.
  const Eigen::MatrixXd dl(l);
  Eigen::MatrixXd lf(n, n - 2), lk(n, 2);
  for (std::size_t i = 0; i < split.free().size(); ++i) lf.col(Eigen::Index(i)) = dl.col(split.free()[i]);
  for (std::size_t i = 0; i < split.fixed().size(); ++i) lk.col(Eigen::Index(i)) = dl.col(split.fixed()[i]);
  const Eigen::MatrixXd normal = lf.transpose() * lf;
  EXPECT_DOUBLE_EQ(q.ridge(), 1e-6 * normal.trace() / double(n - 2));
  const Eigen::MatrixXd want =
      (normal + q.ridge() * Eigen::MatrixXd::Identity(n - 2, n - 2)).ldlt().solve(-lf.transpose() * (lk * y) + q.ridge() * guess);
  EXPECT_LT(relative_error(x, want), 1e-6);
  // The free component moved as a whole towards the guess: its mean is the guess's mean.
  const Eigen::RowVectorXd mean = x.bottomRows(n / 2).colwise().mean(), guess_mean = guess.bottomRows(n / 2).colwise().mean();
  EXPECT_LT((mean - guess_mean).cwiseAbs().maxCoeff(), 1e-6);
}

INSTANTIATE_TEST_SUITE_P(Seeds, ConstrainedQuadraticTest, ::testing::Values(1u, 2u, 3u));

TEST(ConstrainedQuadratic, NotPositiveDefiniteIsReported) {
  SparseMatrix a = random_spd(20, 5);
  a.coeffRef(7, 7) = -50.0;
  EXPECT_FALSE(ConstrainedQuadratic::quadratic(a, UnknownSplit(std::vector<char>(20, 0)), {}).factorised());
  std::vector<char> fixed(20, 0);
  fixed[7] = 1;  // without its row and column the rest is positive definite
  EXPECT_TRUE(ConstrainedQuadratic::quadratic(a, UnknownSplit(fixed), {}).factorised());
}

TEST(ConstrainedQuadratic, NothingFreeGivesTheFixedValues) {
  const SparseMatrix a = random_spd(10, 6);
  const UnknownSplit split(std::vector<char>(10, 1));
  const Eigen::MatrixXd y = random_matrix(10, 3, 7);
  const ConstrainedQuadratic q = ConstrainedQuadratic::quadratic(a, split, {});
  EXPECT_TRUE(q.factorised());
  EXPECT_TRUE((q.assemble(q.solve_free({}, y, Eigen::MatrixXd(0, 3)), y).array() == y.array()).all());
}

TEST(MinQuadraticWithFixed, MatchesDenseKktForUnsortedFixedIndices) {
  const int n = 50;
  const SparseMatrix a = random_spd(n, 9);
  const std::vector<int> fixed{31, 4, 17, 0};
  const Eigen::MatrixXd b = random_matrix(n, 2, 10), y = random_matrix(4, 2, 11);
  const Eigen::MatrixXd x = min_quadratic_with_fixed(a, b, fixed, y);
  EXPECT_LT(relative_error(x, kkt_solve(Eigen::MatrixXd(a), b, fixed, y)), 1e-10);
  for (std::size_t k = 0; k < fixed.size(); ++k) EXPECT_TRUE((x.row(fixed[k]).array() == y.row(Eigen::Index(k)).array()).all());
  EXPECT_THROW(min_quadratic_with_fixed(a, b, {3, 3}, random_matrix(2, 2, 12)), std::invalid_argument);
}

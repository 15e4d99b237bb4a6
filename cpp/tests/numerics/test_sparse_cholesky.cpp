// SparseCholesky (CHOLMOD factor, own multi-column parallel solve) against Eigen's SimplicialLDLT.
#include "numerics/cholesky_factor.hpp"
#include "numerics/supernodal_factor.hpp"
#include "deformkit/numerics/sparse_cholesky.hpp"

#include <Eigen/SparseCholesky>
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

using namespace deformkit;

namespace {

// A grid Laplacian with random positive weights plus a small diagonal: symmetric positive definite,
// with the separator structure of a mesh. n x n vertices; `squared` gives the wider stencil of L^T L.
SparseMatrix grid_system(int n, bool squared, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> weight(0.1, 2.0);
  std::vector<Eigen::Triplet<double>> e;
  auto id = [n](int i, int j) { return i * n + j; };
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      e.emplace_back(id(i, j), id(i, j), 1e-3);
      for (auto [di, dj] : {std::pair{1, 0}, std::pair{0, 1}, std::pair{1, 1}}) {
        if (i + di >= n || j + dj >= n) continue;
        const double w = weight(rng);
        const int a = id(i, j), b = id(i + di, j + dj);
        e.emplace_back(a, a, w), e.emplace_back(b, b, w), e.emplace_back(a, b, -w), e.emplace_back(b, a, -w);
      }
    }
  SparseMatrix l(n * n, n * n);
  l.setFromTriplets(e.begin(), e.end());
  return squared ? SparseMatrix(SparseMatrix(l.transpose()) * l) : l;
}

}  // namespace

class SparseCholeskyTest : public ::testing::TestWithParam<std::tuple<CholeskyKind, bool, int>> {};

TEST_P(SparseCholeskyTest, MatchesEigenForEveryColumnCount) {
  const auto [kind, squared, columns] = GetParam();
  const SparseMatrix a = grid_system(squared ? 120 : 200, squared, 7);
  SparseCholesky chol;
  ASSERT_TRUE(chol.factorize(a, kind));
  EXPECT_GT(chol.factor_nonzeros(), std::size_t(a.nonZeros() / 2));
  const Eigen::MatrixXd b = Eigen::MatrixXd::Random(a.rows(), columns);
  const Eigen::MatrixXd x = chol.solve(b);
  const Eigen::SimplicialLDLT<SparseMatrix> eigen(a);
  for (int c = 0; c < columns; ++c) {
    const Eigen::VectorXd want = eigen.solve(b.col(c));
    EXPECT_LT((x.col(c) - want).cwiseAbs().maxCoeff(), 1e-8 * want.cwiseAbs().maxCoeff()) << "column " << c;
  }
  EXPECT_LT((a * x - b).norm(), 1e-9 * b.norm());
}

INSTANTIATE_TEST_SUITE_P(Kinds, SparseCholeskyTest,
                         ::testing::Combine(::testing::Values(CholeskyKind::Simplicial, CholeskyKind::Supernodal),
                                            ::testing::Bool(), ::testing::Values(1, 3, 5)));

// An indefinite matrix that CHOLMOD's L D L^T factors without complaint (one negative pivot):
// deformkit's own check of D refuses it.
TEST(SparseCholesky, RefusesANegativePivot) {
  SparseMatrix a(2, 2);
  a.insert(0, 0) = 1.0;
  a.insert(1, 1) = -1.0;
  SparseCholesky chol;
  EXPECT_FALSE(chol.factorize(a, CholeskyKind::Simplicial));
  EXPECT_TRUE(chol.empty());
}

TEST(SparseCholesky, RefusesAnIndefiniteMatrix) {
  SparseMatrix a = grid_system(20, false, 3);
  a.coeffRef(17, 17) = -5.0;
  for (CholeskyKind kind : {CholeskyKind::Simplicial, CholeskyKind::Supernodal}) {
    SparseCholesky chol;
    EXPECT_FALSE(chol.factorize(a, kind));
    EXPECT_TRUE(chol.empty());
  }
}

// Eigen's L L^T factor, re-packed: checks CholeskyFactor independently of CHOLMOD.
CholeskyFactor from_eigen(const Eigen::SimplicialLLT<SparseMatrix>& llt) {
  const SparseMatrix l = llt.matrixL();
  CholeskyFactor f;
  f.unit_diagonal = false;
  f.start.assign(l.outerIndexPtr(), l.outerIndexPtr() + l.cols() + 1);
  f.row.assign(l.innerIndexPtr(), l.innerIndexPtr() + l.nonZeros());
  f.value.assign(l.valuePtr(), l.valuePtr() + l.nonZeros());
  f.perm.resize(std::size_t(l.cols()));
  for (Eigen::Index i = 0; i < l.cols(); ++i) f.perm[std::size_t(llt.permutationP().indices()[i])] = i;
  return f;
}

// Eigen's factor is not postordered, so it is solved on one core: the L L^T path on its own.
TEST(CholeskyFactor, SolvesEigensFactor) {
  const SparseMatrix a = grid_system(60, true, 5);
  const Eigen::SimplicialLLT<SparseMatrix> llt(a);
  const Eigen::MatrixXd b = Eigen::MatrixXd::Random(a.rows(), 2);
  const Eigen::MatrixXd want = llt.solve(b);
  CholeskyFactor f = from_eigen(llt);
  f.schedule(2);
  EXPECT_EQ(f.ranges.size(), 1u);  // not postordered: one core
  Eigen::MatrixXd x(a.rows(), 2);
  f.solve(b.data(), x.data(), 2);
  EXPECT_LT((x - want).cwiseAbs().maxCoeff(), 1e-9 * want.cwiseAbs().maxCoeff());
}

// On CHOLMOD's (postordered) factor the split over cores covers every column once, with whole
// subtrees per core, and solves the same for any number of cores.
TEST(CholeskyFactor, ScheduleCoversEveryColumnOnceAndSolvesTheSame) {
  for (CholeskyKind kind : {CholeskyKind::Simplicial, CholeskyKind::Supernodal}) {
  const SparseMatrix a = grid_system(160, true, 11);
  SparseCholesky chol;
  ASSERT_TRUE(chol.factorize(a, kind));
  const Eigen::SimplicialLDLT<SparseMatrix> ldlt(a);
  const Eigen::MatrixXd b = Eigen::MatrixXd::Random(a.rows(), 3);
  const Eigen::MatrixXd want = ldlt.solve(b);
  for (int threads : {1, 2, 3, 8}) {
    CholeskyFactor f = chol.factor();
    f.schedule(threads);
    std::vector<int> seen(f.size(), 0);
    for (const auto& list : f.ranges)
      for (const auto& [lo, hi] : list)
        for (auto j = lo; j <= hi; ++j) ++seen[std::size_t(j)];
    for (auto j : f.top) ++seen[std::size_t(j)];
    EXPECT_EQ(*std::min_element(seen.begin(), seen.end()), 1) << threads;
    EXPECT_EQ(*std::max_element(seen.begin(), seen.end()), 1) << threads;
    if (threads > 1) EXPECT_GT(f.ranges[1].size(), 0u) << "no work for the second core";
    Eigen::MatrixXd x(a.rows(), 3);
    f.solve(b.data(), x.data(), 3);
    EXPECT_LT((x - want).cwiseAbs().maxCoeff(), 1e-8 * want.cwiseAbs().maxCoeff()) << threads;
  }
  }
}

// The supernodal factor is solved in place, split over cores by whole subtrees of supernodes:
// every supernode is solved once, for any number of cores, and the solution is the same.
TEST(SupernodalFactor, ScheduleCoversEverySupernodeOnceAndSolvesTheSame) {
  for (bool squared : {false, true}) {
    const SparseMatrix a = grid_system(squared ? 160 : 300, squared, 13);
    SparseCholesky chol;
    ASSERT_TRUE(chol.factorize(a, CholeskyKind::Supernodal));
    ASSERT_NE(chol.supernodal_factor(), nullptr);
    const Eigen::SimplicialLDLT<SparseMatrix> ldlt(a);
    const Eigen::MatrixXd b = Eigen::MatrixXd::Random(a.rows(), 13);  // blocks of 12 and 1
    const Eigen::MatrixXd want = ldlt.solve(b);
    for (int threads : {1, 2, 3, 8}) {
      SupernodalFactor f = *chol.supernodal_factor();
      f.schedule(threads);
      std::vector<int> seen(std::size_t(f.supernodes), 0);
      for (const auto& list : f.ranges)
        for (const auto& [lo, hi] : list)
          for (auto s = lo; s <= hi; ++s) ++seen[std::size_t(s)];
      for (auto s : f.top) ++seen[std::size_t(s)];
      EXPECT_EQ(*std::min_element(seen.begin(), seen.end()), 1) << threads;
      EXPECT_EQ(*std::max_element(seen.begin(), seen.end()), 1) << threads;
      if (threads > 1) EXPECT_GT(f.ranges[1].size(), 0u) << "no work for the second core";
      Eigen::MatrixXd x(a.rows(), b.cols());
      f.solve(b.data(), x.data(), int(b.cols()));
      EXPECT_LT((x - want).cwiseAbs().maxCoeff(), 1e-8 * want.cwiseAbs().maxCoeff()) << threads;
    }
  }
}

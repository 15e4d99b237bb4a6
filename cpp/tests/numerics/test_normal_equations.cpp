// The bind's assembly helpers (numerics/normal_equations, fill_ordering) against Eigen's own
// products and selections, and the ordering memory's contract.
#include "numerics/fill_ordering.hpp"
#include "numerics/normal_equations.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

using namespace deformkit;

namespace {

// rows x cols with about `per_column` random entries a column, some columns left empty.
SparseMatrix random_sparse(int rows, int cols, int per_column, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> row(0, rows - 1);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  std::vector<Eigen::Triplet<double>> e;
  for (int c = 0; c < cols; ++c)
    if (c % 7 != 3)
      for (int k = 0; k < per_column; ++k) e.emplace_back(row(rng), c, value(rng));
  SparseMatrix m(rows, cols);
  m.setFromTriplets(e.begin(), e.end());
  return m;
}

Eigen::MatrixXd dense_lower(const SymmetricLower& a) {
  Eigen::MatrixXd d = Eigen::MatrixXd::Zero(a.n, a.n);
  for (std::int64_t j = 0; j < a.n; ++j) {
    EXPECT_EQ(a.row[std::size_t(a.start[std::size_t(j)])], j) << "the diagonal comes first";
    for (std::int64_t e = a.start[std::size_t(j)]; e < a.start[std::size_t(j) + 1]; ++e) {
      if (e > a.start[std::size_t(j)]) EXPECT_GT(a.row[std::size_t(e)], a.row[std::size_t(e) - 1]) << "rows ascending";
      d(a.row[std::size_t(e)], j) = a.value[std::size_t(e)];
    }
  }
  return d;
}

}  // namespace

// Both the one-block path (small) and the pool's blocks (above the parallel grain).
TEST(NormalEquations, MatchEigensProductInTheLowerTriangle) {
  for (int cols : {60, 20000}) {
    const SparseMatrix m = random_sparse(cols + 17, cols, 4, 3);
    const SymmetricLower n = normal_equations(m);
    ASSERT_EQ(n.n, cols);
    const SparseMatrix want = SparseMatrix(m.transpose()) * m;
    if (cols <= 60) {
      const Eigen::MatrixXd full(want);
      const Eigen::MatrixXd got = dense_lower(n);
      EXPECT_LT((got - Eigen::MatrixXd(full.triangularView<Eigen::Lower>())).cwiseAbs().maxCoeff(), 1e-14);
    } else {
      double worst = 0;
      for (Eigen::Index j = 0; j < want.cols(); ++j)
        for (SparseMatrix::InnerIterator it(want, j); it; ++it) {
          if (it.row() < j) continue;
          const auto begin = n.row.begin() + n.start[std::size_t(j)], end = n.row.begin() + n.start[std::size_t(j) + 1];
          const auto at = std::lower_bound(begin, end, std::int64_t(it.row()));
          ASSERT_TRUE(at != end && *at == it.row());
          worst = std::max(worst, std::abs(n.value[std::size_t(at - n.row.begin())] - it.value()));
        }
      EXPECT_LT(worst, 1e-14);
    }
  }
}

TEST(NormalEquations, LowerTriangleKeepsTheLowerHalfAndEveryDiagonal) {
  SparseMatrix a = random_sparse(40, 40, 3, 5);
  a = SparseMatrix(a + SparseMatrix(a.transpose()));
  a.prune(0.0);
  const Eigen::MatrixXd want = Eigen::MatrixXd(a).triangularView<Eigen::Lower>();
  EXPECT_EQ((dense_lower(lower_triangle(a)) - want).cwiseAbs().maxCoeff(), 0.0);
}

TEST(NormalEquations, SelectColumnsAndRows) {
  const SparseMatrix m = random_sparse(30, 25, 4, 7);
  std::vector<int> cols(25, -1), rows(30, -1);
  int nc = 0, nr = 0;
  for (int c = 0; c < 25; ++c)
    if (c % 3) cols[std::size_t(c)] = nc++;
  for (int r = 0; r < 30; ++r)
    if (r % 4) rows[std::size_t(r)] = nr++;
  const Eigen::MatrixXd full(m);
  const Eigen::MatrixXd got(select_columns(m, cols, nc, &rows, nr));
  for (int r = 0; r < 30; ++r)
    for (int c = 0; c < 25; ++c)
      if (rows[std::size_t(r)] >= 0 && cols[std::size_t(c)] >= 0) EXPECT_EQ(got(rows[std::size_t(r)], cols[std::size_t(c)]), full(r, c));
  const Eigen::MatrixXd all_rows(select_columns(m, cols, nc));
  EXPECT_EQ(all_rows.rows(), 30);
  for (int c = 0; c < 25; ++c)
    if (cols[std::size_t(c)] >= 0) EXPECT_EQ((all_rows.col(cols[std::size_t(c)]) - full.col(c)).norm(), 0.0);
}

TEST(FillOrdering, AmdIsAPermutationAndItsRestrictionKeepsTheOrder) {
  const SparseMatrix m = random_sparse(300, 200, 3, 11);
  const Ordering perm = amd_ordering(normal_equations(m));
  Ordering sorted = perm;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t k = 0; k < sorted.size(); ++k) ASSERT_EQ(sorted[k], std::int64_t(k));
  std::vector<int> keep(200, -1);
  int kept = 0;
  for (int i = 0; i < 200; ++i)
    if (i % 5) keep[std::size_t(i)] = kept++;
  const Ordering three = restricted_ordering(perm, keep, 3);
  ASSERT_EQ(three.size(), std::size_t(3 * kept));
  std::size_t at = 0;
  for (std::int64_t i : perm) {
    if (keep[std::size_t(i)] < 0) continue;
    for (int a = 0; a < 3; ++a) EXPECT_EQ(three[at++], 3 * keep[std::size_t(i)] + a);
  }
}

TEST(FillOrdering, RememberedByKeyUntilPushedOut) {
  int computed = 0;
  auto make = [&] { ++computed; return Ordering{2, 0, 1}; };
  bool hit = true;
  const std::uint64_t key = 0x7e57ull << 32;
  const auto first = remembered_ordering(key, make, &hit);
  EXPECT_FALSE(hit);
  const auto again = remembered_ordering(key, make, &hit);
  EXPECT_TRUE(hit);
  EXPECT_EQ(first.get(), again.get());
  EXPECT_EQ(computed, 1);
  for (std::uint64_t k = 1; k <= 8; ++k) remembered_ordering(key + k, make);  // eight newer keys
  remembered_ordering(key, make, &hit);
  EXPECT_FALSE(hit);
  EXPECT_EQ(*first, (Ordering{2, 0, 1}));  // a caller's copy outlives its eviction
}

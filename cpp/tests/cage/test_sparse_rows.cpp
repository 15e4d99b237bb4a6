// The sparse row kernel (cpp/src/cage/sparse_rows.hpp) against a plain double loop over the same
// CSR table, with the a-priori bound on any order of summation: |computed - exact| <= n u sum|w c|
// for n products, any order (Higham, "Accuracy and Stability of Numerical Algorithms", 2nd ed.,
// Section 3.1: gamma_n sum|x y|).
#include "cage/sparse_rows.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

using namespace deformkit;

namespace {

struct Table {
  std::vector<std::int64_t> indptr{0};
  std::vector<std::int32_t> indices;
  std::vector<double> values;
  std::size_t rows() const { return indptr.size() - 1; }
};

// Row lengths 0 (empty), 1, 2..7 (below the kernel's four-way unroll and its tails), and long rows;
// columns drawn at random, each row also holding column 0 or the last column now and then.
Table random_table(std::size_t rows, std::size_t columns, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> value(-1.5, 1.5);
  std::uniform_int_distribution<std::int32_t> column(0, std::int32_t(columns) - 1);
  const std::size_t lengths[] = {0, 1, 2, 3, 4, 5, 7, 8, 13, 64, 301, 1000};
  Table t;
  for (std::size_t r = 0; r < rows; ++r) {
    const std::size_t len = lengths[rng() % (sizeof(lengths) / sizeof(lengths[0]))];
    for (std::size_t k = 0; k < len; ++k) {
      const unsigned pick = rng() % 8;
      t.indices.push_back(pick == 0 ? 0 : pick == 1 ? std::int32_t(columns) - 1 : column(rng));
      t.values.push_back(value(rng));
    }
    t.indptr.push_back(std::int64_t(t.indices.size()));
  }
  return t;
}

template <class V>
void expect_matches_plain_loop(const Table& t, const std::vector<V>& values, const std::vector<double>& control) {
  const PaddedControlRows c4(control.data(), control.size() / 3);
  std::vector<double> got(3 * t.rows());
  sparse_rows_product(t.indptr.data(), t.indices.data(), values.data(), t.rows(), c4.rows(), got.data());
  constexpr double u = 0x1p-53;
  for (std::size_t r = 0; r < t.rows(); ++r) {
    for (int a = 0; a < 3; ++a) {
      double want = 0.0, magnitude = 0.0;
      for (std::int64_t k = t.indptr[r]; k < t.indptr[r + 1]; ++k) {
        const double p = double(values[k]) * control[3 * std::size_t(t.indices[k]) + a];
        want += p;
        magnitude += std::abs(p);
      }
      const double n = double(t.indptr[r + 1] - t.indptr[r]);
      // Both sums carry at most n u magnitude each (to first order).
      ASSERT_LE(std::abs(got[3 * r + a] - want), 2 * n * u * magnitude * (1 + 1e-6)) << "row " << r << " axis " << a;
      if (n == 0) ASSERT_EQ(got[3 * r + a], 0.0);
      if (n == 1) ASSERT_EQ(got[3 * r + a], want);  // one product: no sum to round
    }
  }
}

std::vector<double> random_control(std::size_t columns, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-10.0, 10.0);
  std::vector<double> c(3 * columns);
  for (auto& v : c) v = u(rng);
  return c;
}

}  // namespace

TEST(SparseRows, Float64ValuesMatchAPlainLoop) {
  for (std::size_t columns : {1u, 2u, 8u, 152u, 70000u}) {
    const Table t = random_table(400, columns, unsigned(columns));
    expect_matches_plain_loop(t, t.values, random_control(columns, 7));
  }
}

TEST(SparseRows, Float32ValuesAreWidenedExactly) {
  for (std::size_t columns : {1u, 152u, 4096u}) {
    const Table t = random_table(400, columns, 11 + unsigned(columns));
    const std::vector<float> values(t.values.begin(), t.values.end());
    expect_matches_plain_loop(t, values, random_control(columns, 5));
  }
}

TEST(SparseRows, ARowGivesTheSameBitsInAnyCall) {
  const std::size_t columns = 97;
  const Table t = random_table(300, columns, 3);
  const auto control = random_control(columns, 4);
  const PaddedControlRows c4(control.data(), columns);
  std::vector<double> all(3 * t.rows()), one(3);
  sparse_rows_product(t.indptr.data(), t.indices.data(), t.values.data(), t.rows(), c4.rows(), all.data());
  for (std::size_t r = 0; r < t.rows(); ++r) {
    sparse_rows_product(t.indptr.data() + r, t.indices.data(), t.values.data(), 1, c4.rows(), one.data());
    for (int a = 0; a < 3; ++a) ASSERT_EQ(one[a], all[3 * r + a]) << r;
  }
}

TEST(SparseRows, PaddedControlRowsAreAlignedCopies) {
  for (std::size_t columns : {1u, 3u, 50u}) {
    const auto control = random_control(columns, unsigned(columns));
    PaddedControlRows c4(control.data(), columns);
    const PaddedControlRows moved = std::move(c4);
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(moved.rows()) % 32, 0u);
    for (std::size_t j = 0; j < columns; ++j) {
      for (int a = 0; a < 3; ++a) EXPECT_EQ(moved.rows()[4 * j + a], control[3 * j + a]);
      EXPECT_EQ(moved.rows()[4 * j + 3], 0.0);
    }
  }
}

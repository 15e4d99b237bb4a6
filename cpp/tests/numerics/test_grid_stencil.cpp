// The grid solver (multigrid-preconditioned CG over blocks of right-hand sides) on Mesh Deform's
// system built from a union of balls: residuals measured with an independent sparse product,
// CHOLMOD's solution, linear boundary values (which the cut-edge stencil reproduces exactly),
// streaming, refused systems and bitwise determinism.
#include "numerics/grid_stencil_solver.hpp"
#include "numerics/grid_stencil_shapes.hpp"
#include "deformkit/numerics/sparse_cholesky.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <utility>
#include <vector>

using namespace deformkit;
using numerics::GridStencil;
using test::ShapeSystem;

namespace {

SparseMatrix sparse_matrix(const GridStencil& s) {
  std::vector<Eigen::Triplet<double>> e;
  const auto& n = s.cells;
  const int stride[3] = {1, n[0], n[0] * n[1]};
  for (int c = 0; c < n[0] * n[1] * n[2]; ++c) {
    const int u = s.unknown[std::size_t(c)];
    if (u < 0) continue;
    e.emplace_back(u, u, s.diagonal[std::size_t(u)]);
    for (int d = 0; d < 6; ++d) {
      const double w = s.coupling[std::size_t(u)][std::size_t(d)];
      if (w != 0.0) e.emplace_back(u, s.unknown[std::size_t(c + (d % 2 ? 1 : -1) * stride[d / 2])], -w);
    }
  }
  SparseMatrix a(Eigen::Index(s.diagonal.size()), Eigen::Index(s.diagonal.size()));
  a.setFromTriplets(e.begin(), e.end());
  return a;
}

// The boundary values x, y, z and x y.
Eigen::MatrixXd smooth_rhs(const ShapeSystem& s) {
  Eigen::MatrixXd b(Eigen::Index(s.centre.size()), 4);
  b.col(0) = s.rhs([](const Eigen::Vector3d& p) { return p.x(); });
  b.col(1) = s.rhs([](const Eigen::Vector3d& p) { return p.y(); });
  b.col(2) = s.rhs([](const Eigen::Vector3d& p) { return p.z(); });
  b.col(3) = s.rhs([](const Eigen::Vector3d& p) { return p.x() * p.y(); });
  return b;
}

struct Calls {
  std::vector<std::pair<int, int>> fill, take;  // (first, columns)
};

Eigen::MatrixXd solve(const GridStencil& s, const Eigen::MatrixXd& b, int block, double tol, Calls* calls = nullptr,
                      const numerics::GridSolveOptions& options = {}, numerics::GridSolveReport* report = nullptr) {
  Eigen::MatrixXd x = Eigen::MatrixXd::Constant(b.rows(), b.cols(), std::nan(""));
  numerics::solve_grid_stencil(
      s, int(b.cols()), block,
      [&](int first, Eigen::Ref<Eigen::MatrixXd> out) {
        if (calls) calls->fill.emplace_back(first, int(out.cols()));
        out = b.middleCols(first, out.cols());
      },
      [&](int first, const Eigen::Ref<const Eigen::MatrixXd>& sol) {
        if (calls) calls->take.emplace_back(first, int(sol.cols()));
        x.middleCols(first, sol.cols()) = sol;
      },
      tol, options, report);
  return x;
}

// The smallest eigenvalue of a, by inverse iteration from above (a lower bound of 1 / ||A^-1||
// would need more; the tests allow a factor 2).
double smallest_eigenvalue(const SparseMatrix& a, const SparseCholesky& chol) {
  Eigen::MatrixXd v = Eigen::MatrixXd::Ones(a.rows(), 1).normalized();
  double lambda = 0.0;
  for (int it = 0; it < 60; ++it) {
    const Eigen::MatrixXd w = chol.solve(v);
    lambda = 1.0 / w.norm();
    v = w.normalized();
  }
  return lambda;
}

}  // namespace

TEST(GridStencil, ResidualBelowToleranceForEveryColumn) {
  const ShapeSystem s = test::shape_system(test::figure(), 40);
  const SparseMatrix a = sparse_matrix(s.stencil);
  const Eigen::MatrixXd b = smooth_rhs(s);
  // Below the single-precision cycle's rounding too: the tolerance is the conjugate gradients' business.
  for (double tol : {1e-4, 1e-8, 1e-11}) {
    numerics::GridSolveReport report;
    const Eigen::MatrixXd x = solve(s.stencil, b, 3, tol, nullptr, {}, &report);
    for (int c = 0; c < b.cols(); ++c) EXPECT_LE((b.col(c) - a * x.col(c)).norm(), tol * b.col(c).norm()) << "tol " << tol << " column " << c;
    EXPECT_GE(report.levels, 3);  // 40 -> 20 -> 10 -> 5 cells a side
  }
}

TEST(GridStencil, MultigridKeepsIterationsFewAsTheGridRefines) {
  // Geometric multigrid's promise: the steps to a tolerance barely grow with the grid.
  std::vector<int> steps;
  for (int n : {20, 40, 80}) {
    const ShapeSystem s = test::shape_system(test::figure(), n);
    numerics::GridSolveReport report;
    solve(s.stencil, smooth_rhs(s), 4, 1e-8, nullptr, {}, &report);
    steps.push_back(report.iterations.at(0));
  }
  EXPECT_LE(steps[2], 20) << steps[0] << " " << steps[1] << " " << steps[2];
  EXPECT_LE(steps[2], steps[1] + 3) << steps[0] << " " << steps[1] << " " << steps[2];
}

// A fat domain (FireHydrant-like, 29% of the box) of 256k unknowns, 5 levels: the coarse
// correction's over-relaxation (1.95) keeps CG at 8 steps to 1e-8 where 1.8 took 10, and the
// restriction that skips the just-swept rows changes the cycle by rounding only.
TEST(GridStencil, FewStepsOnALargeFatDomain) {
  const ShapeSystem s = test::shape_system(test::one_ball(), 96);
  const SparseMatrix a = sparse_matrix(s.stencil);
  const Eigen::MatrixXd b = smooth_rhs(s);
  numerics::GridSolveReport report;
  const Eigen::MatrixXd x = solve(s.stencil, b, 4, 1e-8, nullptr, {}, &report);
  for (int c = 0; c < b.cols(); ++c) EXPECT_LE((b.col(c) - a * x.col(c)).norm(), 1e-8 * b.col(c).norm()) << "column " << c;
  EXPECT_LE(report.iterations.at(0), 8) << s.centre.size() << " unknowns, " << report.levels << " levels";
}

TEST(GridStencil, AgreesWithCholmodToTheToleranceImpliedAccuracy) {
  for (const auto& shape : {test::one_ball(), test::figure()}) {
    const ShapeSystem s = test::shape_system(shape, 24);
    const SparseMatrix a = sparse_matrix(s.stencil);
    SparseCholesky chol;
    ASSERT_TRUE(chol.factorize(a, CholeskyKind::Supernodal));
    const Eigen::MatrixXd b = smooth_rhs(s);
    const Eigen::MatrixXd want = chol.solve(b);
    const double tol = 1e-9;
    const Eigen::MatrixXd x = solve(s.stencil, b, 4, tol);
    // ||x - x*|| <= ||A^-1|| ||b - A x|| <= tol ||b|| / lambda_min
    const double inverse_norm = 1.0 / smallest_eigenvalue(a, chol);
    for (int c = 0; c < b.cols(); ++c) {
      const double err = (x.col(c) - want.col(c)).norm();
      EXPECT_LE(err, 2.0 * inverse_norm * tol * b.col(c).norm()) << "column " << c;
      EXPECT_LE(err, 1e-6 * want.col(c).norm()) << "column " << c;
    }
  }
}

TEST(GridStencil, LinearBoundaryValuesAreReproducedExactly) {
  // Each axis's two edges of Sum w (u_i - u_j) cancel for a linear u, cut or not, since the weight
  // of an edge is 1 / its length: linear boundary values give the linear function at every centre.
  const ShapeSystem s = test::shape_system(test::figure(), 36);
  const Eigen::Vector3d g(0.3, -1.1, 0.7);
  Eigen::MatrixXd b(Eigen::Index(s.centre.size()), 1);
  b.col(0) = s.rhs([&](const Eigen::Vector3d& p) { return g.dot(p) + 2.0; });
  const Eigen::MatrixXd x = solve(s.stencil, b, 1, 1e-12);
  double worst = 0.0;
  for (std::size_t u = 0; u < s.centre.size(); ++u) worst = std::max(worst, std::abs(x(Eigen::Index(u), 0) - (g.dot(s.centre[u]) + 2.0)));
  EXPECT_LT(worst, 1e-8);
}

TEST(GridStencil, StreamsBlocksInOrderForAnyBlockSize) {
  const ShapeSystem s = test::shape_system(test::one_ball(), 16);
  const SparseMatrix a = sparse_matrix(s.stencil);
  Eigen::MatrixXd b(Eigen::Index(s.centre.size()), 7);
  for (int c = 0; c < 7; ++c) b.col(c) = s.rhs([c](const Eigen::Vector3d& p) { return std::sin(1.0 + c * p.x()) + p.y() * p.z() * c; });
  for (int block : {1, 2, 3, 7, 12}) {
    Calls calls;
    const Eigen::MatrixXd x = solve(s.stencil, b, block, 1e-9, &calls);
    std::vector<std::pair<int, int>> want;
    for (int first = 0; first < 7; first += block) want.emplace_back(first, std::min(block, 7 - first));
    EXPECT_EQ(calls.fill, want) << "block " << block;
    EXPECT_EQ(calls.take, want) << "block " << block;
    for (int c = 0; c < 7; ++c) EXPECT_LE((b.col(c) - a * x.col(c)).norm(), 1e-9 * b.col(c).norm()) << "block " << block << " column " << c;
  }
  Calls none;
  solve(s.stencil, Eigen::MatrixXd(Eigen::Index(s.centre.size()), 0), 4, 1e-8, &none);
  EXPECT_TRUE(none.fill.empty() && none.take.empty());
}

TEST(GridStencil, ZeroRightHandSideGivesZero) {
  const ShapeSystem s = test::shape_system(test::one_ball(), 12);
  Eigen::MatrixXd b = Eigen::MatrixXd::Zero(Eigen::Index(s.centre.size()), 2);
  b.col(1) = s.rhs([](const Eigen::Vector3d& p) { return p.x(); });
  const Eigen::MatrixXd x = solve(s.stencil, b, 2, 1e-8);
  EXPECT_EQ(x.col(0).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_GT(x.col(1).cwiseAbs().maxCoeff(), 0.0);
}

TEST(GridStencil, SameBitsOnOneThreadAndOnThePool) {
  const ShapeSystem s = test::shape_system(test::one_ball(), 40);  // 18k unknowns: each colour's rows split on the pool
  const Eigen::MatrixXd b = smooth_rhs(s);
  numerics::GridSolveOptions serial;
  serial.serial = true;
  const Eigen::MatrixXd pooled = solve(s.stencil, b, 4, 1e-10);
  const Eigen::MatrixXd one = solve(s.stencil, b, 4, 1e-10, nullptr, serial);
  const Eigen::MatrixXd again = solve(s.stencil, b, 4, 1e-10);
  EXPECT_EQ(std::memcmp(pooled.data(), one.data(), sizeof(double) * std::size_t(b.size())), 0);
  EXPECT_EQ(std::memcmp(pooled.data(), again.data(), sizeof(double) * std::size_t(b.size())), 0);
}

namespace {

void expect_refused(const GridStencil& s, const std::string& message, int columns = 1, int block = 1, double tol = 1e-8) {
  Eigen::MatrixXd b = Eigen::MatrixXd::Ones(Eigen::Index(s.diagonal.size()), std::max(columns, 1));
  try {
    solve(s, b.leftCols(columns), block, tol);
    ADD_FAILURE() << "accepted; expected: " << message;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
  }
}

}  // namespace

TEST(GridStencil, RefusesSystemsThatAreNotSymmetricPositiveDefiniteStencils) {
  const GridStencil good = test::shape_system(test::one_ball(), 10).stencil;
  const int u = good.unknown[std::size_t(5 + 10 * (5 + 10 * 5))];  // the centre cell: all neighbours unknown
  ASSERT_GE(u, 0);
  GridStencil s = good;
  s.coupling[std::size_t(u)][1] *= 1.5;
  expect_refused(s, "system.coupling[" + std::to_string(u) + "][1] (+x of cell (5, 5, 5)) is 15.000000 but the neighbour's coupling back is 10.000000; the system must be symmetric");
  s = good, s.diagonal[std::size_t(u)] = 0.0;
  expect_refused(s, "system.diagonal[" + std::to_string(u) + "] is 0.000000; a diagonal must be positive and finite");
  s = good, s.diagonal[std::size_t(u)] = -1.0;
  expect_refused(s, "a diagonal must be positive");
  s = good, s.diagonal[std::size_t(u)] = std::nan("");
  expect_refused(s, "a diagonal must be positive and finite");
  s = good, s.diagonal[std::size_t(u)] = 30.0;
  expect_refused(s, "below the sum of its couplings 60.000000");
  s = good, s.diagonal.pop_back();
  expect_refused(s, "system.coupling has " + std::to_string(good.coupling.size()) + " rows and system.diagonal " + std::to_string(good.coupling.size() - 1));
  s = good, s.unknown.pop_back();
  expect_refused(s, "system.unknown has 999 entries; it needs one per cell, 1000");
  s = good, s.cells[2] = 0;
  expect_refused(s, "system.cells[2] is 0");
  s = good, s.unknown[0] = u;
  expect_refused(s, "gives index " + std::to_string(u) + " to two cells");
  s = good, s.unknown[0] = int(good.diagonal.size());
  expect_refused(s, "system.unknown of cell (0, 0, 0) is " + std::to_string(good.diagonal.size()));
  s = good, s.coupling[std::size_t(good.unknown[std::size_t(1 + 10 * (5 + 10 * 5))])][0] = 1.0;
  expect_refused(s, "-x of cell (1, 5, 5)) is 1.000000 but that neighbour is not an unknown");
  expect_refused(good, "block_columns is 0", 1, 0);
  expect_refused(good, "relative_tolerance is 0.000000", 1, 1, 0.0);
  expect_refused(good, "relative_tolerance is nan", 1, 1, std::nan(""));
  EXPECT_THROW(numerics::solve_grid_stencil(good, -1, 1, [](int, Eigen::Ref<Eigen::MatrixXd>) {}, [](int, const Eigen::Ref<const Eigen::MatrixXd>&) {}, 1e-8),
               std::invalid_argument);
  EXPECT_THROW(numerics::solve_grid_stencil(good, 1, 1, nullptr, [](int, const Eigen::Ref<const Eigen::MatrixXd>&) {}, 1e-8), std::invalid_argument);
}

TEST(GridStencil, RefusesAGroupWithoutCutEdgeAndNonFiniteRightHandSides) {
  // A 4 x 1 x 1 row of unknowns whose diagonals only hold their couplings: constants solve A u = 0.
  GridStencil s{{4, 1, 1}, {0, 1, 2, 3}, {1, 2, 2, 1}, {{{0, 1, 0, 0, 0, 0}}, {{1, 1, 0, 0, 0, 0}}, {{1, 1, 0, 0, 0, 0}}, {{1, 0, 0, 0, 0, 0}}}};
  expect_refused(s, "the 4 connected unknowns around cell (0, 0, 0) have no cut edge");
  s.diagonal[3] = 2;  // one cut edge anchors the row
  const Eigen::MatrixXd x = solve(s, Eigen::MatrixXd::Ones(4, 1), 1, 1e-12);
  // Forward substitution from the first row: u = (10, 9, 7, 4).
  EXPECT_LT((x.col(0) - Eigen::Vector4d(10, 9, 7, 4)).cwiseAbs().maxCoeff(), 1e-9);
  Eigen::MatrixXd bad = Eigen::MatrixXd::Ones(4, 2);
  bad(2, 1) = std::numeric_limits<double>::infinity();
  try {
    solve(s, bad, 2, 1e-8);
    ADD_FAILURE() << "accepted an infinite right-hand side";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("fill wrote inf in row 2 of right-hand side 1; right-hand sides must be finite"), std::string::npos) << e.what();
  }
}

TEST(GridStencil, CopesWithTheHugeDiagonalsOfVeryShortCutEdges) {
  // A cell centre a hair from the cage: its cut edge's weight 1 / len dwarfs the others.
  ShapeSystem s = test::shape_system(test::figure(), 32);
  int shortened = 0;
  for (const test::CutEdge& e : s.cuts)
    if (e.unknown % 7 == 0) s.stencil.diagonal[std::size_t(e.unknown)] += 1e9 / s.h, ++shortened;
  ASSERT_GT(shortened, 20);
  const SparseMatrix a = sparse_matrix(s.stencil);
  SparseCholesky chol;
  ASSERT_TRUE(chol.factorize(a, CholeskyKind::Supernodal));
  Eigen::MatrixXd b = smooth_rhs(s);
  for (const test::CutEdge& e : s.cuts)
    if (e.unknown % 7 == 0) b.row(e.unknown) += 1e9 / s.h * Eigen::RowVector4d(e.hit.x(), e.hit.y(), e.hit.z(), e.hit.x() * e.hit.y());
  const Eigen::MatrixXd want = chol.solve(b);
  const Eigen::MatrixXd x = solve(s.stencil, b, 4, 1e-10);
  // The huge rows dominate ||b||: the plain residual test alone left the others 1e-4 off CHOLMOD's.
  const Eigen::VectorXd inverse_diagonal = Eigen::Map<const Eigen::VectorXd>(s.stencil.diagonal.data(), a.rows()).cwiseInverse();
  for (int c = 0; c < b.cols(); ++c) {
    const Eigen::VectorXd r = b.col(c) - a * x.col(c);
    EXPECT_LE(r.norm(), 1e-10 * b.col(c).norm()) << "column " << c;
    EXPECT_LE(r.cwiseProduct(inverse_diagonal).norm(), 1e-10 * b.col(c).cwiseProduct(inverse_diagonal).norm()) << "column " << c;
    EXPECT_LE((x.col(c) - want.col(c)).norm(), 1e-6 * want.col(c).norm()) << "column " << c;
  }
}

TEST(GridStencil, AColumnThatDoesNotConvergeIsReportedNotReturned) {
  const ShapeSystem s = test::shape_system(test::figure(), 40);
  numerics::GridSolveOptions options;
  options.max_iterations = 2;
  try {
    solve(s.stencil, smooth_rhs(s), 4, 1e-12, nullptr, options);
    ADD_FAILURE() << "returned after 2 steps at tolerance 1e-12";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("right-hand side 0 did not converge in 2 iterations"), std::string::npos) << e.what();
  }
}

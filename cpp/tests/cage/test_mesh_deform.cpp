// dk.MeshDeform's core (Blender's Mesh Deform, harmonic coordinates on its grid; Joshi et al. 2007)
// against invariants the discretisation keeps: the rest cage is the identity; the grid solutions
// are a partition of unity and lie in [0, 1] (discrete maximum principle of an M-matrix whose
// boundary values are a cage polygon's mean value weights); the direct solve leaves a residual at
// rounding level; and an affine move of the cage moves points affinely wherever the cut-edge
// Laplacian and the trilinear interpolation reproduce linear functions (see affine_move below).
#include "cage/cage_shapes.hpp"
#include "cage/exact_geometry.hpp"
#include "cage/harmonic_grid.hpp"
#include "cage/mesh_deform_simd.hpp"
#include "deformkit/cage/mesh_deform.hpp"

#include <gtest/gtest.h>
#include <hwy/targets.h>

#include <Eigen/Core>

#include <cmath>
#include <random>
#include <vector>

using namespace deformkit;

namespace {

// The L prism of cage_shapes.hpp with each cap split into two convex quads: Blender's polygon
// weights (mean value weights with unsigned angles) reproduce linear functions on convex planar
// polygons only, not on the L-shaped hexagon.
PolygonMesh l_prism_of_quads() {
  test::PolygonSoup s = test::l_prism();
  s.faces[0] = {3, 2, 1, 0};
  s.faces[1] = {6, 7, 8, 9};
  s.faces.push_back({5, 4, 3, 0});
  s.faces.push_back({6, 9, 10, 11});
  return test::polygon_mesh(s);
}


// Points of the L prism's interior region (x, y in the L, z in (0, 1)), jittered.
std::vector<double> l_points(int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.02, 1.98), w(0.02, 0.98);
  std::vector<double> p;
  while (int(p.size()) < 3 * count) {
    const double x = u(rng), y = u(rng);
    if (x > 1.0 && y > 1.0) continue;
    p.insert(p.end(), {x, y, w(rng)});
  }
  return p;
}

}  // namespace

TEST(CageMeshDeform, RestCageIsTheIdentityBitForBit) {
  for (bool dynamic : {false, true}) {
    MeshDeform md(CageMesh(test::polygon_mesh(test::l_prism())), 4, dynamic);
    const std::vector<double> p = l_points(200, 1);
    const MeshDeformBinding b = md.bind(p.data(), p.size() / 3);
    std::vector<double> moved = md.cage_points();
    for (double& c : moved) c *= 1.3;
    md.set_cage_points(moved);
    std::vector<double> out(p.size());
    md.deform_bound(b, out.data());
    EXPECT_NE(out, p);
    md.set_cage_points(md.rest_cage_points());
    md.deform_bound(b, out.data());
    EXPECT_EQ(out, p);  // bit for bit, also after a move and back
  }
}

// Every column's solution, summed over the cage's vertices, is 1 at every unknown, and each lies
// in [0, 1]; the residual diagonal u - coupling u_nb - rhs is at rounding level.
TEST(CageMeshDeform, GridSolutionsArePartitionOfUnityWithinZeroOneAndSolveTheSystem) {
  const CageMesh cage(test::polygon_mesh(test::l_prism()));
  const harmonic::RayCage rays(cage, 2);
  const harmonic::HarmonicGrid grid = harmonic::build_grid(rays, cage.rest_points(), 4);
  const numerics::GridStencil st = harmonic::grid_stencil(grid);
  const auto terms = harmonic::boundary_terms(grid, st);
  const int n = int(st.diagonal.size()), m = int(cage.vertex_count());
  ASSERT_GT(n, 100);
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(n, m);
  const PolygonMesh& poly = cage.polygons();
  for (const auto& t : terms)
    for (int i = 0; i < poly.face_size(std::size_t(t.face)); ++i)
      rhs(t.unknown, poly.face(std::size_t(t.face))[i]) += t.inverse_length * grid.cut_weights[std::size_t(t.weights + i)];
  Eigen::MatrixXd x = Eigen::MatrixXd::Zero(n, m);
  numerics::solve_grid_stencil_direct(
      st, m, 5, [&](int first, Eigen::Ref<Eigen::MatrixXd> b) { b = rhs.middleCols(first, b.cols()); },
      [&](int first, const Eigen::Ref<const Eigen::MatrixXd>& s) { x.middleCols(first, s.cols()) = s; }, 1e-12);
  // Neighbour u of each unknown, from the cell grid.
  std::vector<std::int64_t> cell_of(static_cast<std::size_t>(n));
  for (std::int64_t c = 0; c < grid.cells(); ++c)
    if (st.unknown[std::size_t(c)] >= 0) cell_of[std::size_t(st.unknown[std::size_t(c)])] = c;
  double worst_residual = 0.0;
  for (int u = 0; u < n; ++u) {
    EXPECT_NEAR(x.row(u).sum(), 1.0, 1e-12);
    EXPECT_GE(x.row(u).minCoeff(), -1e-14);
    EXPECT_LE(x.row(u).maxCoeff(), 1.0 + 1e-14);
    Eigen::RowVectorXd r = st.diagonal[std::size_t(u)] * x.row(u) - rhs.row(u);
    for (int d = 0; d < 6; ++d) {
      const double w = st.coupling[std::size_t(u)][std::size_t(d)];
      if (w != 0.0) r -= w * x.row(st.unknown[std::size_t(grid.neighbour(cell_of[std::size_t(u)], d))]);
    }
    worst_residual = std::max(worst_residual, r.cwiseAbs().maxCoeff() / st.diagonal[std::size_t(u)]);
  }
  EXPECT_LT(worst_residual, 1e-13);
}

// The cut-edge Laplacian is exact on linear functions (a cut edge's difference quotient over the
// distance to the cage is the linear function's slope), the boundary values of a planar polygon's
// mean value weights are linear, and trilinear interpolation reproduces linear functions: so a
// point whose 8 cells are all unknowns moves exactly affinely, up to the weights Blender drops
// (below 1e-5 each, renormalised: at most m * 1e-5 of the weight, moving a point by m * 1e-5 times
// the displacement's spread). Near the cage the exterior cells' averaged values enter, with an
// error of the order of a cell: bounded here by 2 cell widths times the displacement's spread.
// (Measured: the deep points to 1e-15, the others to about half a cell.)
TEST(CageMeshDeform, AffineMoveMovesInsidePointsAffinelyToTheGridsAccuracy) {
  const CageMesh cage(l_prism_of_quads());
  for (bool dynamic : {false, true}) {
    MeshDeform md(cage, 5, dynamic);
    const std::vector<double> p = l_points(400, 2);
    const std::size_t n = p.size() / 3;
    const MeshDeformBinding b = md.bind(p.data(), n);
    const Eigen::Matrix3d a = (Eigen::Matrix3d() << 1.1, 0.2, 0.0, -0.1, 0.9, 0.3, 0.05, 0.0, 1.2).finished();
    const Eigen::Vector3d t(0.3, -0.2, 0.1);
    std::vector<double> moved = md.rest_cage_points();
    for (std::size_t j = 0; j < moved.size() / 3; ++j) {
      const Eigen::Vector3d c = a * Eigen::Vector3d(moved[3 * j], moved[3 * j + 1], moved[3 * j + 2]) + t;
      for (int k = 0; k < 3; ++k) moved[3 * j + k] = c[k];
    }
    md.set_cage_points(moved);
    std::vector<double> out(p.size());
    md.deform_bound(b, out.data());
    const double width = 2.0 * (1.0 + 4.2 / 32) / 34;  // Blender's padded cell for a side of 2
    const double spread = (a - Eigen::Matrix3d::Identity()).norm() * 2.0 * std::sqrt(3.0);
    int exact = 0;
    for (std::size_t i = 0; i < n; ++i) {
      ASSERT_TRUE(b.inside[i]);
      const Eigen::Vector3d x(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
      const Eigen::Vector3d err = Eigen::Vector3d(out[3 * i], out[3 * i + 1], out[3 * i + 2]) - (a * x + t);
      EXPECT_LE(err.norm(), 2.0 * width * spread) << "point " << i;
      if (err.norm() <= 12 * 1e-5 * spread) ++exact;  // m = 12 vertices, weights below 1e-5 dropped
    }
    EXPECT_GT(exact, int(n / 2));  // the deep interior: affine to the dropped weights
  }
}

// A point none of whose six axis rays meets the cage is outside for Blender (and for any cast
// order): it stays where it is. (Where a ray meets the cage more than once, Blender's ray cast may
// keep a farther hit, so its "inside" is its own; the Blender tests hold deformkit to it.)
TEST(CageMeshDeform, PointsNoRayOfWhichMeetsTheCageStay) {
  MeshDeform md(CageMesh(l_prism_of_quads()), 4, false);
  const std::vector<double> p = {3.0, 3.0, 3.0, -1.0, 2.5, 1.5, 2.5, 1.5, -0.5, 0.5, 0.5, 0.5};
  const MeshDeformBinding b = md.bind(p.data(), 4);
  EXPECT_EQ(b.inside, (std::vector<std::uint8_t>{0, 0, 0, 1}));
  std::vector<double> moved = md.cage_points();
  for (double& c : moved) c += 0.25;
  md.set_cage_points(moved);
  std::vector<double> out(p.size());
  md.deform_bound(b, out.data());
  for (int i = 0; i < 9; ++i) EXPECT_EQ(out[std::size_t(i)], p[std::size_t(i)]);
  for (int i = 9; i < 12; ++i) EXPECT_NEAR(out[std::size_t(i)], p[std::size_t(i)] + 0.25, 1e-12);  // a translation is reproduced
}

// The multigrid solve (the default) against the Cholesky one: the same coordinates to 1e-7 (each
// column solved to the relative residual 1e-7), for a static and a dynamic bind.
TEST(CageMeshDeform, MultigridAndCholeskyGiveTheSameCoordinates) {
  const CageMesh cage(test::polygon_mesh(test::l_prism()));
  const std::vector<double> p = l_points(300, 3);
  for (bool dynamic : {false, true}) {
    const MeshDeform mg(cage, 5, dynamic, 2, GridSolver::Multigrid), ch(cage, 5, dynamic, 2, GridSolver::Cholesky);
    const WeightTable a = mg.weights_table(mg.bind(p.data(), p.size() / 3));
    const WeightTable b = ch.weights_table(ch.bind(p.data(), p.size() / 3));
    ASSERT_EQ(a.indptr.size(), b.indptr.size());
    for (std::size_t i = 0; i + 1 < a.indptr.size(); ++i) {
      std::vector<double> wa(cage.vertex_count(), 0.0), wb(cage.vertex_count(), 0.0);
      for (auto e = a.indptr[i]; e < a.indptr[i + 1]; ++e) wa[std::size_t(a.indices[std::size_t(e)])] = a.values[std::size_t(e)];
      for (auto e = b.indptr[i]; e < b.indptr[i + 1]; ++e) wb[std::size_t(b.indices[std::size_t(e)])] = b.values[std::size_t(e)];
      for (std::size_t j = 0; j < wa.size(); ++j) EXPECT_NEAR(wa[j], wb[j], 1e-7) << "point " << i << " vertex " << j;
    }
  }
}

// The Jacobian against central differences of deform (the map is trilinear within a cell, so a
// step of 1e-6 stays inside one and the difference is exact to rounding: 1e-7 allowed).
TEST(CageMeshDeform, JacobianMatchesCentralDifferences) {
  const CageMesh cage(test::polygon_mesh(test::l_prism()));
  const std::vector<double> p = {0.43, 0.61, 0.52, 1.31, 0.27, 0.44, 0.2, 1.7, 0.8};
  std::mt19937 rng(4);
  std::normal_distribution<double> noise(0.0, 0.1);
  for (bool dynamic : {false, true}) {
    MeshDeform md(cage, 4, dynamic);
    std::vector<double> moved = md.rest_cage_points();
    for (double& c : moved) c += noise(rng);
    md.set_cage_points(moved);
    std::vector<double> jac(27);
    md.jacobian(p.data(), jac.data(), 3);
    const double h = 1e-6;
    for (int axis = 0; axis < 3; ++axis) {
      std::vector<double> up = p, down = p, fu(9), fd(9);
      for (int i = 0; i < 3; ++i) {
        up[std::size_t(3 * i + axis)] += h;
        down[std::size_t(3 * i + axis)] -= h;
      }
      md.deform(up.data(), fu.data(), 3);
      md.deform(down.data(), fd.data(), 3);
      for (int i = 0; i < 3; ++i)
        for (int r = 0; r < 3; ++r)
          EXPECT_NEAR(jac[std::size_t(9 * i + 3 * r + axis)], (fu[std::size_t(3 * i + r)] - fd[std::size_t(3 * i + r)]) / (2 * h), 1e-7)
              << "dynamic " << dynamic << " point " << i;
    }
  }
}

// The filtered turn in front of the ray tests decides as CGAL's exact predicate does, on triples
// built to be (nearly) collinear in the projection: on a line to the last bit, one ulp off it, at
// magnitudes from 1e-3 to 1e6, and edge-on (zero) cases.
TEST(CageMeshDeform, FilteredTurnEqualsTheExactPredicateOnNearlyCollinearPoints) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), along(-2.0, 3.0);
  std::uniform_int_distribution<int> pick(0, 5);
  const double scales[] = {1e-3, 1.0, 37.0, 1e6};
  int zero = 0, nonzero = 0;
  for (int trial = 0; trial < 200000; ++trial) {
    const double scale = scales[trial % 4];
    const Vec3 a(scale * unit(rng), scale * unit(rng), scale * unit(rng));
    const Vec3 b = a + scale * Vec3(unit(rng), unit(rng), unit(rng));
    Vec3 c = a + along(rng) * (b - a);  // on the line up to rounding
    const int nudge = pick(rng);
    if (nudge < 3) c[nudge] = std::nextafter(c[nudge], nudge % 2 ? INFINITY : -INFINITY);
    if (nudge == 5) c = b;  // exactly degenerate
    for (int axis = 0; axis < 3; ++axis) {
      const int exact = cage_exact::turn_along(a, b, c, axis);
      ASSERT_EQ(harmonic::turn_along(a, b, c, axis), exact) << "trial " << trial << " axis " << axis;
      ASSERT_EQ(harmonic::turn_along(c, a, b, axis), exact);
      (exact == 0 ? zero : nonzero) += 1;
    }
  }
  EXPECT_GT(zero, 1000);
  EXPECT_GT(nonzero, 1000);
}

// The frame's weighted sums on every SIMD target this build has and this CPU runs (SSE4's and
// AVX2's float paths differ), for a column type holding indices below `cage`, against plain sums in
// long double: rows of 0 to 9 weights, the columns reaching the largest index (the type's largest
// for 1 and 2 bytes).
template <class Column>
void expect_weighted_rows_on_every_target(std::size_t cage) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  const std::size_t rows = 200;
  std::vector<std::uint32_t> start{0};
  std::vector<Column> column;
  std::vector<double> weight, rows4(4 * cage);
  for (double& r : rows4) r = value(rng);
  for (std::size_t r = 0; r < rows; ++r) {
    for (std::size_t k = 0; k < r % 10; ++k) {
      column.push_back(Column(k == 0 ? cage - 1 - r % 2 : rng() % cage));
      weight.push_back(value(rng));
    }
    start.push_back(std::uint32_t(column.size()));
  }
  const std::vector<float> weight_f(weight.begin(), weight.end()), rows4_f(rows4.begin(), rows4.end());
  std::vector<long double> expected(4 * rows, 0.0L);
  for (std::size_t r = 0; r < rows; ++r)
    for (std::uint32_t e = start[r]; e < start[r + 1]; ++e)
      for (std::size_t c = 0; c < 4; ++c) expected[4 * r + c] += (long double)weight[e] * rows4[4 * std::size_t(column[e]) + c];
  const std::vector<std::int64_t> targets = hwy::SupportedAndGeneratedTargets();
  ASSERT_FALSE(targets.empty());
  for (const std::int64_t target : targets) {
    hwy::SetSupportedTargetsForTest(target);
    std::vector<double> acc(4 * rows);
    std::vector<float> acc_f(4 * rows);
    harmonic::weighted_rows(start.data(), column.data(), weight.data(), 0, rows, rows4.data(), acc.data());
    harmonic::weighted_rows(start.data(), column.data(), weight_f.data(), 0, rows, rows4_f.data(), acc_f.data());
    for (std::size_t i = 0; i < 4 * rows; ++i) {
      EXPECT_NEAR(acc[i], double(expected[i]), 1e-14) << hwy::TargetName(target) << " " << sizeof(Column) << " row " << i / 4;
      EXPECT_NEAR(acc_f[i], double(expected[i]), 5e-6) << hwy::TargetName(target) << " " << sizeof(Column) << " row " << i / 4;
    }
  }
  hwy::SetSupportedTargetsForTest(0);
}

TEST(CageMeshDeform, WeightedRowsAgreeOnEveryTarget) {
  expect_weighted_rows_on_every_target<std::uint8_t>(std::size_t(UINT8_MAX) + 1);
  expect_weighted_rows_on_every_target<std::uint16_t>(std::size_t(UINT16_MAX) + 1);
  expect_weighted_rows_on_every_target<std::uint32_t>(std::size_t(UINT16_MAX) + 1000);
}

// A binding's column indices take the narrowest width that holds every vertex index of its cage: 1
// byte up to 256 vertices, 2 up to 65536, else 4; the largest index reads back unchanged.
TEST(CageMeshDeform, WeightColumnsTakeTheNarrowestWidthThatHoldsTheCage) {
  const std::pair<std::size_t, std::size_t> cases[] = {{8, 1}, {256, 1}, {257, 2}, {65536, 2}, {65537, 4}, {1u << 20, 4}};
  for (const auto& [vertices, bytes] : cases) {
    WeightColumns c(3, vertices);
    EXPECT_EQ(c.bytes_per_index(), bytes) << vertices << " vertices";
    ASSERT_EQ(c.size(), 3u);
    const std::uint32_t last[] = {std::uint32_t(vertices - 1), 0, std::uint32_t(vertices / 2)};
    c.assign(0, last, 3);
    for (std::size_t e = 0; e < 3; ++e) EXPECT_EQ(c[e], last[e]) << vertices << " vertices";
  }
}

// Cages on either side of 256 vertices (cubes of 6 n^2 + 2 vertices: 1- and 2-byte columns),
// float32 and float64 points. An affine move of the cage moves the deep inside points affinely
// (the cut-edge Laplacian and the trilinear interpolation reproduce linear functions, as in
// AffineMoveMovesInsidePointsAffinelyToTheGridsAccuracy; a weight read against another vertex
// would not), up to the weights Blender drops (below 1e-5 each, m of them at most) and the solve's
// 1e-7; and after a random move the float32 frame's displacements are the float64 frame's to
// float rounding.
TEST(CageMeshDeform, NarrowColumnsGiveTheDenseDisplacementsOnEitherSideOf256Vertices) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> deep(0.25, 0.75);
  std::normal_distribution<double> noise(0.0, 0.05);
  for (const int n : {6, 7}) {
    const CageMesh cage(test::polygon_mesh(test::subdivided_cube(n)));
    const std::size_t m = cage.vertex_count();
    ASSERT_EQ(m, std::size_t(6 * n * n + 2));
    MeshDeform md(cage, 4, false);
    std::vector<double> p(3 * 300);
    for (double& x : p) x = deep(rng);
    const std::vector<float> p_f(p.begin(), p.end());
    const MeshDeformBinding b = md.bind(p.data(), 300), b_f = md.bind(p_f.data(), 300);
    EXPECT_EQ(b.weight_vertex.bytes_per_index(), m <= 256 ? 1u : 2u);
    EXPECT_EQ(b_f.weight_vertex.bytes_per_index(), m <= 256 ? 1u : 2u);
    const Eigen::Matrix3d a = (Eigen::Matrix3d() << 1.1, 0.2, 0.0, -0.1, 0.9, 0.3, 0.05, 0.0, 1.2).finished();
    const Eigen::Vector3d t(0.3, -0.2, 0.1);
    std::vector<double> moved = md.rest_cage_points();
    for (std::size_t j = 0; j < m; ++j) {
      const Eigen::Vector3d c = a * Eigen::Vector3d(moved[3 * j], moved[3 * j + 1], moved[3 * j + 2]) + t;
      for (int k = 0; k < 3; ++k) moved[3 * j + std::size_t(k)] = c[k];
    }
    md.set_cage_points(moved);
    std::vector<double> out(p.size());
    std::vector<float> out_f(p.size());
    md.deform_bound(b, out.data());
    md.deform_bound(b_f, out_f.data());
    const double spread = (a - Eigen::Matrix3d::Identity()).norm() * std::sqrt(3.0) + t.norm();
    const double dropped = double(m) * 1e-5 * spread + 1e-6;
    for (std::size_t i = 0; i < 300; ++i) {
      ASSERT_TRUE(b.inside[i] && b_f.inside[i]) << "point " << i;
      const Eigen::Vector3d affine = a * Eigen::Vector3d(p[3 * i], p[3 * i + 1], p[3 * i + 2]) + t;
      for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(out[3 * i + std::size_t(k)], affine[k], dropped) << m << " vertices, point " << i;
        EXPECT_NEAR(out_f[3 * i + std::size_t(k)], affine[k], dropped + 1e-6) << m << " vertices, float32 point " << i;
      }
    }
    for (double& c : moved) c += noise(rng);
    md.set_cage_points(moved);
    md.displacement_bound(b, out.data());
    md.displacement_bound(b_f, out_f.data());
    for (std::size_t i = 0; i < out.size(); ++i) EXPECT_NEAR(out_f[i], out[i], 1e-6) << m << " vertices, coordinate " << i;
  }
}

// The dense frame (a small cage's float binding in blocks of 8 points) on every SIMD target,
// against sums in long double: 1, 8 and 13 cage vertices, 45 points (a last block of 5), with and
// without per-point scales and points; a result that is not finite is reported.
TEST(CageMeshDeform, DenseBlocksAgreeOnEveryTarget) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  const std::size_t n = 45, blocks = (n + 7) / 8;
  for (const std::size_t m : {1, 8, 13}) {
    std::vector<float> weight(8 * m * blocks, 0.0f), rows4(4 * m), points(3 * n);
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t a = 0; a < m; ++a) weight[8 * (m * (i / 8) + a) + i % 8] = float(value(rng));
    for (float& r : rows4) r = float(value(rng));
    for (float& p : points) p = float(value(rng));
    std::vector<double> scale(n);
    for (double& s : scale) s = 0.5 * (value(rng) + 1.0);
    for (const std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
      hwy::SetSupportedTargetsForTest(target);
      for (const bool scaled : {false, true})
        for (const bool offsets : {false, true}) {
          std::vector<float> out(3 * n + 3, 7.0f);  // one point past the end stays
          ASSERT_TRUE(harmonic::dense_blocks(weight.data(), m, rows4.data(), scaled ? scale.data() : nullptr,
                                             offsets ? nullptr : points.data(), 0, blocks, n, out.data()));
          for (std::size_t i = 0; i < n; ++i)
            for (std::size_t c = 0; c < 3; ++c) {
              long double sum = 0.0L;
              for (std::size_t a = 0; a < m; ++a)
                sum += (long double)weight[8 * (m * (i / 8) + a) + i % 8] * rows4[4 * a + c];
              const long double expected = (offsets ? 0.0L : points[3 * i + c]) + (scaled ? scale[i] : 1.0) * sum;
              EXPECT_NEAR(out[3 * i + c], double(expected), 4e-6)
                  << hwy::TargetName(target) << " m " << m << " point " << i << " scaled " << scaled
                  << " offsets " << offsets;
            }
          EXPECT_EQ(out[3 * n], 7.0f);
        }
      std::vector<float> out(3 * n), huge(rows4);
      huge[0] = 3e38f;
      weight[8 * (m * 5) + 2] = 10.0f;  // point 42's first weight: 3e39 overflows
      EXPECT_FALSE(harmonic::dense_blocks(weight.data(), m, huge.data(), nullptr, nullptr, 0, blocks, n, out.data()))
          << hwy::TargetName(target) << " m " << m;
    }
    hwy::SetSupportedTargetsForTest(0);
  }
}

// A float binding on a cube cage (8 vertices, every inside point weighing all of them, most points
// inside) holds its rows dense as well (fewer bytes), and the dense frame gives the rows' frame:
// deform_bound through the float64 binding of the same points (rows, double) to float rounding. A
// float64 binding keeps rows only.
TEST(CageMeshDeform, SmallCagesBindDenseAndTheirFrameIsTheRowsFrame) {
  const CageMesh cage(test::polygon_mesh(test::subdivided_cube(1)));
  ASSERT_EQ(cage.vertex_count(), 8u);
  MeshDeform md(cage, 4, false);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(0.02, 0.98);
  std::vector<double> p(3 * 1001);  // a last block of 1; every tenth point outside, right of the cage
  for (double& x : p) x = u(rng);
  for (std::size_t i = 0; i < 1001; i += 10) p[3 * i] += 1.5;
  const std::vector<float> p_f(p.begin(), p.end());
  const std::vector<double> p_back(p_f.begin(), p_f.end());
  const MeshDeformBinding b = md.bind(p_back.data(), 1001), b_f = md.bind(p_f.data(), 1001);
  EXPECT_TRUE(b.dense_weight.empty());
  ASSERT_EQ(b_f.dense_weight.size(), 8u * 8u * 126u);
  std::normal_distribution<double> noise(0.0, 0.1);
  std::vector<double> moved = md.rest_cage_points();
  for (double& c : moved) c += noise(rng);
  md.set_cage_points(moved);
  std::vector<double> out(p.size());
  std::vector<float> out_f(p.size());
  md.deform_bound(b, out.data());
  md.deform_bound(b_f, out_f.data());
  std::size_t outside = 0;
  for (std::size_t i = 0; i < 1001; ++i) {
    outside += !b_f.inside[i];
    for (std::size_t c = 0; c < 3; ++c) {
      EXPECT_NEAR(out_f[3 * i + c], out[3 * i + c], 2e-6) << "point " << i;
      if (!b_f.inside[i]) EXPECT_EQ(out_f[3 * i + c], p_f[3 * i + c]) << "outside point " << i;
    }
  }
  EXPECT_GT(outside, 0u);
}

// Mean value coordinates against their defining properties: linear precision and partition of unity
// (inside, near, on and outside the cage), interpolation on the cage, affine reproduction, exact
// gradients against finite differences, continuity across a face, and the bound path.
#include "cage/cage_shapes.hpp"
#include "deformkit/cage/mean_value_cage.hpp"
#include "test_util.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <utility>
#include <stdexcept>

using namespace deformkit;
using namespace deformkit::test;

namespace {

MeanValueCage make(const PolygonSoup& s) { return MeanValueCage(CageMesh(polygon_mesh(s))); }

Vec3 vertex(const MeanValueCage& c, int v) {
  const auto& p = c.rest_cage_points();
  return Vec3(p[3 * v], p[3 * v + 1], p[3 * v + 2]);
}

// |sum_j w_j p_j - x| and |sum_j w_j - 1| at x, each over the size of what rounding can cost
// there: 1 + sum_j |w_j| |p_j - x| (outside the cage the weights alternate in sign and grow).
struct Precision {
  double position, sum, scale;
};
Precision precision_error(const MeanValueCage& c, const Vec3& x) {
  std::vector<double> w(c.columns());
  c.coordinates(x, w.data(), nullptr);
  Vec3 sum = Vec3::Zero();
  double total = 0.0, scale = 1.0;
  for (std::size_t j = 0; j < w.size(); ++j) {
    sum += w[j] * (vertex(c, int(j)) - x);
    total += w[j];
    scale += std::abs(w[j]) * (vertex(c, int(j)) - x).norm();
  }
  return {sum.norm(), std::abs(total - 1.0), scale};
}

// Beside a face's plane (at distance h, d from the face's nearest vertex, outside the face) the
// determinant form loses eps d / h to cancellation (docs/math/cage.md, "Accuracy near the cage"):
// the largest d / h over the cage's triangles, at least 1.
double plane_condition(const MeanValueCage& c, const Vec3& x) {
  double worst = 1.0;
  for (const auto& t : c.cage().triangles()) {
    const Vec3 a = vertex(c, t[0]), b = vertex(c, t[1]), e = vertex(c, t[2]);
    const double h = std::abs((b - a).cross(e - a).normalized().dot(x - a));
    const double d = std::min({(a - x).norm(), (b - x).norm(), (e - x).norm()});
    worst = std::max(worst, d / h);
  }
  return worst;
}

bool inside_l_prism(const Vec3& x) {
  return x.minCoeff() > 0 && x.x() < 2 && x.y() < 2 && x.z() < 1 && !(x.x() > 1 && x.y() > 1);
}

void move_randomly(MeanValueCage& c, double amount, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, amount);
  auto p = c.rest_cage_points();
  for (double& v : p) v += n(rng);
  c.set_cage_points(p);
}

Vec3 on_triangle(const MeanValueCage& c, std::size_t t, double a, double b) {
  const auto& tri = c.cage().triangles()[t];
  return (1 - a - b) * vertex(c, tri[0]) + a * vertex(c, tri[1]) + b * vertex(c, tri[2]);
}

Vec3 outward_normal(const MeanValueCage& c, std::size_t t) {
  const auto& tri = c.cage().triangles()[t];
  return (vertex(c, tri[1]) - vertex(c, tri[0])).cross(vertex(c, tri[2]) - vertex(c, tri[0])).normalized();
}

}  // namespace

TEST(MeanValueCage, LinearPrecisionInsideAndOutside) {
  const MeanValueCage c = make(l_prism());
  const auto pts = random_points(600, -0.5, 2.5, 11);  // inside, in the L's notch and outside
  int inside = 0;
  for (std::size_t i = 0; i < 600; ++i) {
    const Vec3 x(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]);
    const Precision e = precision_error(c, x);
    if (inside_l_prism(x)) {  // positive weights: rounding only
      ++inside;
      EXPECT_LT(e.position, 1e-14);
      EXPECT_LT(e.sum, 1e-14);
    }
    const double tolerance = 1e-14 * e.scale * plane_condition(c, x);
    EXPECT_LT(e.position, tolerance) << x.transpose();
    EXPECT_LT(e.sum, tolerance);
  }
  EXPECT_GT(inside, 20);
}

TEST(MeanValueCage, LinearPrecisionNearAFace) {
  const MeanValueCage c = make(l_prism());
  for (std::size_t t = 0; t < c.cage().triangles().size(); ++t)
    for (double delta : {1e-3, 1e-6, 1e-9, 1e-12})
      for (double side : {-1.0, 1.0}) {  // inside and outside
        const Vec3 x = on_triangle(c, t, 0.31, 0.27) + side * delta * outward_normal(c, t);
        const Precision e = precision_error(c, x);
        EXPECT_LT(e.position, 1e-14) << "triangle " << t << " delta " << delta * side;
        EXPECT_LT(e.sum, 1e-14);
      }
}

TEST(MeanValueCage, InterpolatesOnTheCage) {
  const MeanValueCage c = make(l_prism());
  std::vector<double> w(c.columns());
  for (int v = 0; v < int(c.vertex_count()); ++v) {
    c.coordinates(vertex(c, v), w.data(), nullptr);
    for (int j = 0; j < int(w.size()); ++j) EXPECT_EQ(w[j], j == v ? 1.0 : 0.0);
  }
  for (std::size_t t = 0; t < c.cage().triangles().size(); ++t) {
    const auto& tri = c.cage().triangles()[t];
    c.coordinates(on_triangle(c, t, 0.2, 0.5), w.data(), nullptr);
    // On a face: its triangle's barycentric weights (to rounding), nothing elsewhere.
    EXPECT_NEAR(w[tri[0]], 0.3, 1e-14);
    EXPECT_NEAR(w[tri[1]], 0.2, 1e-14);
    EXPECT_NEAR(w[tri[2]], 0.5, 1e-14);
    double others = 0.0;
    for (int j = 0; j < int(w.size()); ++j)
      if (j != tri[0] && j != tri[1] && j != tri[2]) others += std::abs(w[j]);
    EXPECT_EQ(others, 0.0);
  }
}

TEST(MeanValueCage, AnAffineCageMapMovesThePointsAffinely) {
  MeanValueCage c = make(l_prism());
  const Frame f = random_frame(5);
  auto cage = c.rest_cage_points();
  for (std::size_t v = 0; v < c.vertex_count(); ++v) {
    const Vec3 y = f.to_object(Vec3(cage[3 * v], cage[3 * v + 1], cage[3 * v + 2]));
    for (int a = 0; a < 3; ++a) cage[3 * v + a] = y[a];
  }
  c.set_cage_points(cage);
  const auto pts = random_points(200, -0.5, 2.5, 3);
  std::vector<double> out(pts.size());
  c.deform(pts.data(), out.data(), 200);
  const MeanValueCage rest = make(l_prism());
  for (std::size_t i = 0; i < 200; ++i) {
    const Vec3 x(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]);
    const double tolerance = inside_l_prism(x) ? 1e-14 : 1e-14 * precision_error(rest, x).scale * plane_condition(rest, x);
    EXPECT_LT((Vec3(out[3 * i], out[3 * i + 1], out[3 * i + 2]) - f.to_object(x)).norm(), tolerance);
  }
  // Its Jacobian is the affine map's linear part.
  const Mat3 j = jacobian_one(c, Vec3(0.5, 0.5, 0.5));
  EXPECT_LT((j - f.linear).norm(), 1e-12);
}

TEST(MeanValueCage, TheRestCageIsTheIdentityBitForBit) {
  MeanValueCage c = make(unit_cube());
  const auto pts = random_points(100, -1e3, 1e3, 7);
  std::vector<double> out(pts.size());
  c.deform(pts.data(), out.data(), 100);
  EXPECT_EQ(out, pts);
  const CageBinding b = c.bind(pts.data(), 100);
  std::fill(out.begin(), out.end(), 0.0);
  c.deform_bound(b, out.data());
  EXPECT_EQ(out, pts);
  move_randomly(c, 0.1, 1);
  EXPECT_FALSE(c.is_identity());
  c.set_cage_points(c.rest_cage_points());
  EXPECT_TRUE(c.is_identity());
}

TEST(MeanValueCage, JacobianMatchesCentralDifferences) {
  MeanValueCage c = make(l_prism());
  move_randomly(c, 0.15, 2);
  const auto pts = random_points(40, -0.3, 2.3, 9);
  for (std::size_t i = 0; i < 40; ++i) {
    const Vec3 x(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]);
    const Mat3 j = jacobian_one(c, x);
    Mat3 fd;
    const double h = 1e-6;
    for (int a = 0; a < 3; ++a) {
      Vec3 e = Vec3::Zero();
      e[a] = h;
      fd.col(a) = (deform_one(c, x + e) - deform_one(c, x - e)) / (2 * h);
    }
    EXPECT_LT((j - fd).norm(), 1e-6 * (1.0 + j.norm())) << "point " << x.transpose();
  }
}

TEST(MeanValueCage, ContinuousAcrossAFace) {
  MeanValueCage c = make(l_prism());
  move_randomly(c, 0.2, 4);
  for (std::size_t t = 0; t < c.cage().triangles().size(); ++t) {
    const Vec3 on = on_triangle(c, t, 0.25, 0.35), n = outward_normal(c, t);
    const Vec3 at = deform_one(c, on);
    for (double delta : {1e-4, 1e-7}) {
      // C0 across the cage: the jump is of the order of the step (the gradients are bounded).
      EXPECT_LT((deform_one(c, on + delta * n) - at).norm(), 100 * delta);
      EXPECT_LT((deform_one(c, on - delta * n) - at).norm(), 100 * delta);
    }
  }
}

// Just outside the cube by the edge y = z = 1, x at distance delta from it is nearly in both faces'
// planes and beside both; the weights tend to the edge's linear interpolation, 0.63 and 0.37 at
// vertices 3 and 7, and differ from it by about 1.05 delta (Ju, Schaefer, Warren 2005's formula in
// long double: tests/cage/test_mvc_reference.py). Skipping both faces by their distance to their
// nearest vertex lost 0.32 there (docs/math/cage.md, "Accuracy near the cage").
TEST(MeanValueCage, ContinuousJustOutsideAnEdge) {
  const MeanValueCage c = make(unit_cube());
  std::vector<double> w(c.columns());
  for (double delta : {1e-6, 1e-8, 3e-9, 1e-9, 1e-10, 1e-11, 1e-12})
    for (const auto& [a, b] : {std::pair{1.0, 0.5}, std::pair{1.0, 1.0}, std::pair{0.2, 1.0}}) {
      const Vec3 x(0.37, 1 + a * delta, 1 + b * delta);
      c.coordinates(x, w.data(), nullptr);
      for (std::size_t j = 0; j < w.size(); ++j) {
        const double edge = j == 3 ? 0.63 : j == 7 ? 0.37 : 0.0;
        EXPECT_LT(std::abs(w[j] - edge), 2 * delta + 1e-14) << "x " << x.transpose() << " weight " << j;
      }
    }
}

TEST(MeanValueCage, ThePolygonSplitChangesTheCoordinatesEvenOnAPlanarFace) {
  // Claim checked and refuted: were the coordinates of a planar polygon independent of its split,
  // the cube's two diagonal choices would agree. They do not, so the split rule must be a rule.
  const PolygonSoup cube = unit_cube();
  PolygonSoup other = cube;  // every face listed from its next corner: ties break the other way
  for (auto& f : other.faces) f = {f[1], f[2], f[3], f[0]};
  // The split does not depend on the listing (ties broken by vertex index) ...
  EXPECT_EQ(make(cube).cage().triangles(), make(other).cage().triangles());
  // ... but triangulating each face along its other diagonal gives other weights.
  PolygonSoup crossed;
  crossed.points = cube.points;
  const MeanValueCage c = make(cube);
  for (const auto& f : cube.faces) {
    const auto t = split_polygon(cube.points.data(), f.data(), 4);
    const bool on_02 = std::count(t[0].begin(), t[0].end(), f[0]) && std::count(t[0].begin(), t[0].end(), f[2]) &&
                       std::count(t[1].begin(), t[1].end(), f[0]) && std::count(t[1].begin(), t[1].end(), f[2]);
    if (on_02) {
      crossed.faces.push_back({f[1], f[2], f[3]});
      crossed.faces.push_back({f[3], f[0], f[1]});
    } else {
      crossed.faces.push_back({f[0], f[1], f[2]});
      crossed.faces.push_back({f[2], f[3], f[0]});
    }
  }
  const MeanValueCage d = make(crossed);
  std::vector<double> w(8), v(8);
  const Vec3 x(0.3, 0.2, 0.6);
  c.coordinates(x, w.data(), nullptr);
  d.coordinates(x, v.data(), nullptr);
  double differ = 0.0;
  for (int j = 0; j < 8; ++j) differ = std::max(differ, std::abs(w[j] - v[j]));
  EXPECT_GT(differ, 1e-3);
  EXPECT_LT(precision_error(d, x).position, 1e-14);  // both are coordinates all the same
}

TEST(MeanValueCage, BoundPathsAgreeWithDeform) {
  MeanValueCage c = make(l_prism());
  move_randomly(c, 0.2, 8);
  const std::size_t n = 20000;  // past the parallel grain: both cores
  const auto pts = random_points(n, -0.2, 2.2, 10);
  std::vector<double> want(pts.size()), got(pts.size());
  c.deform(pts.data(), want.data(), n);
  const CageBinding dense = c.bind(pts.data(), n);
  c.deform_bound(dense, got.data());
  for (std::size_t i = 0; i < got.size(); ++i) ASSERT_NEAR(got[i], want[i], 1e-13);
  // float32 weights: each weight rounded by at most 2^-24 of itself.
  CageBindOptions f32;
  f32.storage = WeightStorage::Float32;
  const CageBinding single = c.bind(pts.data(), n, f32);
  c.deform_bound(single, got.data());
  double err = 0.0;
  for (std::size_t i = 0; i < got.size(); ++i) err = std::max(err, std::abs(got[i] - want[i]));
  EXPECT_LT(err, 3 * 1e-6);
  EXPECT_GT(single.float32_rounding_max, 0.0);
  // Sparsified: the error at this deformed cage stays within the documented bound.
  CageBindOptions sparse;
  sparse.storage = WeightStorage::Sparse;
  sparse.sparsify_threshold = 1e-3;
  const CageBinding s = c.bind(pts.data(), n, sparse);
  EXPECT_LT(s.sparse.values.size(), n * c.columns());
  c.deform_bound(s, got.data());
  const auto& cp = c.cage_points();
  Vec3 centre = Vec3::Zero();
  for (std::size_t v = 0; v < c.vertex_count(); ++v) centre += Vec3(cp[3 * v], cp[3 * v + 1], cp[3 * v + 2]);
  centre /= double(c.vertex_count());
  double radius = 0.0;
  for (std::size_t v = 0; v < c.vertex_count(); ++v)
    radius = std::max(radius, (Vec3(cp[3 * v], cp[3 * v + 1], cp[3 * v + 2]) - centre).norm());
  double worst = 0.0;
  for (std::size_t i = 0; i < n; ++i)
    worst = std::max(worst, (Vec3(got[3 * i], got[3 * i + 1], got[3 * i + 2]) -
                             Vec3(want[3 * i], want[3 * i + 1], want[3 * i + 2])).norm());
  EXPECT_GT(worst, 0.0);
  EXPECT_LE(worst, s.weight_change_max * radius * (1 + 1e-12));
  EXPECT_GT(s.dropped_weight_max, 0.0);
  EXPECT_LE(s.dropped_weight_max, s.weight_change_max);
  // A binding of another cage is refused.
  const MeanValueCage cube = make(unit_cube());
  EXPECT_THROW(cube.deform_bound(dense, got.data()), std::invalid_argument);
}

TEST(MeanValueCage, ACageDeformerRefusesBadInput) {
  MeanValueCage c = make(unit_cube());
  std::vector<double> short_cage(9, 0.0);
  EXPECT_THROW(c.set_cage_points(short_cage), std::invalid_argument);
  auto p = c.rest_cage_points();
  p[5] = INFINITY;
  EXPECT_THROW(c.set_cage_points(p), std::invalid_argument);
  const double x[3] = {0.5, 0.5, 0.5};
  CageBindOptions bad;
  bad.storage = WeightStorage::Sparse;
  bad.sparsify_threshold = -1.0;
  EXPECT_THROW(c.bind(x, 1, bad), std::invalid_argument);
  bad.sparsify_threshold = 10.0;  // drops every weight
  EXPECT_THROW(c.bind(x, 1, bad), std::invalid_argument);
}

// The SIMD rows (mean_value_rows.cpp) against the single-point weights: the same determinant form,
// so they agree to a few ulps of the weights' scale (times the conditioning beside a face's plane)
// for points inside and outside, and the guarded
// points (on vertices and faces, near faces' planes) come from the single-point code itself.
TEST(MeanValueCage, RowsMatchSinglePoints) {
  for (const PolygonSoup& shape : {unit_cube(), l_prism()}) {
    const MeanValueCage c = make(shape);
    std::vector<double> pts = random_points(300, -0.5, 2.5, 21);
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(0.1, 0.4);
    for (std::size_t t = 0; t < c.cage().triangles().size(); ++t) {
      const Vec3 on = on_triangle(c, t, u(rng), u(rng));
      std::vector<Vec3> extra = {on, vertex(c, c.cage().triangles()[t][0]), on + 3.0 * outward_normal(c, t)};
      for (double h : {1e-2, 1e-6, 1e-9, 1e-12}) {
        extra.push_back(on + h * outward_normal(c, t));
        extra.push_back(on - h * outward_normal(c, t));
      }
      for (const Vec3& p : extra) pts.insert(pts.end(), {p.x(), p.y(), p.z()});
    }
    const std::size_t n = pts.size() / 3, m = c.columns();
    for (std::size_t chunk : {std::size_t(1), std::size_t(5), std::size_t(64), n}) {
      std::vector<double> rows(n * m, -7.0), w(m);
      for (std::size_t lo = 0; lo < n; lo += chunk)
        c.coordinate_rows(pts.data() + 3 * lo, std::min(chunk, n - lo), rows.data() + lo * m);
      double worst = 0.0;
      for (std::size_t i = 0; i < n; ++i) {
        c.coordinates(Vec3(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]), w.data(), nullptr);
        double scale = 1.0;
        for (double v : w) scale = std::max(scale, std::abs(v));
        // Beside a face's plane both lose eps d / h to the determinant's cancellation, each its own way.
        scale *= plane_condition(c, Vec3(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]));
        for (std::size_t j = 0; j < m; ++j) worst = std::max(worst, std::abs(rows[i * m + j] - w[j]) / scale);
      }
      EXPECT_LT(worst, 1e-13) << "chunks of " << chunk;
    }
  }
}

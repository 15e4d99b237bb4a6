// The correspondence phase against independent truths: closest points against dense sampling, the
// k-d tree queries against brute force over every triangle, a sphere fitted onto a differently
// triangulated sphere, similarity poses transferring exactly between unlike meshes, fixed vertices
// and bad input refused by name.
#include "deformkit/transfer/deformation_transfer.hpp"
#include "deformkit/transfer/triangle_correspondence.hpp"
#include "test_util.hpp"
#include "transfer/triangle_locator.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

using namespace deformkit;
using namespace deformkit::test;

namespace {

struct TriMesh {
  std::vector<double> points;
  std::vector<int> triangles;
  PolygonMesh mesh() const { return PolygonMesh(points.data(), points.size() / 3, triangles.data(), triangles.size() / 3, 3); }
  Vec3 at(int i) const { return Vec3(points[3 * i], points[3 * i + 1], points[3 * i + 2]); }
};

// A UV sphere, outward triangles; `bump` makes it a little lumpy so that no two are alike.
TriMesh sphere(int rings, int segments, double radius, Vec3 centre = Vec3::Zero(), double bump = 0.0) {
  TriMesh m;
  auto add = [&](Vec3 p) {
    p = centre + radius * (1 + bump * std::sin(3 * p.x()) * std::cos(2 * p.y())) * p;
    m.points.insert(m.points.end(), {p.x(), p.y(), p.z()});
  };
  const double pi = std::acos(-1.0);
  add(Vec3(0, 0, 1));
  for (int r = 1; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const double th = pi * r / rings, ph = 2 * pi * s / segments;
      add(Vec3(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)));
    }
  add(Vec3(0, 0, -1));
  const int south = int(m.points.size() / 3) - 1;
  auto ring = [&](int r, int s) { return 1 + (r - 1) * segments + (s % segments); };
  for (int s = 0; s < segments; ++s) m.triangles.insert(m.triangles.end(), {0, ring(1, s), ring(1, s + 1)});
  for (int r = 1; r + 1 < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      m.triangles.insert(m.triangles.end(), {ring(r, s), ring(r + 1, s), ring(r + 1, s + 1)});
      m.triangles.insert(m.triangles.end(), {ring(r, s), ring(r + 1, s + 1), ring(r, s + 1)});
    }
  for (int s = 0; s < segments; ++s) m.triangles.insert(m.triangles.end(), {south, ring(rings - 1, s + 1), ring(rings - 1, s)});
  return m;
}

Vec3 unit_normal(const TriMesh& m, std::size_t j) {
  const int* v = m.triangles.data() + 3 * j;
  return (m.at(v[1]) - m.at(v[0])).cross(m.at(v[2]) - m.at(v[0])).normalized();
}

// Markers: for each chosen target vertex, the source vertex nearest to it.
void nearest_markers(const TriMesh& source, const TriMesh& target, const std::vector<int>& on_target,
                     std::vector<int>& s, std::vector<int>& t) {
  for (int g : on_target) {
    int best = 0;
    for (int i = 0; i < int(source.points.size() / 3); ++i)
      if ((source.at(i) - target.at(g)).norm() < (source.at(best) - target.at(g)).norm()) best = i;
    s.push_back(best);
    t.push_back(g);
  }
}

}  // namespace

TEST(TriangleLocator, ClosestPointOnTriangleIsTheNearestOfDenseSamples) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 200; ++trial) {
    const Vec3 a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng)), c(u(rng), u(rng), u(rng)), p(2 * u(rng), 2 * u(rng), 2 * u(rng));
    const Vec3 q = closest_point_on_triangle(p, a, b, c);
    // q lies in the triangle: its barycentric coordinates are in [0, 1].
    Eigen::Matrix<double, 3, 2> e;
    e << b - a, c - a;
    const Eigen::Vector2d w = e.colPivHouseholderQr().solve(q - a);
    EXPECT_LT((a + e * w - q).norm(), 1e-12);
    EXPECT_GE(w.minCoeff(), -1e-12);
    EXPECT_LE(w.sum(), 1 + 1e-12);
    double sampled = std::numeric_limits<double>::infinity();
    const int n = 150;
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j) sampled = std::min(sampled, (a + (b - a) * i / n + (c - a) * j / n - p).norm());
    EXPECT_LE((q - p).norm(), sampled + 1e-12);
    EXPECT_GE((q - p).norm(), sampled - 2 * ((b - a).norm() + (c - a).norm()) / n);
  }
}

TEST(TriangleLocator, QueriesMatchBruteForceOverEveryTriangle) {
  const TriMesh m = sphere(14, 23, 1.0, Vec3(0.1, -0.2, 0.3), 0.15);
  const TriangleLocator locator(m.points, m.triangles);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1.6, 1.6);
  for (int trial = 0; trial < 400; ++trial) {
    const Vec3 p(u(rng), u(rng), u(rng));
    const Vec3 normal = trial % 7 == 0 ? Vec3::Zero() : Vec3(u(rng), u(rng), u(rng)).normalized();
    double best = std::numeric_limits<double>::infinity();
    int nearest = -1;
    double nearest_d = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < m.triangles.size() / 3; ++j) {
      const Vec3 n = unit_normal(m, j);
      const int* v = m.triangles.data() + 3 * j;
      if (normal.isZero() || n.dot(normal) > 0)
        best = std::min(best, (closest_point_on_triangle(p, m.at(v[0]), m.at(v[1]), m.at(v[2])) - p).norm());
      const double dc = (locator.centroid(int(j)) - p).norm();
      if (n.dot(normal) > 0 && dc < 0.4 && dc < nearest_d) {
        nearest = int(j);
        nearest_d = dc;
      }
    }
    const TriangleHit hit = locator.closest_valid_point(p, normal);
    ASSERT_GE(hit.triangle, 0);
    EXPECT_NEAR(hit.distance, best, 1e-14) << "trial " << trial;
    EXPECT_NEAR((hit.point - p).norm(), hit.distance, 1e-14);
    EXPECT_EQ(locator.nearest_compatible_centroid(p, normal, 0.4), nearest) << "trial " << trial;
  }
}

TEST(TriangleCorrespondence, FitsASphereOntoADifferentlyTriangulatedOne) {
  const TriMesh source = sphere(9, 14, 1.0), target = sphere(13, 21, 1.05, Vec3(0.02, 0, 0), 0.1);
  std::vector<int> s, t;
  nearest_markers(source, target, {0, int(target.points.size() / 3) - 1, 1 + 6 * 21, 1 + 6 * 21 + 5, 1 + 6 * 21 + 11}, s, t);
  const TriangleCorrespondence c = triangle_correspondence(source.mesh(), target.mesh(), s, t);
  for (std::size_t i = 0; i < s.size(); ++i)
    for (int a = 0; a < 3; ++a) EXPECT_EQ(c.fitted_source[3 * std::size_t(s[i]) + std::size_t(a)], target.points[3 * std::size_t(t[i]) + std::size_t(a)]);
  // The target's diagonal is about 3.6: the coarse fitted sphere's vertices lie on the lumpy one
  // to a thousandth of that.
  EXPECT_LT(c.mean_distance, 3.6e-3);
  EXPECT_TRUE(c.unmatched_target.empty());
  EXPECT_TRUE(c.unmatched_source.empty());
  // Every pair is compatible: normals on the same side, centroids within the threshold.
  const TriMesh fitted{c.fitted_source, source.triangles};
  const TriangleLocator fs(fitted.points, fitted.triangles), tg(target.points, target.triangles);
  for (std::size_t p = 0; p < c.pairs.size() / 2; ++p) {
    EXPECT_GT(fs.normal(c.pairs[2 * p]).dot(tg.normal(c.pairs[2 * p + 1])), 0);
    EXPECT_LE((fs.centroid(c.pairs[2 * p]) - tg.centroid(c.pairs[2 * p + 1])).norm(), 0.5);  // near: about one coarse edge
  }
}

// A similarity pose has one gradient everywhere, which every target triangle then fits exactly,
// whatever its partners: the target moves by the same similarity, translated so that the target
// markers' centroid moves as the source markers' does.
TEST(TriangleCorrespondence, SimilarityPosesTransferExactlyBetweenUnlikeMeshes) {
  const TriMesh source = sphere(9, 14, 1.0), target = sphere(13, 21, 1.05, Vec3(0.02, 0, 0), 0.1);
  std::vector<int> s, t;
  nearest_markers(source, target, {0, int(target.points.size() / 3) - 1, 1 + 6 * 21}, s, t);
  const DeformationTransfer dt(source.mesh(), target.mesh(), s, t);
  EXPECT_EQ(dt.target_vertex_count(), target.points.size() / 3);
  const Mat3 a = 1.3 * Eigen::AngleAxisd(0.7, Vec3(1, 2, 0.5).normalized()).toRotationMatrix();
  const Vec3 shift(0.3, -1, 2);
  std::vector<double> pose(source.points.size()), out(target.points.size());
  for (std::size_t i = 0; i < pose.size() / 3; ++i) {
    const Vec3 q = a * source.at(int(i)) + shift;
    for (int c = 0; c < 3; ++c) pose[3 * i + std::size_t(c)] = q[c];
  }
  dt.transfer(pose.data(), 1, out.data());
  Vec3 ds = Vec3::Zero(), dg = Vec3::Zero();
  for (std::size_t i = 0; i < s.size(); ++i) {
    ds += a * source.at(s[i]) + shift - source.at(s[i]);
    dg += a * target.at(t[i]) - target.at(t[i]);
  }
  const Vec3 translation = (ds - dg) / double(s.size());
  double worst = 0;
  for (std::size_t i = 0; i < out.size() / 3; ++i)
    worst = std::max(worst, (Vec3(out[3 * i], out[3 * i + 1], out[3 * i + 2]) - (a * target.at(int(i)) + translation)).norm());
  EXPECT_LT(worst, 1e-10);
}

TEST(TriangleCorrespondence, FixedVerticesAreWhereEachPoseSaysAndAtRestByDefault) {
  const TriMesh source = sphere(9, 14, 1.0), target = sphere(13, 21, 1.05, Vec3(0.02, 0, 0), 0.1);
  std::vector<int> s, t;
  nearest_markers(source, target, {0, int(target.points.size() / 3) - 1, 1 + 6 * 21}, s, t);
  const std::vector<int> fixed = {5, 40, 77};
  const DeformationTransfer dt(source.mesh(), target.mesh(), s, t, fixed);
  EXPECT_TRUE(dt.anchors().empty());  // the one part is held by its fixed vertices
  std::vector<double> out(target.points.size());
  dt.transfer(source.points.data(), 1, out.data());
  double worst = 0;
  for (std::size_t i = 0; i < out.size(); ++i) worst = std::max(worst, std::abs(out[i] - target.points[i]));
  EXPECT_LT(worst, 1e-10);  // the rest pose, fixed vertices at rest: the target rest
  std::vector<double> pose = source.points, given = {0, 0, 3, 1, 1, 3, -1, 0, 3};
  for (std::size_t i = 0; i < pose.size() / 3; ++i) pose[3 * i + 2] *= 1.2;
  dt.transfer(pose.data(), 1, out.data(), given.data());
  for (std::size_t f = 0; f < fixed.size(); ++f)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(out[3 * std::size_t(fixed[f]) + std::size_t(c)], given[3 * f + std::size_t(c)]);
}

TEST(TriangleCorrespondence, RefusesBadMarkersByName) {
  const TriMesh source = sphere(7, 10, 1.0), target = sphere(8, 12, 1.0);
  auto refuses = [&](const std::vector<int>& s, const std::vector<int>& t, const std::string& start) {
    try {
      triangle_correspondence(source.mesh(), target.mesh(), s, t);
      ADD_FAILURE() << "accepted markers expected to fail with " << start;
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()).rfind(start, 0), 0u) << e.what();
    }
  };
  refuses({0, 1}, {0}, "markers: expected as many source vertices as target vertices, got 2 and 1");
  refuses({0, 1000}, {0, 1}, "markers: pair 1's source vertex 1000 is outside 0..");
  refuses({0, 1}, {0, -1}, "markers: pair 1's target vertex -1 is outside 0..");
  refuses({0, 0}, {0, 1}, "markers: pairs 0 and 1 give the same source vertex 0");
  refuses({0, 1}, {3, 3}, "markers: pairs 0 and 1 give the same target vertex 3");
  refuses({}, {}, "markers: the source's connected part of vertex 0 has no marker");
  // Two spheres as one source, markers on the first only.
  TriMesh two = source, second = sphere(7, 10, 1.0, Vec3(3, 0, 0));
  const int offset = int(two.points.size() / 3);
  two.points.insert(two.points.end(), second.points.begin(), second.points.end());
  for (int v : second.triangles) two.triangles.push_back(v + offset);
  try {
    triangle_correspondence(two.mesh(), target.mesh(), {0}, {0});
    ADD_FAILURE() << "a source part without markers was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("markers: the source's connected part of vertex " + std::to_string(offset) + " has no marker", 0), 0u) << e.what();
  }
}

TEST(TriangleCorrespondence, RefusesATargetPartNothingHolds) {
  const TriMesh source = sphere(7, 10, 1.0);
  TriMesh target = sphere(8, 12, 1.0), far = sphere(5, 6, 0.2, Vec3(40, 0, 0));
  const int offset = int(target.points.size() / 3);
  target.points.insert(target.points.end(), far.points.begin(), far.points.end());
  for (int v : far.triangles) target.triangles.push_back(v + offset);
  try {
    // Far from every source triangle: no pairs, no marker, no fixed vertex in the second part.
    DeformationTransfer(source.mesh(), target.mesh(), {0, int(source.points.size() / 3) - 1}, {0, offset - 1});
    ADD_FAILURE() << "an unconstrained target part was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("markers: the target's connected part of vertex " + std::to_string(offset) + " has no marker", 0), 0u)
        << e.what();
  }
  // A fixed vertex holds it.
  const DeformationTransfer held(source.mesh(), target.mesh(), {0, int(source.points.size() / 3) - 1}, {0, offset - 1}, {offset + 2});
  EXPECT_EQ(held.unmatched_target_triangles().size(), far.triangles.size() / 3);
}

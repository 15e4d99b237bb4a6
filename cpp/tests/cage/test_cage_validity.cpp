// Cage validity decided exactly (docs/cage.md, "Cage validity"): any contact of two faces beyond
// the vertices and edges they share is refused, touching included, and a valid cage is accepted at
// every rigid placement. The truth is the construction: each refused cage touches or overlaps
// itself by how it is built, each accepted one is a convex or star-shaped prism moved rigidly, or
// two solids a gap of one ulp apart.
#include "cage/cage_shapes.hpp"
#include "deformkit/core/types.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

using namespace deformkit;
using namespace deformkit::test;

namespace {

bool says_self_intersecting(const std::string& e) {
  return e.rfind("faces: faces ", 0) == 0 && e.size() > 39 &&
         e.compare(e.size() - 39, 39, " intersect (the cage intersects itself)") == 0;
}

// b's points and faces after a's, b's indices shifted: two solids in one cage.
PolygonSoup joined(PolygonSoup a, const PolygonSoup& b, const Vec3& shift = Vec3::Zero()) {
  const int offset = int(a.points.size() / 3);
  for (std::size_t i = 0; i < b.points.size(); ++i) a.points.push_back(b.points[i] + shift[int(i % 3)]);
  for (auto f : b.faces) {
    for (int& v : f) v += offset;
    a.faces.push_back(f);
  }
  return a;
}

// The tetrahedron p0..p3 with its faces turned outward (by the sign of its volume).
PolygonSoup tetrahedron(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3) {
  PolygonSoup s;
  for (const Vec3& p : {p0, p1, p2, p3}) s.points.insert(s.points.end(), {p.x(), p.y(), p.z()});
  s.faces = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}};
  if ((p1 - p0).dot((p2 - p0).cross(p3 - p0)) < 0)
    for (auto& f : s.faces) std::swap(f[1], f[2]);
  return s;
}

// A prism over the closed 2D ring (counter-clockwise), z in [z0, z0 + 1]: caps as k-gons, sides as quads.
PolygonSoup prism(const std::vector<std::array<double, 2>>& ring, double z0) {
  const int k = int(ring.size());
  PolygonSoup s;
  for (int z = 0; z < 2; ++z)
    for (const auto& r : ring) s.points.insert(s.points.end(), {r[0], r[1], z0 + z});
  std::vector<int> bottom, top;
  for (int i = 0; i < k; ++i) bottom.push_back(k - 1 - i), top.push_back(k + i);
  s.faces = {bottom, top};
  for (int i = 0; i < k; ++i) s.faces.push_back({i, (i + 1) % k, k + (i + 1) % k, k + i});
  return s;
}

std::vector<std::array<double, 2>> regular_ring(int k) {
  std::vector<std::array<double, 2>> ring;
  for (int i = 0; i < k; ++i) ring.push_back({std::cos(2 * M_PI * i / k), std::sin(2 * M_PI * i / k)});
  return ring;
}

// A star of k points: radii alternating 1 and 0.45, a non-convex 2k-gon.
std::vector<std::array<double, 2>> star_ring(int k) {
  std::vector<std::array<double, 2>> ring;
  for (int i = 0; i < 2 * k; ++i) {
    const double r = i % 2 ? 0.45 : 1.0;
    ring.push_back({r * std::cos(M_PI * i / k), r * std::sin(M_PI * i / k)});
  }
  return ring;
}

double ring_area(const std::vector<std::array<double, 2>>& ring) {
  double a = 0.0;
  for (std::size_t i = 0; i < ring.size(); ++i) {
    const auto& p = ring[i];
    const auto& q = ring[(i + 1) % ring.size()];
    a += 0.5 * (p[0] * q[1] - p[1] * q[0]);
  }
  return a;
}

PolygonSoup placed(PolygonSoup s, const Mat3& rotation, const Vec3& shift) {
  for (std::size_t v = 0; v < s.points.size() / 3; ++v) {
    const Vec3 p = rotation * Vec3(s.points[3 * v], s.points[3 * v + 1], s.points[3 * v + 2]) + shift;
    for (int i = 0; i < 3; ++i) s.points[3 * v + i] = p[i];
  }
  return s;
}

}  // namespace

TEST(CageValidity, OverlappingCubesAreRefusedWhateverTheirContactCurvePassesThrough) {
  // (0.3, 0.3, 0.3), (0.9, 0.9, 0.9) and (0.1, 0, 0): the curve where the cubes' surfaces meet runs
  // through edges and vertices of both, which a strict floating-point test took for touching.
  for (const Vec3& shift : {Vec3(0.3, 0.3, 0.3), Vec3(0.9, 0.9, 0.9), Vec3(0.1, 0, 0), Vec3(0.31, 0.37, 0.43),
                            Vec3(0.5, 0.3, 0.4), Vec3(0, 0, 0.5), Vec3(0.5, 0.5, 0.5)})
    EXPECT_TRUE(says_self_intersecting(error_of(joined(unit_cube(), unit_cube(), shift))))
        << shift.transpose() << ": " << error_of(joined(unit_cube(), unit_cube(), shift));
}

TEST(CageValidity, TouchingIsAnIntersectionAndAGapOfOneUlpIsNot) {
  const double ulp = std::ldexp(1.0, -52);
  // Face on face, edge on edge, vertex on vertex, faces overlapping in one plane; then each moved
  // one ulp of 1 apart (1 + 2^-52 is a double), which leaves a gap.
  const std::pair<Vec3, Vec3> touching_and_apart[] = {
      {{1, 0, 0}, {1 + ulp, 0, 0}},           {{1, 1, 0}, {1 + ulp, 1, 0}}, {{1, 1, 1}, {1 + ulp, 1, 1}},
      {{0.5, 0.5, 1}, {0.5, 0.5, 1 + ulp}}, {{0, 0.5, 1}, {0, 0.5, 1 + ulp}}};
  for (const auto& [touching, apart] : touching_and_apart) {
    EXPECT_TRUE(says_self_intersecting(error_of(joined(unit_cube(), unit_cube(), touching)))) << touching.transpose();
    EXPECT_EQ(error_of(joined(unit_cube(), unit_cube(), apart)), "") << apart.transpose();
  }
  // A vertex exactly on a face, a vertex exactly on an edge, and an edge crossing an edge at one
  // point; each tetrahedron otherwise stays clear of the cube (z - y >= 1 holds for all of it).
  const PolygonSoup on_face = tetrahedron({0.5, 0.5, 1}, {0, 0, 2}, {1, 0, 2}, {0.5, 1, 2});
  const PolygonSoup on_edge = tetrahedron({0.5, 0, 1}, {0, -1, 2}, {1, -1, 2}, {0.5, 0.5, 2});
  const PolygonSoup across = tetrahedron({0.5, -0.5, 0.5}, {0.5, 0.5, 1.5}, {0, -1, 1.5}, {1, -1, 1.5});
  for (const PolygonSoup& t : {on_face, on_edge, across}) {
    EXPECT_TRUE(says_self_intersecting(error_of(joined(unit_cube(), t)))) << error_of(joined(unit_cube(), t));
    EXPECT_EQ(error_of(joined(unit_cube(), t, Vec3(0, 0, ulp))), "");  // lifted by one ulp of 1: apart
  }
}

TEST(CageValidity, ConvexAndStarPrismsAreAcceptedAtEveryPlacement) {
  std::mt19937 rng(29);
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  std::vector<std::pair<std::vector<std::array<double, 2>>, double>> shapes;  // ring, bottom z
  for (int k = 5; k <= 12; ++k) shapes.push_back({regular_ring(k), -0.5});
  for (int k = 3; k <= 6; ++k) shapes.push_back({star_ring(k), 0.0});
  // The case: the hexagonal prism about its centre, turned 19 degrees about x.
  const PolygonSoup hexagon = placed(prism(regular_ring(6), -0.5), Eigen::AngleAxisd(19 * M_PI / 180, Vec3::UnitX()).toRotationMatrix(), Vec3::Zero());
  EXPECT_EQ(error_of(hexagon), "");
  int placements = 0;
  for (const auto& [ring, z0] : shapes)
    for (int trial = 0; trial < 40; ++trial, ++placements) {
      const Mat3 r = Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized().toRotationMatrix();
      const PolygonSoup s = placed(prism(ring, z0), r, Vec3(u(rng), u(rng), u(rng)));
      ASSERT_EQ(error_of(s), "") << ring.size() << "-gon prism, trial " << trial;
      const CageMesh cage(polygon_mesh(s));
      EXPECT_NEAR(cage.volume(), ring_area(ring), 1e-12 * ring_area(ring));
      EXPECT_EQ(cage.triangles().size(), 2 * (ring.size() - 2) + 2 * ring.size());
    }
  EXPECT_EQ(placements, 480);
}
